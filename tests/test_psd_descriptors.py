"""Descriptors (Hazen Eqs. (18)-(20), Cr Eq. (21), moments), SizeSet I/O, accessible domain (Fig. 8), plots."""

import json
import math

import matplotlib
import numpy as np
import pytest
from scipy import integrate, stats

import polypack as pp
from polypack.errors import FormatError, InvalidInputError


def test_hazen_of_a_sizeset_matches_the_volume_weighted_definition():
    # 10 particles of d=1 and 1 of d=2: the big one holds 8/18 of the volume
    d = np.array([1.0] * 10 + [2.0])
    s = pp.psd.SizeSet(d / 2)
    hz = pp.psd.hazen(s)
    assert hz["d10"] == 1.0 and hz["d50"] == 1.0 and hz["d60"] == 2.0  # 10/18 = 0.556 < 0.6
    assert hz["Cu"] == 2.0 and hz["Cc"] == pytest.approx(1.0 / 2.0)
    assert float(s.grading(1.0)) == pytest.approx(10 / 18)


def test_hazen_of_a_large_set_converges_to_the_model():
    m = pp.psd.CumulativeBeta(a=2, b=3, span=0.8)
    s = pp.psd.discretize(m, n_classes=20, min_total=50000, max_total=10**6, method="quantiles")
    hm, hs = pp.psd.hazen(m), pp.psd.hazen(s)
    for k in ("d10", "d30", "d50", "d60", "Cu", "Cc"):
        assert hs[k] == pytest.approx(hm[k], rel=0.02)


def test_cr_is_eq21():
    m = pp.psd.UniformVolume(0.1, 1.0)
    s = pp.psd.SizeSet(np.array([0.1, 0.2, 0.3, 0.5]))
    d = np.geomspace(0.1, 1.0, 15)
    y = s.grading(d)
    ref = math.sqrt(np.sum((y - (d - 0.1) / 0.9) ** 2) / np.sum(y**2))
    assert pp.psd.regression_coefficient(s, m, k=15) == pytest.approx(ref, rel=1e-14)
    # an exact stratified sample of a model has a small Cr, a sample of another law does not
    good = pp.psd.discretize(m, n_classes=20, min_total=20000, method="quantiles")
    bad = pp.psd.UniformSize(0.1, 1.0).sample(20000, method="quantiles")
    assert pp.psd.regression_coefficient(good, m) < 0.01 < 0.1 < pp.psd.regression_coefficient(bad, m)


def test_set_moments_polydispersity_and_skewness():
    rng = np.random.default_rng(0)
    r = rng.lognormal(0, 0.3, 500)
    s = pp.psd.SizeSet(r)
    assert pp.psd.polydispersity(s) == pytest.approx(np.std(r) / np.mean(r), rel=1e-12)
    assert pp.psd.skewness(s) == pytest.approx(stats.skew(r), rel=1e-12)
    assert pp.psd.moment(s, 2, "number", "radius") == pytest.approx(np.mean(r**2))
    assert pp.psd.moment(s, 1, "volume") == pytest.approx(np.sum(2 * r * r**3) / np.sum(r**3))


def test_model_polydispersity_and_skewness_by_quadrature():
    m = pp.psd.Normal(1.0, 0.2, basis="volume")
    f = lambda x: float(m.number_pdf(x))
    mu = [integrate.quad(lambda x: x**k * f(x), m.d_min, m.d_max, epsrel=1e-12)[0] for k in range(4)]
    mean = mu[1] / mu[0]
    var = mu[2] / mu[0] - mean**2
    third = mu[3] / mu[0] - 3 * mean * mu[2] / mu[0] + 2 * mean**3
    assert pp.psd.polydispersity(m) == pytest.approx(math.sqrt(var) / mean, rel=1e-8)
    assert pp.psd.skewness(m) == pytest.approx(third / var**1.5, rel=1e-6)
    # radii and diameters share the polydispersity; the volume law is shifted to larger sizes
    assert pp.psd.moment(m, 1, "volume") > pp.psd.moment(m, 1, "number")


def test_describe_and_bad_input():
    out = pp.psd.describe(pp.psd.CumulativeBeta(1, 3, span=0.5))
    for key in ("d10", "Cu", "Cc", "polydispersity", "skewness", "number_moments", "span"):
        assert key in out
    assert out["span"] == pytest.approx(0.5)
    with pytest.raises(InvalidInputError, match="basis='mass'"):
        pp.psd.moment(pp.psd.UniformVolume(0.1, 1), 1, basis="mass")
    with pytest.raises(InvalidInputError, match="k=1"):
        pp.psd.regression_coefficient(pp.psd.SizeSet([1.0]), pp.psd.UniformVolume(0.1, 1), k=1)


# --- SizeSet ------------------------------------------------------------------------------------
def test_sizeset_save_load_roundtrip(tmp_path):
    s = pp.psd.discretize(pp.psd.CumulativeBeta(a=2, b=2, span=0.6), seed=3, min_total=300)
    csv_path, json_path = s.save(tmp_path / "sizes.csv")
    assert json_path == tmp_path / "sizes.json"
    t = pp.psd.SizeSet.load(csv_path)
    assert np.array_equal(t.radii, s.radii) and np.array_equal(t.species, s.species)
    assert t.radii.dtype == np.float64 and t.species.dtype == np.int64
    assert t.report["seed"]["entropy"] == 3 and t.report["parameters"]["min_total"] == 300
    rep = json.loads(json_path.read_text())
    assert rep["descriptors"]["n"] == s.n
    assert not list(tmp_path.glob(".*tmp"))  # atomic writes leave no temporary files
    # a plain CSV with diameters only
    (tmp_path / "d.csv").write_text("diameter\n1.0\n0.5\n")
    u = pp.psd.SizeSet.load(tmp_path / "d.csv")
    assert u.radii.tolist() == [0.5, 0.25] and u.species.tolist() == [0, 0]


def test_sizeset_bad_input(tmp_path):
    with pytest.raises(InvalidInputError, match="radius -1.0"):
        pp.psd.SizeSet([1.0, -1.0])
    with pytest.raises(InvalidInputError, match="species has 1"):
        pp.psd.SizeSet([1.0, 2.0], species=[0])
    (tmp_path / "x.csv").write_text("foo,bar\n1,2\n")
    with pytest.raises(FormatError, match="neither 'radius' nor 'diameter'"):
        pp.psd.SizeSet.load(tmp_path / "x.csv")
    with pytest.raises(FormatError, match="cannot read"):
        pp.psd.SizeSet.load(tmp_path / "missing.csv")


def test_sizeset_is_accepted_by_packing():
    s = pp.psd.Bimodal(0.313, 0.333).sample(50, seed=1)
    box = np.full(3, 10.0)
    pk = pp.Packing(np.random.default_rng(0).random((s.n, 3)) * 10, s.radii, box, species=s.species)
    assert pk.n == 50 and np.array_equal(pk.species_counts, np.bincount(s.species))


# --- accessible domain, Fig. 8 -----------------------------------------------------------------
def test_accessible_domain_matches_class_counts_and_seed_statements():
    a = np.array([1.0, 3.0, 6.0, 10.0])
    b = np.array([1.0, 3.0, 6.0, 10.0])
    dom = pp.psd.accessible_domain(0.97, a, b, spacing="regular", dim=2, max_total=[10**5, 10**6])
    for j, bb in enumerate(b):
        for i, aa in enumerate(a):
            m = pp.psd.CumulativeBeta(aa, bb, span=0.97, dim=2)
            assert dom.n_total[j, i] == pp.psd.class_counts(m, 10, "regular", 10, 2000, dim=2).total
    acc = dom.accessible(10**6)
    # §2.3: uniform by volume (a=b=1) and by size (a=3, b=1) are accessible; a=b=10 is not
    assert acc[0, 0] and acc[0, 1] and not acc[3, 3]
    # the domain is not symmetric: shapes with a < b need more particles
    assert dom.n_total[1, 0] > dom.n_total[0, 1] and dom.n_total[2, 1] > dom.n_total[1, 2]
    assert np.array_equal(dom.mask, dom.n_total <= 10**5)
    # Hazen grid (Fig. 8c): Cu of a = 3, b = 6 equals the model's
    assert dom.cu[2, 1] == pytest.approx(pp.psd.hazen(pp.psd.CumulativeBeta(3.0, 6.0, span=0.97))["Cu"])
    assert json.dumps(dom.to_dict())


# --- plots ------------------------------------------------------------------------------------------
def test_plots_return_axes(tmp_path):
    m = pp.psd.CumulativeBeta(a=1, b=1, span=0.8)
    s = pp.psd.discretize(m, seed=1, min_total=200)
    for ax in (s.plot_grading(), s.plot_histogram(), pp.psd.plot_grading(m, number=True),
               pp.psd.plot_hazen_vs_span(spans=[0.1, 0.5, 0.9]),
               pp.psd.accessible_domain(0.5, [1, 2], [1, 2], max_total=[10**4, 10**5]).plot()):
        assert isinstance(ax, matplotlib.axes.Axes)
        assert ax.get_xlabel() and ax.get_ylabel()
    # the curves drawn are the model's grading h(d) and partition function F(d)
    ax = pp.psd.plot_grading(m, number=True)
    x, y = ax.lines[0].get_data()
    np.testing.assert_allclose(y, m.grading(x), rtol=1e-12)
    x, y = ax.lines[1].get_data()
    np.testing.assert_allclose(y, m.number_cdf(x), rtol=1e-12)
    ax = s.plot_grading()
    x, y = ax.lines[-1].get_data()  # the generated set's steps
    np.testing.assert_allclose(y, s.grading(x), rtol=1e-12)
    ax.figure.savefig(tmp_path / "g.png")
    assert (tmp_path / "g.png").stat().st_size > 1000
    import matplotlib.pyplot as plt

    plt.close("all")


def test_domain_marks_astronomic_counts_as_infinite():
    dom = pp.psd.accessible_domain(0.999, [1.0, 40.0], [1.0, 40.0], dim=3, max_total=10**8)
    assert np.isfinite(dom.n_total[0, 0]) and dom.mask[0, 0]
    assert np.isinf(dom.n_total[1, 0]) and not dom.mask[1, 0]
    assert json.dumps(dom.to_dict())
    with pytest.raises(pp.InfeasibleError, match="N_p=.*e\\+"):
        pp.psd.discretize(pp.psd.CumulativeBeta(1.0, 40.0, span=0.999))


def test_2d_sizeset_quantile_and_hazen_by_hand():
    """In 2D the grading weights each disk by its area d^2 (3D: volume d^3).
    Diameters 1, 2, 3: areas 1, 4, 9 give cumulative 1/14, 5/14, 1; volumes 1, 8, 27
    give 1/36, 9/36, 1.  So d30 is 2 in 2D but 3 in 3D, and Cc = d30^2 / (d10 d60) is
    4 / 6 in 2D, 9 / 6 in 3D."""
    d = np.array([3.0, 1.0, 2.0])
    s2 = pp.psd.SizeSet.from_diameters(d, dim=2)
    s3 = pp.psd.SizeSet.from_diameters(d, dim=3)
    np.testing.assert_allclose(s2.grading([1.0, 2.0, 2.5, 3.0]), [1 / 14, 5 / 14, 5 / 14, 1.0], rtol=1e-12)
    np.testing.assert_allclose(s3.grading([1.0, 2.0, 3.0]), [1 / 36, 9 / 36, 1.0], rtol=1e-12)
    np.testing.assert_array_equal(s2.quantile([0.05, 1 / 14, 0.3, 5 / 14, 0.4, 1.0]), [1, 1, 2, 2, 3, 3])
    np.testing.assert_array_equal(s3.quantile([0.02, 0.1, 0.25, 0.3]), [1, 2, 2, 3])
    h2, h3 = pp.psd.hazen(s2), pp.psd.hazen(s3)
    assert (h2["d10"], h2["d30"], h2["d50"], h2["d60"]) == (2.0, 2.0, 3.0, 3.0)
    assert (h3["d10"], h3["d30"], h3["d50"], h3["d60"]) == (2.0, 3.0, 3.0, 3.0)
    assert h2["Cu"] == 1.5 and h2["Cc"] == pytest.approx(4 / 6)
    assert h3["Cu"] == 1.5 and h3["Cc"] == pytest.approx(9 / 6)


@pytest.mark.parametrize("dim", [2, 3])
def test_sizeset_quantiles_of_uniform_diameters(dim):
    """Diameters uniform on [1, 2] by number: the d^dim-weighted grading is
    (d^(dim+1) - 1) / (2^(dim+1) - 1), so d_p = (1 + (2^(dim+1) - 1) p)^(1 / (dim + 1)).
    200000 diameters: the sampling error of a weighted quantile is
    sqrt(p (1 - p) / n_eff) / f(d_p), f the weighted density and n_eff = (sum w)^2 / sum w^2;
    tolerance 4 of them (~4e-3; the wrong power d^3 in 2D moves d50 by 0.057)."""
    rng = np.random.default_rng(dim)
    d = rng.uniform(1.0, 2.0, 200_000)
    s = pp.psd.SizeSet.from_diameters(d, dim=dim)
    p = np.array([0.1, 0.3, 0.5, 0.6, 0.9])
    exact = (1 + (2 ** (dim + 1) - 1) * p) ** (1 / (dim + 1))
    w = d**dim
    n_eff = w.sum() ** 2 / np.sum(w**2)
    dens = (dim + 1) * exact**dim / (2 ** (dim + 1) - 1)
    se = np.sqrt(p * (1 - p) / n_eff) / dens
    assert np.all(np.abs(s.quantile(p) - exact) < 4 * se), (s.quantile(p) - exact) / se
    h = pp.psd.hazen(s)
    assert h["Cu"] == pytest.approx(exact[3] / exact[0], abs=4 * (se[3] + se[0]))
    assert h["Cc"] == pytest.approx(exact[1] ** 2 / (exact[0] * exact[3]), abs=4 * (2 * se[1] + se[0] + se[3]))
