#!/usr/bin/env python
"""An independent mutation check of the mechanics, BD, VEM, deposit and report modules (issue 37).

``tools/mutate.py`` holds the harness's own list; a suite tuned against one list can still miss
plausible bugs that list never tried.  This file is a *second* list of one-line mutants,
written for issue 37 from a reading of the modules (signs, factors 2, off-by-one, wrong index,
dropped term or option), each aimed at the test files a maintainer would expect to notice it.
It reuses mutate.py's machinery (tree copy, numba cache seeding, shards, JSON and markdown)
with this list in place of the harness's::

    nice python tools/mutants_independent.py --workdir /tmp/ind_a --shard 1/2 --no-baseline --json a.json &
    nice python tools/mutants_independent.py --workdir /tmp/ind_b --shard 2/2 --no-baseline --json b.json &
    wait; python tools/mutants_independent.py --markdown table.md a.json b.json
    python tools/mutants_independent.py --check     # every mutant applies once, compiles, names existing tests
    python tools/mutants_independent.py --overlap   # mutants whose target text a harness mutant also edits

Do not copy these into mutate.py when they are caught: the point of the list is that the
suite is measured on bugs nobody tuned it against.  A survivor gets a new test (that test's
mutant may then join the harness under its own name).  Results: tools/mutants_result.md.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import mutate  # noqa: E402
from mutate import Mutant  # noqa: E402

K = "src/polypack/_kernels/"
G = "src/polypack/generate/"
M = "src/polypack/mechanics/"
A = "src/polypack/analysis/"
R = "src/polypack/report/"
E = "src/polypack/ensemble/"

# tests/test_mutation_survivors.py holds the tests written for the survivors of the first run (it comes
# first: a mutant it catches stops there); the other files are those a maintainer would run
T_SURV = ("tests/test_mutation_survivors.py",)
T_BD = T_SURV + ("tests/test_brownian.py", "tests/test_bd_kernel.py", "tests/test_dlvo.py")
T_BDT = T_SURV + ("tests/test_brownian_tangential.py", "tests/test_brownian_rigid.py")
T_DEM = T_SURV + ("tests/test_dem_contacts.py", "tests/test_dem_rotations.py", "tests/test_dem.py", "tests/test_dem_static.py")
T_NET = T_SURV + ("tests/test_mechanics_network.py",)
T_EL = T_SURV + ("tests/test_mechanics_elastic.py",)
T_VEM = T_SURV + ("tests/test_vem_internals.py", "tests/test_vem.py")
T_DEP2 = T_SURV + ("tests/test_deposit.py",)
T_DEP3 = T_SURV + ("tests/test_deposit_periodic_window.py", "tests/test_deposit3d.py")
T_REP = T_SURV + ("tests/test_report.py", "tests/test_property_oracles.py")
T_ENS = T_SURV + ("tests/test_error_bars.py", "tests/test_ensemble.py", "tests/test_property_oracles.py")

INDEPENDENT = [
    # ------------------------------------------------------------------ Brownian dynamics, DLVO
    Mutant("i-bd-box-eq5", G + "brownian.py",
           "box_len = a * (4.0 * n * math.pi / (3.0 * phi)) ** (1.0 / 3.0)",
           "box_len = a * (3.0 * n * math.pi / (4.0 * phi)) ** (1.0 / 3.0)",
           T_BD + ("tests/test_stages_protocols.py",), "swapped constants (box of Eq. (5))"),
    Mutant("i-bd-default-step", G + "brownian.py",
           "time_step = (DEFAULT_STEP_FRACTION * lam) ** 2 / (2.0 * D0)",
           "time_step = (DEFAULT_STEP_FRACTION * lam) ** 2 / (6.0 * D0)",
           T_BD, "wrong factor (3D rms for per-coordinate rms)"),
    Mutant("i-bd-pair-force-z", K + "bd.py",
           "        force[j, 2] += fr * dz\n    return vir\n\n\n@njit(cache=True)\ndef _trap_forces",
           "        force[j, 2] -= fr * dz\n    return vir\n\n\n@njit(cache=True)\ndef _trap_forces",
           T_BD, "wrong sign (one component of the pair force)"),
    Mutant("i-bd-projection-full", K + "bd.py",
           "            s = 0.5 * corr / max(r, 1e-12)\n", "            s = corr / max(r, 1e-12)\n",
           T_BD, "factor 2 (bond projection moves both spheres)"),
    Mutant("i-bd-table-interp", K + "bd.py",
           "f = (1.0 - w) * table[q] + w * table[q + 1]", "f = w * table[q] + (1.0 - w) * table[q + 1]",
           T_BD, "swapped weights (linear interpolation)"),
    Mutant("i-bd-initial-gap", G + "brownian.py",
           "a_eff = a + 0.5 * min_gap", "a_eff = a + min_gap",
           T_BD, "factor 2 (initial gap)"),
    Mutant("i-bd-rot-friction", K + "bd.py",
           "SPHERE_ROT_FRICTION = 4.0 / 3.0", "SPHERE_ROT_FRICTION = 8.0 / 3.0",
           T_BDT + T_BD, "factor 2 (rotational friction 8 pi eta a^3 over 6 pi eta a^2)"),
    Mutant("i-dlvo-hhf-force", G + "dlvo.py",
           "dv_el = -pref * kappa / (np.exp(np.minimum(x, 700.0)) + 1.0)",
           "dv_el = -pref * kappa / (np.exp(np.minimum(x, 700.0)) - 1.0)",
           ("tests/test_dlvo.py", "tests/test_brownian.py"), "wrong sign (derivative of ln(1 + e^-x))"),
    Mutant("i-dlvo-vdw-log", G + "dlvo.py",
           "v_vdw = -(A / 6.0) * (2.0 * a2 / s2 + 2.0 * a2 / r2 + np.log(s2 / r2))",
           "v_vdw = -(A / 6.0) * (2.0 * a2 / s2 + 2.0 * a2 / r2 + np.log(r2 / s2))",
           ("tests/test_dlvo.py", "tests/test_property_oracles.py"), "inverted argument (Hamaker log term)"),
    Mutant("i-dlvo-lsa-tanh", G + "dlvo.py",
           "math.tanh(ELEMENTARY_CHARGE * psi / (4.0 * p.kT))", "math.tanh(ELEMENTARY_CHARGE * psi / (2.0 * p.kT))",
           ("tests/test_dlvo.py", "tests/test_property_oracles.py"), "factor 2 (reduced surface potential)"),
    # ------------------------------------------------------------------------------ mechanics
    Mutant("i-dem-phase-angle", M + "_dem_record.py",
           '"phase_angle": math.atan2(gpp, gp)', '"phase_angle": math.atan2(gp, gpp)',
           T_DEM + ("tests/test_stages_mechanics.py",), "swapped arguments (loss angle)"),
    Mutant("i-dem-voigt-slot", M + "_dem_record.py",
           "vo = K.S_STRESS + {frozenset((1, 2)): 3, frozenset((0, 2)): 4, frozenset((0, 1)): 5}",
           "vo = K.S_STRESS + {frozenset((1, 2)): 3, frozenset((0, 2)): 5, frozenset((0, 1)): 4}",
           T_DEM, "wrong index (Voigt slot of the shear stress)"),
    Mutant("i-dem-energy-residual", M + "_dem_record.py",
           '"residual": w - dmp - slp - du - dk', '"residual": w - dmp - du - dk',
           T_DEM, "dropped term (sliding loss in the energy balance)"),
    Mutant("i-dem-kinetic-stress", K + "dem.py",
           "samples[row, S_STRESS + v6] = -(s + kt[v6]) / vol", "samples[row, S_STRESS + v6] = -(s - kt[v6]) / vol",
           T_DEM, "wrong sign (kinetic part of the stress)"),
    Mutant("i-contact-slip-energy", K + "contacts.py",
           "slip = lim * (mag - lim) / ks", "slip = mag * (mag - lim) / ks",
           T_DEM, "wrong factor (sliding loss)"),
    Mutant("i-contact-stored-energy", K + "contacts.py",
           "            e += 0.5 * fn * fn / kn\n", "            e += fn * fn / kn\n",
           T_DEM, "factor 2 (stored normal energy)"),
    Mutant("i-el-shear-moduli", M + "elastic.py",
           "self.stiffness[4, 4], self.stiffness[5, 5]])", "self.stiffness[4, 4], self.stiffness[4, 4]])",
           T_EL, "wrong index (C66)"),
    Mutant("i-net-bonds-per-particle", M + "network.py",
           "return np.bincount(self._i, minlength=n) + np.bincount(self._j, minlength=n)",
           "return np.bincount(self._i, minlength=n) + np.bincount(self._i, minlength=n)",
           T_NET, "wrong index (second end of the bond)"),
    Mutant("i-net-zero-gap-ignored", M + "network.py",
           'rest = length.copy() if reference == "stress-free" else rad[i] + rad[j]',
           'rest = length.copy() if reference == "stress-free" else length.copy()',
           T_NET + ("tests/test_dem.py",), "option dropped (zero-gap reference)"),
    Mutant("i-net-z-backbone", M + "network.py",
           "return 2.0 * int(self.backbone_bonds.sum()) / keep if keep else 0.0",
           "return 2.0 * int(self.backbone_bonds.sum()) / self.n if keep else 0.0",
           T_NET, "wrong denominator (coordination without rattlers)"),
    # ------------------------------------------------------------------------------------ VEM
    Mutant("i-vem-classify-overlap", K + "vem.py",
           "        ov = (s - d) / s\n", "        ov = (s - d) / d\n",
           T_VEM, "wrong denominator (relative overlap)"),
    Mutant("i-vem-grow-inertia", G + "vem.py",
           "        self.radii[self.ns:] *= factor\n        self.inertia = 0.4 * self.radii**2\n",
           "        self.radii[self.ns:] *= factor\n        self.inertia = 0.4 * self.radii\n",
           T_VEM, "wrong power (inertia of grown voids)"),
    Mutant("i-vem-overlap-floor", G + "vem.py",
           "(st[V.C_STRUCT_OVERLAP_SUM] + st[V.C_VOID_OVERLAP_SUM]) <= overlap_floor * n",
           "st[V.C_STRUCT_OVERLAP_SUM] <= overlap_floor * n",
           T_VEM, "dropped term (void overlaps in the unloaded test)"),
    Mutant("i-vem-box", G + "vem.py",
           "box_len = (float(np.sum(4.0 / 3.0 * np.pi * red**3)) / phi) ** (1.0 / 3.0)",
           "box_len = (float(np.sum(4.0 / 3.0 * np.pi * red**2)) / phi) ** (1.0 / 3.0)",
           T_VEM, "wrong power (box of Eq. (5))"),
    # -------------------------------------------------------------------------------- deposits
    Mutant("i-dep-slab-volume", A + "deposits.py",
           "return float(np.sum(np.pi * (r * r * (hi - lo) - (hi**3 - lo**3) / 3.0)))",
           "return float(np.sum(np.pi * (r * r * (hi - lo) - (hi**3 - lo**3) / 2.0)))",
           T_DEP3, "wrong coefficient (spherical slab)"),
    Mutant("i-dep-surface-bins", A + "deposits.py",
           "bw = 4.0 * float(rad.max()) if bin_width is None", "bw = 2.0 * float(rad.max()) if bin_width is None",
           T_DEP2 + T_DEP3, "factor 2 (free-surface bin width: radius for diameter)"),
    Mutant("i-dep-2d-contacts", A + "deposits.py",
           "        z = np.bincount(i, minlength=rad.size) + np.bincount(j, minlength=rad.size)\n"
           "        inside = (pos[:, 0] >= x0)",
           "        z = np.bincount(i, minlength=rad.size) + np.bincount(i, minlength=rad.size)\n"
           "        inside = (pos[:, 0] >= x0)",
           T_DEP2, "wrong index (contacts of 2D deposits)"),
    Mutant("i-dep2-dilated-meet", K + "deposit.py",
           "a = (Ri * Ri - Rj * Rj + d2) / (2.0 * d)", "a = (Ri * Ri - Rj * Rj + d2) / d",
           T_DEP2, "factor 2 (circle intersection)"),
    Mutant("i-dep2-area-images", K + "deposit.py",
           "for shift in (-width, 0.0, width):", "for shift in (0.0, width):",
           T_DEP2, "dropped periodic image"),
    Mutant("i-dep3-default-width", G + "deposit.py",
           "np.sum(radii**3)) / DEFAULT_FRACTION_GUESS_3D) ** (1.0 / 3.0)",
           "np.sum(radii**2)) / DEFAULT_FRACTION_GUESS_3D) ** (1.0 / 3.0)",
           T_DEP3, "wrong power (default footprint)"),
    Mutant("i-dep3-tie-y", K + "deposit3d.py",
           "    return y < by\n", "    return y > by\n",
           T_DEP3, "inverted tie rule (y)"),
    # -------------------------------------------------------------------------------- reports
    Mutant("i-rep-species-fraction-dim", R + "build.py",
           "    vol = pk.radii ** dim\n", "    vol = pk.radii ** 3\n",
           T_REP, "ignores dimension (species volume shares)"),
    Mutant("i-rep-species-phi-dim", R + "build.py",
           "vol = ball_volume(pk.radii, pk.dim)", "vol = ball_volume(pk.radii, 3)",
           T_REP, "ignores dimension (species volume fractions)"),
    Mutant("i-rep-pores-fit-b", R + "build.py",
           'fits[name] = (ea["mean"], _t_half(ea), eb["mean"], _t_half(eb))',
           'fits[name] = (ea["mean"], _t_half(ea), eb["mean"], _t_half(ea))',
           T_REP, "wrong index (half-width of b from a)"),
    Mutant("i-ens-band-se", E + "runner.py",
           '"lo": _nan_none(mean - half),', '"lo": _nan_none(mean - se),',
           T_ENS, "dropped factor (lower band edge without t)"),
]


def overlap():
    """Independent mutants whose target text overlaps a harness mutant's in the same file."""
    out = []
    for m in INDEPENDENT:
        for h in mutate.MUTANTS:
            if h.path == m.path and (h.find in m.find or m.find in h.find):
                out.append(f"{m.id} overlaps harness {h.id}")
    return out


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if "--overlap" in argv:
        lines = overlap()
        print("\n".join(lines) if lines else "no overlap with the harness list")
        return 0
    ids = {m.id for m in INDEPENDENT}
    assert len(ids) == len(INDEPENDENT), "duplicate ids"
    mutate.MUTANTS = INDEPENDENT  # main() and write_markdown() read the module's list
    return mutate.main(argv)


if __name__ == "__main__":
    sys.exit(main())
