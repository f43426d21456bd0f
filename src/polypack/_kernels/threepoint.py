"""numba kernel of :class:`polypack.analysis.ThreePointParameters` (ζ2, η2 of sphere packs).

For a point ``x`` inside sphere ``i`` the angular kernels ``P_l(r̂·ŝ)/(r³ s³)`` of the
three-point integrals factor through the addition theorem into squares of the
"fields" ``S_lm(x) = Σ_j v_j f_l(D_j) Y_lm(D̂_j) / D_j³`` (``D_j = r_j − x``; exterior
field of a uniform ball: ``f_2 = 1``, ``f_4 = 1 − 7 a_j² / (5 D_j²)``). The kernel
integrates ``Σ_{j,k} w_j w_k P_l`` over every ball: the diagonal ``j = k`` terms in
closed form, the cross terms by a product Gauss rule on the ball; the smooth field of
distant neighbours is sampled on coarse nodes and interpolated.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .cells import build_cells, cell_lengths, cells_in_reach, min_image

# output slots per sphere
OUT_J2 = 0
OUT_J4 = 1
OUT_NEIGHBOURS = 2
N_OUT = 3


@njit(cache=True)
def ball_inverse_power(a, d, m):
    """``∫_{|x|<a} |x − d|^(−2m) dx`` for a point at distance ``d > a`` (``m >= 3``).

    Shells of radius ρ average ``|x − d|^(−2m)`` to
    ``[(d−ρ)^(2−2m) − (d+ρ)^(2−2m)] / (4 ρ d (m−1))``; the ρ-integral is closed form.
    """
    k = 2 * m - 2
    f = _shell_antiderivative(d + a, d, k) - _shell_antiderivative(d - a, d, k)
    return np.pi * f / (d * (m - 1))


@njit(cache=True)
def _shell_antiderivative(t, d, k):
    """``d t^(1−k)/(1−k) − t^(2−k)/(2−k)``, the primitive behind :func:`ball_inverse_power`."""
    return d * t ** (1 - k) / (1 - k) - t ** (2 - k) / (2 - k)


@njit(cache=True)
def _basis(ux, uy, uz, b2, b4):
    """Unnormalised real spherical harmonics of degree 2 (5) and 4 (9) at a unit vector."""
    x2 = ux * ux
    y2 = uy * uy
    z2 = uz * uz
    b2[0] = ux * uy
    b2[1] = uy * uz
    b2[2] = ux * uz
    b2[3] = x2 - y2
    b2[4] = 3.0 * z2 - 1.0
    b4[0] = ux * uy * (x2 - y2)
    b4[1] = uy * uz * (3.0 * x2 - y2)
    b4[2] = ux * uy * (7.0 * z2 - 1.0)
    b4[3] = uy * uz * (7.0 * z2 - 3.0)
    b4[4] = 35.0 * z2 * z2 - 30.0 * z2 + 3.0
    b4[5] = ux * uz * (7.0 * z2 - 3.0)
    b4[6] = (x2 - y2) * (7.0 * z2 - 1.0)
    b4[7] = ux * uz * (x2 - 3.0 * y2)
    b4[8] = x2 * x2 - 6.0 * x2 * y2 + y2 * y2


@njit(cache=True)
def _accumulate(dxt, dyt, dzt, volt, asqt, xq, yq, zq, s2, s4, b2, b4):
    """Add one neighbour's l = 2, 4 fields at a point; returns their squared weights."""
    ex = dxt - xq
    ey = dyt - yq
    ez = dzt - zq
    r2 = ex * ex + ey * ey + ez * ez
    ir = 1.0 / np.sqrt(r2)
    w2 = volt * ir * ir * ir
    w4 = w2 * (1.0 - 1.4 * asqt / r2)
    _basis(ex * ir, ey * ir, ez * ir, b2, b4)
    for k in range(5):
        s2[k] += w2 * b2[k]
    for k in range(9):
        s4[k] += w4 * b4[k]
    return w2 * w2, w4 * w4


@njit(cache=True)
def three_point_sums(pos, radii, box, cutoff, near_factor, ncell, qpts, qw, cpts, interp, inv2, inv4):
    """Per-sphere integrals ``∫_{B_i} Σ_{j,k≠i} w_j w_k P_l(D̂_j·D̂_k) dx`` for l = 2, 4.

    Near neighbours (centre distance ``< near_factor a_i``) are evaluated at every fine
    node; the field of the far ones is smooth on the ball, so it is evaluated at the
    coarse nodes and carried to the fine nodes by the least-squares polynomial
    interpolation matrix ``interp``.

    Parameters
    ----------
    pos : (N, 3) float64
    radii : (N,) float64
    box : (3,) float64
    cutoff : float
        Neighbours ``j`` with centre distance ``< cutoff`` from centre ``i`` enter
        (spherical truncation; ``cutoff <= L/2``).
    near_factor : float
        Near/far split in units of the host radius.
    ncell : (3,) int64
        Cell grid.
    qpts, qw : (Q, 3), (Q,) float64
        Fine quadrature nodes in the unit ball and weights (sum ``4π/3``).
    cpts : (C, 3) float64
        Coarse nodes in the unit ball.
    interp : (Q, C) float64
        Values at the fine nodes of the polynomial fitted to values at the coarse nodes.
    inv2, inv4 : (5,), (9,) float64
        ``(4π/(2l+1)) / ∫ b_m² dΩ`` of the basis functions of :func:`_basis`, so that
        ``Σ_m inv_m b_m(u) b_m(u') = P_l(u·u')``.

    Returns
    -------
    out : (N, N_OUT) float64
        ``OUT_J2``, ``OUT_J4`` integrals and ``OUT_NEIGHBOURS`` count per sphere.
    """
    n = pos.shape[0]
    nq = qpts.shape[0]
    nc = cpts.shape[0]
    out = np.zeros((n, N_OUT), np.float64)
    cell_of, start, order = build_cells(pos, box, ncell)
    cl = cell_lengths(box, ncell)
    visit = np.empty(start.shape[0] - 1, np.int64)
    dx = np.empty(n, np.float64)
    dy = np.empty(n, np.float64)
    dz = np.empty(n, np.float64)
    vol = np.empty(n, np.float64)
    asq = np.empty(n, np.float64)
    near = np.empty(n, np.bool_)
    b2 = np.empty(5, np.float64)
    b4 = np.empty(9, np.float64)
    s2 = np.empty(5, np.float64)
    s4 = np.empty(9, np.float64)
    far2 = np.empty((nc, 5), np.float64)
    far4 = np.empty((nc, 9), np.float64)
    cut2 = cutoff * cutoff
    for i in range(n):
        a = radii[i]
        near2 = (near_factor * a) ** 2
        # gather neighbours within the cutoff (centre distance)
        m = 0
        n_far = 0
        nv = cells_in_reach(cell_of[i], cutoff, cl, ncell, visit)
        for q in range(nv):
            c = visit[q]
            for s in range(start[c], start[c + 1]):
                j = order[s]
                if j == i:
                    continue
                ex = min_image(pos[j, 0] - pos[i, 0], box[0])
                ey = min_image(pos[j, 1] - pos[i, 1], box[1])
                ez = min_image(pos[j, 2] - pos[i, 2], box[2])
                d2 = ex * ex + ey * ey + ez * ez
                if d2 >= cut2:
                    continue
                dx[m] = ex
                dy[m] = ey
                dz[m] = ez
                aj = radii[j]
                vol[m] = 4.0 / 3.0 * np.pi * aj * aj * aj
                asq[m] = aj * aj
                near[m] = d2 < near2
                if not near[m]:
                    n_far += 1
                m += 1
        # diagonal (j = k) terms of the near neighbours in closed form
        p2 = 0.0
        p4 = 0.0
        for t in range(m):
            if not near[t]:
                continue
            d = np.sqrt(dx[t] * dx[t] + dy[t] * dy[t] + dz[t] * dz[t])
            i6 = ball_inverse_power(a, d, 3)
            i8 = ball_inverse_power(a, d, 4)
            i10 = ball_inverse_power(a, d, 5)
            v2 = vol[t] * vol[t]
            p2 += v2 * i6
            p4 += v2 * (i6 - 2.8 * asq[t] * i8 + 1.96 * asq[t] * asq[t] * i10)
        # far field at the coarse nodes
        for q in range(nc):
            for k in range(5):
                far2[q, k] = 0.0
            for k in range(9):
                far4[q, k] = 0.0
        if n_far > 0:
            for q in range(nc):
                xq = a * cpts[q, 0]
                yq = a * cpts[q, 1]
                zq = a * cpts[q, 2]
                for k in range(5):
                    s2[k] = 0.0
                for k in range(9):
                    s4[k] = 0.0
                for t in range(m):
                    if near[t]:
                        continue
                    _accumulate(dx[t], dy[t], dz[t], vol[t], asq[t], xq, yq, zq, s2, s4, b2, b4)
                for k in range(5):
                    far2[q, k] = s2[k]
                for k in range(9):
                    far4[q, k] = s4[k]
        # everything else by quadrature over the ball: near-near cross terms, near-far
        # and far-far products (the far diagonal included, its integrand is smooth)
        acc2 = 0.0
        acc4 = 0.0
        for q in range(nq):
            xq = a * qpts[q, 0]
            yq = a * qpts[q, 1]
            zq = a * qpts[q, 2]
            for k in range(5):
                s2[k] = 0.0
            for k in range(9):
                s4[k] = 0.0
            if n_far > 0:
                for c in range(nc):
                    wt = interp[q, c]
                    for k in range(5):
                        s2[k] += wt * far2[c, k]
                    for k in range(9):
                        s4[k] += wt * far4[c, k]
            dg2 = 0.0
            dg4 = 0.0
            for t in range(m):
                if not near[t]:
                    continue
                g2, g4 = _accumulate(dx[t], dy[t], dz[t], vol[t], asq[t], xq, yq, zq, s2, s4, b2, b4)
                dg2 += g2
                dg4 += g4
            a2 = 0.0
            for k in range(5):
                a2 += inv2[k] * s2[k] * s2[k]
            a4 = 0.0
            for k in range(9):
                a4 += inv4[k] * s4[k] * s4[k]
            acc2 += qw[q] * (a2 - dg2)
            acc4 += qw[q] * (a4 - dg4)
        a3 = a * a * a
        out[i, OUT_J2] = p2 + a3 * acc2
        out[i, OUT_J4] = p4 + a3 * acc4
        out[i, OUT_NEIGHBOURS] = m
    return out


def warmup():
    """Compile the kernel on a tiny input."""
    pos = np.array([[0.5, 0.5, 0.5], [2.0, 2.0, 2.0], [3.2, 0.6, 2.5]])
    rad = np.array([0.4, 0.4, 0.3])
    box = np.array([5.0, 5.0, 5.0])
    q = np.array([[0.0, 0.0, 0.5]])
    three_point_sums(pos, rad, box, 2.4, 4.0, np.array([1, 1, 1], np.int64), q, np.array([4.18879]),
                     q, np.ones((1, 1)), np.ones(5), np.ones(9))
