"""Moved: the figures live in :mod:`polypack.report.figures` (the run engine draws nothing).

This alias keeps ``polypack.ensemble.plots`` imports of earlier code working.
"""

from ..report import figures as _figures


def __getattr__(name):
    return getattr(_figures, name)
