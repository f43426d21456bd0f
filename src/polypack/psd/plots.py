"""Plots of size distributions (matplotlib; every function returns the Axes)."""

from __future__ import annotations

import numpy as np

__all__ = ["plot_grading", "plot_class_histogram", "plot_hazen_vs_span", "plot_accessible_domain"]


def _ax(ax):
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots()
    return ax


def plot_grading(model=None, sizeset=None, ax=None, number=False, n_points=400, logx=True):
    """Grading curve of a model (line) and of a generated set (steps), Figs. 1 and 3 of 001.

    ``number=True`` adds the partition functions ``F(d)`` (dashed).
    """
    ax = _ax(ax)
    lo, hi = [], []
    if model is not None:
        lo.append(model.d_min)
        hi.append(model.d_max)
    if sizeset is not None:
        lo.append(sizeset.diameters.min())
        hi.append(sizeset.diameters.max())
    if not lo:
        from ..errors import InvalidInputError

        raise InvalidInputError("plot_grading needs a model or a size set")
    a, b = min(lo), max(hi)
    if a == b:
        a, b = 0.9 * a, 1.1 * b
    d = np.geomspace(a, b, n_points) if logx else np.linspace(a, b, n_points)
    if model is not None:
        ax.plot(d, model.grading(d), "-", color="C0", label="model h(d)")
        if number:
            ax.plot(d, model.number_cdf(d), "--", color="C0", label="model F(d)")
    if sizeset is not None:
        ds = np.sort(sizeset.diameters)
        ax.step(ds, sizeset.grading(ds), where="post", color="C1", label=f"generated set h (N={sizeset.n})")
        if number:
            ax.step(ds, sizeset.number_cdf(ds), where="post", color="C1", ls="--", label="generated set F")
    if logx:
        ax.set_xscale("log")
    ax.set_xlabel("diameter d")
    ax.set_ylabel("cumulative fraction")
    ax.set_ylim(-0.02, 1.02)
    ax.legend(loc="best", fontsize="small")
    return ax


def plot_class_histogram(sizeset, ax=None):
    """Number of particles (bars) and volume fraction (line, right axis) per species/class."""
    ax = _ax(ax)
    counts = np.bincount(sizeset.species)
    vol = np.bincount(sizeset.species, weights=sizeset.diameters**sizeset.dim)
    k = np.arange(counts.size)
    ax.bar(k, counts, color="C0", alpha=0.7, label="particles")
    ax.set_yscale("log")
    ax.set_xlabel("class / species")
    ax.set_ylabel("number of particles")
    ax2 = ax.twinx()
    ax2.plot(k, vol / vol.sum(), "o-", color="C1", label="volume fraction (set)")
    target = sizeset.report.get("classes", {}).get("volume_fractions")
    if target is not None and len(target) == counts.size:
        ax2.plot(k, target, "x", color="k", label="f_v (model)")
        ax2.legend(loc="upper center", fontsize="small")
    ax2.set_ylabel("volume fraction")
    ax2.set_ylim(0, None)
    return ax


def plot_hazen_vs_span(shapes=((1, 1), (1, 3), (3, 1), (3, 3)), spans=None, ax=None):
    """Hazen ``Cu`` and ``Cc`` of the CB model against the span ``s`` (Fig. 4 of 001).

    ``Cu`` is drawn on a log scale on the left axis (solid), ``Cc`` on the right (dashed).
    Returns the left Axes.
    """
    from .descriptors import hazen
    from .models import CumulativeBeta

    ax = _ax(ax)
    spans = np.linspace(0.02, 0.97, 60) if spans is None else np.asarray(spans, float)
    ax2 = ax.twinx()
    for i, (a, b) in enumerate(shapes):
        hz = [hazen(CumulativeBeta(a=a, b=b, span=s, d_max=1.0)) for s in spans]
        ax.plot(spans, [h["Cu"] for h in hz], "-", color=f"C{i}", label=f"a={a:g}, b={b:g}")
        ax2.plot(spans, [h["Cc"] for h in hz], "--", color=f"C{i}")
    ax.set_yscale("log")
    ax.set_xlabel("span s")
    ax.set_ylabel("Cu (solid)")
    ax2.set_ylabel("Cc (dashed)")
    ax.legend(loc="upper left", fontsize="small")
    return ax


def plot_accessible_domain(domain, ax=None):
    """log10 N_p over (a, b) with the boundary N_p = N_p^max for each limit (Fig. 8 of 001)."""
    ax = _ax(ax)
    A, B = np.meshgrid(domain.a_values, domain.b_values)
    z = np.log10(np.clip(domain.n_total, 1, 1e18))
    pc = ax.pcolormesh(A, B, z, shading="auto", cmap="viridis")
    ax.figure.colorbar(pc, ax=ax, label="log10 N_p")
    limits = np.atleast_1d(domain.max_total)
    if domain.a_values.size > 1 and domain.b_values.size > 1:
        cs = ax.contour(A, B, z, levels=np.sort(np.log10(limits.astype(float))), colors="w")
        ax.clabel(cs, fmt=lambda v: f"N_p^max=1e{v:.2g}", fontsize="small")
    ax.set_xlabel("a")
    ax.set_ylabel("b")
    ax.set_title(f"accessible shapes, s = {domain.span:g}")
    return ax
