"""Drop-and-roll deposition of spheres (3D) and the all-sphere cell grid it searches.

Kernels for :func:`polypack.generate.deposit.deposit` with ``rule="roll"`` (and the overlap
test of the overhang fallback of :mod:`.deposit3d`).

Rule (Visscher & Bolsterli 1972; Jullien & Meakin 1990 for size mixtures)
---------------------------------------------------------------------------
Each sphere is released at a random column ``(x, y)`` above the deposit and moves
quasi-statically (no inertia, no friction) under gravity until it is stably supported:

* **fall**: straight down until it touches a sphere (then roll on it) or the floor (rest);
* **roll on one sphere A**: along the great circle of the sphere of radius ``r + r_A``
  around ``A`` in the vertical plane through ``A`` and the centre, downwards, until it
  touches another sphere (roll on two) or reaches ``A``'s equator (fall again) or the floor;
* **roll on two spheres A, B**: along their circle of contact positions (the intersection of
  the spheres of radii ``r + r_A``, ``r + r_B``), downwards, while both contact forces are
  non-negative: the force on ``A`` vanishes where the circle point's unit vector ``w`` has
  ``w_z = -(e_z . e) rho / (d - u)`` and on ``B`` where ``w_z = (e_z . e) rho / u``
  (``e = (B - A)/d``, ``u`` the distance from ``A`` to the circle's centre, ``rho`` its
  radius); there it rolls on the other sphere alone.  The lowest point of the circle is never
  a rest point (gravity there has a negative force on one contact): a sphere that fits
  between ``A`` and ``B`` passes through (a throat);
* **three contacts**: it rests when gravity lies in the cone of the three contact normals
  (``e_z = sum lambda_a n_a``, ``lambda_a >= 0``); otherwise it keeps rolling on the pair (or
  the one sphere) whose contact forces are non-negative and whose motion does not enter the
  dropped contact.

A sphere smaller than the throat of three touching spheres of radius ``R`` (``r < (2/sqrt(3)
- 1) R = 0.1547 R``) therefore passes through the triangle and a larger one rests on it.
The motion is computed event to event in closed form (circle-sphere intersections), each
segment cut into pieces no longer than a grid cell; the spheres near a piece come from the
cell grid below, so the cost follows the neighbourhood of the moving sphere, whatever the
size ratio.  More than ``MAX_EVENTS`` events (never seen) ends the motion where it is
(``state[N_STUCK]``).

Cell grid
---------
A periodic (x, y) or walled grid of cubic-ish cells of edge ``h`` (about the smallest
diameter) up to ``nz`` layers (the top layer takes everything above it); each sphere is
registered in every cell its bounding box covers, so a large sphere is found from every
cell it occupies and a query needs only the cells of the query box.  Entries are linked
lists in a pool sized by :func:`grid_capacity`.  A column map keeps the highest sphere top
over each (x, y) cell (where a fall starts).
"""

from __future__ import annotations

import math
from enum import IntEnum

import numpy as np
from numba import njit

FLOOR = -1
NO_SUPPORT = -6
MAX_EVENTS = 5000


class RollParam(IntEnum):
    """Slots of the ``params`` array of :func:`deposit_roll`."""

    LX = 0
    LY = 1
    PERIODIC = 2  # 1.0: periodic x and y (the only boundary of the roll rule)
    TOL = 3  # relative tolerance of contact tests
    N_PARAMS = 4


class RollState(IntEnum):
    """Slots of the float ``state`` array of :func:`deposit_roll`."""

    N_PLACED = 0
    N_EVENTS = 1  # motion events (contacts made or lost) summed over spheres
    N_STUCK = 2  # spheres stopped after MAX_EVENTS events
    N_FLOOR = 3  # spheres resting on the floor
    N_GATHERED = 4  # neighbour entries examined (the cost of the search)
    N_STATE = 5


# ---------------------------------------------------------------- cell grid

class GridSlot(IntEnum):
    """Slots of the float grid description ``gd``."""

    LX = 0
    LY = 1
    HX = 2
    HY = 3
    HZ = 4
    NX = 5
    NY = 6
    NZ = 7
    PERIODIC = 8
    N = 9


def grid_layout(lx, ly, rmin, rmax, height, periodic, max_cells=4_000_000):
    """Grid description ``gd`` for a deposit of footprint ``lx x ly`` up to ``height``.

    Cells of edge about ``2 rmin`` (the smallest diameter), coarser if that would exceed
    ``max_cells`` cells; at least 3 cells per periodic axis.
    """
    h = 2.0 * rmin
    vol = lx * ly * max(height, 2.0 * rmax)
    h = max(h, (vol / max_cells) ** (1.0 / 3.0))
    nx = max(3, int(lx // h))
    ny = max(3, int(ly // h))
    hz = h
    nz = max(1, int(math.ceil(height / hz)) + 1)
    gd = np.zeros(int(GridSlot.N))
    gd[GridSlot.LX] = lx
    gd[GridSlot.LY] = ly
    gd[GridSlot.HX] = lx / nx
    gd[GridSlot.HY] = ly / ny
    gd[GridSlot.HZ] = hz
    gd[GridSlot.NX] = nx
    gd[GridSlot.NY] = ny
    gd[GridSlot.NZ] = nz
    gd[GridSlot.PERIODIC] = 1.0 if periodic else 0.0
    return gd


def grid_capacity(rad, gd):
    """Entries needed to register every sphere (cells of its bounding box, clipped to the grid)."""
    rad = np.asarray(rad, dtype=np.float64)
    nx, ny, nz = int(gd[GridSlot.NX]), int(gd[GridSlot.NY]), int(gd[GridSlot.NZ])
    cx = np.minimum(np.floor(2 * rad / gd[GridSlot.HX]) + 2, nx)
    cy = np.minimum(np.floor(2 * rad / gd[GridSlot.HY]) + 2, ny)
    cz = np.minimum(np.floor(2 * rad / gd[GridSlot.HZ]) + 2, nz)
    return int(np.sum(cx * cy * cz)) + 16


def make_grid(n, gd, capacity):
    """Arrays of an empty grid: ``(head, ent_next, ent_sph, tops, stamp, counters)``."""
    nc = int(gd[GridSlot.NX]) * int(gd[GridSlot.NY]) * int(gd[GridSlot.NZ])
    head = np.full(nc, -1, np.int64)
    ent_next = np.full(capacity, -1, np.int64)
    ent_sph = np.full(capacity, -1, np.int64)
    tops = np.full(int(gd[GridSlot.NX]) * int(gd[GridSlot.NY]), -np.inf)
    stamp = np.full(max(n, 1), -1, np.int64)
    counters = np.zeros(2, np.int64)  # entries used, query serial
    return head, ent_next, ent_sph, tops, stamp, counters


@njit(cache=True)
def _axis_range(lo, hi, h, n, per):
    """Cell index range ``[a, b]`` covering ``[lo, hi]`` (may run past the grid on a periodic axis)."""
    a = int(math.floor(lo / h))
    b = int(math.floor(hi / h))
    if per:
        if b - a + 1 >= n:
            return 0, n - 1
        return a, b
    if a < 0:
        a = 0
    if b > n - 1:
        b = n - 1
    if a > n - 1:
        a = n - 1
    if b < 0:
        b = 0
    return a, b


@njit(cache=True)
def grid_insert(k, pos, rad, gd, head, ent_next, ent_sph, tops, counters):
    """Register sphere ``k`` in every cell of its bounding box; raise the column tops. False if the pool is full."""
    per = gd[8] > 0.5
    nx = int(gd[5])
    ny = int(gd[6])
    nz = int(gd[7])
    R = rad[k]
    x0, x1 = _axis_range(pos[k, 0] - R, pos[k, 0] + R, gd[2], nx, per)
    y0, y1 = _axis_range(pos[k, 1] - R, pos[k, 1] + R, gd[3], ny, per)
    z0, z1 = _axis_range(pos[k, 2] - R, pos[k, 2] + R, gd[4], nz, False)
    top = pos[k, 2] + R
    for qx in range(x0, x1 + 1):
        ax = qx % nx
        for qy in range(y0, y1 + 1):
            ay = qy % ny
            c2 = ax * ny + ay
            if top > tops[c2]:
                tops[c2] = top
            for az in range(z0, z1 + 1):
                e = counters[0]
                if e >= ent_next.shape[0]:
                    return False
                counters[0] = e + 1
                c = c2 * nz + az
                ent_sph[e] = k
                ent_next[e] = head[c]
                head[c] = e
    return True


@njit(cache=True)
def grid_gather(lo, hi, gd, head, ent_next, ent_sph, stamp, counters, out):
    """Distinct spheres registered in the cells of the box ``[lo, hi]``; returns their number (in ``out``)."""
    per = gd[8] > 0.5
    nx = int(gd[5])
    ny = int(gd[6])
    nz = int(gd[7])
    counters[1] += 1
    serial = counters[1]
    x0, x1 = _axis_range(lo[0], hi[0], gd[2], nx, per)
    y0, y1 = _axis_range(lo[1], hi[1], gd[3], ny, per)
    z0, z1 = _axis_range(lo[2], hi[2], gd[4], nz, False)
    m = 0
    for qx in range(x0, x1 + 1):
        ax = qx % nx
        for qy in range(y0, y1 + 1):
            ay = qy % ny
            c2 = (ax * ny + ay) * nz
            for az in range(z0, z1 + 1):
                e = head[c2 + az]
                while e >= 0:
                    k = ent_sph[e]
                    if stamp[k] != serial:
                        stamp[k] = serial
                        if m >= out.shape[0]:
                            return -1
                        out[m] = k
                        m += 1
                    e = ent_next[e]
    return m


@njit(cache=True)
def grid_column_top(x, y, r, gd, tops):
    """Highest sphere top over the cells of the columns within ``r`` of ``(x, y)`` (``-inf``: none)."""
    per = gd[8] > 0.5
    nx = int(gd[5])
    ny = int(gd[6])
    x0, x1 = _axis_range(x - r, x + r, gd[2], nx, per)
    y0, y1 = _axis_range(y - r, y + r, gd[3], ny, per)
    t = -np.inf
    for qx in range(x0, x1 + 1):
        ax = qx % nx
        for qy in range(y0, y1 + 1):
            v = tops[ax * ny + (qy % ny)]
            if v > t:
                t = v
    return t


@njit(cache=True)
def grid_overlaps(p, r, pos, rad, gd, head, ent_next, ent_sph, stamp, counters, buf, tol):
    """True if a sphere of radius ``r`` at ``p`` overlaps a registered sphere by more than ``tol`` (relative).

    Scans the cells of the box ``p +- r`` directly and stops at the first overlap (a sphere
    registered in several of them is tested more than once, which is cheaper than gathering
    distinct ones; ``stamp``, ``counters`` and ``buf`` are not used: no allocation, the hot
    test of the overhang fallback of :mod:`.deposit3d`).
    """
    per = gd[8] > 0.5
    nx = int(gd[5])
    ny = int(gd[6])
    nz = int(gd[7])
    x0, x1 = _axis_range(p[0] - r, p[0] + r, gd[2], nx, per)
    y0, y1 = _axis_range(p[1] - r, p[1] + r, gd[3], ny, per)
    z0, z1 = _axis_range(p[2] - r, p[2] + r, gd[4], nz, False)
    t2 = (1.0 - tol) ** 2
    for qx in range(x0, x1 + 1):
        ax = qx % nx
        for qy in range(y0, y1 + 1):
            ay = qy % ny
            c2 = (ax * ny + ay) * nz
            for az in range(z0, z1 + 1):
                e = head[c2 + az]
                while e >= 0:
                    k = ent_sph[e]
                    d0 = _mi(p[0] - pos[k, 0], gd[0], per)
                    d1 = _mi(p[1] - pos[k, 1], gd[1], per)
                    d2 = p[2] - pos[k, 2]
                    R = r + rad[k]
                    if d0 * d0 + d1 * d1 + d2 * d2 < R * R * t2:
                        return True
                    e = ent_next[e]
    return False


@njit(cache=True)
def _mi(d, L, per):
    if per:
        d -= L * math.floor(d / L + 0.5)
    return d


# ---------------------------------------------------------------- motion


@njit(cache=True)
def _down_root(al, be, c):
    """Smallest ``t >= 0`` at which ``al cos t + be sin t`` crosses ``c`` downwards (``inf``: never)."""
    M = math.sqrt(al * al + be * be)
    if M <= 0.0:
        return np.inf
    q = c / M
    if q > 1.0 or q < -1.0:
        return np.inf
    t = math.atan2(be, al) + math.acos(q)
    t -= 2.0 * math.pi * math.floor(t / (2.0 * math.pi))
    return t


@njit(cache=True)
def _nearby(lo, hi, gd, head, ent_next, ent_sph, stamp, counters, buf, state):
    m = grid_gather(lo, hi, gd, head, ent_next, ent_sph, stamp, counters, buf)
    state[RollState.N_GATHERED] += max(m, 0)
    return m


@njit(cache=True)
def _scan_arc(O, rho, a, b, t_end, r, ex0, ex1, pos, rad, gd, head, ent_next, ent_sph, stamp,
              counters, buf, state, tol):
    """First sphere entered along ``P(t) = O + rho (cos t a + sin t b)``, ``0 <= t <= t_end``: (t, k) or (inf, -1).

    ``ex0, ex1``: the current contacts (ignored).  A sphere already touched at ``t = 0`` (a
    contact just left, within round-off) counts at ``t = 0`` only if the motion enters it,
    else where the arc comes back into it.
    """
    per = gd[8] > 0.5
    h = min(gd[2], gd[3], gd[4])
    nsub = max(1, int(math.ceil(rho * t_end / h)))
    dt = t_end / nsub
    sag = rho * (1.0 - math.cos(0.5 * dt)) if dt < math.pi else rho
    lo = np.empty(3)
    hi = np.empty(3)
    best_t = np.inf
    best_k = -1
    for s in range(nsub):
        t0 = s * dt
        t1 = t_end if s == nsub - 1 else (s + 1) * dt
        c0 = math.cos(t0)
        s0 = math.sin(t0)
        c1 = math.cos(t1)
        s1 = math.sin(t1)
        for ax in range(3):
            p0 = O[ax] + rho * (c0 * a[ax] + s0 * b[ax])
            p1 = O[ax] + rho * (c1 * a[ax] + s1 * b[ax])
            lo[ax] = min(p0, p1) - sag - r * (1.0 + 1e-9)
            hi[ax] = max(p0, p1) + sag + r * (1.0 + 1e-9)
        m = _nearby(lo, hi, gd, head, ent_next, ent_sph, stamp, counters, buf, state)
        for q in range(m):
            k = buf[q]
            if k == ex0 or k == ex1:
                continue
            D0 = _mi(O[0] - pos[k, 0], gd[0], per)
            D1 = _mi(O[1] - pos[k, 1], gd[1], per)
            D2 = O[2] - pos[k, 2]
            Rk = r + rad[k]
            F0 = D0 * D0 + D1 * D1 + D2 * D2 + rho * rho - Rk * Rk
            al = 2.0 * rho * (a[0] * D0 + a[1] * D1 + a[2] * D2)
            be = 2.0 * rho * (b[0] * D0 + b[1] * D1 + b[2] * D2)
            f0 = F0 + al
            if abs(f0) <= 2.0 * tol * Rk * Rk or f0 < 0.0:
                # touching at the start (within round-off): a contact now if the motion goes into
                # the sphere, else only where the arc comes back into it
                if be < -1e-9 * Rk * rho:
                    t = 0.0
                else:
                    t = _down_root(al, be, -F0)
                    if t < 1e-9:
                        continue
            else:
                t = _down_root(al, be, -F0)
            if t <= t1 and t < best_t:
                best_t = t
                best_k = k
        if best_k >= 0:
            return best_t, best_k
    return best_t, best_k


@njit(cache=True)
def _scan_fall(P, depth, r, pos, rad, gd, head, ent_next, ent_sph, stamp, counters, buf, state,
               tol):
    """First sphere entered by a vertical fall of at most ``depth`` from ``P``: (distance, k) or (inf, -1)."""
    per = gd[8] > 0.5
    h = 2.0 * gd[4]
    nsub = max(1, int(math.ceil(depth / h)))
    dt = depth / nsub
    lo = np.empty(3)
    hi = np.empty(3)
    lo[0] = P[0] - r * (1.0 + 1e-9)
    hi[0] = P[0] + r * (1.0 + 1e-9)
    lo[1] = P[1] - r * (1.0 + 1e-9)
    hi[1] = P[1] + r * (1.0 + 1e-9)
    best_t = np.inf
    best_k = -1
    for s in range(nsub):
        t0 = s * dt
        t1 = depth if s == nsub - 1 else (s + 1) * dt
        lo[2] = P[2] - t1 - r * (1.0 + 1e-9)
        hi[2] = P[2] - t0 + r * (1.0 + 1e-9)
        m = _nearby(lo, hi, gd, head, ent_next, ent_sph, stamp, counters, buf, state)
        for q in range(m):
            k = buf[q]
            D0 = _mi(P[0] - pos[k, 0], gd[0], per)
            D1 = _mi(P[1] - pos[k, 1], gd[1], per)
            D2 = P[2] - pos[k, 2]
            Rk = r + rad[k]
            h2 = D0 * D0 + D1 * D1
            if h2 >= Rk * Rk:
                continue
            if h2 + D2 * D2 - Rk * Rk <= 2.0 * tol * Rk * Rk:
                if D2 > 1e-9 * Rk:
                    t = 0.0  # touching, above its centre: moving into it
                else:
                    continue
            else:
                t = D2 - math.sqrt(Rk * Rk - h2)
                if t < 0.0:
                    continue
            if t <= t1 and t < best_t:
                best_t = t
                best_k = k
        if best_k >= 0:
            return best_t, best_k
    return best_t, best_k


@njit(cache=True)
def _normal(P, k, r, pos, rad, gd, out):
    per = gd[8] > 0.5
    d0 = _mi(P[0] - pos[k, 0], gd[0], per)
    d1 = _mi(P[1] - pos[k, 1], gd[1], per)
    d2 = P[2] - pos[k, 2]
    dn = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    out[0] = d0 / dn
    out[1] = d1 / dn
    out[2] = d2 / dn


@njit(cache=True)
def _lambda3(n0, n1, n2, lam):
    """Solve ``e_z = sum lam_a n_a``; False if the normals are (nearly) coplanar."""
    a00, a01, a02 = n0[0], n1[0], n2[0]
    a10, a11, a12 = n0[1], n1[1], n2[1]
    a20, a21, a22 = n0[2], n1[2], n2[2]
    det = a00 * (a11 * a22 - a12 * a21) - a01 * (a10 * a22 - a12 * a20) + a02 * (a10 * a21 - a11 * a20)
    if abs(det) < 1e-12:
        return False
    lam[0] = (a01 * a12 - a02 * a11) / det
    lam[1] = -(a00 * a12 - a02 * a10) / det
    lam[2] = (a00 * a11 - a01 * a10) / det
    return True


@njit(cache=True)
def _pair_frame(P, A, B, r, pos, rad, gd, C, e, w, t):
    """Circle of contact positions with spheres A and B through P: centre C, axis e, unit w = (P - C)/rho,
    descending tangent t (t_z <= 0).  Returns (rho, d, u, ok)."""
    per = gd[8] > 0.5
    e0 = _mi(pos[B, 0] - pos[A, 0], gd[0], per)
    e1 = _mi(pos[B, 1] - pos[A, 1], gd[1], per)
    e2 = pos[B, 2] - pos[A, 2]
    d = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    if d <= 0.0:
        return 0.0, 0.0, 0.0, False
    e[0] = e0 / d
    e[1] = e1 / d
    e[2] = e2 / d
    RA = r + rad[A]
    RB = r + rad[B]
    u = (RA * RA - RB * RB + d * d) / (2.0 * d)
    # A's image nearest P
    a0 = P[0] - _mi(P[0] - pos[A, 0], gd[0], per)
    a1 = P[1] - _mi(P[1] - pos[A, 1], gd[1], per)
    a2 = pos[A, 2]
    C[0] = a0 + u * e[0]
    C[1] = a1 + u * e[1]
    C[2] = a2 + u * e[2]
    v0 = P[0] - C[0]
    v1 = P[1] - C[1]
    v2 = P[2] - C[2]
    # remove the axial component (round-off) and renormalise
    ax = v0 * e[0] + v1 * e[1] + v2 * e[2]
    v0 -= ax * e[0]
    v1 -= ax * e[1]
    v2 -= ax * e[2]
    vn = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    rho2 = RA * RA - u * u
    if vn <= 0.0 or rho2 <= 0.0:
        return 0.0, d, u, False
    rho = math.sqrt(rho2)
    w[0] = v0 / vn
    w[1] = v1 / vn
    w[2] = v2 / vn
    t[0] = e[1] * w[2] - e[2] * w[1]
    t[1] = e[2] * w[0] - e[0] * w[2]
    t[2] = e[0] * w[1] - e[1] * w[0]
    if t[2] > 0.0:
        t[0] = -t[0]
        t[1] = -t[1]
        t[2] = -t[2]
    return rho, d, u, True


@njit(cache=True)
def _pair_forces(e, w, rho, d, u):
    """Contact forces (scaled) on A and B of a sphere on their contact circle at unit vector w."""
    ee = e[2]
    fa = (ee + (d - u) * w[2] / rho) / d
    fb = (u * w[2] / rho - ee) / d
    return fa, fb


@njit(cache=True)
def _single_tangent(n, t):
    """Descending tangent on one sphere at normal n; False when n is (anti)vertical."""
    s = math.sqrt(max(1.0 - n[2] * n[2], 0.0))
    if s < 1e-12:
        return False
    t[0] = n[2] * n[0] / s
    t[1] = n[2] * n[1] / s
    t[2] = (n[2] * n[2] - 1.0) / s
    return True


@njit(cache=True)
def roll_one(i, x, y, rad, pos, support, gd, head, ent_next, ent_sph, tops, stamp, counters, buf, state, tol):
    """Drop sphere ``i`` at column ``(x, y)`` and roll it to rest; writes ``pos[i]`` and ``support[i]``."""
    r = rad[i]
    per = gd[8] > 0.5
    P = np.empty(3)
    P[0] = x
    P[1] = y
    top = grid_column_top(x, y, r, gd, tops)
    P[2] = max(r, top + r * (1.0 + 1e-9))
    con = np.full(3, -1, np.int64)
    nc = 0
    n0 = np.empty(3)
    n1 = np.empty(3)
    n2 = np.empty(3)
    lam = np.empty(3)
    O = np.empty(3)
    a = np.empty(3)
    b = np.empty(3)
    C = np.empty(3)
    e = np.empty(3)
    w = np.empty(3)
    t = np.empty(3)
    on_floor = False
    ev = 0
    while ev < MAX_EVENTS:
        ev += 1
        if nc == 0:
            depth = P[2] - r
            if depth <= 0.0:
                on_floor = True
                break
            dt, k = _scan_fall(P, depth, r, pos, rad, gd, head, ent_next, ent_sph, stamp,
                               counters, buf, state, tol)
            if k < 0:
                P[2] = r
                on_floor = True
                break
            P[2] -= dt
            con[0] = k
            nc = 1
        elif nc == 1:
            A = con[0]
            _normal(P, A, r, pos, rad, gd, n0)
            RA = r + rad[A]
            O[0] = P[0] - RA * n0[0]
            O[1] = P[1] - RA * n0[1]
            O[2] = P[2] - RA * n0[2]
            if n0[2] <= 1e-12:
                nc = 0
                continue
            if not _single_tangent(n0, t):
                t[0] = -1.0  # on the very top: roll along -x (measure zero)
                t[1] = 0.0
                t[2] = 0.0
            t_end = math.atan2(n0[2], math.sqrt(max(1.0 - n0[2] * n0[2], 0.0)))  # to the equator
            t_fl = _down_root(n0[2], t[2], (r - O[2]) / RA) if O[2] < r else np.inf
            hit_floor = t_fl < t_end
            if hit_floor:
                t_end = t_fl
            th, k = _scan_arc(O, RA, n0, t, t_end, r, A, -1, pos, rad, gd, head, ent_next,
                              ent_sph, stamp, counters, buf, state, tol)
            if k >= 0 and th <= t_end:
                t_end = th
            c = math.cos(t_end)
            s = math.sin(t_end)
            for q in range(3):
                P[q] = O[q] + RA * (c * n0[q] + s * t[q])
            if k >= 0 and th <= t_end:
                con[1] = k
                nc = 2
            elif hit_floor:
                P[2] = r
                on_floor = True
                break
            else:
                nc = 0
        elif nc == 2:
            A = con[0]
            B = con[1]
            rho, d, u, ok = _pair_frame(P, A, B, r, pos, rad, gd, C, e, w, t)
            if not ok:
                con[0] = B
                nc = 1
                continue
            fa, fb = _pair_forces(e, w, rho, d, u)
            if fa < 0.0 and fb < 0.0:
                nc = 0
                continue
            if fa < 0.0 or fb < 0.0:
                if fa < 0.0:
                    con[0] = B
                nc = 1
                continue
            # descend along the circle until a force vanishes, a sphere is touched or the floor
            t_end = np.inf
            if d - u > 0.0:
                t_end = min(t_end, _down_root(w[2], t[2], -e[2] * rho / (d - u)))
            if u > 0.0:
                t_end = min(t_end, _down_root(w[2], t[2], e[2] * rho / u))
            t_bot = math.atan2(-t[2], -w[2])
            if t_bot < 0.0:
                t_bot += 2.0 * math.pi
            if t_end > t_bot:
                t_end = t_bot
            t_fl = _down_root(w[2], t[2], (r - C[2]) / rho) if C[2] - rho < r else np.inf
            hit_floor = t_fl < t_end
            if hit_floor:
                t_end = t_fl
            th, k = _scan_arc(C, rho, w, t, t_end, r, A, B, pos, rad, gd, head, ent_next,
                              ent_sph, stamp, counters, buf, state, tol)
            if k >= 0 and th <= t_end:
                t_end = th
            c = math.cos(t_end)
            s = math.sin(t_end)
            for q in range(3):
                P[q] = C[q] + rho * (c * w[q] + s * t[q])
            if k >= 0 and th <= t_end:
                con[2] = k
                nc = 3
            elif hit_floor:
                P[2] = r
                on_floor = True
                break
            else:
                # a force vanished (or the bottom): the next pass drops that contact
                rho, d, u, ok = _pair_frame(P, A, B, r, pos, rad, gd, C, e, w, t)
                if ok:
                    fa, fb = _pair_forces(e, w, rho, d, u)
                    if fa <= fb:
                        con[0] = B
                nc = 1
        else:
            _normal(P, con[0], r, pos, rad, gd, n0)
            _normal(P, con[1], r, pos, rad, gd, n1)
            _normal(P, con[2], r, pos, rad, gd, n2)
            if _lambda3(n0, n1, n2, lam) and lam[0] >= -tol and lam[1] >= -tol and lam[2] >= -tol:
                break  # stable on three
            # keep rolling on a pair that leaves the third: drop the most negative force first
            order = np.argsort(lam) if _lambda3(n0, n1, n2, lam) else np.arange(3)[::-1].copy()
            moved = False
            for jj in range(3):
                j = order[jj]
                p0 = con[(j + 1) % 3]
                p1 = con[(j + 2) % 3]
                rho, d, u, ok = _pair_frame(P, p0, p1, r, pos, rad, gd, C, e, w, t)
                if not ok:
                    continue
                fa, fb = _pair_forces(e, w, rho, d, u)
                if fa < 0.0 or fb < 0.0:
                    continue
                _normal(P, con[j], r, pos, rad, gd, n2)
                if t[0] * n2[0] + t[1] * n2[1] + t[2] * n2[2] < 0.0:
                    continue  # would enter the dropped sphere
                con[0] = p0
                con[1] = p1
                con[2] = -1
                nc = 2
                moved = True
                break
            if not moved:
                for jj in range(3):
                    j = order[jj]
                    kk = con[(j + 2) % 3]  # keep one sphere: roll on it if that leaves the other two
                    _normal(P, kk, r, pos, rad, gd, n0)
                    if n0[2] <= 0.0 or not _single_tangent(n0, t):
                        continue
                    ok1 = True
                    for q in range(3):
                        if con[q] == kk:
                            continue
                        _normal(P, con[q], r, pos, rad, gd, n1)
                        if t[0] * n1[0] + t[1] * n1[1] + t[2] * n1[2] < 0.0:
                            ok1 = False
                    if ok1:
                        con[0] = kk
                        con[1] = -1
                        con[2] = -1
                        nc = 1
                        moved = True
                        break
            if not moved:
                break  # no admissible motion: rests (a jammed triple, measure zero)
    if ev >= MAX_EVENTS:
        state[RollState.N_STUCK] += 1
    state[RollState.N_EVENTS] += ev
    pos[i, 0] = P[0] - gd[0] * math.floor(P[0] / gd[0]) if per else P[0]
    pos[i, 1] = P[1] - gd[1] * math.floor(P[1] / gd[1]) if per else P[1]
    if per:
        if pos[i, 0] >= gd[0]:
            pos[i, 0] = 0.0
        if pos[i, 1] >= gd[1]:
            pos[i, 1] = 0.0
    pos[i, 2] = P[2]
    support[i, 0] = NO_SUPPORT
    support[i, 1] = NO_SUPPORT
    support[i, 2] = NO_SUPPORT
    m = 0
    if on_floor:
        support[i, 0] = FLOOR
        state[RollState.N_FLOOR] += 1
        m = 1
    for q in range(nc):
        if m < 3 and con[q] >= 0:
            support[i, m] = con[q]
            m += 1


@njit(cache=True)
def deposit_roll(rad, drop, pos, support, state, start, stop, gd, head, ent_next, ent_sph, tops, stamp, counters,
                 buf, tol):
    """Drop and roll spheres ``start .. stop-1`` onto the deposit of spheres ``0 .. start-1``.

    Parameters
    ----------
    rad : (N,) float64
        Radii in deposition order.
    drop : (N, 2) float64
        Release column of each sphere (ignored for rows ``< start``, a fixed bed).
    pos, support : (N, 3) in/out
        Centres and the (up to three) support codes (``FLOOR``, sphere indices, ``NO_SUPPORT``).
    state : (N_STATE,) float64, in/out
        :class:`RollState`.
    gd, head, ent_next, ent_sph, tops, stamp, counters : grid arrays (:func:`make_grid`); the
        spheres ``< start`` must already be registered (:func:`grid_insert`).
    buf : (N,) int64
        Scratch for neighbour lists.
    tol : float
        Relative tolerance of the contact tests.

    Returns
    -------
    int
        0, or 1 if the grid's entry pool ran out (size it with :func:`grid_capacity`).
    """
    for i in range(start, stop):
        roll_one(i, drop[i, 0], drop[i, 1], rad, pos, support, gd, head, ent_next, ent_sph, tops, stamp, counters,
                 buf, state, tol)
        if not grid_insert(i, pos, rad, gd, head, ent_next, ent_sph, tops, counters):
            return 1
        state[RollState.N_PLACED] = i + 1
    return 0


def warmup():
    """Compile the kernel on a tiny input."""
    n = 40
    rad = np.full(n, 0.5)
    rng = np.random.default_rng(0)
    drop = rng.uniform(0, 5.0, (n, 2))
    gd = grid_layout(5.0, 5.0, 0.5, 0.5, 10.0, True)
    head, en, es, tops, stamp, counters = make_grid(n, gd, grid_capacity(rad, gd))
    pos = np.zeros((n, 3))
    support = np.zeros((n, 3), np.int64)
    state = np.zeros(int(RollState.N_STATE))
    deposit_roll(rad, drop, pos, support, state, 0, n, gd, head, en, es, tops, stamp, counters,
                 np.zeros(n, np.int64), 1e-10)
