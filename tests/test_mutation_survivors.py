"""Tests for the survivors of the independent mutation check (tools/mutants_independent.py, issue 37).

Each test pins one quantity the suite did not check, against a closed form or a hand result.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from polypack.generate import dlvo

KB = 1.380649e-23


def test_default_bd_time_step_gives_an_rms_step_of_a_fifth_of_the_debye_length_per_coordinate():
    """Default Δt: the rms Brownian step per coordinate sqrt(2 D0 Δt) is 0.2 Debye lengths
    (docs of BrownianSimulation), so Δt = (0.2 λ)² / (2 D0) with D0 = kT / (6πηa) computed here.
    Taking the 3D rms (6 D0 Δt) would make it 3 times shorter."""
    from polypack.generate.brownian import BrownianSimulation

    a, T, eta = 0.25e-6, 293.15, 1.002e-3
    p = dlvo.dlvo_parameters(0.0, radius=a, temperature=T, viscosity=eta)
    pos = np.array([[1e-6, 1e-6, 1e-6], [2e-6, 2e-6, 2e-6]])
    sim = BrownianSimulation(pos, 4e-6, p, bond_width=None, seed=1)
    d0 = KB * T / (6.0 * math.pi * eta * a)
    lam = p.debye_length
    assert sim.time_step == pytest.approx((0.2 * lam) ** 2 / (2.0 * d0), rel=1e-12, abs=0)
    assert sim.rms_step == pytest.approx(0.2 * lam, rel=1e-12, abs=0)


def test_dem_stress_sample_of_a_free_sphere_is_minus_its_kinetic_tensor_over_the_volume():
    """One free sphere (mass 2) without contacts, moving with v = (0.3, -0.2, 0.5) in a cell of
    volume V = 1000: one sampled step of the DEM kernel records σ = -(m v ⊗ v) / V (the kinetic
    part of the Love-Weber stress, tension positive), in Voigt order xx yy zz yz xz xy; under a
    Lees-Edwards drive along x with gradient z the peculiar velocity v - γ̇ z e_x enters instead."""
    from polypack._kernels import contacts as C
    from polypack._kernels import dem as K

    for amplitude in (0.0, 0.01):
        p = np.zeros(K.N_P)
        p[K.P_DT] = 1e-3
        p[K.P_OMEGA] = 2.0 * np.pi
        p[K.P_AMPLITUDE] = amplitude
        p[K.P_RAMP] = 1.0
        p[K.P_VOLUME] = 1000.0
        p[K.P_LENGTH] = 10.0
        p[K.P_AXIS_A] = 0
        p[K.P_AXIS_G] = 2
        p[K.P_MODE] = K.MODE_LEES_EDWARDS
        p[K.P_SAMPLE_EVERY] = 1
        step = 40
        st = np.zeros(K.N_ST)
        st[K.ST_STEP] = step
        pos = np.array([[5.0, 5.0, 3.0]])
        v = np.array([0.3, -0.2, 0.5])
        vel = v[None, :].copy()
        samples = np.zeros((2, K.N_S))
        e0 = np.zeros(0)
        K.run(1, pos, vel, np.zeros((1, 3)), np.ones(1), np.full(1, 2.0), np.full(1, 0.8), np.zeros(1, np.int64),
              pos.copy(), np.eye(3) * 10.0, np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3)), e0, e0,
              e0, e0, e0, np.zeros(0, np.int64), np.zeros((0, 3)), e0, p, st, samples, 0, pos.copy(), e0,
              np.zeros((2, 0)))
        dt, om = 1e-3, 2.0 * np.pi
        gdot = amplitude * (math.sin(om * step * dt) - math.sin(om * (step - 1) * dt)) / dt
        u = v - np.array([gdot * 3.0, 0.0, 0.0])
        kin = 2.0 * np.outer(u, u)
        voigt = [kin[0, 0], kin[1, 1], kin[2, 2], kin[1, 2], kin[0, 2], kin[0, 1]]
        np.testing.assert_allclose(samples[0, K.S_STRESS:K.S_STRESS + 6], -np.array(voigt) / 1000.0, rtol=1e-12)
        assert samples[0, K.S_KINETIC] == pytest.approx(0.5 * 2.0 * v @ v, rel=1e-12, abs=0)


def test_dem_cycle_energy_balance_and_fit_from_hand_made_samples():
    """The per-direction bookkeeping of oscillatory_shear on synthetic sample rows (two cycles of
    40 rows): G' and G'' of σ = G' γ + (G''/ω) γ̇ recovered exactly, the phase angle atan2(G'', G'),
    the stress read from the Voigt slot of the sheared pair (x-y: C66), and each cycle's energy
    terms the differences of the cumulative columns, residual = work - damping - slip - Δstored -
    Δkinetic (here 0.1 by construction)."""
    import types

    from polypack._kernels import dem as K
    from polypack.mechanics.dem import _direction_result

    spc, ncyc, f, amp, gp, gpp = 40, 2, 2.0, 1e-3, 5.0, 1.5
    om = 2.0 * np.pi * f
    t = np.arange(spc * ncyc + 1) / (spc * f)
    s = np.zeros((t.size, K.N_S))
    s[:, K.S_TIME] = t
    s[:, K.S_STRAIN] = amp * np.sin(om * t)
    s[:, K.S_STRESS + 5] = gp * amp * np.sin(om * t) + gpp * amp * np.cos(om * t)
    s[:, K.S_STRESS + 4] = 99.0  # another slot: must not be read
    s[:, K.S_WORK] = 1.0 * t * f
    s[:, K.S_DAMP] = 0.5 * t * f
    s[:, K.S_SLIP] = 0.2 * t * f
    s[:, K.S_STORED] = 0.1 * t * f + 0.05 * np.sin(om * t) ** 2
    s[:, K.S_KINETIC] = 0.1 * t * f
    sys_ = types.SimpleNamespace(contacts=types.SimpleNamespace(cstate=np.zeros(1, np.int64), n_bonds=1),
                                 bond_source=np.zeros(1, np.int64), st=np.zeros(K.N_ST))
    row, _ = _direction_result(K, s, 1, 0, om, amp, 1.0, 0, spc, "lees-edwards", sys_, f, True)
    assert row["voigt"] == "C66"
    assert row["storage_modulus"] == pytest.approx(gp, rel=1e-9, abs=0)
    assert row["loss_modulus"] == pytest.approx(gpp, rel=1e-9, abs=0)
    assert row["phase_angle"] == pytest.approx(math.atan2(gpp, gp), rel=1e-9, abs=0)
    assert len(row["energy"]) == ncyc
    for e in row["energy"]:
        assert (e["work"], e["damping"], e["slip"]) == pytest.approx((1.0, 0.5, 0.2), rel=1e-12, abs=0)
        assert (e["stored_change"], e["kinetic_change"]) == pytest.approx((0.1, 0.1), rel=1e-9, abs=0)
        assert e["residual"] == pytest.approx(0.1, rel=1e-9, abs=0)


def test_contact_stored_energy_is_half_f_squared_over_k_for_both_springs():
    """One bonded contact compressed by 0.01 (kn = 100: F_n = 1) carrying a stored shear force
    0.3 (ks = 10): the stored energy accumulated by the contact kernel is F_n²/(2 kn) +
    |F_s|²/(2 ks) = 0.005 + 0.0045 (Eq. (1)-(2) of 003_873b69fc71c74cf6.txt as springs)."""
    from polypack._kernels import contacts as C

    pos = np.array([[5.0, 5.0, 5.0], [6.99, 5.0, 5.0]])
    one = np.ones(1)
    cfs = np.array([[0.0, 0.3, 0.0]])
    acc = np.zeros(C.N_ACC)
    C.contact_forces(pos, np.zeros((2, 3)), np.zeros((2, 3)), np.ones(2), np.eye(3) * 20.0, np.zeros((3, 3)), 0.0,
                     np.zeros(1, np.int64), np.ones(1, np.int64), np.zeros((1, 3)), one * 100.0, one * 10.0, one * 2.0,
                     one * np.inf, one * np.inf, np.full(1, C.BONDED, np.int64), cfs, np.zeros(1), 0.0,
                     np.zeros((2, 3)), np.zeros((2, 3)), acc)
    fn = 100.0 * 0.01
    assert acc[C.A_STORED] == pytest.approx(fn * fn / 200.0 + 0.09 / 20.0, rel=1e-9, abs=0)
    assert acc[C.A_ACTIVE] == 1.0
    assert acc[C.A_FORCE_SUM] == pytest.approx(math.hypot(fn, 0.3), rel=1e-9, abs=0)


def test_vem_spheres_have_the_moment_of_inertia_of_solid_spheres_after_the_voids_grow():
    """The VEM assembly (reduced units, mass 1 per sphere) gives every sphere I = ⅖ m r², the
    voids too, and keeps it so when the voids grow (their radii times 1.3)."""
    from polypack.generate.vem import _Assembly

    rng = np.random.default_rng(2)
    pos = rng.uniform(0.0, 12.0, (10, 3))
    radii = np.r_[np.ones(6), np.full(4, 0.2)]
    asm = _Assembly(pos, radii.copy(), np.full(3, 12.0), 6, 1.0, 0.1, 1.0, 0.01, 0.0, 0.7, 0.4)
    np.testing.assert_allclose(asm.inertia, 0.4 * asm.mass * radii ** 2, rtol=1e-14)
    asm.grow_voids(1.3)
    grown = np.r_[np.ones(6), np.full(4, 0.26)]
    np.testing.assert_allclose(asm.radii, grown, rtol=1e-14)
    np.testing.assert_allclose(asm.inertia, 0.4 * asm.mass * grown ** 2, rtol=1e-14)


def test_vem_box_of_a_bidisperse_structure_holds_the_target_volume_fraction():
    """Eq. (5) of 003_873b69fc71c74cf6.txt generalised to unequal spheres: the cubic box side is
    (Σ 4/3 π r³ / Φ)^(1/3): 20 spheres of radius 1 and 20 of radius 0.5 at Φ = 0.3 sit in a box
    of side (100 π)^(1/3) = 6.798; equal spheres cannot tell r³ from r² in reduced units (mean
    radius 1), two sizes can (a box from Σ r² would hold Φ = 0.36)."""
    import polypack as pp

    r = np.r_[np.full(20, 1.0), np.full(20, 0.5)]
    pk = pp.vem(r, volume_fraction=0.3, seed=1, progress=False)
    side = (np.sum(4.0 / 3.0 * np.pi * r ** 3) / 0.3) ** (1.0 / 3.0)
    np.testing.assert_allclose(pk.box, side, rtol=1e-12)
    assert pk.volume_fraction == pytest.approx(0.3, rel=1e-12, abs=0)
    np.testing.assert_array_equal(np.sort(pk.radii), np.sort(r))


@pytest.mark.parametrize("boundary, x0, y0", [("walls", 0.5, 0.5), ("periodic", 0.0, 0.0)])
def test_first_spheres_on_a_bare_3d_floor_fill_a_row_by_the_tie_rule(boundary, x0, y0):
    """On a bare floor every position is equally low: the tie rule (lowest centre, then smallest
    x, then smallest y; §2.4 of 001_ad5bae0acea940c4.txt extended to 3D) puts equal spheres of
    radius 0.5 given in order at x = x0 and y = y0, y0 + 1, y0 + 2, ... (against the y = 0 wall
    with walls, from the origin with a periodic footprint)."""
    import polypack as pp

    pk = pp.deposit(np.full(4, 0.5), width=(4.0, 5.0), boundary=boundary, order="given", dim=3, progress=False)
    expect = np.c_[np.full(4, x0), y0 + np.arange(4.0), np.full(4, 0.5)]
    np.testing.assert_allclose(pk.positions, expect, rtol=0, atol=1e-9)


@pytest.mark.parametrize("dim", [2, 3])
def test_default_deposit_width_gives_a_square_or_cubic_deposit(dim):
    """Without ``width`` the footprint is chosen so that the deposit would be square (2D) or cubic
    (3D) at the guessed packing fraction f: L^dim f = total disk area or sphere volume."""
    import polypack as pp
    from polypack.generate.deposit import DEFAULT_FRACTION_GUESS, DEFAULT_FRACTION_GUESS_3D

    rng = np.random.default_rng(3)
    r = rng.uniform(0.2, 0.5, 150 if dim == 3 else 200)
    pk = pp.deposit(r, boundary="walls", order="given", dim=dim, progress=False)
    if dim == 3:
        side = (4.0 / 3.0 * np.pi * np.sum(r ** 3) / DEFAULT_FRACTION_GUESS_3D) ** (1.0 / 3.0)
        np.testing.assert_allclose(pk.box[:2], side, rtol=1e-12)
    else:
        side = math.sqrt(np.pi * np.sum(r ** 2) / DEFAULT_FRACTION_GUESS)
        assert pk.box[0] == pytest.approx(side, rel=1e-12, abs=0)


def _bidisperse_disks():
    import polypack as pp

    pos = np.array([[1.0, 1.0], [3.0, 1.0], [1.0, 3.0], [3.0, 3.2], [2.0, 2.0]])
    r = np.array([0.5, 0.5, 0.3, 0.3, 0.3])
    return pp.Packing(pos, r, [4.5, 4.5], species=np.array([0, 0, 1, 1, 1])), pos, r


def test_report_species_fractions_of_disks_are_area_fractions():
    """The report's species table (pack report) and the species volume fractions (run report) of a
    2D pack of two disk sizes are area fractions π Σ_k r² / A (2 · π 0.25 / 20.25 and
    3 · π 0.09 / 20.25), not volume-based shares."""
    from polypack.report.build import _pack_tables, _species_volume_fractions

    pk, _, r = _bidisperse_disks()
    area = 4.5 * 4.5
    expect = [np.pi * np.sum(r[:2] ** 2) / area, np.pi * np.sum(r[2:] ** 2) / area]
    np.testing.assert_allclose(_species_volume_fractions(pk), expect, rtol=1e-12)
    _, sp_rows = _pack_tables(pk, None)
    np.testing.assert_allclose([row[3] for row in sp_rows], expect, rtol=1e-12)
    assert [row[1] for row in sp_rows] == [2, 3]


def test_run_report_pores_fit_half_widths_are_each_parameters_own(monkeypatch):
    """The pores figure of a run report gets, for each fit (seed, normalized), a and b with their
    own 95 % half-widths t(0.975, n - 1) SE (scipy.stats here), not b's taken from a."""
    import types

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy import stats

    import polypack.report.figures as P
    from polypack.report.build import run_figures

    seen = {}

    def fake(entry, r0, fits):
        seen.update(fits)
        return plt.figure()

    monkeypatch.setattr(P, "pores_figure", fake)
    sc = {"pores.fit.seed.a": {"mean": 0.4, "se": 0.01, "n": 4}, "pores.fit.seed.b": {"mean": 2.0, "se": 0.3, "n": 4},
          "pores.fit.normalized.a": {"mean": 0.5, "se": 0.02, "n": 3},
          "pores.fit.normalized.b": {"mean": 1.5, "se": 0.2, "n": 3}}
    run = types.SimpleNamespace(curves={"analyses": {"pores": {}}, "n_realizations": 4}, name="r",
                                records=[{"analysis": {"pores": {"fit": {"r0": 1.0}}}, "scalars": {}}],
                                scalars=sc, study={"protocol": {"kind": "crm"}})
    run_figures(run, [])
    for name, n in (("seed", 4), ("normalized", 3)):
        a, b = sc[f"pores.fit.{name}.a"], sc[f"pores.fit.{name}.b"]
        q = stats.t.ppf(0.975, n - 1)
        assert seen[name] == pytest.approx((a["mean"], q * a["se"], b["mean"], q * b["se"]), rel=1e-12, abs=0)
