"""RDF and partial RDFs: Poisson points, lattices (seed 000 §5.2 numbers), freud, oracles."""

import numpy as np
import pytest

import polypack as pp
from _analysis_packs import lattice, poisson, rsa
from polypack.errors import InvalidInputError


@pytest.fixture(scope="module")
def poisson2():
    return poisson(np.random.default_rng(7), 30000, 20.0, n_species=2)


@pytest.fixture(scope="module")
def bidisperse():
    return rsa(np.random.default_rng(3), 1500, 16.0, radii_choices=(0.6, 0.3), weights=(0.5, 0.5))


def test_poisson_total_and_partials_are_one(poisson2):
    pk = poisson2
    g = pp.analysis.RDF(r_max=5.0, dr=0.25).compute(pk)
    n = pk.n
    vol = pk.box_volume
    edges = np.arange(21) * 0.25
    shell = 4 / 3 * np.pi * np.diff(edges**3)
    # independent error: unordered pairs expected in each shell
    exp_total = 0.5 * n * (n - 1) / vol * shell
    assert np.allclose(g.r, 0.5 * (edges[1:] + edges[:-1]))
    assert np.all(np.abs(g.g - 1) < 5 / np.sqrt(exp_total))
    assert abs(np.average(g.g, weights=exp_total) - 1) < 3 / np.sqrt(exp_total.sum())
    cnt = pk.species_counts
    for k in range(2):
        for m in range(2):
            pairs = cnt[k] * (cnt[m] - (k == m)) / vol * shell / (2 if k == m else 1)
            assert np.all(np.abs(g.partial[(k, m)] - 1) < 5 / np.sqrt(pairs)), (k, m)


def test_total_is_weighted_sum_of_partials(bidisperse):
    pk = bidisperse
    g = pp.analysis.RDF(r_max=4.0, dr=0.05).compute(pk)
    cnt = pk.species_counts.astype(float)
    w = np.outer(cnt, cnt) - np.diag(cnt)
    tot = sum(w[k, m] * g.partial[(k, m)] for k in range(2) for m in range(2)) / w.sum()
    assert np.allclose(tot, g.g, rtol=1e-12, atol=1e-12)
    assert np.array_equal(g.partial[(0, 1)], g.partial[(1, 0)])
    # hard core: no pair closer than contact
    assert np.all(g.partial[(0, 0)][g.r < 1.2 - 0.05] == 0)
    assert np.all(g.partial[(0, 1)][g.r < 0.9 - 0.05] == 0)
    assert g.partial[(0, 1)][np.searchsorted(g.r, 0.9)] > 1.0


def test_matches_freud_total_and_partials(bidisperse):
    import freud  # in the test extra (freud-analysis): a missing install fails, never skips
    pk = bidisperse
    L = float(pk.box[0])
    box = freud.box.Box.cube(L)
    P = pk.positions - L / 2
    for mode, ours in (("exact", "seed"), ("finite_size", "finite_size")):
        g = pp.analysis.RDF(r_max=5.0, dr=0.05, normalization=ours).compute(pk)
        f = freud.density.RDF(bins=100, r_max=5.0, normalization_mode=mode).compute((box, P))
        assert np.allclose(f.bin_centers, g.r, atol=1e-5)
        assert np.allclose(f.rdf, g.g, rtol=2e-5, atol=1e-6), mode
        for k in range(2):
            for m in range(2):
                pts, q = P[pk.species == m], P[pk.species == k]
                # distinct point sets: the ideal pair number is N_k N_m in both of our
                # modes; freud's finite_size mode assumes shared points, so use "exact"
                fm = mode if k == m else "exact"
                f = freud.density.RDF(bins=100, r_max=5.0, normalization_mode=fm)
                f.compute((box, pts), query_points=None if k == m else q)
                assert np.allclose(f.rdf, g.partial[(k, m)], rtol=2e-5, atol=1e-6), (mode, k, m)


@pytest.mark.parametrize("delta_R, printed", [(0.1, 9.55), (0.01, 95.5), (0.005, 190.9)])
def test_simple_cubic_contact_values_of_seed(delta_R, printed):
    """§5.2 of seed 000: g+(2a, dR) = 9.55, 95.5, 190.9 for a simple cubic lattice."""
    a = 0.5
    sc = lattice("sc", 6, a=2 * a)
    gr = pp.analysis.RDF(r_max=2.0, dr=delta_R * a, method="right", normalization="seed").compute(sc)
    i = int(np.argmin(np.abs(gr.r - 2 * a)))
    assert gr.r[i] == pytest.approx(2 * a)
    assert gr.g[i] == pytest.approx(printed, rel=2e-3)
    # Eqs. (15)-(16): the central difference at the discontinuity is half the right one
    gc = pp.analysis.RDF(r_max=2.0, dr=2 * delta_R * a, method="central", normalization="seed").compute(sc)
    j = int(np.argmin(np.abs(gc.r - 2 * a)))
    assert gc.g[j] == pytest.approx(0.5 * gr.g[i], rel=1e-12)


def test_lattice_shell_counts_from_histogram():
    """Histogram counts per sphere reproduce the exact neighbour shells of SC/BCC/FCC."""
    shells = {
        "sc": [(1.0, 6), (np.sqrt(2), 12), (np.sqrt(3), 8), (2.0, 6), (np.sqrt(5), 24)],
        "bcc": [(np.sqrt(3) / 2, 8), (1.0, 6), (np.sqrt(2), 12), (np.sqrt(11) / 2, 24), (np.sqrt(3), 8)],
        "fcc": [(1 / np.sqrt(2), 12), (1.0, 6), (np.sqrt(1.5), 24), (np.sqrt(2), 12), (np.sqrt(2.5), 24)],
    }
    for kind, exp in shells.items():
        pk = lattice(kind, 5)
        g = pp.analysis.RDF(r_max=2.4, dr=0.01).compute(pk)
        per_sphere = g.pair_counts[0, 0] / pk.n
        for r0, count in exp:
            k = int(np.floor(r0 / 0.01 + 1e-9))
            assert per_sphere[k] == count, (kind, r0)
        # everything below r_max, against a brute-force minimum-image oracle
        d = pk.positions[:, None] - pk.positions[None]
        d -= pk.box * np.round(d / pk.box)
        d = np.sqrt((d**2).sum(-1))
        assert per_sphere.sum() * pk.n == np.count_nonzero((d > 0) & (d < 2.4))
        assert per_sphere.sum() == {"sc": 56, "bcc": 112, "fcc": 224}[kind]


def test_k_derivative_and_histogram_agree(bidisperse):
    pk = bidisperse
    h = pp.analysis.RDF(r_max=5.0, dr=0.1).compute(pk)
    c = pp.analysis.RDF(r_max=5.0, dr=0.1, method="central").compute(pk)
    # central(r) uses the shell [r - dr/2, r + dr/2); the histogram is reported at shell centres
    assert np.all(np.diff(c.r) > 0)
    # same counts, volumes differ by O(dr^2/r^2): 4 pi r^2 dr vs exact shell volume
    g_hist_at_c = np.interp(c.r, h.r, h.g)
    mask = c.r > 2.0
    err = np.interp(c.r, h.r, h.g_err)[mask]
    # measured: at most 1.6 errors apart (interpolation between shell centres adds ~g'' dr^2 / 8)
    assert np.all(np.abs(c.g[mask] - g_hist_at_c[mask]) < 4 * err)
    # exact: the central estimate at r counts the pairs of the two half-width shells around r,
    # so g_c(r) 4 pi r^2 dr = sum of g_hist * exact shell volume over those shells (dr/2 grid)
    h2 = pp.analysis.RDF(r_max=5.0, dr=0.05).compute(pk)
    edges = np.arange(101) * 0.05
    vol = 4 / 3 * np.pi * np.diff(edges**3)
    k = np.arange(1, 50)
    np.testing.assert_allclose(c.r, k * 0.1, rtol=1e-12)
    lhs = c.g * 4 * np.pi * c.r**2 * 0.1
    rhs = h2.g[2 * k - 1] * vol[2 * k - 1] + h2.g[2 * k] * vol[2 * k]
    np.testing.assert_allclose(lhs, rhs, rtol=1e-12, atol=1e-12)
    assert rhs.sum() > 0


def test_contact_scaled_matches_bruteforce_oracle():
    rng = np.random.default_rng(11)
    n, L = 300, 10.0
    rad = rng.uniform(0.2, 0.8, n)
    pk = pp.Packing(rng.random((n, 3)) * L, rad, L, species=(rad > 0.5).astype(int))
    g = pp.analysis.RDF(r_max=2.5, dr=0.1, scale="contact").compute(pk)
    d = pk.positions[:, None] - pk.positions[None]
    d -= L * np.round(d / L)
    d = np.sqrt((d**2).sum(-1))
    s = rad[:, None] + rad[None]
    x = d / s
    off = ~np.eye(n, dtype=bool)
    edges = np.linspace(0, 2.5, 26)
    shell = 4 / 3 * np.pi * np.diff(edges**3)
    for k in range(2):
        for m in range(2):
            sel = off & (pk.species[:, None] == k) & (pk.species[None] == m)
            cnt = np.histogram(x[sel], bins=edges)[0]
            ideal = (s[sel] ** 3).sum() / L**3 * shell
            assert np.allclose(g.partial[(k, m)], cnt / ideal, rtol=1e-10), (k, m)


def test_accumulation_pools_realizations():
    rng = np.random.default_rng(5)
    packs = [poisson(rng, 4000, 12.0, n_species=2) for _ in range(3)]
    acc = pp.analysis.RDF(r_max=4.0, dr=0.5)
    for p in packs:
        acc.compute(p, reset=False)
    assert acc.n_realizations == 3
    single = [pp.analysis.RDF(r_max=4.0, dr=0.5).compute(p) for p in packs]
    counts = sum(s.pair_counts.sum(axis=(0, 1)) for s in single)
    ideal = sum(p.n * (p.n - 1) / p.box_volume for p in packs)
    shell = 4 / 3 * np.pi * np.diff((np.arange(9) * 0.5) ** 3)
    assert np.allclose(acc.g, counts / (ideal * shell))
    assert np.all(np.isfinite(acc.g_err)) and np.all(acc.g_err > 0)
    assert np.allclose(acc.g_err, np.std([s.g for s in single], axis=0, ddof=1) / np.sqrt(3))
    acc.compute(packs[0])  # reset=True drops the others
    assert acc.n_realizations == 1


def test_scaled_coordinate_R_km(bidisperse):
    g = pp.analysis.RDF(r_max=4.0, dr=0.05).compute(bidisperse)
    a = g.species_radii
    assert np.allclose(a, [0.6, 0.3])
    assert np.allclose(g.R(0, 1), (g.r - 0.6) / 0.3 + 1)
    # contact of a k and an m sphere sits at R_km = 2 for every pair
    assert pp.analysis.scaled_coordinate(0.9, 0.6, 0.3) == pytest.approx(2.0)
    assert pp.analysis.scaled_coordinate(0.9, 0.3, 0.6) == pytest.approx(2.0)


def test_contact_value_of_boolean_model_is_one():
    """Poisson centres with finite radii: g = 1 in the contact-scaled coordinate."""
    rng = np.random.default_rng(2)
    n, L = 40000, 20.0
    rad = np.where(rng.random(n) < 0.5, 0.5, 0.25)
    pk = pp.Packing(rng.random((n, 3)) * L, rad, L, species=(rad < 0.4).astype(int))
    vals, errs = pp.analysis.contact_value(pk, width=0.1, n_bins=10, return_error=True)
    for key in [(0, 0), (0, 1), (1, 1)]:
        assert 0 < errs[key] < 0.3
        assert abs(vals[key] - 1) < 4 * errs[key], key
    assert vals[(0, 1)] == vals[(1, 0)]


def test_contact_value_detects_contacts():
    """FCC at contact: 12 touching neighbours per sphere all in the first bin."""
    pk = lattice("fcc", 4)
    s = 1 / np.sqrt(2)
    v = pp.analysis.contact_value(pk, width=0.01, n_bins=1, degree=0)
    expected = 12 * pk.box_volume / ((pk.n - 1) * s**3 * 4 / 3 * np.pi * (1.01**3 - 1))
    assert v[(0, 0)] == pytest.approx(expected, rel=1e-9)
    # a small expansion opens every gap by 2 %: nothing left within 1 % of contact
    loose = pk.replace(radii=pk.radii / 1.02)
    assert pp.analysis.contact_value(loose, width=0.01, n_bins=1, degree=0)[(0, 0)] == 0


def test_bad_input():
    rng = np.random.default_rng(0)
    pk = poisson(rng, 100, 5.0)
    with pytest.raises(InvalidInputError, match="half the smallest box"):
        pp.analysis.RDF(r_max=3.0, dr=0.1).compute(pk)
    for bad in (0.0, -0.1, float("nan")):
        with pytest.raises(InvalidInputError, match="dr="):
            pp.analysis.RDF(r_max=2.0, dr=bad)
    with pytest.raises(InvalidInputError, match="method"):
        pp.analysis.RDF(r_max=2.0, dr=0.1, method="left")
    g = pp.analysis.RDF(r_max=2.0, dr=0.1).compute(pk)
    with pytest.raises(InvalidInputError, match="unknown species pair"):
        g.partial[(0, 3)]
    with pytest.raises(InvalidInputError, match="unknown species pair"):
        pp.analysis.contact_value(pk, pairs=[(0, 2)])
    empty = pp.Packing(np.zeros((0, 3)), np.zeros(0), 5.0)
    with pytest.raises(InvalidInputError, match="at least 2 spheres"):
        pp.analysis.RDF(r_max=2.0, dr=0.1).compute(empty)
    with pytest.raises(pp.NotComputedError, match="RDF.g is not computed yet"):
        pp.analysis.RDF(r_max=2.0, dr=0.1).g
    with pytest.raises(InvalidInputError, match="Packing"):
        pp.analysis.RDF(r_max=2.0, dr=0.1).compute(np.zeros((4, 3)))


def test_plot_and_to_dict(bidisperse):
    import json

    g = pp.analysis.RDF(r_max=3.0, dr=0.1).compute(bidisperse)
    ax = g.plot()
    assert len(ax.lines) >= 4
    ax2 = g.plot(coordinate="R")
    assert ax2.get_xlabel() == "$R_{km}$"
    d = json.loads(json.dumps(g.to_dict()))
    assert d["estimator"] == "RDF" and set(d["partial"]) == {"0-0", "0-1", "1-1"}
    assert len(d["g"]) == len(d["r"]) == 30


def test_half_shell_kernel_equals_general_kernel():
    from polypack._kernels import analysis as kern

    for pk in (rsa(np.random.default_rng(9), 700, 12.0, radii_choices=(0.6, 0.3)), lattice("fcc", 8)):
        box = np.ascontiguousarray(pk.box)
        pos = np.ascontiguousarray(pk.positions)
        sp = np.ascontiguousarray(pk.species, dtype=np.int64)
        nc = np.array([6, 6, 6], np.int64)
        off = kern.half_shell_offsets(nc, box / nc, 2.5)
        assert off.shape[0] > 0
        fast = kern.pair_histogram_distance(pos, sp, box, pk.n_species, 2.5, 250, nc, off)
        slow = kern.pair_histogram(pos, np.ascontiguousarray(pk.radii), sp, box, pk.n_species, 2.5, 250, False, nc)
        assert np.array_equal(fast, slow)
        assert fast.sum() > 0


def test_size_classes_for_continuous_distributions():
    rng = np.random.default_rng(4)
    rad = rng.uniform(0.1, 0.4, 3000)
    pk = pp.Packing(rng.random((3000, 3)) * 15.0, rad, 15.0)
    pc = pp.analysis.size_classes(pk, edges=[0.1, 0.2, 0.3, 0.4])
    assert pc.n_species == 3
    assert np.all(pc.radii[pc.species == 0] >= 0.3) and np.all(pc.radii[pc.species == 2] < 0.2)
    assert np.array_equal(pc.positions, pk.positions)
    g = pp.analysis.RDF(r_max=4.0, dr=0.5).compute(pc)
    assert len(g.partial) == 9
    assert pp.analysis.size_classes(pk, n_classes=4).n_species == 4
    with pytest.raises(InvalidInputError, match="increasing"):
        pp.analysis.size_classes(pk, edges=[0.3, 0.2])
