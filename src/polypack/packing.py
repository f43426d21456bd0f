"""The one data model of polypack: a periodic pack of spheres."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from .errors import InvalidInputError

__all__ = ["Packing"]


def _wrap(positions: np.ndarray, box: np.ndarray) -> np.ndarray:
    """Fold positions into ``[0, L)`` per axis (never returns ``L`` itself)."""
    p = np.mod(positions, box)
    p = np.where(p >= box, p - box, p)
    return np.where(p < 0, 0.0, p)


class Packing:
    """Spheres in an orthorhombic box that is periodic on all axes.

    Parameters
    ----------
    positions : (N, 3) array_like of float
        Sphere centres; folded into ``[0, L)`` per axis.
    radii : (N,) array_like of float
        Radii, finite and > 0, in the user's length unit.
    box : (3,) array_like of float or float
        Box lengths (a scalar means a cube), finite and > 0; the origin is at 0.
    species : (N,) array_like of int, optional
        Size class or mode index ``0..K-1`` of each sphere; default all 0.
    meta : dict, optional
        Provenance (tool version, seed, parameters, protocol history); copied.

    Notes
    -----
    A Packing is immutable in practice: its arrays are read-only and generators
    return new packings. Use :meth:`replace` to derive a modified copy.

    Raises
    ------
    InvalidInputError
        On a shape mismatch, NaN or infinite values, radii <= 0, box lengths <= 0,
        a sphere whose diameter exceeds half the smallest box length (the minimum
        image would no longer be unique) or non-integer or negative species.
    """

    __slots__ = ("_positions", "_radii", "_box", "_species", "meta")

    def __init__(self, positions, radii, box, species=None, meta=None):
        pos = np.array(positions, dtype=np.float64, copy=True)
        rad = np.array(radii, dtype=np.float64, copy=True)
        if rad.ndim != 1:
            raise InvalidInputError(f"radii must be a 1-D array, got shape {rad.shape}")
        n = rad.shape[0]
        if pos.ndim == 1 and pos.size == 0 and n == 0:
            pos = pos.reshape(0, 3)
        if pos.ndim != 2 or pos.shape[1] != 3:
            raise InvalidInputError(f"positions must have shape (N, 3), got {pos.shape}")
        if pos.shape[0] != n:
            raise InvalidInputError(
                f"positions has {pos.shape[0]} rows but radii has {n} entries; they must match"
            )
        bx = np.array(box, dtype=np.float64, copy=True)
        if bx.ndim == 0:
            bx = np.full(3, float(bx))
        if bx.shape != (3,):
            raise InvalidInputError(f"box must be a scalar or have 3 lengths, got shape {bx.shape}")
        if not np.all(np.isfinite(bx)) or np.any(bx <= 0):
            raise InvalidInputError(f"box lengths {bx.tolist()} must be finite and > 0")
        bad = ~np.isfinite(pos)
        if bad.any():
            k = int(np.argwhere(bad)[0, 0])
            raise InvalidInputError(f"position of sphere {k} is {pos[k].tolist()}; must be finite")
        bad = ~np.isfinite(rad) | (rad <= 0)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise InvalidInputError(f"radius of sphere {k} is {rad[k]!r}; radii must be finite and > 0")
        if n and 2.0 * rad.max() > 0.5 * bx.min():
            k = int(np.argmax(rad))
            raise InvalidInputError(
                f"sphere {k} has diameter {2 * rad[k]:g} > half the smallest box length "
                f"{0.5 * bx.min():g}; the periodic box must be at least 4 radii wide"
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
        pos = _wrap(pos, bx)
        for arr in (pos, rad, bx, sp):
            arr.setflags(write=False)
        self._positions, self._radii, self._box, self._species = pos, rad, bx, sp
        self.meta: dict[str, Any] = copy.deepcopy(dict(meta)) if meta else {}

    # ------------------------------------------------------------------ data
    @property
    def positions(self) -> np.ndarray:
        """(N, 3) centres in ``[0, L)`` (read-only)."""
        return self._positions

    @property
    def radii(self) -> np.ndarray:
        """(N,) radii (read-only)."""
        return self._radii

    @property
    def box(self) -> np.ndarray:
        """(3,) box lengths (read-only)."""
        return self._box

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
        """Volume of the periodic box."""
        return float(np.prod(self._box))

    @property
    def volume_fraction(self) -> float:
        """Sum of sphere volumes over the box volume (spheres never overlap in a valid pack)."""
        return float(4.0 / 3.0 * np.pi * np.sum(self._radii**3) / self.box_volume)

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
        """Volume fraction of each species, ``c^(k)`` in seed 000 (sums to ``volume_fraction``)."""
        vol = 4.0 / 3.0 * np.pi * self._radii**3
        return np.bincount(self._species, weights=vol, minlength=self.n_species) / self.box_volume

    # ---------------------------------------------------------------- checks
    def min_gap(self) -> float:
        """Exact minimum over pairs of ``d_ij / (r_i + r_j) - 1`` (minimum image).

        Negative means overlap. Size-aware cell search: O(N) for any size ratio.
        Returns ``inf`` for fewer than two spheres.
        """
        from .neighbors import min_relative_gap

        return min_relative_gap(self._positions, self._radii, self._box)[0]

    def closest_pair(self):
        """``(gap, (i, j))`` of the pair realising :meth:`min_gap` (``(inf, None)`` if N < 2)."""
        from .neighbors import min_relative_gap

        return min_relative_gap(self._positions, self._radii, self._box)

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
        i, j, d = pairs_within(self._positions, self._radii, self._box, a=1.0, b=0.0)
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
        """A new Packing with some of positions, radii, box, species, meta replaced."""
        kw = dict(
            positions=self._positions,
            radii=self._radii,
            box=self._box,
            species=self._species,
            meta=self.meta,
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
            and self.meta == other.meta
        )

    __hash__ = None  # mutable meta

    def __repr__(self) -> str:
        if self.n:
            rr = f"radii {self._radii.min():.4g}..{self._radii.max():.4g}"
        else:
            rr = "empty"
        return (
            f"Packing(n={self.n}, box={self._box.tolist()}, volume_fraction={self.volume_fraction:.4f}, "
            f"{rr}, species={self.n_species})"
        )
