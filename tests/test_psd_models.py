"""Closed-form checks of the size-distribution models (001_ad5bae0acea940c4.txt, 000_2cedc098acbd866b.txt)."""

import math

import numpy as np
import pytest
from scipy import integrate, special, stats

import polypack as pp
from polypack.errors import InvalidInputError
from polypack.psd import models as M


# --- Eqs. (2)-(4): uniform by volume fraction -------------------------------------------------
@pytest.mark.parametrize("dim", [2, 3])
def test_eq4_inverts_eq3_exactly(dim):
    d_min, d_max = 0.013, 1.7
    d = np.linspace(d_min, d_max, 1001)
    y = M.uv_cdf(d, d_min, d_max, dim)
    np.testing.assert_allclose(M.uv_ppf(y, d_min, d_max, dim), d, rtol=1e-11, atol=0)  # cond. number ~ (d_max/d_min)**(dim-1) * eps
    u = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(M.uv_cdf(M.uv_ppf(u, d_min, d_max, dim), d_min, d_max, dim), u, rtol=0, atol=1e-13)
    assert M.uv_cdf(d_min, d_min, d_max, dim) == 0.0
    assert abs(M.uv_cdf(d_max, d_min, d_max, dim) - 1.0) < 1e-15


def test_dim2_is_literally_eqs_3_and_4():
    d_min, d_max = 0.2, 3.0
    d = np.linspace(d_min, d_max, 50)
    eq3 = d_max / (d_max - d_min) * (d - d_min) / d
    np.testing.assert_allclose(M.uv_cdf(d, d_min, d_max, 2), eq3, rtol=1e-13)
    y = np.linspace(0, 1, 50)
    eq4 = d_max * d_min / (d_max + y * (d_min - d_max))
    np.testing.assert_allclose(M.uv_ppf(y, d_min, d_max, 2), eq4, rtol=1e-14)


@pytest.mark.parametrize("dim", [2, 3])
def test_uniform_volume_has_linear_grading_and_d_minus_dim_density(dim):
    m = pp.psd.UniformVolume(0.1, 1.0, dim=dim)
    d = np.linspace(0.1, 1.0, 7)
    np.testing.assert_allclose(m.grading(d), (d - 0.1) / 0.9, atol=1e-15)
    # number density ∝ d**-dim, normalised
    tot = integrate.quad(lambda x: m.number_pdf(x), 0.1, 1.0, epsrel=1e-12)[0]
    assert abs(tot - 1) < 1e-10
    assert m.number_pdf(0.2) / m.number_pdf(0.4) == pytest.approx(2.0**dim, rel=1e-12)
    # the generic conversion of the base class agrees with the closed form
    np.testing.assert_allclose(M.SizeDistribution.number_cdf(m, d), m.number_cdf(d), atol=1e-11)


# --- number <-> volume conversions against independent numerical integration -------------------
def _models():
    return [
        pp.psd.CumulativeBeta(a=1.0, b=3.0, span=0.9, d_max=1.0),
        pp.psd.CumulativeBeta(a=0.5, b=0.7, span=0.6, d_max=2.0),
        pp.psd.CumulativeBeta(a=4.0, b=2.0, d_min=0.3, d_max=1.5, dim=2),
        pp.psd.Normal(mean=1.0, std=0.25),
        pp.psd.Normal(mean=1.0, std=0.25, basis="volume"),
        pp.psd.UniformSize(0.2, 1.0),
        pp.psd.LogNormal(median=1.0, sigma=0.4),
        pp.psd.LogNormal(median=1.0, sigma=0.4, basis="volume", dim=2),
    ]


def _oracle_pdfs(m):
    """Volume density g and number density f from the defining law only (no model conversions)."""
    if isinstance(m, pp.psd.CumulativeBeta):
        base = lambda x: stats.beta(m.a, m.b).pdf((x - m.d_min) / (m.d_max - m.d_min))  # volume law
        kind = "volume"
    elif isinstance(m, pp.psd.Normal):
        base = lambda x: stats.norm(m.mean_, m.std).pdf(x)
        kind = m.basis
    elif isinstance(m, pp.psd.UniformSize):
        base = lambda x: 1.0
        kind = "number"
    else:
        base = lambda x: stats.norm(math.log(m.median), m.sigma).pdf(math.log(x)) / x
        kind = m.basis
    w = -m.dim if kind == "volume" else m.dim
    other = lambda x: base(x) * x**w
    return (base, other) if kind == "volume" else (other, base)


def _cdf_by_quad(f, lo, hi, d):
    tot = integrate.quad(f, lo, hi, epsabs=0, epsrel=1e-12, limit=500)[0]
    return np.array([integrate.quad(f, lo, x, epsabs=0, epsrel=1e-12, limit=500)[0] / tot for x in d])


def _cb_oracle(m, k, w, x=1.0):
    """∫_0^x t^(a-1) (1-t)^(b-1) d(t)^(k+w) dt with d = d_min + Δ t, singular ends as quad weights."""
    dd = lambda t: (m.d_min + (m.d_max - m.d_min) * t) ** (k + w)
    if x >= 1.0:
        return integrate.quad(dd, 0, 1, weight="alg", wvar=(m.a - 1, m.b - 1), epsabs=0, epsrel=1e-13)[0]
    return integrate.quad(lambda t: (1 - t) ** (m.b - 1) * dd(t), 0, x, weight="alg", wvar=(m.a - 1, 0),
                          epsabs=0, epsrel=1e-13)[0]


@pytest.mark.parametrize("m", _models(), ids=lambda m: repr(m)[:40])
def test_conversions_agree_with_numerical_integration(m):
    d = np.linspace(m.d_min, m.d_max, 9)[1:-1]
    if isinstance(m, pp.psd.CumulativeBeta):  # singular densities: integrate in d_r with algebraic weights
        x = (d - m.d_min) / (m.d_max - m.d_min)
        F = np.array([_cb_oracle(m, 0, -m.dim, xi) for xi in x]) / _cb_oracle(m, 0, -m.dim)
        np.testing.assert_allclose(m.number_cdf(d), F, atol=2e-10)
        np.testing.assert_allclose(m.grading(d), special.betainc(m.a, m.b, x), atol=1e-14)
        for k in (1, 2, 3, -1):
            assert m.moment(k, "number") == pytest.approx(_cb_oracle(m, k, -m.dim) / _cb_oracle(m, 0, -m.dim), rel=1e-9)
            assert m.moment(k, "volume") == pytest.approx(_cb_oracle(m, k, 0) / _cb_oracle(m, 0, 0), rel=1e-9)
        return
    g, f = _oracle_pdfs(m)
    np.testing.assert_allclose(m.grading(d), _cdf_by_quad(g, m.d_min, m.d_max, d), atol=2e-9)
    np.testing.assert_allclose(m.number_cdf(d), _cdf_by_quad(f, m.d_min, m.d_max, d), atol=2e-9)
    # densities are the derivatives of the cumulative curves, normalised
    for pdf, cdf in ((m.volume_pdf, m.grading), (m.number_pdf, m.number_cdf)):
        x = d[3]
        h = 1e-6 * (m.d_max - m.d_min)
        assert pdf(x) == pytest.approx((cdf(x + h) - cdf(x - h)) / (2 * h), rel=1e-5)
    # moments by number and by volume
    for k in (1, 2, 3, -1):
        tot = integrate.quad(f, m.d_min, m.d_max, epsrel=1e-12, limit=500)[0]
        ref = integrate.quad(lambda x: x**k * f(x), m.d_min, m.d_max, epsrel=1e-12, limit=500)[0] / tot
        assert m.moment(k, "number") == pytest.approx(ref, rel=1e-9)
        tot = integrate.quad(g, m.d_min, m.d_max, epsrel=1e-12, limit=500)[0]
        ref = integrate.quad(lambda x: x**k * g(x), m.d_min, m.d_max, epsrel=1e-12, limit=500)[0] / tot
        assert m.moment(k, "volume") == pytest.approx(ref, rel=1e-9)


def test_cb_densities_are_derivatives():
    m = pp.psd.CumulativeBeta(a=2.0, b=3.0, span=0.8)
    x, h = 0.5, 1e-6
    assert m.volume_pdf(x) == pytest.approx((m.grading(x + h) - m.grading(x - h)) / (2 * h), rel=1e-6)
    assert m.number_pdf(x) == pytest.approx((m.number_cdf(x + h) - m.number_cdf(x - h)) / (2 * h), rel=1e-6)


@pytest.mark.parametrize("m", _models(), ids=lambda m: repr(m)[:40])
def test_round_trips(m):
    p = np.array([1e-4, 0.01, 0.1, 0.3, 0.5, 0.77, 0.99, 1 - 1e-7])
    np.testing.assert_allclose(m.grading(m.quantile(p)), p, atol=1e-10)
    np.testing.assert_allclose(m.number_cdf(m.number_quantile(p)), p, atol=1e-10)
    d = np.linspace(m.d_min, m.d_max, 11)[1:-1]
    np.testing.assert_allclose(m.quantile(m.grading(d)), d, rtol=1e-9)
    np.testing.assert_allclose(m.number_quantile(m.number_cdf(d)), d, rtol=1e-9)
    # exact identity E_N[d^k] = E_V[d^(k-D)] / E_V[d^(-D)]
    D = m.dim
    assert m.moment(2, "number") == pytest.approx(m.moment(2 - D, "volume") / m.moment(-D, "volume"), rel=1e-10)


def test_lognormal_hatch_choate_matches_generic_conversion():
    m = pp.psd.LogNormal(median=2.0, sigma=0.3, d_min=1.0, d_max=4.0)
    d = np.linspace(1.05, 3.95, 13)
    generic = M.SizeDistribution.grading(m, d)  # base-class conversion from the number law
    np.testing.assert_allclose(m.grading(d), generic, atol=1e-11)
    # untruncated limit: volume median = number median * exp(3 sigma^2)
    wide = pp.psd.LogNormal(median=2.0, sigma=0.3, d_min=2.0 * math.exp(-12 * 0.3), d_max=2.0 * math.exp(12 * 0.3))
    assert float(wide.quantile(0.5)) == pytest.approx(2.0 * math.exp(3 * 0.09), rel=1e-9)


@pytest.mark.parametrize("m", [pp.psd.CumulativeBeta(a=2, b=5, span=0.8), pp.psd.Normal(1.0, 0.2),
                               pp.psd.CumulativeBeta(a=0.6, b=2, span=0.5)], ids=repr)
def test_random_samples_follow_the_number_law(m):
    d = m.sample_diameters(20000, seed=7)
    assert stats.kstest(d, m.number_cdf).pvalue > 1e-3
    # and are not distributed like the volume law (the test can fail)
    assert stats.kstest(d, m.grading).pvalue < 1e-6


def test_quantile_sampling_is_exact_and_reproducible():
    m = pp.psd.CumulativeBeta(a=1, b=3, span=0.9)
    d = m.sample_diameters(500, method="quantiles")
    np.testing.assert_allclose(m.number_cdf(d), (np.arange(500) + 0.5) / 500, atol=1e-10)
    assert np.array_equal(d, m.sample(500, method="quantiles").diameters)
    a = m.sample(100, seed=3)
    b = m.sample(100, seed=3)
    assert np.array_equal(a.radii, b.radii) and a.report["seed"]["entropy"] == 3
    np.testing.assert_array_equal(a.diameters, 2 * a.radii)


# --- CB model: Hazen coefficients, Eqs. (18)-(20) ----------------------------------------------
@pytest.mark.parametrize("a,b,s", [(1, 3, 0.98), (3, 3, 0.5), (3, 1, 0.9), (0.5, 0.5, 0.2), (1, 1, 0.97)])
def test_cb_hazen_matches_inverse_incomplete_beta(a, b, s):
    m = pp.psd.CumulativeBeta(a=a, b=b, span=s, d_max=2.0)
    d_max = 2.0
    d_min = d_max * (1 - s) / (1 + s)
    dx = {x: d_min + (d_max - d_min) * special.betaincinv(a, b, x / 100) for x in (10, 30, 50, 60)}
    hz = pp.psd.hazen(m)
    for x in (10, 30, 50, 60):
        assert hz[f"d{x}"] == pytest.approx(dx[x], rel=1e-13)
    assert hz["Cu"] == pytest.approx(dx[60] / dx[10], rel=1e-12)
    assert hz["Cc"] == pytest.approx(dx[30] ** 2 / (dx[10] * dx[60]), rel=1e-12)


def test_cb_grading_is_betainc_and_named_cases():
    m = pp.psd.CumulativeBeta(a=2.5, b=1.5, d_min=0.5, d_max=3.0)
    d = np.linspace(0.5, 3.0, 21)
    np.testing.assert_allclose(m.grading(d), special.betainc(2.5, 1.5, (d - 0.5) / 2.5), rtol=1e-15)
    # a = b = 1 is uniform by volume fraction
    cb = pp.psd.CumulativeBeta(a=1, b=1, span=0.7)
    uv = pp.psd.UniformVolume(span=0.7, d_max=1.0)
    np.testing.assert_allclose(cb.number_cdf(d / 3), uv.number_cdf(d / 3), atol=1e-11)
    assert m.span == pytest.approx(2.5 / 3.5)


def test_cu_grows_monotonically_with_span():  # Fig. 4 / §2.1 of seed 001
    spans = np.linspace(0.05, 0.97, 25)
    for a, b in [(1, 1), (1, 3), (3, 1), (4, 4)]:
        cu = [pp.psd.hazen(pp.psd.CumulativeBeta(a=a, b=b, span=s))["Cu"] for s in spans]
        assert np.all(np.diff(cu) > 0)


# --- bimodal pack of seed 000 -------------------------------------------------------------------
def test_bimodal_seed000_has_168_large_spheres():
    s = pp.psd.Bimodal(size_ratio=0.313, volume_ratio=0.333, d_large=1.0).sample(2000, seed=1)
    assert s.n == 2000
    assert np.sum(s.species == 0) == 168
    assert np.all(s.radii[s.species == 0] == 0.5)
    assert np.allclose(s.radii[s.species == 1], 0.5 * 0.313)
    v = s.radii**3
    xi = v[s.species == 1].sum() / v[s.species == 0].sum()
    assert xi == pytest.approx(0.333, rel=5e-3)  # one large sphere more or less would move it by 0.6 %
    # exact number fraction of large spheres: 1 / (1 + ξ / λ^3)
    m = pp.psd.Bimodal(0.313, 0.333)
    assert m.number_fractions[0] == pytest.approx(1 / (1 + 0.333 / 0.313**3), rel=1e-12)
    assert m.volume_fractions.tolist() == pytest.approx([1 / 1.333, 0.333 / 1.333])


def test_mixture_counts_and_spread_modes():
    m = pp.psd.Mixture.from_modes([1.0, 0.5, 0.2], [0.5, 0.3, 0.2], spread=0.05)
    s = m.sample(3001, seed=4)
    counts = np.bincount(s.species)
    assert counts.sum() == 3001
    share = 3001 * m.number_fractions
    assert np.all(np.abs(counts - share) < 3)
    # grading of a mixture is the volume-weighted sum of its modes
    d = np.array([0.3, 0.7, 1.05])
    ref = sum(c * k.grading(d) for c, k in zip(m.volume_fractions, m.components))
    np.testing.assert_allclose(m.grading(d), ref)
    # h = 0.5 between the 0.5 and the 1.0 mode: the inverse takes the smallest such size
    assert float(m.quantile(0.5)) == pytest.approx(m.components[1].d_max, rel=1e-9)
    assert float(m.quantile(0.6)) == pytest.approx(float(m.components[0].quantile(0.2)), rel=1e-9)


def test_sieve_table_is_piecewise_linear_and_exact(tmp_path):
    p = tmp_path / "sieve.csv"
    p.write_text("size_mm,passing_pct\n0.1,0\n0.2,20\n0.5,70\n1.0,100\n")
    m = pp.psd.SieveTable.from_csv(p)
    np.testing.assert_allclose(m.grading([0.15, 0.35, 0.75]), [0.1, 0.45, 0.85])
    np.testing.assert_allclose(m.quantile([0.1, 0.45, 0.85]), [0.15, 0.35, 0.75])
    # number fractions per sieve interval: f_v / <V> of a uniform-by-volume class
    f = lambda x: m.volume_pdf(x) / x**3
    tot = sum(integrate.quad(f, lo, hi)[0] for lo, hi in [(0.1, 0.2), (0.2, 0.5), (0.5, 1.0)])
    assert float(m.number_cdf(0.2)) == pytest.approx(integrate.quad(f, 0.1, 0.2)[0] / tot, rel=1e-10)


# --- bad input: one-line errors naming the value --------------------------------------------------
@pytest.mark.parametrize("kw,needle", [
    (dict(a=0.0, b=1.0, span=0.5), "a=0.0"),
    (dict(a=1.0, b=-2.0, span=0.5), "b=-2.0"),
    (dict(a=1.0, b=1.0, span=0.0), "span=0.0"),
    (dict(a=1.0, b=1.0, span=1.0), "span=1.0"),
    (dict(a=1.0, b=1.0, span=1.2), "span=1.2"),
    (dict(a=1.0, b=1.0, d_min=2.0, d_max=1.0), "d_min=2.0"),
    (dict(a=1.0, b=1.0, d_min=1.0, d_max=1.0), "d_min=1.0"),
    (dict(a=float("nan"), b=1.0, span=0.5), "a=nan"),
])
def test_cb_bad_input(kw, needle):
    with pytest.raises(InvalidInputError) as e:
        pp.psd.CumulativeBeta(**kw)
    assert needle in str(e.value) and "\n" not in str(e.value)


def test_other_bad_input():
    with pytest.raises(InvalidInputError, match=r"passing 15\.0 at size 0\.5"):
        pp.psd.SieveTable([0.1, 0.2, 0.5, 1.0], [0, 20, 15, 100])
    with pytest.raises(InvalidInputError, match=r"sieve size 0\.2"):
        pp.psd.SieveTable([0.1, 0.3, 0.2, 1.0], [0, 20, 50, 100])
    with pytest.raises(InvalidInputError, match=r"from 0\.0 to 90\.0"):
        pp.psd.SieveTable([0.1, 0.3, 1.0], [0, 20, 90])
    with pytest.raises(InvalidInputError, match=r"sum to 1 \(sum is 0\.9"):
        pp.psd.Mixture([1.0, 0.5], [0.6, 0.3])
    with pytest.raises(InvalidInputError, match="size_ratio=1.5"):
        pp.psd.Bimodal(size_ratio=1.5)
    with pytest.raises(InvalidInputError, match="volume_ratio=-1"):
        pp.psd.Bimodal(volume_ratio=-1)
    with pytest.raises(InvalidInputError, match="p="):
        pp.psd.CumulativeBeta(1, 1, span=0.5).quantile(1.5)
    with pytest.raises(InvalidInputError, match="dim=4"):
        pp.psd.UniformVolume(0.1, 1, dim=4)


def test_discrete_fraction_conversions_round_trip():
    sizes, c = [1.0, 0.313], [0.75, 0.25]
    x = pp.psd.volume_to_number_fractions(sizes, c)
    assert x[0] == pytest.approx(1 / (1 + (0.25 / 0.75) / 0.313**3), rel=1e-14)
    np.testing.assert_allclose(pp.psd.number_to_volume_fractions(sizes, x), c, rtol=1e-14)
    np.testing.assert_allclose(pp.psd.volume_to_number_fractions(sizes, c, dim=2)[0], 1 / (1 + (1 / 3) / 0.313**2))
    m = pp.psd.Mixture(sizes, c)
    np.testing.assert_allclose(m.number_fractions, x, rtol=1e-14)


def test_fraction_between_is_eq6():
    m = pp.psd.CumulativeBeta(2, 3, span=0.5)
    lo, hi = 0.5, 0.7
    assert m.fraction_between(lo, hi) == pytest.approx(float(m.grading(hi) - m.grading(lo)))
    assert m.fraction_between(lo, hi, "number") == pytest.approx(float(m.number_cdf(hi) - m.number_cdf(lo)))
