"""polypack: exact random packs of polydisperse spheres, their size distributions and statistics.

Implements 000_2cedc098acbd866b.txt (random bimodal packs), 001_ad5bae0acea940c4.txt
(particle-size distributions) and 003_873b69fc71c74cf6.txt (degree of heterogeneity).
"""

from __future__ import annotations

# First: in the CLI's own process (``polypack ...``, ``python -m polypack ...``) a Ctrl-C
# during the imports below exits 130 with one line, not with a traceback (see _interrupt).
from ._interrupt import guard_cli_process as _guard_cli_process

_guard_cli_process()

import os as _os  # noqa: E402

# A per-user numba cache folder: a shared or read-only site-packages cache breaks caching.
# numba does not invalidate a cached kernel when a kernel it calls from another file
# changes, so the folder is keyed on a digest of all kernel sources.
def _numba_cache_dir():
    import hashlib

    kernels = _os.path.join(_os.path.dirname(__file__), "_kernels")
    digest = hashlib.sha1()
    try:
        for name in sorted(_os.listdir(kernels)):
            if name.endswith(".py"):
                with open(_os.path.join(kernels, name), "rb") as fh:
                    digest.update(name.encode() + fh.read())
    except OSError:
        pass
    base = _os.environ.get("XDG_CACHE_HOME", _os.path.join(_os.path.expanduser("~"), ".cache"))
    return _os.path.join(base, "polypack", "numba", digest.hexdigest()[:12])


if "NUMBA_CACHE_DIR" not in _os.environ:
    _os.environ["NUMBA_CACHE_DIR"] = _numba_cache_dir()
    import sys as _sys

    if "numba.core.config" in _sys.modules:  # numba imported first: its config is already read
        _sys.modules["numba.core.config"].CACHE_DIR = _os.environ["NUMBA_CACHE_DIR"]

from importlib import import_module as _import_module

from .errors import FormatError, InfeasibleError, InvalidInputError, NotComputedError, OverlapError, PolypackError
from .packing import Packing

from ._version import __version__

__all__ = [
    "Packing",
    "PolypackError",
    "InvalidInputError",
    "OverlapError",
    "FormatError",
    "InfeasibleError",
    "NotComputedError",
    "pack",
    "shake",
    "scrm",
    "deposit",
    "brownian",
    "vem",
    "io",
    "psd",
    "analysis",
    "generate",
    "neighbors",
    "mechanics",
    "report",
    "view",
    "__version__",
]

# Lazy attributes: subpackages and generator functions are imported on first use, so
# ``import polypack`` stays fast and numba kernels compile only when needed.
_LAZY_MODULES = {"io", "psd", "analysis", "generate", "neighbors", "ensemble", "study", "mechanics", "report",
                 "studies"}
_LAZY_FUNCS = {
    "pack": ("polypack.generate.lubachevsky", "pack"),
    "shake": ("polypack.generate.shake", "shake"),
    "scrm": ("polypack.generate.shake", "scrm"),
    "deposit": ("polypack.generate.deposit", "deposit"),
    "brownian": ("polypack.generate.brownian", "brownian"),
    "vem": ("polypack.generate.vem", "vem"),
    "view": ("polypack.report.viewer", "view"),
}


def __getattr__(name):
    if name in _LAZY_MODULES:
        return _import_module(f"polypack.{name}")
    if name in _LAZY_FUNCS:
        mod, attr = _LAZY_FUNCS[name]
        return getattr(_import_module(mod), attr)
    raise AttributeError(f"module 'polypack' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | _LAZY_MODULES | set(_LAZY_FUNCS))
