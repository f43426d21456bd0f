"""Three-point parameters ζ2, η2 of sphere packs: closed forms, brute force, hard-sphere literature."""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import eval_legendre

import polypack as pp
from polypack._kernels.threepoint import _basis, ball_inverse_power
from polypack.analysis.threepoint import ThreePointParameters, ball_quadrature, harmonic_weights
from polypack.errors import InvalidInputError, NotComputedError


def _hard_spheres(n, phi, seed, shakes=10, radii=1.0):
    pk = pp.pack(np.broadcast_to(radii, (n,)).copy() if np.ndim(radii) == 0 else radii, volume_fraction=phi, seed=seed)
    return pp.shake(pk, global_shakes=shakes, seed=seed + 1000, method="metropolis")


@pytest.mark.parametrize("a,d,m", [(1.0, 2.3, 3), (1.0, 1.3, 4), (0.3, 5.0, 5), (1.0, 10.0, 3), (0.05, 6.0, 5)])
def test_ball_inverse_power_closed_form(a, d, m):
    def shell(rho):
        return np.pi * rho / (d * (m - 1)) * ((d - rho) ** (2 - 2 * m) - (d + rho) ** (2 - 2 * m))

    assert ball_inverse_power(a, d, m) == pytest.approx(quad(shell, 0, a, epsabs=0, epsrel=1e-13)[0], rel=1e-8)
    # independent check: Monte Carlo-free cubature of the ball in spherical coordinates
    pts, w = ball_quadrature(40, 40)
    x = a * pts
    val = (a**3) * np.sum(w * np.linalg.norm(x - np.array([0, 0, d]), axis=1) ** (-2 * m))
    assert ball_inverse_power(a, d, m) == pytest.approx(val, rel=2e-3 if d - a < 0.5 else 1e-6)


def test_harmonic_weights_give_legendre_addition_theorem():
    inv2, inv4 = harmonic_weights()
    rng = np.random.default_rng(1)
    b = [np.empty(5), np.empty(9), np.empty(5), np.empty(9)]
    for _ in range(20):
        u, v = rng.normal(size=(2, 3))
        u, v = u / np.linalg.norm(u), v / np.linalg.norm(v)
        _basis(*u, b[0], b[1])
        _basis(*v, b[2], b[3])
        assert np.sum(inv2 * b[0] * b[2]) == pytest.approx(eval_legendre(2, u @ v), abs=1e-12)
        assert np.sum(inv4 * b[1] * b[3]) == pytest.approx(eval_legendre(4, u @ v), abs=1e-12)


def test_ball_quadrature_weights():
    pts, w = ball_quadrature(4, 6)
    assert w.sum() == pytest.approx(4 * np.pi / 3, rel=1e-13)
    assert np.all(np.linalg.norm(pts, axis=1) < 1)
    # exact for a low-degree polynomial: int_B x^2 y^2 = 4 pi / 105
    assert np.sum(w * pts[:, 0] ** 2 * pts[:, 1] ** 2) == pytest.approx(4 * np.pi / 105, rel=1e-12)


def test_dilute_coefficients_from_the_pair_integral():
    # ζ2 and η2 to first order in φ: the pair terms with g = 1 beyond contact; this checks the
    # normalisations (9/2, 5/21, 150/7, 8π²) and the ball factor 1 - 7a²/(5D²) of the P4 field.
    def avg(r, s, m):  # mean of |x - y|^(-2m) over the sphere |y| = r, |x| = s < r
        lo, hi = (r - s) ** 2, (r + s) ** 2
        return (lo ** (1 - m) - hi ** (1 - m)) / ((m - 1) * 4 * r * s)

    def j(l):
        def inner(s):
            def f(r):
                if l == 2:
                    return 4 * np.pi * r * r * avg(r, s, 3)
                return 4 * np.pi * r * r * (avg(r, s, 3) - 2.8 * avg(r, s, 4) + 1.96 * avg(r, s, 5))

            return quad(f, 2, np.inf, epsrel=1e-12)[0]

        return quad(lambda s: 4 * np.pi * s * s * inner(s), 0, 1, epsrel=1e-12)[0] / (8 * np.pi**2)

    zeta_slope = 4.5 * j(2)
    eta_slope = 5 * zeta_slope / 21 + 150 / 7 * j(4)
    assert zeta_slope == pytest.approx(0.21068, abs=1e-5)
    assert eta_slope == pytest.approx(0.48274, abs=1e-5)


def _brute_force(pk, cut, k_points, rng):
    """ζ2, η2 and their Monte Carlo errors by random points in every ball and explicit P_l double sums."""
    pos, rad, box = pk.positions, pk.radii, pk.box
    acc, var = {2: 0.0, 4: 0.0}, {2: 0.0, 4: 0.0}
    for i in range(pk.n):
        d0 = pos - pos[i]
        d0 -= box * np.round(d0 / box)
        sel = np.linalg.norm(d0, axis=1) < cut
        sel[i] = False
        dj, aj = d0[sel], rad[sel]
        vj = 4 / 3 * np.pi * aj**3
        u = rng.normal(size=(k_points, 3))
        u /= np.linalg.norm(u, axis=1)[:, None]
        x = u * (rad[i] * rng.random(k_points) ** (1 / 3))[:, None]
        vi = 4 / 3 * np.pi * rad[i] ** 3
        for l in (2, 4):
            vals = np.empty(k_points)
            for k in range(k_points):
                dd = dj - x[k]
                r = np.linalg.norm(dd, axis=1)
                uu = dd / r[:, None]
                w = vj / r**3
                if l == 4:
                    w = w * (1 - 1.4 * aj**2 / r**2)
                vals[k] = w @ eval_legendre(l, uu @ uu.T) @ w
            acc[l] += vi * vals.mean()
            var[l] += vi**2 * vals.var() / k_points
    vol, phi = np.prod(box), pk.volume_fraction
    c = 1 / (8 * np.pi**2 * vol * phi * (1 - phi))
    z, zs = 4.5 * c * acc[2], 4.5 * c * np.sqrt(var[2])
    e4, e4s = 150 / 7 * c * acc[4], 150 / 7 * c * np.sqrt(var[4])
    return z, zs, 5 * z / 21 + e4, np.hypot(5 * zs / 21, e4s)


def test_kernel_matches_brute_force_bidisperse():
    rng = np.random.default_rng(0)
    pk = pp.pack(rng.choice([1.0, 0.6], 120), volume_fraction=0.45, seed=3)
    tp = ThreePointParameters(cutoff=3.5).compute(pk)
    z, zs, e, es = _brute_force(pk, 3.5, 120, rng)
    # Monte Carlo error ~1 %; a wrong pair integral, field factor or weight is off by far more
    assert tp.zeta2 == pytest.approx(z, abs=4 * zs)
    assert tp.eta2 == pytest.approx(e, abs=4 * es)
    assert zs < 0.015 * z and es < 0.015 * e  # the comparison is sharp to ~5 %


def test_quadrature_converged():
    pk = _hard_spheres(300, 0.5, seed=5, shakes=2)
    a = ThreePointParameters(cutoff=4.0).compute(pk)
    b = ThreePointParameters(cutoff=4.0, radial_nodes=8, angular_nodes=12).compute(pk)
    assert a.zeta2 == pytest.approx(b.zeta2, rel=1e-3)
    assert a.eta2 == pytest.approx(b.eta2, rel=1e-3)


def _cell_mean_fields(pk, cut, m_points, rng):
    """(1/8π²) ⟨Σ_jk w_j w_k P_l⟩ over the whole cell (matrix and spheres) for l = 2, 4."""
    pos, rad, box = pk.positions, pk.radii, pk.box
    pts = rng.random((m_points, 3)) * box
    out = {2: [], 4: []}
    for x in pts:
        d = pos - x
        d -= box * np.round(d / box)
        r = np.linalg.norm(d, axis=1)
        sel = (r < cut) & (r >= rad)
        dd, rr, aj = d[sel], r[sel], rad[sel]
        uu = dd / rr[:, None]
        p2, p4 = eval_legendre(2, uu @ uu.T), eval_legendre(4, uu @ uu.T)
        w = 4 / 3 * np.pi * aj**3 / rr**3
        out[2].append(w @ p2 @ w)
        w4 = w * (1 - 1.4 * aj**2 / rr**2)
        out[4].append(w4 @ p4 @ w4)
    return {l: (np.mean(v) / (8 * np.pi**2), np.std(v) / np.sqrt(m_points) / (8 * np.pi**2)) for l, v in out.items()}


@pytest.mark.slow
def test_phase_sums_zeta1_plus_zeta2_is_one():
    # the cell mean of the fields is exact: ζ1 + ζ2 = 1 and η1 + η2 = 1 (Fourier transforms of
    # the P2 and P4 kernels); the spheres' share is the estimator, the matrix's share is sampled
    rng = np.random.default_rng(2)
    pk = _hard_spheres(300, 0.4, seed=7, shakes=3)
    phi = pk.volume_fraction
    cut = 0.49 * pk.box.min()
    cell = _cell_mean_fields(pk, cut, 6000, rng)
    tp = ThreePointParameters(cutoff=cut).compute(pk)
    total2 = 9 * cell[2][0] / (2 * phi * (1 - phi))
    total4 = 5 / 21 + 150 * cell[4][0] / (7 * phi * (1 - phi))
    assert total2 == pytest.approx(1.0, abs=4 * 9 * cell[2][1] / (2 * phi * (1 - phi)) + 0.01)
    assert total4 == pytest.approx(1.0, abs=4 * 150 * cell[4][1] / (7 * phi * (1 - phi)) + 0.01)
    assert 0 < tp.zeta2 < 1 and tp.zeta1 == pytest.approx(1 - tp.zeta2)


@pytest.mark.slow
@pytest.mark.parametrize("phi", [0.2, 0.4])
def test_equilibrium_hard_spheres_against_miller_torquato(phi):
    # Miller & Torquato (J. Appl. Phys. 68, 5486, 1990): their simulations of equilibrium hard
    # spheres follow ζ2 = 0.21068 φ - 0.04693 φ² "virtually exactly" for φ <= 0.5. Three packs
    # of 1000 spheres give ~1-2 % standard error; 3 % catches a wrong term of the estimator.
    tp = ThreePointParameters()
    for s in range(3):
        tp.compute(_hard_spheres(1000, phi, seed=40 + s), reset=False)
    assert tp.n_realizations == 3
    quadratic = 0.21068 * phi - 0.04693 * phi**2
    assert abs(tp.zeta2 - quadratic) < max(0.03 * quadratic, 3 * tp.zeta2_stderr)
    # η2 starts at 0.48274 φ and bends upward (measured 0.501 φ at 0.2, 0.517 φ at 0.4)
    assert 0.485 * phi < tp.eta2 < 0.53 * phi
    assert 0 < tp.zeta2_stderr < 0.03 * tp.zeta2 and 0 < tp.eta2_stderr < 0.02 * tp.eta2


def test_accumulation_and_errors():
    pks = [_hard_spheres(200, 0.3, seed=s, shakes=1) for s in (1, 2)]
    tp = ThreePointParameters(cutoff=3.0)
    vals = [tp.compute(p).zeta2 for p in pks]
    assert np.isnan(tp.zeta2_stderr)
    tp.compute(pks[0])
    tp.compute(pks[1], reset=False)
    assert tp.zeta2 == pytest.approx(np.mean(vals), rel=1e-12)
    assert tp.zeta2_stderr == pytest.approx(np.std(vals, ddof=1) / np.sqrt(2), rel=1e-9)
    d = tp.to_dict()
    assert d["n_realizations"] == 2 and len(d["per_realization"]["zeta2"]) == 2
    with pytest.raises(InvalidInputError, match="half the smallest box"):
        ThreePointParameters(cutoff=100.0).compute(pks[0])
    with pytest.raises(InvalidInputError, match="Packing"):
        ThreePointParameters().compute(np.zeros((3, 3)))
    with pytest.raises(NotComputedError, match="not computed yet"):
        ThreePointParameters().zeta2
    assert pp.analysis.ThreePointParameters is ThreePointParameters
