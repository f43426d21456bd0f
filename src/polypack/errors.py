"""Exception hierarchy of polypack.

Every error raised on purpose by polypack derives from :class:`PolypackError`, so a
caller can catch everything polypack-specific with one ``except``. Messages are one
line and name the offending value and what is allowed.
"""

from __future__ import annotations

__all__ = [
    "PolypackError",
    "InvalidInputError",
    "OverlapError",
    "FormatError",
    "InfeasibleError",
    "OutputError",
    "Interrupted",
    "OverlapWarning",
    "NotComputedError",
]


class PolypackError(Exception):
    """Base class of all polypack errors."""


class InvalidInputError(PolypackError, ValueError):
    """An argument has a wrong shape, type or value (NaN radii, a negative box, ...)."""


class OverlapError(PolypackError):
    """Spheres overlap where a valid (non-overlapping) packing is required."""


class FormatError(PolypackError):
    """A file is unreadable, truncated, empty or not in the expected format."""


class InfeasibleError(PolypackError):
    """The request cannot be met (an impossible volume fraction, too many particles, ...)."""


class OutputError(PolypackError):
    """An output path cannot be written (a device, FIFO, socket or folder at the target,
    a read-only folder, a file where a folder is needed ...)."""


class Interrupted(KeyboardInterrupt):
    """A computation stopped at a safe point on Ctrl-C (SIGINT).

    Derives from :class:`KeyboardInterrupt`, not from :class:`PolypackError`: it is not
    an error of the input, and ``except Exception`` must never swallow it.  ``partial``
    is the state reached (e.g. the pack grown so far, marked ``status="interrupted"``
    in its ``meta``) or None; it is never a complete result and is saved only where
    asked for under a name that says so (``polypack pack --checkpoint``).
    """

    def __init__(self, message="interrupted", partial=None):
        super().__init__(message)
        self.partial = partial


class OverlapWarning(UserWarning):
    """An analysis was given a pack with overlapping spheres (its numbers are not those of
    a hard-sphere pack); see :func:`polypack.analysis.overlap_policy`."""


class NotComputedError(PolypackError, RuntimeError):
    """A result of an estimator was asked for before ``compute(packing)`` was called."""
