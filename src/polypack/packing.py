"""The one data model of polypack: a pack of spheres (3D) or disks (2D) in a box."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from .errors import InvalidInputError
from .geometry import DIMENSIONS, normalize_periodic, unit_ball_volume, wrap

__all__ = ["Packing", "WALL_TOLERANCE"]

#: Relative round-off (in units of the radius) by which a sphere may poke through a wall.
WALL_TOLERANCE = 1e-9


def _float_array(name, value):
    """A float64 copy of ``value``; InvalidInputError (not a bare ValueError) for text or objects."""
    try:
        return np.array(value, dtype=np.float64, copy=True)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(
            f"{name}={_short_repr(value)}: must be numbers (an array of float), not {type(value).__name__} ({exc})"
        ) from None


def _short_repr(value, width=40):
    text = repr(value)
    return text if len(text) <= width else text[: width - 3] + "..."


class Packing:
    """Spheres (3D) or disks (2D) in an orthorhombic box, periodic per axis.

    Parameters
    ----------
    positions : (N, dim) array_like of float
        Centres, ``dim`` = 3 (spheres) or 2 (disks); folded into ``[0, L)`` on every
        periodic axis. On a wall axis they are kept as given and every sphere must lie
        inside ``[0, L]`` (``r <= x <= L - r`` up to a round-off of
        ``WALL_TOLERANCE`` radii).
    radii : (N,) array_like of float
        Radii, finite and > 0, in the user's length unit.
    box : (dim,) array_like of float or float
        Box lengths (a scalar means a cube or square), finite and > 0; the origin is at 0.
    species : (N,) array_like of int, optional
        Size class or mode index ``0..K-1`` of each sphere; default all 0.
    meta : dict, optional
        Provenance (tool version, seed, parameters, protocol history); copied.
    periodic : bool or sequence of bool, optional
        Periodic axes: ``None`` or ``True`` (default) all periodic, ``False`` walls on
        every axis, or one flag per axis (e.g. ``(True, False)`` for a 2D deposit with a
        floor and an open top bounded by the box height).

    Notes
    -----
    A Packing is immutable in practice: its arrays are read-only and generators
    return new packings. Use :meth:`replace` to derive a modified copy.

    Raises
    ------
    InvalidInputError
        On a shape mismatch, NaN or infinite values, radii <= 0, box lengths <= 0,
        a sphere whose diameter exceeds half the smallest periodic box length (the
        minimum image would no longer be unique), a sphere outside the box on a wall
        axis, or non-integer or negative species.
    """

    __slots__ = ("_positions", "_radii", "_box", "_species", "_periodic", "meta")

    def __init__(self, positions, radii, box, species=None, meta=None, periodic=None):
        pos = _float_array("positions", positions)
        rad = _float_array("radii", radii)
        if rad.ndim != 1:
            raise InvalidInputError(f"radii must be a 1-D array, got shape {rad.shape}")
        n = rad.shape[0]
        bx = _float_array("box", box)
        if pos.ndim == 1 and pos.size == 0 and n == 0:
            pos = pos.reshape(0, bx.shape[0] if bx.ndim == 1 and bx.shape[0] in DIMENSIONS else 3)
        if pos.ndim != 2 or pos.shape[1] not in DIMENSIONS:
            raise InvalidInputError(f"positions must have shape (N, 3) or (N, 2), got {pos.shape}")
        dim = pos.shape[1]
        if pos.shape[0] != n:
            raise InvalidInputError(
                f"positions has {pos.shape[0]} rows but radii has {n} entries; they must match"
            )
        if bx.ndim == 0:
            bx = np.full(dim, float(bx))
        if bx.shape != (dim,):
            raise InvalidInputError(
                f"box must be a scalar or have {dim} lengths (positions are {dim}-D), got shape {bx.shape}"
            )
        if not np.all(np.isfinite(bx)) or np.any(bx <= 0):
            raise InvalidInputError(f"box lengths {bx.tolist()} must be finite and > 0")
        flags = normalize_periodic(periodic, dim)
        bad = ~np.isfinite(pos)
        if bad.any():
            k = int(np.argwhere(bad)[0, 0])
            raise InvalidInputError(f"position of sphere {k} is {pos[k].tolist()}; must be finite")
        bad = ~np.isfinite(rad) | (rad <= 0)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise InvalidInputError(f"radius of sphere {k} is {rad[k]!r}; radii must be finite and > 0")
        pbox = bx[np.array(flags)]
        if n and pbox.size and 2.0 * rad.max() > 0.5 * pbox.min():
            k = int(np.argmax(rad))
            raise InvalidInputError(
                f"sphere {k} has diameter {2 * rad[k]:g} > half the smallest periodic box length "
                f"{0.5 * pbox.min():g}; the periodic box must be at least 4 radii wide"
            )
        for ax in range(dim):
            if flags[ax] or not n:
                continue
            slack = WALL_TOLERANCE * rad
            out = (pos[:, ax] - rad < -slack) | (pos[:, ax] + rad > bx[ax] + slack)
            if out.any():
                k = int(np.flatnonzero(out)[0])
                raise InvalidInputError(
                    f"sphere {k} at {'xyz'[ax]}={pos[k, ax]!r} with radius {rad[k]!r} crosses a wall of axis "
                    f"{'xyz'[ax]}; on a wall axis spheres must lie inside [0, {bx[ax]!r}]"
                )
        if species is None:
            sp = np.zeros(n, dtype=np.int64)
        else:
            raw = np.asarray(species)
            if raw.shape != (n,):
                raise InvalidInputError(f"species must have shape ({n},), got {raw.shape}")
            if raw.dtype.kind == "f":
                if not np.all(np.isfinite(raw)) or np.any(raw != np.round(raw)):
                    k = int(np.flatnonzero(~np.isfinite(raw) | (raw != np.round(raw)))[0])
                    raise InvalidInputError(f"species of sphere {k} is {raw[k]!r}; must be an integer")
            elif raw.dtype.kind not in "iub" and n:
                raise InvalidInputError(f"species must be integers, got dtype {raw.dtype}")
            sp = raw.astype(np.int64)
            if n and sp.min() < 0:
                k = int(np.argmin(sp))
                raise InvalidInputError(f"species of sphere {k} is {sp[k]}; must be >= 0")
        pos = wrap(pos, bx, flags)
        for arr in (pos, rad, bx, sp):
            arr.setflags(write=False)
        self._positions, self._radii, self._box, self._species = pos, rad, bx, sp
        self._periodic = flags
        self.meta: dict[str, Any] = copy.deepcopy(dict(meta)) if meta else {}

    # ------------------------------------------------------------------ data
    @property
    def positions(self) -> np.ndarray:
        """(N, dim) centres, in ``[0, L)`` on periodic axes (read-only)."""
        return self._positions

    @property
    def radii(self) -> np.ndarray:
        """(N,) radii (read-only)."""
        return self._radii

    @property
    def box(self) -> np.ndarray:
        """(dim,) box lengths (read-only)."""
        return self._box

    @property
    def dim(self) -> int:
        """Space dimension: 3 (spheres) or 2 (disks), from the positions' shape."""
        return int(self._positions.shape[1])

    @property
    def periodic(self) -> tuple[bool, ...]:
        """Per-axis flags: ``True`` periodic, ``False`` walls at 0 and L."""
        return self._periodic

    @property
    def fully_periodic(self) -> bool:
        """True when every axis is periodic."""
        return all(self._periodic)

    @property
    def species(self) -> np.ndarray:
        """(N,) integer species labels (read-only)."""
        return self._species

    # --------------------------------------------------------------- derived
    @property
    def n(self) -> int:
        """Number of spheres."""
        return int(self._radii.shape[0])

    def __len__(self) -> int:
        return self.n

    @property
    def box_volume(self) -> float:
        """Volume of the box (its area in 2D)."""
        return float(np.prod(self._box))

    @property
    def volume_fraction(self) -> float:
        """Sum of sphere volumes (disk areas in 2D) over the box volume (area).

        Spheres never overlap in a valid pack.
        """
        d = self.dim
        return float(unit_ball_volume(d) * np.sum(self._radii**d) / self.box_volume)

    @property
    def n_species(self) -> int:
        """Number of species labels ``max(species) + 1`` (0 for an empty pack)."""
        return int(self._species.max()) + 1 if self.n else 0

    @property
    def species_counts(self) -> np.ndarray:
        """Number of spheres per species label."""
        return np.bincount(self._species, minlength=self.n_species)

    @property
    def species_fractions(self) -> np.ndarray:
        """Volume (area) fraction of each species, ``c^(k)`` in seed 000 (sums to ``volume_fraction``)."""
        vol = unit_ball_volume(self.dim) * self._radii**self.dim
        return np.bincount(self._species, weights=vol, minlength=self.n_species) / self.box_volume

    # ---------------------------------------------------------------- checks
    def min_gap(self) -> float:
        """Exact minimum over pairs of ``d_ij / (r_i + r_j) - 1`` (minimum image on periodic axes).

        Negative means overlap. Walls are not pairs (see :meth:`wall_gap`). Size-aware cell search: O(N) for any size ratio.
        Returns ``inf`` for fewer than two spheres.
        """
        from .neighbors import min_relative_gap

        return min_relative_gap(self._positions, self._radii, self._box, periodic=self._periodic)[0]

    def wall_gap(self) -> float:
        """Minimum over spheres and wall axes of ``(distance to the wall) / r - 1``.

        ``inf`` when every axis is periodic or the pack is empty; about 0 for a sphere
        resting on a wall.
        """
        best = float("inf")
        for ax, per in enumerate(self._periodic):
            if per or not self.n:
                continue
            x, r = self._positions[:, ax], self._radii
            best = min(best, float(np.min(np.minimum(x, self._box[ax] - x) / r - 1.0)))
        return best

    def closest_pair(self):
        """``(gap, (i, j))`` of the pair realising :meth:`min_gap` (``(inf, None)`` if N < 2)."""
        from .neighbors import min_relative_gap

        return min_relative_gap(self._positions, self._radii, self._box, periodic=self._periodic)

    def overlaps(self, tol: float = 0.0) -> np.ndarray:
        """Pairs whose relative gap ``d_ij / (r_i + r_j) - 1`` is below ``-tol``.

        Parameters
        ----------
        tol : float, default 0
            Relative overlap tolerated (``1e-12`` ignores round-off contacts).

        Returns
        -------
        (M, 3) float array with rows ``(i, j, gap)``, ``i < j``, sorted by gap.
        Use ``.astype(int)`` on the first two columns for indices.
        """
        from .neighbors import pairs_within

        if tol < 0 or not np.isfinite(tol):
            raise InvalidInputError(f"tol={tol!r}: must be finite and >= 0")
        i, j, d = pairs_within(self._positions, self._radii, self._box, a=1.0, b=0.0, periodic=self._periodic)
        rel = d / (self._radii[i] + self._radii[j]) - 1.0
        keep = rel < -tol
        lo, hi = np.minimum(i[keep], j[keep]), np.maximum(i[keep], j[keep])
        out = np.column_stack([lo, hi, rel[keep]]).astype(np.float64)
        return out[np.argsort(out[:, 2], kind="stable")] if out.size else out.reshape(0, 3)

    def check_no_overlap(self, tol: float = 0.0) -> None:
        """Raise :class:`~polypack.OverlapError` naming the worst pair if any overlap exceeds ``tol``."""
        from .errors import OverlapError

        ov = self.overlaps(tol)
        if len(ov):
            i, j, g = int(ov[0, 0]), int(ov[0, 1]), ov[0, 2]
            raise OverlapError(
                f"{len(ov)} overlapping pair(s); worst is spheres {i} and {j} with relative gap {g:.3e} "
                f"(allowed >= {-tol:g})"
            )

    # ------------------------------------------------------------- utilities
    def replace(self, **changes) -> "Packing":
        """A new Packing with some of positions, radii, box, species, meta, periodic replaced."""
        kw = dict(
            positions=self._positions,
            radii=self._radii,
            box=self._box,
            species=self._species,
            meta=self.meta,
            periodic=self._periodic,
        )
        unknown = set(changes) - set(kw)
        if unknown:
            raise InvalidInputError(f"unknown field(s) {sorted(unknown)}; allowed: {sorted(kw)}")
        kw.update(changes)
        return Packing(**kw)

    def __eq__(self, other) -> bool:
        if not isinstance(other, Packing):
            return NotImplemented
        return (
            np.array_equal(self._positions, other._positions)
            and np.array_equal(self._radii, other._radii)
            and np.array_equal(self._box, other._box)
            and np.array_equal(self._species, other._species)
            and self._periodic == other._periodic
            and self.meta == other.meta
        )

    __hash__ = None  # mutable meta

    def __repr__(self) -> str:
        if self.n:
            rr = f"radii {self._radii.min():.4g}..{self._radii.max():.4g}"
        else:
            rr = "empty"
        extra = "" if self.dim == 3 else f", dim={self.dim}"
        if not self.fully_periodic:
            extra += f", periodic={self._periodic}"
        return (
            f"Packing(n={self.n}, box={self._box.tolist()}, volume_fraction={self.volume_fraction:.4f}, "
            f"{rr}, species={self.n_species}{extra})"
        )
