"""Pair statistics of 2D packs (disks): RDF, K function, shell and window counts, contact values.

Checked against exact results: triangular and square lattices (integer shell populations), the
binomial law of a fixed-N Poisson pattern, and a brute-force distance-matrix oracle.
"""

import numpy as np
import pytest
from _oracles import distance_matrix
from scipy import stats

import polypack as pp


def triangular(nx=12, ny=12, d=1.0):
    """Triangular lattice of spacing d, touching disks (radius d/2); the periodic box fits it exactly."""
    pts = [((i + 0.5 * (j % 2)) * d, j * d * np.sqrt(3) / 2) for j in range(ny) for i in range(nx)]
    return pp.Packing(np.array(pts), np.full(nx * ny, 0.5 * d), [nx * d, ny * d * np.sqrt(3) / 2])


def square(n=14, d=1.0, radius=0.3):
    g = np.array([(i * d, j * d) for i in range(n) for j in range(n)], float)
    return pp.Packing(g, np.full(n * n, radius), [n * d, n * d])


def poisson2d(rng, n, side, n_species=1):
    sp = rng.integers(0, n_species, n) if n_species > 1 else None
    return pp.Packing(rng.random((n, 2)) * side, np.full(n, 1e-5), [side, side], species=sp)


def test_shell_count_triangular_and_square_lattices():
    """I(r): 6, 6, 6, 12 neighbours at d, sqrt(3) d, 2 d, sqrt(7) d (triangular); 4, 4, 4, 8 at 1, sqrt 2, 2, sqrt 5 (square)."""
    s = pp.analysis.ShellCount(r_max=2.9, dr=0.01).compute(triangular())
    for r, n in ((1.0, 6), (np.sqrt(3), 6), (2.0, 6), (np.sqrt(7), 12)):
        k = int(np.floor(r / 0.01 + 1e-9))
        assert s.I[k] == pytest.approx(n, abs=1e-12), r
    assert s.cumulative[-1] == pytest.approx(30, abs=1e-12)  # every shell below 2.9 d: 6+6+6+12
    q = pp.analysis.ShellCount(r_max=2.5, dr=0.01).compute(square())
    for r, n in ((1.0, 4), (np.sqrt(2), 4), (2.0, 4), (np.sqrt(5), 8)):
        assert q.I[int(np.floor(r / 0.01 + 1e-9))] == pytest.approx(n, abs=1e-12), r
    assert q.cumulative[-1] == pytest.approx(20, abs=1e-12)


def test_rdf_triangular_lattice_first_shell_exact():
    """Histogram RDF of the triangular lattice: 6 neighbours at d in the bin [d, d + dr), so
    g = 6 A / ((N - 1) pi ((d + dr)^2 - d^2)) there and 0 between shells."""
    pk = triangular()
    dr = 0.02
    g = pp.analysis.RDF(r_max=2.5, dr=dr).compute(pk)
    k = int(np.floor(1.0 / dr + 1e-9))
    area = float(np.prod(pk.box))
    expected = 6 * area / ((pk.n - 1) * np.pi * ((1.0 + dr) ** 2 - 1.0))
    assert g.g[k] == pytest.approx(expected, rel=1e-12)
    between = (g.r > 1.05) & (g.r < 1.7)
    assert np.all(g.g[between] == 0.0)
    # the K function steps by 6 A/(N - 1) at every member of a 6-shell
    kf = pp.analysis.KFunction(r_max=2.5, dr=dr).compute(pk)
    step = area / (pk.n - 1)
    assert kf.K[int(round(1.5 / dr)) - 1] == pytest.approx(6 * step, rel=1e-12)
    assert kf.K[int(round(1.9 / dr)) - 1] == pytest.approx(12 * step, rel=1e-12)


def test_pair_counts_match_brute_force_oracle_2d():
    """Exact counts: the RDF's pair counts per species pair equal a numpy histogram of the oracle distances."""
    rng = np.random.default_rng(4)
    n, side = 600, 30.0
    pk = poisson2d(rng, n, side, n_species=2)
    r_max, dr = 7.0, 0.25
    g = pp.analysis.RDF(r_max=r_max, dr=dr).compute(pk)
    d = distance_matrix(pk.positions, pk.box)
    edges = np.arange(int(round(r_max / dr)) + 1) * dr
    for a in range(2):
        for b in range(2):
            sel = d[np.ix_(pk.species == a, pk.species == b)]
            if a == b:
                sel = sel[~np.eye(sel.shape[0], dtype=bool)]
            ref = np.histogram(sel.ravel(), bins=edges)[0]
            np.testing.assert_array_equal(g.pair_counts[a, b], ref)


def test_poisson_2d_rdf_k_and_windows_are_ideal():
    """Fixed-N Poisson disks: E g = 1 (finite-size normalisation), E K = pi r^2, and the window count of
    every centre is Binomial(N - 1, pi R^2 / A) exactly."""
    rng = np.random.default_rng(9)
    n, side = 4000, 60.0
    g = pp.analysis.RDF(r_max=6.0, dr=0.5)
    kf = pp.analysis.KFunction(r_max=6.0, dr=0.5)
    w = pp.analysis.WindowCounts(window_radius=2.5e5, reference="species")  # R_h a = 2.5 length units
    for k in range(6):
        pk = poisson2d(rng, n, side)
        g.compute(pk, reset=(k == 0))
        kf.compute(pk, reset=(k == 0))
        w.compute(pk, reset=(k == 0))
    z = (g.g - 1.0) / g.g_err
    assert np.all(np.abs(z) < 4.5), z  # each point within its own error bar (4.5 sigma over 12 points)
    assert abs(np.mean(g.g) - 1.0) < 0.02
    assert np.all(np.abs(kf.K / kf.poisson - 1.0) < 0.03)
    assert np.allclose(kf.poisson, np.pi * kf.r**2)
    assert np.all(np.abs(kf.L - kf.r) < 0.03 * kf.r + 0.01)
    p_win = np.pi * 2.5**2 / side**2
    assert w.mean == pytest.approx((n - 1) * p_win, rel=0.01)
    assert w.variance == pytest.approx((n - 1) * p_win * (1 - p_win), rel=0.06)
    # 24 000 overlapping windows: the binomial sd of one p (~0.0018) times ~2 for the overlap, 2 sigma
    ref = stats.binom.pmf(w.n_h, n - 1, p_win)
    assert np.max(np.abs(w.p - ref)) < 0.008


def test_window_counts_triangular_lattice():
    # a window of 1.1 d holds the 6 nearest centres exactly; 1.8 d adds the sqrt(3) d shell
    pk = triangular()
    for rh, n in ((2.2, 6), (3.6, 12)):  # R_h in units of the radius d/2
        w = pp.analysis.WindowCounts(window_radius=rh).compute(pk)
        assert w.mean == n and w.variance == 0.0


def test_contact_value_2d_against_lattice_and_rsa_limit():
    """The triangular lattice has all 6 N/2 contacts at x = 1: the histogram value in the first bin of a
    1 % window is 6 A / ((N - 1) pi (2r)^2 (1.01^2 - 1))."""
    pk = triangular()
    v = pp.analysis.contact_value(pk, width=0.01, n_bins=1, degree=0)[(0, 0)]
    area = float(np.prod(pk.box))
    assert v == pytest.approx(6 * area / ((pk.n - 1) * np.pi * (1.01**2 - 1.0)), rel=1e-9)


def test_rdf_of_2d_pack_and_mixing_dimensions_rejected():
    pk = pp.pack(np.full(300, 0.5), 0.6, seed=1, dim=2, growth_rate=0.05)
    g = pp.analysis.RDF(r_max=4.0, dr=0.05).compute(pk)
    assert np.all(g.g[g.r < 0.99] == 0.0)  # no overlaps: nothing inside contact
    assert g.g[(g.r > 1.0) & (g.r < 1.05)].mean() > 3.0  # the contact peak of a dense disk fluid
    assert abs(g.g[g.r > 3.0].mean() - 1.0) < 0.1
    with pytest.raises(pp.InvalidInputError, match="2D but earlier realizations were 3D"):
        pp.analysis.RDF(r_max=1.0, dr=0.1).compute(pp.pack(np.full(50, 0.5), 0.3, seed=1)).compute(pk, reset=False)
    walls = pp.Packing(np.array([[2.0, 2.0], [5.0, 5.0]]), [0.5, 0.5], [10.0, 10.0], periodic=(True, False))
    with pytest.raises(pp.InvalidInputError, match="periodic on every axis"):
        pp.analysis.RDF(r_max=2.0, dr=0.1).compute(walls)
