"""One noise-free step of the Brownian-dynamics kernel (polypack._kernels.bd.run) against hand-computed
displacements: the pair force acts along the line of centres with opposite signs on the two spheres,
and the drift cap lets an attraction close at most ``drift_cap`` of the gap per step.

Reduced units of the kernel (radius 1, kT 1, time a^2/D0): a sphere moves by F dt. Without noise
the step is deterministic, so the expected positions hold to round-off (1e-12), except where the
pair loop's r² force table (``F/r`` interpolated in ``s = r²``, bd._force_table_r2) stands in for the
h table: there to its interpolation error (tests at the end of this file bound it).
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
    # force > 0 repels: sphere 0 moves by -F dt along x, sphere 1 by +F dt; y and z stay.  The pair
    # loop interpolates F/r linearly in s = r^2 (1024 intervals over s in [1.9^2, 2.5^2] here): the
    # 1/r it stands in for is off by at most ds^2/8 max|d2(s^-1/2)/ds2| r = 3 ds^2 / (32 s^2) ~ 3e-8,
    # so F dt is off by ~1e-10 (a wrong sign or axis would be 3e-3 off)
    pos = _step(0.3, force, 1e-3, 0.0)
    np.testing.assert_allclose(pos[:, 0], [4.0 - force * 1e-3, 6.3 + force * 1e-3], rtol=0, atol=1e-9)
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
    run_tangential (no springs) share the pair-force loop: run and run_tangential give the same positions
    bit for bit, run_rigid the same within the r² table's interpolation error (F dt ~ 0.05 here; the
    flexible kernels read the r² table, the rigid one the h table it is resampled from)."""
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
    np.testing.assert_allclose(out[0], out[1], rtol=0, atol=1e-6)
    np.testing.assert_array_equal(out[0], out[2])


def _dense(seed, n=120, box_len=9.0):
    """``n`` spheres at random in a cube of side ``box_len`` (Φ ≈ 0.7: many overlaps and capture pairs)."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0.0, box_len, (n, 3))
    box = np.full(3, box_len)
    p = np.zeros(bd.N_PARAMS)
    p[bd.P_R_CUT] = 2.5
    p[bd.P_SKIN] = 0.4
    p[bd.P_BOND_WIDTH] = 0.05
    p[bd.P_SWEEPS] = 6
    p[bd.P_PROJ_TOL] = 0.0
    return pos, box, p


def _full_sweeps(pos, box, p, pi, pj, bonded):
    """Reference: plain Gauss–Seidel capture and shell sweeps over every listed pair (module docstring of bd)."""
    pos = pos.copy()
    bonded = bonded.copy()
    lim = 2.0 + p[bd.P_BOND_WIDTH]
    for _ in range(int(p[bd.P_SWEEPS])):
        for k in range(pi.size):
            i, j = pi[k], pj[k]
            d = pos[j] - pos[i]
            d -= box * np.round(d / box)
            r = float(np.sqrt(d @ d))
            if not bonded[k]:
                if r >= lim:
                    continue
                bonded[k] = 1
            corr = 2.0 - r if r < 2.0 else (lim - r if r > lim else 0.0)
            if corr != 0.0:
                pos[i] -= 0.5 * corr / r * d
                pos[j] += 0.5 * corr / r * d
    return pos, bonded


def _project_with(margin, pos0, box, p, lists, flag0):
    pi, pj, img = lists
    n = pos0.shape[0]
    pos = pos0.copy()
    flag = flag0.copy()
    istate = np.zeros(bd.N_ISTATE, np.int64)
    status = bd._project(pos, box, p, np.zeros(bd.N_STATE), istate, pi, pj, flag, img,
                         np.zeros((n * 12, 2), np.int64), np.zeros((n, 24), np.int64), np.zeros(n, np.int64),
                         np.empty(pi.size, np.int64), np.zeros(n), margin)
    assert status == 0
    return pos, flag, istate


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_projection_near_list_gives_the_full_sweeps(seed):
    """The sweeps after the first visit only the pairs that can act (bd._project): the result is that of
    plain full sweeps, for any margin (huge: every pair kept; tiny: the fallback to a full sweep fires).
    Two starts: random spheres (large corrections), and a relaxed pack jiggled by 0.03 radii
    (corrections of the order of the margins, so that the near lists are used and the bound matters);
    a few pairs are bonded beforehand and stretched far beyond the shell."""
    pos_rand, box, p = _dense(seed)
    n = pos_rand.shape[0]
    cells = np.array([3, 3, 3], np.int64)
    pi, pj, flag_r, img = bd._build(pos_rand, box, p, np.zeros((n, 24), np.int64), np.zeros(n, np.int64), cells)
    q = p.copy()
    q[bd.P_SWEEPS] = 60
    q[bd.P_OVERLAP_ONLY] = 1.0
    relaxed, _, _ = _project_with(1e3, pos_rand, box, q, (pi, pj, img), flag_r)
    rng = np.random.default_rng(seed)
    starts = [pos_rand, relaxed + rng.normal(0.0, 0.03, relaxed.shape)]
    for pos0 in starts:
        # the list of the jiggled pack is rebuilt (image counts of its own positions)
        pi, pj, flag0, img = bd._build(pos0, box, p, np.zeros((n, 24), np.int64), np.zeros(n, np.int64), cells)
        d = pos0[pj] - pos0[pi]
        d -= box * np.round(d / box)
        r = np.sqrt((d * d).sum(1))
        far = np.flatnonzero((r > 2.3) & (r < 2.8))[::7]
        assert far.size >= 5
        flag0[far] = 1
        ref, ref_bonded = _full_sweeps(pos0, box, p, pi, pj, flag0)
        assert np.abs(ref - pos0).max() > 0.1  # the sweeps moved spheres
        outs = []
        for margin in (1e3, 0.5, 0.2, 0.1, 0.05, 0.02, 1e-3, 0.0):
            pos, flag, istate = _project_with(margin, pos0, box, p, (pi, pj, img), flag0)
            assert istate[bd.I_SWEEPS] == p[bd.P_SWEEPS]
            np.testing.assert_array_equal(flag, ref_bonded)
            assert istate[bd.I_NBONDS] == ref_bonded.sum() - far.size
            outs.append(pos)
        np.testing.assert_allclose(outs[0], ref, rtol=0, atol=1e-12)
        for out in outs[1:]:
            np.testing.assert_array_equal(out, outs[0])


def _overlap_sweeps(pos0, pi, pj, sweeps):
    """Overlap-only projections of hand-placed spheres in a large box (no images) over the hand-ordered
    pair list (pi, pj) for each margin; every result must be the plain full sweeps' (margin 0) bit for bit."""
    box = np.full(3, 40.0)
    p = np.zeros(bd.N_PARAMS)
    p[bd.P_BOND_WIDTH] = 0.05
    p[bd.P_SWEEPS] = sweeps
    p[bd.P_PROJ_TOL] = 0.0
    p[bd.P_OVERLAP_ONLY] = 1.0
    lists = (pi, pj, np.zeros((pi.size, 3), np.int64))
    flag = np.zeros(pi.size, np.uint8)
    ref, _, _ = _project_with(0.0, pos0, box, p, lists, flag)
    assert np.abs(ref - pos0).max() > 0.01
    for margin in np.concatenate([np.geomspace(1e-3, 1.0, 61), [1e3]]):
        pos, _, istate = _project_with(margin, pos0, box, p, lists, flag)
        assert istate[bd.I_SWEEPS] == sweeps
        np.testing.assert_array_equal(pos, ref, err_msg=f"margin {margin}")


def test_projection_near_list_resumes_at_the_pair_after_the_trigger():
    """Three spheres in a row A-B-C overlapping by 0.1 and 0.06, pairs (A, B), (B, C): the second
    sweep uses the near list, and for margins where B's tally crosses half the margin at (A, B), the
    sweep goes on as a full one from the very next pair (B, C), which still overlaps (skipping it, as a
    restart one pair too far would, changes the result)."""
    pos0 = np.array([[10.0, 10.0, 10.0], [11.9, 10.0, 10.0], [13.84, 10.0, 10.0]])
    _overlap_sweeps(pos0, np.array([0, 1]), np.array([1, 2]), 3)


def test_projection_near_list_counts_the_second_sphere_of_a_pair():
    """Spheres J and K 2.11 apart, their pair listed first (left out of the near list for margins
    below 0.11); J is the second sphere of three pairs with spheres I1..I3 on its far side and K of
    three pairs with L1..L3 (overlaps 0.06, at 40 degrees from the J-K axis).  One sweep moves each I
    and L by 0.03 but J and K by about 0.09 towards each other, so that they overlap: the tally must
    count the second sphere's movement, else the next sweep visits the near list only and misses
    the J-K contact."""
    th = np.radians(40.0)
    j = np.array([10.0, 10.0, 10.0])
    k = j + [2.11, 0.0, 0.0]
    pts = [j, k]
    for c, sgn in ((j, -1.0), (k, 1.0)):
        for phi in np.radians([0.0, 120.0, 240.0]):
            pts.append(c + sgn * 1.94 * np.array([np.cos(th), np.sin(th) * np.cos(phi), np.sin(th) * np.sin(phi)]))
    _overlap_sweeps(np.array(pts), np.array([0, 2, 3, 4, 5, 6, 7]), np.array([1, 0, 0, 0, 1, 1, 1]), 3)


def test_far_periodic_images_give_the_same_step():
    """Unwrapped positions several boxes away (image counts |q| >= 2 in the Verlet list) give the
    same forces, captures and projections as the wrapped ones."""
    pos0, box, p = _dense(3, n=80)
    p[bd.P_DT] = 1e-4
    p[bd.P_CAP_DRIFT] = 0.25
    p[bd.P_TAB_LO] = 0.05
    p[bd.P_TAB_DH] = 0.05
    table = -np.linspace(50.0, 0.0, 10)
    shifts = np.random.default_rng(4).integers(-3, 4, pos0.shape) * box
    out = []
    for pos in (pos0.copy(), pos0 + shifts):
        n = pos.shape[0]
        istate = np.zeros(bd.N_ISTATE, np.int64)
        status = bd.run(pos, box, p, np.zeros(bd.N_STATE), istate, table, np.zeros((n * 12, 2), np.int64),
                        np.zeros((n, 24), np.int64), np.zeros(n, np.int64), np.array([3, 3, 3], np.int64),
                        np.array([1, 2, 3, 4], np.uint64), 3)
        assert status == 0 and istate[bd.I_NBONDS] > 10
        out.append((pos, istate[bd.I_NBONDS]))
    assert out[0][1] == out[1][1]
    np.testing.assert_allclose(out[1][0] - shifts, out[0][0], rtol=0, atol=1e-9)


def test_ziggurat_normals_are_standard_normal():
    """bd.next_normal (256-layer ziggurat): 2e6 draws against N(0, 1): moments, Kolmogorov-Smirnov,
    the mass of the tail beyond the base strip r = 3.654 (drawn by its own algorithm) and of each wedge
    region, within 5 standard errors."""
    from scipy import stats

    out = np.empty(2_000_000)
    bd.fill_normals(np.array([5, 6, 7, 8], np.uint64), np.zeros(bd.N_STATE), out)
    n = out.size
    assert abs(out.mean()) < 5 / np.sqrt(n)
    assert abs(out.var() - 1.0) < 5 * np.sqrt(2 / n)
    assert abs(stats.kurtosis(out)) < 5 * np.sqrt(24 / n)
    assert stats.kstest(out, "norm").pvalue > 1e-3
    r = 3.6541528853610088
    p_tail = 2 * stats.norm.sf(r)
    assert abs((np.abs(out) > r).sum() - n * p_tail) < 5 * np.sqrt(n * p_tail)
    assert (np.abs(out) > 4.5).sum() > 0 and np.abs(out).max() < 6.5
    edges = np.linspace(-4.0, 4.0, 81)
    h, _ = np.histogram(out, edges)
    e = n * np.diff(stats.norm.cdf(edges))
    assert ((h - e) ** 2 / e).sum() < 80 + 5 * np.sqrt(160)  # chi-square, 80 bins
    # reproducible from the state, and the state advances
    a = np.empty(5)
    b = np.empty(5)
    bd.fill_normals(np.array([5, 6, 7, 8], np.uint64), np.zeros(bd.N_STATE), a)
    bd.fill_normals(np.array([5, 6, 7, 8], np.uint64), np.zeros(bd.N_STATE), b)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, out[:5])
    assert len(set(a)) == 5


@pytest.mark.parametrize("ncell", [(5, 4, 6), (3, 3, 3), (1, 2, 7), (7, 9, 8)])
def test_verlet_list_is_pairs_within_by_i_then_j_with_flags_and_image_counts(ncell):
    """bd._build (cells enumerated in place, scan stopped at j >= i, bonded flags from a per-sphere mark):
    the pairs of cells.pairs_within, ordered by i then j, on unwrapped positions (some several boxes away),
    in grids with wrapped, fully scanned (2 r + 1 >= ncell) and single-cell axes; flags are the bonded
    pairs of a random bond list, image counts give the minimum image."""
    from polypack._kernels.cells import min_image, pairs_within

    rng = np.random.default_rng(sum(ncell))
    box = np.array([23.0, 20.0, 25.0])
    n = 300
    pos = rng.uniform(0.0, 1.0, (n, 3)) * box + rng.integers(-3, 4, (n, 3)) * box
    p = np.zeros(bd.N_PARAMS)
    p[bd.P_R_CUT] = 2.5
    p[bd.P_SKIN] = 0.9
    nc = np.array(ncell, np.int64)
    ri, rj, _ = pairs_within(pos, np.ones(n), box, 0.0, 3.4, nc)
    assert ri.size > 200
    # the oracle itself against all pairs by brute force (it shares cells.axis_reach / wrap_cell with bd)
    d = pos[:, None, :] - pos[None, :, :]
    d -= box * np.round(d / box)
    bi, bj = np.nonzero(np.tril(np.einsum("ijk,ijk->ij", d, d) <= 3.4 ** 2, -1))
    assert sorted(zip(ri.tolist(), rj.tolist())) == sorted(zip(bi.tolist(), bj.tolist()))
    bonded = {tuple(sorted(x)) for x in zip(ri[::3], rj[::3])}
    adj = np.zeros((n, 24), np.int64)
    deg = np.zeros(n, np.int64)
    for a, b in bonded:
        adj[a, deg[a]] = b
        deg[a] += 1
        adj[b, deg[b]] = a
        deg[b] += 1
    pi, pj, flag, img = bd._build(pos, box, p, adj, deg, nc)
    key = np.lexsort((rj, ri))  # by i, then j
    np.testing.assert_array_equal(pi, ri[key])
    np.testing.assert_array_equal(pj, rj[key])
    np.testing.assert_array_equal(flag, [tuple(sorted(x)) in bonded for x in zip(pi, pj)])
    for k in range(pi.size):
        for c in range(3):
            d = pos[pj[k], c] - pos[pi[k], c]
            assert d - box[c] * img[k, c] == pytest.approx(min_image(d, box[c]), abs=1e-9)


@pytest.mark.parametrize("bonds", ["flexible", "tangential", "rigid", "lubrication"])
def test_trajectory_does_not_depend_on_skin_cell_grid_or_rebuild_times(bonds):
    """The Verlet list is ordered by (i, j), so the pairs that act meet the force loop and the projections
    in the same order whatever the skin, the cell grid and the steps the list was rebuilt at: 200-sphere
    15 mV gels (4 nm contact, the largest step) with skins 0.3, 0.5 and 0.9 a (rebuild counts differing
    several-fold) and a coarser cell grid end bit for bit at the same positions."""
    from polypack.generate import brownian as B

    p = pp_dlvo(0.015, minimum_separation=4e-9)
    n = 200
    L = p.radius * (4 * n * np.pi / (3 * 0.4)) ** (1 / 3)
    pos0 = B._initial_positions(n, p.radius, L, 2 * p.debye_length, 3)
    kw = dict(time_step=1.37e-5, bond_width=4e-9, seed=7)
    if bonds == "lubrication":
        kw.update(hydrodynamics="lubrication")
    else:
        kw.update(bonds=bonds)
    out, rebuilds = [], []
    for skin, coarse in ((0.3, False), (0.5, False), (0.9, False), (0.5, True)):
        sim = B.BrownianSimulation(pos0, L, p, skin=skin, **kw)
        if coarse:
            sim._ncell = np.maximum(sim._ncell // 2, 1)
        sim.run(400)
        out.append(np.concatenate([sim.positions.ravel(), sim.orientations.ravel()]))
        rebuilds.append(sim.rebuilds)
        assert sim.n_bonds > 10
    assert rebuilds[0] > 2 * rebuilds[2] > 0, rebuilds
    for o in out[1:]:
        np.testing.assert_array_equal(o, out[0])


def pp_dlvo(psi, **kw):
    import polypack as pp

    return pp.generate.dlvo_parameters(psi, **kw)


def test_default_skin_grows_with_the_step_within_the_half_box():
    """BrownianSimulation's default skin: 0.4 a at the default step, 30 rms steps at the largest one
    (the rebuild interval), but never past half the box (20 spheres: L/2 = 2.97 a, cutoff 2.5 a)."""
    from polypack.generate import brownian as B

    p = pp_dlvo(0.015, minimum_separation=4e-9)
    skins = {}
    for n in (20, 200):
        L = p.radius * (4 * n * np.pi / (3 * 0.4)) ** (1 / 3)
        pos = B._initial_positions(n, p.radius, L, 2 * p.debye_length, 1)
        for dt in (None, 1.37e-5):
            sim = B.BrownianSimulation(pos, L, p, time_step=dt, bond_width=4e-9)
            skins[n, dt] = (sim._params[bd.P_SKIN], 30 * sim.rms_step / p.radius, 0.5 * L / p.radius - 2.5)
    assert skins[200, None][0] == 0.4 and skins[20, None][0] == 0.4
    s, steps30, room = skins[200, 1.37e-5]
    assert s == pytest.approx(steps30) and 0.5 < s < 0.7
    s, steps30, room = skins[20, 1.37e-5]
    assert room < steps30 and s == pytest.approx(room)


def _pair_forces(t2, tp, p, table, r):
    """The pair loop's force (kT/a, > 0 repulsive) of one unbonded pair at each centre distance in ``r``
    (flexible kernels' branch of bd._central_forces, one call: pair k is spheres 2k, 2k + 1 on a line
    parallel to x, 10 radii from the next pair; ``table`` the h table, read below the r² table's start)."""
    n = r.size
    pos = np.zeros((2 * n, 3))
    pos[1::2, 0] = r
    pos[:, 1] = 10.0 * np.repeat(np.arange(n), 2)
    f = np.zeros((2 * n, 3))
    k = np.arange(n, dtype=np.int64)
    bd._central_forces(pos, np.full(3, 10.0 * n + 100.0), p, 2 * k + 1, 2 * k, k, np.zeros((n, 3)),
                       np.zeros(n, np.uint8), table, t2, tp, f, bd._NO_LABELS, False)
    np.testing.assert_array_equal(f[0::2, 0], -f[1::2, 0])
    assert not f[:, 1:].any()
    return f[1::2, 0]


def _tables():
    """The force tables of three production set-ups (N = 60, only the tables are used): the
    repulsive suspension of benchmarks/bench_brownian.py's rate part, the default 15 mV gel and
    the seed study's model A at 0 and 15 mV (4 nm contact, the largest step)."""
    import polypack as pp
    from polypack.generate import brownian as B

    out = []
    a = 0.25e-6
    lam = a / 40
    ps = pp.generate.dlvo_parameters(0.03, hamaker=0.0, debye_length=lam)
    out.append(("suspension", B.BrownianSimulation(np.zeros((60, 3)), 20 * a, ps, bond_width=None,
                                                   cutoff=(2.0 + 30 * lam / a) * a)))
    out.append(("gel 15 mV", B.BrownianSimulation(np.zeros((60, 3)), 20 * a, pp.generate.dlvo_parameters(0.015))))
    for psi in (0.0, 0.015):
        pa = pp.generate.dlvo_parameters(psi, minimum_separation=4e-9)
        out.append((f"model A {psi * 1e3:.0f} mV", B.BrownianSimulation(
            np.zeros((60, 3)), 20 * a, pa, time_step=1.37e-5, bond_width=4e-9, bonds="tangential")))
    return out


def _drift_cap(f, h, p):
    """bd._cap_attraction by hand: an attraction ``f`` at gap ``h`` closes at most P_CAP_DRIFT h per step."""
    cap, dt, uc = p[bd.P_CAP_DRIFT], p[bd.P_DT], p[bd.P_LUB_RANGE]
    if not (cap > 0 and dt > 0):
        return f
    fmax = cap * np.maximum(h, 0.0) / (2.0 * dt)
    if uc > 0:
        fmax = fmax * np.array([bd.lubrication_beta(x, uc)[0] for x in h])
    return np.where(-f > fmax, -fmax, f)


@pytest.mark.parametrize("case", range(4))
def test_r2_force_table_error_against_the_h_table_and_the_exact_dlvo_force(case):
    """The pair loop's force (F/r linear in s = r^2, bd._force_table_r2) against the h table it is
    resampled from (bd._pair_force, the model force of the h grid) and against the exact DLVO force,
    on 4000 distances from the table start to the cutoff, both without the drift cap.  Measured (max over
    r of |ΔF| / max|F| where the cap does not bind): vs the h table 1.9e-7 / 6.3e-6 / 2.4e-7 / 8.5e-7
    (suspension / gel 15 mV / model A 0 / 15 mV), vs exact DLVO 2.1e-7 / 1.0e-5 / 3.1e-7 / 1.1e-6, where the
    h table alone is 2.1e-7 / 1.0e-5 / 3.0e-7 / 1.1e-6 off: the resampling adds less than the h grid's own
    error.  Bounds: per point against the h table 2e-5 of the local max|F| (below), 2.5e-5 max|F| overall,
    and against exact DLVO at most 2 x the h table's own error + 1e-7 max|F|.  With the cap the loop's
    force is its own uncapped force capped exactly, at r (to round-off), and below the table's start (an
    overlap beyond it) it is the h table's force (capped), as in the rigid kernel."""
    from scipy.ndimage import maximum_filter1d

    from polypack.generate.dlvo import dlvo_force

    name, sim = _tables()[case]
    p, table = sim._params, sim._table
    t2, tp = bd._force_table_r2(table, p)
    lo, rc = p[bd.P_TAB_LO], p[bd.P_R_CUT]
    r = np.linspace(2.0 + lo, rc, 4001)[:-1]
    args = (table, lo, 1.0 / p[bd.P_TAB_DH])
    fk = _pair_forces(t2, tp, p, table, r)
    q, tq = p.copy(), tp.copy()
    q[bd.P_CAP_DRIFT] = 0.0
    tq[3] = -1.0
    free = _pair_forces(t2, tq, q, table, r)  # the loop's force without the cap
    fh = np.array([bd._pair_force(x - 2.0, *args, 0.0, 0.0) for x in r])
    fe = dlvo_force(r * sim.parameters.radius, sim.parameters) * sim.parameters.radius / sim.parameters.kT
    # where the cap binds (near contact in the gels) the model force is the cap, not DLVO: the exact
    # comparison and the scale max|F| are taken where it does not (decided on the h table: a sample at the
    # threshold only moves between the sets, the bounds hold on both)
    uncapped = _drift_cap(fh, r - 2.0, p) == fh
    scale = np.abs(fe[uncapped]).max()
    err = np.abs(free - fh)
    # per point, against the force's own size nearby (max |F| within 0.01 radii: the error of a linear
    # interpolant follows the local force and its curvature), so the barrier and the secondary minimum, where
    # |F| is far below its contact maximum, are held to their own force: measured max 1.2e-6 / 5.2e-6 /
    # 2.4e-6 / 3.1e-6 of it
    local = maximum_filter1d(np.abs(fh), 2 * int(np.ceil(0.01 / (r[1] - r[0]))) + 1)
    assert (err <= 2e-5 * local).all(), (name, r[np.argmax(err / local)], (err / local).max())
    assert err[uncapped].max() < 2.5e-5 * scale, name
    e_table = np.abs(free - fe)[uncapped].max()
    e_h = np.abs(fh - fe)[uncapped].max()
    assert e_table < 2.0 * e_h + 1e-7 * scale and e_table < 2.5e-5 * scale, name
    # the drift cap, exact at r, on the loop's own uncapped force (no sample can fall between two interpolants)
    np.testing.assert_allclose(fk, _drift_cap(free, r - 2.0, p), rtol=1e-12, atol=1e-12 * scale, err_msg=name)
    if case > 0:
        assert (fk != free).any(), name  # the cap binds somewhere (the gels)
    # below the table's start: the h table's force (F clamped at the first entry, capped), not F/r clamped
    r_lo = 2.0 + lo
    below = np.linspace(1.0, r_lo, 60, endpoint=False)
    expect = np.array([bd._pair_force(x - 2.0, *args, p[bd.P_CAP_DRIFT], p[bd.P_DT], p[bd.P_LUB_RANGE])
                       for x in below])
    np.testing.assert_allclose(_pair_forces(t2, tp, p, table, below), expect, rtol=1e-12, atol=1e-12 * scale,
                               err_msg=name)
    if case == 0:  # repulsive: F/r clamped would be F(r_lo) r / r_lo, up to 47 % weaker here
        assert expect.min() > 0 and np.ptp(expect) == 0.0


@pytest.mark.parametrize("case", range(1, 4))
def test_r2_force_table_takes_the_drift_cap_wherever_it_can_bind(case):
    """Pairs with s = r^2 above the table's s_cap skip the drift-cap test: on a dense grid from s_cap to
    the cutoff (25 points per r² table interval) the loop's force equals, to round-off, that of the
    same loop taking the exact cap at every pair (s_cap = inf), and the cap does bind just inside s_cap
    (so s_cap is not a trivially safe 'everything')."""
    name, sim = _tables()[case]
    p, table = sim._params, sim._table
    t2, tp = bd._force_table_r2(table, p)
    s_cap = tp[3]
    assert s_cap > 4.0, name
    rc2 = p[bd.P_R_CUT] ** 2
    ds = 1.0 / tp[1]
    npts = int(25 * np.ceil((rc2 - s_cap) / ds))
    r = np.sqrt(np.linspace(s_cap, rc2, npts, endpoint=False))
    exact = tp.copy()
    exact[3] = np.inf
    fk = _pair_forces(t2, tp, p, table, r)
    fx = _pair_forces(t2, exact, p, table, r)
    np.testing.assert_allclose(fk, fx, rtol=1e-13, atol=0, err_msg=name)
    inside = np.sqrt(np.linspace(tp[0], s_cap, 2001))
    none = tp.copy()
    none[3] = -1.0
    f_none = _pair_forces(t2, none, p, table, inside)
    bind = np.abs(_pair_forces(t2, tp, p, table, inside) - f_none) > 1e-9 * np.abs(f_none).max()
    assert bind[-200:].any(), name  # within 10 % of the capped range of s_cap
    # no cap when the step or the cap fraction is zero
    q = p.copy()
    q[bd.P_CAP_DRIFT] = 0.0
    assert bd._force_table_r2(table, q)[1][3] == -1.0


def test_r2_force_table_is_as_fine_as_asked_whatever_the_h_table_length():
    """bd._force_table_r2's spacing in s is at most the h table's at its start over R2_REFINE (ds <= 2 r_lo dh /
    R2_REFINE) for 64 to 2^20 h table points: the interval limit grows with a long table (2^20 points over
    the model-A range ask for 2.4e6 intervals, beyond R2_MAX_INTERVALS), and a short one gets at least
    R2_MIN_INTERVALS."""
    p = np.zeros(bd.N_PARAMS)
    lo, rc = 0.004, 2.6
    p[bd.P_TAB_LO] = lo
    p[bd.P_R_CUT] = rc
    counts = []
    for npts in (64, 8192, 1 << 20):
        dh = (rc - 2.0 - lo) / (npts - 1)
        p[bd.P_TAB_DH] = dh
        t2, tp = bd._force_table_r2(np.linspace(-1.0, 1.0, npts), p)
        assert tp[0] == (2.0 + lo) ** 2 and t2.size == tp[2] + 2
        assert (rc * rc - tp[0]) / tp[2] == pytest.approx(1.0 / tp[1], rel=1e-12)
        assert 1.0 / tp[1] <= 2.0 * (2.0 + lo) * dh / bd.R2_REFINE * (1 + 1e-12), npts
        counts.append(tp[2])
    assert counts[0] == bd.R2_MIN_INTERVALS and counts[2] > 2 * bd.R2_MAX_INTERVALS


@pytest.mark.parametrize("model", ["flexible", "tangential", "lubrication", "suspension"])
def test_a_run_continues_bit_for_bit_across_kernel_calls(model):
    """40 steps in one kernel call or in calls of 25 and 15 give the same positions bit for bit: the
    generator's state (held in registers during a pass, bd._u64) is stored back, and nothing else a
    call rebuilds (Verlet list, r² table, near list) changes the trajectory."""
    import polypack as pp
    from polypack.generate import brownian as B

    p = pp.generate.dlvo_parameters(0.0 if model == "suspension" else 0.015,
                                     hamaker=0.0 if model == "suspension" else None)
    a = p.radius
    n = 150
    box = a * (4 * n * np.pi / (3 * 0.4)) ** (1 / 3)
    pos = B._initial_positions(n, a, box, 2 * p.debye_length, 1)
    kw = {"tangential": dict(bonds="tangential"), "lubrication": dict(hydrodynamics="lubrication"),
          "suspension": dict(bond_width=None)}.get(model, {})
    out = []
    dt = (0.5 * p.debye_length) ** 2 / (2 * p.diffusion_coefficient)
    for chunks in ((40,), (25, 15)):
        sim = B.BrownianSimulation(pos, box, p, seed=4, time_step=dt, **kw)
        for c in chunks:
            sim.run(c)
        out.append(np.concatenate([sim.positions.ravel(), sim.orientations.ravel()]))
    assert not np.array_equal(out[0][:3 * n], pos)
    np.testing.assert_array_equal(out[0], out[1])


@pytest.mark.parametrize("kernel", ["run", "tangential", "lubrication"])
def test_the_noise_is_the_generator_stream_in_order_across_steps(kernel):
    """Free spheres (no forces: the pair table is zero): two steps move each coordinate by sqrt(2 dt) times
    the ziggurat normals of the generator's state (bd.fill_normals from the same state), in order:
    per step 3N translational normals and, in run_tangential with rotation on, 3N rotational ones
    after them, which turn each sphere's orientation by Rodrigues' rotation of sqrt(2 (3/4) dt) times
    them; the state left after the call is the stream's state after those draws.  "lubrication": run with
    a lubrication range 0.3 and one listed pair 2.8 apart (inside the list's reach 2.9, beyond 2 + 0.3), so
    that the lubricated translation (bd._translate's second branch) runs, with no lubricated pair."""
    n = 5
    pos0 = np.array([[10.0 + 15.0 * k, 20.0, 30.0 + 7.0 * k] for k in range(n)])
    box = np.full(3, 100.0)
    p = np.zeros(bd.N_PARAMS)
    p[bd.P_DT] = 1e-3
    p[bd.P_NOISE] = np.sqrt(2e-3)
    p[bd.P_R_CUT] = 2.5
    p[bd.P_SKIN] = 0.4
    p[bd.P_BOND_WIDTH] = -1.0
    p[bd.P_SWEEPS] = 4
    p[bd.P_PROJ_TOL] = 1e-9
    p[bd.P_TAB_LO] = 0.0
    p[bd.P_TAB_DH] = 0.1
    p[bd.P_ROTATE] = 1.0
    if kernel == "lubrication":
        p[bd.P_LUB_RANGE] = 0.3
        pos0[1] = pos0[0] + [2.8, 0.0, 0.0]
        pi, _, _, _ = bd._build(pos0, box, p, np.zeros((n, 8), np.int64), np.zeros(n, np.int64),
                                np.array([3, 3, 3], np.int64))
        assert pi.size == 1  # the lubricated branch runs (a listed pair), its pair beyond the range
    rng = np.array([11, 22, 33, 44], np.uint64)
    per_step = 3 * n * (2 if kernel == "tangential" else 1)
    g = np.empty(2 * per_step + 1)
    ref_state = rng.copy()
    bd.fill_normals(ref_state, np.zeros(bd.N_STATE), g)
    pos = pos0.copy()
    args = (pos, box, p, np.zeros(bd.N_STATE), np.zeros(bd.N_ISTATE, np.int64), np.zeros(4), np.zeros((4, 2), np.int64),
            np.zeros((n, 8), np.int64), np.zeros(n, np.int64), np.array([3, 3, 3], np.int64), rng, 2)
    orient = np.zeros((n, 3))
    orient[:, 2] = 1.0
    if kernel == "tangential":
        assert bd.run_tangential(*args, np.zeros((4, 6)), orient) == 0
    else:
        assert bd.run(*args) == 0
    noise = p[bd.P_NOISE]
    expect = (pos0 + noise * g[:3 * n].reshape(n, 3)) + noise * g[per_step:per_step + 3 * n].reshape(n, 3)
    np.testing.assert_array_equal(pos, expect)
    if kernel == "tangential":
        rnoise = noise * np.sqrt(bd.SPHERE_ROT_MOBILITY)
        o = np.tile([0.0, 0.0, 1.0], (n, 1))
        for step in range(2):
            turn = rnoise * g[step * per_step + 3 * n:(step + 1) * per_step].reshape(n, 3)
            o = np.array([np.reshape(bd._rodrigues(*t), (3, 3)) @ x for t, x in zip(turn, o)])
        assert np.abs(o - [0.0, 0.0, 1.0]).max() > 1e-3  # the orientations turned
        np.testing.assert_allclose(orient, o, rtol=0, atol=1e-14)
    nxt = np.empty(1)
    bd.fill_normals(rng, np.zeros(bd.N_STATE), nxt)  # the kernel's state continues the stream
    assert nxt[0] == g[-1]
