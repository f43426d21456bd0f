"""Statistical descriptors of packs and the analytic theory they are compared with.

Estimators follow one protocol (freud style): ``compute(packing, reset=True)``
returns ``self``; results are properties; ``reset=False`` accumulates realizations
(pooled estimates with standard errors between realizations); ``plot(ax=None)``
returns a matplotlib Axes; ``to_dict()`` gives plain JSON-able data.

Implements §2 and §5 of 000_2cedc098acbd866b.txt and the degree of heterogeneity
of §2.3 of 003_873b69fc71c74cf6.txt.
"""

from __future__ import annotations

from importlib import import_module as _import_module

from ._base import overlap_policy, set_overlap_policy
from .kfunction import KFunction
from .rdf import RDF, ContactValueMonitor, contact_value, scaled_coordinate, size_classes

__all__ = ["KFunction", "RDF", "ContactValueMonitor", "contact_value", "scaled_coordinate", "size_classes",
           "overlap_policy", "set_overlap_policy"]

_LAZY = {
    "WindowCounts": "windows",
    "ShellCount": "windows",
    "lattice_shell_count": "windows",
    "Contacts": "contacts",
    "DepositStatistics": "deposits",
    "free_surface_height": "deposits",
    "small_fraction_profile": "deposits",
    "PoreSizes": "pores",
    "nearest_surface_distance": "pores",
    "ThreePointParameters": "threepoint",
    "power_law_fit": "powerlaw",
    "PowerLawFit": "powerlaw",
    "theory": None,
}


def __getattr__(name):
    if name in _LAZY:
        mod = _LAZY[name]
        if mod is None:
            return _import_module(f"{__name__}.{name}")
        return getattr(_import_module(f"{__name__}.{mod}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
