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
