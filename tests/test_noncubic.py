"""Orthorhombic (non-cubic) boxes: analysis kernels, contacts, pack and shake against
brute-force oracles with their own distance code (tests/_oracles.py).

The box lengths differ on every axis, so a kernel that used ``box[0]`` (or any other
axis) where another one belongs finds pairs at wrong distances and fails these tests.
Counts are compared exactly and distances to 1e-12 (round-off of one subtraction).
"""

import numpy as np
import pytest

import _oracles as orc
import polypack as pp
from polypack._kernels import analysis as kern
from polypack.analysis._paircounts import pair_counts
from polypack.neighbors import pairs_within

BOX = np.array([9.0, 12.5, 16.0])


@pytest.fixture(scope="module")
def gas():
    """Overlapping polydisperse spheres with two species (points for the analyses)."""
    rng = np.random.default_rng(31)
    n = 900
    rad = rng.uniform(0.15, 0.6, n)
    return pp.Packing(rng.random((n, 3)) * BOX, rad, BOX, species=(rad > 0.35).astype(int))


def _oracle_hist(pk, x, x_max, nbins):
    """Ordered-pair counts (K, K, nbins) of the coordinate matrix ``x`` in bins [k h, (k+1) h)."""
    ns = pk.n_species
    h = x_max / nbins
    b = np.floor(x / h + 1e-9).astype(np.int64)
    off = ~np.eye(pk.n, dtype=bool)
    out = np.zeros((ns, ns, nbins), np.int64)
    for k in range(ns):
        for m in range(ns):
            sel = off & (pk.species[:, None] == k) & (pk.species[None, :] == m) & (b < nbins)
            out[k, m] = np.bincount(b[sel], minlength=nbins)[:nbins]
    return out


def test_pair_histograms_both_kernels(gas):
    pk = gas
    d = orc.distance_matrix(pk.positions, pk.box)
    ref = _oracle_hist(pk, d, 2.5, 50)
    assert ref.sum() > 10000
    pos, box = np.ascontiguousarray(pk.positions), np.ascontiguousarray(pk.box)
    sp = np.ascontiguousarray(pk.species, dtype=np.int64)
    rad = np.ascontiguousarray(pk.radii)
    # the half-shell sweep needs >= 5 cells per axis here; cells longer along x than along y
    # and the other way round, so an offset pruned with the wrong cell length shows up
    for grid in ([6, 8, 10], [5, 10, 10], [7, 5, 9]):
        nc = np.array(grid, np.int64)
        off = kern.half_shell_offsets(nc, box / nc, 2.5)
        assert off.shape[0] > 0
        fast = kern.pair_histogram_distance(pos, sp, box, 2, 2.5, 50, nc, off).reshape(2, 2, 50)
        np.testing.assert_array_equal(fast, ref, err_msg=str(grid))
    for grid in ([6, 8, 10], [3, 4, 5], [1, 2, 7]):
        slow = kern.pair_histogram(pos, rad, sp, box, 2, 2.5, 50, False, np.array(grid, np.int64))
        np.testing.assert_array_equal(slow.reshape(2, 2, 50), ref, err_msg=str(grid))
    # through the public estimators (whichever kernel they pick)
    np.testing.assert_array_equal(pp.analysis.RDF(r_max=2.5, dr=0.05).compute(pk).pair_counts, ref)
    np.testing.assert_array_equal(pair_counts(pk, 4.4, 88).reshape(2, 2, 88), _oracle_hist(pk, d, 4.4, 88))
    # contact-scaled coordinate d / (r_i + r_j)
    x = d / (pk.radii[:, None] + pk.radii[None, :])
    np.testing.assert_array_equal(pair_counts(pk, 3.0, 30, "contact").reshape(2, 2, 30), _oracle_hist(pk, x, 3.0, 30))


def test_half_shell_sweep_visits_every_offset_that_holds_a_pair():
    """Pairs planted just inside r_max in random directions, on grids whose cells are long on one
    axis and short on another (e.g. 9 x 25 x 10 cells of 1.6 x 0.9 x 1.3): the pruned offsets
    (cells whose closest points are farther apart than r_max) must hold none of them, so an
    offset pruned with another axis' cell length loses planted pairs.  Exact counts against
    the brute-force oracle."""
    box = np.array([14.4, 22.5, 13.0])
    r_max = 2.5
    rng = np.random.default_rng(3)
    m = 1500
    a = rng.random((m, 3)) * box
    u = rng.normal(size=(m, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    b = (a + u * rng.uniform(0.8, 1.0, m)[:, None] * r_max) % box
    pk = pp.Packing(np.vstack([a, b]), np.full(2 * m, 0.1), box, species=np.repeat([0, 1], m))
    ref = _oracle_hist(pk, orc.distance_matrix(pk.positions, box), r_max, 25)
    assert ref[:, :, 20:].sum() > 2 * m  # the planted pairs, in bins [0.8 r_max, r_max)
    pos = np.ascontiguousarray(pk.positions)
    sp = np.ascontiguousarray(pk.species, dtype=np.int64)
    for grid in ([9, 25, 10], [16, 9, 6], [5, 9, 26]):
        nc = np.array(grid, np.int64)
        off = kern.half_shell_offsets(nc, box / nc, r_max)
        assert off.shape[0] > 0
        fast = kern.pair_histogram_distance(pos, sp, box, 2, r_max, 25, nc, off).reshape(2, 2, 25)
        np.testing.assert_array_equal(fast, ref, err_msg=str(grid))


def test_pairs_within_finds_the_oracle_pairs_and_distances(gas):
    pk = gas
    for a, b in ((1.0, 0.05), (1.2, 0.0), (0.0, 2.0)):
        i, j, d = pairs_within(pk.positions, pk.radii, pk.box, a, b)
        lo, hi = np.minimum(i, j), np.maximum(i, j)
        o = np.lexsort((hi, lo))
        ri, rj, rd = orc.pairs(pk.positions, pk.radii, pk.box, a, b)
        assert ri.size > 100
        np.testing.assert_array_equal(lo[o], ri)
        np.testing.assert_array_equal(hi[o], rj)
        np.testing.assert_allclose(d[o], rd, rtol=1e-12)
    assert pk.min_gap() == pytest.approx(orc.min_gap(pk.positions, pk.radii, pk.box), rel=1e-12)


def test_window_counts(gas):
    pk = gas
    d = orc.distance_matrix(pk.positions, pk.box)
    np.fill_diagonal(d, np.inf)
    for reference, rh in (("sphere", 5.0), ("species", 4.0)):
        w = pp.analysis.WindowCounts(window_radius=rh, reference=reference).compute(pk)
        a = pk.radii if reference == "sphere" else np.array([pk.radii[pk.species == k].mean() for k in (0, 1)])[pk.species]
        inside = d <= (rh * a)[:, None]
        np.testing.assert_array_equal(w.counts, inside.sum(axis=1))
        for k in (0, 1):
            for m in (0, 1):
                ref = inside[pk.species == k][:, pk.species == m].sum(axis=1)
                p = np.bincount(ref, minlength=w.n_h.size)[: w.n_h.size] / ref.size
                np.testing.assert_allclose(w.partial[(k, m)], p, rtol=1e-12)


def test_nearest_surface(gas):
    rng = np.random.default_rng(5)
    pts = rng.random((3000, 3)) * BOX
    # a few big spheres among small ones: several radius classes with their own grids
    rad = gas.radii.copy()
    rad[:10] = 2.0
    pk = gas.replace(radii=rad)
    got = pp.analysis.nearest_surface_distance(pk, pts)
    np.testing.assert_allclose(got, orc.nearest_surface(pts, pk.positions, pk.radii, pk.box), rtol=0, atol=1e-12)


def test_contacts_on_an_orthorhombic_lattice():
    # spheres of radius 1 touching along x and y (spacing 2) but not along z (spacing 2.6),
    # with 6 x 5 x 4 cells: every sphere has exactly 4 contacts
    r = 1.0
    g = [np.arange(6) * 2.0, np.arange(5) * 2.0, np.arange(4) * 2.6]
    pos = np.stack(np.meshgrid(*g, indexing="ij"), -1).reshape(-1, 3) + 0.3
    pk = pp.Packing(pos, np.full(len(pos), r), [12.0, 10.0, 10.4])
    c = pp.analysis.Contacts(tolerance=0.01, min_contacts=3).compute(pk)
    assert c.coordination == 4.0
    assert np.all(c.per_sphere == 4)
    assert not c.rattlers.any()
    b = np.abs(c.branch_vectors)
    assert np.allclose(np.sort(b, axis=1), [0.0, 0.0, 2.0], atol=1e-12)
    assert np.allclose(c.distances, 2.0, atol=1e-12)
    # every sphere has its four contacts, two along x and two along y, also across the faces
    assert np.count_nonzero(b[:, 0] > 1) == np.count_nonzero(b[:, 1] > 1) == pk.n


@pytest.fixture(scope="module")
def packed():
    """pp.pack continued from a non-cubic start: the box keeps its proportions."""
    rng = np.random.default_rng(8)
    box = np.array([8.0, 10.0, 13.0])
    n = 360
    rad = np.where(np.arange(n) < 120, 0.5, 0.3)
    rad = rad * 0.3  # a dilute, non-overlapping start
    sites = np.stack(np.meshgrid(*[np.arange(int(L)) + 0.5 for L in box], indexing="ij"), -1).reshape(-1, 3)
    pos = sites[rng.choice(len(sites), n, replace=False)] + rng.uniform(-0.2, 0.2, (n, 3))
    start = pp.Packing(pos, rad, box, species=(rad < 0.12).astype(int))
    assert orc.min_gap(start.positions, start.radii, start.box) > 0
    pk = pp.pack(start, 0.5, seed=2)
    return start, pk


def test_pack_continues_in_a_non_cubic_box(packed):
    start, pk = packed
    assert pk.meta["status"] == "target"
    assert pk.volume_fraction == pytest.approx(0.5, rel=1e-9)
    np.testing.assert_allclose(pk.box / pk.box[0], start.box / start.box[0], rtol=1e-12)
    np.testing.assert_array_equal(pk.radii, start.radii)
    assert orc.min_gap(pk.positions, pk.radii, pk.box) >= 0.0
    # dense: the closest pairs are in contact to within a few percent
    assert orc.min_gap(pk.positions, pk.radii, pk.box) < 0.01


@pytest.mark.parametrize("method", ["paper", "collision", "metropolis"])
@pytest.mark.parametrize("neighbours", ["verlet", "cells"])
def test_shake_never_overlaps_at_any_sweep(packed, method, neighbours):
    """A large window and a small Verlet skin, every sweep checked by the oracle."""
    _, pk = packed
    gaps = []

    def check(m, cur):
        np.testing.assert_array_equal(cur.box, pk.box)
        gaps.append(orc.min_gap(cur.positions, cur.radii, cur.box))

    tuning = pp.generate.ShakeTuning(neighbours=neighbours, skin=0.3 if neighbours == "verlet" else None)
    out = pp.shake(pk, global_shakes=8, shake_radius=0.3, method=method, seed=4, tuning=tuning,
                   monitor_every=0, callback=check, max_trials=1 if method != "paper" else 20)
    assert len(gaps) == 8
    assert min(gaps) >= 0.0, gaps
    assert out.meta["shake"]["final_neighbour_structure"] == neighbours
    moved = orc.distance_matrix(np.vstack([out.positions, pk.positions]), pk.box)[np.arange(pk.n), pk.n + np.arange(pk.n)]
    assert np.median(moved) > 0.01 * pk.radii.mean()  # the spheres did move
