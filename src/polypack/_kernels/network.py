"""Bond-network kernels: adjacency, recursive rattler removal, bond angles, stiffness assembly.

Flat arrays in, flat arrays out. Bond ``c`` joins particles ``bi[c]`` and ``bj[c]``;
``normal[c]`` is the unit vector from ``bi[c]`` to (the image of) ``bj[c]``.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def adjacency(n, bi, bj):
    """CSR incidence of bond ends per particle.

    Returns ``(offsets, bond, sign)``: the ends of particle ``p`` are the entries
    ``offsets[p]:offsets[p + 1]``; ``bond`` is the bond index and ``sign`` is +1 for the
    ``i`` end (normal points away from ``p``) and -1 for the ``j`` end.
    """
    m = bi.shape[0]
    offsets = np.zeros(n + 1, np.int64)
    for c in range(m):
        offsets[bi[c] + 1] += 1
        offsets[bj[c] + 1] += 1
    for p in range(n):
        offsets[p + 1] += offsets[p]
    fill = offsets[:-1].copy()
    bond = np.empty(2 * m, np.int64)
    sign = np.empty(2 * m, np.int64)
    for c in range(m):
        p = bi[c]
        bond[fill[p]] = c
        sign[fill[p]] = 1
        fill[p] += 1
        p = bj[c]
        bond[fill[p]] = c
        sign[fill[p]] = -1
        fill[p] += 1
    return offsets, bond, sign


@njit(cache=True)
def peel(n, bi, bj, live_bond, min_bonds):
    """Recursively remove particles with fewer than ``min_bonds`` live bonds.

    ``live_bond`` (int64, 1 = bond counts) is not modified. Returns an int64 array,
    1 for a removed particle (rattler) and 0 otherwise. A queue makes it O(N + M).
    """
    offsets, bond, sign = adjacency(n, bi, bj)
    deg = np.zeros(n, np.int64)
    for c in range(bi.shape[0]):
        if live_bond[c]:
            deg[bi[c]] += 1
            deg[bj[c]] += 1
    removed = np.zeros(n, np.int64)
    queue = np.empty(n, np.int64)
    head = 0
    tail = 0
    for p in range(n):
        if deg[p] < min_bonds:
            removed[p] = 1
            queue[tail] = p
            tail += 1
    while head < tail:
        p = queue[head]
        head += 1
        for e in range(offsets[p], offsets[p + 1]):
            c = bond[e]
            if not live_bond[c]:
                continue
            q = bj[c] if sign[e] == 1 else bi[c]
            if removed[q] or q == p:
                continue
            deg[q] -= 1
            if deg[q] < min_bonds:
                removed[q] = 1
                queue[tail] = q
                tail += 1
    return removed


@njit(cache=True)
def bond_angle_cosines(n, bi, bj, normal):
    """Cosines of the angles between every two bonds that share a particle.

    Each unordered pair of bond ends at a particle counts once; the bond direction
    at particle ``p`` points from ``p`` to its partner.
    """
    offsets, bond, sign = adjacency(n, bi, bj)
    dim = normal.shape[1]
    total = 0
    for p in range(n):
        k = offsets[p + 1] - offsets[p]
        total += k * (k - 1) // 2
    out = np.empty(total, np.float64)
    w = 0
    for p in range(n):
        for e in range(offsets[p], offsets[p + 1]):
            for f in range(e + 1, offsets[p + 1]):
                s = 0.0
                for d in range(dim):
                    s += normal[bond[e], d] * normal[bond[f], d]
                s *= sign[e] * sign[f]
                if s > 1.0:
                    s = 1.0
                elif s < -1.0:
                    s = -1.0
                out[w] = s
                w += 1
    return out


@njit(cache=True)
def components(n, bi, bj, shift, live_bond):
    """Connected components and whether each one wraps the periodic box.

    Walks each component, giving every particle an integer image offset so that bond
    ends agree (``img[j] = img[i] + shift``). A bond whose ends disagree closes a loop
    around the box: the component spans it along the axes where they differ.

    Returns ``(label, n_comp, spans)``: a component label per particle (-1 for a
    particle without live bonds), the number of components, and ``spans`` of shape
    ``(n_comp, dim)``, 1 where the component wraps that axis.
    """
    dim = shift.shape[1]
    offsets, bond, sign = adjacency(n, bi, bj)
    label = np.full(n, -1, np.int64)
    img = np.zeros((n, dim), np.int64)
    spans = np.zeros((n, dim), np.int64)
    stack = np.empty(n, np.int64)
    n_comp = 0
    for s in range(n):
        if label[s] >= 0:
            continue
        has = False
        for e in range(offsets[s], offsets[s + 1]):
            if live_bond[bond[e]]:
                has = True
                break
        if not has:
            continue
        label[s] = n_comp
        top = 0
        stack[top] = s
        top += 1
        while top > 0:
            top -= 1
            p = stack[top]
            for e in range(offsets[p], offsets[p + 1]):
                c = bond[e]
                if not live_bond[c]:
                    continue
                if sign[e] == 1:
                    q = bj[c]
                else:
                    q = bi[c]
                if label[q] < 0:
                    label[q] = n_comp
                    for d in range(dim):
                        img[q, d] = img[p, d] + sign[e] * shift[c, d]
                    stack[top] = q
                    top += 1
                else:
                    for d in range(dim):
                        if img[q, d] != img[p, d] + sign[e] * shift[c, d]:
                            spans[n_comp, d] = 1
        n_comp += 1
    return label, n_comp, spans[:n_comp].copy()


def warmup():
    """Compile the kernels of this module on a tiny input."""
    bi = np.array([0, 1, 2], np.int64)
    bj = np.array([1, 2, 0], np.int64)
    nrm = np.eye(3)
    live = np.ones(3, np.int64)
    peel(3, bi, bj, live, 2)
    bond_angle_cosines(3, bi, bj, nrm)
    components(3, bi, bj, np.zeros((3, 3), np.int64), live)
