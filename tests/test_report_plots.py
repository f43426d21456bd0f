"""The paper figures draw what they claim: the seed's reduced coordinates, its formulas and the
run's numbers (checked on the plotted data against formulas written here)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from polypack.report import figures as P


def _entry(x, curves, n=4):
    return {"x": list(map(float, x)), "n_realizations": n,
            "curves": {k: {"mean": list(map(float, v)), "lo": list(map(float, v - 0.1)), "hi": list(map(float, v + 0.1)),
                           "se": [0.05] * len(v)} for k, v in curves.items()}}


def _lines(ax):
    return {ln.get_label(): ln for ln in ax.get_lines()}


def test_partial_rdfs_are_drawn_against_R_km_with_the_theory():
    a = np.array([0.5, 0.2])
    c = np.array([0.45, 0.15])
    r = np.arange(0.01, 2.5, 0.02)
    curves = {f"partial.{k}-{m}": 1.0 + np.sin(r * (k + 2 * m + 1)) for k in range(2) for m in range(k, 2)}
    run = {"label": "SCRM", "entry": _entry(r, curves), "species_radii": a, "volume_fractions": c, "n_realizations": 4}
    fig = P.partial_rdf_figure([run], theory=True)
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert len(axes) == 3
    # Percus-Yevick mixture contact values, written out here:
    # g_ii = (1 - z3 + 3 a_i z2) / (1 - z3)^2, g_ij = (a_j g_ii + a_i g_jj) / (a_i + a_j),
    # z_alpha = pi 2^(alpha-1) / 3 sum n_k a_k^alpha, n_k = c_k / (4/3 pi a_k^3)
    n = c / (4 / 3 * np.pi * a**3)
    z2 = np.pi * 2 / 3 * np.sum(n * a**2)
    z3 = np.pi * 4 / 3 * np.sum(n * a**3)
    gii = (1 - z3 + 3 * a * z2) / (1 - z3) ** 2
    for ax, (k, m) in zip(axes, [(0, 0), (0, 1), (1, 1)]):
        lines = _lines(ax)
        meas = lines["SCRM (mean of 4)"]
        R = (r - a[k]) / a[m] + 1  # seed 000 §5.3
        assert np.allclose(meas.get_xdata(), R) and np.allclose(meas.get_ydata(), curves[f"partial.{k}-{m}"])
        ws = lines["well-stirred (seed 000 eq. 19)"]
        assert np.array_equal(ws.get_ydata(), np.where(R >= 2, 1.0, 0.0))
        (wl,) = [ln for lab, ln in lines.items() if lab.startswith("Willis form")]
        gkm = (a[m] * gii[k] + a[k] * gii[m]) / (a[k] + a[m])
        # Eq. (20) of 000_2cedc098acbd866b.txt: 1 + (g_c - 1) cos(pi R) exp(2 (2 - R)) beyond contact
        expect = np.where(R >= 2, 1 + (gkm - 1) * np.cos(np.pi * R) * np.exp(2 * (2 - R)), 0.0)
        assert np.allclose(wl.get_ydata(), expect, rtol=1e-12)
        assert f"{gkm:.2f}" in wl.get_label()
        assert "R_{" in ax.get_xlabel() and ax.get_title() in ("large–large pairs", "large–small pairs",
                                                               "small–small pairs")


def test_runs_compared_overlay_in_each_panel():
    a = np.array([0.5, 0.2])
    r = np.arange(0.01, 2.0, 0.05)
    curves = {f"partial.{k}-{m}": np.ones_like(r) for k in range(2) for m in range(k, 2)}
    runs = [{"label": "SCRM", "entry": _entry(r, curves, 16), "species_radii": a, "n_realizations": 16},
            {"label": "CRM", "entry": _entry(r, {k: 2 * v for k, v in curves.items()}, 3), "species_radii": a * 1.01,
             "n_realizations": 3}]
    fig = P.partial_rdf_figure(runs)
    for ax in fig.axes[:3]:
        lines = _lines(ax)
        assert {"SCRM (mean of 16)", "CRM (mean of 3)"} <= set(lines)
        assert np.allclose(lines["CRM (mean of 3)"].get_ydata(), 2.0)


def test_binomial_reference_is_the_ideal_gas_law():
    from scipy.stats import binom

    n_h = np.arange(0, 60)
    V, N = 1000.0, 2001
    w = np.full(10, 1.7)
    p = (4 / 3) * math.pi * 1.7**3 / V
    assert np.allclose(P.binomial_reference(n_h, N - 1, V, w), binom.pmf(n_h, N - 1, p), rtol=1e-10, atol=1e-300)
    # a mixture of window sizes: normalised, mean = (N - 1) <v> / V
    w = np.r_[np.full(30, 1.0), np.full(10, 2.0)]
    nn = np.arange(0, 400)
    q = P.binomial_reference(nn, N - 1, V, w)
    assert abs(q.sum() - 1) < 1e-10
    vmean = np.mean(4 / 3 * np.pi * w**3)
    assert abs(np.sum(nn * q) - (N - 1) * vmean / V) < 1e-8


def test_window_figure_draws_the_poisson_law_of_the_measured_mean():
    from scipy.stats import poisson

    x = np.arange(0, 15)
    p = poisson.pmf(x, 4.0) * 0.6 + poisson.pmf(x, 6.0) * 0.4
    e = _entry(x, {"p": p})
    fig = P.windows_figure([("R_h = 2.5", e)], species=np.zeros(100, int), box_volume=500.0,
                           window_radii=[np.full(100, 1.2)])
    ax = fig.axes[0]
    lines = _lines(ax)
    (pl,) = [ln for lab, ln in lines.items() if lab.startswith("Poisson")]
    mu = float(np.sum(x * p))
    assert np.allclose(pl.get_ydata(), poisson.pmf(pl.get_xdata(), mu), rtol=1e-10, atol=1e-300)
    ideal = lines["ideal gas, binomial"]
    assert abs(np.sum(ideal.get_xdata() * ideal.get_ydata()) - 99 * (4 / 3 * np.pi * 1.2**3) / 500.0) < 1e-6


def test_pore_figure_draws_eq_6_with_the_run_parameters():
    r0 = 0.2
    r = np.linspace(0, 0.3, 61)
    surv = 1 - np.array([math.erf(v) for v in (r / r0 - 0.01) / (0.25 * math.sqrt(2))])
    e = _entry(r, {"survival": surv})
    fig = P.pores_figure(e, r0=r0, fits={"seed": (0.25, 0.002, 0.01, 0.001), "normalized": (0.16, np.nan, 0.2, np.nan)})
    ax = fig.axes[0]
    lines = _lines(ax)
    x = r / r0
    (eq6,) = [ln for lab, ln in lines.items() if lab.startswith("seed 003 eq. 6")]
    assert "a = 0.250 ± 0.002" in eq6.get_label() and "b = 0.010 ± 0.001" in eq6.get_label()
    # Eq. (6) of 003_873b69fc71c74cf6.txt: P(r_P > r) = 1 - erf((r/r0 - b) / (a sqrt 2))
    assert np.allclose(eq6.get_ydata(), [1 - math.erf((v - 0.01) / (0.25 * math.sqrt(2))) for v in x], rtol=1e-12)
    (gs,) = [ln for lab, ln in lines.items() if lab.startswith("Gaussian")]
    assert np.allclose(gs.get_ydata(), [0.5 * math.erfc((v - 0.2) / (0.16 * math.sqrt(2))) for v in x], rtol=1e-12)
    assert np.allclose(lines["measured (mean of 4)"].get_xdata(), x)
    assert "r_0" in ax.get_xlabel()


def test_grading_figure_marks_hazen_diameters():
    # 10 spheres of radius 1 and 10 of radius 2: the small ones are 10 / 90 of the volume,
    # so d10 = 2 (the small diameter) and d30 = d60 = 4 (Eq. (18) of 001_ad5bae0acea940c4.txt)
    radii = np.r_[np.ones(10), 2 * np.ones(10)]
    fig, hz = P.grading_figure(radii)
    assert (hz["d10"], hz["d30"], hz["d60"]) == (2.0, 4.0, 4.0)
    assert hz["Cu"] == 2.0 and hz["Cc"] == 2.0
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert "$d_{10}$ = 2" in texts and "$d_{60}$ = 4" in texts
    vert = [ln for ln in fig.axes[0].get_lines() if ln.get_linestyle() == "--"]
    assert sorted(float(ln.get_xdata()[0]) for ln in vert) == [2.0, 4.0, 4.0]


def test_save_figure_writes_every_format(tmp_path):
    fig, _ = P.grading_figure(np.r_[np.ones(5), 2 * np.ones(5)])
    paths = P.save_figure(fig, tmp_path / "g", ("png", "svg", "pdf"))
    heads = [p.read_bytes()[:8] for p in paths]
    assert heads[0].startswith(b"\x89PNG") and b"<?xml" in heads[1] + paths[1].read_bytes()[:64] and heads[2].startswith(b"%PDF")
    assert "<svg" in P.svg_text(fig)[:10]
    from polypack.errors import InvalidInputError

    with pytest.raises(InvalidInputError, match="plot format 'bmp'"):
        P.save_figure(fig, tmp_path / "g", ("bmp",))
