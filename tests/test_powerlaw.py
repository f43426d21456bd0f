"""Eq. (7) of 003_873b69fc71c74cf6.txt: the power-law fit G'p = A (a - a0)^beta."""

from __future__ import annotations

import numpy as np
import pytest

import polypack as pp
from polypack.analysis.powerlaw import power_law
from polypack.errors import InvalidInputError

A_GRID = np.linspace(0.38, 0.60, 11)  # the seed's DOH range (Table 2)
TRUE = dict(a0=0.35, beta=0.2, prefactor=2.0)


def test_noise_free_data_give_the_parameters_exactly():
    g = power_law(A_GRID, 0.373, 0.187, 1.9)
    f = pp.analysis.power_law_fit(A_GRID, g, sigma=np.full(A_GRID.size, 1e-3))
    assert f.a0 == pytest.approx(0.373, abs=1e-7)
    assert f.beta == pytest.approx(0.187, rel=1e-6)
    assert f.prefactor == pytest.approx(1.9, rel=1e-6)
    assert f.chi2 < 1e-10 and f.a0_determined


def test_errors_are_calibrated_on_synthetic_noise():
    """2 % Gaussian noise: each parameter lies within its reported 1-sigma error in 68 % of
    the realizations (150 of them: binomial sd 0.038, so the 0.13 band is 3.4 sd); a
    covariance that is off by a factor 1.5 gives 50 % or 82 % and fails."""
    rng = np.random.default_rng(7)
    g0 = power_law(A_GRID, **TRUE)
    sig = 0.02 * g0
    hits = np.zeros(3)
    n = 150
    for _ in range(n):
        f = pp.analysis.power_law_fit(A_GRID, g0 + rng.normal(size=A_GRID.size) * sig, sigma=sig)
        for q, (v, e, t) in enumerate(((f.a0, f.a0_err, TRUE["a0"]), (f.beta, f.beta_err, TRUE["beta"]),
                                       (f.prefactor, f.prefactor_err, TRUE["prefactor"]))):
            hits[q] += abs(v - t) < e
    assert np.all(np.abs(hits / n - 0.683) < 0.13), hits / n


def test_unweighted_fit_recovers_within_three_sigma():
    rng = np.random.default_rng(3)
    g = power_law(A_GRID, **TRUE) * (1 + 0.02 * rng.normal(size=A_GRID.size))
    f = pp.analysis.power_law_fit(A_GRID, g)
    assert f.a0_determined
    assert abs(f.a0 - TRUE["a0"]) < 3 * f.a0_err
    assert abs(f.beta - TRUE["beta"]) < 3 * f.beta_err
    assert np.isfinite(f.a0_without_lowest)


def test_reports_when_a0_is_not_determined():
    rng = np.random.default_rng(1)
    # a0 far below a narrow range: the curve is nearly a straight line and a0 is unbounded
    a = np.linspace(0.5, 0.6, 6)
    g = power_law(a, 0.0, 0.2, 2.0) * (1 + 0.02 * rng.normal(size=6))
    f = pp.analysis.power_law_fit(a, g)
    assert not f.a0_determined and "do not determine a0" in f.note
    # three points for three parameters
    f3 = pp.analysis.power_law_fit(A_GRID[::5], power_law(A_GRID[::5], **TRUE))
    assert not f3.a0_determined and "3 points" in f3.note


def test_bad_input():
    with pytest.raises(InvalidInputError, match="at least 3"):
        pp.analysis.power_law_fit([0.4, 0.5], [1.0, 2.0])
    with pytest.raises(InvalidInputError, match="lengths differ"):
        pp.analysis.power_law_fit([0.4, 0.5, 0.6], [1.0, 2.0])
    with pytest.raises(InvalidInputError, match="> 0"):
        pp.analysis.power_law_fit([0.4, 0.5, 0.6], [1.0, -2.0, 3.0])


def test_plot_labels(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    g = power_law(A_GRID, **TRUE)
    f = pp.analysis.power_law_fit(A_GRID, g * 1.001)
    ax = f.plot()
    assert "a" in ax.get_xlabel() and "MPa" in ax.get_ylabel()
    assert len(ax.get_legend().get_texts()) == 3
    ax.figure.savefig(tmp_path / "f.png")
