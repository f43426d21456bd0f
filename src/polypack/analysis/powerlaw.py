"""The power law of the plateau modulus against the degree of heterogeneity.

Eq. (7) of 003_873b69fc71c74cf6.txt: ``G'_p = A (a - a0)^β`` for ``a >= a0``, with the DOH
parameter ``a`` of Eq. (6) of 003_873b69fc71c74cf6.txt and a critical DOH ``a0`` below which
the elastic properties vanish (seed: a0 = 0.373 ± 0.001, β = 0.187 ± 0.032, uncertainties by
error propagation of the fit).

:func:`power_law_fit` fits the three parameters by weighted nonlinear least squares
(``scipy.optimize.least_squares``) in the parametrisation ``(ln A, β, ln(a_min - a0))``,
which keeps ``a0`` below the smallest ``a`` of the data, and reports standard errors from
the covariance ``(Jᵀ W J)⁻¹`` (scaled by the reduced χ² when no measurement errors are
given, as ``scipy.optimize.curve_fit`` does).  Whether the data determine ``a0`` is
reported, not assumed (the seed's own caution: "the obtained value for a0 does not solely
rely on the data point possessing the lowest a-value"; without it the seed finds
a0' = 0.360):

* fewer than four points (three parameters) never determine a0;
* the one-sigma interval of ``a0`` must stay below the smallest ``a`` of the data
  (otherwise the lowest point alone pins a0 and the fit cannot tell a0 from a_min);
* the fit without the lowest point (``a0_without_lowest``) is reported beside it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InvalidInputError

__all__ = ["PowerLawFit", "power_law_fit", "power_law"]


def power_law(a, a0, beta, prefactor):
    """``A (a - a0)^β`` for ``a > a0`` and 0 below (Eq. (7) of 003_873b69fc71c74cf6.txt)."""
    a = np.asarray(a, dtype=np.float64)
    x = np.clip(a - a0, 0.0, None)
    with np.errstate(over="ignore", under="ignore"):
        return prefactor * x**beta


@dataclass
class PowerLawFit:
    """Result of :func:`power_law_fit`."""

    a0: float
    beta: float
    prefactor: float
    a0_err: float
    beta_err: float
    prefactor_err: float
    covariance: np.ndarray
    chi2: float
    dof: int
    n_points: int
    a0_determined: bool
    note: str
    a0_without_lowest: float = float("nan")
    a0_without_lowest_err: float = float("nan")
    data: dict = field(default_factory=dict)

    def __call__(self, a):
        return power_law(a, self.a0, self.beta, self.prefactor)

    def to_dict(self) -> dict:
        return {"a0": self.a0, "beta": self.beta, "prefactor": self.prefactor, "a0_err": self.a0_err,
                "beta_err": self.beta_err, "prefactor_err": self.prefactor_err, "chi2": self.chi2, "dof": self.dof,
                "n_points": self.n_points, "a0_determined": self.a0_determined, "note": self.note,
                "a0_without_lowest": self.a0_without_lowest, "a0_without_lowest_err": self.a0_without_lowest_err,
                "covariance": np.asarray(self.covariance).tolist()}

    def plot(self, ax=None, label="power-law fit (seed eq. 7)", unit="MPa"):
        """Data with error bars, the fit and the critical a0 (the seed's Fig. 6)."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(5, 4))
        a = np.asarray(self.data.get("a", []))
        g = np.asarray(self.data.get("g", []))
        s = self.data.get("sigma")
        if a.size:
            ax.errorbar(a, g, yerr=None if s is None else np.asarray(s), fmt="o", ms=4, capsize=2,
                        label="measured")
            lo = min(self.a0, float(a.min())) if math.isfinite(self.a0) else float(a.min())
            xs = np.linspace(lo, float(a.max()) * 1.02, 300)
            ax.plot(xs, self(xs), "-", label=f"{label}: a0 = {self.a0:.3f} ± {self.a0_err:.3f}, "
                    f"β = {self.beta:.3f} ± {self.beta_err:.3f}")
        if math.isfinite(self.a0):
            ax.axvline(self.a0, ls="--", color="0.5", label="critical DOH a0")
        ax.set_xlabel("DOH parameter a (Eq. 6), dimensionless")
        ax.set_ylabel(f"plateau storage modulus G'p ({unit})")
        ax.legend(fontsize=7)
        return ax


def _fit(a, g, w, a_min):
    from scipy.optimize import least_squares

    span = float(a.max() - a.min())
    # starting values: for a grid of a0, a straight line of ln G against ln(a - a0)
    best = None
    for d in np.geomspace(1e-3 * max(span, 1e-6), 3.0 * max(span, 1e-6), 40):
        x = np.log(a - (a_min - d))
        beta, lnA = np.polyfit(x, np.log(g), 1)
        r = (np.exp(lnA) * np.exp(beta * x) - g) * w
        sse = float(r @ r)
        if best is None or sse < best[0]:
            best = (sse, lnA, beta, math.log(d))
    p0 = np.array(best[1:])

    def resid(p):
        lnA, beta, t = p
        return (np.exp(lnA) * (a - a_min + np.exp(t)) ** beta - g) * w

    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        res = least_squares(resid, p0, method="lm", x_scale="jac", max_nfev=2000)
    lnA, beta, t = res.x
    J = res.jac
    try:
        cov_p = np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        cov_p = np.full((3, 3), np.inf)
    return res, lnA, beta, t, cov_p


def power_law_fit(a, g, sigma=None) -> PowerLawFit:
    """Fit Eq. (7) of 003_873b69fc71c74cf6.txt, ``G'_p = A (a - a0)^β``, with uncertainties.

    Parameters
    ----------
    a : array_like
        DOH parameters ``a`` (Eq. (6) of 003_873b69fc71c74cf6.txt), one per structure.
    g : array_like
        Moduli ``G'_p`` (> 0, any unit; the prefactor comes out in it).
    sigma : array_like, optional
        Standard errors of ``g`` (absolute weights; the parameter errors are then the
        error-propagated ones).  Without them the points are weighted equally and the
        covariance is scaled by the reduced χ².

    Returns
    -------
    PowerLawFit
        ``a0, beta, prefactor`` with standard errors, covariance (of ``a0, β, A``), χ²,
        ``a0_determined`` and ``note`` (why not), and the fit without the lowest point.
        ``a0`` counts as determined when its 1-sigma interval stays below the smallest ``a``.
        With ``sigma``, ``note`` also says when the law misses the points by more than their
        error bars (chi-squared survival probability below 1e-3); such a fit whose a0 the data
        without the lowest point do not determine (five or more points) has ``a0`` held up by
        that one point and is reported as not determined. On a good fit that refit is only
        noted (dropping the lowest point always widens a0's interval).

    Raises
    ------
    InvalidInputError
        Fewer than three points, lengths that differ, non-positive ``g`` or ``sigma``.
    """
    a = np.asarray(a, dtype=np.float64).ravel()
    g = np.asarray(g, dtype=np.float64).ravel()
    if a.size != g.size:
        raise InvalidInputError(f"a and g: lengths differ ({a.size} and {g.size})")
    if a.size < 3:
        raise InvalidInputError(f"a: {a.size} points; the three-parameter power law needs at least 3")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(g))) or np.any(g <= 0):
        raise InvalidInputError("g: moduli must be finite and > 0 (a and g finite)")
    if float(a.max() - a.min()) <= 0:
        raise InvalidInputError("a: all values equal; the power law needs a range of a")
    absolute = sigma is not None
    if absolute:
        s = np.asarray(sigma, dtype=np.float64).ravel()
        if s.size != a.size or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise InvalidInputError("sigma: one finite value > 0 per point")
        w = 1.0 / s
    else:
        s = None
        w = np.ones_like(a)
    a_min = float(a.min())
    res, lnA, beta, t, cov_p = _fit(a, g, w, a_min)
    dof = a.size - 3
    chi2 = float(res.fun @ res.fun)
    if not absolute:
        cov_p = cov_p * (chi2 / dof if dof > 0 else np.inf)
    A = math.exp(lnA)
    d = math.exp(t)
    a0 = a_min - d
    # Jacobian of (a0, beta, A) with respect to (lnA, beta, t)
    T = np.array([[0.0, 0.0, -d], [0.0, 1.0, 0.0], [A, 0.0, 0.0]])
    with np.errstate(invalid="ignore", over="ignore"):
        cov = T @ cov_p @ T.T
    errs = np.sqrt(np.clip(np.diag(cov), 0.0, None)) if np.all(np.isfinite(cov)) else np.full(3, np.inf)
    notes = []
    if a.size < 4:
        notes.append(f"{a.size} points for 3 parameters: a0 is not determined")
    elif not np.isfinite(errs[0]):
        notes.append("singular fit: a0 is not determined")
    elif a0 + errs[0] >= a_min:
        notes.append(f"the 1-sigma interval of a0 ({a0:.4g} ± {errs[0]:.2g}) reaches the smallest a ({a_min:.4g}): "
                     "the data do not determine a0 (it is pinned by the lowest point or unbounded below)")
    determined = not notes
    out = PowerLawFit(float(a0), float(beta), float(A), float(errs[0]), float(errs[1]), float(errs[2]), cov, chi2, dof, int(a.size),
                      determined, "; ".join(notes) if notes else "a0 determined by the data",
                      data={"a": a.tolist(), "g": g.tolist(), "sigma": None if s is None else s.tolist()})
    if a.size >= 4:
        keep = np.argsort(a)[1:]
        amin2 = float(a[keep].min())
        r2, _, _, t2, c2 = _fit(a[keep], g[keep], w[keep], amin2)
        if not absolute:
            c2 = c2 * (float(r2.fun @ r2.fun) / (keep.size - 3) if keep.size > 3 else np.inf)
        d2 = math.exp(t2)
        out.a0_without_lowest = amin2 - d2
        var = c2[2, 2] * d2 * d2
        out.a0_without_lowest_err = float(math.sqrt(var)) if np.isfinite(var) and var >= 0 else float("inf")
    misfit = False
    if absolute and dof > 0:
        from scipy.stats import chi2 as chi2_dist

        misfit = bool(chi2_dist.sf(chi2, dof) < 1e-3)  # the bars are the data's own: the law misses the points
    if determined and a.size >= 5:
        e2 = out.a0_without_lowest_err
        if not (math.isfinite(e2) and out.a0_without_lowest + e2 < float(np.sort(a)[1])):
            # Dropping the lowest point always widens a0's interval (that point carries most of what the
            # data say about a0), so on a good fit this is only a remark; on a fit that misses its points
            # a0 is a threshold that one point holds up, not a property of the data.
            lean = f"without the lowest point (a = {a_min:.4g}) the data do not determine a0 " \
                   f"(a0' = {out.a0_without_lowest:.4g} ± {e2:.2g})"
            if misfit:
                out.a0_determined = False
                out.note = "a0 rests on the lowest point: " + lean
            else:
                out.note += "; " + lean
    if misfit:
        out.note += (f"; the power law misses the points by more than their error bars "
                     f"(chi2 = {chi2:.4g} for {dof} dof)")
    return out
