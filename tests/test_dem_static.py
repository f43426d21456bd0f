"""The DEM's own static shear modulus near floppiness (``pp.mechanics.static_shear_modulus``).

The relaxed modulus is the minimum of a linear least-squares problem (the bond energy,
Eq. (1) of 003_873b69fc71c74cf6.txt and Eq. (2) of 003_873b69fc71c74cf6.txt linearised).
Oracles: a dense minimum-norm least-squares solve assembled here bond by bond (no polypack
stiffness code), lattices with analytically known floppy modes and moduli, and
``elastic_tensor`` (a separate assembly and solver) where that one is exact.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import polypack as pp
from polypack.errors import InfeasibleError
from polypack.mechanics import BondNetwork, dem, elastic_tensor
from polypack.mechanics._dem_stiffness import static_shear_modulus as raw

from _dem_networks import lattice

KN, KS = 100.0, 10.0


def _skew(n):
    return np.array([[0.0, -n[2], n[1]], [n[2], 0.0, -n[0]], [-n[1], n[0], 0.0]])


def dense_least_squares(pos, radii, box, i, j, shift, kn, ks, a, g):
    """Oracle: ``min sum_c |K_c^1/2 (Delta_c + e_a b_g)|^2 / V`` by a dense minimum-norm least-squares solve.

    The contact point of ``i`` (``x_i + l_i n``) moves by ``u_i + theta_i x l_i n``, that of
    ``j`` (``x_j - l_j n``) by ``u_j - theta_j x l_j n``, so the relative displacement is
    ``Delta = u_j - u_i + l_i n x theta_i + l_j n x theta_j``; the affine part of the simple
    shear is ``e_a (b . e_g)``.  Rotations are scaled by the mean radius (columns of one
    scale); numpy's SVD-based solve drops singular values below eps max(shape) of the largest.
    """
    n_p, m = len(pos), len(i)
    ell = float(np.mean(radii))
    R = np.zeros((3 * m, 6 * n_p))
    r = np.zeros(3 * m)
    for c in range(m):
        b = pos[j[c]] + shift[c] * box - pos[i[c]]
        d = np.linalg.norm(b)
        n = b / d
        li = 0.5 * (d + radii[i[c]] - radii[j[c]])
        lj = d - li
        P = np.outer(n, n)
        W = math.sqrt(kn[c]) * P + math.sqrt(ks[c]) * (np.eye(3) - P)
        rows = slice(3 * c, 3 * c + 3)
        R[rows, 6 * i[c]:6 * i[c] + 3] -= W
        R[rows, 6 * i[c] + 3:6 * i[c] + 6] += W @ _skew(n) * (li / ell)
        R[rows, 6 * j[c]:6 * j[c] + 3] += W
        R[rows, 6 * j[c] + 3:6 * j[c] + 6] += W @ _skew(n) * (lj / ell)
        r[rows] = W @ (np.eye(3)[a] * b[g])
    x, *_ = np.linalg.lstsq(R, -r, rcond=None)
    res = R @ x + r
    return float(res @ res) / float(np.prod(box))


def _arrays(net):
    n = dem._network(net)
    return n.pos, n.radii, np.diag(n.box), n.i, n.j, n.shift, n.kn, n.ks


@pytest.fixture(scope="module")
def vem_soft_1000():
    """A larger near-floppy VEM structure (void ratio 1, SI units), bonded at epsilon = 0.01."""
    pk = pp.vem(1000, volume_fraction=0.4, void_ratio=1.0, seed=2, radius=0.25e-6, progress=False)
    return BondNetwork.from_packing(pk, epsilon=0.01)


@pytest.fixture(scope="module")
def vem_soft():
    """A VEM structure (seed 003's generator, SI units) bonded at the seed's epsilon = 0.01: Z < 4."""
    pk = pp.vem(200, volume_fraction=0.4, void_ratio=1.0, seed=3, radius=0.25e-6, progress=False)
    return BondNetwork.from_packing(pk, epsilon=0.01)


def test_near_floppy_vem_equals_dense_least_squares(vem_soft):
    # Z below the isostatic 4: hundreds of zero modes and a relaxed modulus orders of
    # magnitude below the affine one (the cancellation that broke the shifted direct solve).
    # The dense minimum-norm solve is exact to ~1e-10 here; 1e-7 would catch a single
    # unrelaxed soft mode (each one carries a few per cent of this modulus)
    pos, radii, cell, i, j, shift, kn, ks = _arrays(vem_soft)
    assert vem_soft.coordination < 4.0
    for a, g in ((0, 2), (1, 2), (0, 1)):
        C, info = raw(pos, radii, cell, i, j, shift, kn, ks, a, g)
        oracle = dense_least_squares(pos, radii, np.diag(cell), i, j, shift, kn, ks, a, g)
        assert C == pytest.approx(oracle, rel=1e-7)
        assert C < 0.05 * info["affine"]
        assert info["floppy_modes"] > 0 and info["residual"] < 1e-8
    assert dem.static_shear_modulus(vem_soft, 2, 0) == pytest.approx(
        raw(pos, radii, cell, i, j, shift, kn, ks, 0, 2)[0], rel=1e-12)


@pytest.mark.parametrize("solver", ["direct", "cg"])
def test_elastic_tensor_relaxes_the_soft_modes_of_a_near_floppy_vem(vem_soft, solver):
    # elastic_tensor (its own assembly, factorization and Krylov relaxation) on the same
    # near-floppy network equals the dense least-squares oracle for the three shear
    # moduli to 1e-7 (a shifted solve refined by stationary iteration was 20 % high on a
    # VEM network like this one: modes softer than the shift stayed unrelaxed). Every
    # relaxed value is a bond energy, hence never below the exact minimum beyond round-off.
    pos, radii, cell, i, j, shift, kn, ks = _arrays(vem_soft)
    et = elastic_tensor(vem_soft, solver=solver)
    assert et.floppy_modes is None or et.floppy_modes > 0
    for col, (a, g) in zip((3, 4, 5), ((1, 2), (0, 2), (0, 1))):
        oracle = dense_least_squares(pos, radii, np.diag(cell), i, j, shift, kn, ks, a, g)
        assert et.stiffness[col, col] == pytest.approx(oracle, rel=1e-7)
        assert et.stiffness[col, col] >= oracle * (1 - 1e-9)
    assert np.linalg.eigvalsh(et.stiffness).min() >= -1e-12 * np.abs(et.stiffness).max()


def test_elastic_tensor_on_a_1000_sphere_near_floppy_vem_equals_the_sparse_oracle(vem_soft_1000):
    # N = 1000 at void ratio 1 (Z ~ 3.8): soft modes down to ~1e-13 of the stiffest, which the
    # shifted refinement left unrelaxed (C55 20 % high); the oracle is the DEM's own
    # least-squares relaxation (separate assembly, SuperLU-preconditioned CG, 1e-12 residual)
    et = elastic_tensor(vem_soft_1000, solver="direct")
    assert vem_soft_1000.coordination < 4.0 and et.floppy_modes > 0
    for col, (g, a) in zip((3, 4, 5), ((1, 2), (0, 2), (0, 1))):
        oracle = dem.static_shear_modulus(vem_soft_1000, g, a)
        assert et.stiffness[col, col] == pytest.approx(oracle, rel=1e-5)
        assert et.stiffness[col, col] < 0.02 * et.affine_stiffness[col, col]


def test_near_floppy_nonaffine_fields_carry_the_relaxed_energy(vem_soft_1000):
    # the returned fields (zero modes projected out, soft modes kept: they are response) are
    # the relaxed state: their bond energies, summed here with numpy from the network's own
    # arrays, give the tensor's diagonal (projecting out a loaded soft mode would not)
    net = vem_soft_1000
    et = elastic_tensor(net, solver="direct")
    box = np.asarray(net.packing.box, dtype=float)
    K = (net.normal_stiffness - net.shear_stiffness)[:, None, None] * np.einsum("ma,mb->mab", net.normal, net.normal)
    K += net.shear_stiffness[:, None, None] * np.eye(3)
    pairs = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
    on = np.isfinite(et.nonaffine_displacements[0, net.i, 0]) & np.isfinite(et.nonaffine_displacements[0, net.j, 0])
    for col, (p, r) in enumerate(pairs):
        e = np.zeros((3, 3))
        e[p, r] = e[r, p] = 1.0 if p == r else 0.5
        u, w = et.nonaffine_displacements[col], et.nonaffine_rotations[col]
        i, j = net.i[on], net.j[on]
        delta = (u[j] + np.cross(w[j], net.lever_arm_j[on])) - (u[i] + np.cross(w[i], net.lever_arm_i[on]))
        delta += net.branch[on] @ e.T
        energy = np.einsum("ma,mab,mb->", delta, K[on], delta) / np.prod(box)
        assert energy == pytest.approx(et.stiffness[col, col], rel=1e-6)


def test_elastic_tensor_raises_when_the_relaxation_does_not_converge(vem_soft, monkeypatch):
    from polypack.mechanics import _elastic_solvers as el

    real = el._solve_cg
    monkeypatch.setattr(el, "_solve_cg", lambda *a, **kw: real(*a, **{**kw, "maxiter": 2}))
    with pytest.raises(InfeasibleError, match="did not converge"):
        elastic_tensor(vem_soft, solver="cg")


def test_diluted_jammed_pack_agrees_with_elastic_tensor():
    # a jammed pack with a fifth of its bonds removed at random: floppy modes beyond the
    # rattlers', yet rigid; elastic_tensor (its own assembly and factorization) is exact on it.
    # Counts: without rattlers (their spheres keep no bond, 6 rigid modes each) the two
    # definitions of a floppy mode coincide
    pk = pp.pack(np.full(250, 0.5), volume_fraction=0.62, seed=2, progress=False)
    full = BondNetwork.from_packing(pk, epsilon=0.02, normal_stiffness=KN, shear_stiffness=KS)
    keep = np.random.default_rng(5).random(full.n_bonds) < 0.8
    thin = BondNetwork.from_pairs(pk, full.i[keep], full.j[keep], shift=full.shift[keep],
                                  normal_stiffness=KN, shear_stiffness=KS)
    bb = thin.backbone_bonds
    net = BondNetwork.from_pairs(pk, thin.i[bb], thin.j[bb], shift=thin.shift[bb],
                                 normal_stiffness=KN, shear_stiffness=KS)
    et = elastic_tensor(net, solver="direct")
    assert et.floppy_modes > 0
    pos, radii, cell, i, j, shift, kn, ks = _arrays(net)
    got = []
    for a, g in ((1, 2), (0, 2), (0, 1)):
        C, info = raw(pos, radii, cell, i, j, shift, kn, ks, a, g)
        got.append(C)
        assert info["floppy_modes"] >= et.floppy_modes  # islands that do not wrap count here only
    # 1e-8: both are exact solves (round-off ~1e-12); a missed relaxation is a per-cent effect
    np.testing.assert_allclose(got, et.shear_moduli, rtol=1e-8)


@pytest.mark.parametrize("d", [1.0, 5e-7])
def test_central_force_fcc_has_3n_floppy_rotations(d):
    # ks = 0: a bond sees only the normal relative displacement, which no rotation changes,
    # so every sphere's three rotations are exact zero modes (3N floppy modes) while the
    # translations stay rigid (Z = 12); a Bravais lattice deforms affinely:
    # C44 = kn / (sqrt(2) d) exactly, in any units (d = 0.5 um: the seed's SI scale)
    net = lattice("fcc", 3, d=d, kn=KN, ks=KS)
    pos, radii, cell, i, j, shift, kn, _ = _arrays(net)
    for a, g in dem.SHEAR_DIRECTIONS:
        C, info = raw(pos, radii, cell, i, j, shift, kn, np.zeros_like(kn), a, g)
        assert C == pytest.approx(KN / (math.sqrt(2) * d), rel=1e-10)
        assert info["floppy_modes"] == 3 * net.n
        assert info["rigid_modes"] == 3


def _diamond(cells, d):
    """Diamond lattice of touching spheres (diameter d), nearest-neighbour bonds."""
    a = 4.0 * d / math.sqrt(3.0)
    fcc = np.array([[0, 0, 0], [0, 0.5, 0.5], [0.5, 0, 0.5], [0.5, 0.5, 0]])
    basis = np.concatenate([fcc, fcc + 0.25])
    g = np.arange(cells)
    cell = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    pos = ((cell[:, None, :] + basis[None]).reshape(-1, 3) + 0.1) * a
    pk = pp.Packing(pos, np.full(len(pos), 0.5 * d), np.full(3, cells * a))
    return BondNetwork.from_packing(pk, epsilon=1e-6, normal_stiffness=KN, shear_stiffness=KS)


@pytest.mark.parametrize("d", [1.0, 5e-7])
def test_central_force_diamond_has_zero_shear_modulus(d):
    # diamond with bond stretching only (Keating's beta = 0) is a mechanism in shear: the two
    # fcc sublattices slide against each other (internal relaxation) and C44 = 0 exactly,
    # while the affine C44 = sqrt(3) kn / (12 d) is not zero (16 bonds of n_x^2 n_z^2 = 1/9
    # per cube of side 4 d / sqrt(3)).  Round-off: 1e-10 of the affine value
    net = _diamond(2, d)
    assert net.n_bonds == 2 * net.n
    pos, radii, cell, i, j, shift, kn, _ = _arrays(net)
    affine = math.sqrt(3.0) * KN / (12.0 * d)
    for a, g in dem.SHEAR_DIRECTIONS:
        C, info = raw(pos, radii, cell, i, j, shift, kn, np.zeros_like(kn), a, g)
        assert info["affine"] == pytest.approx(affine, rel=1e-10)
        assert abs(C) < 1e-10 * affine
        # 3N rotations plus at least the N translational mechanisms of Maxwell's count (3N - 2N)
        assert info["floppy_modes"] >= 4 * net.n - 3


@pytest.mark.parametrize("d", [1.0, 5e-7])
def test_simple_cubic_rotations_relax_in_any_units(d):
    # simple cubic with shear springs: C44 = ks / (2 d) needs the spheres to rotate; in SI
    # units (d = 0.5 um) a rotation costs ks l^2 ~ 1e-12 N m against kn ~ 100 N/m, and a
    # solver that does not scale the unknowns freezes them (C44 = ks / d, twice the truth)
    net = lattice("sc", 4, d=d, kn=KN, ks=KS)
    for g, a in dem.SHEAR_DIRECTIONS:
        assert dem.static_shear_modulus(net, g, a) == pytest.approx(KS / (2 * d), rel=1e-10)


@pytest.mark.parametrize("d", [1.0, 5e-7])
def test_unbonded_sphere_adds_six_rigid_modes_and_no_floppy_one(d):
    # an fcc lattice with shear springs (Z = 12, rigid: no floppy mode, C44 = (kn + ks) / (sqrt(2) d)
    # as in test_dem) plus one small sphere alone in an octahedral hole (no bond): its six
    # degrees of freedom are zero modes and rigid-body motions, so the counts are exact --
    # 3 (the lattice cluster wraps the box) + 6 rigid, 0 floppy -- and the modulus is unchanged
    fcc = lattice("fcc", 3, d=d, kn=KN, ks=KS)
    pk = fcc.packing
    a = math.sqrt(2.0) * d
    hole = (np.array([0.5, 0.5, 0.5]) + 0.25) * a  # octahedral site: a/2 = 0.71 d from six centres
    grown = pp.Packing(np.vstack([pk.positions, hole]), np.append(pk.radii, 0.1 * d), pk.box)
    net = BondNetwork.from_pairs(grown, fcc.i, fcc.j, shift=fcc.shift, normal_stiffness=KN, shear_stiffness=KS)
    c, info = dem.static_shear_modulus(net, 2, 0, details=True)
    assert c == pytest.approx((KN + KS) / (math.sqrt(2.0) * d), rel=1e-8)
    assert info["rigid_modes"] == 3 + 6
    assert info["floppy_modes"] == 0
    assert info["zero_modes"] == 9


def test_rigid_random_pack_unchanged_and_details():
    # a rigid network (Z ~ 5): the same moduli as elastic_tensor to round-off, the affine value
    # as the Voigt bound, and the details of the solve
    pk = pp.pack(np.full(200, 0.5), volume_fraction=0.62, seed=1, progress=False)
    net = BondNetwork.from_packing(pk, epsilon=0.02, normal_stiffness=KN, shear_stiffness=KS)
    et = elastic_tensor(net, solver="direct")
    c, info = dem.static_shear_modulus(net, 2, 0, details=True)
    assert c == pytest.approx(et.shear_moduli[1], rel=1e-9)
    assert c < info["affine"] and info["residual"] < 1e-10
    assert info["zero_modes"] == info["rigid_modes"] + info["floppy_modes"]


def test_unconverged_relaxation_is_refused(vem_soft):
    # no CG iteration allowed: the relaxation cannot converge and the error names the floppy modes
    pos, radii, cell, i, j, shift, kn, ks = _arrays(vem_soft)
    with pytest.raises(InfeasibleError, match=r"floppy modes"):
        raw(pos, radii, cell, i, j, shift, kn, ks, 0, 2, maxiter=0)


def test_positive_factor_retries_a_zero_pivot_with_a_larger_shift():
    # a soft spectrum at the round-off floor makes the Cholesky factor of h + shift D fail
    # (MKL error -4): the Krylov preconditioner is then built with a 1000x larger shift
    import scipy.sparse as sp

    from polypack.mechanics import _elastic_solvers as el

    shifts = []

    class FailsOnce:
        def __init__(self, a, mtype):
            shifts.append(float(a.diagonal()[0]) - 1.0)
            if len(shifts) == 1:
                raise RuntimeError("zero pivot")

    el._positive_factor(FailsOnce, sp.identity(4, format="csr"), np.ones(4), 1e-12)
    assert shifts == pytest.approx([1e-12, 1e-9], rel=1e-3)

    class AlwaysFails(FailsOnce):
        def __init__(self, a, mtype):
            raise RuntimeError("zero pivot")

    with pytest.raises(RuntimeError):
        el._positive_factor(AlwaysFails, sp.identity(4, format="csr"), np.ones(4), 1e-12)
