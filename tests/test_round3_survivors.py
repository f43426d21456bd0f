"""Tests for the survivors of the independent round-3 mutation check (tools/mutants_round3.py, issue 37).

Each test pins a form that the suite left free: a one-line bug of the round-3 modules passed every
test a maintainer would run.  Oracles: closed forms of lattices, the documented limits, hand counts.
"""

import math

import numpy as np
import pytest
from _lattices import simple_cubic

import polypack as pp
from polypack import registry
from polypack.mechanics import BondNetwork, elastic_tensor

KN, KS = 100.0, 10.0


# ----------------------------------------------------------------- issue 31: rigid / floppy
def _sheets(cells=3):
    """Simple cubic lattice (d = 1) bonded along x and y only: xy sheets with no bond across z."""
    pk = simple_cubic(cells=cells)
    c = cells

    def idx(a, b, e):
        return ((a % c) * c + (b % c)) * c + (e % c)

    i, j = [], []
    for a in range(c):
        for b in range(c):
            for e in range(c):
                for d in ((1, 0, 0), (0, 1, 0)):
                    i.append(idx(a, b, e))
                    j.append(idx(a + d[0], b + d[1], e + d[2]))
    return BondNetwork.from_pairs(pk, i, j, normal_stiffness=KN, shear_stiffness=KS)


def test_one_floppy_strain_mode_is_not_rigid():
    """Sheets bonded along x and y, no rotations: only eps_33 costs no energy (no bond has a z
    component), so exactly 1 of 6 strain modes is floppy and the network is floppy, not rigid.
    Closed form per unit cell (d = 1, affine: the lattice is centrosymmetric): C11 = C22 = kn,
    C44 = C55 = ks/4 (one bond sees gamma d/2 across), C66 = ks/2 (both bonds do).  With rotations
    a uniform spin cancels the tangential loads of gamma_23 and gamma_13: 3 floppy modes."""
    net = _sheets()
    for rotations, diag, soft in [(False, [KN, KN, 0, KS / 4, KS / 4, KS / 2], 1),
                                  (True, [KN, KN, 0, 0, 0, KS / 2], 3)]:
        et = elastic_tensor(net, rotations=rotations, solver="direct")
        np.testing.assert_allclose(np.diag(et.stiffness), diag, rtol=1e-9, atol=1e-9 * KN)
        assert et.floppy_strains == soft
        assert et.rigid is False and et.status == "floppy" and f"{soft} of 6" in et.floppy_reason


def _row(gp, gpp):
    return {"storage_modulus": gp, "loss_modulus": gpp, "normal": 2, "shear": 0, "phase_angle": math.atan2(gpp, gp)}


def test_shear_assessment_limits_are_the_documented_ones():
    """_assess at each documented limit, from both sides: loss tangent G''/G' <= LOSS_TANGENT_LIMIT (1),
    G' at most (1 + STATIC_EXCESS_LIMIT) = 1.25 times the static modulus, inertial error <= 1."""
    from polypack.mechanics import dem

    assert dem.LOSS_TANGENT_LIMIT == 1.0 and dem.STATIC_EXCESS_LIMIT == 0.25 and dem.INERTIAL_ERROR_LIMIT == 1.0
    ok = dem._assess([_row(1.0, 0.9)], 1.0, 1.0, 0.5, True)
    assert ok == ("ok", [])
    for rows, g, static, inertial in [([_row(1.0, 1.5)], 1.0, 1.0, 0.5),     # G'' > G' (phase 56 deg)
                                      ([_row(1.0, 0.1)], 1.0, 1 / 1.3, 0.5),  # G' 30 % above static
                                      ([_row(1.0, 0.1)], 1.0, 1.0, 1.1),      # inertial error above 1
                                      ([_row(-1.0, 0.1)], -1.0, 1.0, math.nan)]:
        status, problems = dem._assess(rows, g, static, inertial, True)
        assert status == "not_converged" and problems, (rows, g, static, inertial)
    assert dem._assess([_row(1.0, 0.1)], 1.0, 1 / 1.2, 0.5, True)[0] == "ok"  # 20 % above static: ok


def test_bondless_records_are_counted_floppy():
    """A pack without a single bond: both mechanics records carry the summary flag floppy = 1 (the
    fraction of floppy structures is its mean), not just the status word."""
    from polypack.mechanics.stages import run_elastic, run_shear

    dilute = pp.Packing(np.array([[1.0, 1.0, 1.0], [4.0, 4.0, 4.0], [1.0, 4.0, 2.0]]), [0.5, 0.5, 0.5], 8.0)
    el = run_elastic(dilute, registry.get("analysis", "elastic").resolve({}), None)
    sh = run_shear(dilute, registry.get("analysis", "shear").resolve({}), None)
    assert el["floppy"] == 1 and el["rigid"] is False
    assert sh["floppy"] == 1 and sh["converged"] == 0


def test_not_converged_shear_is_not_floppy_and_its_inertial_error_uses_the_static_modulus():
    """100 steps per cycle on a rigid pack (G' ~ +47 % over its static limit): the record is
    not_converged, floppy = 0, no G' nor G'' to average; the inertial error is (omega H / c_s)^2 / 3
    with c_s from the *smaller* of G' and the static modulus (the overshooting G' would hide the
    error); the bulk density is rho * phi of the rescaled monodisperse pack."""
    from polypack.mechanics.stages import run_shear

    pk = pp.pack(np.full(60, 0.5), volume_fraction=0.6, seed=5)
    cap = registry.get("analysis", "shear")
    rec = run_shear(pk, cap.resolve({"epsilon": 0.05, "directions": [[2, 0]], "cycles": 2, "steps_per_cycle": 100}),
                    None)
    assert rec["status"] == "not_converged" and rec["floppy"] == 0 and rec["converged"] == 0
    assert rec["storage_modulus"] is None and rec["loss_modulus"] is None
    assert rec["measured_loss_modulus"] is not None
    gp, static = rec["measured_storage_modulus"], rec["static_storage_modulus"]
    assert gp > 1.25 * static  # the case where min() matters
    s = rec["radius_m"] / 0.5
    h = float(np.max(pk.box)) * s
    rho_bulk = rec["density"] * float(np.sum(4.0 / 3.0 * np.pi * pk.radii ** 3)) / float(np.prod(pk.box))
    want = (2.0 * np.pi * rec["frequency"] * h) ** 2 * rho_bulk / static / 3.0
    assert rec["inertial_error"] == pytest.approx(want, rel=1e-9, abs=0)
