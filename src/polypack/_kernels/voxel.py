"""numba kernel of :func:`polypack.io.voxelize`: a phase-label image of a sphere (disk) pack.

Voxel ``(i, j, k)`` has its centre at ``((i + 1/2) h_x, (j + 1/2) h_y, (k + 1/2) h_z)``; it
takes the label ``1 + species`` of the sphere that holds its centre, else 0 (the matrix).
With ``subsamples = s > 0`` every voxel the sphere's surface may cross (centre within
half a voxel diagonal of the surface) is sampled on an ``s^dim`` grid of sub-voxel points
and the fraction of them inside the sphere is added to ``fraction`` (voxels wholly inside
get 1): the inclusion volume fraction of each voxel, a composite-voxel field.

2D packs use the same loop with one layer (``dim = 2``: ``nz = 1``, no z distance).
Periodic axes wrap indices; wall axes drop voxels outside ``[0, n)``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def voxelize_spheres(pos, radii, species, dim, n, h, periodic, subsamples, labels, fraction):
    """Fill ``labels`` (flat int32, C order ``(nx, ny[, nz])``) and ``fraction`` (flat float64).

    ``pos`` is ``(N, dim)``; ``n``, ``h``, ``periodic`` have 3 entries (``n[2] = 1`` in 2D).
    Returns the number of voxels whose centre more than one sphere claimed (0 for a valid pack).
    """
    nx, ny, nz = n[0], n[1], n[2]
    hx, hy, hz = h[0], h[1], h[2]
    s = subsamples
    if dim == 2:
        half_diag = 0.5 * math.sqrt(hx * hx + hy * hy)
    else:
        half_diag = 0.5 * math.sqrt(hx * hx + hy * hy + hz * hz)
    clashes = 0
    for p in range(radii.shape[0]):
        cx = pos[p, 0]
        cy = pos[p, 1]
        cz = pos[p, 2] if dim == 3 else 0.5 * hz
        r = radii[p]
        r2 = r * r
        lab = species[p] + 1
        i0 = int(math.floor((cx - r) / hx - 0.5))
        i1 = int(math.ceil((cx + r) / hx - 0.5))
        j0 = int(math.floor((cy - r) / hy - 0.5))
        j1 = int(math.ceil((cy + r) / hy - 0.5))
        if dim == 3:
            k0 = int(math.floor((cz - r) / hz - 0.5))
            k1 = int(math.ceil((cz + r) / hz - 0.5))
        else:
            k0 = 0
            k1 = 0
        for i in range(i0, i1 + 1):
            ii = i
            if ii < 0 or ii >= nx:
                if periodic[0] == 0:
                    continue
                ii = ii % nx
            dx = (i + 0.5) * hx - cx
            for j in range(j0, j1 + 1):
                jj = j
                if jj < 0 or jj >= ny:
                    if periodic[1] == 0:
                        continue
                    jj = jj % ny
                dy = (j + 0.5) * hy - cy
                for k in range(k0, k1 + 1):
                    kk = k
                    if kk < 0 or kk >= nz:
                        if periodic[2] == 0:
                            continue
                        kk = kk % nz
                    dz = (k + 0.5) * hz - cz if dim == 3 else 0.0
                    d2 = dx * dx + dy * dy + dz * dz
                    idx = (ii * ny + jj) * nz + kk
                    if d2 < r2:
                        if labels[idx] != 0:
                            clashes += 1
                        labels[idx] = lab
                    if s <= 0:
                        continue
                    d = math.sqrt(d2)
                    if d + half_diag <= r:
                        fraction[idx] += 1.0
                    elif d - half_diag < r:
                        inside = 0
                        total = 0
                        for a in range(s):
                            sx = dx + ((a + 0.5) / s - 0.5) * hx
                            for b in range(s):
                                sy = dy + ((b + 0.5) / s - 0.5) * hy
                                if dim == 2:
                                    total += 1
                                    if sx * sx + sy * sy < r2:
                                        inside += 1
                                    continue
                                for c in range(s):
                                    sz = dz + ((c + 0.5) / s - 0.5) * hz
                                    total += 1
                                    if sx * sx + sy * sy + sz * sz < r2:
                                        inside += 1
                        fraction[idx] += inside / total
    return clashes


def warmup():
    """Compile the kernel on a tiny input (the argument types of the real calls)."""
    pos = np.array([[0.5, 0.5, 0.5], [1.5, 1.5, 1.5]])
    rad = np.array([0.4, 0.3])
    sp = np.array([0, 1], np.int64)
    n = np.array([4, 4, 4], np.int64)
    h = np.array([0.5, 0.5, 0.5])
    per = np.array([1, 1, 1], np.int64)
    lab = np.zeros(64, np.int32)
    fr = np.zeros(64)
    voxelize_spheres(pos, rad, sp, 3, n, h, per, 2, lab, fr)
