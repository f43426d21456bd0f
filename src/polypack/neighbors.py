"""Shared periodic neighbour utilities (minimum image, size-aware pair queries).

Every generator and estimator that needs neighbours goes through this module, so
the periodic conventions live in one place.  The heavy lifting is done by the numba
kernels in :mod:`polypack._kernels.cells`, which work on 3D periodic boxes.

Other boxes are embedded into that case without touching the kernel: a 2D pack gets
a third coordinate 0 in a one-cell-thick slab (the z separation is always 0), and a
wall axis of length ``L`` (positions in ``[0, L]``) is handed to the kernel as a
periodic axis of length ``2 L``, on which no separation ``|dx| <= L`` is ever folded,
so the minimum image is the plain separation there.  3D fully periodic input takes
the kernel path directly (bit-identical to the historical code).
"""

from __future__ import annotations

import numpy as np

from .errors import InvalidInputError
from .geometry import minimum_image, normalize_periodic

__all__ = ["minimum_image", "choose_cells", "pairs_within", "min_relative_gap"]


def _embed(pos, box, periodic):
    """``(pos3, box3, ncell_z_one, periodic_box)`` handing any box to the 3D periodic kernel.

    Returns the inputs unchanged (and ``False`` for the flag) for 3D fully periodic
    boxes. ``periodic_box`` is the array of periodic box lengths (may be empty).
    """
    dim = pos.shape[1]
    flags = normalize_periodic(periodic, dim)
    pbox = box[np.array(flags, dtype=bool)]
    if dim == 3 and all(flags):
        return pos, box, False, pbox
    ebox = np.where(np.array(flags), box, 2.0 * box)
    if dim == 2:
        pos = np.ascontiguousarray(np.column_stack([pos, np.zeros(pos.shape[0])]))
        ebox = np.append(ebox, max(float(ebox.max()), 1.0))
    return pos, np.ascontiguousarray(ebox, dtype=np.float64), dim == 2, pbox


def choose_cells(box, n, reach_small):
    """Cells per axis for a grid whose cells are about ``reach_small`` wide.

    The cell is never smaller than what gives about two spheres per cell on average,
    and the grid never has more than ``4 n + 27`` cells.
    """
    box = np.asarray(box, dtype=np.float64)
    vol = float(np.prod(box))
    h = max(float(reach_small), (vol / max(2 * n, 1)) ** (1.0 / 3.0), 1e-300)
    nc = np.maximum(1, np.floor(box / h)).astype(np.int64)
    while np.prod(nc) > 4 * n + 27:
        nc = np.maximum(1, nc // 2)
    return nc


def _choose_cells_flat(box3, n, reach_small):
    """Cells for a 2D pack embedded as a slab: a square-ish grid in x, y and one cell in z."""
    area = float(box3[0] * box3[1])
    h = max(float(reach_small), (area / max(2 * n, 1)) ** 0.5, 1e-300)
    nc = np.maximum(1, np.floor(box3 / h)).astype(np.int64)
    nc[2] = 1
    while np.prod(nc) > 4 * n + 27:
        nc = np.maximum(1, nc // 2)
    return nc


def pairs_within(positions, radii, box, a=1.0, b=0.0, method="cells", periodic=None):
    """Every pair with ``d_ij <= a (r_i + r_j) + b`` under minimum image, each once.

    Parameters
    ----------
    positions : (N, dim) array_like
        Centres (``dim`` 2 or 3); on wall axes they must lie in ``[0, L]``.
    radii : (N,) array_like
    box : (dim,) array_like
    a, b : float
        ``a = 1, b = gap``: surface separation below ``gap``; ``a = 0, b = r_c``:
        centre distance below ``r_c``; ``a = 1 + eps, b = 0``: relative gap below eps.
    method : {"cells", "brute"}
        ``"brute"`` is the O(N^2) oracle.
    periodic : bool or sequence of bool, optional
        Periodic axes (default all); the minimum image applies only on those.

    Returns
    -------
    i, j : numpy.ndarray of int64
        Pair indices; sphere ``i`` is the larger one (ties: larger index).
    d : numpy.ndarray of float64
        Centre distances (minimum image).

    Raises
    ------
    InvalidInputError
        If the search reach ``2 a max(r) + b`` exceeds half the smallest periodic box
        length, where minimum image stops being the only image.
    """
    from ._kernels import cells

    pos = np.ascontiguousarray(positions, dtype=np.float64)
    rad = np.ascontiguousarray(radii, dtype=np.float64)
    box = np.ascontiguousarray(box, dtype=np.float64)
    if a < 0 or b < 0 or not np.isfinite(a) or not np.isfinite(b):
        raise InvalidInputError(f"pair criterion a={a}, b={b}: both must be finite and >= 0")
    if pos.ndim != 2 or pos.shape[1] not in (2, 3) or box.shape != (pos.shape[1],):
        raise InvalidInputError(f"positions {pos.shape} and box {box.shape}: need (N, dim) and (dim,), dim 2 or 3")
    n = pos.shape[0]
    if n < 2:
        e = np.empty(0, np.int64)
        return e, e.copy(), np.empty(0, np.float64)
    pos, ebox, flat, pbox = _embed(pos, box, periodic)
    reach_max = 2.0 * a * float(rad.max()) + b
    if pbox.size and reach_max > 0.5 * float(pbox.min()) * (1 + 1e-12):
        raise InvalidInputError(
            f"neighbour reach {reach_max:g} exceeds half the smallest periodic box length "
            f"{0.5 * float(pbox.min()):g}; use a smaller cutoff"
        )
    if method == "brute":
        return cells.pairs_brute(pos, rad, ebox, float(a), float(b))
    if method != "cells":
        raise InvalidInputError(f"method={method!r}: allowed are 'cells' and 'brute'")
    reach_small = 2.0 * a * float(np.percentile(rad, 10)) + b
    nc = _choose_cells_flat(ebox, n, reach_small) if flat else choose_cells(ebox, n, reach_small)
    # writable arrays, whatever the caller passed (a Packing's arrays are read-only): numba
    # compiles one version per writability, so every caller shares the one that
    # polypack._kernels.cells.warmup compiles and the packer's kernel calls (issue 33: cold start)
    return cells.pairs_within(_writable(pos), _writable(rad), _writable(ebox), float(a), float(b), nc)


def _writable(a):
    """``a`` if it is writable, else a copy (O(N), small beside the pair search)."""
    return a if a.flags.writeable else a.copy()


def min_relative_gap(positions, radii, box, method="cells", periodic=None):
    """Exact ``min_ij d_ij / (r_i + r_j) - 1`` under minimum image, and the pair.

    ``periodic`` (default all axes) selects the axes with a minimum image; positions
    may be 2D or 3D.

    Searches pairs within a relative gap ``eps`` that grows until a pair is found;
    any pair not found has a larger relative gap than every pair found, so the
    minimum over the candidates is the global minimum.

    Returns
    -------
    gap : float
        ``inf`` when fewer than two spheres.
    pair : tuple of int or None
    """
    pos = np.ascontiguousarray(positions, dtype=np.float64)
    rad = np.ascontiguousarray(radii, dtype=np.float64)
    box = np.ascontiguousarray(box, dtype=np.float64)
    n = pos.shape[0]
    if n < 2:
        return float("inf"), None
    flags = normalize_periodic(periodic, pos.shape[1])
    pbox = box[np.array(flags, dtype=bool)]
    a_cap = 0.5 * float(pbox.min()) / (2.0 * float(rad.max())) if pbox.size else float("inf")
    eps = 0.02
    while True:
        a = min(1.0 + eps, a_cap)
        i, j, d = pairs_within(pos, rad, box, a=a, b=0.0, method=method, periodic=periodic)
        if i.size:
            rel = d / (rad[i] + rad[j]) - 1.0
            k = int(np.argmin(rel))
            return float(rel[k]), (int(min(i[k], j[k])), int(max(i[k], j[k])))
        if a >= a_cap:
            break
        eps *= 4.0
    # Very dilute: no pair within the largest admissible reach; exhaustive search.
    return _min_gap_exhaustive(pos, rad, box, periodic)


def _min_gap_exhaustive(pos, rad, box, periodic=None):
    best, pair = float("inf"), None
    for i in range(pos.shape[0] - 1):
        dv = minimum_image(pos[i + 1 :] - pos[i], box, periodic)
        rel = np.sqrt((dv * dv).sum(axis=1)) / (rad[i + 1 :] + rad[i]) - 1.0
        k = int(np.argmin(rel))
        if rel[k] < best:
            best, pair = float(rel[k]), (i, i + 1 + k)
    return best, pair
