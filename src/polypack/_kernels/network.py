"""Bond-network kernels: adjacency, recursive rattler removal, bond angles, stiffness assembly.

Flat arrays in, flat arrays out. Bond ``c`` joins particles ``bi[c]`` and ``bj[c]``;
``normal[c]`` is the unit vector from ``bi[c]`` to (the image of) ``bj[c]``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .csr import pair_offsets


@njit(cache=True)
def adjacency(n, bi, bj):
    """CSR incidence of bond ends per particle.

    Returns ``(offsets, bond, sign)``: the ends of particle ``p`` are the entries
    ``offsets[p]:offsets[p + 1]``; ``bond`` is the bond index and ``sign`` is +1 for the
    ``i`` end (normal points away from ``p``) and -1 for the ``j`` end.
    """
    m = bi.shape[0]
    offsets, fill = pair_offsets(n, bi, bj)
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


@njit(cache=True)
def _cross_matrix(a, out):
    """``out = [a]_x`` with ``[a]_x v = a x v``."""
    out[0, 0] = 0.0
    out[0, 1] = -a[2]
    out[0, 2] = a[1]
    out[1, 0] = a[2]
    out[1, 1] = 0.0
    out[1, 2] = -a[0]
    out[2, 0] = -a[1]
    out[2, 1] = a[0]
    out[2, 2] = 0.0


@njit(cache=True)
def assemble(n, bi, bj, kn, ks, normal, branch, arm_i, arm_j, ell, rotations):
    """Blocks of the linear-response problem of a 3D bonded network.

    Degrees of freedom per particle: translation ``u`` (3) and, when ``rotations``,
    the rotation ``w = ell * theta`` (3, scaled to length units so both halves of a
    block have the same scale). The relative displacement of the contact point of
    bond ``c`` is ``delta = B_i q_i + B_j q_j + A eps`` with
    ``B_i = [-I, [a_i]_x / ell]``, ``B_j = [I, -[a_j]_x / ell]`` (``a`` the lever
    arms from each centre to the contact point) and ``A eps = eps b`` for the Voigt
    strain ``eps`` with engineering shears; the spring matrix is
    ``K = kn n n^T + ks (I - n n^T)``.

    Returns
    -------
    diag : (n, nd, nd)
        Diagonal blocks ``sum B_p^T K B_p`` of the Hessian.
    off : (m, nd, nd)
        Block ``B_i^T K B_j`` of each bond (row ``bi``, column ``bj``); its transpose is
        the ``(bj, bi)`` block.
    rhs : (n, nd, 6)
        ``sum B_p^T K A``: the force (per unit strain) that the affine deformation
        leaves on each degree of freedom.
    caff : (6, 6)
        ``sum A^T K A`` (times the volume, the affine stiffness).
    """
    m = bi.shape[0]
    nd = 6 if rotations else 3
    diag = np.zeros((n, nd, nd))
    off = np.zeros((m, nd, nd))
    rhs = np.zeros((n, nd, 6))
    caff = np.zeros((6, 6))
    K = np.empty((3, 3))
    A = np.zeros((3, 6))
    Bi = np.zeros((3, nd))
    Bj = np.zeros((3, nd))
    X = np.empty((3, 3))
    KBi = np.empty((3, nd))
    KBj = np.empty((3, nd))
    KA = np.empty((3, 6))
    for c in range(m):
        for r in range(3):
            for s in range(3):
                K[r, s] = (kn[c] - ks[c]) * normal[c, r] * normal[c, s]
            K[r, r] += ks[c]
        b0 = branch[c, 0]
        b1 = branch[c, 1]
        b2 = branch[c, 2]
        A[0, 0] = b0
        A[0, 4] = 0.5 * b2
        A[0, 5] = 0.5 * b1
        A[1, 1] = b1
        A[1, 3] = 0.5 * b2
        A[1, 5] = 0.5 * b0
        A[2, 2] = b2
        A[2, 3] = 0.5 * b1
        A[2, 4] = 0.5 * b0
        for r in range(3):
            for s in range(3):
                Bi[r, s] = -1.0 if r == s else 0.0
                Bj[r, s] = 1.0 if r == s else 0.0
        if rotations:
            _cross_matrix(arm_i[c], X)
            for r in range(3):
                for s in range(3):
                    Bi[r, 3 + s] = X[r, s] / ell
            _cross_matrix(arm_j[c], X)
            for r in range(3):
                for s in range(3):
                    Bj[r, 3 + s] = -X[r, s] / ell
        for r in range(3):
            for s in range(nd):
                ti = 0.0
                tj = 0.0
                for t in range(3):
                    ti += K[r, t] * Bi[t, s]
                    tj += K[r, t] * Bj[t, s]
                KBi[r, s] = ti
                KBj[r, s] = tj
            for s in range(6):
                ta = 0.0
                for t in range(3):
                    ta += K[r, t] * A[t, s]
                KA[r, s] = ta
        p = bi[c]
        q = bj[c]
        for r in range(nd):
            for s in range(nd):
                dii = 0.0
                djj = 0.0
                dij = 0.0
                for t in range(3):
                    dii += Bi[t, r] * KBi[t, s]
                    djj += Bj[t, r] * KBj[t, s]
                    dij += Bi[t, r] * KBj[t, s]
                diag[p, r, s] += dii
                diag[q, r, s] += djj
                off[c, r, s] = dij
            for s in range(6):
                fi = 0.0
                fj = 0.0
                for t in range(3):
                    fi += Bi[t, r] * KA[t, s]
                    fj += Bj[t, r] * KA[t, s]
                rhs[p, r, s] += fi
                rhs[q, r, s] += fj
        for r in range(6):
            for s in range(6):
                v = 0.0
                for t in range(3):
                    v += A[t, r] * KA[t, s]
                caff[r, s] += v
    return diag, off, rhs, caff


@njit(cache=True)
def bond_stress(bi, bj, kn, ks, normal, branch, arm_i, arm_j, ell, rotations, q, eps):
    """Sum over bonds of ``f b^T`` (3x3) for nodal displacements ``q`` (n, nd) and Voigt strain ``eps``.

    ``f = K delta`` is the force that particle ``j`` exerts on ``i`` (tension positive).
    """
    m = bi.shape[0]
    out = np.zeros((3, 3))
    d = np.empty(3)
    e = np.empty((3, 3))
    e[0, 0] = eps[0]
    e[1, 1] = eps[1]
    e[2, 2] = eps[2]
    e[1, 2] = e[2, 1] = 0.5 * eps[3]
    e[0, 2] = e[2, 0] = 0.5 * eps[4]
    e[0, 1] = e[1, 0] = 0.5 * eps[5]
    for c in range(m):
        p = bi[c]
        s = bj[c]
        for r in range(3):
            d[r] = q[s, r] - q[p, r]
            for t in range(3):
                d[r] += e[r, t] * branch[c, t]
        if rotations:
            # theta x a = -a x theta; theta = w / ell
            ti = q[p, 3:6] / ell
            tj = q[s, 3:6] / ell
            ai = arm_i[c]
            aj = arm_j[c]
            d[0] += (tj[1] * aj[2] - tj[2] * aj[1]) - (ti[1] * ai[2] - ti[2] * ai[1])
            d[1] += (tj[2] * aj[0] - tj[0] * aj[2]) - (ti[2] * ai[0] - ti[0] * ai[2])
            d[2] += (tj[0] * aj[1] - tj[1] * aj[0]) - (ti[0] * ai[1] - ti[1] * ai[0])
        dn = d[0] * normal[c, 0] + d[1] * normal[c, 1] + d[2] * normal[c, 2]
        for r in range(3):
            f = ks[c] * d[r] + (kn[c] - ks[c]) * dn * normal[c, r]
            for t in range(3):
                out[r, t] += f * branch[c, t]
    return out


@njit(cache=True)
def relaxed_gram(bi, bj, kn, ks, normal, branch, arm_i, arm_j, ell, rotations, q, cols):
    """Gram matrix ``G[a, b] = sum_c delta_a^T K_c delta_b`` of relaxed bond deformations.

    ``q`` (n, nd, k): one nodal field per column (translations, then ``w = ell * theta``
    as in :func:`assemble`); column ``a`` is the response to the unit Voigt strain
    ``cols[a]`` (engineering shears), so ``delta_a = B_i q_ia + B_j q_ja + A e_cols[a]``.
    ``G / V`` is the relaxed stiffness, a sum of non-negative bond energies with no
    cancelling terms (twice the elastic energy of the fields on the diagonal).
    """
    m = bi.shape[0]
    k = q.shape[2]
    g = np.zeros((k, k))
    d = np.empty((3, k))
    f = np.empty((3, k))
    for c in range(m):
        p = bi[c]
        s = bj[c]
        ai = arm_i[c]
        aj = arm_j[c]
        for a in range(k):
            for r in range(3):
                d[r, a] = q[s, r, a] - q[p, r, a]
            if rotations:
                ti0 = q[p, 3, a] / ell
                ti1 = q[p, 4, a] / ell
                ti2 = q[p, 5, a] / ell
                tj0 = q[s, 3, a] / ell
                tj1 = q[s, 4, a] / ell
                tj2 = q[s, 5, a] / ell
                d[0, a] += (tj1 * aj[2] - tj2 * aj[1]) - (ti1 * ai[2] - ti2 * ai[1])
                d[1, a] += (tj2 * aj[0] - tj0 * aj[2]) - (ti2 * ai[0] - ti0 * ai[2])
                d[2, a] += (tj0 * aj[1] - tj1 * aj[0]) - (ti0 * ai[1] - ti1 * ai[0])
            v = cols[a]
            if v < 3:
                d[v, a] += branch[c, v]
            else:
                # engineering shear gamma: e_pr = e_rp = gamma / 2
                pp = 1 if v == 3 else 0
                rr = 1 if v == 5 else 2
                d[pp, a] += 0.5 * branch[c, rr]
                d[rr, a] += 0.5 * branch[c, pp]
            dn = d[0, a] * normal[c, 0] + d[1, a] * normal[c, 1] + d[2, a] * normal[c, 2]
            for r in range(3):
                f[r, a] = ks[c] * d[r, a] + (kn[c] - ks[c]) * dn * normal[c, r]
        for a in range(k):
            for b in range(a, k):
                v = d[0, a] * f[0, b] + d[1, a] * f[1, b] + d[2, a] * f[2, b]
                g[a, b] += v
                if b != a:
                    g[b, a] += v
    return g


def warmup():
    """Compile the kernels of this module on a tiny input."""
    bi = np.array([0, 1, 2], np.int64)
    bj = np.array([1, 2, 0], np.int64)
    nrm = np.eye(3)
    live = np.ones(3, np.int64)
    peel(3, bi, bj, live, 2)
    bond_angle_cosines(3, bi, bj, nrm)
    components(3, bi, bj, np.zeros((3, 3), np.int64), live)
    k = np.ones(3)
    for rot in (True, False):
        assemble(3, bi, bj, k, k, nrm, nrm, 0.5 * nrm, -0.5 * nrm, 0.5, rot)
        bond_stress(bi, bj, k, k, nrm, nrm, 0.5 * nrm, -0.5 * nrm, 0.5, rot, np.zeros((3, 6 if rot else 3)), np.ones(6))
        relaxed_gram(bi, bj, k, k, nrm, nrm, 0.5 * nrm, -0.5 * nrm, 0.5, rot, np.zeros((3, 6 if rot else 3, 6)),
                     np.arange(6, dtype=np.int64))
