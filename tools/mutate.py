#!/usr/bin/env python
"""Mutation testing of polypack with a hand-written list of plausible one-line bugs.

Each mutant replaces one exact piece of source text (a wrong sign, a factor 2, a
swapped box length, an off-by-one, ...) in a copy of the tree; the tests that
should notice it run on the copy (``PYTHONPATH=<copy>/src``, ``pytest -x``, with a
timeout) and the mutant is *caught* when they fail.  A table and the caught
fraction are printed; ``--json`` writes the results.

Why hand-written and not mutmut / cosmic-ray: those tools rewrite the source of
every module they import, which defeats numba's on-disk cache (every mutant then
recompiles all kernels, minutes each) and they mutate the numba kernels into code
that often does not compile at all.  A short list of bugs a reviewer would
actually make, aimed at stable spots (kernels, analyses, PSD, shaking, packing,
the study pipeline), runs in minutes and says exactly what the suite misses.

numba cache: polypack keys its cache folder on a digest of the kernel sources.  A
mutant of a kernel file gets its own folder, seeded (hard links) from the warm cache
of the unmodified tree minus the entries of the mutated module and of every kernel
module that imports it (their machine code has the mutated code inlined), so only
those recompile; the folder is deleted afterwards.  Mutants elsewhere reuse the warm
cache.  The copy lives at a fixed path, with the original mtimes restored after each
mutant, so numba's per-file index stays valid between mutants.

A mutant whose tests run out of time is reported as ``timeout``, not as caught: a
slow machine is no evidence that the tests notice the bug (rerun it with a longer
``--timeout``).

A mutant whose target text no longer occurs exactly once (the code was refactored)
is reported as ``stale`` and skipped, never applied somewhere else.

Two shards run side by side on two cores: each has its own workdir (the copy, its numba
cache folders and the pytest temporary folder live there), and ``--markdown`` merges
their result files::

    nice python tools/mutate.py --workdir /tmp/mut_a --shard 1/2 --json a.json &
    nice python tools/mutate.py --workdir /tmp/mut_b --shard 2/2 --json b.json &
    wait; python tools/mutate.py --markdown tools/mutants_result.md a.json b.json

Usage::

    python tools/mutate.py                 # all mutants
    python tools/mutate.py --list          # the list only
    python tools/mutate.py --check         # every mutant applies once, compiles, names existing tests
    python tools/mutate.py --shard 2/3     # every third mutant from the second (list order)
    python tools/mutate.py --only k-rdf-fast-ly s-random-order
    python tools/mutate.py --timeout 300 --json mutants.json
    python tools/mutate.py --markdown tools/mutants_result.md a.json b.json   # table of results

The recorded result of the whole list is tools/mutants_result.md.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Mutant:
    id: str
    path: str  # relative to the repository root
    find: str  # exact text, must occur exactly once
    replace: str
    tests: tuple  # pytest arguments (files or node ids)
    kind: str  # which kind of bug


K = "src/polypack/_kernels/"
A = "src/polypack/analysis/"
P = "src/polypack/psd/"
G = "src/polypack/generate/"
E = "src/polypack/ensemble/"

# the file expected to catch a mutant comes first (pytest -x stops at the first failure)
T_NC = "tests/test_noncubic.py"
T_EB = "tests/test_error_bars.py"
T_RDF = (T_NC, "tests/test_analysis_rdf.py")
T_WIN = (T_NC, "tests/test_analysis_windows_contacts.py")
T_PORE = (T_NC, "tests/test_analysis_pores.py")
T_SHAKE = ("tests/test_shake.py", T_NC)
T_SHAKE_NC = (T_NC, "tests/test_shake.py")
T_PACK = ("tests/test_pack.py", T_NC)
T_PSD = ("tests/test_psd_descriptors.py", "tests/test_psd_models.py", "tests/test_psd_classes.py")

MUTANTS = [
    # ---------------------------------------------------------------- kernels
    Mutant("k-minimage-half", K + "cells.py",
           "    half = 0.5 * length\n",
           "    half = length\n",
           ("tests/test_packing.py", "tests/test_analysis_rdf.py"), "factor 2"),
    Mutant("k-separation2-box", K + "cells.py",
           "    dy = min_image(pos[j, 1] - pos[i, 1], box[1])\n    dz = min_image(pos[j, 2] - pos[i, 2], box[2])\n"
           "    return dx * dx + dy * dy + dz * dz",
           "    dy = min_image(pos[j, 1] - pos[i, 1], box[1])\n    dz = min_image(pos[j, 2] - pos[i, 2], box[0])\n"
           "    return dx * dx + dy * dy + dz * dz",
           (T_NC, "tests/test_packing.py"), "swapped box length"),
    # (inside one cell the fast kernel's min_image never wraps: it needs >= 5 cells per axis,
    # so a swapped length there is an equivalent mutant; the cross-cell sweep is not)
    Mutant("k-rdf-fast-ly", K + "analysis.py",
           "                    dy = min_image(y[j] - yi, ly)\n",
           "                    dy = min_image(y[j] - yi, lz)\n",
           T_RDF, "swapped box length"),
    Mutant("k-rdf-fast-cross-lz", K + "analysis.py",
           "                    dz = min_image(z[j] - zi, lz)\n",
           "                    dz = min_image(z[j] - zi, lx)\n",
           T_RDF, "swapped box length"),
    Mutant("k-halfshell-cly", K + "analysis.py",
           "gy = max(abs(oy) - 1, 0) * cl[1]",
           "gy = max(abs(oy) - 1, 0) * cl[0]",
           (T_NC + "::test_half_shell_sweep_visits_every_offset_that_holds_a_pair", "tests/test_analysis_rdf.py"),
           "swapped box length"),
    Mutant("k-rdf-bin-offbyone", K + "analysis.py",
           "                b = int(np.floor(xv * inv_h + 1e-9))\n",
           "                b = int(np.floor(xv * inv_h + 1e-9)) + 1\n",
           (T_NC, "tests/test_analysis_rdf.py"), "off-by-one"),
    Mutant("k-window-species", K + "analysis.py",
           "                    out[i, species[j]] += 1\n",
           "                    out[i, species[i]] += 1\n",
           T_WIN, "wrong index"),
    Mutant("k-window-strict", K + "analysis.py",
           "if j != i and separation2(pos, i, j, box) <= r2:",
           "if j != i and separation2(pos, i, j, box) < r2:",
           ("tests/test_analysis_windows_contacts.py::test_window_is_closed_on_its_boundary",
            "tests/test_analysis_windows_contacts.py", T_NC), "off-by-one (closed vs open window)"),
    Mutant("k-pores-cl1", K + "analysis.py",
           "            cl1 = box[1] / nc1\n",
           "            cl1 = box[0] / nc1\n",
           T_PORE, "swapped box length"),
    Mutant("k-pores-minimage-y", K + "analysis.py",
           "                                dy = min_image(sy[s] - qy, box[1])\n",
           "                                dy = min_image(sy[s] - qy, box[0])\n",
           T_PORE, "swapped box length"),
    Mutant("k-pores-radius-sign", K + "analysis.py",
           "dd = np.sqrt(dx * dx + dy * dy + dz * dz) - sr[s]",
           "dd = np.sqrt(dx * dx + dy * dy + dz * dz) + sr[s]",
           ("tests/test_analysis_pores.py", T_NC), "wrong sign"),
    Mutant("k-shake-overlap-ly", K + "shake.py",
           "    dy -= ly * np.rint(dy / ly)\n    dz -= lz * np.rint(dz / lz)\n    sig = ri + radii[j]\n"
           "    return dx * dx",
           "    dy -= lx * np.rint(dy / lx)\n    dz -= lz * np.rint(dz / lz)\n    sig = ri + radii[j]\n"
           "    return dx * dx",
           T_SHAKE_NC, "swapped box length"),
    Mutant("k-shake-wrap-y", K + "shake.py",
           "                    yn = _wrap1(y0 + dya, box[1])\n                    zn = _wrap1(z0 + dza, box[2])\n"
           "                    if use_cells:",
           "                    yn = _wrap1(y0 + dya, box[0])\n                    zn = _wrap1(z0 + dza, box[2])\n"
           "                    if use_cells:",
           T_SHAKE_NC, "swapped box length"),
    Mutant("k-shake-random-order", K + "shake.py",
           "                i = int(rng_uniform(rng) * n)\n",
           "                i = int(rng_uniform(rng) * (n - 1))\n",
           T_SHAKE, "off-by-one"),
    Mutant("k-shake-adapt-shrink", K + "shake.py",
           "                    if f > step:\n                        rsh[k] *= 1.0 + adapt_factor\n"
           "                    else:\n                        rsh[k] /= 1.0 + adapt_factor\n",
           "                    if f > step:\n                        rsh[k] *= 1.0 + adapt_factor\n"
           "                    else:\n                        rsh[k] /= 1.0 + 2.0 * adapt_factor\n",
           T_SHAKE, "factor 2"),
    Mutant("k-shake-flight-sign", K + "shake.py",
           "    return t if (b < 0.0 and disc >= 0.0) else np.inf  # approaching and hitting\n",
           "    return t if (b > 0.0 and disc >= 0.0) else np.inf  # approaching and hitting\n",
           T_SHAKE, "wrong sign"),
    Mutant("k-shake-collision-tau", K + "shake.py",
           "                tau = bestf if bestf < step else step\n",
           "                tau = step\n",
           T_SHAKE, "bound ignored"),
    Mutant("k-edmd-minimage-z", K + "edmd.py",
           "        dz = min_image(P[j, 2] - P[i, 2], box[2])\n",
           "        dz = min_image(P[j, 2] - P[i, 2], box[0])\n",
           (T_NC, "tests/test_pack.py"), "swapped box length"),
    Mutant("h33-pair-bound", K + "edmd.py",
           "    if (A >= 0.0) & ((B >= 0.0) | ((C > 0.0) & (C >= best * (-2.0 * B) * (1.0 + 1e-9)))):\n",
           "    if (A >= 0.0) & ((B >= 0.0) | ((C > 0.0) & (C >= best * (-1.0 * B) * (1.0 + 1e-9)))):\n",
           ("tests/test_edmd_hot.py",), "lower bound of the pair time too high (skips real collisions)"),
    Mutant("h33-skip-separating-growing", K + "edmd.py",
           "    if (A >= 0.0) & ((B >= 0.0) | ((C > 0.0)",
           "    if ((B >= 0.0) | ((C > 0.0)",
           ("tests/test_edmd_hot.py",), "skips pairs that grow into each other while separating (A < 0)"),
    Mutant("h33-record-velocity", K + "edmd.py",
           "            P[i, R_V + k] = v[o, k]\n",
           "            P[i, R_V + k] = v[o, k] * 0.5\n",
           ("tests/test_golden.py",), "wrong value copied into the per-sphere record"),
    Mutant("h33-argsort-unstable", K + "cells.py",
           "                if keys[a[j]] < keys[a[i]]:  # strict",
           "                if keys[a[j]] <= keys[a[i]]:  # strict",
           ("tests/test_cold_start.py",), "stable merge takes the right run first on ties"),
    Mutant("h33-median-even", K + "edmd.py",
           "        return (a[o[h - 1]] + a[o[h]]) / 2\n",
           "        return (a[o[h]] + a[o[h + 1]]) / 2\n",
           ("tests/test_cold_start.py",), "off-by-one (upper middle pair)"),
    Mutant("h33-options-only-early", G + "shake.py",
           "    options_only = _OPTIONS_ONLY.get()\n",
           "    options_only = _OPTIONS_ONLY.get()\n    if options_only:\n        return packing\n",
           ("tests/test_cold_start.py",), "options check returns before the skin checks"),
    # --------------------------------------------------------------- analyses
    Mutant("a-k-err-sqrt2", A + "kfunction.py",
           "return np.sqrt(2.0 * tot) / dens_t", "return np.sqrt(tot) / dens_t",
           (T_EB, "tests/test_analysis_kfunction.py"), "factor sqrt 2"),
    Mutant("a-g-err-sqrt2", A + "rdf.py",
           "rel = np.where(ct > 0, 1.0 / np.sqrt(ct / 2.0), np.nan)",
           "rel = np.where(ct > 0, 1.0 / np.sqrt(ct), np.nan)",
           (T_EB, "tests/test_analysis_rdf.py"), "factor sqrt 2"),
    Mutant("a-partial-err-diag", A + "rdf.py",
           "unordered = np.where(diag, cp / 2.0, cp)", "unordered = np.where(diag, cp, cp)",
           (T_EB, "tests/test_analysis_rdf.py"), "factor sqrt 2"),
    Mutant("a-rdf-shell-volume", A + "rdf.py",
           "            vol = shell_measure(r, self._dim) * (2.0 * h)\n",
           "            vol = shell_measure(r, self._dim) * h\n",
           ("tests/test_analysis_rdf.py",), "factor 2"),
    Mutant("a-contact-err", A + "rdf.py",
           "sig = np.sqrt(np.maximum(cnt, 1.0)) * g / np.maximum(cnt, 1.0)",
           "sig = np.sqrt(2.0 * np.maximum(cnt, 1.0)) * g / np.maximum(cnt, 1.0)",
           (T_EB, "tests/test_analysis_rdf.py"), "factor sqrt 2"),
    Mutant("a-window-p-err", A + "windows.py",
           "return np.sqrt((b - 1) / b * np.sum((pj - pj.mean(axis=0)) ** 2, axis=0))",
           "return np.sqrt(1.0 / b * np.sum((pj - pj.mean(axis=0)) ** 2, axis=0))",
           (T_EB, "tests/test_analysis_windows_contacts.py"), "wrong factor (jackknife)"),
    Mutant("a-pores-survival-err", A + "pores.py",
           "        return np.sqrt(s * (1 - s) / nv)\n",
           "        return np.sqrt(s * (1 - s) / (2 * nv))\n",
           (T_EB, "tests/test_analysis_pores.py"), "factor sqrt 2"),
    Mutant("a-pores-default-r0", A + "pores.py",
           'r0 = self.r0 if self.r0 is not None else float(packing.radii.mean())',
           'r0 = self.r0 if self.r0 is not None else float(packing.radii.max())',
           ("tests/test_analysis_pores.py",), "wrong reference"),
    Mutant("a-contacts-z-live", A + "contacts.py",
           '"z_live": 2.0 * int(live.sum()) / n_live if n_live else np.nan,',
           '"z_live": 2.0 * int(live.sum()) / n if n_live else np.nan,',
           ("tests/test_analysis_windows_contacts.py",), "wrong denominator"),
    Mutant("a-pairnorm-contact-3", A + "_paircounts.py",
           "        + 3.0 * np.outer(mom[2], mom[1])\n",
           "        + 2.0 * np.outer(mom[2], mom[1])\n",
           ("tests/test_analysis_rdf.py", "tests/test_analysis_kfunction.py"), "wrong coefficient"),
    Mutant("a-cs-contact", A + "theory.py",
           "return (1.0 - 0.5 * c) / (1.0 - c) ** 3", "return (1.0 - 0.5 * c) / (1.0 - c) ** 2",
           ("tests/test_analysis_theory.py",), "wrong power"),
    Mutant("a-eq17-printed", A + "theory.py",
           "q = (g2 - 1) / (g1 - 1) if printed else g2 / g1", "q = (g2 - 1) / g1 if printed else g2 / g1",
           ("tests/test_analysis_theory.py",), "dropped term"),
    # --------------------------------------------------------------------- psd
    Mutant("p-sizeset-quantile-dim", P + "sizeset.py",
           "        ds = np.sort(self.diameters)\n        cum = np.cumsum(ds**self.dim)\n",
           "        ds = np.sort(self.diameters)\n        cum = np.cumsum(ds**3)\n",
           T_PSD, "ignores dimension"),
    Mutant("p-sizeset-grading-dim", P + "sizeset.py",
           "        ds = dd[order]\n        cum = np.cumsum(ds**self.dim)\n",
           "        ds = dd[order]\n        cum = np.cumsum(ds**3)\n",
           T_PSD, "ignores dimension"),
    Mutant("p-sizeset-quantile-side", P + "sizeset.py",
           'k = np.searchsorted(cum, p - 1e-12, side="left")',
           'k = np.searchsorted(cum, p + 1e-12, side="left")',
           T_PSD, "off-by-one"),
    Mutant("p-hazen-cu", P + "descriptors.py",
           '"Cu": d60 / d10,', '"Cu": d50 / d10,', T_PSD, "wrong index"),
    # --------------------------------------------------------------- generate
    Mutant("g-metropolis-feedback", G + "shake.py",
           "fac = min(1.4, max(0.7, acc[k] / o[\"target_acceptance\"]))",
           "fac = min(1.4, max(0.7, o[\"target_acceptance\"] / acc[k]))",
           T_SHAKE, "wrong sign (inverted feedback)"),
    Mutant("g-pack-event-budget", G + "lubachevsky.py",
           "ev_budget = int(max_events) - int(state[edmd.S_EVENTS])", "ev_budget = int(max_events)",
           ("tests/test_pack.py::test_event_budget_is_shared_by_all_chunks",) + T_PACK, "budget not decremented"),
    Mutant("g-pack-cs", G + "lubachevsky.py",
           "return (1 + eta + eta**2 - eta**3) / (1 - eta) ** 3",
           "return (1 + eta + eta**2 - 2 * eta**3) / (1 - eta) ** 3",
           T_PACK, "wrong coefficient"),
    # ------------------------------------------------------- study / ensemble
    Mutant("e-discretize-ignored", P + "config.py",
           'if resolved["sampling"] == "discretize":', 'if resolved["sampling"] == "discretise":',
           ("tests/test_pipeline_options.py",), "option ignored"),
    Mutant("e-shake-keys", G + "_capabilities.py",
           '"shaking variant", api="method",',
           '"shaking variant", api="methods",',
           ("tests/test_pipeline_options.py",), "option misrouted"),
    Mutant("e-proto-stats-declared", E + "stages.py",
           "tables = cap.meta_tables() if cap is not None else ()",
           "tables = (\"shake\", \"scrm\", \"brownian\")",
           ("tests/test_declarations.py",), "hard-coded protocol statistics (issue 30)"),
    Mutant("e-cli-flag-dropped", "src/polypack/_cli/_generated.py",
           "        table[key] = value", "        pass",
           ("tests/test_declarations.py::test_a_toy_protocol_and_mechanics_stage_are_one_dataclass_one_function_one_register",),
           "a generated CLI flag checked but never passed on (issue 30)"),
    Mutant("e-cli-unit-dropped", "src/polypack/_cli/_generated.py",
           'unit = f" \\\\[{spec.unit}]" if spec.unit else ""', 'unit = ""',
           ("tests/test_declarations.py::test_every_capability_is_one_declaration_cli_study_docs",),
           "the CLI help loses the field's unit (issue 30)"),
    Mutant("e-cli-alias-dropped", "src/polypack/_cli/_generated.py",
           "                kw[key] = value\n", "                pass\n",
           ("tests/test_mechanics_cli.py",), "a deprecated flag spelling (--kn) accepted but ignored (issue 30)"),
    Mutant("e-cli-repeat-last", "src/polypack/_cli/_generated.py",
           "    if len(values) == 1:\n        return values[0]", "    if len(values) >= 1:\n        return values[-1]",
           ("tests/test_moduli_cli.py",), "a repeated flag keeps its last value only (--inclusions per species)"),
    Mutant("e-cli-shear-ks", "src/polypack/_cli/shear_commands.py",
           "        kn, ks = _stiffnesses(o)", '        kn, ks = o["normal_stiffness"], 10.0',
           ("tests/test_declarations.py::test_mechanics_commands_take_the_stage_fields_and_match_the_stage",),
           "the command's own default (k_s = 10) instead of the stage's (k_n / 10) (issue 30)"),
    Mutant("e-cli-old-direction", "src/polypack/_cli/shear_commands.py",
           '        flags = {**flags, "directions": _direction_pairs(own["direction"])}', "        _direction_pairs(own[\"direction\"])",
           ("tests/test_declarations.py::test_mechanics_commands_take_the_stage_fields_and_match_the_stage",),
           "the old --direction N,S checked but dropped (all six directions run)"),
    Mutant("e-psd-descriptors-dropped", "src/polypack/psd/descriptors.py",
           'sizes.report.setdefault("descriptors", describe(sizes))', 'sizes.report.setdefault("descriptors", {})',
           ("tests/test_psd_descriptors.py", "tests/test_psd_classes.py"),
           "a generated size set loses its descriptors (SizeSet made data only, issue 30)"),
    Mutant("e-psd-cr-dropped", "src/polypack/psd/descriptors.py",
           "        if not model.has_atoms:\n            sizes.report", "        if False:\n            sizes.report",
           ("tests/test_psd_classes.py",), "Cr (Eq. (21) of seed 001) no longer reported for a sampled set"),
    Mutant("e-unset-rule-dropped", "src/polypack/registry.py",
           'md.get("fill", True), md.get("unset", ""))', 'md.get("fill", True), "")',
           ("tests/test_declarations.py::test_every_optional_field_declares_its_unset_rule",),
           "the declared rule of an unset option lost (back to 'the run's own default')"),
    Mutant("e-ci-dof", E + "runner.py",
           "t_quantile(cnt - 1)", "t_quantile(cnt)",
           (T_EB, "tests/test_ensemble.py"), "off-by-one (degrees of freedom)"),
]


# round 2 (added as it lands): dimension-aware geometry, mechanics
MUTANTS += [
    Mutant("r2-geometry-circle", "src/polypack/geometry.py",
           "return 4.0 * np.pi if check_dim(dim) == 3 else 2.0 * np.pi",
           "return 4.0 * np.pi if check_dim(dim) == 3 else np.pi",
           ("tests/test_dimensions.py",), "factor 2 (2D)"),
    Mutant("r2-zeta-reference", "src/polypack/mechanics/effective.py",
           "return g * (9.0 * k + 8.0 * g) / (6.0 * (k + 2.0 * g))",
           "return g * (9.0 * k + 8.0 * g) / (6.0 * (k + g))",
           ("tests/test_mechanics_effective.py",), "dropped factor"),
    Mutant("r2-dilute-sign", "src/polypack/mechanics/effective.py",
           "        g += ci * (m.shear + z) * (1.0 - (m.shear + z) * _inv(p.shear + z))\n",
           "        g -= ci * (m.shear + z) * (1.0 - (m.shear + z) * _inv(p.shear + z))\n",
           ("tests/test_mechanics_effective.py",), "wrong sign"),
]


# round 2 (session 5): mechanics, Brownian dynamics, VEM, deposition, 2D EDMD, ensemble, stages
M = "src/polypack/mechanics/"
T_NET = ("tests/test_mechanics_network.py",)
T_EL = ("tests/test_mechanics_elastic.py",)
T_EFF = ("tests/test_mechanics_effective.py",)
T_DEM = ("tests/test_dem.py",)
T_3PT = ("tests/test_analysis_threepoint.py",)
T_BD = ("tests/test_brownian.py", "tests/test_dlvo.py")
T_BDR = ("tests/test_brownian_rigid.py",)
T_VEM = ("tests/test_vem.py",)
T_DEP2 = ("tests/test_deposit.py",)
T_DEP3 = ("tests/test_deposit3d.py",)
T_P2D = ("tests/test_pack2d.py",)
T_ST = ("tests/test_stages_mechanics.py",)
MUTANTS += [
    # bonded networks
    Mutant("m-net-bond-rule", M + "network.py",
           "pi, pj, _ = _candidate_pairs(packing, 1.0 + eps)", "pi, pj, _ = _candidate_pairs(packing, 1.0 + 2.0 * eps)",
           T_NET, "factor 2 (bonding distance)"),
    Mutant("m-net-shift-sign", M + "network.py",
           "shift = np.where(periodic, -np.round(delta / box), 0.0).astype(np.int64)",
           "shift = np.where(periodic, np.round(delta / box), 0.0).astype(np.int64)",
           T_NET, "wrong sign (periodic image)"),
    Mutant("m-net-rattler-threshold", M + "network.py",
           "        return self._peel(2)\n", "        return self._peel(1)\n",
           T_NET, "off-by-one (rattler rule)"),
    Mutant("m-net-lever-arm", M + "network.py",
           "return (r[self._i] - 0.5 * self.overlap)[:, None] * self._normal",
           "return (r[self._i] - self.overlap)[:, None] * self._normal",
           T_NET + T_EL, "factor 2 (contact point)"),
    Mutant("k-net-peel-strict", K + "network.py",
           "            if deg[q] < min_bonds:\n", "            if deg[q] <= min_bonds:\n",
           T_NET, "off-by-one (recursive peel)"),
    # the shared CSR primitive (bond incidence of the network kernels, the shaking Verlet list)
    Mutant("k-csr-prefix-last", K + "csr.py",
           "    for p in range(n):\n        offsets[p + 1] += offsets[p]\n",
           "    for p in range(n - 1):\n        offsets[p + 1] += offsets[p]\n",
           T_NET + ("tests/test_shake.py",), "off-by-one (prefix sum stops before the last particle)"),
    Mutant("k-csr-one-end", K + "csr.py",
           "        offsets[b[q] + 1] += 1\n", "        offsets[a[q] + 1] += 1\n",
           ("tests/test_shake.py",) + T_NET, "wrong index (both ends of a pair counted at its first particle)"),
    # exact elastic tensor
    Mutant("m-el-affine-voigt", M + "elastic.py",
           "w = 1.0 if p == r else 0.5", "w = 1.0 if p == r else 1.0",
           T_EL, "factor 2 (engineering shear)"),
    Mutant("m-el-spring-matrix", M + "elastic.py",
           "k = (kn - ks)[:, None, None] * n[:, :, None] * n[:, None, :] + ks[:, None, None] * np.eye(3)",
           "k = (kn + ks)[:, None, None] * n[:, :, None] * n[:, None, :] + ks[:, None, None] * np.eye(3)",
           T_EL, "wrong sign"),
    Mutant("m-el-voigt-average-g", M + "elastic.py",
           "return (a + 2.0 * b) / 9.0, (a - b + 3.0 * s) / 15.0", "return (a + 2.0 * b) / 9.0, (a - b + 2.0 * s) / 15.0",
           ("tests/test_mechanics_averages.py",) + T_EL, "wrong coefficient (isotropic average)"),
    Mutant("m-el-reuss", M + "elastic.py",
           "return 1.0 / (a + 2.0 * b), 15.0 / (4.0 * a - 4.0 * b + 3.0 * t)",
           "return 1.0 / (a + 2.0 * b), 15.0 / (4.0 * a - 4.0 * b + 4.0 * t)",
           ("tests/test_mechanics_averages.py",) + T_EL, "wrong coefficient (Reuss average)"),
    Mutant("k-net-assemble-voigt", K + "network.py",
           "        A[0, 4] = 0.5 * b2\n", "        A[0, 4] = b2\n",
           T_EL, "factor 2 (engineering shear)"),
    Mutant("k-net-assemble-arm-sign", K + "network.py",
           "                    Bj[r, 3 + s] = -X[r, s] / ell\n", "                    Bj[r, 3 + s] = X[r, s] / ell\n",
           T_EL, "wrong sign (lever arm of j)"),
    # DEM: contact law, damping, Lees-Edwards
    Mutant("k-dem-damping-sign", K + "dem.py",
           "                if vr > 0.0:\n                    fd = -alpha * abs(f)\n",
           "                if vr > 0.0:\n                    fd = alpha * abs(f)\n",
           T_DEM, "wrong sign (local damping)"),
    Mutant("k-dem-le-streaming", K + "dem.py",
           "                    vr = v - gdot * pos[i, g]\n", "                    vr = v + gdot * pos[i, g]\n",
           T_DEM, "wrong sign (Lees-Edwards streaming velocity)"),
    Mutant("k-dem-le-shift", K + "dem.py",
           "            h[a, g] += gam * lg\n", "            h[g, a] += gam * lg\n",
           T_DEM, "swapped indices (Lees-Edwards tilt)"),
    Mutant("k-contact-lever", K + "contacts.py",
           "        li = 0.5 * (d + ri - rj)\n", "        li = 0.5 * (d + rj - ri)\n",
           ("tests/test_dem_contacts.py",) + T_DEM, "swapped radii (lever arm)"),
    Mutant("k-contact-tension", K + "contacts.py",
           "        if -fn >= fnb:\n", "        if fn >= fnb:\n",
           T_DEM, "wrong sign (tensile breakage)"),
    # effective moduli
    Mutant("m-eff-mt-reference", M + "effective.py",
           "return Phase(bulk=_lam(m.shear, bulks, c), shear=_gam(zeta_reference(m.bulk, m.shear), shears, c))",
           "return Phase(bulk=_lam(m.bulk, bulks, c), shear=_gam(zeta_reference(m.bulk, m.shear), shears, c))",
           T_EFF, "wrong reference modulus (Mori-Tanaka)"),
    Mutant("m-eff-lambda-43", M + "effective.py",
           "return _hs_form(bulks, c, 4.0 * z / 3.0)", "return _hs_form(bulks, c, 2.0 * z / 3.0)",
           T_EFF, "factor 2 (HS bulk form)"),
    Mutant("m-eff-hs-upper", M + "effective.py",
           "shear=_gam(zeta_reference(kmax, gmax), shears, c))", "shear=_gam(zeta_reference(kmin, gmax), shears, c))",
           T_EFF, "wrong extreme (HS upper bound)"),
    Mutant("m-eff-3pt-tilde", M + "effective.py",
           "        tilde = phi2 * m1 + phi1 * m2\n", "        tilde = phi1 * m1 + phi2 * m2\n",
           T_EFF, "swapped fractions (three-point bound)"),
    # three-point parameters
    Mutant("a-3pt-zeta-phi1", A + "threepoint.py",
           "zeta2 = 9.0 * j2 / (2.0 * phi1 * phi2)", "zeta2 = 9.0 * j2 / (2.0 * phi2)",
           T_3PT, "dropped factor"),
    Mutant("a-3pt-eta-coefficient", A + "threepoint.py",
           "eta2 = 5.0 * zeta2 / 21.0 + 150.0 * j4", "eta2 = 5.0 * zeta2 / 7.0 + 150.0 * j4",
           T_3PT, "wrong coefficient"),
    Mutant("k-3pt-f4", K + "threepoint.py",
           "w4 = w2 * (1.0 - 1.4 * asqt / r2)", "w4 = w2 * (1.0 - 1.2 * asqt / r2)",
           T_3PT, "wrong coefficient (ball field l = 4)"),
    # Brownian dynamics and DLVO
    Mutant("g-bd-noise", G + "brownian.py",
           "params[bd.P_NOISE] = math.sqrt(2.0 * dt_r)", "params[bd.P_NOISE] = math.sqrt(dt_r)",
           T_BD, "factor sqrt 2 (noise amplitude)"),
    Mutant("g-dlvo-force-sign", G + "dlvo.py",
           "    return v_vdw + v_el, -(dv_vdw + dv_el)\n", "    return v_vdw + v_el, dv_vdw + dv_el\n",
           T_BD, "wrong sign (DLVO force)"),
    Mutant("g-dlvo-lsa-force", G + "dlvo.py",
           "dv_el = pref * ex * (-kappa / r - 1.0 / (r * r))", "dv_el = pref * ex * (-kappa / r + 1.0 / (r * r))",
           T_BD, "wrong sign (screened Coulomb derivative)"),
    Mutant("k-bd-drift-cap", K + "bd.py",
           "        fmax = cap_drift * max(h, 0.0) / (2.0 * dt)\n",
           "        fmax = cap_drift * max(h, 0.0) / dt\n",
           ("tests/test_bd_kernel.py",) + T_BD, "factor 2 (both spheres move)"),
    Mutant("k-bd-rigid-drag", K + "bd.py",
           "        sm = 1.0 / np.sqrt(m)\n", "        sm = 1.0 / m\n",
           T_BDR, "wrong power (cluster noise)"),
    # void expansion
    Mutant("k-vem-classify", K + "vem.py",
           "        if i < n_struct and j < n_struct:\n", "        if i < n_struct or j < n_struct:\n",
           T_VEM, "wrong condition"),
    # (kn = kn,V = 100 by default: a swap of the normal stiffnesses is an equivalent mutant)
    Mutant("g-vem-void-stiffness", G + "vem.py",
           "self.cks = np.where(struct, self.ks, np.where(voids, self.ksvv, self.ksv))",
           "self.cks = np.where(struct, self.ksv, np.where(voids, self.ksvv, self.ks))",
           ("tests/test_vem.py::test_void_contacts_get_the_void_stiffnesses",) + T_VEM, "swapped stiffnesses"),
    Mutant("g-vem-coordination", G + "vem.py",
           "c = 2.0 * st[V.C_STRUCT_CONTACTS] / ns", "c = 2.0 * st[V.C_STRUCT_CONTACTS] / (ns + n_void)",
           T_VEM, "wrong denominator"),
    # deposition
    Mutant("k-dep2-tie-rule", K + "deposit.py",
           "    if y <= best_y + tie and x < best_x:\n", "    if y <= best_y + tie and x > best_x:\n",
           ("tests/test_deposit.py::test_equal_pockets_fill_from_the_left",) + T_DEP2, "inverted tie rule"),
    Mutant("k-dep2-pair-between", K + "deposit.py",
           "    if px < lo or px > hi:\n        return False, 0.0, 0.0, -1, -1\n    return True, xi + px",
           "    if px < lo and px > hi:\n        return False, 0.0, 0.0, -1, -1\n    return True, xi + px",
           T_DEP2, "dropped check (equilibrium on the pair)"),
    Mutant("k-dep3-stable", K + "deposit3d.py",
           "    return l0 >= -tol and l1 >= -tol and l2 >= -tol\n", "    return l0 >= -tol and l1 >= -tol\n",
           T_DEP3, "dropped check (stability cone)"),
    Mutant("k-dep3-stable-ly", K + "deposit3d.py",
           "            d1 = _mi(p[1] - pos[s, 1], L[1], per[1])\n", "            d1 = _mi(p[1] - pos[s, 1], L[0], per[0])\n",
           T_DEP3, "swapped box length"),
    # 2D event-driven packing
    Mutant("k-edmd-window-pressure", K + "edmd.py",
           "    p = 1.0 + w_vir / (2.0 * w_ke) if w_ke > 0.0 else INF\n",
           "    p = 1.0 + w_vir / (3.0 * w_ke) if w_ke > 0.0 else INF\n",
           T_P2D + ("tests/test_pack.py",), "wrong dimension factor (2D and 3D share it)"),
    Mutant("k-edmd2d-predict-ly", K + "edmd2d.py",
           "        dy = min_image(x[j, 1] + v[j, 1] * dtj - xi1, box[1])\n",
           "        dy = min_image(x[j, 1] + v[j, 1] * dtj - xi1, box[0])\n",
           T_P2D, "swapped box length"),
    # ensemble statistics, study stages
    Mutant("e-t-one-sided", E + "runner.py",
           "q = student_t.ppf(0.5 + 0.5 * CI_LEVEL,", "q = student_t.ppf(CI_LEVEL,",
           (T_EB, "tests/test_ensemble.py"), "one-sided quantile"),
    Mutant("e-se-ddof", E + "runner.py",
           "sd = np.nanstd(y, axis=0, ddof=1) if len(sets) > 1", "sd = np.nanstd(y, axis=0, ddof=0) if len(sets) > 1",
           (T_EB, "tests/test_ensemble.py"), "off-by-one (degrees of freedom)"),
    Mutant("m-stage-ks-default", M + "stages.py",
           "ks = kn / 10.0 if ks is None else float(ks)", "ks = kn * 10.0 if ks is None else float(ks)",
           T_ST, "inverted ratio"),
    Mutant("m-stage-protocol-bonds", M + "stages.py",
           'if rule != "distance" and has:', 'if rule == "protocol" and has:',
           T_ST, "option misrouted (auto ignores the BD bonds)"),
    Mutant("m-stage-radius-scale", M + "stages.py",
           "s = float(radius) / float(np.mean(packing.radii))", "s = float(radius) / float(np.max(packing.radii))",
           T_ST, "wrong reference"),
]


# round 2 (session 6): the DEM's static reference, the closed-form three-point shear bounds,
# the PARDISO inertia count, the pruning of 3D deposition
T_DST = ("tests/test_dem_static.py",) + T_DEM
T_MPT = ("tests/test_mechanics_threepoint_bounds.py",) + T_EFF
MUTANTS += [
    # static_shear_modulus (mechanics/_dem_stiffness.py).  (The reference length ell and any
    # scaling of whole unknown columns cancel in min |R q + r|: only a scaling that differs
    # between unknowns of the same kind changes the conditioning, the SI-scale tests see it.)
    Mutant("m-static-rot-scale-j", M + "_dem_stiffness.py",
           "    B[:, :, 3:6] /= ell\n    B[:, :, 9:12] /= ell\n",
           "    B[:, :, 3:6] /= ell\n    B[:, :, 3:6] /= ell\n",
           T_DST, "copy-paste (rotations of j left in SI units)"),
    Mutant("m-static-energy-sign", M + "_dem_stiffness.py",
           "    relaxed = R @ q + r\n", "    relaxed = R @ q - r\n",
           T_DST, "wrong sign (relaxed energy)"),
    Mutant("m-static-unbonded-rigid", M + "_dem_stiffness.py",
           "+ 6 * np.count_nonzero(label < 0))", "+ 3 * np.count_nonzero(label < 0))",
           ("tests/test_dem_static.py::test_unbonded_sphere_adds_six_rigid_modes_and_no_floppy_one",) + T_DST,
           "wrong count (rigid modes of an unbonded sphere)"),
    # closed-form Milton-Phan-Thien parameters (mechanics/effective.py): a zeta average for an
    # eta one keeps the Hashin-Shtrikman limits (zeta2 = eta2 = 0 and 1) exact
    Mutant("m-mpt-theta-eta", M + "effective.py",
           "th_num = 3 * ge * (6 * kz + 7 * gz) - 5 * gz * gz", "th_num = 3 * ge * (6 * kz + 7 * gz) - 5 * gz * ge",
           T_MPT, "wrong average (Theta, eta for zeta)"),
    Mutant("m-mpt-xi-eta", M + "effective.py",
           "128 / k2 + 99 / g2) + 45 * ig_e", "128 / k2 + 99 / g2) + 45 * ig_z",
           T_MPT, "wrong average (Xi, zeta for eta)"),
    # the variational oracle of those closed forms (mechanics/_threepoint_bounds.py)
    Mutant("m-3ptb-i4", M + "_threepoint_bounds.py",
           "i4 = 7.0 * phi1 * phi2 * (eta2 - 5.0 * zeta2 / 21.0) / 150.0",
           "i4 = 7.0 * phi1 * phi2 * (eta2 - 5.0 * zeta2 / 7.0) / 150.0",
           ("tests/test_mechanics_threepoint_bounds.py",), "wrong coefficient (I4 of the oracle)"),
    # PARDISO inertia: pypardiso's get_iparm is 1-based, iparm(22) the positive pivots
    Mutant("m-el-pardiso-inertia", M + "_elastic_solvers.py",
           "self.negative = int(self._s.get_iparm(23))", "self.negative = int(self._s.get_iparm(22))",
           T_EL, "off-by-one (iparm index of the inertia)"),
    # 3D deposition: the envelope-level lower bound that orders and stops the searches
    Mutant("k-dep3-level-bound", K + "deposit3d.py",
           "lbl = work_f[s, 6 + lev] + (r - rho[lev]) - lmargin", "lbl = work_f[s, 6 + lev] + (r - rmin) - lmargin",
           ("tests/test_deposit3d.py::test_pruned_search_equals_the_exhaustive_search",) + T_DEP3,
           "wrong reference radius (pruning bound)"),
    # elastic_tensor near floppiness (landed 2 Dec, second round): soft modes need the Krylov path,
    # the moduli are bond energies of the relaxed fields
    Mutant("m-el-soft-mode-projected", M + "_elastic_solvers.py",
           "zero = np.all(carried <= 1e-12 * e_now[None, :], axis=1) & (ritz <= 1e-9 * scale)",
           "zero = ritz <= 1e-9 * scale",
           ("tests/test_dem_static.py",) + T_EL, "missing condition (soft, loaded modes projected out of the fields)"),
    Mutant("k-gram-shear-half", K + "network.py",
           "d[pp, a] += 0.5 * branch[c, rr]", "d[pp, a] += branch[c, rr]",
           ("tests/test_dem_static.py",) + T_EL, "dropped factor (engineering shear in the relaxed energy)"),
    Mutant("m-el-cg-best-energy", M + "_elastic_solvers.py",
           "better = (e_now < best_e - slack) | ((e_now <= best_e + slack) & (res < best_xr))",
           "better = res < best_xr",
           ("tests/test_dem_static.py",) + T_EL, "wrong criterion (best iterate by residual, not energy)"),
    # lubricated Brownian dynamics (landed 2 Dec): only the Ito drift (div M) sees dbeta/du
    Mutant("k-lub-dbeta", K + "bd.py",
           "db = -(54.0 * uu * uu + 24.0 * uu + 8.0) / (den * den)", "db = -(54.0 * uu * uu + 24.0 * uu + 4.0) / (den * den)",
           ("tests/test_brownian_lubrication.py",), "wrong coefficient (derivative of the Honig factor)"),
    Mutant("k-lub-taper-slope", K + "bd.py",
           "dsfac = -6.0 * t * (1.0 - t) * 2.0 / uc", "dsfac = -6.0 * t * (1.0 - t) / uc",
           ("tests/test_brownian_lubrication.py",), "dropped factor (chain rule of the taper)"),
    # BD Verlet list built in place (issue 32, 5 Dec): cell wrap, fully scanned axes, bonded flags by mark
    Mutant("k-bd-cell-wrap", K + "cells.py",
           "    elif x >= ncell:\n        x -= ncell\n", "    elif x > ncell:\n        x -= ncell\n",
           ("tests/test_bd_kernel.py",), "off-by-one (periodic wrap of the cell index)"),
    Mutant("k-bd-reach-full", K + "cells.py",
           "    if 2 * r + 1 >= ncell:\n        return 0, ncell - 1, True\n",
           "    if 2 * r + 1 > ncell + 1:\n        return 0, ncell - 1, True\n",
           ("tests/test_bd_kernel.py",), "off-by-one (an axis of 2r cells scanned by offsets: a cell visited twice, "
                                         "its pairs listed twice)"),
    Mutant("k-bd-flag-mark", K + "bd.py",
           "        if mark[pj[k]] == i:\n", "        if mark[pj[k]] >= 0:\n",
           ("tests/test_bd_kernel.py",), "wrong condition (partners of earlier spheres flagged as bonded)"),
    # branch-free projection correction and movement tally (issue 32, 5 Dec)
    Mutant("k-bd-proj-tether-sign", K + "bd.py",
           "corr = max(2.0 - r, 0.0) + min(cap_lim - r, 0.0)", "corr = max(2.0 - r, 0.0) - min(cap_lim - r, 0.0)",
           ("tests/test_bd_kernel.py",) + T_BD, "wrong sign (stretched bonds pushed further apart)"),
    Mutant("k-bd-proj-tally-j", K + "bd.py",
           "tally = max(tally, max(moved[i], moved[j]))", "tally = max(tally, moved[i])",
           ("tests/test_bd_kernel.py",), "dropped term (second sphere's movement not in the tally: unsafe skips)"),
    Mutant("k-bd-verlet-keep", K + "bd.py",
           "                        m += dx * dx + dy * dy + dz * dz <= lim2\n",
           "                        m += dx * dx + dy * dy + dz * dz < lim2 * 0.99\n",
           ("tests/test_bd_kernel.py",), "wrong bound (pairs near the list reach dropped)"),
    Mutant("k-bd-rot-orient", K + "bd.py",
           "                orient[i, 1] = r10 * x + r11 * y + r12 * z\n",
           "                orient[i, 1] = r01 * x + r11 * y + r12 * z\n",
           ("tests/test_brownian_tangential.py",), "wrong index (body axis rotated by the transpose's row)"),
    Mutant("k-bd-verlet-order", K + "bd.py",
           "            while b >= m0 and pj[b] > v:\n", "            while b > m0 and pj[b] > v:\n",
           ("tests/test_bd_kernel.py",), "off-by-one (a sphere's first pair never sorted: order by cells again)"),
    Mutant("g-bd-default-skin", G + "brownian.py",
           "skin = max(0.4, min(30.0 * rms / a, 0.5 * bx.min() / a - rc))",
           "skin = max(0.4, 30.0 * rms / a)",
           ("tests/test_bd_kernel.py", "tests/test_brownian.py"), "dropped bound (skin beyond the half box)"),
    # reversible tangential gels (issue 32, fifth pass): the rolling yield of the model the test pins
    Mutant("g-bd-rolling-moment-scale", G + "brownian.py",
           "m = mc / kT / kr if kr > 0 else math.inf",
           "m = 0.1 * mc / kT / kr if kr > 0 else math.inf",
           ("tests/test_brownian_escape.py::test_reversible_tangential_gel_coarsens_at_15_mV_within_the_coordination_band",),
           "wrong scale (rolling yields at a tenth of the given moment: creeping rolling)"),
    # rolling_moment="dlvo" (issue 32, sixth pass): the pull-off force of the whole DLVO potential at contact
    Mutant("g-dlvo-adhesion-vdw-only", G + "dlvo.py",
           "return float(dv_vdw[0] + dv_el[0])", "return float(dv_vdw[0])",
           ("tests/test_dlvo.py::test_adhesion_force_is_the_contact_slope_of_the_potential",
            "tests/test_dlvo.py::test_adhesion_force_derjaguin_identities"),
           "dropped term (double layer left out of the pull-off force)"),
    Mutant("g-bd-dlvo-moment-ignores-psi", G + "brownian.py",
           "            f_adh = adhesion_force(p)\n",
           "            f_adh = p.hamaker * a / (12.0 * p.minimum_separation ** 2)\n",
           ("tests/test_brownian_tangential.py::test_dlvo_rolling_moment_follows_the_pull_off_force",),
           "wrong force (the van der Waals default in place of the DLVO pull-off force)"),
]

# drop-and-roll 3D deposition, the all-sphere cell grid, the surface rule's overhang fallback, the
# small-fraction profile (issue 35)
T_ROLL = ("tests/test_deposit_roll.py",)
MUTANTS += [
    Mutant("k-roll-pair-force-sign", K + "roll3d.py",
           "    fb = (u * w[2] / rho - ee) / d\n", "    fb = (u * w[2] / rho + ee) / d\n",
           T_ROLL, "wrong sign (contact force on the second sphere of a pair)"),
    Mutant("k-roll-query-box", K + "roll3d.py",
           "            lo[ax] = min(p0, p1) - sag - r * (1.0 + 1e-9)\n", "            lo[ax] = min(p0, p1) - sag\n",
           T_ROLL, "query box not dilated by the moving radius"),
    Mutant("k-roll-stable-three", K + "roll3d.py",
           "if _lambda3(n0, n1, n2, lam) and lam[0] >= -tol and lam[1] >= -tol and lam[2] >= -tol:",
           "if _lambda3(n0, n1, n2, lam) and lam[1] >= -tol and lam[2] >= -tol:",
           T_ROLL, "dropped check (force on the oldest contact of three)"),
    Mutant("k-grid-insert-half", K + "roll3d.py",
           "    x0, x1 = _axis_range(pos[k, 0] - R, pos[k, 0] + R, gd[2], nx, per)\n",
           "    x0, x1 = _axis_range(pos[k, 0], pos[k, 0] + R, gd[2], nx, per)\n",
           T_ROLL, "sphere registered in half its cells"),
    Mutant("k-dep3-fallback-alive-only", K + "deposit3d.py",
           "    if not strict:\n        gd, ghead, gnext", "    if False:\n        gd, ghead, gnext",
           ("tests/test_deposit_roll.py::test_surface_rule_at_large_size_ratios_places_no_sphere_into_the_bed",),
           "the old fallback (overlaps tested against the surface spheres only)"),
    Mutant("a-small-fraction-weights", "src/polypack/analysis/deposits.py",
           "vs[:, j] = np.bincount(col, weights=v * small, minlength=nb)",
           "vs[:, j] = np.bincount(col, weights=small * 1.0, minlength=nb)",
           ("tests/test_deposit_roll.py::test_small_fraction_profile_of_a_stratified_column",),
           "counts instead of volumes"),
]


# round 3 (issue 37): the weak areas of the property half, each caught by an oracle test
T_PO = ("tests/test_property_oracles.py",)
T_ROT = ("tests/test_dem_rotations.py",)
T_VI = ("tests/test_vem_internals.py",)
T_DPW = ("tests/test_deposit_periodic_window.py",)
T_WALK = ("tests/test_stage_option_walk.py",)
MUTANTS += [
    # fit and ensemble statistics
    Mutant("r3-fit-dof", A + "powerlaw.py", "    dof = a.size - 3\n", "    dof = a.size - 2\n",
           T_PO + ("tests/test_powerlaw.py",), "off-by-one (degrees of freedom of chi2/dof)"),
    Mutant("r3-fit-dof-refit", A + "powerlaw.py",
           "(keep.size - 3) if keep.size > 3", "(keep.size - 2) if keep.size > 3",
           T_PO + ("tests/test_powerlaw.py",), "off-by-one (degrees of freedom of the refit)"),
    Mutant("r3-report-t-dof", "src/polypack/report/build.py",
           "float(stdtrit(n - 1, 0.975))", "float(stdtrit(n, 0.975))",
           T_PO + ("tests/test_report.py",), "off-by-one (Student t of the report)"),
    # DLVO parameter conversions, BD adhesion
    Mutant("r3-dlvo-ionic-11", G + "dlvo.py",
           "ion = eps * BOLTZMANN * T / (2.0 * AVOGADRO", "ion = eps * BOLTZMANN * T / (AVOGADRO",
           T_PO + T_BD, "dropped factor (1:1 electrolyte, Debye length -> ionic strength)"),
    Mutant("r3-dlvo-kappa-11", G + "dlvo.py",
           "kappa2 = 2.0 * AVOGADRO", "kappa2 = AVOGADRO",
           T_PO + T_BD, "dropped factor (1:1 electrolyte, ionic strength -> Debye length)"),
    Mutant("r3-dlvo-stokes", G + "dlvo.py",
           "return self.kT / (6.0 * math.pi * self.viscosity * self.radius)",
           "return self.kT / (4.0 * math.pi * self.viscosity * self.radius)",
           T_PO + T_BD, "wrong coefficient (Stokes drag)"),
    Mutant("r3-bd-adhesion-plane", G + "brownian.py",
           "f_adh = p.hamaker * a / (12.0 * p.minimum_separation ** 2)",
           "f_adh = p.hamaker * a / (6.0 * p.minimum_separation ** 2)",
           T_PO + ("tests/test_brownian_tangential.py",), "sphere-plane for sphere-sphere (Derjaguin)"),
    # options dropped inside study stages
    Mutant("r3-stage-shear-friction", M + "stages.py",
           '"safety", "mass_scale", "damping", "friction", "density"', '"safety", "mass_scale", "damping", "density"',
           T_WALK + T_ST, "option dropped ([analysis.shear] friction)"),
    Mutant("r3-stage-shear-strength", M + "stages.py",
           'for k in ("normal_strength", "shear_strength", "reference") if k in opts}',
           'for k in ("normal_strength", "reference") if k in opts}',
           T_WALK + T_ST, "option dropped (shear strength never reaches the network builder)"),
    Mutant("r3-stage-vem-key", G + "_capabilities.py",
           "return vem(sizes, seed=seed, progress=False, **pr)",
           "return vem(sizes, seed=seed, progress=False, **{k: x for k, x in pr.items() if k != \"structure_contacts\"})",
           T_WALK + ("tests/test_pipeline_options.py",), "option dropped ([protocol] structure_contacts of vem)"),
    Mutant("r3-stage-brownian-key", G + "protocols.py",
           "gel = brownian(int(np.asarray(sizes.radii).size), seed=seed, progress=False, **pr)",
           "gel = brownian(int(np.asarray(sizes.radii).size), seed=seed, progress=False, "
           "**{k: x for k, x in pr.items() if k != \"lubrication_range\"})",
           T_WALK + ("tests/test_stages_protocols.py",), "option dropped ([protocol] lubrication_range)"),
    # DEM rotations
    Mutant("r3-contact-twist-mean", K + "contacts.py",
           "            wn = 0.5 * ((omg[i, 0] + omg[j, 0]) * nx", "            wn = ((omg[i, 0] + omg[j, 0]) * nx",
           T_ROT + T_DEM, "factor 2 (mean spin of the pair)"),
    Mutant("r3-contact-twist-sign", K + "contacts.py",
           "            fx += wn * tx\n            fy += wn * ty\n            fz += wn * tz\n",
           "            fx -= wn * tx\n            fy -= wn * ty\n            fz -= wn * tz\n",
           T_ROT + T_DEM, "wrong sign (twist of the shear force)"),
    Mutant("r3-contact-tilt-magnitude", K + "contacts.py",
           "                sc = np.sqrt(f2 / g2)\n", "                sc = 1.0\n",
           T_ROT + T_DEM, "dropped step (magnitude of the rotated shear force)"),
    Mutant("r3-dem-inertia", M + "_dem_system.py",
           "return mass, 0.4 * mass * radii**2", "return mass, 2.0 / 3.0 * mass * radii**2",
           T_ROT + T_DEM, "wrong coefficient (moment of inertia: shell for solid sphere)"),
    Mutant("r3-dem-rot-mass", K + "dem.py",
           "wn = w + (tq + td) * dt / ii", "wn = w + (tq + td) * dt / mi",
           T_ROT + T_DEM, "mass for moment of inertia"),
    Mutant("r3-dem-damp-flow-spin", K + "dem.py",
           "                    wr = w - spin\n", "                    wr = w\n",
           T_ROT + T_DEM, "damps the flow's own spin (Lees-Edwards)"),
    Mutant("r3-dem-flow-spin-sense", K + "dem.py",
           "sgn = 1.0 if (g - a) % 3 == 2 else -1.0", "sgn = 1.0 if (g - a) % 3 == 1 else -1.0",
           T_ROT + T_DEM, "wrong sign (sense of the flow's spin)"),
    Mutant("r3-crit-rot-inertia", M + "_dem_stiffness.py",
           "minv.reshape(-1, 6)[:, 3:] = 1.0 / np.sqrt(inertia)[:, None]",
           "minv.reshape(-1, 6)[:, 3:] = 1.0 / np.sqrt(mass)[:, None]",
           T_ROT + T_DST, "mass for moment of inertia (critical step)"),
    # VEM internals
    Mutant("r3-vem-ratio-half", G + "vem.py",
           "return fu / (2.0 * fc) if fc > 0 else 0.0", "return fu / fc if fc > 0 else 0.0",
           T_VI + T_VEM + ("tests/test_vem_adhesive.py",), "factor 2 (unbalanced-force ratio)"),
    Mutant("r3-vem-projection-full", K + "vem.py",
           "corr = 0.5 * (lim - d) / d", "corr = (lim - d) / d",
           T_VI + T_VEM, "factor 2 (overlap-removal projection)"),
    # deposit statistics, one periodic side axis
    Mutant("r3-dep3-swap-box", A + "deposits.py",
           "            box[[0, 1]] = box[[1, 0]]\n", "",
           T_DPW + T_DEP3, "dropped swap (box of a y-periodic deposit)"),
    Mutant("r3-dep3-periodic-margin", A + "deposits.py",
           "lo = np.array([0.0 if per[0] else margin, 0.0 if per[1] else margin, margin])",
           "lo = np.array([margin, 0.0 if per[1] else margin, margin])",
           T_DPW + T_DEP3, "margin on a periodic axis"),
    Mutant("r3-dep3-images", A + "deposits.py",
           "float(box[0]), bool(per[0]))", "float(box[0]), False)",
           T_DPW + T_DEP3, "periodic images ignored"),
    Mutant("r3-dep3-window-order", A + "deposits.py",
           "            window = window[[2, 3, 0, 1, 4, 5]]\n", "            pass\n",
           T_DPW + T_DEP3, "window reported in the swapped axis order (y-periodic)"),
]


# issue 31: rigidity as an answer (floppy networks, unconverged shear tests, NaN-free records)
MUTANTS += [
    Mutant("m31-floppy-never", M + "elastic.py",
           "    soft = lam < tol * ref\n", "    soft = lam < 0.0 * ref\n",
           T_EL, "dropped check (round-off moduli of a floppy network reported as numbers)"),
    Mutant("m31-untouched-rows", M + "elastic.py",
           "self.untouched = (np.asarray(self.h.diagonal()) <= 0.0) & keep",
           "self.untouched = (np.asarray(self.h.diagonal()) < 0.0) & keep",
           T_EL, "off-by-one (empty rows of H left in the factorization)"),
    Mutant("m31-static-excess", M + "_dem_record.py",
           "if static and gmean > (1.0 + STATIC_EXCESS_LIMIT) * static:",
           "if static and gmean > (2.0 + STATIC_EXCESS_LIMIT) * static:",
           T_DEM, "wrong bound (an inertia-stiffened G' accepted)"),
    Mutant("m31-record-nan", "src/polypack/ensemble/runner.py",
           "        return float(v) if math.isfinite(v) else None\n",
           "        return float(v)\n",
           T_ST, "dropped check (NaN written to a record)"),
    Mutant("m31-pores-survival-all-points", A + "pores.py",
           '        nv = max(sum(f["void"].size for f in self._frames), 1)\n        return np.sqrt(s * (1 - s) / nv)\n',
           '        nv = max(sum(f["n"] for f in self._frames), 1)\n        return np.sqrt(s * (1 - s) / nv)\n',
           (T_EB, "tests/test_analysis_pores.py"), "wrong count (all test points for the void points)"),
    Mutant("m31-check-shear-protocol", M + "stages.py",
           "    _prefixed(path, check_protocol, **kw)\n", "    pass\n",
           ("tests/test_check_complete.py",), "dropped check (shear protocol options only checked at run time)"),
    Mutant("m31-check-vem-dim", G + "protocols.py",
           '    _need_3d(info, path, "vem")\n', "    pass\n",
           ("tests/test_check_complete.py",), "dropped check (a 2D size set made into 3D VEM structures)"),
    Mutant("m31-convert-drops-bonds", "src/polypack/_cli/io_commands.py",
           "        if net is not None and not drop_bonds:\n", "        if net is not None and drop_bonds:\n",
           ("tests/test_network_files.py",), "inverted condition (convert drops the bonds of a network)"),
    Mutant("m31-writes-onto-input", "src/polypack/_util.py",
           "        if src is not None and _same_file(path, src):\n", "        if False:\n",
           ("tests/test_network_files.py",), "dropped check (a command writes onto its own input)"),
]

# rigidity of the bonded network (issue 36): floppy space, rigid clusters, backbone, fabric
T_RIG = ("tests/test_mechanics_rigidity.py",)
MUTANTS += [
    Mutant("m-rig-translation-not-rotation", M + "rigidity_analysis.py",
           "dw = zz[:, bj, 3:] - zz[:, bi, 3:]", "dw = zz[:, bj, :3] - zz[:, bi, :3]",
           T_RIG, "wrong components (rigid bond = equal rotations)"),
    Mutant("m-rig-constraints-per-bond", M + "rigidity_analysis.py",
           "cons = 1 if central else 3", "cons = 1 if central else 2",
           T_RIG, "wrong count (constraints of a contact bond)"),
    Mutant("m-rig-backbone-z-factor", M + "rigidity_analysis.py",
           "bb_z = 2.0 * float(union.sum()) / max(int(bb_part.sum()), 1)",
           "bb_z = float(union.sum()) / max(int(bb_part.sum()), 1)",
           T_RIG, "dropped factor 2 (coordination)"),
    Mutant("m-rig-nonaffinity-modes", M + "rigidity_analysis.py",
           "gam = float(gam_m[3:].mean())", "gam = float(gam_m[:3].mean())",
           T_RIG, "wrong slice (axial instead of shear strains)"),
    Mutant("m-rig-percolation-any-axis", M + "rigidity_analysis.py",
           "perc = bool(sp_c.all(axis=1).any()) if sp_c.size else False",
           "perc = bool(sp_c.any(axis=1).any()) if sp_c.size else False",
           T_RIG, "wrong quantifier (one axis instead of every axis)"),
    Mutant("m-el-null-samples-no-metric", M + "_elastic_solvers.py",
           "        z = shift * solve(dd[:, None] * z)\n", "        z = shift * solve(z)\n",
           T_RIG, "missing factor (D in the inverse iteration: participation off)"),
    Mutant("m-el-null-samples-no-sweep", M + "_elastic_solvers.py",
           "    for _ in range(sweeps):\n        z = shift", "    for _ in range(0):\n        z = shift",
           T_RIG, "off-by-all (no inverse iteration: samples not in the null space)"),
    Mutant("k-rig-hinge-merge", K + "rigidity.py",
           "if np.sqrt(dd) * lbar > tol * amp[s]:", "if np.sqrt(dd) * lbar > 1e30 * amp[s]:",
           T_RIG, "missing condition (triangles sharing a bond merged without equal rotations)"),
    Mutant("k-rig-triangle-test", K + "rigidity.py",
           "if abs(dot) / dik > tol * amp[s]:", "if abs(dot) / dik > 1e30 * amp[s]:",
           T_RIG, "missing condition (every triangle rigid)"),
    Mutant("m-rig-no-force-floor", M + "rigidity_analysis.py",
           "_FORCE_FLOOR = 1e-4\n", "_FORCE_FLOOR = 0.0\n",
           T_RIG, "missing floor (round-off forces of a floppy strain counted as load)"),
    Mutant("k-rig-unwrap-sign", K + "rigidity.py",
           "img[q, d] = img[p, d] + sign[e] * shift[c, d]", "img[q, d] = img[p, d] - sign[e] * shift[c, d]",
           T_RIG, "wrong sign (periodic image)"),
]


# issue 34: voxel images and full-field FFT homogenization
T_HOM = ("tests/test_homogenize.py",)
T_VOX = ("tests/test_io_voxel.py",)
T_HST = ("tests/test_stages_homogenize.py",)
T_H32 = ("tests/test_stiffness_semantics.py",)
F = "src/polypack/mechanics/fullfield.py"
MUTANTS += [
    Mutant("h34-green-c0", F,
           "c0 = (lam0 + mu0) / (mu0 * (lam0 + 2.0 * mu0))", "c0 = (lam0 + mu0) / (mu0 * (lam0 + mu0))",
           T_HOM, "wrong formula (Green operator of the reference medium)"),
    Mutant("h34-engineering-shear", F,
           "e[m] = 1.0 if m < 3 else 0.5  # engineering shear gamma = 1", "e[m] = 1.0",
           T_HOM, "wrong convention (tensor shear strain loaded as engineering: C44 doubled)"),
    Mutant("h34-willot-symbol", F,
           "k = (2.0 / spacing[a]) * np.sin(th / 2.0)", "k = (2.0 / spacing[a]) * np.sin(th)",
           T_HOM, "wrong formula (discrete Green operator symbol)"),
    Mutant("h34-cg-sign", F,
           "        x += alpha * p\n", "        x -= alpha * p\n",
           T_HOM, "wrong sign (CG update)"),
    Mutant("h34-cg-beta", F,
           "        p *= rr_new / rr\n", "        p *= rr / rr_new\n",
           T_HOM, "swapped ratio (CG direction update)"),
    # (the C0 inner product's off-diagonal weight 2 -> 1 survives: CG then works in another norm and
    # reaches the same solution in as many iterations, an equivalent mutant for the results)
    Mutant("h34-stiffness-trace", F,
           "        out[2] += lt\n", "",
           T_HOM, "dropped term (lambda tr(eps) missing from sigma_33)"),
    Mutant("h34-richardson", F,
           "val = f[-1] + (f[-1] - f[-2]) / (r ** p - 1.0)", "val = f[-1] + (f[-1] - f[-2]) / (r ** p + 1.0)",
           T_HOM, "wrong sign (Richardson extrapolation)"),
    Mutant("h34-voxel-centre", K + "voxel.py",
           "            dx = (i + 0.5) * hx - cx\n", "            dx = i * hx - cx\n",
           T_VOX + T_HOM, "off-by-half (voxel corner for its centre)"),
    Mutant("h34-voxel-wrap", K + "voxel.py",
           "            if ii < 0 or ii >= nx:\n                if periodic[0] == 0:",
           "            if ii < 0 or ii >= nx:\n                if periodic[0] == 1:",
           T_VOX + T_HOM, "inverted check (periodic images dropped along x)"),
    Mutant("h34-subvoxel-inside", K + "voxel.py",
           "                    if d + half_diag <= r:", "                    if d <= r:",
           T_VOX, "wrong bound (boundary voxels counted full)"),
    Mutant("h34-exact-species", "src/polypack/io/voxel.py",
           "ball_volume(packing.radii[packing.species == s], dim)", "ball_volume(packing.radii, dim)",
           T_VOX, "wrong selection (every sphere counted for each species)"),
    Mutant("h34-vti-order", "src/polypack/io/voxel.py",
           '_b64(lab.reshape(n).ravel(order="F"))', "_b64(lab.reshape(n).ravel())",
           T_VOX, "wrong memory order (VTK wants x fastest)"),
    Mutant("h34-composite-voigt", F,
           "    return k0 + phi * d * dim * k0 / (dim * k0 + (1.0 - phi) * d)\n", "    return k0 + phi * d\n",
           T_HOM, "wrong formula (Voigt mean for the coated composite-voxel rule)"),
    # (zeta(K0, G0) -> 4 G0 / 3 in the shear rule survives: 7 % on the reference of the boundary voxels only)
    Mutant("h34-composite-fraction", F,
           "g = m.shear + phi * dg / (1.0 + (1.0 - phi) * dg / (m.shear + z))",
           "g = m.shear + phi * dg / (1.0 + phi * dg / (m.shear + z))",
           T_HOM, "wrong fraction (matrix fraction for the inclusion's in the coated rule)"),
    Mutant("h34-stage-unconverged", M + "stages.py",
           "    if not r.converged:\n        return out\n", "    if False:\n        return out\n",
           T_HST, "dropped check (moduli of an unconverged solve recorded)"),
    Mutant("h34-stage-ratio", M + "stages.py",
           "young_ratio=r.young / matrix.young", "young_ratio=r.young / matrix.shear",
           T_HST, "wrong reference (E*/E0 over the shear modulus)"),
    # issue 32: stiffness semantics ("contact" | "particle": per-ball values in series per contact)
    Mutant("h32-particle-scalar", M + "network.py", "        return 0.5 * k\n", "        return k\n",
           T_H32, "dropped factor (a per-ball scalar used as the contact spring)"),
    Mutant("h32-series-mean", M + "network.py",
           "return k[:, None] * k[None, :] / (k[:, None] + k[None, :])",
           "return 0.5 * (k[:, None] + k[None, :])",
           T_H32, "wrong formula (arithmetic mean of the two balls instead of the series value)"),
    Mutant("h32-stage-drop", M + "stages.py",
           'stiffness=opts.get("stiffness", "contact"), **strengths)', 'stiffness="contact", **strengths)',
           T_H32, "dropped option (the stages' stiffness never reaches the network)"),
    Mutant("h32-vem-void-void", "src/polypack/generate/vem.py",
           "np.where(voids, self.knvv, self.knv)", "np.where(voids, self.knv, self.knv)",
           T_H32, "wrong pair (void-void contacts get the structure-void spring)"),
    Mutant("h32-vem-option", "src/polypack/generate/vem.py",
           '    if o["stiffness"] == "particle":\n', "    if False:\n",
           T_H32, "dropped option (VEM ignores stiffness = \"particle\")"),
    Mutant("h32-cli-elastic", "src/polypack/_cli/elastic_commands.py",
           'o["radius"], o.get("stiffness", "contact")', 'o["radius"], "contact"',
           T_H32, "dropped option (polypack elastic --stiffness ignored)"),
    Mutant("h32-cli-export", "src/polypack/_cli/network_commands.py",
           'stiffness=options.get("stiffness", "contact"))', 'stiffness="contact")',
           T_H32, "dropped option (polypack export-network --stiffness ignored: per-ball values exported)"),
    Mutant("h32-report-semantics", "src/polypack/studies/seed003_heterogeneity.py",
           '        return elastic.get("stiffness", "contact")\n', '        return "contact"\n',
           T_H32, "wrong record (the report's own tensor always said per contact)"),
]

def _kernel_digest(src: Path) -> str:
    h = hashlib.sha1()
    for p in sorted((src / "polypack" / "_kernels").glob("*.py")):
        h.update(p.name.encode() + p.read_bytes())
    return h.hexdigest()[:12]


def _kernel_dependents(kernels: Path, stem: str) -> set:
    """``stem`` and every kernel module that imports it, directly or through another one."""
    imports = {}
    for p in kernels.glob("*.py"):
        text = p.read_text()
        imports[p.stem] = {q.stem for q in kernels.glob("*.py")
                           if f"from .{q.stem} import" in text or f"from . import {q.stem}" in text}
    out, grew = {stem}, True
    while grew:
        new = {m for m, deps in imports.items() if deps & out} - out
        out |= new
        grew = bool(new)
    return out


def _seed_cache(clean: Path, dest: Path, stems: set):
    """Hard-link copy of the warm cache ``clean`` without the entries of modules ``stems``."""
    shutil.rmtree(dest, ignore_errors=True)
    if not clean.is_dir():
        return
    for sub in clean.iterdir():
        if not sub.is_dir():
            continue
        (dest / sub.name).mkdir(parents=True, exist_ok=True)
        for f in sub.iterdir():
            if f.name.split(".", 1)[0] in stems:
                continue
            try:
                os.link(f, dest / sub.name / f.name)  # numba replaces files, never writes in place
            except OSError:
                shutil.copy2(f, dest / sub.name / f.name)


def _user_cache(src: Path) -> Path:
    """The numba cache folder that ``import polypack`` uses for the kernels under ``src``."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        base = Path(os.environ["NUMBA_CACHE_DIR"])
    else:
        xdg = os.environ.get("XDG_CACHE_HOME", os.path.join(os.path.expanduser("~"), ".cache"))
        base = Path(xdg) / "polypack" / "numba" / _kernel_digest(src)
    kernels = str((src / "polypack" / "_kernels").resolve())
    return base / ("_kernels_" + hashlib.sha1(kernels.encode()).hexdigest())


def _seed_from_user_cache(tree: Path, clean: Path):
    """Hard-link the repository's own warm cache into the copy's clean cache.

    numba names a cache subfolder after the source folder's path and checks each
    file's mtime and size, which the copy keeps: a suite run in the repository
    (e.g. by the landing script) makes every kernel of the copy start warm.
    Returns the number of files linked.
    """
    src = _user_cache(ROOT / "src")
    if not src.is_dir():
        return 0
    kernels = str((tree / "src" / "polypack" / "_kernels").resolve())
    dest = clean / ("_kernels_" + hashlib.sha1(kernels.encode()).hexdigest())
    dest.mkdir(parents=True, exist_ok=True)
    k = 0
    for f in src.iterdir():
        if not (dest / f.name).exists():
            try:
                os.link(f, dest / f.name)
            except OSError:
                shutil.copy2(f, dest / f.name)
            k += 1
    return k


def _copy_tree(dest: Path):
    if dest.exists():
        shutil.rmtree(dest)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", ".git", "*.egg-info", ".pytest_cache")
    for name in ("src", "tests", "examples", "docs", "pyproject.toml"):  # docs: tests check generated pages
        s = ROOT / name
        if s.is_dir():
            shutil.copytree(s, dest / name, ignore=ignore)  # copy2: keeps mtimes
        elif s.exists():
            shutil.copy2(s, dest / name)


def _children_cpu():
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def _run_tests(tree: Path, tests, timeout, cache_base: Path):
    """Run ``tests`` on ``tree``: ``(status, wall seconds, last line, CPU seconds)``."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(tree / "src")
    env["NUMBA_CACHE_DIR"] = str(cache_base / _kernel_digest(tree / "src"))
    env["MPLBACKEND"] = "Agg"
    env.setdefault("PYTHONDONTWRITEBYTECODE", "1")
    tests = [t for t in tests if (tree / t.split("::")[0]).exists()]
    if not tests:
        return "no-tests", 0.0, "none of the listed test files exists", 0.0
    # the pytest temporary folder inside the workdir: shards running side by side never
    # share (or clean up) each other's folders
    basetemp = cache_base.parent / "pytest-tmp"
    cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", "-m", "",
           f"--basetemp={basetemp}", *tests]
    t0, c0 = time.perf_counter(), _children_cpu()
    try:
        pr = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return "timeout", time.perf_counter() - t0, "", _children_cpu() - c0
    dt, cpu = time.perf_counter() - t0, _children_cpu() - c0
    out = pr.stdout.strip().splitlines()
    failed = next((ln for ln in out if ln.startswith(("FAILED", "ERROR"))), out[-1] if out else "")
    if pr.returncode == 0:
        return "passed", dt, out[-1] if out else "", cpu
    if pr.returncode == 1:
        return "failed", dt, failed, cpu
    return f"error{pr.returncode}", dt, failed or (pr.stderr.strip().splitlines() or [""])[-1], cpu


def _write_json(path, rows, meta):
    ran = [r for r in rows if r[1] in ("caught", "SURVIVED")]
    caught = sum(r[1] == "caught" for r in ran)
    data = [{"id": m.id, "path": m.path, "kind": m.kind, "result": v, "seconds": round(dt, 1),
             "cpu_seconds": round(cpu, 1), "detail": d} for m, v, dt, d, cpu in rows]
    meta = dict(meta, finished=time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()),
                load_average_end=[round(x, 2) for x in os.getloadavg()])
    tmp = Path(str(path) + ".tmp")
    tmp.write_text(json.dumps({"caught": caught, "ran": len(ran), "run": meta, "mutants": data}, indent=1))
    os.replace(tmp, path)


def _caught_by(detail):
    """The test node of a ``FAILED tests/x.py::name - message`` line (or the line itself)."""
    if detail.startswith(("FAILED ", "ERROR ")):
        return detail.split(" ", 1)[1].split(" - ", 1)[0]
    return detail


def write_markdown(json_paths, out):
    """Merge result files (later ones win per mutant) into a markdown table in list order."""
    res = {}
    for p in json_paths:
        for r in json.loads(Path(p).read_text())["mutants"]:
            res[r["id"]] = r
    lines = ["| # | mutant | file | kind | result | s (wall / CPU) | caught by (first failing test) |",
             "|---|---|---|---|---|---|---|"]
    wall = cpu = 0.0
    for k, m in enumerate(MUTANTS, 1):
        r = res.get(m.id)
        if r is None:
            lines.append(f"| {k} | `{m.id}` | `{m.path}` | {m.kind} | not run | | |")
            continue
        wall += r["seconds"]
        cpu += r.get("cpu_seconds", 0.0)
        t = f"{r['seconds']:.0f} / {r['cpu_seconds']:.0f}" if "cpu_seconds" in r else f"{r['seconds']:.0f}"
        by = _caught_by(r["detail"]) if r["result"] == "caught" else ""
        lines.append(f"| {k} | `{m.id}` | `{m.path}` | {m.kind} | {r['result']} | {t} | " + (f"`{by}` |" if by else "|"))
    ran = [r for r in res.values() if r["result"] in ("caught", "SURVIVED")]
    caught = sum(r["result"] == "caught" for r in ran)
    missing = sum(m.id not in res for m in MUTANTS)
    lines.append("")
    lines.append(f"Caught {caught} of {len(ran)} mutants run ({len(MUTANTS)} in the list"
                 + (f", {missing} not run" if missing else "") + f"); the mutants' tests, summed: {wall / 60:.0f} min wall, "
                 f"{cpu / 60:.0f} min CPU in total.")
    Path(out).write_text("\n".join(lines) + "\n")
    return caught, len(ran)


def check(mutants, root=ROOT):
    """Problems of the list against the tree ``root``: one line per mutant that would not run as meant.

    A mutant must find its text exactly once (else it is stale), the mutated file must still
    compile (a syntax error is "caught" by any test, which says nothing) and every test file
    and test function it names must exist.
    """
    problems = []
    for m in mutants:
        target = root / m.path
        if not target.exists():
            problems.append(f"{m.id}: {m.path} does not exist")
            continue
        text = target.read_text()
        hits = text.count(m.find)
        if hits != 1:
            problems.append(f"{m.id}: target text found {hits} times in {m.path}")
            continue
        if m.find == m.replace:
            problems.append(f"{m.id}: the replacement equals the target")
        try:
            compile(text.replace(m.find, m.replace), str(target), "exec")
        except SyntaxError as exc:
            problems.append(f"{m.id}: the mutated {m.path} does not compile ({exc.msg}, line {exc.lineno})")
        for t in m.tests:
            f, _, node = t.partition("::")
            if not (root / f).exists():
                problems.append(f"{m.id}: test file {f} does not exist")
            elif node and f"def {node.split('[')[0]}(" not in (root / f).read_text():
                problems.append(f"{m.id}: test {t} does not exist")
    return problems


def _shard(text):
    try:
        k, n = (int(v) for v in text.split("/"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--shard {text!r}: give k/n with 1 <= k <= n, e.g. 1/2") from None
    if not 1 <= k <= n:
        raise argparse.ArgumentTypeError(f"--shard {text!r}: give k/n with 1 <= k <= n, e.g. 1/2")
    return k, n


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="*", help="mutant ids to run")
    ap.add_argument("--list", action="store_true", help="print the mutant list and exit")
    ap.add_argument("--check", action="store_true",
                    help="check that every selected mutant applies exactly once and compiles, and exit")
    ap.add_argument("--shard", type=_shard, metavar="K/N",
                    help="run every N-th selected mutant from the K-th (list order; shards run side by side "
                         "with different --workdir)")
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds per mutant (default 600)")
    ap.add_argument("--json", help="write the results to this file")
    ap.add_argument("--workdir", help="where the copy lives (default: a fixed folder in the temp dir)")
    ap.add_argument("--no-baseline", action="store_true", help="skip the unmutated run of all selected tests")
    ap.add_argument("--markdown", nargs="+", metavar=("OUT", "JSON"),
                    help="write the table of results OUT from result files JSON... (later ones win) and exit")
    args = ap.parse_args(argv)
    if args.markdown:
        if len(args.markdown) < 2:
            ap.error("--markdown needs OUT and at least one JSON result file")
        caught, ran = write_markdown(args.markdown[1:], args.markdown[0])
        print(f"{args.markdown[0]}: caught {caught} of {ran}")
        return 0

    mutants = MUTANTS if not args.only else [m for m in MUTANTS if m.id in set(args.only)]
    if args.only and len(mutants) != len(set(args.only)):
        unknown = set(args.only) - {m.id for m in mutants}
        ap.error(f"unknown mutant id(s): {sorted(unknown)}")
    if args.shard:
        k, n = args.shard
        mutants = mutants[k - 1::n]
    if args.check:
        problems = check(mutants)
        for line in problems:
            print(line)
        print(f"{len(mutants) - len({p.split(':', 1)[0] for p in problems})} of {len(mutants)} mutants apply")
        return 1 if problems else 0
    if args.list:
        for m in mutants:
            print(f"{m.id:26s} {m.kind:34s} {m.path}")
        return 0

    work = Path(args.workdir or Path(tempfile.gettempdir()) / f"polypack-mutate-{os.getuid()}")
    meta = {"started": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()),
            "load_average_start": [round(x, 2) for x in os.getloadavg()],
            "argv": sys.argv[1:] if argv is None else list(argv), "workdir": str(work), "timeout": args.timeout}
    tree = work / "tree"
    cache_base = work / "numba"
    _copy_tree(tree)
    clean_digest = _kernel_digest(tree / "src")

    seeded = _seed_from_user_cache(tree, cache_base / clean_digest)
    if seeded:
        print(f"numba cache: {seeded} files from the repository's own cache", flush=True)
    if not seeded and any(m.path.startswith(K) for m in mutants):
        # compile every kernel of the unmodified tree once (``polypack warmup``): the seed of
        # the per-mutant caches, so a kernel mutant recompiles only its own module(s); without a
        # kernel mutant the tests fill the clean cache as they go
        env = dict(os.environ, PYTHONPATH=str(tree / "src"), NUMBA_CACHE_DIR=str(cache_base / clean_digest))
        t0 = time.perf_counter()
        wr = subprocess.run([sys.executable, "-m", "polypack.cli", "warmup"], cwd=tree, env=env,
                            capture_output=True, text=True)
        print(f"kernels compiled in {time.perf_counter() - t0:.0f} s" if wr.returncode == 0
              else f"warmup failed: {(wr.stderr.strip().splitlines() or [''])[-1]}", flush=True)

    if not args.no_baseline:
        tests = sorted({t for m in mutants for t in m.tests})
        status, dt, line, _ = _run_tests(tree, tests, 4 * args.timeout, cache_base)
        print(f"baseline (no mutant): {status} in {dt:.0f} s  {line}")
        if status != "passed":
            print("the unmutated tree fails its tests: fix that first", file=sys.stderr)
            return 2

    rows = []
    for m in mutants:
        target = tree / m.path
        if not target.exists():
            rows.append((m, "stale", 0.0, f"{m.path} does not exist", 0.0))
            print(f"{m.id:26s} stale     (file gone)", flush=True)
            continue
        original = target.read_bytes()
        stat = target.stat()
        text = original.decode()
        hits = text.count(m.find)
        if hits != 1:
            rows.append((m, "stale", 0.0, f"target text found {hits} times", 0.0))
            print(f"{m.id:26s} stale     (target text found {hits} times)", flush=True)
            continue
        target.write_text(text.replace(m.find, m.replace))
        digest = _kernel_digest(tree / "src")
        if digest != clean_digest:
            kernels = tree / "src" / "polypack" / "_kernels"
            _seed_cache(cache_base / clean_digest, cache_base / digest, _kernel_dependents(kernels, target.stem))
        try:
            status, dt, line, cpu = _run_tests(tree, m.tests, args.timeout, cache_base)
        finally:
            target.write_bytes(original)
            os.utime(target, ns=(stat.st_atime_ns, stat.st_mtime_ns))
            if digest != clean_digest:
                shutil.rmtree(cache_base / digest, ignore_errors=True)
        verdict = {"passed": "SURVIVED", "no-tests": "no-tests", "timeout": "timeout"}.get(status, "caught")
        rows.append((m, verdict, dt, line if status != "timeout" else "timeout", cpu))
        print(f"{m.id:26s} {verdict:9s} {dt:6.0f} s {cpu:6.0f} cpu-s  {status:8s} {line[:90]}", flush=True)
        if args.json:  # after every mutant: an interrupted run keeps what it measured
            _write_json(args.json, rows, meta)

    ran = [r for r in rows if r[1] in ("caught", "SURVIVED")]
    caught = sum(r[1] == "caught" for r in ran)
    print()
    print(f"{'mutant':26s} {'kind':34s} {'result':9s} {'s':>5s} {'cpu-s':>6s}")
    for m, verdict, dt, _, cpu in rows:
        print(f"{m.id:26s} {m.kind:34s} {verdict:9s} {dt:5.0f} {cpu:6.0f}")
    stale = sum(r[1] == "stale" for r in rows)
    slow = sum(r[1] == "timeout" for r in rows)
    print(f"\ncaught {caught} of {len(ran)} mutants ({caught / max(len(ran), 1):.0%})"
          + (f"; {slow} timed out (rerun with a longer --timeout)" if slow else "")
          + (f"; {stale} stale (target text changed: update the list)" if stale else ""))
    if args.json:
        _write_json(args.json, rows, meta)
    return 0 if caught == len(ran) and not slow else 1


if __name__ == "__main__":
    sys.exit(main())
