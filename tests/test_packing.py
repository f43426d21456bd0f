import numpy as np
import pytest

import polypack as pp
from polypack.neighbors import min_relative_gap, pairs_within

import _oracles as orc
from conftest import random_polydisperse


def brute_min_gap(pos, rad, box):
    best = np.inf
    for i in range(len(rad)):
        for j in range(i + 1, len(rad)):
            d = pos[j] - pos[i]
            d -= box * np.round(d / box)
            best = min(best, np.linalg.norm(d) / (rad[i] + rad[j]) - 1)
    return best


@pytest.mark.parametrize("ratio", [1.0, 3.0, 10.0, 20.0])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_min_gap_matches_brute_force(ratio, seed):
    rng = np.random.default_rng(seed)
    box = 10.0
    pos, rad = random_polydisperse(rng, 300, ratio, box, phi_target=0.15)
    pk = pp.Packing(pos, rad, box)
    assert pk.min_gap() == pytest.approx(brute_min_gap(pk.positions, rad, pk.box), rel=1e-12, abs=1e-14)


@pytest.mark.parametrize("ratio", [1.0, 20.0])
def test_pairs_within_matches_brute_force(ratio, rng):
    box = np.array([9.0, 10.0, 11.0])
    pos, rad = random_polydisperse(rng, 400, ratio, 9.0, phi_target=0.3)
    pos = rng.random((400, 3)) * box
    for a, b in [(1.0, 0.05), (1.2, 0.0), (0.0, 1.5)]:
        # the oracle of tests/_oracles.py has its own distance code; distances compared too
        oi, oj, od = orc.pairs(pos, rad, box, a, b)
        ref = {(int(x), int(y)): float(z) for x, y, z in zip(oi, oj, od)}
        for method in ("cells", "brute"):
            i, j, d = pairs_within(pos, rad, box, a, b, method=method)
            got = {(int(min(x, y)), int(max(x, y))): float(z) for x, y, z in zip(i, j, d)}
            assert got.keys() == ref.keys() and len(got) == i.size
            assert np.allclose([got[k] for k in ref], list(ref.values()), rtol=1e-12, atol=0)
        assert len(ref) > 0


def test_touching_pair_across_boundary():
    box = 10.0
    pos = np.array([[0.05, 5.0, 5.0], [9.05, 5.0, 5.0], [5.0, 5.0, 5.0]])
    rad = np.array([0.5, 0.5, 0.2])
    pk = pp.Packing(pos, rad, box)
    gap, pair = pk.closest_pair()
    assert pair == (0, 1)
    assert gap == pytest.approx(0.0, abs=1e-12)
    # push them 1 % closer: now an overlap across the boundary, reported by overlaps()
    pk2 = pk.replace(positions=pos + np.array([[-0.005, 0, 0], [0.005, 0, 0], [0, 0, 0]]))
    ov = pk2.overlaps()
    assert ov.shape == (1, 3) and tuple(ov[0, :2].astype(int)) == (0, 1)
    assert ov[0, 2] == pytest.approx(-0.01, rel=1e-9)
    with pytest.raises(pp.OverlapError, match="spheres 0 and 1"):
        pk2.check_no_overlap()
    pk.check_no_overlap()


def test_corner_images():
    box = np.array([4.0, 5.0, 6.0])
    pos = np.array([[0.1, 0.1, 0.1], [3.9, 4.9, 5.9]])
    pk = pp.Packing(pos, [0.15, 0.15], box)
    d = np.sqrt(3 * 0.2**2)
    assert pk.min_gap() == pytest.approx(d / 0.3 - 1)


def test_dilute_min_gap_exhaustive():
    pk = pp.Packing([[1, 1, 1], [6, 6, 6]], [0.1, 0.2], 12.0)
    assert pk.min_gap() == pytest.approx(np.sqrt(75) / 0.3 - 1)


def test_derived_quantities():
    pos = np.array([[1, 1, 1], [3, 3, 3], [5, 5, 5.0]])
    rad = np.array([0.5, 0.5, 1.0])
    pk = pp.Packing(pos, rad, 10.0, species=[0, 0, 1], meta={"seed": 3})
    v = 4 / 3 * np.pi * np.array([0.125, 0.125, 1.0])
    assert pk.n == 3 and len(pk) == 3
    assert pk.volume_fraction == pytest.approx(v.sum() / 1000)
    np.testing.assert_allclose(pk.species_fractions, [v[:2].sum() / 1000, v[2] / 1000])
    np.testing.assert_array_equal(pk.species_counts, [2, 1])
    assert pk.meta == {"seed": 3}
    with pytest.raises(ValueError):
        pk.positions[0, 0] = 3.0


def test_positions_are_wrapped():
    pk = pp.Packing([[-1.0, 10.0, 25.0], [-1e-17, 0, 0]], [0.5, 0.5], 10.0)
    assert np.all(pk.positions >= 0) and np.all(pk.positions < 10.0)
    np.testing.assert_allclose(pk.positions[0], [9.0, 0.0, 5.0])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(positions=np.zeros((3, 4)), radii=[1, 1, 1], box=10), "shape"),
        (dict(positions=np.zeros((2, 3)), radii=[1, 1, 1], box=10), "match"),
        (dict(positions=[[0, 0, np.nan]], radii=[1], box=10), "finite"),
        (dict(positions=[[0, 0, np.inf]], radii=[1], box=10), "finite"),
        (dict(positions=[[0, 0, 0]], radii=[np.nan], box=10), "radius of sphere 0"),
        (dict(positions=[[0, 0, 0]], radii=[0.0], box=10), "> 0"),
        (dict(positions=[[0, 0, 0]], radii=[-1.0], box=10), "-1.0"),
        (dict(positions=[[0, 0, 0]], radii=[1.0], box=[10, 0, 10]), "box lengths"),
        (dict(positions=[[0, 0, 0]], radii=[1.0], box=[10, 10]), "box"),
        (dict(positions=[[0, 0, 0]], radii=[1.0], box=[10, np.nan, 10]), "box lengths"),
        (dict(positions=[[0, 0, 0]], radii=[3.0], box=10), "half the smallest periodic box"),
        (dict(positions=[[0, 0, 0]], radii=[1.0], box=10, species=[0.5]), "integer"),
        (dict(positions=[[0, 0, 0]], radii=[1.0], box=10, species=["a"]), "integers"),
        (dict(positions=[[0, 0, 0]], radii=[1.0], box=10, species=[-1]), ">= 0"),
        (dict(positions=[[0, 0, 0]], radii=[1.0], box=10, species=[0, 1]), "species must have shape"),
    ],
)
def test_constructor_rejections(kwargs, match):
    with pytest.raises(pp.InvalidInputError, match=match):
        pp.Packing(**kwargs)


def test_replace_and_equality():
    pk = pp.Packing([[1, 1, 1]], [0.5], 10.0, meta={"a": 1})
    pk2 = pk.replace(radii=[0.4])
    assert pk2.radii[0] == 0.4 and pk.radii[0] == 0.5
    assert pk == pk.replace()
    assert pk != pk2
    with pytest.raises(pp.InvalidInputError, match="unknown field"):
        pk.replace(colour=1)


def test_error_hierarchy():
    for e in (pp.InvalidInputError, pp.OverlapError, pp.FormatError, pp.InfeasibleError):
        assert issubclass(e, pp.PolypackError)


def test_min_gap_is_linear_for_large_size_ratio():
    # 1:20 size ratio, 20000 spheres: must finish fast (the size-aware search).
    rng = np.random.default_rng(5)
    n = 20000
    rad = np.where(rng.random(n) < 0.002, 1.0, 0.05)
    box = 12.0
    pk = pp.Packing(rng.random((n, 3)) * box, rad, box)
    i, j, d = pairs_within(pk.positions, pk.radii, pk.box, 1.0, 0.0)
    gap, pair = min_relative_gap(pk.positions, pk.radii, pk.box)
    # independent oracle: scipy's periodic k-d tree for small-small pairs (d < 0.1) plus
    # all distances from the few large spheres
    from scipy.spatial import cKDTree

    big = np.flatnonzero(rad > 0.5)
    small = np.flatnonzero(rad < 0.5)
    tree = cKDTree(pk.positions[small], boxsize=box)
    ss = tree.sparse_distance_matrix(tree, 0.1, output_type="coo_matrix")
    keep = ss.row < ss.col
    gaps_ss = ss.data[keep] / 0.1 - 1
    dd = np.abs(pk.positions[big][:, None, :] - pk.positions[None, :, :])
    dd = np.sqrt(np.sum(np.minimum(dd, box - dd) ** 2, axis=-1))
    gaps_b = dd / (rad[big][:, None] + rad[None, :]) - 1
    gaps_b[np.arange(big.size), big] = np.inf
    ref = min(gaps_ss.min(), gaps_b.min())
    assert gap == pytest.approx(ref, rel=1e-12, abs=1e-14)
    # overlapping pairs (d <= r_i + r_j): the same number as the oracle finds
    n_ss = np.count_nonzero(ss.data[keep] <= 0.1)
    n_b = np.count_nonzero(gaps_b <= 0) - np.count_nonzero(gaps_b[:, big] <= 0) // 2
    assert i.size == n_ss + n_b > 0
