"""Shared periodic neighbour utilities (minimum image, size-aware pair queries).

Every generator and estimator that needs neighbours goes through this module, so
the periodic conventions live in one place.  The heavy lifting is done by the numba
kernels in :mod:`polypack._kernels.cells`.
"""

from __future__ import annotations

import numpy as np

from .errors import InvalidInputError

__all__ = ["minimum_image", "choose_cells", "pairs_within", "min_relative_gap"]


def minimum_image(delta, box):
    """Minimum-image separation vectors in an orthorhombic periodic box.

    Parameters
    ----------
    delta : array_like, (..., 3)
        Raw separations ``x_j - x_i``.
    box : array_like, (3,)
        Box lengths.

    Returns
    -------
    numpy.ndarray
        Separations folded into ``[-L/2, L/2]`` per axis.
    """
    delta = np.asarray(delta, dtype=np.float64)
    box = np.asarray(box, dtype=np.float64)
    return delta - box * np.round(delta / box)


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


def pairs_within(positions, radii, box, a=1.0, b=0.0, method="cells"):
    """Every pair with ``d_ij <= a (r_i + r_j) + b`` under minimum image, each once.

    Parameters
    ----------
    positions : (N, 3) array_like
    radii : (N,) array_like
    box : (3,) array_like
    a, b : float
        ``a = 1, b = gap``: surface separation below ``gap``; ``a = 0, b = r_c``:
        centre distance below ``r_c``; ``a = 1 + eps, b = 0``: relative gap below eps.
    method : {"cells", "brute"}
        ``"brute"`` is the O(N^2) oracle.

    Returns
    -------
    i, j : numpy.ndarray of int64
        Pair indices; sphere ``i`` is the larger one (ties: larger index).
    d : numpy.ndarray of float64
        Centre distances (minimum image).

    Raises
    ------
    InvalidInputError
        If the search reach ``2 a max(r) + b`` exceeds half the smallest box length,
        where minimum image stops being the only image.
    """
    from ._kernels import cells

    pos = np.ascontiguousarray(positions, dtype=np.float64)
    rad = np.ascontiguousarray(radii, dtype=np.float64)
    box = np.ascontiguousarray(box, dtype=np.float64)
    if a < 0 or b < 0 or not np.isfinite(a) or not np.isfinite(b):
        raise InvalidInputError(f"pair criterion a={a}, b={b}: both must be finite and >= 0")
    n = pos.shape[0]
    if n < 2:
        e = np.empty(0, np.int64)
        return e, e.copy(), np.empty(0, np.float64)
    reach_max = 2.0 * a * float(rad.max()) + b
    if reach_max > 0.5 * float(box.min()) * (1 + 1e-12):
        raise InvalidInputError(
            f"neighbour reach {reach_max:g} exceeds half the smallest box length "
            f"{0.5 * float(box.min()):g}; use a smaller cutoff"
        )
    if method == "brute":
        return cells.pairs_brute(pos, rad, box, float(a), float(b))
    if method != "cells":
        raise InvalidInputError(f"method={method!r}: allowed are 'cells' and 'brute'")
    reach_small = 2.0 * a * float(np.percentile(rad, 10)) + b
    nc = choose_cells(box, n, reach_small)
    return cells.pairs_within(pos, rad, box, float(a), float(b), nc)


def min_relative_gap(positions, radii, box, method="cells"):
    """Exact ``min_ij d_ij / (r_i + r_j) - 1`` under minimum image, and the pair.

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
    a_cap = 0.5 * float(box.min()) / (2.0 * float(rad.max()))
    eps = 0.02
    while True:
        a = min(1.0 + eps, a_cap)
        i, j, d = pairs_within(pos, rad, box, a=a, b=0.0, method=method)
        if i.size:
            rel = d / (rad[i] + rad[j]) - 1.0
            k = int(np.argmin(rel))
            return float(rel[k]), (int(min(i[k], j[k])), int(max(i[k], j[k])))
        if a >= a_cap:
            break
        eps *= 4.0
    # Very dilute: no pair within the largest admissible reach; exhaustive search.
    return _min_gap_exhaustive(pos, rad, box)


def _min_gap_exhaustive(pos, rad, box):
    best, pair = float("inf"), None
    for i in range(pos.shape[0] - 1):
        dv = minimum_image(pos[i + 1 :] - pos[i], box)
        rel = np.sqrt((dv * dv).sum(axis=1)) / (rad[i + 1 :] + rad[i]) - 1.0
        k = int(np.argmin(rel))
        if rel[k] < best:
            best, pair = float(rel[k]), (i, i + 1 + k)
    return best, pair
