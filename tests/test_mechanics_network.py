"""BondNetwork: bonds, geometry, per-species parameters, rattlers, statistics, errors."""

import numpy as np
import pytest
from _lattices import bcc, fcc, simple_cubic

import polypack as pp
from polypack.errors import InfeasibleError, InvalidInputError
from polypack.mechanics import BondNetwork, series_stiffness
from polypack.neighbors import minimum_image, pairs_within


@pytest.fixture(scope="module")
def jammed():
    return pp.pack(np.full(300, 0.5), volume_fraction="jammed", seed=3)


@pytest.fixture(scope="module")
def bidisperse():
    r = np.where(np.arange(300) % 3 == 0, 0.7, 0.4)
    return pp.pack(r, volume_fraction=0.6, seed=5, species=(np.arange(300) % 3 == 0).astype(int))


def test_fcc_bonds_angles_and_geometry():
    pk = fcc(cells=3, d=1.0)
    net = BondNetwork.from_packing(pk, epsilon=0.01)
    # FCC: 12 nearest neighbours at distance d, nothing else within 1.01 d
    assert net.n_bonds == 6 * pk.n
    assert np.all(net.bonds_per_particle == 12)
    np.testing.assert_allclose(net.length, 1.0, rtol=1e-12)
    assert np.all(net.i < net.j)
    # shift reproduces the branch vectors; normals are unit
    b = pk.positions[net.j] + net.shift * pk.box - pk.positions[net.i]
    np.testing.assert_allclose(net.branch, b, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(net.normal, axis=1), 1.0, rtol=1e-12)
    assert not net.rattlers.any()
    assert net.coordination == 12.0
    # 66 bond pairs per particle: 24 at 60 deg, 12 at 90, 24 at 120, 6 at 180
    ang = np.round(np.degrees(net.bond_angles()), 3)  # arccos near pi: ~1e-6 deg
    vals, counts = np.unique(ang, return_counts=True)
    np.testing.assert_allclose(vals, [60, 90, 120, 180])
    np.testing.assert_array_equal(counts, np.array([24, 12, 24, 6]) * pk.n)
    np.testing.assert_allclose(net.fabric, np.eye(3) / 3, atol=1e-12)
    label, spans = net.components()
    assert label.max() == 0 and spans.all()
    # touching spheres: contact point is the tangency point x_i + r_i n
    np.testing.assert_allclose(net.contact_point, pk.positions[net.i] + 0.5 * net.normal, atol=1e-12)


@pytest.mark.parametrize("lattice,z", [(simple_cubic, 6), (bcc, 8)])
def test_other_lattices_coordination(lattice, z):
    pk = lattice()
    net = BondNetwork.from_packing(pk, epsilon=0.01)
    assert np.all(net.bonds_per_particle == z)
    np.testing.assert_allclose(net.length, 1.0, rtol=1e-12)


def test_bonds_match_brute_force(bidisperse):
    pk = bidisperse
    eps = 0.05
    net = BondNetwork.from_packing(pk, epsilon=eps)
    bi, bj, bd = pairs_within(pk.positions, pk.radii, pk.box, a=1 + eps, method="brute")
    want = {(min(a, b), max(a, b)) for a, b in zip(bi.tolist(), bj.tolist())}
    got = set(zip(net.i.tolist(), net.j.tolist()))
    assert got == want
    # every bond is the minimum image and below the bonding distance
    d = minimum_image(pk.positions[net.j] - pk.positions[net.i], pk.box)
    np.testing.assert_allclose(net.branch, d, atol=1e-12)
    assert np.all(net.length <= (1 + eps) * (pk.radii[net.i] + pk.radii[net.j]) * (1 + 1e-12))
    assert net.relative_gap.max() <= eps + 1e-12


def test_contact_point_across_gap_is_pfc(bidisperse):
    net = BondNetwork.from_packing(bidisperse, epsilon=0.05)
    r = bidisperse.radii
    g = -net.overlap  # gap
    ci = np.linalg.norm(net.contact_point - bidisperse.positions[net.i], axis=1)
    np.testing.assert_allclose(ci, r[net.i] + g / 2, rtol=1e-12)
    # lever arms meet at the contact point from both centres
    xj = bidisperse.positions[net.j] + net.shift * bidisperse.box
    np.testing.assert_allclose(xj + net.lever_arm_j, net.contact_point, atol=1e-12)


def test_per_species_stiffness_and_strengths(bidisperse):
    pk = bidisperse
    mat = np.array([[100.0, 150.0], [150.0, 200.0]])
    net = BondNetwork.from_packing(pk, epsilon=0.05, normal_stiffness=mat,
                                   shear_stiffness={(0, 0): 1.0, (0, 1): 2.0, (1, 1): 3.0},
                                   normal_strength=np.inf)
    s = pk.species
    np.testing.assert_array_equal(net.normal_stiffness, mat[s[net.i], s[net.j]])
    np.testing.assert_array_equal(net.shear_stiffness, 1.0 + s[net.i] + s[net.j])
    assert np.all(np.isinf(net.normal_strength)) and np.all(net.shear_strength == 1e-6)
    # PFC 4: equal balls of stiffness k in series give k / 2 per contact
    np.testing.assert_allclose(series_stiffness([100.0, 300.0]), [[50.0, 75.0], [75.0, 150.0]])
    with pytest.raises(InvalidInputError, match="species pair"):
        BondNetwork.from_packing(pk, epsilon=0.05, normal_stiffness={(0, 0): 1.0})
    with pytest.raises(InvalidInputError, match="2 species"):
        BondNetwork.from_packing(pk, epsilon=0.05, normal_stiffness=np.ones((1, 1)))


def test_reference_zero_gap_prestress(bidisperse):
    pk = bidisperse
    free = BondNetwork.from_packing(pk, epsilon=0.05)
    zero = BondNetwork.from_packing(pk, epsilon=0.05, reference="zero-gap")
    np.testing.assert_array_equal(free.rest_length, free.length)
    assert np.all(free.normal_force == 0)
    np.testing.assert_allclose(zero.rest_length, pk.radii[zero.i] + pk.radii[zero.j])
    # a bond across a gap g is under tension kn g (negative normal force)
    np.testing.assert_allclose(zero.normal_force, -100.0 * (zero.length - zero.rest_length))
    assert zero.normal_force.min() < 0


def _rattlers_oracle(n, i, j):
    keep = np.ones(n, bool)
    while True:
        live = keep[i] & keep[j]
        z = np.bincount(i[live], minlength=n) + np.bincount(j[live], minlength=n)
        drop = keep & (z < 2)
        if not drop.any():
            return ~keep
        keep &= ~drop


def test_rattlers_recursive():
    # triangle 0-1-2 with a dangling chain 2-3-4-5 and an isolated particle 6
    pos = np.array([[0, 0, 0], [1, 0, 0], [0.5, 0.87, 0], [0.5, 1.87, 0], [0.5, 2.87, 0],
                    [0.5, 3.87, 0], [5.0, 5.0, 5.0]], float) + 1.0
    pk = pp.Packing(pos, np.full(7, 0.5), 10.0)
    net = BondNetwork.from_pairs(pk, [0, 1, 2, 2, 3, 4], [1, 2, 0, 3, 4, 5])
    np.testing.assert_array_equal(net.rattlers, [0, 0, 0, 1, 1, 1, 1])
    np.testing.assert_array_equal(net.rattlers_with(3), np.ones(7, bool))
    assert net.coordination == pytest.approx(12 / 7)
    assert net.coordination_without_rattlers == pytest.approx(2.0)
    label, spans = net.components()
    assert label.tolist() == [0, 0, 0, -1, -1, -1, -1] and not spans.any()


def test_rattlers_against_oracle(jammed):
    net = BondNetwork.from_packing(jammed, epsilon=0.002)
    np.testing.assert_array_equal(net.rattlers, _rattlers_oracle(net.n, net.i, net.j))
    assert net.rattlers.any() and not net.rattlers.all()


def test_from_pairs_minimum_image_order_and_select(jammed):
    ref = BondNetwork.from_packing(jammed, epsilon=0.01)
    perm = np.random.default_rng(0).permutation(ref.n_bonds)
    i, j = ref.j[perm], ref.i[perm]  # flipped orientation, shuffled
    kn = np.linspace(50, 150, ref.n_bonds)
    net = BondNetwork.from_pairs(jammed, i, j, normal_stiffness=kn)
    np.testing.assert_array_equal(net.i, i)
    np.testing.assert_allclose(net.branch, -ref.branch[perm], atol=1e-12)
    np.testing.assert_array_equal(net.normal_stiffness, kn)
    sub = net.select(net.normal_stiffness > 100)
    assert sub.n_bonds == int((kn > 100).sum()) and np.all(sub.normal_stiffness > 100)
    with pytest.raises(ValueError):
        net.i[0] = 1  # read-only


def test_from_pairs_errors(jammed):
    with pytest.raises(InvalidInputError, match="itself"):
        BondNetwork.from_pairs(jammed, [0], [0])
    with pytest.raises(InvalidInputError, match=r"\[0, 300\)"):
        BondNetwork.from_pairs(jammed, [0], [300])
    with pytest.raises(InvalidInputError, match="more than once"):
        BondNetwork.from_pairs(jammed, [0, 5], [5, 0])
    with pytest.raises(InvalidInputError, match="shape"):
        BondNetwork.from_pairs(jammed, [0], [5], shift=[[0, 0]])
    with pytest.raises(InfeasibleError, match="no bonds"):
        BondNetwork.from_pairs(jammed, [], [])


@pytest.mark.parametrize(
    "kw,match",
    [
        ({"epsilon": -0.01}, "epsilon=-0.01"),
        ({"epsilon": float("nan")}, "epsilon"),
        ({"normal_stiffness": 0.0}, "normal_stiffness=0.0"),
        ({"shear_stiffness": -1.0}, "shear_stiffness=-1.0"),
        ({"normal_stiffness": np.inf}, "finite"),
        ({"normal_strength": 0.0}, "normal_strength=0.0"),
        ({"reference": "relaxed"}, "reference='relaxed'"),
    ],
)
def test_bad_input(jammed, kw, match):
    with pytest.raises(InvalidInputError, match=match):
        BondNetwork.from_packing(jammed, **kw)


def test_no_bonds_is_an_error():
    pk = pp.Packing([[1.0, 1, 1], [5, 5, 5]], [0.5, 0.5], 10.0)
    with pytest.raises(InfeasibleError, match="no bonds"):
        BondNetwork.from_packing(pk)


def test_2d_and_wall_axes_against_brute_force():
    rng = np.random.default_rng(2)
    n, box = 400, np.array([20.0, 12.0])
    rad = rng.uniform(0.3, 0.6, n)
    pos = rng.random((n, 2)) * (box - [0, 1.2]) + [0, 0.6]
    pk = pp.Packing(pos, rad, box, periodic=(True, False))
    net = BondNetwork.from_packing(pk, epsilon=0.0)
    d = pos[None] - pos[:, None]
    d[..., 0] -= box[0] * np.round(d[..., 0] / box[0])  # periodic x only
    close = np.sqrt((d**2).sum(-1)) <= rad[:, None] + rad[None]
    want = {(a, b) for a, b in zip(*np.nonzero(np.triu(close, 1)))}
    assert set(zip(net.i.tolist(), net.j.tolist())) == want
    assert np.all(net.shift[:, 1] == 0) and np.any(net.shift[:, 0] != 0)
    assert net.dim == 2 and net.branch.shape == (len(want), 2)
