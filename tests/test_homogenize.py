"""Full-field FFT homogenization (pp.mechanics.homogenize) against exact results and a second solver."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as sla

import polypack as pp
from polypack.errors import InvalidInputError
from polypack.mechanics import Phase, dilute, hashin_shtrikman, homogenize, mori_tanaka, three_point_bounds
from polypack.mechanics.fullfield import richardson

EPOXY, GLASS = Phase.from_young(3.01e9, 0.394), Phase.from_young(76e9, 0.23)


def _lm(p):
    return p.bulk - 2.0 * p.shear / 3.0, p.shear


def test_homogeneous_medium_is_the_phase_exactly():
    lab = np.zeros((8, 8, 8), np.int64)
    r = homogenize(lab, EPOXY, GLASS)
    assert r.iterations == [0] * 6 and r.converged
    assert r.bulk == pytest.approx(EPOXY.bulk, rel=1e-14) and r.shear == pytest.approx(EPOXY.shear, rel=1e-14)
    lam, mu = _lm(EPOXY)
    assert r.stiffness[0, 1] == pytest.approx(lam, rel=1e-13) and r.stiffness[3, 3] == pytest.approx(mu, rel=1e-13)
    # every voxel an inclusion: the inclusion phase
    r = homogenize(np.ones((6, 6, 6), np.int64), EPOXY, GLASS)
    assert r.shear == pytest.approx(GLASS.shear, rel=1e-14)
    c = homogenize(np.ones((5, 7), np.int64), 2.0, 3.5, property="conductivity").conductivity
    assert c == pytest.approx(3.5 * np.eye(2), rel=1e-14)


@pytest.mark.parametrize("scheme", ["willot", "fourier"])
def test_laminate_is_exactly_backus(scheme):
    # layers normal to x: the exact effective tensor of a laminate (Backus averages)
    lab = np.zeros((16, 4, 4), np.int64)
    lab[3:9] = 1
    c = 6 / 16
    r = homogenize(lab, EPOXY, GLASS, tolerance=1e-12, scheme=scheme)
    assert r.converged

    def avg(f):
        return (1 - c) * f(*_lm(EPOXY)) + c * f(*_lm(GLASS))

    c11 = 1.0 / avg(lambda lam, mu: 1.0 / (lam + 2 * mu))
    lm = avg(lambda lam, mu: lam / (lam + 2 * mu))
    exact = {
        (0, 0): c11, (0, 1): lm * c11, (0, 2): lm * c11,
        (1, 1): avg(lambda lam, mu: 4 * mu * (lam + mu) / (lam + 2 * mu)) + lm ** 2 * c11,
        (1, 2): avg(lambda lam, mu: 2 * mu * lam / (lam + 2 * mu)) + lm ** 2 * c11,
        (3, 3): avg(lambda lam, mu: mu),                                  # Voigt along the layers
        (4, 4): 1.0 / avg(lambda lam, mu: 1.0 / mu), (5, 5): 1.0 / avg(lambda lam, mu: 1.0 / mu),  # Reuss across
    }
    for (i, j), v in exact.items():
        assert r.stiffness[i, j] == pytest.approx(v, rel=1e-9), (i, j)
    assert r.stiffness[2, 2] == pytest.approx(exact[(1, 1)], rel=1e-9)
    assert abs(r.stiffness[0, 3]) < 1e-9 * c11
    k = homogenize(lab, 1.0, 20.0, property="conductivity", tolerance=1e-12, scheme=scheme).conductivity
    assert k[0, 0] == pytest.approx(1.0 / ((1 - c) + c / 20.0), rel=1e-10)
    assert k[1, 1] == pytest.approx((1 - c) + 20.0 * c, rel=1e-10)
    # 2D: layers normal to y
    k2 = homogenize(lab[:, :, 0].T.copy(), 1.0, 20.0, property="conductivity", tolerance=1e-12).conductivity
    assert k2[1, 1] == pytest.approx(1.0 / ((1 - c) + c / 20.0), rel=1e-10)


def _one_sphere(c):
    return pp.Packing(np.array([[0.5, 0.5, 0.5]]), np.array([(3 * c / (4 * np.pi)) ** (1 / 3)]), np.ones(3))


def _slopes(r, c):
    return (r.bulk / EPOXY.bulk - 1) / c, (r.shear / EPOXY.shear - 1) / c


def test_dilute_sphere_matches_eshelby_at_low_contrast():
    # c = 0.01, inclusion 1.5x the matrix: the dilute (Eshelby) slopes to 0.5 % (the voxel
    # volume fraction is used: the staircase sphere has that volume), Mori-Tanaka (which adds
    # the O(c) interaction) to 0.15 %
    soft = Phase(1.5 * EPOXY.bulk, 1.5 * EPOXY.shear)
    r = homogenize(_one_sphere(0.01), EPOXY, soft, 32)
    cv = r.volume_fractions["voxel"][1]
    d = dilute(EPOXY, [soft], [1.0])
    exact = ((d.bulk / EPOXY.bulk - 1), (d.shear / EPOXY.shear - 1))
    for got, want in zip(_slopes(r, cv), exact):
        assert got == pytest.approx(want, rel=5e-3)
    mt = mori_tanaka(EPOXY, [soft], [cv])
    assert r.bulk == pytest.approx(mt.bulk, rel=1.5e-3 * cv) and r.shear == pytest.approx(mt.shear, rel=1.5e-3 * cv)


def test_dilute_glass_sphere_error_falls_with_resolution():
    # glass in epoxy (contrast 25), c = 0.008: the staircase surface stiffens the sphere; the
    # error of the dilute slope (mean over three sub-voxel positions of the centre, which
    # smooths the staircase noise) falls as the sphere spans more voxels (measured: bulk
    # 7.4, 4.5, 3.2 %, shear 12.8, 10.7, 7.9 % at n = 12, 24, 40)
    d = dilute(EPOXY, [GLASS], [1.0])
    exact = np.array([d.bulk / EPOXY.bulk - 1, d.shear / EPOXY.shear - 1])
    offsets = np.random.default_rng(0).random((3, 3))
    errs = []
    for n in (12, 24, 40):
        s = []
        for o in offsets:
            pk = pp.Packing(np.array([0.5 + o / n]), np.array([(3 * 0.008 / (4 * np.pi)) ** (1 / 3)]), np.ones(3))
            r = homogenize(pk, EPOXY, GLASS, n)
            s.append(_slopes(r, r.volume_fractions["voxel"][1]))
        errs.append(np.abs(np.mean(s, axis=0) / exact - 1))
    errs = np.array(errs)
    assert np.all(errs[1] < errs[0]) and np.all(errs[2] < errs[1])
    assert errs[2][0] < 0.045 and errs[2][1] < 0.09


def test_composite_voxels_converge_to_the_dilute_slope_at_the_exact_fraction():
    # coated (HS lower) composite voxels from sub-voxel fractions: the phase volume is exact,
    # so the slope is taken at the exact c; the error falls monotonically without averaging
    # over centre positions (measured bulk 7.9, 4.0, 2.9 %, shear 9.1, 5.4, 4.7 % at n = 12, 24, 40)
    d = dilute(EPOXY, [GLASS], [1.0])
    exact = np.array([d.bulk / EPOXY.bulk - 1, d.shear / EPOXY.shear - 1])
    errs = np.array([np.abs(np.array(_slopes(homogenize(_one_sphere(0.008), EPOXY, GLASS, n, composite=True), 0.008))
                            / exact - 1) for n in (12, 24, 40)])
    assert np.all(errs[1] < errs[0]) and np.all(errs[2] < errs[1])
    assert errs[2][0] < 0.035 and errs[2][1] < 0.055


def test_composite_voxels_follow_rayleigh_at_first_order():
    # simple cubic array, conductivity contrast 10, against Rayleigh at the exact c: the error
    # halves with the voxel size (measured 1.0 -> 0.51 % at c = 0.1, 2.4 -> 1.2 % at c = 0.3)
    for c in (0.1, 0.3):
        pos = np.array([[i + 0.5, j + 0.5, k + 0.5] for i in range(2) for j in range(2) for k in range(2)], float)
        pk = pp.Packing(pos, np.full(8, (3 * c / (4 * np.pi)) ** (1 / 3)), np.full(3, 2.0))
        e = [homogenize(pk, 1.0, 10.0, 2 * n, property="conductivity", composite=True).mean_conductivity
             / _rayleigh(c, 10.0) - 1 for n in (16, 32)]
        assert 0 < e[1] < 0.6 * e[0] and e[1] < 0.013
    with pytest.raises(InvalidInputError, match="composite=True needs"):
        homogenize(np.zeros((4, 4, 4), np.int64), 1.0, 2.0, property="conductivity", composite=True)


def _rayleigh(c, a, coef=1.305):
    """Rayleigh's series for a simple cubic array (McPhedran & McKenzie 1978): MG + the c^(10/3) term."""
    b, g = (a - 1) / (a + 2), (a - 1) / (a + 4 / 3)
    return 1 + 3 * c / (1 / b - c - coef * g * c ** (10 / 3))


def _sc_cell(c, n):
    """One unit cell (n^3 voxels) of a simple cubic array: the sub-block of a 2x2x2 periodic pack."""
    pos = np.array([[i + 0.5, j + 0.5, k + 0.5] for i in range(2) for j in range(2) for k in range(2)], float)
    pk = pp.Packing(pos, np.full(8, (3 * c / (4 * np.pi)) ** (1 / 3)), np.full(3, 2.0))
    return pp.io.voxelize(pk, 2 * n).labels[:n, :n, :n].astype(np.int64)


@pytest.mark.parametrize("c", [0.1, 0.2, 0.3])
def test_simple_cubic_conductivity_follows_rayleigh(c):
    a = 10.0
    lab = _sc_cell(c, 32)
    cv = lab.mean()
    r = homogenize(lab, 1.0, a, property="conductivity")
    assert r.converged and r.anisotropy < 1e-10  # cubic symmetry
    k = r.mean_conductivity
    assert k == pytest.approx(_rayleigh(cv, a), rel=0.013)
    if c == 0.3:  # the c^(10/3) term is resolved: closer to Rayleigh than to Maxwell-Garnett
        assert abs(k - _rayleigh(cv, a)) < 0.6 * abs(k - _rayleigh(cv, a, coef=0.0))


def _fv_conductivity(kf, axis):
    """Independent solver: finite volumes (two-point flux, harmonic face conductance), periodic."""
    n, N = kf.shape, kf.size
    idx = np.arange(N).reshape(n)
    rows, cols, vals, rhs = [], [], [], np.zeros(N)
    for a in range(3):
        j = np.roll(idx, -1, axis=a).ravel()
        i = idx.ravel()
        g = (2 * kf * np.roll(kf, -1, axis=a) / (kf + np.roll(kf, -1, axis=a))).ravel()
        rows += [i, i, j, j]
        cols += [i, j, j, i]
        vals += [g, -g, g, -g]
        if a == axis:
            np.add.at(rhs, i, g)
            np.add.at(rhs, j, -g)
    A = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(N, N))
    t, info = sla.cg(A, rhs, rtol=1e-8, maxiter=5000, M=sp.diags(1.0 / A.diagonal()))
    assert info == 0
    j = np.roll(idx, -1, axis=axis).ravel()
    g = (2 * kf * np.roll(kf, -1, axis=axis) / (kf + np.roll(kf, -1, axis=axis))).ravel()
    return float(np.mean(g * (1 + t[j] - t)))


@pytest.fixture(scope="module")
def pack30():
    return pp.pack(np.full(20, 1.0), volume_fraction=0.3, seed=1)


def test_random_pack_agrees_with_a_finite_volume_solver(pack30):
    # two discretizations of the same images: their gap is discretization error and shrinks
    # about as the voxel size (measured 13, 7.3, 5.5 % at n = 12, 20, 28)
    gaps = []
    for n in (12, 20, 28):
        im = pp.io.voxelize(pack30, n)
        kf = np.where(im.labels > 0, 10.0, 1.0)
        fft = homogenize(im, 1.0, 10.0, property="conductivity").conductivity
        fv = np.array([_fv_conductivity(kf, a) for a in range(3)])
        gaps.append(np.abs(np.diag(fft) / fv - 1))
    assert np.all(gaps[1] < 0.7 * gaps[0]) and np.all(gaps[2] < 0.85 * gaps[1]) and np.all(gaps[2] < 0.065)


def test_random_pack_inside_hs_and_three_point_bounds(pack30):
    from polypack.analysis import ThreePointParameters

    r = homogenize(pack30, EPOXY, GLASS, 24)
    c = float(pack30.volume_fraction)
    tp = ThreePointParameters().compute(pack30)
    lo3, up3 = three_point_bounds(EPOXY, GLASS, c, tp.zeta2, tp.eta2)
    lo, up = hashin_shtrikman([EPOXY, GLASS], [1 - c, c])
    assert r.converged
    assert lo.bulk < lo3.bulk < r.bulk < up3.bulk < up.bulk
    assert lo.shear < lo3.shear < r.shear < up3.shear < up.shear
    # symmetric positive-definite, near-isotropic (20 spheres: a few per cent of sampling anisotropy)
    assert r.asymmetry < 1e-6
    assert np.linalg.eigvalsh(r.stiffness).min() > 0
    assert r.anisotropy < 0.12
    # the continuous-symbol scheme agrees to discretization error
    f = homogenize(pack30, EPOXY, GLASS, 24, scheme="fourier")
    assert f.shear == pytest.approx(r.shear, rel=0.05) and f.bulk == pytest.approx(r.bulk, rel=0.03)


def test_single_precision_gives_the_same_moduli(pack30):
    im = pp.io.voxelize(pack30, 16)
    d = homogenize(im, EPOXY, GLASS, tolerance=1e-5)
    s = homogenize(im, EPOXY, GLASS, tolerance=1e-5, precision="single")
    assert s.iterations == d.iterations
    assert s.stiffness == pytest.approx(d.stiffness, rel=2e-5, abs=2e-5 * d.stiffness.max())
    with pytest.raises(InvalidInputError, match="precision="):
        homogenize(im, EPOXY, GLASS, precision="half")


def test_voids_and_near_rigid_inclusions_converge(pack30):
    im = pp.io.voxelize(pack30, 16)
    void = homogenize(im, EPOXY, Phase(0.0, 0.0), tolerance=1e-6)
    lo, up = hashin_shtrikman([EPOXY, Phase(0.0, 0.0)], [0.7, 0.3])
    assert void.converged and 0 < void.shear < up.shear and 0 < void.bulk < up.bulk
    stiff = homogenize(im, EPOXY, Phase(5e4 * EPOXY.bulk, 5e4 * EPOXY.shear), tolerance=1e-6)
    assert stiff.converged and stiff.shear > homogenize(im, EPOXY, GLASS).shear
    assert max(stiff.iterations) < 400


def test_non_convergence_is_reported(pack30):
    r = homogenize(pack30, EPOXY, GLASS, 12, max_iterations=2)
    assert not r.converged and r.to_dict()["converged"] is False


def test_richardson_recovers_a_known_limit():
    n = np.array([16, 32, 64])
    est = richardson(n, 2.0 + 3.0 / n ** 2)
    assert est["value"] == pytest.approx(2.0, rel=1e-12) and est["order"] == pytest.approx(2.0)
    assert richardson([16, 32], [1.5, 1.25])["value"] == pytest.approx(1.0)  # first order assumed


def test_resolution_series_and_to_dict(pack30):
    r = homogenize(pack30, 1.0, 10.0, resolutions=[8, 12, 16], property="conductivity")
    assert [c["resolution"][0] for c in r.convergence] == [8, 12, 16]
    assert set(r.extrapolated) == {"mean_conductivity"}
    d = r.to_dict()
    assert d["resolution"] == [16, 16, 16] and d["mean_conductivity"] == pytest.approx(r.mean_conductivity)


def test_bad_input():
    lab = np.zeros((4, 4, 4), np.int64)
    with pytest.raises(InvalidInputError, match="property="):
        homogenize(lab, EPOXY, GLASS, property="thermal")
    with pytest.raises(InvalidInputError, match="finite moduli"):
        homogenize(lab, EPOXY, Phase(np.inf, np.inf))
    with pytest.raises(InvalidInputError, match="tolerance="):
        homogenize(lab, EPOXY, GLASS, tolerance=0)
    with pytest.raises(InvalidInputError, match="scheme="):
        homogenize(lab, EPOXY, GLASS, scheme="x")
    with pytest.raises(InvalidInputError, match="3D"):
        homogenize(np.zeros((4, 4), np.int64), EPOXY, GLASS)
    with pytest.raises(InvalidInputError, match="Phase"):
        homogenize(lab, 1.0, GLASS)
    with pytest.raises(InvalidInputError, match="conductivity"):
        homogenize(lab, 1.0, -2.0, property="conductivity")
    with pytest.raises(InvalidInputError, match="backend="):
        homogenize(lab, EPOXY, GLASS, backend="torch")
