"""Generators of packings: Lubachevsky–Stillinger growth (:func:`pack`), shaking (SCRM), deposition.

Functions are imported lazily so that importing this package does not compile kernels.
"""

from __future__ import annotations

from importlib import import_module as _import_module

__all__ = ["pack", "shake", "scrm", "deposit", "PackTuning", "ShakeTuning"]

_LAZY = {
    "pack": ("polypack.generate.lubachevsky", "pack"),
    "shake": ("polypack.generate.shake", "shake"),
    "scrm": ("polypack.generate.shake", "scrm"),
    "deposit": ("polypack.generate.deposit", "deposit"),
    "PackTuning": ("polypack.generate.lubachevsky", "PackTuning"),
    "ShakeTuning": ("polypack.generate.shake", "ShakeTuning"),
}


def __getattr__(name):
    if name in _LAZY:
        mod, attr = _LAZY[name]
        return getattr(_import_module(mod), attr)
    raise AttributeError(f"module 'polypack.generate' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
