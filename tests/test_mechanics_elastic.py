"""Exact elastic tensor of bonded networks: lattices in closed form, random packs, an independent optimiser."""

import numpy as np
import pytest
import scipy.optimize
from _lattices import bcc, diamond, fcc, simple_cubic

import polypack as pp
from polypack.errors import InfeasibleError, InvalidInputError
from polypack.mechanics import BondNetwork, elastic_tensor, voigt_average

KN, KS = 100.0, 10.0
S2, S3 = np.sqrt(2.0), np.sqrt(3.0)


def cubic_tensor(c11, c12, c44):
    c = np.zeros((6, 6))
    c[:3, :3] = c12
    c[np.arange(3), np.arange(3)] = c11
    c[np.arange(3, 6), np.arange(3, 6)] = c44
    return c


@pytest.fixture(scope="module")
def jammed():
    return pp.pack(np.full(250, 0.5), volume_fraction="jammed", seed=11)


@pytest.fixture(scope="module")
def jammed_net(jammed):
    return BondNetwork.from_packing(jammed, epsilon=0.01)


# ------------------------------------------------------------------ lattices
@pytest.mark.parametrize("rotations", [True, False])
@pytest.mark.parametrize("solver", ["direct", "cg", "amg"])
@pytest.mark.parametrize("d", [1.0, 0.37])
def test_fcc_closed_form(rotations, solver, d):
    """FCC, nearest-neighbour bonds of length d (issue 14): 1e-6 relative (round-off is ~1e-14)."""
    net = BondNetwork.from_packing(fcc(cells=3, d=d), normal_stiffness=KN, shear_stiffness=KS)
    et = elastic_tensor(net, rotations=rotations, solver=solver)
    want = cubic_tensor(S2 * (KN + KS) / d, (KN - KS) / (S2 * d), (KN + KS) / (S2 * d))
    np.testing.assert_allclose(et.stiffness, want, rtol=1e-6, atol=1e-6 * want.max())
    np.testing.assert_allclose(et.affine_stiffness, want, rtol=1e-6, atol=1e-6 * want.max())
    # centrosymmetric and torque-free under any strain: no non-affine motion at all
    assert np.nanmax(np.abs(et.nonaffine_displacements)) < 1e-9 * d


def test_simple_cubic_and_bcc_closed_forms():
    """Derived in docs/mechanics.md: SC C11 = kn/d, C12 = 0, C44 = ks/(2d);
    BCC C11 = (kn + 2ks)/(sqrt3 d), C12 = (kn - ks)/(sqrt3 d), C44 = (2kn + ks)/(2 sqrt3 d)."""
    for pk, want, floppy in [
        (simple_cubic(cells=4), cubic_tensor(KN, 0.0, KS / 2), 12),
        (bcc(cells=3), cubic_tensor((KN + 2 * KS) / S3, (KN - KS) / S3, (2 * KN + KS) / (2 * S3)), 3),
    ]:
        net = BondNetwork.from_packing(pk)
        et = elastic_tensor(net, solver="direct")
        np.testing.assert_allclose(et.stiffness, want, rtol=1e-6, atol=1e-6 * want.max())
        # SC: spins about x staggered in each yz plane (3 axes x 4 planes); BCC: opposite
        # uniform spins of the two sublattices (3 axes). Both cost no energy.
        assert et.floppy_modes == floppy
        assert elastic_tensor(net, rotations=False, solver="direct").floppy_modes == 0


@pytest.mark.parametrize("rotations", [True, False])
def test_diamond_internal_relaxation(rotations):
    """Diamond (derived in docs/mechanics.md): the sublattices shift under shear, so the
    relaxed C44 = C44_aff - sqrt3 (kn-ks)^2 / (12 d (kn+2ks)) is below the affine
    C44_aff = sqrt3 (4kn+2ks)/(48 d); C11 = sqrt3 (kn+2ks)/(12 d), C12 = sqrt3 (kn-ks)/(12 d)
    are not relaxed. Rotations decouple by symmetry."""
    net = BondNetwork.from_packing(diamond(cells=2))
    et = elastic_tensor(net, rotations=rotations)
    c44a = S3 * (4 * KN + 2 * KS) / 48
    c44 = c44a - S3 * (KN - KS) ** 2 / (12 * (KN + 2 * KS))
    c11, c12 = S3 * (KN + 2 * KS) / 12, S3 * (KN - KS) / 12
    np.testing.assert_allclose(et.stiffness, cubic_tensor(c11, c12, c44), rtol=1e-6, atol=1e-6 * c11)
    np.testing.assert_allclose(et.affine_stiffness, cubic_tensor(c11, c12, c44a), rtol=1e-6, atol=1e-6 * c11)
    # the two sublattices move rigidly against each other along x under gamma_23
    u = et.nonaffine_displacements[3]
    sub = np.arange(net.n) % 8 >= 4
    shift = -(KN - KS) / ((KN + 2 * KS) * S3)  # per unit gamma_23, B relative to A (derivation)
    np.testing.assert_allclose(u[sub].mean(0) - u[~sub].mean(0), [shift, 0, 0], atol=1e-8)


# -------------------------------------------------------------- random packs
def test_random_pack_bounds_symmetry_and_affine_formula(jammed, jammed_net):
    et = elastic_tensor(jammed_net)
    c, ca = et.stiffness, et.affine_stiffness
    scale = np.abs(ca).max()
    # symmetric, positive semi-definite, relaxed <= affine in every strain mode
    assert et.asymmetry < 1e-8
    assert np.linalg.eigvalsh(c)[0] > -1e-9 * scale
    assert np.linalg.eigvalsh(ca - c)[0] > -1e-9 * scale
    assert np.all(np.diag(c) < np.diag(ca))
    # affine isotropic shear modulus of equal spheres: phi Z (kn + 1.5 ks) / (5 pi d);
    # bond lengths lie in [d, 1.01 d], so the sum of b^2 exceeds Z d^2 N/2 by < 2 %
    phi, z, d = jammed.volume_fraction, jammed_net.coordination, 1.0
    g_formula = phi * z * (KN + 1.5 * KS) / (5 * np.pi * d)
    assert et.affine_shear_modulus == pytest.approx(g_formula, rel=0.02)
    assert et.affine_shear_modulus >= g_formula * (1 - 1e-12)
    # a random jammed pack relaxes substantially (non-affine motion), but stays rigid
    assert 0.2 < et.relaxation_ratio < 0.9
    assert np.all(np.isnan(et.nonaffine_displacements[:, jammed_net.rattlers]))
    k, g = voigt_average(c)
    assert (k, g) == (et.bulk_modulus, et.shear_modulus)


def test_rotations_only_soften(jammed_net):
    """More degrees of freedom can only lower the relaxed energy: C(rot) <= C(no rot)."""
    a = elastic_tensor(jammed_net, rotations=True).stiffness
    b = elastic_tensor(jammed_net, rotations=False).stiffness
    assert np.linalg.eigvalsh(b - a)[0] > -1e-9 * np.abs(b).max()
    assert np.trace(b - a) > 1e-3 * np.trace(b)


@pytest.mark.parametrize("rotations", [True, False])
def test_multigrid_solver_agrees_with_the_direct_one(jammed_net, monkeypatch, rotations):
    """AMG-preconditioned CG (solver="amg"): coarsest level forced to 20 particle blocks, so the
    250-particle pack gets a real hierarchy (smoothing, restriction, prolongation); the tensor
    agrees with the sparse factorization to 1e-8 of its largest entry (CG to 1e-12 residual: a
    wrong cycle would either not converge, raising the residual, or not be symmetric, breaking CG)."""
    from polypack.mechanics import _elastic_solvers as el

    monkeypatch.setattr(el, "_AMG_MAX_COARSE", 20)
    ed = elastic_tensor(jammed_net, rotations=rotations, solver="direct")
    ea = elastic_tensor(jammed_net, rotations=rotations, solver="amg", tol=1e-12)
    assert len(ea.multigrid_levels) >= 2 and ea.residual <= 1e-12
    np.testing.assert_allclose(ea.stiffness, ed.stiffness, rtol=0, atol=1e-8 * np.abs(ed.stiffness).max())
    # the multigrid cycle cuts the iterations of block-Jacobi CG on the same system
    ec = elastic_tensor(jammed_net, rotations=rotations, solver="cg", tol=1e-12)
    assert ea.iterations < ec.iterations


def test_solvers_agree_and_floppy_count_matches_dense_spectrum(jammed_net):
    ed = elastic_tensor(jammed_net, solver="direct")
    ec = elastic_tensor(jammed_net, solver="cg", tol=1e-12)
    np.testing.assert_allclose(ec.stiffness, ed.stiffness, rtol=0, atol=1e-8 * np.abs(ed.stiffness).max())
    # floppy modes: count eigenvalues of the scaled, pinned Hessian below 1e-9 densely
    from polypack.mechanics.elastic import _hessian

    net = jammed_net
    act = ~net.rattlers
    idx = np.cumsum(act) - 1
    on = act[net.i] & act[net.j]
    h, _, _ = _hessian(int(act.sum()), idx[net.i[on]], idx[net.j[on]], net.normal_stiffness[on],
                       net.shear_stiffness[on], np.ascontiguousarray(net.normal[on]),
                       np.ascontiguousarray(net.branch[on]), np.ascontiguousarray(net.lever_arm_i[on]),
                       np.ascontiguousarray(net.lever_arm_j[on]), 0.5, True)
    hd = h.toarray()[3:, 3:]
    s = 1 / np.sqrt(np.diag(hd))
    ev = np.linalg.eigvalsh(hd * s[:, None] * s[None, :])
    assert ed.floppy_modes == int(np.count_nonzero(ev < 1e-9))


def test_invariance_translation_and_relabelling(jammed, jammed_net):
    ref = elastic_tensor(jammed_net).stiffness
    tol = 1e-8 * np.abs(ref).max()
    moved = jammed.replace(positions=jammed.positions + np.array([0.37, -1.9, 2.6]))
    np.testing.assert_allclose(elastic_tensor(BondNetwork.from_packing(moved)).stiffness, ref, atol=tol)
    perm = np.random.default_rng(4).permutation(jammed.n)
    relab = jammed.replace(positions=jammed.positions[perm], radii=jammed.radii[perm])
    et = elastic_tensor(BondNetwork.from_packing(relab))
    np.testing.assert_allclose(et.stiffness, ref, atol=tol)
    # the non-affine field moves with the labels
    e0 = elastic_tensor(jammed_net)
    np.testing.assert_allclose(et.nonaffine_displacements[:, :, :], e0.nonaffine_displacements[:, perm],
                               atol=1e-7, equal_nan=True)


def _energy_and_grad(q, net, eps_voigt, nd):
    """Harmonic bond energy written directly (numpy only) and its gradient."""
    n = net.n
    q = q.reshape(n, nd)
    e = np.array([[eps_voigt[0], eps_voigt[5] / 2, eps_voigt[4] / 2],
                  [eps_voigt[5] / 2, eps_voigt[1], eps_voigt[3] / 2],
                  [eps_voigt[4] / 2, eps_voigt[3] / 2, eps_voigt[2]]])
    i, j, nrm = net.i, net.j, net.normal
    delta = q[j, :3] - q[i, :3] + net.branch @ e.T
    if nd == 6:
        delta += np.cross(q[j, 3:], net.lever_arm_j) - np.cross(q[i, 3:], net.lever_arm_i)
    dn = np.einsum("ij,ij->i", delta, nrm)
    f = net.shear_stiffness[:, None] * delta + ((net.normal_stiffness - net.shear_stiffness) * dn)[:, None] * nrm
    energy = 0.5 * np.einsum("ij,ij->", f, delta)
    g = np.zeros((n, nd))
    np.add.at(g[:, :3], j, f)
    np.add.at(g[:, :3], i, -f)
    if nd == 6:  # d/dtheta of f . (theta x a) = a x f
        np.add.at(g[:, 3:], j, np.cross(net.lever_arm_j, f))
        np.add.at(g[:, 3:], i, -np.cross(net.lever_arm_i, f))
    return energy, g.ravel(), f


@pytest.mark.parametrize("rotations", [True, False])
def test_finite_strain_with_independent_optimiser(rotations):
    """Apply +-1e-6 strain, minimise the bond energy with scipy's Newton-CG, compare sigma = sum f b / V."""
    pk = pp.pack(np.full(120, 0.5), volume_fraction="jammed", seed=21)
    net = BondNetwork.from_packing(pk, epsilon=0.02)
    et = elastic_tensor(net, rotations=rotations)
    nd = 6 if rotations else 3
    h = 1e-6
    for mode in (0, 3, 5):
        sig = []
        for sgn in (1.0, -1.0):
            eps = np.zeros(6)
            eps[mode] = sgn * h
            g0 = _energy_and_grad(np.zeros(net.n * nd), net, eps, nd)[1]
            res = scipy.optimize.minimize(
                lambda q, *a: _energy_and_grad(q, *a)[0], np.zeros(net.n * nd), args=(net, eps, nd),
                jac=lambda q, *a: _energy_and_grad(q, *a)[1], method="Newton-CG",
                # the energy is quadratic: H v = grad(v) - grad(0) exactly
                hessp=lambda q, v, *a: _energy_and_grad(v, *a)[1] - g0,
                options={"maxiter": 200, "xtol": 1e-14})
            f = _energy_and_grad(res.x, net, eps, nd)[2]
            s = np.einsum("ci,cj->ij", f, net.branch) / pk.box_volume
            if rotations:  # torque balance at equilibrium makes sum f b^T symmetric
                assert np.abs(s - s.T).max() < 1e-3 * np.abs(s).max()
            # particles held against rotation carry torques: the work-conjugate stress is
            # the symmetric part
            s = 0.5 * (s + s.T)
            sig.append(np.array([s[0, 0], s[1, 1], s[2, 2], s[1, 2], s[0, 2], s[0, 1]]))
        col = (sig[0] - sig[1]) / (2 * h)
        # 1e-4 of the largest entry: well above the optimiser's stopping error, far below
        # the non-affine relaxation (> 5 % of the largest entry, checked next)
        np.testing.assert_allclose(col, et.stiffness[:, mode], atol=1e-4 * np.abs(et.stiffness).max())
        assert np.abs(col - et.affine_stiffness[:, mode]).max() > 0.05 * np.abs(et.stiffness).max()


# --------------------------------------------------------------------- units
def test_si_units_from_radius(jammed_net):
    et = elastic_tensor(jammed_net)
    si = elastic_tensor(jammed_net, radius=0.25e-6)
    # stiffness per length: lengths scaled by 0.25e-6 / 0.5 divide the moduli by that factor
    np.testing.assert_allclose(si.stiffness, et.stiffness * 0.5 / 0.25e-6, rtol=1e-12)
    assert si.units == "Pa" and si.to_dict()["shear_modulus_MPa"] == pytest.approx(si.shear_modulus * 1e-6)
    np.testing.assert_allclose(si.reduced_stiffness, et.reduced_stiffness, rtol=1e-12)
    np.testing.assert_allclose(et.reduced_stiffness, et.stiffness * 1.0 / KN, rtol=1e-12)


# -------------------------------------------------------------------- errors
def test_disconnected_network_is_floppy():
    """No bonded cluster wraps the box (issue 31): G = 0 and "floppy", never a number."""
    pk = pp.pack(np.full(200, 0.5), volume_fraction=0.3, seed=2)
    net = BondNetwork.from_packing(pk, epsilon=0.05)
    et = elastic_tensor(net)
    assert not et.rigid and et.status == "floppy" and et.floppy_strains == 6
    assert "disconnected" in et.floppy_reason
    assert np.all(et.stiffness == 0.0) and et.shear_modulus == 0.0 and et.affine_shear_modulus > 0
    d = et.to_dict()
    assert d["status"] == "floppy" and d["shear_modulus"] == 0.0 and d["relaxation_ratio"] == 0.0


def _chains(n=4, m=2, d=1.0):
    """``m x m`` parallel straight chains of ``n`` touching spheres along x, ``2 d`` apart."""
    x = (np.arange(n) + 0.5) * d
    yz = (2 * np.arange(m) + 1.0) * d
    pos = np.array([[a, b, c] for a in x for b in yz for c in yz])
    return pp.Packing(pos, np.full(len(pos), d / 2), [n * d, 2 * m * d, 2 * m * d])


@pytest.mark.parametrize("solver", ["direct", "cg"])
def test_straight_chains_partly_floppy_closed_form(solver):
    """Bonds only along x, one per (d x 2d x 2d) cell: C11 = kn / (4 d) exactly. With
    rotations a uniform spin cancels the tangential load of gamma_12 and gamma_13, so 5 of
    the 6 strain modes are floppy; without rotations C55 = C66 = ks d^2/4 / (4 d^3) =
    ks / (16 d) and 3 are (22, 33, 23: no bond). The spin about a chain's axis touches no
    bond (an empty row of H; it broke the factorization before issue 31)."""
    net = BondNetwork.from_packing(_chains(), epsilon=0.01, normal_stiffness=KN, shear_stiffness=KS)
    for rotations, want, soft in [(True, np.diag([KN / 4, 0, 0, 0, 0, 0]), 5),
                                  (False, np.diag([KN / 4, 0, 0, 0, KS / 16, KS / 16]), 3)]:
        et = elastic_tensor(net, rotations=rotations, solver=solver)
        np.testing.assert_allclose(et.stiffness, want, rtol=1e-9, atol=1e-9 * KN)
        assert et.floppy_strains == soft and not et.rigid and et.status == "floppy"
        assert np.all(et.stiffness[want == 0] == 0.0)  # exactly zero, not round-off


@pytest.mark.parametrize("solver", ["direct", "cg"])
def test_floppy_and_rigid_random_networks(solver):
    """A phi = 0.4 pack bonded to Z = 3.0 and 3.5 (below the isostatic 4: the raw relaxed
    moduli are 1e-30 to 1e-18 of the affine one) is floppy with G = 0 exactly; bonded to
    Z = 4.7 it is rigid, G / G_aff = 0.142 (its moduli are 1e-3 to 1e-1 of the affine ones)."""
    from polypack.neighbors import pairs_within

    pk = pp.pack(np.full(300, 0.5), volume_fraction=0.4, seed=5, progress=False)
    i, j, d = pairs_within(pk.positions, pk.radii, pk.box, a=1.5)
    gaps = np.sort(d / (pk.radii[i] + pk.radii[j]) - 1.0)
    for z, rigid in [(3.0, False), (3.5, False), (4.7, True)]:
        net = BondNetwork.from_packing(pk, epsilon=float(gaps[int(round(z * pk.n / 2)) - 1]))
        et = elastic_tensor(net, solver=solver)
        assert et.rigid is rigid and et.floppy_strains == (0 if rigid else 6), z
        if rigid:
            assert et.relaxation_ratio == pytest.approx(0.1422, abs=2e-3)
        else:
            assert np.all(et.stiffness == 0.0) and et.shear_modulus == 0.0 and "6 of 6" in et.floppy_reason


def test_bad_input(jammed):
    with pytest.raises(InvalidInputError, match="zero-gap"):
        elastic_tensor(BondNetwork.from_packing(jammed, reference="zero-gap"))
    net = BondNetwork.from_packing(jammed)
    with pytest.raises(InvalidInputError, match="solver='lu'"):
        elastic_tensor(net, solver="lu")
    with pytest.raises(InvalidInputError, match="radius=-1"):
        elastic_tensor(net, radius=-1.0)
    with pytest.raises(InvalidInputError, match="BondNetwork"):
        elastic_tensor(jammed)


def test_2d_is_refused():
    rng = np.random.default_rng(0)
    disks = pp.Packing(rng.random((50, 2)) * 10, np.full(50, 0.8), [10.0, 10.0])
    with pytest.raises(InvalidInputError, match="dim=2"):
        elastic_tensor(BondNetwork.from_packing(disks))
    walls = pp.Packing(rng.random((50, 3)) * [10, 10, 8] + [0, 0, 1], np.full(50, 0.8), 10.0,
                       periodic=(True, True, False))
    with pytest.raises(InvalidInputError, match="periodic"):
        elastic_tensor(BondNetwork.from_packing(walls, epsilon=0.5))


def test_agrees_with_the_dem_static_solver(jammed_net):
    """polypack.mechanics.dem has its own linearised solver (simple shear, separate assembly):
    C44, C55, C66 agree to solver precision (1e-7 relative)."""
    from polypack.mechanics import static_shear_modulus

    et = elastic_tensor(jammed_net)
    other = [static_shear_modulus(jammed_net, 2, 1), static_shear_modulus(jammed_net, 2, 0),
             static_shear_modulus(jammed_net, 1, 0)]
    np.testing.assert_allclose(et.shear_moduli, other, rtol=1e-7)


# ---------------------------------------------- factorizations and solver choice
@pytest.fixture(scope="module")
def loose_net():
    """A phi = 0.4 hard-sphere fluid bonded out to Z ~ 4.7 (near-isostatic, many floppy modes)."""
    from polypack.neighbors import pairs_within

    pk = pp.pack(np.full(300, 0.5), volume_fraction=0.4, seed=5, progress=False)
    i, j, d = pairs_within(pk.positions, pk.radii, pk.box, a=1.5)
    gaps = np.sort(d / (pk.radii[i] + pk.radii[j]) - 1.0)
    return BondNetwork.from_packing(pk, epsilon=float(gaps[int(round(4.7 * pk.n / 2)) - 1]))


def _has_pardiso():
    from polypack.mechanics import _elastic_solvers as el

    return el._pardiso_module() is not None


@pytest.mark.parametrize("which", ["jammed", "loose"])
def test_pardiso_and_superlu_factorizations_agree(which, jammed_net, loose_net, monkeypatch):
    """The PARDISO path (one indefinite factorization: inertia count and solve) against the
    SuperLU one (two factorizations, no pivoting) and block-Jacobi CG: the tensor to 1e-8 of
    its largest entry (both refine to a 1e-12 residual; near-isostatic networks amplify it by
    ~1e3), the same floppy-mode count and the same minimum-norm non-affine field (1e-6 in
    norm: a field with a floppy component left is off by O(1))."""
    from polypack.mechanics import _elastic_solvers as el

    if not _has_pardiso():
        pytest.skip("pypardiso (MKL) is not installed on this platform: only the SuperLU path exists")
    net = jammed_net if which == "jammed" else loose_net
    ep = elastic_tensor(net, solver="direct")
    assert ep.factorization == "pardiso"
    monkeypatch.setattr(el, "_pardiso_module", lambda: None)
    es = elastic_tensor(net, solver="direct")
    assert es.factorization == "superlu"
    scale = np.abs(es.stiffness).max()
    np.testing.assert_allclose(ep.stiffness, es.stiffness, rtol=0, atol=1e-8 * scale)
    ec = elastic_tensor(net, solver="cg", tol=1e-10)
    np.testing.assert_allclose(ec.stiffness, es.stiffness, rtol=0, atol=1e-7 * scale)
    assert ep.floppy_modes == es.floppy_modes
    if which == "loose":
        assert ep.floppy_modes > 5  # the case the local spin modes are for
    for a, b in [(ep.nonaffine_displacements, es.nonaffine_displacements),
                 (ep.nonaffine_rotations, es.nonaffine_rotations)]:
        assert np.array_equal(np.isnan(a), np.isnan(b))
        ok = ~np.isnan(b)
        assert np.linalg.norm(a[ok] - b[ok]) < 1e-6 * np.linalg.norm(b[ok])


def test_local_spin_modes_are_floppy(loose_net):
    """Every unpinned particle with two bonds spins freely about the line through its contact
    points: h v = 0 to round-off (1e-12 of the largest diagonal entry; a wrong lever arm or
    rotation scaling leaves O(k_n) forces), unit norm, and no more of them than floppy modes."""
    from polypack.mechanics import _elastic_solvers as el
    from polypack.mechanics import elastic

    net = loose_net
    act = ~net.rattlers
    idx = np.cumsum(act) - 1
    on = act[net.i] & act[net.j]
    n, nd = int(act.sum()), 6
    bi, bj = idx[net.i[on]], idx[net.j[on]]
    ell = float(net.packing.radii[act].mean())
    h, _, _ = elastic._hessian(n, bi, bj, net.normal_stiffness[on], net.shear_stiffness[on],
                          np.ascontiguousarray(net.normal[on]), np.ascontiguousarray(net.branch[on]),
                          np.ascontiguousarray(net.lever_arm_i[on]), np.ascontiguousarray(net.lever_arm_j[on]),
                          ell, True)
    keep = np.ones(n * nd, bool)
    keep[:3] = False
    hr = h.tocsr()[keep][:, keep]
    v = el._local_spin_modes(n, nd, keep, bi, bj, net.lever_arm_i[on], net.lever_arm_j[on], ell)
    deg = np.bincount(np.concatenate([bi, bj]), minlength=n)
    assert v.shape[1] == int(np.count_nonzero(deg[1:] == 2))  # particle 0 is pinned
    assert v.shape[1] > 0
    np.testing.assert_allclose(np.sqrt(np.asarray(v.multiply(v).sum(axis=0))).ravel(), 1.0, atol=1e-12)
    assert np.abs(hr @ v.toarray()).max() < 1e-12 * hr.diagonal().max()
    assert v.shape[1] <= elastic_tensor(net, solver="direct").floppy_modes


def test_auto_solver_rule(monkeypatch):
    """solver="auto": the factorization for small systems and (with PARDISO) for near-isostatic
    ones up to _PARDISO_MAX unknowns; CG / AMG-CG for well-connected or larger networks."""
    from polypack.mechanics import _elastic_solvers as el

    monkeypatch.setattr(el, "_pardiso_module", lambda: object())
    assert el._auto_solver(5000, 6.6, 6) == "direct"
    assert el._auto_solver(48000, 4.7, 6) == "direct"      # phi = 0.4 gel-like network
    assert el._auto_solver(48000, 6.6, 6) == "amg"         # jammed pack
    assert el._auto_solver(12000, 6.6, 6) == "direct"
    assert el._auto_solver(13000, 6.6, 6) == "cg"
    assert el._auto_solver(24000, 2.5, 3) == "direct"      # translations only: isostatic Z = 2
    assert el._auto_solver(600000, 4.7, 6) == "amg"        # too large to factorize
    monkeypatch.setattr(el, "_pardiso_module", lambda: None)
    assert el._auto_solver(48000, 4.7, 6) == "amg"
    assert el._auto_solver(5000, 4.7, 6) == "direct"
    assert el._auto_solver(12000, 6.6, 6) == "cg"


def test_moduli_do_not_depend_on_the_collective_floppy_projection(loose_net, monkeypatch):
    """Above _FLOPPY_BASIS_MAX collective floppy modes the dense basis is skipped (it costs
    O(n k^2)); a floppy mode carries no stress, so the tensor and the floppy count must be the
    same with and without it, to the solve's 1e-8 of the largest entry."""
    from polypack.mechanics import _elastic_solvers as el

    full = elastic_tensor(loose_net, solver="direct")
    monkeypatch.setattr(el, "_FLOPPY_BASIS_MAX", -1)
    capped = elastic_tensor(loose_net, solver="direct")
    scale = np.abs(full.stiffness).max()
    np.testing.assert_allclose(capped.stiffness, full.stiffness, rtol=0, atol=1e-8 * scale)
    assert capped.floppy_modes == full.floppy_modes > 5
