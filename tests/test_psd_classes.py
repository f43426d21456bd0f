"""Size classes, representativity criteria and discretisation, §1.2 and §2.2-2.3 of 001_ad5bae0acea940c4.txt."""

import math

import numpy as np
import pytest

import polypack as pp
from polypack.errors import InfeasibleError, InvalidInputError


def test_geometric_bounds_follow_eq11():
    m = pp.psd.CumulativeBeta(a=2, b=2, span=0.98)
    b = pp.psd.class_bounds(m, 10, "geometric")
    r = math.exp((math.log(m.d_max) - math.log(m.d_min)) / 10)
    np.testing.assert_allclose(b[1:] / b[:-1], r, rtol=1e-12)
    assert b[0] == m.d_min and b[-1] == m.d_max
    np.testing.assert_allclose(np.diff(pp.psd.class_bounds(m, 7, "regular")), (m.d_max - m.d_min) / 7)


def test_isochoric_classes_carry_equal_volume():
    m = pp.psd.CumulativeBeta(a=1, b=3, span=0.9)
    b = pp.psd.class_bounds(m, 8, "isochoric")
    np.testing.assert_allclose(pp.psd.class_volume_fractions(m, b), 1 / 8, atol=1e-11)


def test_class_volume_fractions_eq6():
    m = pp.psd.CumulativeBeta(a=3, b=1, span=0.5)
    b = pp.psd.class_bounds(m, 5, "geometric")
    fv = pp.psd.class_volume_fractions(m, b)
    x = (b - m.d_min) / (m.d_max - m.d_min)
    np.testing.assert_allclose(fv, np.diff(x**3), atol=1e-15)  # I_x(3, 1) = x^3
    assert fv.sum() == pytest.approx(1.0)


@pytest.mark.parametrize("dim", [2, 3])
def test_counts_follow_eqs_7_to_9(dim):
    m = pp.psd.CumulativeBeta(a=1, b=2, span=0.6)
    b = pp.psd.class_bounds(m, 6, "geometric")
    fv = pp.psd.class_volume_fractions(m, b)
    # Eq. (7) with d_m the median (by number) of the class law uniform by volume, whose number
    # density is f(d) ∝ d^-dim on [lo, hi]: found here by quadrature and root finding
    from scipy.integrate import quad
    from scipy.optimize import brentq

    lo, hi = b[:-1], b[1:]

    def median(l, h):
        mass = quad(lambda d: d**-dim, l, h)[0]
        return brentq(lambda x: quad(lambda d: d**-dim, l, x)[0] - 0.5 * mass, l, h, xtol=1e-14, rtol=1e-14)

    dm = np.array([median(lo_k, hi_k) for lo_k, hi_k in zip(lo, hi)])
    n = fv / dm**dim
    first = np.floor(10 / n.min() * n + 1e-9).astype(int)  # Eq. (8)
    cc = pp.psd.class_counts(m, 6, "geometric", min_per_class=10, min_total=1, dim=dim)
    np.testing.assert_array_equal(cc.first, first)
    np.testing.assert_array_equal(cc.counts, first)
    assert cc.counts.min() == 10
    # Eq. (9): scaled up to N_p^min when the first estimate is too small
    big = 50 * first.sum()
    cc = pp.psd.class_counts(m, 6, "geometric", min_per_class=10, min_total=big, dim=dim)
    assert cc.total == big
    assert np.all(np.abs(cc.counts - big / first.sum() * first) < 1.0)


CASES = [
    (pp.psd.CumulativeBeta(a=1, b=1, span=0.9), dict(n_classes=10, spacing="geometric")),
    (pp.psd.CumulativeBeta(a=3, b=3, span=0.9), dict(n_classes=10, spacing="regular")),
    (pp.psd.CumulativeBeta(a=3, b=1, span=0.9), dict(n_classes=10, spacing="isochoric")),
    (pp.psd.CumulativeBeta(a=0.5, b=0.5, span=0.5), dict(n_classes=4, spacing="geometric", min_total=300)),
    (pp.psd.LogNormal(1.0, 0.3), dict(n_classes=12, spacing="regular", min_per_class=25)),
    (pp.psd.Normal(1.0, 0.2, basis="volume"), dict(n_classes=5, spacing="geometric", min_total=500)),
    (pp.psd.SieveTable([0.1, 0.2, 0.5, 1.0], [0, 20, 20, 100]), dict(n_classes=6, spacing="geometric")),
    (pp.psd.SieveTable([0.1, 0.2, 0.5, 1.0], [0, 20, 70, 100]), dict(spacing="modes", min_per_class=30)),
    (pp.psd.Bimodal(0.313, 0.333), dict(min_per_class=50, min_total=1000)),
    (pp.psd.Mixture.from_modes([1.0, 0.3], [0.7, 0.3], spread=0.1), dict(spacing="modes", min_total=800)),
]


@pytest.mark.parametrize("model,kw", CASES, ids=[repr(c[0])[:30] + str(i) for i, c in enumerate(CASES)])
@pytest.mark.parametrize("method", ["random", "quantiles"])
def test_representativity_criteria_hold_for_every_generated_set(model, kw, method):
    kw = {"min_per_class": 10, "min_total": 2000, "max_total": 10**6, **kw}
    s = pp.psd.discretize(model, seed=11, method=method, **kw)
    cls = s.report["classes"]
    counts = np.bincount(s.species, minlength=len(cls["counts"]))
    np.testing.assert_array_equal(counts, cls["counts"])
    fv = np.asarray(cls["volume_fractions"])
    assert np.all(counts[fv > 0] >= kw["min_per_class"])  # criterion (1), Eq. (8)
    assert np.all(counts[fv == 0] == 0)
    assert kw["min_total"] <= s.n <= kw["max_total"]  # Eq. (9) and accessibility
    d = s.diameters
    lo, hi = np.asarray(cls["lower"]), np.asarray(cls["upper"])
    assert np.all(d >= lo[s.species] * (1 - 1e-12)) and np.all(d <= hi[s.species] * (1 + 1e-12))
    assert s.radii.dtype == np.float64 and s.species.dtype == np.int64
    # criterion (2): in each class one particle is a small part of the class volume
    v = d**s.dim
    share = np.array([v[s.species == i].max() / v[s.species == i].sum() for i in np.unique(s.species)])
    assert np.all(share <= 1.0 / kw["min_per_class"] * (hi / lo)[np.unique(s.species)] ** s.dim + 1e-12)


def test_uniform_by_volume_set_reproduces_h_and_cr_falls():
    m = pp.psd.UniformVolume(span=0.9, d_max=1.0)
    settings = [(2, 500), (5, 2000), (10, 2000), (20, 20000)]
    mean_cr, q_cr = [], []
    for nc, nmin in settings:
        crs = [pp.psd.discretize(m, n_classes=nc, min_total=nmin, max_total=10**6, seed=s).report["descriptors"]["Cr"]
               for s in range(6)]
        mean_cr.append(np.mean(crs))
        q = pp.psd.discretize(m, n_classes=nc, min_total=nmin, max_total=10**6, method="quantiles")
        q_cr.append(pp.psd.regression_coefficient(q, m))
    assert np.all(np.diff(mean_cr) < 0), mean_cr
    assert np.all(np.diff(q_cr) < 0), q_cr
    assert q_cr[-1] < 0.005 and mean_cr[-1] < 0.03
    # and the largest set follows the analytic straight line h(d) within a few 1e-3
    s = pp.psd.discretize(m, n_classes=20, min_total=20000, max_total=10**6, method="quantiles")
    d = np.geomspace(m.d_min, m.d_max, 50)
    assert np.max(np.abs(s.grading(d) - m.grading(d))) < 0.01


def test_dim2_classes_use_eq4_literally():
    m = pp.psd.UniformVolume(0.1, 1.0, dim=2)
    s = pp.psd.discretize(m, n_classes=3, min_per_class=5, min_total=10, method="quantiles")
    cls = s.report["classes"]
    for i, c in enumerate(cls["counts"]):
        lo, hi = cls["lower"][i], cls["upper"][i]
        y = (np.arange(c) + 0.5) / c
        eq4 = hi * lo / (hi + y * (lo - hi))
        np.testing.assert_allclose(np.sort(s.diameters[s.species == i]), eq4, rtol=1e-14)


def test_count_basis_mean_gives_unbiased_class_volumes():
    m = pp.psd.CumulativeBeta(a=2, b=2, span=0.9)
    kw = dict(n_classes=4, spacing="regular", min_total=10**5, max_total=10**6, method="quantiles")
    s = pp.psd.discretize(m, count_basis="mean", **kw)
    fv = np.asarray(s.report["classes"]["volume_fractions"])
    got = np.asarray(s.report["descriptors"]["species_volume_fractions"])
    # only the integer parts of Eq. (8) (10 particles in the coarsest class) remain
    np.testing.assert_allclose(got, fv, atol=2e-3)
    # the seed's median-diameter estimate of Eq. (7) is biased for wide classes
    med = pp.psd.discretize(m, **kw)
    got_med = np.asarray(med.report["descriptors"]["species_volume_fractions"])
    assert np.max(np.abs(got_med - fv)) > 0.05


def test_unreachable_max_total_states_the_number_needed():
    m = pp.psd.CumulativeBeta(a=1, b=3, span=0.98)
    need = pp.psd.class_counts(m, 10, "geometric", 10, 2000).total
    with pytest.raises(InfeasibleError) as e:
        pp.psd.discretize(m, max_total=10**5, seed=1)
    msg = str(e.value)
    assert f"N_p={need}" in msg and "max_total=100000" in msg and "\n" not in msg
    assert need > 10**5


def test_seeds_and_reproducibility():
    m = pp.psd.CumulativeBeta(a=2, b=3, span=0.7)
    a = pp.psd.discretize(m, seed=5)
    b = pp.psd.discretize(m, seed=5)
    c = pp.psd.discretize(m, seed=6)
    assert np.array_equal(a.radii, b.radii) and not np.array_equal(a.radii, c.radii)
    assert a.report["seed"]["entropy"] == 5
    q1 = pp.psd.discretize(m, method="quantiles")
    q2 = pp.psd.discretize(m, method="quantiles")
    assert np.array_equal(q1.radii, q2.radii) and "seed" not in q1.report


def test_bimodal_discretize_uses_modes():
    s = pp.psd.discretize(pp.psd.Bimodal(0.313, 0.333), min_per_class=10, min_total=2000, seed=1)
    assert s.report["classes"]["spacing"] == "modes"
    assert s.n == 2000 and set(np.unique(s.radii)) == {0.5, 0.5 * 0.313}
    assert abs(np.sum(s.species == 0) - 2000 / (1 + 0.333 / 0.313**3)) < 1


@pytest.mark.parametrize("kw,needle", [
    (dict(n_classes=0), "n_classes=0"),
    (dict(spacing="log"), "spacing='log'"),
    (dict(min_per_class=0), "min_per_class=0"),
    (dict(method="sobol"), "method='sobol'"),
    (dict(count_basis="mode"), "count_basis='mode'"),
    (dict(dim=4), "dim=4"),
    (dict(bounds=[0.1, 0.05, 1.0]), "bounds="),
])
def test_discretize_bad_input(kw, needle):
    with pytest.raises(InvalidInputError) as e:
        pp.psd.discretize(pp.psd.CumulativeBeta(a=1, b=1, span=0.5), **kw)
    assert needle in str(e.value)


def test_recorded_seed_regenerates_an_unseeded_set():
    from polypack._util import seed_from_record

    for make in (lambda seed: pp.psd.CumulativeBeta(2, 3, span=0.5).sample(200, seed=seed),
                 lambda seed: pp.psd.Bimodal(0.4, 1.0).sample(200, seed=seed),
                 lambda seed: pp.psd.discretize(pp.psd.CumulativeBeta(2, 3, span=0.5), seed=seed)):
        s = make(None)
        t = make(seed_from_record(s.report["seed"]))
        assert np.array_equal(s.radii, t.radii) and np.array_equal(s.species, t.species)


def test_monodisperse_set():
    s = pp.psd.Monodisperse(2.0).sample(10, seed=3)
    assert np.all(s.radii == 1.0) and s.report["descriptors"]["Cu"] == 1.0
    assert s.report["descriptors"]["skewness"] == 0.0 and s.report["descriptors"]["polydispersity"] == 0.0


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=40, deadline=None)
@given(a=st.floats(0.3, 6), b=st.floats(0.3, 6), span=st.floats(0.05, 0.95), nc=st.integers(1, 15),
       spacing=st.sampled_from(["geometric", "regular", "isochoric"]), npc=st.integers(1, 30),
       nmin=st.integers(1, 5000), dim=st.sampled_from([2, 3]))
def test_criteria_hold_or_infeasible_property(a, b, span, nc, spacing, npc, nmin, dim):
    m = pp.psd.CumulativeBeta(a=a, b=b, span=span, dim=dim)
    try:
        s = pp.psd.discretize(m, n_classes=nc, spacing=spacing, min_per_class=npc, min_total=nmin,
                              max_total=200_000, method="quantiles")
    except InfeasibleError as e:
        need = pp.psd.class_counts(m, nc, spacing, npc, nmin).total
        assert need > 200_000 and f"N_p={need}" in str(e)
        return
    except InvalidInputError as e:  # isochoric classes can collapse for extreme shapes
        assert "collapse" in str(e)
        return
    counts = np.asarray(s.report["classes"]["counts"])
    fv = np.asarray(s.report["classes"]["volume_fractions"])
    assert np.all(counts[fv > 0] >= npc)
    assert nmin <= s.n <= 200_000
    assert counts.sum() == s.n
