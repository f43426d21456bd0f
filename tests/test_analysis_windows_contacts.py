"""Window counts p(n_h), shell count I(r) (Eq. 18) and contacts on exact configurations."""

import json

import numpy as np
import pytest
from scipy import stats

import polypack as pp
from _analysis_packs import lattice, poisson, rsa
from polypack.errors import InvalidInputError


def test_window_counts_poisson_are_poisson():
    """Other centres in a ball around a point of a fixed-N uniform pattern: Binomial(N-1, v/V)."""
    rng = np.random.default_rng(8)
    n, L, a = 20000, 20.0, 0.4
    pk = poisson(rng, n, L, radius=a)
    w = pp.analysis.WindowCounts(window_radius=5.0).compute(pk)
    q = 4 / 3 * np.pi * (5.0 * a) ** 3 / L**3
    pmf = stats.binom.pmf(w.n_h, n - 1, q)
    # the window counts add up to twice the number U of unordered pairs closer than 5a, and
    # U ~ Binomial(N (N-1)/2, q) (pair indicators sharing a point are uncorrelated on the
    # torus), so the mean count 2U/N has standard error sqrt(2 (N-1) q / N) = 0.09: 4 of them
    se = np.sqrt(2 * (n - 1) * q * (1 - q) / n)
    assert abs(w.mean - (n - 1) * q) < 4 * se
    assert np.all(np.abs(w.p - pmf) < 5 * np.sqrt(pmf * (1 - pmf) / n) + 1e-4)


def test_window_counts_lattice_exact():
    pk = lattice("fcc", 5)  # radius = nn / 2, nn = 1/sqrt(2)
    a = pk.radii[0]
    w = pp.analysis.WindowCounts(window_radius=1.05 / a * (1 / np.sqrt(2))).compute(pk)
    assert np.array_equal(w.n_h, np.arange(13)) and w.p[12] == 1.0
    w = pp.analysis.WindowCounts(window_radius=1.05 / a, include_self=True).compute(pk)
    assert w.p[-1] == 1.0 and w.n_h[-1] == 12 + 6 + 1  # shells at 0.707 and 1.0, plus itself
    assert w.partial[(0, 0)][-1] == 1.0
    assert json.loads(json.dumps(w.to_dict()))["mean"] == 19
    ax = w.plot()
    np.testing.assert_array_equal(ax.lines[0].get_ydata(), w.p)
    assert ax.get_xlabel() == "$n_h$" and ax.get_ylabel() == "$p(n_h)$"


def test_window_is_closed_on_its_boundary():
    """``d_ij <= R_h a`` counts (the documented closed window), the convention that lattice shells at
    exactly the window radius rely on.  Simple cubic, spacing 1, coordinates k + 1/2, radius 1/2 and
    R_h = 2: every distance, its periodic image and the window R_h a = 1 are exact in binary floating
    point, so the six neighbours at exactly the window radius count (an open window counts none), and
    for R_h one ulp below 2 none does."""
    g = np.arange(6) + 0.5
    pos = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    pk = pp.Packing(pos, np.full(len(pos), 0.5), 6.0)
    w = pp.analysis.WindowCounts(window_radius=2.0).compute(pk)
    assert np.all(w.counts == 6)
    w = pp.analysis.WindowCounts(window_radius=np.nextafter(2.0, 0.0)).compute(pk)
    assert np.all(w.counts == 0)


def test_window_species_partials_and_errors():
    rng = np.random.default_rng(3)
    pk = rsa(rng, 1000, 14.0, radii_choices=(0.6, 0.3), weights=(0.5, 0.5))
    w = pp.analysis.WindowCounts(window_radius=2.5).compute(pk)
    tot = w.counts
    # partial histograms are consistent with the totals: mean of (k, 0) + (k, 1) counts
    for k in range(2):
        m0 = np.sum(w.partial[(k, 0)] * np.arange(w.n_h.size))
        m1 = np.sum(w.partial[(k, 1)] * np.arange(w.n_h.size))
        assert m0 + m1 == pytest.approx(tot[pk.species == k].mean())
    with pytest.raises(InvalidInputError, match="half the smallest box"):
        pp.analysis.WindowCounts(window_radius=20.0).compute(pk)
    with pytest.raises(InvalidInputError, match="window_radius"):
        pp.analysis.WindowCounts(window_radius=0)


@pytest.mark.parametrize("kind, first", [("sc", 6), ("bcc", 8), ("fcc", 12)])
def test_shell_count_I_of_lattices(kind, first):
    pk = lattice(kind, 5)
    nn = pk.radii[0] * 2
    for dr in (0.1, 0.01, 0.005):  # Eq. (18): I does not depend on dr
        r, I = pp.analysis.lattice_shell_count(pk, r_max=2.0, dr=dr)
        k = int(np.floor(nn / dr + 1e-9))
        assert I[k] == first and I[:k].sum() == 0
    s = pp.analysis.ShellCount(r_max=2.0, dr=0.01).compute(pk)
    assert s.cumulative[int(np.floor(nn / 0.01 + 1e-9))] == first
    ax = s.plot(a=pk.radii[0])
    np.testing.assert_allclose(ax.lines[0].get_xdata(), s.r / pk.radii[0], rtol=1e-12)
    np.testing.assert_array_equal(ax.lines[0].get_ydata(), s.I)
    assert ax.get_xlabel() == "r / a" and ax.get_ylabel() == "I(r)"


@pytest.mark.parametrize("kind, z", [("sc", 6), ("bcc", 8), ("fcc", 12)])
def test_contacts_on_lattices(kind, z):
    pk = lattice(kind, 4)
    for shrink, expected in ((1.0, z), (1.005, z), (1.02, 0)):  # gap 0, 0.5 %, 2 % vs eps = 1 %
        c = pp.analysis.Contacts(tolerance=0.01).compute(pk.replace(radii=pk.radii / shrink))
        assert c.coordination == pytest.approx(expected)
        assert np.all(c.per_sphere == expected)
        assert c.pairs.shape == (pk.n * expected // 2, 2)
        if expected:
            assert np.all(c.pairs[:, 0] < c.pairs[:, 1])
            assert np.allclose(np.linalg.norm(c.branch_vectors, axis=1), c.distances)
            assert np.allclose(c.gaps, shrink - 1, atol=1e-12)
    # rattlers: every SC sphere has 6 >= 4 contacts; with 7 required all are rattlers
    c = pp.analysis.Contacts(tolerance=0.01).compute(pk)
    assert c.rattler_fraction == 0 and c.coordination_without_rattlers == pytest.approx(z)
    c = pp.analysis.Contacts(tolerance=0.01, min_contacts=z + 1).compute(pk)
    assert c.rattler_fraction == 1


def test_contacts_per_species_and_rattler_cascade():
    # chain of 3 touching spheres plus a touching pair elsewhere, two species
    L = 20.0
    pos = np.array([[1, 1, 1], [2, 1, 1], [3, 1, 1], [10, 10, 10], [10.8, 10, 10]], float)
    rad = np.array([0.5, 0.5, 0.5, 0.5, 0.3])
    sp = np.array([0, 0, 0, 0, 1])
    pk = pp.Packing(pos, rad, L, species=sp)
    c = pp.analysis.Contacts(tolerance=1e-9).compute(pk)
    assert c.coordination == pytest.approx(2 * 3 / 5)
    # species 0: 4 spheres with 1+2+1+1 = 5 contacts, 4 with species 0, 1 with species 1
    assert np.allclose(c.per_species, [[4 / 4, 1 / 4], [1.0, 0.0]])
    c2 = pp.analysis.Contacts(tolerance=1e-9, min_contacts=2).compute(pk)
    assert c2.rattler_fraction == 1.0  # the chain end-spheres drop, then the middle one
    d = json.loads(json.dumps(c.to_dict(include_list=True)))
    assert d["contact_number_histogram"] == [0, 4, 1]
    with pytest.raises(InvalidInputError, match="tolerance"):
        pp.analysis.Contacts(tolerance=-0.1)
    with pytest.raises(InvalidInputError, match="at least 1 spheres"):
        pp.analysis.Contacts().compute(pp.Packing(np.zeros((0, 3)), np.zeros(0), 5.0))


def test_contacts_accumulate():
    packs = [rsa(np.random.default_rng(s), 300, 8.0) for s in range(3)]
    c = pp.analysis.Contacts(tolerance=0.05)
    for pk in packs:
        c.compute(pk, reset=False)
    single = [pp.analysis.Contacts(tolerance=0.05).compute(pk) for pk in packs]
    z = [s.coordination for s in single]
    # each from its own contact list: 2 M / N
    assert z == [2 * len(s.pairs) / 300 for s in single]
    assert c.n_realizations == 3
    assert c.coordination == pytest.approx(np.mean(z), rel=1e-12)
    assert c.coordination_err == pytest.approx(np.std(z, ddof=1) / np.sqrt(3), rel=1e-12)
    assert c.coordination_err > 0
    assert np.array_equal(c.per_sphere, single[-1].per_sphere)  # lists are of the last realization
    ax = c.plot()
    heights = [b.get_height() for b in ax.patches]
    h = np.bincount(single[-1].per_sphere)
    assert np.allclose(heights, h / h.sum())
    assert ax.get_xlabel() and ax.get_ylabel()


def test_coordination_without_rattlers():
    """Simple cubic lattice at contact (6 contacts each) plus small spheres in some cube
    centres, too small to touch the corners: they are rattlers, and without them the
    coordination is exactly the lattice's 6; two small ones touching each other stay
    rattlers (1 contact < 4)."""
    cells = 5
    g = np.arange(cells) * 2.0
    lat = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    small = np.array([[1.0, 1.0, 1.0], [5.0, 5.0, 5.0], [5.6, 5.0, 5.0]])  # last two touch
    pos = np.vstack([lat, small])
    rad = np.r_[np.ones(len(lat)), 0.3, 0.3, 0.3]
    pk = pp.Packing(pos, rad, cells * 2.0)
    c = pp.analysis.Contacts(tolerance=1e-6).compute(pk)
    n_lat = len(lat)
    assert c.coordination == pytest.approx((6 * n_lat + 2) / (n_lat + 3), rel=1e-12)
    assert np.array_equal(np.flatnonzero(c.rattlers), [n_lat, n_lat + 1, n_lat + 2])
    assert c.rattler_fraction == pytest.approx(3 / (n_lat + 3), rel=1e-12)
    assert c.coordination_without_rattlers == 6.0


@pytest.mark.parametrize("reference", ["species", "sphere"])
def test_window_counts_match_bruteforce_per_sphere(reference):
    # window radius R_h a^(k): the species mean radius (seed) or the sphere's own radius
    rng = np.random.default_rng(12)
    n, L = 600, 12.0
    rad = np.where(rng.random(n) < 0.4, 0.6, 0.25) * rng.uniform(0.9, 1.1, n)
    sp = (rad < 0.4).astype(int)
    pk = pp.Packing(rng.random((n, 3)) * L, rad, L, species=sp)
    w = pp.analysis.WindowCounts(window_radius=3.0, reference=reference).compute(pk)
    d = pk.positions[:, None] - pk.positions[None]
    d -= L * np.round(d / L)
    d = np.sqrt((d**2).sum(-1))
    a = np.array([rad[sp == k].mean() for k in range(2)])[sp] if reference == "species" else rad
    inside = (d <= 3.0 * a[:, None]) & ~np.eye(n, dtype=bool)
    assert np.array_equal(w.counts, inside.sum(1))
    for k in range(2):
        for m in range(2):
            vals = inside[sp == k][:, sp == m].sum(1)
            expect = np.bincount(vals, minlength=w.n_h.size)[: w.n_h.size] / vals.size
            assert np.allclose(w.partial[(k, m)], expect), (k, m)
