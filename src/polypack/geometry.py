"""Dimension-aware measures and periodic conventions (2D disks, 3D spheres).

One place for the formulas that depend on the space dimension ``dim`` (2 or 3):
the volume of a ball (the area of a disk in 2D), the measure of its boundary shell
(surface area, or circumference in 2D), the volume of a spherical shell between two
radii, and the minimum image and wrapping of positions in an orthorhombic box that
is periodic on some axes and bounded by walls on the others.

The expressions are written so that, for ``dim = 3``, they evaluate in exactly the
same floating-point order as the historical inline ``4.0 / 3.0 * np.pi * r**3``
(results are bit-identical to the code they replace).
"""

from __future__ import annotations

import numpy as np

from .errors import InvalidInputError

__all__ = [
    "DIMENSIONS",
    "check_dim",
    "unit_ball_volume",
    "unit_sphere_measure",
    "ball_volume",
    "shell_measure",
    "shell_volume",
    "radius_of_volume",
    "normalize_periodic",
    "minimum_image",
    "wrap",
]

DIMENSIONS = (2, 3)


def check_dim(dim) -> int:
    """``int(dim)`` if it is 2 or 3, else an :class:`~polypack.InvalidInputError`."""
    if isinstance(dim, bool) or not isinstance(dim, (int, np.integer)) or int(dim) not in DIMENSIONS:
        raise InvalidInputError(f"dim={dim!r}: allowed are 2 (disks) and 3 (spheres)")
    return int(dim)


def unit_ball_volume(dim: int = 3) -> float:
    """Volume of the unit ball: ``4 π / 3`` in 3D, ``π`` (area of the unit disk) in 2D."""
    return 4.0 / 3.0 * np.pi if check_dim(dim) == 3 else np.pi


def unit_sphere_measure(dim: int = 3) -> float:
    """Measure of the unit sphere: surface ``4 π`` in 3D, circumference ``2 π`` in 2D."""
    return 4.0 * np.pi if check_dim(dim) == 3 else 2.0 * np.pi


def ball_volume(r, dim: int = 3):
    """Volume ``4/3 π r³`` (3D) or area ``π r²`` (2D) of balls of radius ``r``.

    Parameters
    ----------
    r : float or array_like
        Radii.
    dim : {2, 3}
        Space dimension.
    """
    d = check_dim(dim)
    r = np.asarray(r, dtype=np.float64) if not np.isscalar(r) else r
    return unit_ball_volume(d) * r**d


def shell_measure(r, dim: int = 3):
    """Boundary measure of a ball of radius ``r``: ``4 π r²`` (3D) or ``2 π r`` (2D).

    Multiplied by a bin width ``dr`` this is the thin-shell volume used to normalise
    pair densities, e.g. ``g(r)`` of Eq. (4) of 000_2cedc098acbd866b.txt.
    """
    d = check_dim(dim)
    r = np.asarray(r, dtype=np.float64) if not np.isscalar(r) else r
    return unit_sphere_measure(d) * r ** (d - 1)


def shell_volume(r_lo, r_hi, dim: int = 3):
    """Exact volume between concentric spheres (circles in 2D) of radii ``r_lo <= r_hi``."""
    d = check_dim(dim)
    r_lo = np.asarray(r_lo, dtype=np.float64)
    r_hi = np.asarray(r_hi, dtype=np.float64)
    return unit_ball_volume(d) * (r_hi**d - r_lo**d)


def radius_of_volume(v, dim: int = 3):
    """Inverse of :func:`ball_volume`: the radius of a ball of volume (area) ``v``."""
    d = check_dim(dim)
    v = np.asarray(v, dtype=np.float64)
    if d == 3:
        return np.cbrt(v / unit_ball_volume(3))
    return np.sqrt(v / np.pi)


def normalize_periodic(periodic, dim: int) -> tuple[bool, ...]:
    """Per-axis periodic flags from ``None`` (all periodic), a bool or a sequence of ``dim`` bools."""
    d = check_dim(dim)
    if periodic is None:
        return (True,) * d
    if isinstance(periodic, (bool, np.bool_)):
        return (bool(periodic),) * d
    try:
        flags = tuple(periodic)
    except TypeError:
        raise InvalidInputError(
            f"periodic={periodic!r}: give True/False or a sequence of {d} booleans (one per axis)"
        ) from None
    if len(flags) != d or not all(isinstance(f, (bool, np.bool_)) for f in flags):
        raise InvalidInputError(f"periodic={periodic!r}: give True/False or a sequence of {d} booleans (one per axis)")
    return tuple(bool(f) for f in flags)


def minimum_image(delta, box, periodic=None):
    """Minimum-image separation vectors in an orthorhombic box.

    Parameters
    ----------
    delta : array_like, (..., dim)
        Raw separations ``x_j - x_i``.
    box : array_like, (dim,)
        Box lengths.
    periodic : bool or sequence of bool, optional
        Periodic axes (default all). Separations along wall axes are left as they are.

    Returns
    -------
    numpy.ndarray
        Separations folded into ``[-L/2, L/2]`` on every periodic axis.
    """
    delta = np.asarray(delta, dtype=np.float64)
    box = np.asarray(box, dtype=np.float64)
    if periodic is None:
        return delta - box * np.round(delta / box)
    flags = np.array(normalize_periodic(periodic, box.shape[0]))
    if flags.all():
        return delta - box * np.round(delta / box)
    return delta - np.where(flags, box * np.round(delta / box), 0.0)


def wrap(positions, box, periodic=None):
    """Fold positions into ``[0, L)`` on every periodic axis (never returns ``L`` itself).

    Wall axes are left unchanged.
    """
    positions = np.asarray(positions, dtype=np.float64)
    box = np.asarray(box, dtype=np.float64)
    p = np.mod(positions, box)
    p = np.where(p >= box, p - box, p)
    p = np.where(p < 0, 0.0, p)
    if periodic is None:
        return p
    flags = np.array(normalize_periodic(periodic, box.shape[0]))
    if flags.all():
        return p
    return np.where(flags, p, positions)
