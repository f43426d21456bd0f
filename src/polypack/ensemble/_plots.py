"""The run engine's own ensemble figures: ``ensemble/<analysis>.<fmt>`` (mean and 95 % band of each
registered curve) and ``ensemble/grading.<fmt>``, written beside ``summary.csv`` when the study's
``output.plots`` is true.  Every other figure lives in :mod:`polypack.report.figures`, which
re-exports these two.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .runner import _curves_spec


def plot_grading(study, records, path, fmt="png"):
    """Grading curve h(d) of the model against realization 0's size set (Figs. 1, 3 of 001)."""
    import matplotlib.pyplot as plt

    from .. import psd as psd_mod
    from .._util import atomic_path
    from ..ensemble.stages import make_model, make_sizes, stage_seeds

    try:
        plot = psd_mod.plot_grading
    except AttributeError:  # pragma: no cover - older psd
        return
    model = make_model(study.data["psd"])
    sizes = make_sizes(study.data["psd"], stage_seeds(records[0]["seed"])[0]) if records else None
    fig, ax = plt.subplots(figsize=(6, 4))
    plot(model, sizes, ax=ax)
    ax.set_title(f"{study.name}: grading curve, model and realization 0 (N={records[0]['n']})", fontsize=9)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=fmt, dpi=120)
    plt.close(fig)


def plot_curves(curves: dict, folder, fmt="png", title=""):
    """One figure per analysis: ensemble mean of each curve with its 95 % band.

    Labels, the curves drawn and the style come from each analysis' registered
    :class:`~polypack.registry.Curves`.
    """
    import matplotlib.pyplot as plt

    from .._util import atomic_path

    for name, entry in curves.items():
        base = name.rstrip("0123456789")
        spec = _curves_spec(base) or _curves_spec(name)
        if spec is None:
            continue
        fig, ax = plt.subplots(figsize=(6, 4))
        x = np.array(entry["x"], dtype=float)
        many = sum(c.startswith("partial") for c in entry["curves"]) > 6
        for c, d in entry["curves"].items():
            if c.startswith("partial") and (many or not spec.partials):
                continue  # too many species pairs for one plot: the total only
            if spec.plot is not None and not c.startswith("partial") and c not in spec.plot:
                continue
            if spec.plot is not None and c.startswith("partial") and "partial" not in spec.plot:
                continue
            mean = np.array([np.nan if v is None else v for v in d["mean"]])
            lo = np.array([np.nan if v is None else v for v in d["lo"]])
            hi = np.array([np.nan if v is None else v for v in d["hi"]])
            label = "total" if c in ("g", "K", "p", "survival") else c.replace("partial.", "species pair ")
            if spec.style == "points":
                if np.nan_to_num(mean[0]) > 0.99:
                    continue  # (almost) every window empty: a spike at n_h = 0 hides the others
                ax.errorbar(x, mean, yerr=[mean - lo, hi - mean], fmt="o-", ms=3, label=label)
            else:
                (line,) = ax.plot(x, mean, lw=1.2, label=label)
                ax.fill_between(x, lo, hi, color=line.get_color(), alpha=0.25, lw=0)
        ax.set_xlabel(spec.x_label or entry["x_name"])
        ax.set_ylabel(spec.y_label or name)
        ax.set_title(f"{title}: {name}, mean and 95 % t band over {entry['n_realizations']} realization(s)", fontsize=9)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
        fig.tight_layout()
        target = Path(folder) / f"{name}.{fmt}"
        with atomic_path(target) as tmp:
            fig.savefig(tmp, format=fmt, dpi=120)
        plt.close(fig)
