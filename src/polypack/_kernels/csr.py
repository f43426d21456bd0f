"""Compressed sparse row (CSR) adjacency, built once for every kernel that needs one.

The pair ends of ``m`` pairs ``(a[q], b[q])`` are grouped by particle: particle ``p``
owns the slots ``offsets[p]:offsets[p + 1]``, one per end at ``p``. Used by the bond
incidence of :func:`polypack._kernels.network.adjacency` (and through it by the
component and rigidity walks) and by the Verlet list of
:func:`polypack._kernels.shake.build_list`.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def pair_offsets(n, a, b):
    """CSR offsets of the ends of the pairs ``(a[q], b[q])`` over ``n`` particles.

    Returns ``(offsets, fill)``: ``offsets`` of length ``n + 1`` (each pair counts once at
    ``a[q]`` and once at ``b[q]``) and ``fill = offsets[:-1].copy()``, the next free slot of
    each particle, which the caller advances as it writes the ends in pair order.
    """
    m = a.shape[0]
    offsets = np.zeros(n + 1, np.int64)
    for q in range(m):
        offsets[a[q] + 1] += 1
        offsets[b[q] + 1] += 1
    for p in range(n):
        offsets[p + 1] += offsets[p]
    return offsets, offsets[:-1].copy()


def warmup():
    """Compile the kernel of this module on a tiny input."""
    pair_offsets(3, np.array([0, 1], np.int64), np.array([1, 2], np.int64))
