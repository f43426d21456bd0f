#!/usr/bin/env python
"""Independent mutation check of the round-3 modules (issue 37's rule for resolving a round-3 issue).

Before a round-3 issue (30, 31, 32, 33, 34, 35, 36) is called resolved, issue 37 asks for an
independent mutation check of the modules it touched: plausible one-line bugs written
from a reading of those modules only, *without* looking at the harness's list
(``tools/mutate.py``) or at ``tools/mutants_independent.py``'s list, each aimed at the
test files a maintainer would expect to notice it.  This is that list, grouped by issue
(mutant ids ``r3-<issue>-...``).  It reuses mutate.py's machinery (tree copy, numba cache
seeding, shards, ``--check``, ``--only``, JSON and markdown) with this list in place of
the harness's::

    python tools/mutants_round3.py --check          # every mutant applies once, compiles, names existing tests
    nice python tools/mutants_round3.py --workdir /tmp/r3_a --shard 1/2 --no-baseline --json a.json &
    nice python tools/mutants_round3.py --workdir /tmp/r3_b --shard 2/2 --no-baseline --json b.json &
    wait; python tools/mutants_round3.py --markdown table.md a.json b.json
    python tools/mutants_round3.py --issue 35 --list   # one issue's mutants (--issue filters before the rest)
    python tools/mutants_round3.py --overlap        # mutants whose target text a harness mutant also edits

As for mutants_independent.py: do not copy these into mutate.py when they are caught (the
point is that the suite is measured on bugs nobody tuned it against).  Results:
tools/mutants_result.md ("Round-3 independent check").
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import mutate  # noqa: E402
from mutate import Mutant  # noqa: E402

S = "src/polypack/"
K = S + "_kernels/"
M = S + "mechanics/"

# the test files a maintainer would run for each module (the most specific first: -x stops there);
# tests/test_round3_survivors.py holds the tests written for the survivors of the first run and comes first
T_S3 = ("tests/test_round3_survivors.py",)
T_EL = T_S3 + ("tests/test_mechanics_elastic.py",)
T_DEMCHK = T_S3 + ("tests/test_dem.py", "tests/test_check_complete.py")
T_STM = T_S3 + ("tests/test_stages_mechanics.py",)
T_NETF = T_S3 + ("tests/test_network_files.py", "tests/test_io_bonds.py")
T_OUT = T_S3 + ("tests/test_network_files.py", "tests/test_cli_mechanics_units.py", "tests/test_output_paths.py")
T_SWEEP = T_S3 + ("tests/test_sweep.py",)
T_CLIU = T_S3 + ("tests/test_cli_mechanics_units.py",)
T_HOM = T_S3 + ("tests/test_homogenize.py",)
T_HST = T_S3 + ("tests/test_stages_homogenize.py", "tests/test_homogenize.py")
T_VOX = T_S3 + ("tests/test_io_voxel.py", "tests/test_homogenize.py")
T_ROLL = T_S3 + ("tests/test_deposit_roll.py", "tests/test_deposit3d.py")
T_DEP3 = T_S3 + ("tests/test_deposit3d.py", "tests/test_deposit_roll.py", "tests/test_deposit_periodic_window.py")
T_DEP3P = T_S3 + ("tests/test_deposit3d.py::test_pruned_search_equals_the_exhaustive_search",
                  "tests/test_deposit3d.py", "tests/test_deposit_roll.py")
T_PROF = T_S3 + ("tests/test_deposit_roll.py", "tests/test_stages_protocols.py")
T_RIG = T_S3 + ("tests/test_mechanics_rigidity.py",)
T_REG = T_S3 + ("tests/test_registry.py", "tests/test_declarations.py", "tests/test_options.py")
T_GEN = T_S3 + ("tests/test_declarations.py", "tests/test_registry.py")
T_VEMR = ("tests/test_vem_restructure.py",)
T_VEMA = ("tests/test_vem_adhesive.py",)
T_FIG5 = ("tests/test_sweep.py::test_fig5_picks_the_brownian_set_when_there_is_one",
          "tests/test_sweep.py::test_fig5_gp_against_kn_of_the_most_and_least_heterogeneous",
          "tests/test_sweep.py::test_fig5_uses_the_studys_elastic_settings")
T_BDK = ("tests/test_bd_kernel.py",)
T_SETS = ("tests/test_sweep_sets.py",)
T_ESC = ("tests/test_brownian_escape.py",)
T_EDMD = ("tests/test_edmd_hot.py", "tests/test_golden.py")

ROUND3 = [
    # ============================================================== issue 33: packer speed (edmd.py renumbering)
    Mutant("r3-33-unpermute-positions", K + "edmd.py",
           "            x[o, k] = P[i, R_X + k]\n",
           "            x[i, k] = P[i, R_X + k]\n",
           T_EDMD, "wrong un-permutation (positions returned in the event loop's numbering)"),
    Mutant("r3-33-records-growth", K + "edmd.py",
           "        P[i, R_G] = g[o]\n",
           "        P[i, R_G] = g[i]\n",
           T_EDMD, "wrong permutation (growth speeds left in the caller's numbering)"),
    Mutant("r3-33-lists-unmapped", K + "edmd.py",
           "        pj[k] = new[pj[k]]\n",
           "        pj[k] = pj[k]\n",
           T_EDMD, "missing step (one side of every pair left in the caller's numbering)"),
    Mutant("r3-33-levels-unmapped", K + "edmd.py",
           "                    lev[i] = level[orig[i]]\n",
           "                    lev[i] = level[i]\n",
           T_EDMD, "wrong permutation (size levels in the caller's numbering: wrong grid of a shell)"),
    Mutant("r3-33-cell-gap-far-side", K + "edmd.py",
           "        gap = k * w - y\n",
           "        gap = (k + 1) * w - y\n",
           T_EDMD, "wrong bound (a cell's far side: cells with partners skipped in a local rebuild)"),
    # ============================================================== issue 32: Brownian-dynamics speed (bd.py)
    Mutant("r3-32-near-restart", K + "bd.py",
           "                    q = k + 1\n",
           "                    q = k + 2\n",
           T_BDK, "off-by-one (the pair after the one that triggered the fallback skipped)"),
    Mutant("r3-32-near-stale-tally", K + "bd.py",
           "use_near = nnear >= 0 and tally < half_margin",
           "use_near = nnear >= 0",
           T_BDK, "dropped condition (near list used although the last full sweep moved spheres beyond the margin)"),
    # equivalent (tools/mutants_result.md): a bonded pair left out moves by >= margin / 2 in that sweep
    Mutant("r3-32-near-keep-bonded", K + "bd.py",
           "if collect and (flag[k] != 0 or r2 < keep2):",
           "if collect and r2 < keep2:",
           T_BDK, "dropped condition (stretched bonds left out of the near list)"),
    Mutant("r3-32-near-tally", K + "bd.py",
           "                moved[j] += 0.5 * c\n",
           "                moved[j] += 0.0 * c\n",
           T_BDK, "dropped term (movement of the second sphere not counted: unsafe skips)"),
    Mutant("r3-32-image-count-far", K + "bd.py",
           "        q = 1\n        d -= length\n        if d > half:\n            q += int(np.floor(d / length + 0.5))\n",
           "        q = 1\n        d -= length\n",
           T_BDK, "dropped branch (image count of spheres unwrapped more than 1.5 boxes apart)"),
    Mutant("r3-32-shift-sign", K + "bd.py",
           "    return d - length * q\n",
           "    return d + length * q\n",
           T_BDK + ("tests/test_brownian.py",), "wrong sign (minimum image of listed pairs)"),
    # issue 32: the dynamic G'p on the first realization(s) of a dynamic value only (sweep dynamic_realizations)
    Mutant("r3-32-dynreal-skip-bound", S + "ensemble/stages.py",
           "return isinstance(lim, int) and not isinstance(lim, bool) and index >= lim",
           "return isinstance(lim, int) and not isinstance(lim, bool) and index > lim",
           ("tests/test_sweep_sets.py",), "off-by-one (realization n also gets the limited analysis)"),
    Mutant("r3-32-dynreal-default-all", S + "ensemble/sweep.py",
           'def _check_dynamic_realizations(x, where="sweep", default=1):',
           'def _check_dynamic_realizations(x, where="sweep", default=None):',
           ("tests/test_sweep_sets.py",), "wrong default (every realization of a dynamic value sheared again)"),
    Mutant("r3-32-dynreal-set-ignores-own", S + "ensemble/sweep.py",
           'dreal = _check_dynamic_realizations(s.get("dynamic_realizations"), f\'sweep.set "{sname}"\',',
           'dreal = _check_dynamic_realizations(sw.get("dynamic_realizations"), f\'sweep.set "{sname}"\',',
           ("tests/test_sweep_sets.py",), "wrong table (a set's own dynamic_realizations ignored)"),
    Mutant("r3-32-dynreal-same-note-always", S + "studies/seed003_heterogeneity.py",
           'if tested < row["realizations"] and row.get("G_dyn_static_MPa") is not None:',
           'if tested <= row["realizations"] and row.get("G_dyn_static_MPa") is not None:',
           ("tests/test_sweep_sets.py",), "wrong comparison (static-of-the-same note on rows whose every structure "
                                           "had the test)"),
    # ============================================================== issue 31: floppy / rigid, outputs
    Mutant("r3-31-floppy-ref-index", M + "elastic.py",
           "ref = float(np.linalg.eigvalsh(0.5 * (c_aff + c_aff.T))[-1])",
           "ref = float(np.linalg.eigvalsh(0.5 * (c_aff + c_aff.T))[0])",
           T_EL, "wrong index (smallest, not largest, affine eigenvalue as the floppy scale)"),
    Mutant("r3-31-wrapping-all-axes", M + "elastic.py",
           "    wrapping = spans.any(axis=1)\n    common",
           "    wrapping = spans.all(axis=1)\n    common",
           T_EL, "any/all (a cluster wrapping one axis only counted as disconnected)"),
    Mutant("r3-31-rigid-one-soft", M + "elastic.py",
           "rigid=n_soft == 0,",
           "rigid=n_soft <= 1,",
           T_EL + T_STM, "off-by-one (one floppy strain mode still called rigid)"),
    Mutant("r3-31-pin-rotations", M + "elastic.py",
           "pinned = (first[:, None] * nd + np.arange(3)[None, :]).ravel()",
           "pinned = (first[:, None] * nd + np.arange(nd)[None, :]).ravel()",
           T_EL, "over-constraint (rotations of the pinned particle fixed too)"),
    Mutant("r3-31-dem-cs-max", M + "_dem_record.py",
           "c_s = math.sqrt((min(gmean, static) if static else gmean) / rho_bulk)",
           "c_s = math.sqrt((max(gmean, static) if static else gmean) / rho_bulk)",
           T_S3 + ("tests/test_dem.py",), "min/max (wave speed from the inertia-stiffened G': hides the error)"),
    Mutant("r3-31-dem-samples-eq", M + "dem.py",
           "    if samples_per_cycle > steps_per_cycle:\n",
           "    if samples_per_cycle >= steps_per_cycle:\n",
           T_DEMCHK, "off-by-one (samples_per_cycle = steps_per_cycle refused)"),
    Mutant("r3-31-dem-discard-eq", M + "dem.py",
           "or not 0 <= discard_cycles < cycles:",
           "or not 0 <= discard_cycles <= cycles:",
           T_DEMCHK, "off-by-one (discarding every cycle accepted: nothing left to fit)"),
    Mutant("r3-31-dem-loss-flip", M + "_dem_record.py",
           "elif gpp > LOSS_TANGENT_LIMIT * gp:",
           "elif gpp > LOSS_TANGENT_LIMIT * gp * 2.0:",
           T_S3 + ("tests/test_dem.py", "tests/test_stages_mechanics.py"), "factor 2 (loss-tangent limit of an elastic response)"),
    Mutant("r3-31-stage-floppy-flag", M + "stages.py",
           "out[\"floppy\"] = int(not et.rigid)",
           "out[\"floppy\"] = int(et.floppy_strains == 6)",
           T_STM, "wrong flag (only fully floppy tensors flagged)"),
    Mutant("r3-31-shear-flag-status", M + "stages.py",
           "out[\"floppy\"] = int(res.status == \"floppy\")",
           "out[\"floppy\"] = int(res.status != \"ok\")",
           T_STM, "wrong flag (not-converged shear counted floppy)"),
    Mutant("r3-31-measured-loss-kept", M + "stages.py",
           "for k in (\"storage_modulus\", \"loss_modulus\", \"storage_modulus_sd\",",
           "for k in (\"storage_modulus\", \"storage_modulus_sd\",",
           T_STM, "dropped key (a not-converged G'' still averaged in)"),
    Mutant("r3-31-bondless-flag", M + "stages.py",
           "out = {\"estimator\": estimator, \"status\": \"floppy\", \"rigid\": False, \"floppy\": 1,",
           "out = {\"estimator\": estimator, \"status\": \"floppy\", \"rigid\": False, \"floppy\": 0,",
           T_STM, "wrong flag (a bondless pack not counted floppy)"),
    Mutant("r3-31-gsd-image-sign", S + "io/bonds.py",
           "    img = shift + c[j] - c[i]\n",
           "    img = shift - c[j] + c[i]\n",
           T_NETF, "wrong sign (GSD periodic image of a bond in the centred frame)"),
    Mutant("r3-31-gsd-typeid", S + "io/bonds.py",
           "frame.bonds.typeid = (btype - 1).astype(np.uint32)",
           "frame.bonds.typeid = btype.astype(np.uint32)",
           T_NETF, "off-by-one (1-based bond types written as GSD type ids)"),
    Mutant("r3-31-vtm-parts-force", S + "io/bonds.py",
           "if part.exists() and part.name not in own:",
           "if part.exists() and part.name not in own and own:",
           T_NETF, "dropped check (foreign _particles/_bonds.vtp replaced when there is no index)"),
    Mutant("r3-31-self-bond", S + "io/bonds.py",
           "bad = (i < 0) | (i >= n) | (j < 0) | (j >= n) | (i == j)",
           "bad = (i < 0) | (i >= n) | (j < 0) | (j >= n)",
           T_NETF, "dropped check (a bond of a particle with itself written)"),
    Mutant("r3-31-min-image-sign", S + "io/bonds.py",
           "return np.where(periodic, -np.round(delta / box), 0.0).astype(np.int64)",
           "return np.where(periodic, np.round(delta / box), 0.0).astype(np.int64)",
           T_NETF, "wrong sign (minimum-image shift of a bond)"),
    Mutant("r3-31-new-output-kind", S + "_util.py",
           "    if os.path.isfile(path) and not force:\n        have = file_kind(path)",
           "    if os.path.isfile(path) and force:\n        have = file_kind(path)",
           T_OUT, "inverted flag (--force needed to write onto a file of the same kind, other kinds replaced)"),
    Mutant("r3-31-new-output-input", S + "_util.py",
           "if src is not None and _same_file(path, src):",
           "if src is not None and os.path.abspath(path) == src:",
           T_OUT, "weaker comparison (an input named by a relative path is overwritten)"),
    Mutant("r3-31-sweep-name-round", S + "ensemble/sweep.py",
           "    return short if same else repr(v)",
           "    return short",
           T_SWEEP, "rounded folder name (0.2500000000000001 onto 0.25's folder)"),
    Mutant("r3-31-radius-zero", S + "_cli/_network.py",
           "if not math.isfinite(r) or r < 0:",
           "if not math.isfinite(r) or r <= 0:",
           T_CLIU, "comparison flipped (--radius 0, keep the file's unit, refused)"),
    # ============================================================== issue 34: full field, voxelize
    Mutant("r3-34-richardson-denominator", M + "fullfield.py",
           "val = f[-1] + (f[-1] - f[-2]) / (r ** p - 1.0)",
           "val = f[-1] + (f[-1] - f[-2]) / (r ** p + 1.0)",
           T_HOM, "wrong sign (Richardson extrapolation denominator)"),
    Mutant("r3-34-poisson", M + "fullfield.py",
           "return None if k is None else (3.0 * k - 2.0 * g) / (2.0 * (3.0 * k + g))",
           "return None if k is None else (3.0 * k - 2.0 * g) / (3.0 * k + g)",
           T_HST, "dropped factor 2 (Poisson ratio from K, G)"),
    Mutant("r3-34-willot-cos", M + "fullfield.py",
           "k = k * np.cos(grids[b] / 2.0)",
           "k = k * np.cos(grids[b])",
           T_HOM, "factor 2 (half-angle of the rotated scheme's other axes)"),
    Mutant("r3-34-willot-spacing", M + "fullfield.py",
           "k = (2.0 / spacing[a]) * np.sin(th / 2.0)",
           "k = (2.0 / spacing[0]) * np.sin(th / 2.0)",
           T_HOM, "wrong axis (voxel size of x on every axis)"),
    Mutant("r3-34-green-c0", M + "fullfield.py",
           "c0 = (lam0 + mu0) / (mu0 * (lam0 + 2.0 * mu0))",
           "c0 = (lam0 + 2.0 * mu0) / (mu0 * (lam0 + 2.0 * mu0))",
           T_HOM, "wrong constant (Green operator's second term)"),
    Mutant("r3-34-engineering-shear", M + "fullfield.py",
           "e[m] = 1.0 if m < 3 else 0.5  # engineering shear gamma = 1",
           "e[m] = 1.0  # engineering shear gamma = 1",
           T_HOM, "factor 2 (tensor vs engineering shear strain)"),
    Mutant("r3-34-coated-dim", M + "fullfield.py",
           "return k0 + phi * d * dim * k0 / (dim * k0 + (1.0 - phi) * d)",
           "return k0 + phi * d * 3 * k0 / (3 * k0 + (1.0 - phi) * d)",
           T_HOM, "dimension lost (3D Maxwell-Garnett in 2D composite voxels)"),
    Mutant("r3-34-aniso-shear", M + "fullfield.py",
           "iso[np.arange(3, 6), np.arange(3, 6)] = g",
           "iso[np.arange(3, 6), np.arange(3, 6)] = 2.0 * g",
           T_HST, "factor 2 (shear diagonal of the isotropic projection)"),
    Mutant("r3-34-stage-precision", M + "stages.py",
           "precision=opts.get(\"precision\", \"double\"),",
           "precision=\"double\",",
           T_HST + ("tests/test_stage_option_walk.py",), "dropped option (precision never reaches homogenize)"),
    Mutant("r3-34-stage-ext-error", M + "stages.py",
           "ext[q + \"_ratio\"] = {\"value\": e[\"value\"] / ref, \"error\": e[\"error\"] / ref,",
           "ext[q + \"_ratio\"] = {\"value\": e[\"value\"] / ref, \"error\": e[\"error\"],",
           T_HST, "unit lost (Richardson error not made relative to the matrix)"),
    Mutant("r3-34-voxel-shape-min", S + "io/voxel.py",
           "return tuple(max(1, int(round(r * L / box.max()))) for L in box)",
           "return tuple(max(1, int(round(r * L / box.min()))) for L in box)",
           T_VOX, "min/max (resolution along the shortest axis)"),
    Mutant("r3-34-exact-2d", S + "io/voxel.py",
           "exact = np.array([float(np.sum(ball_volume(packing.radii[packing.species == s], dim))) / vol for s in range(ns)])",
           "exact = np.array([float(np.sum(ball_volume(packing.radii[packing.species == s], 3))) / vol for s in range(ns)])",
           T_VOX, "dimension lost (sphere volumes of disks)"),
    Mutant("r3-34-vti-order", S + "io/voxel.py",
           "{_b64(lab.reshape(n).ravel(order=\"F\"))}",
           "{_b64(lab.reshape(n).ravel())}",
           T_VOX, "wrong memory order (VTK x-fastest)"),
    Mutant("r3-34-kernel-dy-axis", K + "voxel.py",
           "dy = (j + 0.5) * hy - cy",
           "dy = (j + 0.5) * hx - cy",
           T_VOX, "wrong axis (x voxel size on y)"),
    Mutant("r3-34-kernel-subsample-offset", K + "voxel.py",
           "sz = dz + ((c + 0.5) / s - 0.5) * hz",
           "sz = dz + (c / s - 0.5) * hz",
           T_VOX, "off-by-half (sub-voxel points at the corners, z)"),
    Mutant("r3-34-kernel-interior", K + "voxel.py",
           "if d + half_diag <= r:",
           "if d <= r:",
           T_VOX, "tolerance (voxel counted wholly inside when its centre is)"),
    # ============================================================== issue 35: deposition rules, profile
    Mutant("r3-35-roll-pair-centre", K + "roll3d.py",
           "u = (RA * RA - RB * RB + d * d) / (2.0 * d)",
           "u = (RA * RA - RB * RB + d * d) / d",
           T_ROLL, "factor 2 (centre of the contact circle of two supports)"),
    Mutant("r3-35-roll-lambda-sign", K + "roll3d.py",
           "lam[1] = -(a00 * a12 - a02 * a10) / det",
           "lam[1] = (a00 * a12 - a02 * a10) / det",
           T_ROLL, "wrong sign (Cramer cofactor of the three-contact rest test)"),
    Mutant("r3-35-roll-force-b", K + "roll3d.py",
           "fb = (u * w[2] / rho - ee) / d",
           "fb = (u * w[2] / rho + ee) / d",
           T_ROLL, "wrong sign (contact force on B while rolling on two)"),
    Mutant("r3-35-roll-floor-stat", S + "generate/deposit.py",
           "\"on_floor\": int(state[kr.RollState.N_FLOOR])",
           "\"on_floor\": int(state[kr.RollState.N_STUCK])",
           T_ROLL + ("tests/test_stages_protocols.py",), "wrong index (statistic slot)"),
    Mutant("r3-35-drop-x-only", S + "generate/deposit.py",
           "drop = rng.uniform(0.0, 1.0, (radii.size, 2)) * w",
           "drop = rng.uniform(0.0, 1.0, (radii.size, 2)) * w[0]",
           T_ROLL, "wrong axis (drop columns scaled by Lx on both axes)"),
    Mutant("r3-35-species-unpermuted", S + "generate/deposit.py",
           "pk = Packing(pos, rad, [w[0], w[1], height], species=species[perm], meta=meta,",
           "pk = Packing(pos, rad, [w[0], w[1], height], species=species, meta=meta,",
           T_DEP3, "dropped permutation (species of a shuffled 3D deposit)"),
    Mutant("r3-35-last-resort-one-axis", K + "deposit3d.py",
           "elif gbest[3] < np.inf and per[0] and per[1]:",
           "elif gbest[3] < np.inf and per[0]:",
           T_DEP3, "dropped condition (roll with a wall on y)"),
    # the surface rule's per-radius caches and pruned fallback (issue 35, second pass)
    Mutant("r3-35-slot-reach", K + "deposit3d.py",
           "if h2 <= (rad[k] + r + 2.0 * slot_r[cc] + cmargin) ** 2:",
           "if h2 <= (rad[k] + r + slot_r[cc] + cmargin) ** 2:",
           T_DEP3P, "missing term (a slot's cache forgotten only within r_k + r_c + r: stale candidates)"),
    Mutant("r3-35-none-at-all", K + "deposit3d.py",
           "elif valid and cache_f[s, c, fo + 4] == np.inf:",
           "elif valid and cache_f[s, c, fo + 4] >= 0.0:",
           T_DEP3P, "wrong condition (\"none below a threshold\" read as \"no candidate at all\")"),
    Mutant("r3-35-fallback-window", K + "deposit3d.py",
           "zlo = sz - 4.0 * math.sqrt(tol) * Rs if strict else -np.inf",
           "zlo = sz - 4.0 * math.sqrt(tol) * Rs",
           T_DEP3P, "dropped condition (the envelope's lower limit applied under overhangs)"),
    Mutant("r3-35-forget-dead", K + "deposit3d.py",
           "            _forget_overhang(dead[q], pos,",
           "            0 and _forget_overhang(dead[q], pos,",
           T_DEP3P, "missing step (fallback caches kept after a supporting neighbour dies)"),
    Mutant("r3-35-offer-precheck", K + "deposit3d.py",
           "                if p[2] <= best[0] + tol * r:  # else not better than the best (_better): skip the call\n"
           "                    _offer(p, r, s, int(nb[a, 4])",
           "                if p[2] < best[0] - tol * r:  # else not better than the best (_better): skip the call\n"
           "                    _offer(p, r, s, int(nb[a, 4])",
           T_DEP3P, "wrong bound (candidates tied in height with the best skipped: the tie rule broken)"),
    Mutant("r3-35-profile-slab", S + "analysis/deposits.py",
           "v = np.pi * (r * r * (hi - lo) - (hi**3 - lo**3) / 3.0)",
           "v = np.pi * (r * r * (hi - lo) - (hi**3 - lo**3) / 2.0)",
           T_PROF, "wrong factor (volume of a spherical slab)"),
    Mutant("r3-35-profile-block-axis", S + "analysis/deposits.py",
           "by = np.clip((pos[:, 1] / box[1] * blocks).astype(np.int64), 0, blocks - 1)",
           "by = np.clip((pos[:, 1] / box[0] * blocks).astype(np.int64), 0, blocks - 1)",
           T_PROF, "wrong axis (footprint columns on y cut with Lx)"),
    Mutant("r3-35-profile-ddof", S + "analysis/deposits.py",
           "err = np.nanstd(fb, axis=0, ddof=1) / np.sqrt(np.sum(np.isfinite(fb), axis=0))",
           "err = np.nanstd(fb, axis=0) / np.sqrt(np.sum(np.isfinite(fb), axis=0))",
           T_PROF, "off-by-one (ddof of the layer standard errors)"),
    Mutant("r3-35-profile-uncentred", S + "analysis/deposits.py",
           "    hc = h - h.mean()\n",
           "    hc = h\n",
           T_PROF, "dropped centring (slope denominator)"),
    Mutant("r3-35-profile-split", S + "analysis/deposits.py",
           "    small = rad < split\n",
           "    small = rad <= split\n",
           T_PROF, "comparison flipped (split = r_max counts every sphere small)"),
    Mutant("r3-35-profile-window", S + "analysis/deposits.py",
           "window = (4.0 * dmax, free_surface_height(packing) - 4.0 * dmax)",
           "window = (4.0 * dmax, free_surface_height(packing))",
           T_PROF, "dropped term (window reaches the rough free surface)"),
    # ============================================================== issue 36: rigidity analysis
    Mutant("r3-36-rigid-fraction-lone", M + "rigidity_analysis.py",
           "big = np.flatnonzero(np.asarray(self.cluster_sizes) >= 2)",
           "big = np.flatnonzero(np.asarray(self.cluster_sizes) >= 1)",
           T_RIG, "off-by-one (clusters of one particle counted rigid)"),
    Mutant("r3-36-percolation-any", M + "rigidity_analysis.py",
           "perc = bool(sp_c.all(axis=1).any()) if sp_c.size else False",
           "perc = bool(sp_c.any(axis=1).any()) if sp_c.size else False",
           T_RIG, "any/all (a cluster wrapping one axis called percolating)"),
    Mutant("r3-36-deviator-trace", M + "rigidity_analysis.py",
           "dev = f - np.trace(f) / 3.0 * np.eye(3)",
           "dev = f - np.trace(f) / 2.0 * np.eye(3)",
           T_RIG, "wrong constant (deviator in 3D)"),
    Mutant("r3-36-nonaffinity-modes", M + "rigidity_analysis.py",
           "gam = float(gam_m[3:].mean())",
           "gam = float(gam_m[:3].mean())",
           T_RIG, "wrong slice (non-affinity of the normal, not shear, strains)"),
    Mutant("r3-36-backbone-z", M + "rigidity_analysis.py",
           "bb_z = 2.0 * float(union.sum()) / max(int(bb_part.sum()), 1) if union.any() else None",
           "bb_z = float(union.sum()) / max(int(bb_part.sum()), 1) if union.any() else None",
           T_RIG, "dropped factor 2 (coordination = 2 bonds / particles)"),
    Mutant("r3-36-isostatic", M + "rigidity_analysis.py",
           "isostatic_coordination=2.0 * nd / cons,",
           "isostatic_coordination=nd / cons,",
           T_RIG, "dropped factor 2 (isostatic coordination)"),
    Mutant("r3-36-cluster-order", M + "rigidity_analysis.py",
           "order = np.lexsort((uniq, -counts))",
           "order = np.lexsort((uniq, counts))",
           T_RIG, "wrong sort order (smallest cluster first)"),
    Mutant("r3-36-self-stress-sign", M + "rigidity_analysis.py",
           "sss = int(floppy - maxwell)",
           "sss = int(maxwell - floppy)",
           T_RIG, "wrong sign (index theorem)"),
    Mutant("r3-36-shear-fabric-modes", M + "rigidity_analysis.py",
           "bshear = np.array([_fourth_shear(normals, bb[3 + p])[p] for p in range(3)])",
           "bshear = np.array([_fourth_shear(normals, bb[p])[p] for p in range(3)])",
           T_RIG, "wrong index (backbone of the normal strain for a shear plane)"),
    Mutant("r3-36-participation-metric", M + "rigidity_analysis.py",
           "part_all = np.sum(dmet[None] * zz * zz, axis=2).mean(axis=0)",
           "part_all = np.sum(zz * zz, axis=2).mean(axis=0)",
           T_RIG, "dropped metric (participation in raw, not D-weighted, units)"),
    # ============================================================== issue 30: declarations, generated CLI
    Mutant("r3-30-positive-zero", S + "_validate.py",
           "    v = number(v)\n    if not v > 0:\n        raise Bad(\"must be > 0\")",
           "    v = number(v)\n    if v < 0:\n        raise Bad(\"must be > 0\")",
           T_REG, "comparison flipped (0 accepted as positive)"),
    Mutant("r3-30-between-open", S + "_validate.py",
           "if (v <= lo if lo_open else v < lo) or (v >= hi if hi_open else v > hi):",
           "if (v < lo if lo_open else v < lo) or (v >= hi if hi_open else v > hi):",
           T_REG, "open end accepted (lower bound of an open interval)"),
    Mutant("r3-30-int-min", S + "_validate.py",
           "        if v < lo:\n            raise Bad(f\"must be an integer >= {lo}\")",
           "        if v <= lo:\n            raise Bad(f\"must be an integer >= {lo}\")",
           T_REG, "off-by-one (the minimum itself refused)"),
    Mutant("r3-30-integer-float", S + "_validate.py",
           "if isinstance(v, float) and v.is_integer():",
           "if isinstance(v, float):",
           T_REG, "dropped check (2.5 accepted as the integer 2)"),
    Mutant("r3-30-number-inf", S + "_validate.py",
           "    if not math.isfinite(v):\n        raise Bad(\"must be finite\")",
           "    if math.isnan(v):\n        raise Bad(\"must be finite\")",
           T_REG, "weaker check (inf accepted as a number)"),
    Mutant("r3-30-fill-ignored", S + "registry.py",
           "if spec.default is not None and spec.fill:",
           "if spec.default is not None:",
           T_REG + ("tests/test_pipeline_options.py",), "dropped condition (fill=False defaults filled into tables)"),
    Mutant("r3-30-api-name", S + "registry.py",
           "return {(specs[k].api or k) if k in specs else k: v for k, v in table.items()}",
           "return {k: v for k, v in table.items()}",
           T_REG + ("tests/test_stage_option_walk.py",), "dropped mapping (api= names of options)"),
    Mutant("r3-30-check-call-unchecked", S + "registry.py",
           "            out[key] = spec.check(value) if spec.check is not None else value\n        except Bad as exc:\n            raise InvalidInputError(f\"{key}={value!r}: {exc}\") from None",
           "            out[key] = value\n        except Bad as exc:\n            raise InvalidInputError(f\"{key}={value!r}: {exc}\") from None",
           T_REG, "dropped check (API keywords not validated)"),
    Mutant("r3-30-cli-fields-study", S + "_cli/_generated.py",
           "return {k: s for k, s in cap.specs().items() if s.cli}",
           "return {k: s for k, s in cap.specs().items() if s.study}",
           T_GEN, "wrong attribute (study-only options offered as flags)"),
    Mutant("r3-30-flag-default-unset", S + "_cli/_generated.py",
           "default = None if spec.required or spec.default is None else spec.default",
           "default = None",
           T_GEN, "dropped default (generated flags show no declared default)"),
    Mutant("r3-30-cli-type-or", S + "_cli/_generated.py",
           "if d.startswith(\"number\") and \"array\" not in d and \" or \" not in d:",
           "if d.startswith(\"number\") and \"array\" not in d:",
           T_GEN, "dropped condition (number-or-list options typed float)"),
    Mutant("r3-30-reference-unit", S + "_reference.py",
           "{_cell(s.unit) or '–'}",
           "'–'",
           T_GEN, "unit lost (reference page's unit column)"),
    Mutant("r3-30-default-dr", S + "analysis/_capabilities.py",
           "dr: float = option(0.02, v.positive, \"bin width, user length units\")",
           "dr: float = option(0.01, v.positive, \"bin width, user length units\")",
           T_GEN + ("tests/test_analysis_cli.py",), "wrong default (rdf bin width)"),
    Mutant("r3-30-default-growth", S + "generate/_capabilities.py",
           "growth_steps: int = option(10, v.int_min(1),",
           "growth_steps: int = option(1, v.int_min(1),",
           T_GEN + ("tests/test_pack_cli.py",), "wrong default (SCRM growth stages)"),
    # ============================================================== issue 32: VEM coagulation, sweep report
    Mutant("r3-32-coag-stop-sign", S + "generate/vem.py",
           "abs(coord[m] - coord[m - nwin]) <= RESTRUCTURE_TOLERANCE * coord[m]",
           "abs(coord[m] - coord[m - nwin]) >= RESTRUCTURE_TOLERANCE * coord[m]",
           T_VEMR, "inverted comparison (stops while the coordination still changes)"),
    Mutant("r3-32-coag-no-window", S + "generate/vem.py",
           "if m >= nwin and coord[m] > 0",
           "if m >= 1 and coord[m] > 0",
           T_VEMR, "window ignored (compares with the first record)"),
    Mutant("r3-32-coag-record-step", S + "generate/vem.py",
           "per = max(1, int(round(RESTRUCTURE_RECORD * tau / sim.time_step)))",
           "per = max(1, int(round(2 * RESTRUCTURE_RECORD * tau / sim.time_step)))",
           T_VEMR, "wrong record interval (twice the declared one: the window spans twice the time)"),
    Mutant("r3-32-coag-bond-model", S + "generate/vem.py",
           "                             bonds=o[\"restructure_bonds\"])",
           "                             bonds=\"flexible\")",
           T_VEMR, "option dropped (the bond model ignored: always free rolling)"),
    Mutant("r3-32-coag-no-final-separation", S + "generate/vem.py",
           "        wpos, status, s2, _ = _separate(wpos, red, box, ns, skin)",
           "        s2 = 0",
           T_VEMR, "missing step (overlaps left by the coagulation not removed)"),
    Mutant("r3-32-coag-potential", S + "generate/vem.py",
           "p = dlvo_parameters(o[\"restructure_potential\"])",
           "p = dlvo_parameters(0.015)",
           T_VEMR, "option dropped (the surface potential ignored)"),
    Mutant("r3-32-report-ratio", S + "report/build.py",
           "f\"{r['a'] / s[1]:.3f}\"",
           "f\"{s[1] / r['a']:.3f}\"",
           T_SWEEP, "inverted ratio (a_seed / a in the a / a_seed column)"),
    Mutant("r3-32-report-seed-c", S + "report/build.py",
           "pm(r.get(\"C\"), r.get(\"C_se\"), 2), f\"{s[2]:.2f}\" if s else",
           "pm(r.get(\"C\"), r.get(\"C_se\"), 2), f\"{s[3]:.2f}\" if s else",
           T_SWEEP, "wrong column (the seed's G'p shown as its C)"),
    Mutant("r3-32-fig5-ks-fixed", S + "studies/seed003_heterogeneity.py",
           "shear_stiffness=float(kn) * ratio))",
           "shear_stiffness=ks0))",
           T_FIG5, "option dropped (ks held at the study's value while kn varies: ks / kn not constant)"),
    Mutant("r3-32-fig5-pick-swap", S + "studies/seed003_heterogeneity.py",
           "return max(pool, key=lambda k: points[k][\"a\"]), min(pool, key=lambda k: points[k][\"a\"]), among",
           "return min(pool, key=lambda k: points[k][\"a\"]), max(pool, key=lambda k: points[k][\"a\"]), among",
           T_FIG5, "swapped roles (the least heterogeneous structure labelled HE)"),
    Mutant("r3-32-fig5-study-settings-ignored", S + "studies/seed003_heterogeneity.py",
           "    if src == \"[analysis.elastic]\":\n",
           "    if src == \"[analysis.shear]\":\n",
           T_FIG5, "option dropped (the study's [analysis.elastic] settings ignored: the report's defaults)"),
    Mutant("r3-32-fig5-ratio-inverted", S + "studies/seed003_heterogeneity.py",
           "res[\"ratio\"] = (np.asarray(res[\"he\"][\"G_Pa\"]) / np.asarray(res[\"ho\"][\"G_Pa\"])).tolist()",
           "res[\"ratio\"] = (np.asarray(res[\"ho\"][\"G_Pa\"]) / np.asarray(res[\"he\"][\"G_Pa\"])).tolist()",
           T_FIG5, "inverted ratio (G'p^HO / G'p^HE)"),
    Mutant("r3-32-sweep-no-html", S + "_cli/run_commands.py",
           "        path = sweep_report(out_dir, entries, title=name)",
           "        path = out_dir / \"report.html\"",
           T_SWEEP, "missing step (the sweep writes no report.html)"),
    # ------------------------------------------------------------------ issue 32: sweep sets, dynamic G'p
    Mutant("r3-32-set-protocol-merge-always", S + "ensemble/sweep.py",
           "d[\"protocol\"] = _merge(base, s[\"protocol\"]) if kind == base_kind else copy.deepcopy(s[\"protocol\"])",
           "d[\"protocol\"] = _merge(base, s[\"protocol\"])",
           T_SETS, "wrong rule (another kind's [protocol] merged into the study's: its options leak in)"),
    Mutant("r3-32-set-protocol-replace-always", S + "ensemble/sweep.py",
           "d[\"protocol\"] = _merge(base, s[\"protocol\"]) if kind == base_kind else copy.deepcopy(s[\"protocol\"])",
           "d[\"protocol\"] = copy.deepcopy(s[\"protocol\"])",
           T_SETS, "wrong rule (a set of the same kind loses the study's protocol options)"),
    Mutant("r3-32-set-folder-flat", S + "ensemble/sweep.py",
           "return sub if self.set is None else Path(self.set) / sub",
           "return sub",
           T_SETS, "missing step (sets share one folder level: values of different sets can collide)"),
    Mutant("r3-32-set-names-not-unique", S + "ensemble/sweep.py",
           "        if sname in names:\n",
           "        if sname in names and False:\n",
           T_SETS, "dropped check (two sets with one name write into one folder)"),
    Mutant("r3-32-set-analysis-ignored", S + "ensemble/sweep.py",
           "    for sec in (\"study\", \"psd\", \"analysis\"):\n        if sec in s:",
           "    for sec in (\"study\", \"analysis\"):\n        if sec in s:",
           T_SETS, "option dropped (a set's [sweep.set.psd] ignored)"),
    Mutant("r3-32-dynamic-every-value", S + "ensemble/sweep.py",
           "            dv = any(_same_value(v, x) for x in dyn)",
           "            dv = bool(dyn)",
           T_SETS, "wrong selection (every value of a set with a dynamic choice gets the shear test)"),
    Mutant("r3-32-dynamic-no-elastic-bonds", S + "ensemble/sweep.py",
           "if k in specs}",
           "if k in specs and k == \"radius\"}",
           T_SETS, "option dropped (the dynamic test ignores [analysis.elastic]'s bond rule: another network)"),
    Mutant("r3-32-dynamic-sweep-shear-ignored", S + "ensemble/sweep.py",
           "    table.update(copy.deepcopy(shear))",
           "    pass",
           T_SETS, "option dropped ([sweep.shear] not applied)"),
    Mutant("r3-32-dynamic-row-first", S + "studies/seed003_heterogeneity.py",
           "row[\"G_dyn_MPa\"] = float(d[:, 0].mean()) * 1e-6",
           "row[\"G_dyn_MPa\"] = float(d[0, 0]) * 1e-6",
           T_SETS, "wrong reduction (the first structure's dynamic G'p instead of the mean)"),
    Mutant("r3-32-dynamic-floppy-nan", S + "studies/seed003_heterogeneity.py",
           "        return 0.0, 0.0, status\n",
           "        return math.nan, math.nan, status\n",
           T_SETS + ("tests/test_sweep.py",), "wrong value (a floppy network's dynamic G'p reported as missing, not 0)"),
    Mutant("r3-32-set-param-first", S + "studies/seed003_heterogeneity.py",
           "par = item[2] if len(item) > 2 and item[2] is not None else parameter",
           "par = parameter",
           T_SETS, "option dropped (every set labelled by the first set's parameter: BD rows lose the seed's row)"),
    Mutant("r3-32-html-dynamic-missing", S + "report/build.py",
           "                    _g_dyn_cell(r),\n",
           "                    \"–\",\n",
           T_SETS, "missing output (the dynamic G'p column of report.html always empty)"),
    # ------------------------------------------------------------------ issue 32: VEM adhesive restructuring
    Mutant("r3-32-adh-friction-ignored", S + "generate/vem.py",
           "        p[K.P_MU] = mu\n",
           "        p[K.P_MU] = 0.0\n",
           T_VEMA, "option dropped (new contacts frictionless: they slide and the network folds too far)"),
    Mutant("r3-32-adh-no-bonds", S + "generate/vem.py",
           "bond = d <= (1.0 + ADHESION_BOND_GAP) * (self.radii[i] + self.radii[j])",
           "bond = d < 0.0 * (self.radii[i] + self.radii[j])",
           T_VEMA, "missing step (the VEM contacts not bonded: they slide and open)"),
    Mutant("r3-32-adh-range-centre", S + "generate/vem.py",
           "att = (~bonded) & (gap < self.rng)",
           "att = (~bonded) & (d < self.rng)",
           T_VEMA, "wrong quantity (centre distance instead of surface gap: no pair attracts)"),
    Mutant("r3-32-adh-break-at-contact", S + "generate/vem.py",
           "np.full(na, kap * (self.lever + self.rng))",
           "np.full(na, kap * self.lever)",
           T_VEMA, "wrong constant (the attraction breaks at touching: it pulls nothing closed)"),
    # ------------------------------------------------------------------ issue 32: reversible BD bonds (bond_escape)
    Mutant("r3-32-escape-no-r2", S + "generate/brownian.py",
           "outer = np.exp(v - v.max()) * inner / (2.0 * r * r)",
           "outer = np.exp(v - v.max()) * inner / (2.0 * r)",
           T_ESC, "wrong formula (radial first passage without the r² weight)"),
    Mutant("r3-32-escape-d0", S + "generate/brownian.py",
           "outer = np.exp(v - v.max()) * inner / (2.0 * r * r)",
           "outer = np.exp(v - v.max()) * inner / (r * r)",
           T_ESC, "wrong constant (pair diffusion D0 instead of 2 D0)"),
    Mutant("r3-32-exit-secondary", S + "generate/brownian.py",
           "            hx = ex.barrier_separation\n",
           "            hx = ex.secondary_separation\n",
           T_ESC, "wrong exit (secondary minimum instead of the barrier top)"),
    Mutant("r3-32-break-per-step", S + "generate/brownian.py",
           "rows = np.nonzero(self.rng.random(nb) < -math.expm1(-h / self.tau))[0]",
           "rows = np.nonzero(self.rng.random(nb) < -math.expm1(-sim.time_step / self.tau))[0]",
           T_ESC, "wrong rate (per-step probability applied once per chunk)"),
    Mutant("r3-32-chunk-long", S + "generate/brownian.py",
           "ESCAPE_CHUNK = 0.02",
           "ESCAPE_CHUNK = 2.0",
           T_ESC, "wrong constant (chunks longer than the escape time)"),
    Mutant("r3-32-break-gap", S + "generate/brownian.py",
           "s = 0.5 * (2.0 + g - r) / max(r, 1e-12)",
           "s = (2.0 + g - r) / max(r, 1e-12)",
           T_ESC, "wrong geometry (each sphere moved by the whole gap change)"),
]

ISSUES = ("30", "31", "32", "33", "34", "35", "36")


def issue_of(m) -> str:
    return m.id.split("-")[1]


def overlap():
    """Round-3 mutants whose target text overlaps a harness or independent mutant's in the same file."""
    import mutants_independent

    out = []
    for m in ROUND3:
        for h in list(mutate.MUTANTS) + list(mutants_independent.INDEPENDENT):
            if h.path == m.path and (h.find in m.find or m.find in h.find):
                out.append(f"{m.id} overlaps {h.id}")
    return out


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if "--overlap" in argv:
        lines = overlap()
        print("\n".join(lines) if lines else "no overlap with the harness or the independent list")
        return 0
    ids = {m.id for m in ROUND3}
    assert len(ids) == len(ROUND3), "duplicate ids"
    chosen = ROUND3
    if "--issue" in argv:
        k = argv.index("--issue")
        wanted = set(argv[k + 1].split(","))
        bad = wanted - set(ISSUES)
        if bad:
            print(f"--issue {argv[k + 1]}: allowed {', '.join(ISSUES)}", file=sys.stderr)
            return 2
        chosen = [m for m in ROUND3 if issue_of(m) in wanted]
        del argv[k:k + 2]
    mutate.MUTANTS = chosen  # main() and write_markdown() read the module's list
    return mutate.main(argv)


if __name__ == "__main__":
    sys.exit(main())
