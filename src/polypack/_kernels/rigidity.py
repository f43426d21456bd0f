"""Rigidity kernels: periodic unwrapping of bonded clusters and rigid clusters of central-force networks.

Flat arrays in, flat arrays out. Bond ``c`` joins particles ``bi[c]`` and ``bj[c]``;
``branch[c]`` is the vector from ``bi[c]`` to the image ``shift[c]`` of ``bj[c]``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .network import adjacency


@njit(cache=True)
def unwrap_images(n, bi, bj, shift, live_bond):
    """Integer periodic image of every particle that makes the live bonds of its cluster agree.

    A breadth-first walk from the lowest particle of each cluster sets
    ``img[q] = img[p] + sign * shift[c]`` across every live bond ``c``; the unwrapped
    position is ``x + img * box``. Where a cluster wraps the box the walk's tree decides
    (bonds that close a loop through the boundary disagree). Particles without live
    bonds keep image 0.
    """
    dim = shift.shape[1]
    offsets, bond, sign = adjacency(n, bi, bj)
    seen = np.zeros(n, np.int64)
    img = np.zeros((n, dim), np.int64)
    queue = np.empty(n, np.int64)
    for s in range(n):
        if seen[s]:
            continue
        seen[s] = 1
        head = 0
        tail = 0
        queue[tail] = s
        tail += 1
        while head < tail:
            p = queue[head]
            head += 1
            for e in range(offsets[p], offsets[p + 1]):
                c = bond[e]
                if not live_bond[c]:
                    continue
                q = bj[c] if sign[e] == 1 else bi[c]
                if seen[q]:
                    continue
                seen[q] = 1
                for d in range(dim):
                    img[q, d] = img[p, d] + sign[e] * shift[c, d]
                queue[tail] = q
                tail += 1
    return img


@njit(cache=True)
def _find(parent, a):
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


@njit(cache=True)
def central_triangles(n, bi, bj, branch, live_bond, z, amp, tol):
    """Rigid triangles of a central-force (bar-joint) network and their rigid-body clusters.

    Two live, non-collinear bonds ``p-i`` and ``p-k`` at particle ``p`` span a rigid
    triangle when, in every sampled zero mode ``z[s]`` ((S, n, 3) displacements), the
    distance ``|r_i - r_k|`` is kept: ``(r_i - r_k) . (v_i - v_k) = 0`` with
    ``v = u - u_p``, the defect taken relative to ``amp[s]`` and compared with ``tol``.
    Its infinitesimal rotation ``omega`` (``v_i = omega x r_i``, ``v_k = omega x r_k``,
    least squares) is kept per sample. Two rigid triangles that share a bond are one
    rigid body when their rotations agree (``|omega - omega'| L <= tol amp``, ``L`` the
    mean bond length): triangles that share only a bond may hinge about it.

    Returns ``(tri_bonds, tri_label, k)``: the two bonds of every rigid triangle
    ((T, 2)), the rigid-body label of each triangle (0 .. k-1) and k.
    """
    m = bi.shape[0]
    ns = z.shape[0]
    offsets, bond, sign = adjacency(n, bi, bj)
    total = 0
    for p in range(n):
        k = offsets[p + 1] - offsets[p]
        total += k * (k - 1) // 2
    tb = np.empty((total, 2), np.int64)
    om = np.empty((total, ns, 3))
    nt = 0
    ri = np.empty(3)
    rk = np.empty(3)
    a = np.empty((3, 3))
    rhs = np.empty(3)
    lbar = 0.0
    for c in range(m):
        lbar += np.sqrt(branch[c, 0] ** 2 + branch[c, 1] ** 2 + branch[c, 2] ** 2)
    lbar /= max(m, 1)
    for p in range(n):
        for e in range(offsets[p], offsets[p + 1]):
            ce = bond[e]
            if not live_bond[ce]:
                continue
            qi = bj[ce] if sign[e] == 1 else bi[ce]
            for d in range(3):
                ri[d] = sign[e] * branch[ce, d]
            for f in range(e + 1, offsets[p + 1]):
                cf = bond[f]
                if not live_bond[cf]:
                    continue
                qk = bj[cf] if sign[f] == 1 else bi[cf]
                for d in range(3):
                    rk[d] = sign[f] * branch[cf, d]
                li = np.sqrt(ri[0] ** 2 + ri[1] ** 2 + ri[2] ** 2)
                lk = np.sqrt(rk[0] ** 2 + rk[1] ** 2 + rk[2] ** 2)
                cx = ri[1] * rk[2] - ri[2] * rk[1]
                cy = ri[2] * rk[0] - ri[0] * rk[2]
                cz = ri[0] * rk[1] - ri[1] * rk[0]
                if np.sqrt(cx * cx + cy * cy + cz * cz) <= 1e-6 * li * lk:
                    continue
                dik = np.sqrt((ri[0] - rk[0]) ** 2 + (ri[1] - rk[1]) ** 2 + (ri[2] - rk[2]) ** 2)
                rigid = True
                for s in range(ns):
                    dot = 0.0
                    for d in range(3):
                        dot += (ri[d] - rk[d]) * ((z[s, qi, d] - z[s, p, d]) - (z[s, qk, d] - z[s, p, d]))
                    if abs(dot) / dik > tol * amp[s]:
                        rigid = False
                        break
                if not rigid:
                    continue
                # omega from v = omega x r = -[r]_x omega: normal equations sum [r]_x^T [r]_x omega = -sum [r]_x^T v
                for s in range(ns):
                    for r in range(3):
                        rhs[r] = 0.0
                        for t in range(3):
                            a[r, t] = 0.0
                    for which in range(2):
                        q = qi if which == 0 else qk
                        rr = ri if which == 0 else rk
                        r2 = rr[0] ** 2 + rr[1] ** 2 + rr[2] ** 2
                        v0 = z[s, q, 0] - z[s, p, 0]
                        v1 = z[s, q, 1] - z[s, p, 1]
                        v2 = z[s, q, 2] - z[s, p, 2]
                        # [r]_x^T [r]_x = |r|^2 I - r r^T ; [r]_x^T v = v x r
                        for r in range(3):
                            for t in range(3):
                                a[r, t] -= rr[r] * rr[t]
                            a[r, r] += r2
                        rhs[0] += v1 * rr[2] - v2 * rr[1]
                        rhs[1] += v2 * rr[0] - v0 * rr[2]
                        rhs[2] += v0 * rr[1] - v1 * rr[0]
                    w = np.linalg.solve(a, rhs)
                    for d in range(3):
                        om[nt, s, d] = w[d]
                tb[nt, 0] = ce
                tb[nt, 1] = cf
                nt += 1
    # union-find over triangles: every two that share a bond and turn alike
    parent = np.arange(nt)
    cnt = np.zeros(m + 1, np.int64)
    for t in range(nt):
        cnt[tb[t, 0] + 1] += 1
        cnt[tb[t, 1] + 1] += 1
    for c in range(m):
        cnt[c + 1] += cnt[c]
    fill = cnt[:-1].copy()
    tri = np.empty(2 * nt, np.int64)
    for t in range(nt):
        for side in range(2):
            c = tb[t, side]
            tri[fill[c]] = t
            fill[c] += 1
    for c in range(m):
        for x0 in range(cnt[c], cnt[c + 1]):
            for y0 in range(x0 + 1, cnt[c + 1]):
                t = tri[x0]
                o = tri[y0]
                if _find(parent, t) == _find(parent, o):
                    continue
                same = True
                for s in range(ns):
                    dd = 0.0
                    for d in range(3):
                        dd += (om[t, s, d] - om[o, s, d]) ** 2
                    if np.sqrt(dd) * lbar > tol * amp[s]:
                        same = False
                        break
                if same:
                    x = _find(parent, t)
                    y = _find(parent, o)
                    if x != y:
                        parent[x] = y
    label = np.empty(nt, np.int64)
    root_label = np.full(nt, -1, np.int64)
    k = 0
    for t in range(nt):
        r = _find(parent, t)
        if root_label[r] < 0:
            root_label[r] = k
            k += 1
        label[t] = root_label[r]
    return tb[:nt].copy(), label, k


def warmup():
    """Compile the kernels of this module on a tiny input."""
    bi = np.array([0, 1, 2], np.int64)
    bj = np.array([1, 2, 0], np.int64)
    live = np.ones(3, np.int64)
    br = np.array([[1.0, 0.0, 0.0], [-0.5, 0.8, 0.0], [-0.5, -0.8, 0.0]])
    unwrap_images(3, bi, bj, np.zeros((3, 3), np.int64), live)
    central_triangles(3, bi, bj, br, live, np.zeros((2, 3, 3)), np.ones(2), 1e-6)
