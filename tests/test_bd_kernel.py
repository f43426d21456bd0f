"""One noise-free step of the Brownian-dynamics kernel (polypack._kernels.bd.run) against hand-computed
displacements: the pair force acts along the line of centres with opposite signs on the two spheres,
and the drift cap lets an attraction close at most ``drift_cap`` of the gap per step.

Reduced units of the kernel (radius 1, kT 1, time a^2/D0): a sphere moves by F dt. Without noise
the step is deterministic, so the expected positions hold to round-off (1e-12).
"""

import numpy as np
import pytest

from polypack._kernels import bd


def _step(gap, force, dt, cap):
    """Two spheres on the x axis ``2 + gap`` apart; the tabulated pair force is ``force`` everywhere."""
    pos = np.array([[4.0, 5.0, 5.0], [6.0 + gap, 5.0, 5.0]])
    box = np.full(3, 12.0)
    p = np.zeros(bd.N_PARAMS)
    p[bd.P_DT] = dt
    p[bd.P_NOISE] = 0.0
    p[bd.P_R_CUT] = 2.5
    p[bd.P_SKIN] = 0.4
    p[bd.P_BOND_WIDTH] = -1.0  # no bonds, no projections: only the pair force moves the spheres
    p[bd.P_CAP_DRIFT] = cap
    p[bd.P_SWEEPS] = 20
    p[bd.P_PROJ_TOL] = 1e-9
    p[bd.P_TAB_LO] = -0.1
    p[bd.P_TAB_DH] = 0.1
    table = np.full(12, float(force))
    state = np.zeros(bd.N_STATE)
    istate = np.zeros(bd.N_ISTATE, np.int64)
    status = bd.run(pos, box, p, state, istate, table, np.zeros((4, 2), np.int64), np.zeros((2, 8), np.int64),
                    np.zeros(2, np.int64), np.array([3, 3, 3], np.int64), np.array([1, 2, 3, 4], np.uint64), 1)
    assert status == 0
    return pos


@pytest.mark.parametrize("force", [-5.0, 3.0])
def test_pair_force_moves_both_spheres_along_the_line_of_centres(force):
    # force > 0 repels: sphere 0 moves by -F dt along x, sphere 1 by +F dt; y and z stay
    pos = _step(0.3, force, 1e-3, 0.0)
    np.testing.assert_allclose(pos[:, 0], [4.0 - force * 1e-3, 6.3 + force * 1e-3], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(pos[:, 1:], 5.0)


@pytest.mark.parametrize("cap", [0.25, 0.5])
def test_drift_cap_closes_that_fraction_of_the_gap(cap):
    # uncapped, F dt = 0.1 per sphere would close 0.2 > the gap 0.1; capped, the gap shrinks by cap * 0.1
    pos = _step(0.1, -100.0, 1e-3, cap)
    assert pos[1, 0] - pos[0, 0] - 2.0 == pytest.approx(0.1 * (1.0 - cap), abs=1e-12)
    assert pos[0, 0] - 4.0 == pytest.approx(-(pos[1, 0] - 6.1), abs=1e-12)  # symmetric


def test_pair_force_interpolates_the_table_and_clamps_like_np_interp():
    # the one pair-force helper of all three kernels: linear interpolation on the uniform grid,
    # clamped beyond both ends (np.interp does the same), to round-off
    rng = np.random.default_rng(3)
    table = rng.normal(size=40)
    lo, dh = -0.1, 0.05
    grid = lo + dh * np.arange(table.size)
    for h in np.concatenate([rng.uniform(lo - 0.5, grid[-1] + 0.5, 200), grid]):
        f = bd._pair_force(h, table, lo, 1.0 / dh, 0.0, 1e-3)
        assert f == pytest.approx(np.interp(h, grid, table), abs=1e-12)
    # capped attraction: -f * 2 dt = cap * h exactly; repulsion is never capped
    attract = np.full(8, -1e3)
    assert bd._pair_force(0.2, attract, lo, 1.0 / dh, 0.25, 1e-3) == pytest.approx(-0.25 * 0.2 / 2e-3, rel=1e-12)
    assert bd._pair_force(0.2, -attract, lo, 1.0 / dh, 0.25, 1e-3) == 1e3


def test_the_three_kernels_apply_the_same_pair_force():
    """One noise-free step of two unbonded spheres: run, run_rigid (two one-sphere clusters) and
    run_tangential (no springs) share the pair-force helper and give the same positions bit for bit."""
    rng = np.random.default_rng(0)
    table = rng.normal(size=12) * 50.0
    out = []
    for kernel in ("run", "rigid", "tangential"):
        pos = np.array([[4.0, 5.0, 5.0], [6.13, 5.4, 4.9]])
        box = np.full(3, 12.0)
        p = np.zeros(bd.N_PARAMS)
        p[bd.P_DT] = 1e-3
        p[bd.P_R_CUT] = 2.9
        p[bd.P_SKIN] = 0.4
        p[bd.P_BOND_WIDTH] = 0.004
        p[bd.P_CAP_DRIFT] = 0.25
        p[bd.P_SWEEPS] = 20
        p[bd.P_PROJ_TOL] = 1e-9
        p[bd.P_TAB_LO] = 0.004
        p[bd.P_TAB_DH] = 0.08
        args = (pos, box, p, np.zeros(bd.N_STATE), np.zeros(bd.N_ISTATE, np.int64), table, np.zeros((4, 2), np.int64),
                np.zeros((2, 8), np.int64), np.zeros(2, np.int64), np.array([3, 3, 3], np.int64),
                np.array([1, 2, 3, 4], np.uint64), 1)
        if kernel == "run":
            status = bd.run(*args)
        elif kernel == "rigid":
            cl = [np.zeros(2, np.int64) for _ in range(5)]
            frozen = np.zeros(2, np.uint8)
            bd.init_clusters(2, *cl, frozen)
            status = bd.run_rigid(*args, *cl, frozen)
        else:
            orient = np.zeros((2, 3))
            orient[:, 2] = 1.0
            status = bd.run_tangential(*args, np.zeros((4, 6)), orient)
        assert status == 0
        out.append(pos)
    assert not np.array_equal(out[0], [[4.0, 5.0, 5.0], [6.13, 5.4, 4.9]])  # the force moved them
    np.testing.assert_array_equal(out[0], out[1])
    np.testing.assert_array_equal(out[0], out[2])
