"""Sequential deposition of disks by potential minimisation (2D), §2.4 of 001_ad5bae0acea940c4.txt.

Kernels for :mod:`polypack.generate.deposit`.  Disks are placed one at a time; each goes
to the lowest centre height ``y`` (the gravitational potential) at which it rests on the
floor ``y = 0``, a side wall (or nothing: the x axis may be periodic) or two disks of the
*free surface*, and at which it can be reached by a vertical drop from above.

Geometry
--------
Let ``top(x)`` be the upper boundary of the deposit (0 where the floor is bare).  A disk
of radius ``r`` dropped at abscissa ``x`` stops with its centre at the height of the
dilated envelope

    U_r(x) = max(r, max_k [y_k + sqrt((r + r_k)^2 - (x - x_k)^2)]),

the maximum running over the disks ``k`` that show in ``top`` (the *chain*), because
``U_r(x) = max_{x'} top(x') + sqrt(r^2 - (x - x')^2)`` and every point of ``top`` lies on a
chain disk.  The chosen position is the global minimum of ``U_r`` over ``x`` (walls:
``r <= x <= W - r``).  A minimum of an upper envelope of concave arcs is

* a kink of two dilated arcs ``i``, ``j``: the upper intersection of the circles of radii
  ``r + r_i`` and ``r + r_j``, with the new centre between ``x_i`` and ``x_j`` (the disk
  is then in equilibrium under gravity on its two contacts);
* a floor position ``y = r`` at the left end of a bare stretch of floor: next to a wall,
  touching a disk whose centre is not higher than ``r``, or where the dilated arc of a
  higher disk ends (the drop cannot pass under its overhang), or ``x = 0`` on a
  periodic floor;
* a wall position ``x = r`` (``W - r``) on a disk lying on the far side of the centre.

The kernel enumerates these candidates over the chain and keeps the lowest one that is
on the envelope (no chain disk's dilated arc above it, up to ``tol`` relative).  When
``U_r`` has no pocket at all (every local minimum is the end of an overhanging arc, which
happens for a small disk among much larger ones: it would land on a slope and roll under
the overhang), the disk goes to the lowest *wedge*: an intersection of the dilated circles
of a disk below and a disk above the new centre, in equilibrium under gravity on the two
contacts, with no other disk above it.
**Tie rule**: candidates whose heights differ by at most ``tol * r`` are equal; the
leftmost (smallest ``x`` in ``[0, W)``) wins, so under ``FLOOR_LEFT`` a bare floor fills from
the left wall (from ``x = 0`` when periodic); ``FLOOR_CENTRED`` (the default of
:func:`polypack.deposit`) puts a disk that reaches bare floor at the midpoint of the leftmost
bare stretch instead (:func:`_floor_centred`).

Surface structure
-----------------
The chain is a list of entries ``(disk, x_lo, x_hi)`` sorted by ``x``, covering ``[0, W)``
contiguously (disk ``-1`` = bare floor).  A newly placed disk lies above everything in its
column range (its centre is on the envelope, so every disk sharing a column is below
the separating line of the pair), so the update replaces the entries over
``[x - r, x + r]`` by the new disk (each disk's visible part stays one interval; periodic
ranges that wrap are split in two entries).  The cost per disk is linear in the chain
length (about ``W / d``), independent of the number of disks already placed.

Support codes (``support`` array; a wedge lists the lower disk first), two per disk): ``>= 0`` a disk index, ``FLOOR``,
``LEFT_WALL``, ``RIGHT_WALL`` or ``NO_SUPPORT`` (second slot of a disk on a bare periodic
floor, and of fixed bed disks).
"""

from __future__ import annotations

import math
from enum import IntEnum

import numpy as np
from numba import njit

FLOOR = -1
LEFT_WALL = -2
RIGHT_WALL = -3
NO_SUPPORT = -4


class DepositStatus(IntEnum):
    """Return codes of :func:`deposit_disks`."""

    OK = 0
    NO_POSITION = 1  # no admissible position (inconsistent input; never for valid input)
    CHAIN_FULL = 2  # chain capacity exceeded (cannot happen with the capacity the caller allocates)


class DepositParam(IntEnum):
    """Slots of the ``params`` array of :func:`deposit_disks`."""

    WIDTH = 0  # box width W along x
    PERIODIC = 1  # 1.0: x periodic, 0.0: walls at x = 0 and x = W
    TOL = 2  # relative tolerance of contact tests and of the tie rule
    RMAX = 3  # largest radius of all disks (bed included)
    FLOOR_RULE = 4  # 0.0: leftmost point of the leftmost bare floor stretch; 1.0: its midpoint
    N_PARAMS = 5


FLOOR_LEFT = 0
FLOOR_CENTRED = 1


class DepositState(IntEnum):
    """Slots of the integer ``state`` array (outputs)."""

    N_PLACED = 0  # disks placed (bed included) when the kernel returned
    CHAIN_LEN = 1  # chain entries at the end
    CHAIN_MAX = 2  # longest chain seen
    N_STATE = 3


@njit(cache=True)
def _mi(dx, width, periodic):
    """Minimum-image separation along a periodic x axis (identity with walls)."""
    if periodic:
        half = 0.5 * width
        if dx > half:
            dx -= width
        elif dx < -half:
            dx += width
    return dx


@njit(cache=True)
def _wrap(x, width, periodic):
    if periodic:
        if x >= width:
            x -= width
        elif x < 0.0:
            x += width
        if x >= width or x < 0.0:
            x = x - width * math.floor(x / width)
            if x >= width:
                x = 0.0
    return x


@njit(cache=True)
def _entry_at(clo, ns, x):
    """Index of the chain entry whose interval ``[clo, chi)`` contains ``x``."""
    lo = 0
    hi = ns - 1
    while lo < hi:
        mid = (lo + hi + 1) >> 1
        if clo[mid] <= x:
            lo = mid
        else:
            hi = mid - 1
    return lo


@njit(cache=True)
def _on_envelope(x, y, r, skip_a, skip_b, pos, rad, cid, clo, chi, ns, width, periodic, reach, tol):
    """True when no chain disk's dilated arc rises above ``(x, y)`` (beyond ``tol``).

    Scans the chain entries whose intervals come within ``reach`` of ``x``; every disk
    ``k`` with ``|x - x_k| < r + r_k`` has its visible interval inside that range.
    """
    e0 = _entry_at(clo, ns, x)
    # backward, starting at e0
    e = e0
    off = 0.0
    steps = 0
    while True:
        k = cid[e]
        if k >= 0 and k != skip_a and k != skip_b:
            R = r + rad[k]
            dx = _mi(x - pos[k, 0], width, periodic)
            if dx < R and dx > -R:
                h = pos[k, 1] + math.sqrt(R * R - dx * dx)
                if h > y + tol * R:
                    return False
        steps += 1
        if steps >= ns:
            return True
        e -= 1
        if e < 0:
            if not periodic:
                break
            e = ns - 1
            off = width
        if x - (chi[e] - off) > reach:
            break
    # forward, starting after e0
    e = e0
    off = 0.0
    steps = 1
    while True:
        e += 1
        if e >= ns:
            if not periodic:
                break
            e = 0
            off = width
        if clo[e] + off - x > reach:
            break
        steps += 1
        if steps > ns:
            break
        k = cid[e]
        if k >= 0 and k != skip_a and k != skip_b:
            R = r + rad[k]
            dx = _mi(x - pos[k, 0], width, periodic)
            if dx < R and dx > -R:
                h = pos[k, 1] + math.sqrt(R * R - dx * dx)
                if h > y + tol * R:
                    return False
    return True


@njit(cache=True)
def _cover(cid, clo, chi, ns, k, a, b, eps):
    """Replace the chain over ``[a, b]`` (``0 <= a < b <= W``) by disk ``k``; new length.

    Remnants of the cut entries shorter than ``eps`` are absorbed into the new entry so
    the chain stays contiguous.  Returns -1 when the capacity would be exceeded.
    """
    # p0: first entry with chi > a
    lo = 0
    hi = ns - 1
    while lo < hi:
        mid = (lo + hi) >> 1
        if chi[mid] > a:
            hi = mid
        else:
            lo = mid + 1
    p0 = lo
    # p1: last entry with clo < b
    lo = 0
    hi = ns - 1
    while lo < hi:
        mid = (lo + hi + 1) >> 1
        if clo[mid] < b:
            lo = mid
        else:
            hi = mid - 1
    p1 = lo
    if p1 < p0:
        p1 = p0
    new_lo = a
    new_hi = b
    left = clo[p0] < a - eps
    if not left:
        new_lo = clo[p0]
    right = chi[p1] > b + eps
    if not right:
        new_hi = chi[p1]
    lid = cid[p0]
    llo = clo[p0]
    rid = cid[p1]
    rhi = chi[p1]
    nnew = 1 + (1 if left else 0) + (1 if right else 0)
    nold = p1 - p0 + 1
    delta = nnew - nold
    if ns + delta > cid.shape[0]:
        return -1
    if delta > 0:
        for q in range(ns - 1, p1, -1):
            cid[q + delta] = cid[q]
            clo[q + delta] = clo[q]
            chi[q + delta] = chi[q]
    elif delta < 0:
        for q in range(p1 + 1, ns):
            cid[q + delta] = cid[q]
            clo[q + delta] = clo[q]
            chi[q + delta] = chi[q]
    q = p0
    if left:
        cid[q] = lid
        clo[q] = llo
        chi[q] = a
        q += 1
    cid[q] = k
    clo[q] = new_lo
    chi[q] = new_hi
    q += 1
    if right:
        cid[q] = rid
        clo[q] = b
        chi[q] = rhi
    return ns + delta


@njit(cache=True)
def _cover_disk(cid, clo, chi, ns, k, x, r, width, periodic, eps):
    """Chain update for disk ``k`` of radius ``r`` at abscissa ``x`` (splits wrapping ranges)."""
    a = x - r
    b = x + r
    if periodic:
        if a < 0.0:
            ns = _cover(cid, clo, chi, ns, k, a + width, width, eps)
            if ns < 0:
                return ns
            return _cover(cid, clo, chi, ns, k, 0.0, b, eps)
        if b > width:
            ns = _cover(cid, clo, chi, ns, k, a, width, eps)
            if ns < 0:
                return ns
            return _cover(cid, clo, chi, ns, k, 0.0, b - width, eps)
        return _cover(cid, clo, chi, ns, k, a, b, eps)
    if a < 0.0:
        a = 0.0
    if b > width:
        b = width
    return _cover(cid, clo, chi, ns, k, a, b, eps)


@njit(cache=True)
def _better(y, x, best_y, best_x, tie):
    """Tie rule: lower centre wins; within ``tie`` the smaller abscissa wins."""
    if y < best_y - tie:
        return True
    if y <= best_y + tie and x < best_x:
        return True
    return False


@njit(cache=True)
def _dilated_meet(i, j, r, pos, rad, width, periodic):
    """Where the dilated circles (radii ``r + r_i``, ``r + r_j``) of disks ``i`` and ``j`` meet.

    Returns ``(ok, dx, dy, Ri, Rj, a, h, ux, uy)``: ``(dx, dy)`` from ``i`` to ``j`` (minimum
    image), ``(ux, uy)`` its unit vector, the two intersections at ``a u +- h u_perp`` from
    ``i``; ``ok`` is False when the circles do not cross.
    """
    xi = pos[i, 0]
    yi = pos[i, 1]
    dx = _mi(pos[j, 0] - xi, width, periodic)
    dy = pos[j, 1] - yi
    Ri = r + rad[i]
    Rj = r + rad[j]
    d2 = dx * dx + dy * dy
    if d2 >= (Ri + Rj) * (Ri + Rj) or d2 <= (Ri - Rj) * (Ri - Rj) or d2 == 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    d = math.sqrt(d2)
    a = (Ri * Ri - Rj * Rj + d2) / (2.0 * d)
    h2 = Ri * Ri - a * a
    h = math.sqrt(h2) if h2 > 0.0 else 0.0
    ux = dx / d
    uy = dy / d
    return True, dx, dy, Ri, Rj, a, h, ux, uy


@njit(cache=True)
def _pair_candidate(i, j, r, pos, rad, width, periodic):
    """Upper intersection of the dilated circles of ``i`` and ``j``.

    Returns ``(ok, x, y, left, right)``; ``ok`` is False when the circles do not meet
    or the point is not between the two centres (no equilibrium on the pair).
    """
    ok, dx, dy, Ri, Rj, a, h, ux, uy = _dilated_meet(i, j, r, pos, rad, width, periodic)
    if not ok:
        return False, 0.0, 0.0, -1, -1
    xi = pos[i, 0]
    yi = pos[i, 1]
    if ux >= 0.0:
        px = a * ux - h * uy
        py = a * uy + h * ux
        left = i
        right = j
        lo = 0.0
        hi = dx
    else:
        px = a * ux + h * uy
        py = a * uy - h * ux
        left = j
        right = i
        lo = dx
        hi = 0.0
    if px < lo or px > hi:
        return False, 0.0, 0.0, -1, -1
    return True, xi + px, yi + py, left, right


@njit(cache=True)
def _wedge_candidate(i, j, r, pos, rad, width, periodic, side):
    """Intersection ``side`` (0, 1) of the dilated circles of ``i`` and ``j`` as a wedge.

    A wedge has one disk below the new centre (``lo``) and one above it (``hi``), and is
    in equilibrium under gravity: ``(0, 1) = a n_lo + b n_hi`` with ``a, b >= 0`` for the
    unit contact normals.  Returns ``(ok, x, y, lo, hi)``.
    """
    ok, dx, dy, Ri, Rj, a, h, ux, uy = _dilated_meet(i, j, r, pos, rad, width, periodic)
    if not ok:
        return False, 0.0, 0.0, -1, -1
    xi = pos[i, 0]
    yi = pos[i, 1]
    sg = 1.0 if side == 0 else -1.0
    px = a * ux - sg * h * uy
    py = a * uy + sg * h * ux
    # normals from each support to the new centre
    nix = px / Ri
    niy = py / Ri
    njx = (px - dx) / Rj
    njy = (py - dy) / Rj
    if niy >= 0.0 and njy < 0.0:
        lo = i
        hi = j
        lx, ly, hx, hy = nix, niy, njx, njy
    elif njy >= 0.0 and niy < 0.0:
        lo = j
        hi = i
        lx, ly, hx, hy = njx, njy, nix, niy
    else:
        return False, 0.0, 0.0, -1, -1
    det = lx * hy - ly * hx
    if det == 0.0:
        return False, 0.0, 0.0, -1, -1
    wa = -hx / det
    wb = lx / det
    if wa < 0.0 or wb < 0.0:
        return False, 0.0, 0.0, -1, -1
    return True, xi + px, yi + py, lo, hi


@njit(cache=True)
def _floor_centred(r, pos, rad, cid, ns, width, periodic, tol, res):
    """Midpoint of the leftmost bare-floor stretch of centres (``FLOOR_CENTRED`` rule).

    At the floor level ``y = r`` chain disk ``j`` blocks the centres with
    ``|x - x_j| < w_j``: ``w_j = sqrt(R^2 - (r - y_j)^2)`` when its centre is not higher than
    ``r`` (it would overlap), else ``w_j = R = r + r_j`` (a vertical drop cannot pass under
    its dilated arc).  The free centres form closed stretches ``[a, b]``; the leftmost one
    (smallest ``a``, in ``[0, W)`` when periodic) is chosen and the disk goes to its
    midpoint, touching only the floor (or, for a stretch of zero length, its ends).
    Returns ``(found, touch_left, touch_right)`` and writes ``res = (x, r)``.
    """
    lo = np.empty(ns)
    ln = np.empty(ns)
    m = 0
    last = -1
    for e in range(ns):
        j = cid[e]
        if j < 0 or j == last:
            continue
        last = j
        R = r + rad[j]
        dyf = pos[j, 1] - r
        if dyf <= 0.0:
            w2 = R * R - dyf * dyf
            if w2 <= 0.0:
                continue
            w = math.sqrt(w2)
        else:
            w = R
        a = pos[j, 0] - w
        if periodic:
            a = _wrap(a, width, periodic)
        lo[m] = a
        ln[m] = 2.0 * w
        m += 1
    slack = tol * r
    if m == 0:
        res[0] = 0.0 if periodic else 0.5 * width
        res[1] = r
        if not periodic and width < 2.0 * r * (1.0 - tol):
            return False, NO_SUPPORT, NO_SUPPORT
        return True, NO_SUPPORT, NO_SUPPORT
    order = np.argsort(lo[:m])
    best_a = np.inf
    best_len = 0.0
    if periodic:
        # sweep two turns of the circle; a gap is counted once, where it ends at a blocked
        # stretch of the second turn (so the stretches of the first turn that run past W
        # are accounted for)
        end = -np.inf
        for q in range(2 * m):
            k = order[q % m]
            a = lo[k] + (width if q >= m else 0.0)
            b = a + ln[k]
            if q >= m and a >= end - slack:
                ga = _wrap(end, width, periodic)
                if ga < best_a:
                    best_a = ga
                    best_len = max(a - end, 0.0)
            if b > end:
                end = b
    else:
        end = r  # the left wall
        hi = width - r  # the right wall
        for q in range(m + 1):
            if q < m:
                a = lo[order[q]]
                b = a + ln[order[q]]
            else:
                a = hi
                b = hi
            if end > hi + slack:
                break
            if a >= end - slack:
                best_a = end
                best_len = max(min(a, hi) - end, 0.0)
                break
            if b > end:
                end = b
    if not best_a < np.inf:
        return False, NO_SUPPORT, NO_SUPPORT
    x = best_a + 0.5 * best_len
    if periodic:
        x = _wrap(x, width, periodic)
    res[0] = x
    res[1] = r
    return True, NO_SUPPORT, NO_SUPPORT


@njit(cache=True)
def _step(f, off, ns, width, periodic):
    """Next chain entry after ``f`` and its offset (``+W`` once it wrapped past the end); ``f = -1`` at a wall."""
    f += 1
    if f >= ns:
        if not periodic:
            return -1, off
        return 0, width
    return f, off


@njit(cache=True)
def _admit(x, y, r, i, j, pos, rad, cid, clo, chi, ns, width, periodic, reach, tol, best_y, best_x):
    """A pocket or wedge ``(x, y)`` on disks ``i``, ``j``: inside the box, better than the best, on the envelope.

    Returns ``(ok, x)`` with ``x`` wrapped into ``[0, W)`` on a periodic axis.
    """
    tie = tol * r
    if periodic:
        x = _wrap(x, width, periodic)
    elif x < r - tie or x > width - r + tie:
        return False, x
    if not _better(y, x, best_y, best_x, tie):
        return False, x
    return _on_envelope(x, y, r, i, j, pos, rad, cid, clo, chi, ns, width, periodic, reach, tol), x


@njit(cache=True)
def _place_one(n, r, pos, rad, cid, clo, chi, ns, width, periodic, rmax, tol, res, floor_rule):
    """Find the position of disk ``n`` (radius ``r``); writes ``res = (x, y)``, returns supports.

    Returns ``(found, s0, s1)``.
    """
    reach = r + 2.0 * rmax
    tie = tol * r
    # ---- floor positions (y = r): only if some floor is bare
    has_floor = False
    for e in range(ns):
        if cid[e] < 0:
            has_floor = True
            break
    best_y = np.inf
    best_x = np.inf
    s0 = -1
    s1 = -1
    if has_floor and floor_rule == FLOOR_CENTRED:
        found, t0, t1 = _floor_centred(r, pos, rad, cid, ns, width, periodic, tol, res)
        if found and _on_envelope(res[0], r, r, -1, -1, pos, rad, cid, clo, chi, ns, width, periodic, reach, tol):
            return True, FLOOR, t1
    if has_floor:
        if periodic:
            if _on_envelope(0.0, r, r, -1, -1, pos, rad, cid, clo, chi, ns, width, periodic, reach, tol):
                res[0] = 0.0
                res[1] = r
                return True, FLOOR, NO_SUPPORT
        else:
            if _on_envelope(r, r, r, -1, -1, pos, rad, cid, clo, chi, ns, width, periodic, reach, tol):
                res[0] = r
                res[1] = r
                return True, FLOOR, LEFT_WALL
            if _on_envelope(width - r, r, r, -1, -1, pos, rad, cid, clo, chi, ns, width, periodic, reach, tol):
                best_y = r
                best_x = width - r
                s0 = FLOOR
                s1 = RIGHT_WALL
        # the leftmost bare-floor abscissa of a gap is the right end of some disk's reach:
        # a contact when the disk's centre is no higher than r, else the end of its
        # dilated arc (the new disk then touches the floor only: it cannot get under the
        # overhang by a vertical drop)
        last = -1
        for e in range(ns):
            j = cid[e]
            if j < 0 or j == last:
                continue
            last = j
            R = r + rad[j]
            dyf = pos[j, 1] - r
            if dyf <= 0.0:
                x = pos[j, 0] + math.sqrt(R * R - dyf * dyf)
                touch = j
            else:
                x = pos[j, 0] + R
                touch = NO_SUPPORT
            if periodic:
                x = _wrap(x, width, periodic)
            elif x < r or x > width - r:
                continue
            if x >= best_x:
                continue
            if _on_envelope(x, r, r, j, -1, pos, rad, cid, clo, chi, ns, width, periodic, reach, tol):
                best_y = r
                best_x = x
                s0 = FLOOR
                s1 = touch
        if best_y == r:
            res[0] = best_x
            res[1] = best_y
            return True, s0, s1
    # ---- wall positions
    if not periodic:
        for side in range(2):
            xw = r if side == 0 else width - r
            e = 0 if side == 0 else ns - 1
            while e >= 0 and e < ns:
                if side == 0 and clo[e] > xw + reach:
                    break
                if side == 1 and chi[e] < xw - reach:
                    break
                j = cid[e]
                e = e + 1 if side == 0 else e - 1
                if j < 0:
                    continue
                dx = pos[j, 0] - xw
                if (side == 0 and dx <= 0.0) or (side == 1 and dx >= 0.0):
                    continue
                R = r + rad[j]
                if dx * dx >= R * R:
                    continue
                y = pos[j, 1] + math.sqrt(R * R - dx * dx)
                if not _better(y, xw, best_y, best_x, tie):
                    continue
                if _on_envelope(xw, y, r, j, -1, pos, rad, cid, clo, chi, ns, width, periodic, reach, tol):
                    best_y = y
                    best_x = xw
                    s0 = LEFT_WALL if side == 0 else RIGHT_WALL
                    s1 = j
    # ---- pairs of chain disks: adjacent entries first (a good bound), then all pairs in range
    for sweep in range(2):
        for e in range(ns):
            i = cid[e]
            if i < 0:
                continue
            yi = pos[i, 1]
            if yi > best_y + tie:
                continue
            # i's centre in the frame of entry e (a periodic entry may sit across x = 0 from it)
            xi_e = clo[e] + _mi(pos[i, 0] - clo[e], width, periodic)
            limit = xi_e + rad[i] + 2.0 * r + 2.0 * rmax
            f = e
            off = 0.0
            steps = 0
            while True:
                f, off = _step(f, off, ns, width, periodic)
                steps += 1
                if f < 0 or steps >= ns:
                    break
                if sweep == 0 and steps > 1:
                    # adjacent distinct disk only
                    break
                j = cid[f]
                if j < 0:
                    if sweep == 0:
                        break
                    if clo[f] + off > limit:
                        break
                    continue
                if j == i:
                    continue
                if clo[f] + off > limit:
                    break
                if pos[j, 1] > best_y + tie:
                    continue
                ok, x, y, left, right = _pair_candidate(i, j, r, pos, rad, width, periodic)
                if not ok:
                    continue
                if y < r - tie:
                    continue
                if y < yi - tie or y < pos[j, 1] - tie:
                    continue
                ok, x = _admit(x, y, r, i, j, pos, rad, cid, clo, chi, ns, width, periodic, reach, tol, best_y, best_x)
                if ok:
                    best_y = y
                    best_x = x
                    s0 = left
                    s1 = right
    if best_y == np.inf:
        # no pocket: every local minimum of the drop height is the end of an overhanging
        # arc (a small disk among much larger ones); the disk slides under the overhang to
        # the lowest wedge between a disk below and the single disk above it
        for e in range(ns):
            i = cid[e]
            if i < 0:
                continue
            xi_e = clo[e] + _mi(pos[i, 0] - clo[e], width, periodic)
            limit = xi_e + rad[i] + 2.0 * r + 2.0 * rmax
            f = e
            foff = 0.0
            fsteps = 0
            while True:
                f, foff = _step(f, foff, ns, width, periodic)
                fsteps += 1
                if f < 0 or fsteps >= ns or clo[f] + foff > limit:
                    break
                j = cid[f]
                if j < 0 or j == i:
                    continue
                for side in range(2):
                    ok, x, y, lo_k, hi_k = _wedge_candidate(i, j, r, pos, rad, width, periodic, side)
                    if not ok or y < r - tie:
                        continue
                    ok, x = _admit(x, y, r, i, j, pos, rad, cid, clo, chi, ns, width, periodic, reach, tol, best_y,
                                   best_x)
                    if ok:
                        best_y = y
                        best_x = x
                        s0 = lo_k
                        s1 = hi_k
    if best_y == np.inf:
        return False, -1, -1
    if not periodic:
        # a wall contact within round-off: keep the disk inside the box
        if best_x < r:
            best_x = r
        elif best_x > width - r:
            best_x = width - r
    res[0] = best_x
    res[1] = best_y
    return True, s0, s1


@njit(cache=True)
def deposit_disks(rad, n_fixed, k_stop, pos, support, params, cid, clo, chi, state):
    """Deposit disks ``state[N_PLACED]..k_stop-1`` in index order (resumable in chunks).

    Disks ``0..n_fixed-1`` are a fixed bed; the first call (``state[N_PLACED] == 0``)
    builds the chain from it, later calls continue from the chain left in
    ``cid, clo, chi`` and ``state[CHAIN_LEN]``.

    Parameters
    ----------
    rad : (N,) float64
        Radii in deposition order (bed first).
    n_fixed : int
        Number of bed disks, whose positions ``pos[:n_fixed]`` are given (no overlap,
        inside the box, ``y >= r``).
    k_stop : int
        Deposit up to (excluding) this index.
    pos : (N, 2) float64
        In: bed positions. Out: all centres (x in ``[0, W)`` when periodic).
    support : (N, 2) int64
        Out: the two supports of each deposited disk (see the module's support codes).
    params : (N_PARAMS,) float64
        See :class:`DepositParam`.
    cid, clo, chi : (capacity,) int64, float64, float64
        The chain (capacity ``>= 2 N + 8``), kept between calls.
    state : (N_STATE,) int64
        In/out: see :class:`DepositState` (all zero before the first call).

    Returns
    -------
    int
        A :class:`DepositStatus` code.
    """
    width = params[DepositParam.WIDTH]
    periodic = params[DepositParam.PERIODIC] != 0.0
    tol = params[DepositParam.TOL]
    rmax = params[DepositParam.RMAX]
    floor_rule = int(params[DepositParam.FLOOR_RULE])
    eps = 1e-14 * width
    if state[DepositState.N_PLACED] == 0:
        cid[0] = -1
        clo[0] = 0.0
        chi[0] = width
        ns = 1
        # bed: insert in order of increasing centre height (each is then above the others
        # in its columns, by the separating line of any non-overlapping pair)
        order = np.argsort(pos[:n_fixed, 1])
        for q in range(n_fixed):
            k = order[q]
            support[k, 0] = NO_SUPPORT
            support[k, 1] = NO_SUPPORT
            ns = _cover_disk(cid, clo, chi, ns, k, pos[k, 0], rad[k], width, periodic, eps)
            if ns < 0:
                return DepositStatus.CHAIN_FULL
        state[DepositState.N_PLACED] = n_fixed
        state[DepositState.CHAIN_LEN] = ns
        state[DepositState.CHAIN_MAX] = ns
    ns = state[DepositState.CHAIN_LEN]
    chain_max = state[DepositState.CHAIN_MAX]
    res = np.zeros(2)
    for k in range(state[DepositState.N_PLACED], k_stop):
        r = rad[k]
        found, s0, s1 = _place_one(k, r, pos, rad, cid, clo, chi, ns, width, periodic, rmax, tol, res, floor_rule)
        if not found:
            state[DepositState.N_PLACED] = k
            state[DepositState.CHAIN_LEN] = ns
            state[DepositState.CHAIN_MAX] = chain_max
            return DepositStatus.NO_POSITION
        pos[k, 0] = res[0]
        pos[k, 1] = res[1]
        support[k, 0] = s0
        support[k, 1] = s1
        ns = _cover_disk(cid, clo, chi, ns, k, res[0], r, width, periodic, eps)
        if ns < 0:
            state[DepositState.N_PLACED] = k
            return DepositStatus.CHAIN_FULL
        if ns > chain_max:
            chain_max = ns
        state[DepositState.N_PLACED] = k + 1
    state[DepositState.CHAIN_LEN] = ns
    state[DepositState.CHAIN_MAX] = chain_max
    return DepositStatus.OK


@njit(cache=True)
def _chord_integral(t, r):
    """``∫ sqrt(r^2 - t^2) dt`` (antiderivative at ``t``, ``|t| <= r``)."""
    if t >= r:
        return 0.25 * math.pi * r * r
    if t <= -r:
        return -0.25 * math.pi * r * r
    return 0.5 * (t * math.sqrt(r * r - t * t) + r * r * math.asin(t / r))


@njit(cache=True)
def disk_rectangle_area(xc, yc, r, x0, x1, y0, y1):
    """Exact area of the disk ``(xc, yc, r)`` inside the rectangle ``[x0, x1] x [y0, y1]``.

    The vertical chord at ``x`` is clipped to ``[y0, y1]``; between the abscissae where
    the circle crosses ``y = y0`` or ``y = y1`` the clipped chord has a fixed form
    (a constant or an arc), integrated in closed form.
    """
    a = max(x0, xc - r)
    b = min(x1, xc + r)
    if a >= b or y1 <= y0:
        return 0.0
    pts = np.empty(6)
    m = 0
    pts[m] = a
    m += 1
    for yb in (y0, y1):
        t = yb - yc
        if t > -r and t < r:
            w = math.sqrt(r * r - t * t)
            for xb in (xc - w, xc + w):
                if xb > a and xb < b:
                    pts[m] = xb
                    m += 1
    pts[m] = b
    m += 1
    # insertion sort
    for i in range(1, m):
        v = pts[i]
        j = i - 1
        while j >= 0 and pts[j] > v:
            pts[j + 1] = pts[j]
            j -= 1
        pts[j + 1] = v
    total = 0.0
    for q in range(m - 1):
        u = pts[q]
        v = pts[q + 1]
        if v <= u:
            continue
        mid = 0.5 * (u + v) - xc
        s = math.sqrt(max(r * r - mid * mid, 0.0))
        if yc + s <= y0 or yc - s >= y1:
            continue
        tu = u - xc
        tv = v - xc
        arc = _chord_integral(tv, r) - _chord_integral(tu, r)
        if yc + s > y1:
            top = y1 * (v - u)
        else:
            top = yc * (v - u) + arc
        if yc - s < y0:
            bot = y0 * (v - u)
        else:
            bot = yc * (v - u) - arc
        total += top - bot
    return total


@njit(cache=True)
def disks_rectangle_area(pos, rad, x0, x1, y0, y1, width, periodic):
    """Total area of disks inside ``[x0, x1] x [y0, y1]`` (periodic images along x if ``periodic``)."""
    total = 0.0
    for k in range(rad.shape[0]):
        x = pos[k, 0]
        y = pos[k, 1]
        r = rad[k]
        if y + r <= y0 or y - r >= y1:
            continue
        if periodic:
            for shift in (-width, 0.0, width):
                total += disk_rectangle_area(x + shift, y, r, x0, x1, y0, y1)
        else:
            total += disk_rectangle_area(x, y, r, x0, x1, y0, y1)
    return total


def warmup():
    """Compile the kernels of this module on a tiny input (four equal disks, both boundaries)."""
    rad = np.full(4, 0.5)
    for periodic in (0.0, 1.0):
        pos = np.zeros((4, 2))
        support = np.zeros((4, 2), np.int64)
        params = np.zeros(int(DepositParam.N_PARAMS))
        params[DepositParam.WIDTH] = 4.0
        params[DepositParam.PERIODIC] = periodic
        params[DepositParam.TOL] = 1e-10
        params[DepositParam.RMAX] = 0.5
        cap = 2 * 4 + 8
        state = np.zeros(int(DepositState.N_STATE), np.int64)
        deposit_disks(rad, 0, 4, pos, support, params, np.zeros(cap, np.int64), np.zeros(cap), np.zeros(cap), state)
        disks_rectangle_area(pos, rad, 0.0, 4.0, 0.0, 1.0, 4.0, periodic != 0.0)
