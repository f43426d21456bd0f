"""Self-contained HTML reports of packs and run folders, with a 3D viewer (``polypack report``).

:func:`view` gives a viewer of one pack for Jupyter or the browser; :func:`report`
writes the report of a pack file or of a ``polypack run`` folder.
"""

from __future__ import annotations

from .viewer import View, view

__all__ = ["View", "view", "report"]


def report(*args, **kwargs):
    """See :func:`polypack.report.build.report`."""
    from .build import report as _report

    return _report(*args, **kwargs)
