"""Figures fit for a paper from the results a run wrote (ensemble curves, records, study).

Every function takes plain data as the run folder holds it (an entry of
``ensemble/curves.json``, numbers of ``ensemble/scalars.json``, radii read from a pack)
and returns a :class:`matplotlib.figure.Figure`; nothing is recomputed from the packs.

* :func:`partial_rdf_figure`: partial RDFs ``g_km`` against the reduced distance
  ``R_km = (r - a_k)/a_m + 1`` of §5.3 of 000_2cedc098acbd866b.txt (Figs. 9-11 of the seed), one
  panel per species pair, with the ensemble band and, on request, the well-stirred
  approximation, Eq. (19) of 000_2cedc098acbd866b.txt, and the Willis form with Percus-Yevick contact
  values, Eq. (20) of 000_2cedc098acbd866b.txt; several runs (CRM and SCRM) overlay.
* :func:`windows_figure`: window histograms ``p(n_h)`` (Fig. 4 of the seed) with the
  Poisson law of the same mean and the binomial law of an ideal gas of the same N.
* :func:`pores_figure`: the pore-size survival ``P(r_P > r)`` against ``r / r0`` with
  the fit of Eq. (6) of 003_873b69fc71c74cf6.txt and its ``(a, b)``.
* :func:`modulus_vs_doh_figure`: the shear modulus of each realization against its DOH a
  (Fig. 6 of 003_873b69fc71c74cf6.txt), several runs overlaid.
* :func:`grading_figure`: grading curve ``h(d)`` of the model and of a realization's
  sizes with Hazen's ``d10``, ``d30``, ``d60`` marked, Eq. (18) of 001_ad5bae0acea940c4.txt.
* :func:`plot_curves`, :func:`plot_grading`: the files ``ensemble/<analysis>.<fmt>`` and
  ``ensemble/grading.<fmt>`` that ``polypack run`` writes (``[output] plots``).

Moved here from ``polypack.ensemble`` (issue 30): the run engine computes, the report draws.

Labels come from each analysis' registered :class:`~polypack.registry.Curves` where
they exist; species are named in words (large/small for two sizes).
"""

from __future__ import annotations

import io
import math
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..errors import InvalidInputError

__all__ = ["paper_style", "partial_rdf_figure", "windows_figure", "pores_figure", "grading_figure", "generic_figure",
           "species_words", "save_figure", "svg_text", "PLOT_FORMATS", "modulus_vs_doh_figure"]

PLOT_FORMATS = ("png", "svg", "pdf")

_STYLE = {
    "font.size": 9, "axes.titlesize": 9, "axes.labelsize": 9, "legend.fontsize": 7.5, "xtick.labelsize": 8,
    "ytick.labelsize": 8, "axes.spines.top": False, "axes.spines.right": False, "lines.linewidth": 1.3,
    "figure.dpi": 100, "savefig.dpi": 200, "svg.fonttype": "none", "axes.grid": False, "legend.frameon": False,
    "pdf.fonttype": 42,
}


@contextmanager
def paper_style():
    """The consistent style of polypack's figures (matplotlib ``rc_context``)."""
    import matplotlib

    with matplotlib.rc_context(_STYLE):
        yield


def _label(name, which):
    from .. import registry

    try:
        spec = registry.get("analysis", name).outputs.curves
    except InvalidInputError:
        spec = None
    if spec is None:
        return ""
    return spec.x_label if which == "x" else spec.y_label


def _arr(v):
    return np.array([np.nan if e is None else e for e in v], dtype=np.float64)


def species_words(radii) -> list:
    """A name per species: ``"large"``/``"small"`` for two sizes, else ``"species k"`` (with its radius)."""
    a = [float(x) for x in radii]
    if len(a) == 2 and a[0] != a[1]:
        big = int(np.argmax(a))
        return ["large" if k == big else "small" for k in range(2)]
    if len(a) == 1:
        return ["all"]
    return [f"species {k} (a = {ak:.3g})" for k, ak in enumerate(a)]


def _band(ax, x, c, label, color=None, points=False, band_label=True):
    mean, lo, hi = _arr(c["mean"]), _arr(c["lo"]), _arr(c["hi"])
    if points:
        ok = np.isfinite(mean)
        yerr = np.vstack([mean - lo, hi - mean])
        yerr = np.where(np.isfinite(yerr), yerr, 0.0)
        return ax.errorbar(x[ok], mean[ok], yerr=yerr[:, ok], fmt="o", ms=2.5, lw=0.8, capsize=0, color=color,
                           label=label)
    (line,) = ax.plot(x, mean, color=color, label=label)
    if np.any(np.isfinite(lo)):
        ax.fill_between(x, lo, hi, color=line.get_color(), alpha=0.22, lw=0,
                        label="95 % band" if band_label else None)
    return line


def _series_label(series, n_real):
    return f"{series} (mean of {n_real})" if n_real > 1 else series


# ------------------------------------------------------------------ partial RDFs vs R_km
def partial_rdf_figure(runs, *, theory=False, title=""):
    """Partial RDFs ``g_km(R_km)`` per species pair, as Figs. 9-11 of 000_2cedc098acbd866b.txt.

    Parameters
    ----------
    runs : list of dict
        One per run to overlay (e.g. CRM and SCRM): ``{"label": str, "entry": the "rdf"
        entry of ensemble/curves.json, "species_radii": mean radius a_k per species,
        "volume_fractions": c_k per species (for the theory), "n_realizations": int}``.
    theory : bool
        Add the well-stirred approximation ``H(R_km - 2)``, Eq. (19) of 000_2cedc098acbd866b.txt,
        and the Willis form of Eq. (20) of 000_2cedc098acbd866b.txt with the Percus-Yevick mixture
        contact values of Eq. (21) of 000_2cedc098acbd866b.txt (of the first run's species).

    Returns
    -------
    matplotlib.figure.Figure
        One panel per unordered pair (k <= m); for one species the total g(R) with
        ``R = r / a``.
    """
    import matplotlib.pyplot as plt

    from ..analysis.rdf import scaled_coordinate
    from ..analysis.theory import percus_yevick_mixture_contact, well_stirred_partial, willis_partial

    if not runs:
        raise InvalidInputError("partial_rdf_figure: no run with an rdf to plot")
    a0 = np.asarray(runs[0]["species_radii"], dtype=np.float64)
    ns = a0.size
    pairs = [(k, m) for k in range(ns) for m in range(k, ns)]
    words = species_words(a0)
    with paper_style():
        ncol = min(len(pairs), 3)
        nrow = math.ceil(len(pairs) / ncol)
        fig, axes = plt.subplots(nrow, ncol, figsize=(3.0 * ncol + 0.4, 2.6 * nrow + 0.5), squeeze=False)
        for p, (k, m) in enumerate(pairs):
            ax = axes[p // ncol][p % ncol]
            for i, run in enumerate(runs):
                a = np.asarray(run["species_radii"], dtype=np.float64)
                e = run["entry"]
                r = _arr(e["x"])
                key = "g" if ns == 1 else f"partial.{k}-{m}"
                if key not in e["curves"]:
                    continue
                R = scaled_coordinate(r, a[k], a[m])
                _band(ax, R, e["curves"][key], _series_label(run["label"], run.get("n_realizations", 1)),
                      color=f"C{i}", band_label=(i == 0))
            if theory:
                r = _arr(runs[0]["entry"]["x"])
                R = scaled_coordinate(r, a0[k], a0[m])
                ax.plot(R, well_stirred_partial(r, a0[k], a0[m]), color="0.45", lw=0.9, ls=":",
                        label="well-stirred (seed 000 eq. 19)")
                vf = runs[0].get("volume_fractions")
                cf = np.asarray([] if vf is None else vf, dtype=np.float64)
                if cf.size == ns and cf.sum() < 1:
                    gc = percus_yevick_mixture_contact(a0, cf)
                    ax.plot(R, willis_partial(r, a0[k], a0[m], gc[k, m]), color="k", lw=0.9, ls="--",
                            label=f"Willis form (eq. 20), PY contact {gc[k, m]:.2f}")
            ax.axhline(1.0, color="0.7", lw=0.5, zorder=0)
            ax.set_xlim(left=1.5 if ns > 1 else 1.5)
            sym = f"g_{{{k}{m}}}(R_{{{k}{m}}})" if ns > 1 else "g(R)"
            ax.set_ylabel(f"${sym}$")
            ax.set_xlabel(f"$R_{{{k}{m}}} = (r - a_{k})/a_{m} + 1$" if ns > 1 else "$R = r / a$")
            ax.set_title(f"{words[k]}–{words[m]} pairs" if ns > 1 else "all pairs")
            if p == 0:
                ax.legend(loc="upper right")
        for q in range(len(pairs), nrow * ncol):
            axes[q // ncol][q % ncol].set_visible(False)
        if title:
            fig.suptitle(title, fontsize=9)
        fig.tight_layout()
    return fig


# ------------------------------------------------------------------ window histograms
def binomial_reference(n_h, n_others, box_volume, window_radii):
    """``p(n_h)`` of ideal-gas points: the mixture over the windows of ``Bin(n_others, v_i / V)``.

    ``n_others`` points are uniform in the box of volume ``V``; ``v_i`` is the volume of
    window i (radius ``window_radii[i]``). The mean is ``n_others * mean(v_i) / V``.
    """
    w, cnt = np.unique(np.asarray(window_radii, dtype=np.float64), return_counts=True)
    frac = 4.0 / 3.0 * np.pi * w**3 / float(box_volume)
    out = np.zeros(np.asarray(n_h).shape, dtype=np.float64)
    for f, c in zip(frac, cnt):
        out += c * _binom_pmf(n_h, int(n_others), min(f, 1.0))
    return out / cnt.sum()


def _binom_pmf(k, n, p):
    """Binomial probabilities (scipy.special only: scipy.stats takes seconds to import)."""
    from scipy.special import gammaln

    k = np.asarray(k, dtype=np.float64)
    ok = (k >= 0) & (k <= n)
    kk = np.where(ok, k, 0.0)
    if p <= 0.0:
        return np.where(k == 0, 1.0, 0.0)
    if p >= 1.0:
        return np.where(k == n, 1.0, 0.0)
    lg = gammaln(n + 1) - gammaln(kk + 1) - gammaln(n - kk + 1) + kk * np.log(p) + (n - kk) * np.log1p(-p)
    return np.where(ok, np.exp(lg), 0.0)


def _poisson_pmf(k, mu):
    from scipy.special import gammaln

    k = np.asarray(k, dtype=np.float64)
    if mu <= 0:
        return np.where(k == 0, 1.0, 0.0)
    return np.exp(k * np.log(mu) - mu - gammaln(k + 1))


def windows_figure(entries, *, species=None, box_volume=None, window_radii=None, names=None, title=""):
    """Window histograms ``p(n_h)`` with random references, as Fig. 4 of 000_2cedc098acbd866b.txt.

    Parameters
    ----------
    entries : list of (str, dict)
        ``(label, curves.json entry of a windows analysis)``, one row per window radius R_h.
    species : (N,) int array, optional
        Species of the spheres of a pack of the run (for the ideal-gas references).
    box_volume : float, optional
        Box volume V of the packs.
    window_radii : list of (N,) arrays, optional
        Per entry, the window radius of every sphere (``R_h a_k``).
    names : list of str, optional
        Species names in words.

    With one or two species, one panel per pair (k, m): ``p`` of the number of m centres
    in the windows around k spheres; with more, the total ``p(n_h)``. References: the
    Poisson law with the measured mean ``sum n_h p(n_h)`` and the binomial law of an
    ideal gas with the same numbers of spheres, ``Bin(N_m - delta_km, v_k / V)``. A pack
    whose histogram is narrower than both is more uniform than random points.
    """
    import matplotlib.pyplot as plt

    sp = None if species is None else np.asarray(species, dtype=np.int64)
    ns = int(sp.max()) + 1 if sp is not None and sp.size else 1
    if any(f"partial.0-0" not in e["curves"] for _, e in entries):
        ns = 1
    pairs = [(k, m) for k in range(ns) for m in range(ns)] if ns <= 2 else [None]
    if ns == 1:
        pairs = [None]
    names = names or [f"species {k}" for k in range(ns)]
    with paper_style():
        fig, axes = plt.subplots(len(entries), len(pairs), figsize=(2.9 * len(pairs) + 0.4, 2.5 * len(entries) + 0.3),
                                 squeeze=False)
        for i, (label, e) in enumerate(entries):
            x = _arr(e["x"])
            for j, pair in enumerate(pairs):
                ax = axes[i][j]
                key = "p" if pair is None else f"partial.{pair[0]}-{pair[1]}"
                c = e["curves"][key]
                _band(ax, x, c, _series_label("pack", e.get("n_realizations", 1)), color="C0",
                      points=np.count_nonzero(np.nan_to_num(_arr(c["mean"])) > 1e-4) <= 40)
                mean = _arr(c["mean"])
                mu = float(np.nansum(x * mean))
                last = np.nonzero(np.nan_to_num(mean) > 1e-4)[0]
                top = int(x[last[-1]]) + 2 if last.size else int(x.max())
                nn = np.arange(0, max(top, int(mu + 4 * math.sqrt(mu + 1))) + 1)
                ax.plot(nn, _poisson_pmf(nn, mu), color="C3", lw=0.9, label=f"Poisson, same mean {mu:.3g}")
                if sp is not None and box_volume and window_radii is not None and window_radii[i] is not None:
                    wr = np.asarray(window_radii[i], dtype=np.float64)
                    if pair is None:
                        ref = binomial_reference(nn, sp.size - 1, box_volume, wr)
                    else:
                        k, m = pair
                        ref = binomial_reference(nn, int(np.sum(sp == m)) - (k == m), box_volume, wr[sp == k])
                    ax.plot(nn, ref, color="0.3", lw=0.9, ls="--", label="ideal gas, binomial")
                ax.set_xlim(-0.5, nn[-1] + 0.5)
                ax.set_ylim(bottom=0)
                ax.set_xlabel(_label("windows", "x") or "$n_h$" if pair is None
                              else f"{names[pair[1]]} centres in the window $n_h$")
                ax.set_ylabel("$p(n_h)$")
                where = "" if pair is None else f"around {names[pair[0]]} spheres"
                ax.set_title(f"{label}\n{where}" if where else label, fontsize=8)
                if i == 0 and j == 0:
                    ax.legend(loc="upper right")
        if title:
            fig.suptitle(title, fontsize=9)
        fig.tight_layout()
    return fig


# ------------------------------------------------------------------ pore sizes
def pores_figure(entry, *, r0, fits=None, title=""):
    """Pore-size survival ``P(r_P > r)`` vs ``r / r0`` with the DOH fit, Eq. (6) of 003_873b69fc71c74cf6.txt.

    Parameters
    ----------
    entry : dict
        The ``pores`` entry of ensemble/curves.json (x = r in length units).
    r0 : float
        The length ``r0`` of the fit (the number-mean radius the run used).
    fits : dict, optional
        ``{"seed": (a, a_band, b, b_band), "normalized": (...)}``: ensemble means of the
        fitted parameters with their 95 % half-widths (NaN when unknown); ``"seed"`` is
        Eq. (6) of 003_873b69fc71c74cf6.txt as printed, ``1 - erf((r/r0 - b)/(a sqrt 2))``, ``"normalized"`` the
        Gaussian survival ``erfc((r/r0 - b)/(a sqrt 2)) / 2``.
    """
    import matplotlib.pyplot as plt

    from ..analysis.pores import doh_normalized, doh_seed

    with paper_style():
        fig, ax = plt.subplots(figsize=(4.6, 3.2))
        x = _arr(entry["x"]) / float(r0)
        _band(ax, x, entry["curves"]["survival"], _series_label("measured", entry.get("n_realizations", 1)),
              color="C0")
        for name, fn, ls, col, words in (("seed", doh_seed, "--", "k", "seed 003 eq. 6"),
                                         ("normalized", doh_normalized, ":", "C3", "Gaussian survival")):
            f = (fits or {}).get(name)
            if not f or not np.isfinite(f[0]):
                continue
            a, da, b, db = f

            def pm(v, d):
                return f"{v:.3f} ± {d:.2g}" if np.isfinite(d) else f"{v:.3f}"

            ax.plot(x, fn(x, a, b), ls=ls, color=col, lw=1.0, label=f"{words}: a = {pm(a, da)}, b = {pm(b, db)}")
        ax.set_xlabel(f"pore radius $r / r_0$ ($r_0$ = {float(r0):.4g} length units, mean sphere radius)")
        ax.set_ylabel(_label("pores", "y") or "$P(r_P > r)$")
        ax.set_ylim(-0.02, 1.05)
        ax.set_xlim(left=0)
        ax.legend(loc="upper right")
        if title:
            ax.set_title(title)
        fig.tight_layout()
    return fig


# ------------------------------------------------------------------ grading curves
def grading_figure(radii, *, model=None, species=None, dim=3, title=""):
    """Grading curve ``h(d)`` (cumulative volume fraction) with Hazen's diameters marked.

    ``radii`` are the sizes of one pack (read from its file), ``model`` the study's size
    distribution (optional); ``d10``, ``d30``, ``d60`` and ``Cu = d60/d10``,
    ``Cc = d30^2/(d10 d60)`` are those of Eq. (18) of 001_ad5bae0acea940c4.txt to the pack's sizes.
    """
    import matplotlib.pyplot as plt

    from ..psd import SizeSet, hazen, plot_grading

    sizes = SizeSet(np.asarray(radii, dtype=np.float64), species=species, dim=dim)
    hz = hazen(sizes)
    with paper_style():
        fig, ax = plt.subplots(figsize=(4.6, 3.2))
        plot_grading(model, sizes, ax=ax)
        for key, col in (("d10", "C2"), ("d30", "C4"), ("d60", "C5")):
            d = hz[key]
            frac = int(key[1:]) / 100
            ax.plot([d, d], [-0.02, frac], color=col, lw=0.8, ls="--")
            ax.annotate(f"$d_{{{key[1:]}}}$ = {d:.3g}", (d, frac), textcoords="offset points", xytext=(4, -10),
                        fontsize=7.5, color=col)
        ax.text(0.02, 0.97, f"$C_u = d_{{60}}/d_{{10}}$ = {hz['Cu']:.3g}\n$C_c = d_{{30}}^2/(d_{{10}} d_{{60}})$ = "
                f"{hz['Cc']:.3g}", transform=ax.transAxes, va="top", fontsize=7.5)
        ax.set_xlabel("diameter d (length units)")
        ax.set_ylabel("cumulative volume fraction h(d)" if dim == 3 else "cumulative area fraction h(d)")
        handles, labels = ax.get_legend_handles_labels()
        labels = [lab.replace("model h(d)", "size-distribution model").replace("generated set h", "pack sizes")
                  for lab in labels]
        ax.legend(handles, labels, loc="lower right")
        if title:
            ax.set_title(title)
        fig.tight_layout()
    return fig, hz


# ------------------------------------------------------------------ output
def svg_text(fig) -> str:
    """The figure as an inline ``<svg>`` element (text kept as text)."""
    buf = io.StringIO()
    with paper_style():
        fig.savefig(buf, format="svg")
    s = buf.getvalue()
    return s[s.index("<svg"):]


def save_figure(fig, base, formats=("png",)) -> list:
    """Write ``base.<fmt>`` for each format (atomically); returns the paths."""
    from .._util import atomic_path

    out = []
    for fmt in formats:
        if fmt not in PLOT_FORMATS:
            raise InvalidInputError(f"plot format {fmt!r}: allowed are {', '.join(PLOT_FORMATS)}")
        path = Path(f"{base}.{fmt}")
        with atomic_path(path) as tmp, paper_style():
            fig.savefig(tmp, format=fmt)
        out.append(path)
    return out


# ------------------------------------------------------------------ any other registered curves
def generic_figure(name, entry, title=""):
    """Ensemble mean and band of every curve of analysis ``name`` (labels from its registration).

    Returns None if the analysis declares no curves.
    """
    import matplotlib.pyplot as plt

    from .. import registry

    base = name.rstrip("0123456789")
    try:
        spec = registry.get("analysis", base).outputs.curves
    except InvalidInputError:
        spec = None
    if spec is None:
        return None
    with paper_style():
        fig, ax = plt.subplots(figsize=(4.6, 3.2))
        x = _arr(entry["x"])
        for i, (c, d) in enumerate(entry["curves"].items()):
            if spec.plot is not None and c not in spec.plot and not (c.startswith("partial") and "partial" in spec.plot):
                continue
            if c.startswith("partial") and not spec.partials:
                continue
            label = "all pairs" if not c.startswith("partial") else "species pair " + c.split(".", 1)[1]
            _band(ax, x, d, label, color=f"C{i % 10}", points=spec.style == "points", band_label=(i == 0))
        ax.set_xlabel(spec.x_label or entry.get("x_name", "x"))
        ax.set_ylabel(spec.y_label or name)
        ax.legend(loc="best")
        if title:
            ax.set_title(title)
        fig.tight_layout()
    return fig


# ------------------------------------------------------------------ modulus against the DOH
#: Per-realization moduli drawn against the DOH, in order of preference: (summary column, axis label).
MODULUS_COLUMNS = (
    ("shear.storage_modulus", "storage modulus G′ (Pa)"),
    ("elastic.shear_modulus", "static shear modulus G (Pa, or stiffness per pack length unit)"),
)
DOH_COLUMN = "pores.fit.seed.a"


def modulus_vs_doh_figure(groups, *, y_label, title=""):
    """Shear modulus against the degree of heterogeneity a, one point per realization (Fig. 6 of
    003_873b69fc71c74cf6.txt, where G′ falls as a power of a, Eq. (7) of 003_873b69fc71c74cf6.txt).

    Parameters
    ----------
    groups : list of (str, array_like, array_like)
        ``(label, a, G)`` per run (structures of one kind), a from Eq. (6) of
        003_873b69fc71c74cf6.txt.
    """
    import matplotlib.pyplot as plt

    with paper_style():
        fig, ax = plt.subplots(figsize=(4.6, 3.4))
        shown = 0
        for i, (label, a, g) in enumerate(groups):
            a, g = np.asarray(a, dtype=np.float64), np.asarray(g, dtype=np.float64)
            ok = np.isfinite(a) & np.isfinite(g) & (g > 0)
            floppy = int(np.sum(np.isfinite(g) & (g <= 0)))
            words = f"{label} ({int(ok.sum())} realizations" + (f"; {floppy} floppy, G = 0, not drawn)" if floppy else ")")
            ax.plot(a[ok], g[ok], "o", ms=3.5, mfc="none", color=f"C{i}", label=words)
            shown += int(ok.sum())
        if shown:  # log axes need a positive point (a set of floppy structures has none)
            ax.set_xscale("log")
            ax.set_yscale("log")
        else:
            ax.text(0.5, 0.5, "no rigid structure: every modulus is 0", transform=ax.transAxes,
                    ha="center", va="center")
        ax.set_xlabel("degree of heterogeneity a (seed 003 eq. 6)")
        ax.set_ylabel(y_label)
        ax.legend(loc="best")
        if title:
            ax.set_title(title)
        fig.tight_layout()
    return fig


# --------------------------------------------------------------------------- full-field moduli (issue 34)
def fullfield_moduli_groups(label, records):
    """Per-realization points of one run for :func:`moduli_vs_c_figure`, or None.

    Needs ``[analysis.moduli]`` and an ``[analysis.homogenize]`` entry of the same matrix and
    inclusion phases in the records; returns ``{"label", "matrix", "inclusion", "c", "est": {name:
    {"young": [...], "shear": [...]}}, "ff": {"young", "shear", "young_ext", "shear_ext", "shear_ext_err"}}``.
    """
    out = {"label": label, "c": [], "est": {}, "ff": {k: [] for k in ("young", "shear", "shear_ext", "shear_ext_err")}}
    for r in records:
        an = r.get("analysis", {})
        mod, hom = an.get("moduli"), an.get("homogenize")
        if not isinstance(mod, dict) or hom is None:
            continue
        homs = hom if isinstance(hom, list) else [hom]
        m = mod.get("matrix", {})
        inc = (mod.get("inclusions") or [{}])[0]
        match = [h for h in homs if h.get("matrix", {}).get("young") == m.get("young")
                 and (h.get("inclusions") or [{}])[0].get("young") == inc.get("young") and h.get("converged")]
        if not match:
            continue
        h = match[0]
        out["matrix"], out["inclusion"] = m, inc
        out["c"].append(mod["volume_fraction"])
        for e in ("mori_tanaka", "three_point_lower", "three_point_upper", "mefm", "hs_lower", "hs_upper"):
            if e in mod:
                d = out["est"].setdefault(e, {"young": [], "shear": []})
                d["young"].append(mod[e]["young_ratio"])
                d["shear"].append(mod[e]["shear_ratio"])
        out["ff"]["young"].append(h["young_ratio"])
        out["ff"]["shear"].append(h["shear_ratio"])
        ext = (h.get("extrapolated") or {}).get("shear_ratio")
        out["ff"]["shear_ext"].append(ext["value"] if ext else None)
        out["ff"]["shear_ext_err"].append(ext["error"] if ext else None)
    return out if out["c"] else None


def moduli_vs_c_figure(groups, title=""):
    """E*/E0 and μ*/μ0 against the inclusion fraction c (Figs. 8–9 of 000_2cedc098acbd866b.txt) with
    the full-field points of :func:`polypack.mechanics.homogenize` beside MT, HS, the three-point
    bounds and MEFM, one colour per protocol (e.g. CRM and SCRM packs apart; runs at several c
    of one protocol share its colour).

    ``groups``: dicts from :func:`fullfield_moduli_groups`; points are means over realizations with
    ± 1.96 standard errors; open diamonds are the Richardson continuum estimates of μ*/μ0 with their
    estimated discretization error.
    """
    import matplotlib.pyplot as plt

    from ..mechanics import Phase, hashin_shtrikman, mori_tanaka

    def ms(v):
        v = np.asarray([x for x in v if x is not None], dtype=np.float64)
        if v.size == 0:
            return np.nan, 0.0
        return float(v.mean()), float(1.96 * v.std(ddof=1) / np.sqrt(v.size)) if v.size > 1 else 0.0

    g0 = groups[0]
    m = Phase(g0["matrix"]["bulk"], g0["matrix"]["shear"])
    f = Phase(g0["inclusion"]["bulk"], g0["inclusion"]["shear"])
    cmax = max(max(g["c"]) for g in groups)
    cs = np.linspace(0.0, min(0.74, cmax + 0.05), 60)
    mt = [mori_tanaka(m, [f], [x]) for x in cs]
    hs = [hashin_shtrikman([m, f], [1 - x, x])[1] for x in cs]
    with paper_style():
        fig, axes = plt.subplots(1, 2, figsize=(9.2, 3.8))
        for ax, q, ref, lab in ((axes[0], "young", m.young, "E*/E0"), (axes[1], "shear", m.shear, "μ*/μ0")):
            ax.plot(cs, [getattr(p, q) / ref for p in mt], "k-", lw=1, label="Mori–Tanaka (= HS lower)")
            ax.plot(cs, [getattr(p, q) / ref for p in hs], "k:", lw=1, label="Hashin–Shtrikman upper")
            kinds = list(dict.fromkeys(g["label"].split(" (")[0] for g in groups))
            seen = set()
            for g in sorted(groups, key=lambda g: float(np.mean(g["c"]))):
                kind = g["label"].split(" (")[0]
                col = f"C{kinds.index(kind)}"
                c, _ = ms(g["c"])
                c += 0.012 * kinds.index(kind)  # protocols side by side at the same c
                first = kind not in seen
                seen.add(kind)
                if "three_point_lower" in g["est"]:
                    lo, _ = ms(g["est"]["three_point_lower"][q])
                    up, _ = ms(g["est"]["three_point_upper"][q])
                    ax.plot([c, c], [lo, up], "-", color=col, lw=5, alpha=0.25,
                            label=f"three-point bounds, {kind}" if first else None)
                if "mefm" in g["est"]:
                    y, e = ms(g["est"]["mefm"][q])
                    ax.errorbar(c - 0.004, y, yerr=e, fmt="s", ms=4, mfc="none", color=col, capsize=2,
                                label=f"MEFM, {kind}" if first else None)
                y, e = ms(g["ff"][q])
                ax.errorbar(c + 0.004, y, yerr=e, fmt="o", ms=4.5, color=col, capsize=2,
                            label=f"full field (FFT), {kind}" if first else None)
                if q == "shear" and any(v is not None for v in g["ff"]["shear_ext"]):
                    y, _ = ms(g["ff"]["shear_ext"])
                    err, _ = ms(g["ff"]["shear_ext_err"])
                    ax.errorbar(c + 0.008, y, yerr=err, fmt="D", ms=4, mfc="none", color=col, capsize=2,
                                label=f"full field, Richardson estimate, {kind}" if first else None)
            ax.set_xlabel("inclusion volume fraction c (–)")
            ax.set_ylabel(f"{lab} (–)")
        axes[1].legend(fontsize=6, loc="upper left")
        if title:
            fig.suptitle(title)
        fig.tight_layout()
    return fig


# --------------------------------------------------------------------------- the run folder's ensemble figures
# Drawn by the run engine itself (its ensemble/*.png files, like summary.csv): they live in
# polypack.ensemble._plots so the engine imports nothing from the report layer.
from ..ensemble._plots import plot_curves, plot_grading  # noqa: E402,F401
