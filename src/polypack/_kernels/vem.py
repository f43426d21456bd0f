"""Kernels of the void expansion method (§2.2 of 003_873b69fc71c74cf6.txt).

The damped soft-contact dynamics of the expansion itself is the discrete-element engine
:func:`polypack._kernels.dem.run` (forces from :mod:`polypack._kernels.contacts`); this
module adds what the generator needs around it, flat arrays in and out:

* :func:`classify` - per-contact counts of the expansion's monitors (structure-structure
  contacts carrying force, void contacts, overlaps);
* :func:`separate` - the final rigidisation of the structure: symmetric Gauss-Seidel
  projections along the line of centres (Heyes & Melrose 1993) that remove every residual
  overlap of a candidate pair list, so that the returned structure spheres are hard.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .cells import min_image

#: Slots of the output of :func:`classify`.
C_STRUCT_CONTACTS = 0  # structure-structure pairs with overlap > 0
C_VOID_CONTACTS = 1  # pairs involving a void with overlap > 0
C_STRUCT_OVERLAP_SUM = 2  # sum of relative overlaps (r_i + r_j - d) / (r_i + r_j), structure pairs
C_STRUCT_OVERLAP_MAX = 3
C_VOID_OVERLAP_SUM = 4
C_VOID_OVERLAP_MAX = 5
N_C = 6

#: Status of :func:`separate`.
SEPARATE_DONE = 0
SEPARATE_SWEEPS = 1  # sweep budget used up with overlaps left


@njit(cache=True)
def classify(pos, radii, h, ci, cj, cshift, n_struct, out):
    """Count the overlapping contacts of a contact list (geometry only).

    Spheres ``0 .. n_struct - 1`` are structure spheres, the others voids.  ``out``
    (length ``N_C``) receives the slots ``C_*``.
    """
    for q in range(N_C):
        out[q] = 0.0
    m = ci.shape[0]
    for c in range(m):
        i = ci[c]
        j = cj[c]
        bx = pos[j, 0] - pos[i, 0] + h[0, 0] * cshift[c, 0]
        by = pos[j, 1] - pos[i, 1] + h[1, 1] * cshift[c, 1]
        bz = pos[j, 2] - pos[i, 2] + h[2, 2] * cshift[c, 2]
        d = np.sqrt(bx * bx + by * by + bz * bz)
        s = radii[i] + radii[j]
        if d >= s:
            continue
        ov = (s - d) / s
        if i < n_struct and j < n_struct:
            out[C_STRUCT_CONTACTS] += 1.0
            out[C_STRUCT_OVERLAP_SUM] += ov
            if ov > out[C_STRUCT_OVERLAP_MAX]:
                out[C_STRUCT_OVERLAP_MAX] = ov
        else:
            out[C_VOID_CONTACTS] += 1.0
            out[C_VOID_OVERLAP_SUM] += ov
            if ov > out[C_VOID_OVERLAP_MAX]:
                out[C_VOID_OVERLAP_MAX] = ov


@njit(cache=True)
def separate(pos, radii, box, pi, pj, target, max_sweeps):
    """Remove the overlaps of the candidate pairs ``(pi, pj)`` by projections.

    Every sweep visits the pairs in order; a pair closer than ``target (r_i + r_j)``
    (minimum image in the periodic ``box``) is pushed apart symmetrically along its line
    of centres to exactly that distance.  Sweeps repeat until one finds no pair closer
    than ``r_i + r_j`` (no overlap at all) or ``max_sweeps`` are done.  ``pos`` is
    updated in place.

    Returns
    -------
    status : int
        ``SEPARATE_DONE`` or ``SEPARATE_SWEEPS``.
    sweeps : int
        Sweeps done.
    worst : float
        Largest relative overlap ``1 - d / (r_i + r_j)`` seen in the first sweep.
    """
    m = pi.shape[0]
    first = 0.0
    for sweep in range(max_sweeps):
        worst = 0.0
        for c in range(m):
            i = pi[c]
            j = pj[c]
            dx = min_image(pos[j, 0] - pos[i, 0], box[0])
            dy = min_image(pos[j, 1] - pos[i, 1], box[1])
            dz = min_image(pos[j, 2] - pos[i, 2], box[2])
            d = np.sqrt(dx * dx + dy * dy + dz * dz)
            s = radii[i] + radii[j]
            lim = target * s
            if d < lim:
                if d < s:
                    ov = 1.0 - d / s
                    if ov > worst:
                        worst = ov
                if d > 0.0:
                    corr = 0.5 * (lim - d) / d
                    pos[i, 0] -= corr * dx
                    pos[i, 1] -= corr * dy
                    pos[i, 2] -= corr * dz
                    pos[j, 0] += corr * dx
                    pos[j, 1] += corr * dy
                    pos[j, 2] += corr * dz
                else:  # coincident centres: separate along x
                    pos[i, 0] -= 0.5 * lim
                    pos[j, 0] += 0.5 * lim
        if sweep == 0:
            first = worst
        if worst == 0.0:
            return SEPARATE_DONE, sweep + 1, first
    return SEPARATE_SWEEPS, max_sweeps, first


def warmup():
    """Compile the kernels of this module on a tiny input."""
    pos = np.array([[1.0, 1.0, 1.0], [2.9, 1.0, 1.0], [1.0, 2.5, 1.0]])
    radii = np.ones(3)
    box = np.full(3, 10.0)
    pi = np.array([0, 0], np.int64)
    pj = np.array([1, 2], np.int64)
    out = np.zeros(N_C)
    classify(pos, radii, np.diag(box), pi, pj, np.zeros((2, 3)), 2, out)
    separate(pos.copy(), radii, box, pi, pj, 1.0 + 1e-10, 10)
