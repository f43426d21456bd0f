"""Independent brute-force oracles: their own periodic distance code, no polypack imports.

The periodic distance along each axis is taken as ``min(|dx|, L - |dx|)`` for wrapped
coordinates (the two images of a separation in ``(-L, L)``), which is exact in an
orthorhombic box and shares nothing with polypack's ``min_image`` (rounding) code.
"""

import numpy as np


def _axis_dist(a, b, length):
    d = np.abs(a - b)
    return np.minimum(d, length - d)


def distance_matrix(pos, box):
    """``(N, N)`` periodic centre distances of wrapped positions (diagonal 0)."""
    pos = np.asarray(pos, float)
    box = np.broadcast_to(np.asarray(box, float), (pos.shape[1],))
    d2 = np.zeros((pos.shape[0], pos.shape[0]))
    for k in range(pos.shape[1]):
        a = _axis_dist(pos[:, None, k], pos[None, :, k], box[k])
        d2 += a * a
    return np.sqrt(d2)


def pairs(pos, radii, box, a, b):
    """Sorted list of ``(i, j, d)`` with ``i < j`` and ``d <= a (r_i + r_j) + b``."""
    d = distance_matrix(pos, box)
    r = np.asarray(radii, float)
    lim = a * (r[:, None] + r[None, :]) + b
    i, j = np.nonzero(np.triu(d <= lim, k=1))
    return i, j, d[i, j]


def min_gap(pos, radii, box):
    """Minimum over pairs of ``d_ij / (r_i + r_j) - 1``."""
    d = distance_matrix(pos, box)
    r = np.asarray(radii, float)
    g = d / (r[:, None] + r[None, :]) - 1.0
    np.fill_diagonal(g, np.inf)
    return float(g.min())


def nearest_surface(points, pos, radii, box):
    """``min_j (|p - x_j| - r_j)`` for wrapped points, in chunks of points."""
    points = np.asarray(points, float)
    pos = np.asarray(pos, float)
    box = np.broadcast_to(np.asarray(box, float), (pos.shape[1],))
    out = np.empty(points.shape[0])
    for s in range(0, points.shape[0], 256):
        p = points[s : s + 256]
        d2 = np.zeros((p.shape[0], pos.shape[0]))
        for k in range(pos.shape[1]):
            a = _axis_dist(p[:, None, k], pos[None, :, k], box[k])
            d2 += a * a
        out[s : s + 256] = np.min(np.sqrt(d2) - np.asarray(radii, float)[None, :], axis=1)
    return out


def ball_volume(r):
    return 4.0 / 3.0 * np.pi * np.asarray(r, float) ** 3
