"""Generators of packings: Lubachevsky–Stillinger growth (:func:`pack`), shaking (SCRM), deposition,
Brownian dynamics with DLVO forces (:func:`brownian`) and the DLVO pair potential.

Functions are imported lazily so that importing this package does not compile kernels.
"""

from __future__ import annotations

from importlib import import_module as _import_module

__all__ = ["pack", "shake", "scrm", "deposit", "PackTuning", "ShakeTuning", "brownian", "brownian_bonds",
           "dlvo_parameters", "dlvo_potential", "dlvo_force", "dlvo_extrema", "plot_dlvo", "DLVO_DEFAULTS", "vem"]

_LAZY = {
    "pack": ("polypack.generate.lubachevsky", "pack"),
    "shake": ("polypack.generate.shake", "shake"),
    "scrm": ("polypack.generate.shake", "scrm"),
    "deposit": ("polypack.generate.deposit", "deposit"),
    "brownian": ("polypack.generate.brownian", "brownian"),
    "brownian_bonds": ("polypack.generate.brownian", "brownian_bonds"),
    "dlvo_parameters": ("polypack.generate.dlvo", "dlvo_parameters"),
    "dlvo_potential": ("polypack.generate.dlvo", "dlvo_potential"),
    "dlvo_force": ("polypack.generate.dlvo", "dlvo_force"),
    "dlvo_extrema": ("polypack.generate.dlvo", "dlvo_extrema"),
    "plot_dlvo": ("polypack.generate.dlvo", "plot_dlvo"),
    "DLVO_DEFAULTS": ("polypack.generate.dlvo", "DLVO_DEFAULTS"),
    "PackTuning": ("polypack.generate.lubachevsky", "PackTuning"),
    "ShakeTuning": ("polypack.generate.shake", "ShakeTuning"),
    "vem": ("polypack.generate.vem", "vem"),
}


def __getattr__(name):
    if name in _LAZY:
        mod, attr = _LAZY[name]
        return getattr(_import_module(mod), attr)
    raise AttributeError(f"module 'polypack.generate' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
