"""Sequential deposition of spheres by potential minimisation (3D), the 3D twin of :mod:`.deposit`.

Kernels for :func:`polypack.generate.deposit.deposit` with 3D sizes.  Spheres are placed one at
a time in a box with a floor ``z = 0``, an open top, and x, y axes that are periodic or have
walls at 0 and ``L``; each sphere goes to the lowest centre height ``z`` at which it rests
stably and which it can reach by a vertical drop from above.

Geometry
--------
A sphere of radius ``r`` dropped at ``(x, y)`` stops with its centre at the height of the
dilated envelope ``U_r(x, y) = max(r, max_k [z_k + sqrt((r + r_k)^2 - h_k^2)])`` (``h_k`` the
horizontal distance to sphere ``k``, the max over spheres with ``h_k < r + r_k``): a position is
reachable without overlap exactly when it lies on this envelope.  The envelope is a maximum of
concave caps, so its minima lie at its vertices, where three constraints meet.  The kernel
enumerates every vertex candidate: three spheres (the upper and lower intersection of the
spheres of radii ``r + r_k``), two spheres and a plane, one sphere and two planes, where the
planes are the floor ``z = r``, the walls ``x = r``, ``x = L - r`` (``y`` likewise) and, for the
tie rule only, the periodic seams ``x = 0``, ``y = 0``.  A candidate is accepted if it is on
the envelope (no sphere's dilated cap above it, relative tolerance ``tol``, floor and walls
respected) and **stable**: the vertical ``e_z`` lies in the cone of its contact normals
(``e_z = sum lambda_a n_a`` with ``lambda_a >= 0``; a floor contact is always stable).  The
sphere goes to the lowest accepted candidate.  If there is none (a small sphere whose every
pocket lies under an overhang), it goes to the lowest stable candidate free of overlaps with
every sphere placed, buried ones included (all-sphere cell grid of :mod:`.roll3d`; counted in
``state[N_OVERHANG]``).  If there is none either (large size ratios), it is dropped at the column
of the lowest reachable unstable vertex and rolls from there to a stable rest (drop-and-roll,
:func:`.roll3d.roll_one`; with walls it stays at that vertex, unsupported), counted in
``state[N_ROLLED]``.

**Tie rule**: candidates whose heights differ by at most ``tol * r`` are equal; the one with
the smallest ``x`` in ``[0, Lx)`` wins, then the smallest ``y``.  A bare floor therefore fills
from the corner ``(x, y) = (0, 0)`` (walls: ``(r, r)``) along ``x`` first.

Surface structure
-----------------
Only *alive* spheres are searched.  A fine column grid keeps ``cov``, a lower bound on the
drop envelope ``U_rmin`` of the smallest sphere on every column of each cell (the highest
single dilated cap ``z_k + sqrt((r_k + rmin)^2 - f^2)`` at the cell's farthest column).
Every dilated cap grows at least as fast as its radius, so ``U_r >= U_rmin + (r - rmin)``
for every ``r >= rmin``.  A sphere ``k`` is dead once the smallest ``cov`` over the columns
within ``r_k + r_max`` exceeds ``z_k + r_k + rmin``: a new sphere of radius ``r`` touching
``k`` would have its centre on one of those columns at a height of at most
``z_k + r_k + r``, below the envelope there.  A dead sphere is never touched again and is
never the highest cap of a column (the same inequality), which makes the envelope test
over alive spheres exact.  The alive spheres sit in a coarse grid of columns; each alive
sphere owns the candidates of which it is the highest sphere support (largest ``z``, then
largest index), which therefore lie at or above its centre.  Per new sphere the alive
spheres are searched in the order of a lower bound on their owned candidates (``cov``
plus ``r - rmin``; ``z_s`` where no bare floor is near; a cached result for the same
radius) and the search stops once the bound exceeds the best height found; each search
only looks at candidates below that best height (the best one owned, or the knowledge
that there is none below it, is cached until a sphere lands nearby).  The work per sphere
is proportional to the number of alive spheres (the surface, ~ ``Lx Ly / d^2``), not to
the number already placed.

Pruning (none of it changes the pack: ``SEARCH_ALL`` turns it off, and the tests compare):

* **Envelope levels**: besides ``cov`` for ``rmin``, the column grid keeps the same bound
  for ``COVER_LEVELS`` radii ``rho_j`` between ``rmin`` and ``rmax``; a sphere of radius
  ``r`` uses the highest ``rho_j <= r`` (``U_r >= U_rho_j + (r - rho_j)``, a much tighter
  bound than from ``rmin``) over the columns within ``r_s + rho_{j+1}`` of the owner.
* **Height window**: a thresholded search only wants candidates between ``z_s`` and the
  threshold; a neighbour whose dilated sphere meets the owner's on a circle outside that
  height range gives none (except on the floor) and is skipped before the pair loops.
* **Quick rejection**: a candidate is first tested against the owner and the neighbours
  already gathered for it (with twice the tolerance, so it only rejects what the full
  envelope test would reject) before the full test over the alive spheres.
* **One cache per radius** (issue 35): the best owned candidate (or "none below a bound") is
  kept per alive sphere and per radius class (:func:`make_cache`: one slot per distinct radius
  up to 16), so a bidisperse or discretised stream, which alternates radii, keeps the searches
  of every class; a slot of radius ``r_c`` is forgotten when a sphere of radius ``r`` lands
  within ``r_s + 2 r_c + r`` of its owner (the reach of a candidate plus that of a blocker).
* **The fallback pruned** (issue 35): the search under overhangs is thresholded, ordered and
  cached the same way (its caches are also forgotten when a neighbour dies, since only alive
  spheres support a fallback position), and the all-sphere overlap test allocates nothing.

Support codes (``support`` array, three per sphere): ``>= 0`` a sphere index, ``FLOOR``,
``WALL_X0``, ``WALL_X1``, ``WALL_Y0``, ``WALL_Y1``, ``NO_SUPPORT`` (a periodic seam used by the tie
rule, not a contact).
"""

from __future__ import annotations

import math
from enum import IntEnum

import numpy as np
from numba import njit

from .roll3d import grid_insert, grid_overlaps, roll_one

FLOOR = -1
WALL_X0 = -2
WALL_X1 = -3
WALL_Y0 = -4
WALL_Y1 = -5
NO_SUPPORT = -6
_SEAM_X = -7  # internal: periodic seam x = 0 (reported as NO_SUPPORT)
_SEAM_Y = -8

# fields of the per-radius candidate cache (cache_f[s, slot, :]) of deposit_spheres: the strict search
# (reachable by a vertical drop) first, then the search under overhangs (the fallback)
C_R = 0  # radius the strict fields are for (-1: invalid)
C_Z = 1  # best owned strict candidate z, x, y (z = inf: none below the bound)
C_B = 4  # lower bound on the owned strict candidates: the best height, or the threshold of the search
C_UZ = 5  # lowest reachable unstable point z, x, y (read only when C_B = inf: searched without threshold)
C_NR = 8  # radius the fallback fields are for; then best z, x, y and bound as for the strict fields
N_CACHE_F = 13
N_CACHE_I = 6  # supports of the best strict candidate, then of the best fallback candidate


class Deposit3DStatus(IntEnum):
    """Return codes of :func:`deposit_spheres`."""

    OK = 0
    NO_POSITION = 1  # no admissible position (never for valid input)
    GRID_FULL = 2  # the all-sphere grid's entry pool ran out (never: sized by make_grid_3d)


class Deposit3DParam(IntEnum):
    """Slots of the ``params`` array of :func:`deposit_spheres`."""

    LX = 0
    LY = 1
    PERIODIC_X = 2  # 1.0 periodic, 0.0 walls at 0 and LX
    PERIODIC_Y = 3
    TOL = 4  # relative tolerance of contact tests and of the tie rule
    RMAX = 5  # largest radius
    COLUMN_CELL = 6  # edge of the fine column grid of covered heights
    COVER_LEVELS = 7  # radius levels of the envelope bound used to order the searches (0: rmin only)
    SEARCH_ALL = 8  # 1.0: search every alive sphere in full for every sphere (the test oracle of the pruning)
    N_PARAMS = 9


class Deposit3DState(IntEnum):
    """Slots of the float ``state`` array (outputs, accumulated across calls)."""

    N_PLACED = 0
    N_ALIVE = 1  # alive spheres at the end
    ALIVE_MAX = 2  # most alive spheres seen
    N_OVERHANG = 3  # spheres placed by the overhang fallback
    N_RECOMPUTED = 4  # per-sphere candidate searches done
    N_IMPROVED = 5  # searches that found a candidate below the best one so far
    N_ROLLED = 6  # last resort: no stable overlap-free pocket; dropped at the lowest reachable point and rolled
    N_STATE = 7


@njit(cache=True)
def _mi(d, L, per):
    if per:
        if d > 0.5 * L:
            d -= L
        elif d < -0.5 * L:
            d += L
    return d


@njit(cache=True)
def _wrap(x, L, per):
    if per:
        x -= L * math.floor(x / L)
        if x >= L:
            x = 0.0
    return x


@njit(cache=True)
def _cell_of(x, y, h, nx, ny):
    cx = int(x / h[0])
    cy = int(y / h[1])
    if cx >= nx:
        cx = nx - 1
    if cx < 0:
        cx = 0
    if cy >= ny:
        cy = ny - 1
    if cy < 0:
        cy = 0
    return cx, cy


@njit(cache=True)
def _window(x, y, reach, hcell, ncx, ncy, per):
    """Ranges ``(x_lo, x_hi, y_lo, y_hi)`` of coarse cells within ``reach`` of the column ``(x, y)``.

    Indices may run past the grid on a periodic axis (take them modulo ``ncx``, ``ncy``);
    the whole axis when the window would wrap onto itself, clipped to the grid at walls.
    """
    rx = int(math.ceil(reach / hcell[0]))
    ry = int(math.ceil(reach / hcell[1]))
    cx, cy = _cell_of(x, y, hcell, ncx, ncy)
    x_lo, x_hi = cx - rx, cx + rx
    y_lo, y_hi = cy - ry, cy + ry
    if per[0]:
        if 2 * rx + 1 >= ncx:
            x_lo, x_hi = 0, ncx - 1
    else:
        x_lo, x_hi = max(x_lo, 0), min(x_hi, ncx - 1)
    if per[1]:
        if 2 * ry + 1 >= ncy:
            y_lo, y_hi = 0, ncy - 1
    else:
        y_lo, y_hi = max(y_lo, 0), min(y_hi, ncy - 1)
    return x_lo, x_hi, y_lo, y_hi


@njit(cache=True)
def _better(z, x, y, bz, bx, by, tolz):
    """Tie rule: lower by more than ``tolz``, or equal within it and smaller x, then smaller y."""
    if z < bz - tolz:
        return True
    if z > bz + tolz:
        return False
    if x < bx - 1e-12:
        return True
    if x > bx + 1e-12:
        return False
    return y < by


@njit(cache=True)
def _stable(p, r, s0, s1, s2, pos, L, per, tol, nrm):
    """Gravity in the cone of the contact normals (a floor contact is always stable)."""
    nrm[:, :] = 0.0
    m = 0
    for a in range(3):
        s = s0 if a == 0 else (s1 if a == 1 else s2)
        if s == FLOOR:
            return True
        if s >= 0:
            d0 = _mi(p[0] - pos[s, 0], L[0], per[0])
            d1 = _mi(p[1] - pos[s, 1], L[1], per[1])
            d2 = p[2] - pos[s, 2]
            dn = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            nrm[m, 0] = d0 / dn
            nrm[m, 1] = d1 / dn
            nrm[m, 2] = d2 / dn
            m += 1
        elif WALL_Y1 <= s <= WALL_X0:
            # walls push inwards: +x at x = 0 (WALL_X0), -x at x = L (WALL_X1), y alike
            nrm[m, 0 if s >= WALL_X1 else 1] = 1.0 if (s == WALL_X0 or s == WALL_Y0) else -1.0
            m += 1
    if m < 3:
        return False
    # solve N^T lambda = e_z (columns of N^T are the normals) by Cramer's rule
    a00, a01, a02 = nrm[0, 0], nrm[1, 0], nrm[2, 0]
    a10, a11, a12 = nrm[0, 1], nrm[1, 1], nrm[2, 1]
    a20, a21, a22 = nrm[0, 2], nrm[1, 2], nrm[2, 2]
    det = a00 * (a11 * a22 - a12 * a21) - a01 * (a10 * a22 - a12 * a20) + a02 * (a10 * a21 - a11 * a20)
    if abs(det) < 1e-12:
        return False
    # right-hand side (0, 0, 1)
    l0 = (a01 * a12 - a02 * a11) / det
    l1 = -(a00 * a12 - a02 * a10) / det
    l2 = (a00 * a11 - a01 * a10) / det
    return l0 >= -tol and l1 >= -tol and l2 >= -tol


@njit(cache=True)
def _admissible(p, r, s0, s1, s2, pos, rad, L, per, tol, strict, head, nxt, hcell, ncx, ncy, rmax, grid):
    """``strict``: on the envelope (reachable by a vertical drop); else only free of overlaps.

    Checks the floor, the walls and, ``strict``, every alive sphere whose column is within
    ``r + r_max`` (the envelope of the alive spheres is the envelope of all); not ``strict``
    (a pocket under an overhang, below the envelope), every sphere placed, buried ones
    included, from the all-sphere cell grid ``grid`` (:mod:`.roll3d`).
    """
    if p[2] < r * (1.0 - tol):
        return False
    if not per[0] and (p[0] < r * (1.0 - tol) or p[0] > L[0] - r * (1.0 - tol)):
        return False
    if not per[1] and (p[1] < r * (1.0 - tol) or p[1] > L[1] - r * (1.0 - tol)):
        return False
    if not strict:
        gd, ghead, gnext, gsph, gstamp, gcnt, gbuf, _gtops = grid
        return not grid_overlaps(p, r, pos, rad, gd, ghead, gnext, gsph, gstamp, gcnt, gbuf, tol)
    reach = r + rmax
    x_lo, x_hi, y_lo, y_hi = _window(p[0], p[1], reach, hcell, ncx, ncy, per)
    for qx in range(x_lo, x_hi + 1):
        ax = qx % ncx
        for qy in range(y_lo, y_hi + 1):
            ay = qy % ncy
            k = head[ax * ncy + ay]
            while k >= 0:
                # supports included: a support touched from below has its cap above p
                d0 = _mi(p[0] - pos[k, 0], L[0], per[0])
                d1 = _mi(p[1] - pos[k, 1], L[1], per[1])
                R = r + rad[k]
                h2 = d0 * d0 + d1 * d1
                if h2 < R * R:
                    d2 = p[2] - pos[k, 2]
                    if strict:
                        # on or above k's dilated cap: above its centre and outside its sphere
                        # (squared form: exact at an equator contact, where the cap is vertical);
                        # a column grazing the dilated footprint (h = R) is free
                        if h2 < R * R * (1.0 - tol) ** 2 and (d2 < -tol * R or h2 + d2 * d2 < R * R * (1.0 - tol) ** 2):
                            return False
                    elif h2 + d2 * d2 < R * R * (1.0 - tol) ** 2:
                        return False
                k = nxt[k]
    return True


@njit(cache=True)
def _blocked_near(o0, o1, o2, Rs, nb, m, nbh, mh, tol, strict):
    """Quick rejection of a candidate at ``o`` from the centre of its owner (dilated radius ``Rs``).

    The test of :func:`_admissible` for the owner and the neighbours already gathered around it
    (``nb``: lower, ``nbh``: higher, vectors from the owner, dilated radii), with twice the
    tolerance, so that a candidate rejected here is rejected there too (the difference of the two
    roundings of the vectors is ~1e-16, far below the tolerance).
    """
    t2 = (1.0 - 2.0 * tol) ** 2
    for q in range(-1, m + mh):
        if q < 0:
            d0, d1, d2, R = o0, o1, o2, Rs
        elif q < m:
            d0, d1, d2, R = o0 - nb[q, 0], o1 - nb[q, 1], o2 - nb[q, 2], nb[q, 3]
        else:
            w = q - m
            d0, d1, d2, R = o0 - nbh[w, 0], o1 - nbh[w, 1], o2 - nbh[w, 2], nbh[w, 3]
        h2 = d0 * d0 + d1 * d1
        if strict:
            if h2 < R * R * t2 and (d2 < -2.0 * tol * R or h2 + d2 * d2 < R * R * t2):
                return True
        elif h2 + d2 * d2 < R * R * t2:
            return True
    return False


@njit(cache=True)
def _offer(p, r, s0, s1, s2, pos, rad, L, per, tol, strict, head, nxt, hcell, ncx, ncy, rmax, best, bsup, nrm,
           owner, Rs, nb, m, nbh, mh, grid):
    """Test a candidate; keep it in ``best`` (z, x, y) / ``bsup`` if admissible, stable and better.

    ``owner`` (a sphere index, or -1) with ``Rs``, ``nb[:m]``, ``nbh[:mh]``: a quick rejection by
    :func:`_blocked_near` before the full envelope test.
    """
    o0 = p[0]
    o1 = p[1]
    o2 = p[2]
    p[0] = _wrap(p[0], L[0], per[0])
    p[1] = _wrap(p[1], L[1], per[1])
    if not _better(p[2], p[0], p[1], best[0], best[1], best[2], tol * r):
        return
    if owner >= 0 and _blocked_near(o0 - pos[owner, 0], o1 - pos[owner, 1], o2 - pos[owner, 2], Rs, nb, m, nbh, mh,
                                    tol, strict):
        return
    if not _admissible(p, r, s0, s1, s2, pos, rad, L, per, tol, strict, head, nxt, hcell, ncx, ncy, rmax, grid):
        return
    if not _stable(p, r, s0, s1, s2, pos, L, per, tol, nrm):
        if strict and best.shape[0] > 3 and p[2] < best[3]:
            # the lowest reachable point that is no stable rest (the last resort of deposit_spheres)
            best[3] = p[2]
            best[4] = p[0]
            best[5] = p[1]
        return
    best[0] = p[2]
    best[1] = p[0]
    best[2] = p[1]
    bsup[0] = s0
    bsup[1] = s1
    bsup[2] = s2


@njit(cache=True)
def _plane_value(code, r, L):
    """(axis, value) of a plane constraint for a sphere of radius r."""
    if code == FLOOR:
        return 2, r
    if code == WALL_X0:
        return 0, r
    if code == WALL_X1:
        return 0, L[0] - r
    if code == WALL_Y0:
        return 1, r
    if code == WALL_Y1:
        return 1, L[1] - r
    if code == _SEAM_X:
        return 0, 0.0
    return 1, 0.0  # _SEAM_Y


@njit(cache=True)
def _floor_rho2(R, zk, r):
    """Squared radius of the circle bounding, in the floor plane ``z = r``, where sphere ``k`` blocks the drop.

    Below the new centre level (``z_k < r``) it is the contact circle; above it the drop is
    blocked over the whole dilated footprint, so the floor is free from ``h = R`` on (the
    new sphere then grazes ``k``'s vertical tangent cylinder without touching it).
    """
    if zk >= r:
        return R * R
    return R * R - (r - zk) ** 2


@njit(cache=True)
def _report(code):
    return NO_SUPPORT if code <= _SEAM_X else code


@njit(cache=True)
def _candidates_of(s, r, pos, rad, L, per, tol, strict, planes, nplanes, head, nxt, hcell, ncx, ncy, rmax,
                   best, bsup, nb, nrm, thr, floor_ok, nbh, grid):
    """Best candidate owned by alive sphere ``s`` (the highest of its sphere supports), if below ``thr``.

    Only candidates lower than ``thr + tol * r`` are examined (``thr = inf``: all); if none
    is found ``best[1]`` stays ``inf``.  A sphere owns a candidate when it is the highest of
    its sphere supports (largest ``z``, then largest index), so every owned candidate lies
    at or above ``z_s`` (it is on the envelope, hence not below a support's centre).
    ``floor_ok = False`` skips the floor candidates (the caller knows the floor is covered
    near ``s``).  The periodic seams only enter with the floor: elsewhere a seam point
    lies on a ridge of the envelope (the intersection of two concave caps), never below
    the vertex at the ridge's end, so it cannot be a minimum or a tie.
    """
    best[0] = thr + 2.0 * tol * r if thr < np.inf else np.inf
    best[1] = np.inf
    best[2] = np.inf
    bsup[0] = NO_SUPPORT
    bsup[1] = NO_SUPPORT
    bsup[2] = NO_SUPPORT
    p = np.empty(3)
    base = np.empty(3)
    rel = np.empty(3)
    off = np.empty(3)
    Rs = r + rad[s]
    # lower neighbours (z, then index, below s's) that can touch the same new sphere (relative vectors to s)
    reach = rad[s] + rmax + 2.0 * r
    x_lo, x_hi, y_lo, y_hi = _window(pos[s, 0], pos[s, 1], reach, hcell, ncx, ncy, per)
    m = 0
    mh = 0  # higher neighbours: only for the quick rejection of candidates (_blocked_near)
    own = s if thr < np.inf else -1  # quick rejection and height window: thresholded searches only
    for qx in range(x_lo, x_hi + 1):
        ax = qx % ncx
        for qy in range(y_lo, y_hi + 1):
            ay = qy % ncy
            k = head[ax * ncy + ay]
            while k >= 0:
                lower = pos[k, 2] < pos[s, 2] or (pos[k, 2] == pos[s, 2] and k < s)
                if k != s:
                    d0 = _mi(pos[k, 0] - pos[s, 0], L[0], per[0])
                    d1 = _mi(pos[k, 1] - pos[s, 1], L[1], per[1])
                    d2 = pos[k, 2] - pos[s, 2]
                    lim = Rs + r + rad[k]
                    if d0 * d0 + d1 * d1 + d2 * d2 <= lim * lim:
                        if lower:
                            nb[m, 0] = d0
                            nb[m, 1] = d1
                            nb[m, 2] = d2
                            nb[m, 3] = r + rad[k]
                            nb[m, 4] = k
                            nb[m, 5] = 1.0
                            m += 1
                        else:
                            nbh[mh, 0] = d0
                            nbh[mh, 1] = d1
                            nbh[mh, 2] = d2
                            nbh[mh, 3] = r + rad[k]
                            mh += 1
                k = nxt[k]
    sx = pos[s, 0]
    sy = pos[s, 1]
    sz = pos[s, 2]
    if thr < np.inf:
        # height window of a candidate owned by s: below the threshold (within the tie tolerance)
        # and, strict, on the envelope, hence not below s's centre (by more than the grazing slack
        # of the admissibility test; a candidate under an overhang has no lower limit).  A
        # candidate on s and neighbour a lies on the circle where their dilated spheres meet: a
        # neighbour whose circle misses the window gives no candidate with s except on the floor
        # (marked nb[a, 5] = 0).
        zlo = sz - 4.0 * math.sqrt(tol) * Rs if strict else -np.inf
        zhi = thr + 4.0 * tol * r
        for a in range(m):
            d2a = nb[a, 0] * nb[a, 0] + nb[a, 1] * nb[a, 1] + nb[a, 2] * nb[a, 2]
            Ra = nb[a, 3]
            if d2a <= 0.0:
                continue
            da = math.sqrt(d2a)
            u = (Rs * Rs - Ra * Ra + d2a) / (2.0 * da)
            rho2 = Rs * Rs - u * u
            slack = 1e-9 * (Rs + Ra)
            if rho2 < -slack * Rs:
                nb[a, 5] = 0.0
                continue
            ez = nb[a, 2] / da
            half = math.sqrt(max(rho2, 0.0) * max(1.0 - ez * ez, 0.0))
            zc = sz + u * ez
            if zc + half < zlo - slack or zc - half > zhi + slack:
                nb[a, 5] = 0.0
    # --- three spheres: s, j, k
    for a in range(m):
        if nb[a, 5] == 0.0:
            continue
        ax_ = nb[a, 0]
        ay_ = nb[a, 1]
        az_ = nb[a, 2]
        Ra = nb[a, 3]
        d = math.sqrt(ax_ * ax_ + ay_ * ay_ + az_ * az_)
        if d <= 0.0 or d > Rs + Ra:
            continue
        ex0, ex1, ex2 = ax_ / d, ay_ / d, az_ / d
        for b in range(a + 1, m):
            if nb[b, 5] == 0.0:
                continue
            bx_ = nb[b, 0]
            by_ = nb[b, 1]
            bz_ = nb[b, 2]
            Rb = nb[b, 3]
            i_ = ex0 * bx_ + ex1 * by_ + ex2 * bz_
            t0 = bx_ - i_ * ex0
            t1 = by_ - i_ * ex1
            t2 = bz_ - i_ * ex2
            jn = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
            if jn < 1e-12 * (Rs + Ra + Rb):
                continue
            ey0, ey1, ey2 = t0 / jn, t1 / jn, t2 / jn
            ez0 = ex1 * ey2 - ex2 * ey1
            ez1 = ex2 * ey0 - ex0 * ey2
            ez2 = ex0 * ey1 - ex1 * ey0
            u = (Rs * Rs - Ra * Ra + d * d) / (2.0 * d)
            v = (Rs * Rs - Rb * Rb + i_ * i_ + jn * jn) / (2.0 * jn) - i_ * u / jn
            w2 = Rs * Rs - u * u - v * v
            if w2 < 0.0:
                continue
            w = math.sqrt(w2)
            for sg in (1.0, -1.0):
                p[0] = sx + u * ex0 + v * ey0 + sg * w * ez0
                p[1] = sy + u * ex1 + v * ey1 + sg * w * ez1
                p[2] = sz + u * ex2 + v * ey2 + sg * w * ez2
                if p[2] <= best[0] + tol * r:  # else not better than the best (_better): skip the call
                    _offer(p, r, s, int(nb[a, 4]), int(nb[b, 4]), pos, rad, L, per, tol, strict, head, nxt, hcell,
                           ncx, ncy, rmax, best, bsup, nrm, own, Rs, nb, m, nbh, mh, grid)
                if w == 0.0:
                    break
    # --- two spheres and a plane: s, j, plane
    for q in range(nplanes):
        code = planes[q]
        if code <= _SEAM_X or (code == FLOOR and not floor_ok):
            continue
        axis, val = _plane_value(code, r, L)
        o1 = (axis + 1) % 3
        o2 = (axis + 2) % 3
        if axis == 2:
            o1, o2 = 0, 1
        base[0] = sx
        base[1] = sy
        base[2] = sz
        ds = val - base[axis]
        if axis < 2:
            if per[axis]:
                ds = _mi(ds, L[axis], True)
        rho_s2 = Rs * Rs - ds * ds
        sup_s = s
        if code == FLOOR:
            rho_s2 = _floor_rho2(Rs, sz, r)
            if sz > r * (1.0 + tol):
                sup_s = NO_SUPPORT  # grazing, not a contact
        if rho_s2 < 0.0:
            continue
        for a in range(m):
            if code != FLOOR and nb[a, 5] == 0.0:
                continue
            rel[0] = nb[a, 0]
            rel[1] = nb[a, 1]
            rel[2] = nb[a, 2]
            Ra = nb[a, 3]
            da = ds - rel[axis]
            rho_a2 = Ra * Ra - da * da
            sup_a = int(nb[a, 4])
            if code == FLOOR:
                rho_a2 = _floor_rho2(Ra, sz + rel[2], r)
                if sz + rel[2] > r * (1.0 + tol):
                    sup_a = NO_SUPPORT
            if rho_a2 < 0.0:
                continue
            c1 = rel[o1]
            c2 = rel[o2]
            dd = math.sqrt(c1 * c1 + c2 * c2)
            if dd <= 0.0:
                continue
            u = (rho_s2 - rho_a2 + dd * dd) / (2.0 * dd)
            h2 = rho_s2 - u * u
            if h2 < 0.0:
                continue
            hh = math.sqrt(h2)
            for sg in (1.0, -1.0):
                off[axis] = ds
                off[o1] = (u * c1 - sg * hh * c2) / dd
                off[o2] = (u * c2 + sg * hh * c1) / dd
                p[0] = sx + off[0]
                p[1] = sy + off[1]
                p[2] = sz + off[2]
                if p[2] <= best[0] + tol * r:  # else not better than the best (_better): skip the call
                    _offer(p, r, sup_s, sup_a, code, pos, rad, L, per, tol, strict, head, nxt, hcell,
                           ncx, ncy, rmax, best, bsup, nrm, own, Rs, nb, m, nbh, mh, grid)
                if hh == 0.0:
                    break
    # --- one sphere and two planes: s, plane, plane
    for q1 in range(nplanes):
        for q2 in range(q1 + 1, nplanes):
            has_floor = planes[q1] == FLOOR or planes[q2] == FLOOR
            if has_floor and not floor_ok:
                continue
            if (planes[q1] <= _SEAM_X or planes[q2] <= _SEAM_X) and not has_floor:
                continue
            a1, v1 = _plane_value(planes[q1], r, L)
            a2, v2 = _plane_value(planes[q2], r, L)
            if a1 == a2:
                continue
            a3 = 3 - a1 - a2
            base[0] = sx
            base[1] = sy
            base[2] = sz
            dd1 = v1 - base[a1]
            dd2 = v2 - base[a2]
            if a1 < 2 and per[a1]:
                dd1 = _mi(dd1, L[a1], True)
            if a2 < 2 and per[a2]:
                dd2 = _mi(dd2, L[a2], True)
            rest = Rs * Rs - dd1 * dd1 - dd2 * dd2
            sup_s = s
            if planes[q1] == FLOOR or planes[q2] == FLOOR:
                other = dd2 if planes[q1] == FLOOR else dd1
                rest = _floor_rho2(Rs, sz, r) - other * other
                if sz > r * (1.0 + tol):
                    sup_s = NO_SUPPORT
            if rest < 0.0:
                continue
            rt = math.sqrt(rest)
            off[a1] = dd1
            off[a2] = dd2
            for sg in (1.0, -1.0):
                off[a3] = sg * rt
                p[0] = sx + off[0]
                p[1] = sy + off[1]
                p[2] = sz + off[2]
                if p[2] <= best[0] + tol * r:  # else not better than the best (_better): skip the call
                    _offer(p, r, sup_s, planes[q1], planes[q2], pos, rad, L, per, tol, strict, head, nxt, hcell,
                           ncx, ncy, rmax, best, bsup, nrm, own, Rs, nb, m, nbh, mh, grid)
                if rt == 0.0:
                    break


@njit(cache=True)
def _global_candidates(r, pos, rad, L, per, tol, strict, planes, nplanes, head, nxt, hcell, ncx, ncy, rmax,
                       best, bsup, nrm, grid):
    """Candidates without a sphere: three planes (the floor corner of the tie rule)."""
    best[0] = np.inf
    best[1] = np.inf
    best[2] = np.inf
    p = np.empty(3)
    for q1 in range(nplanes):
        for q2 in range(q1 + 1, nplanes):
            for q3 in range(q2 + 1, nplanes):
                a1, v1 = _plane_value(planes[q1], r, L)
                a2, v2 = _plane_value(planes[q2], r, L)
                a3, v3 = _plane_value(planes[q3], r, L)
                if a1 == a2 or a1 == a3 or a2 == a3:
                    continue
                p[a1] = v1
                p[a2] = v2
                p[a3] = v3
                _offer(p, r, planes[q1], planes[q2], planes[q3], pos, rad, L, per, tol, strict, head, nxt,
                       hcell, ncx, ncy, rmax, best, bsup, nrm, -1, 0.0, nrm, 0, nrm, 0, grid)


@njit(cache=True)
def _link(i, c, head, nxt, prv, cell):
    h0 = head[c]
    nxt[i] = h0
    prv[i] = -1
    if h0 >= 0:
        prv[h0] = i
    head[c] = i
    cell[i] = c


@njit(cache=True)
def _unlink(i, head, nxt, prv, cell):
    c = cell[i]
    p = prv[i]
    q = nxt[i]
    if p >= 0:
        nxt[p] = q
    else:
        head[c] = q
    if q >= 0:
        prv[q] = p
    nxt[i] = -1
    prv[i] = -1
    cell[i] = -1


@njit(cache=True)
def _level_radii(rmin, rmax, nlev):
    """Radii ``rho_j = rmin + j (rmax - rmin) / nlev`` of the envelope-bound levels and their reaches.

    A sphere of radius ``r`` uses the highest level with ``rho_j <= r`` (:func:`_level_of`);
    its candidates lie within ``r_s + r`` of their owner ``s``, at most ``r_s + reach_j``
    with ``reach_j = rho_{j+1}`` (``rmax`` for the top level).
    """
    rho = np.empty(max(nlev, 1))
    reach = np.empty(max(nlev, 1))
    for j in range(nlev):
        rho[j] = rmin + (rmax - rmin) * j / nlev
    for j in range(nlev):
        reach[j] = rho[j + 1] if j + 1 < nlev else rmax
    return rho, reach


@njit(cache=True)
def _level_of(r, rho, nlev):
    """Highest level ``j`` with ``rho_j <= r`` (``rho_0 = rmin <= r`` always)."""
    j = nlev - 1
    while j > 0 and rho[j] > r:
        j -= 1
    return j


@njit(cache=True)
def _cover_levels(p, r, covl, rho, nlev, hc, mx, my, L, per):
    """Raise the envelope lower bounds of the fine cells near a new sphere, every level at once.

    ``covl[c * nlev + j]`` is a lower bound on ``U_{rho_j}`` (the drop envelope of a sphere of
    radius ``rho_j``) on every column of cell ``c``.  A sphere at horizontal distance at most
    ``f`` from every column of the cell gives ``U_rho >= z + sqrt((r + rho)^2 - f^2)`` when
    ``f < r + rho``.  For any radius ``r' >= rho``, ``U_r' >= U_rho + (r' - rho)`` (each
    dilated cap ``sqrt(R^2 - h^2)`` grows at least as fast as ``R``), which makes the bound
    usable for every larger sphere.  One level ``rho = (rmin,)`` is the bound at ``rmin``
    that every sphere uses (``cov`` of :func:`deposit_spheres`).
    """
    R = r + rho[nlev - 1] * (1.0 - 1e-9)
    rx = int(math.ceil(R / hc[0])) + 1
    ry = int(math.ceil(R / hc[1])) + 1
    cx = int(p[0] / hc[0])
    cy = int(p[1] / hc[1])
    for qx in range(cx - rx, cx + rx + 1):
        if not per[0] and (qx < 0 or qx >= mx):
            continue
        ax = qx % mx
        dx = abs(_mi((ax + 0.5) * hc[0] - p[0], L[0], per[0])) + 0.5 * hc[0]
        if dx >= R:
            continue
        for qy in range(cy - ry, cy + ry + 1):
            if not per[1] and (qy < 0 or qy >= my):
                continue
            ay = qy % my
            dy = abs(_mi((ay + 0.5) * hc[1] - p[1], L[1], per[1])) + 0.5 * hc[1]
            f2 = dx * dx + dy * dy
            c = (ax * my + ay) * nlev
            for j in range(nlev):
                Rj = r + rho[j] * (1.0 - 1e-9)
                if f2 < Rj * Rj:
                    v = p[2] + math.sqrt(Rj * Rj - f2) * (1.0 - 1e-12)
                    if v > covl[c + j]:
                        covl[c + j] = v


@njit(cache=True)
def _min_cover_levels(k, pos, rad, covl, reach, nlev, hc, mx, my, L, per, out):
    """Smallest envelope bounds near sphere ``k``: ``out[j]`` = smallest ``covl`` level ``j`` within ``r_k + reach_j``.

    A candidate owned by ``k`` for a sphere of radius ``r`` at level ``j`` lies on one of these
    columns, on the envelope ``U_r >= U_{rho_j} + (r - rho_j)``, so ``out[j] + r - rho_j``
    bounds its height from below.  With the one level ``rmin`` and ``reach = (rmax,)``: a new
    sphere touching ``k`` has its centre within ``r_k + rmax``, so its height is at least
    ``out[0] + r - rmin``, and if ``out[0]`` exceeds ``z_k + r_k + rmin`` no sphere can ever
    touch ``k`` again (the highest centre touching it is ``z_k + r_k + r``): it is dead.
    """
    for j in range(nlev):
        out[j] = np.inf
    R = rad[k] + reach[nlev - 1]
    rx = int(math.ceil(R / hc[0])) + 1
    ry = int(math.ceil(R / hc[1])) + 1
    cx = int(pos[k, 0] / hc[0])
    cy = int(pos[k, 1] / hc[1])
    for qx in range(cx - rx, cx + rx + 1):
        if not per[0] and (qx < 0 or qx >= mx):
            continue
        ax = qx % mx
        dx = max(abs(_mi((ax + 0.5) * hc[0] - pos[k, 0], L[0], per[0])) - 0.5 * hc[0], 0.0)
        if dx > R:
            continue
        for qy in range(cy - ry, cy + ry + 1):
            if not per[1] and (qy < 0 or qy >= my):
                continue
            ay = qy % my
            dy = max(abs(_mi((ay + 0.5) * hc[1] - pos[k, 1], L[1], per[1])) - 0.5 * hc[1], 0.0)
            f2 = dx * dx + dy * dy
            c = (ax * my + ay) * nlev
            for j in range(nlev):
                Rj = rad[k] + reach[j]
                if f2 <= Rj * Rj and covl[c + j] < out[j]:
                    out[j] = covl[c + j]


@njit(cache=True)
def _forget_overhang(k, pos, rad, L, per, head, nxt, hcell, ncx, ncy, rmax, cache_f, slot_r, cmargin):
    """Invalidate the fallback caches of the alive spheres that may have had dead sphere ``k`` as a support.

    A neighbour ``k`` of owner ``s`` for radius ``r_c`` is within ``r_s + 2 r_c + r_k`` of it.
    """
    x_lo, x_hi, y_lo, y_hi = _window(pos[k, 0], pos[k, 1], rad[k] + 3.0 * rmax, hcell, ncx, ncy, per)
    for qx in range(x_lo, x_hi + 1):
        ax = qx % ncx
        for qy in range(y_lo, y_hi + 1):
            ay = qy % ncy
            s = head[ax * ncy + ay]
            while s >= 0:
                d0 = _mi(pos[s, 0] - pos[k, 0], L[0], per[0])
                d1 = _mi(pos[s, 1] - pos[k, 1], L[1], per[1])
                h2 = d0 * d0 + d1 * d1
                for c in range(cache_f.shape[1]):
                    if h2 <= (rad[s] + rad[k] + 2.0 * slot_r[c] + cmargin) ** 2:
                        cache_f[s, c, C_NR] = -1.0
                s = nxt[s]


@njit(cache=True)
def deposit_spheres(rad, params, pos, support, state, start, stop, work_f, work_i, cov, grid, slot_of, slot_r,
                    cache_f, cache_i):
    """Place spheres ``start .. stop-1`` (radii ``rad``, in order) on the deposit of spheres ``0 .. start-1``.

    Parameters
    ----------
    rad : (N,) float64
        Radii in deposition order.
    params : (N_PARAMS,) float64
        Slots of :class:`Deposit3DParam`.
    pos : (N, 3) float64, in/out
        Centres; rows ``< start`` are the deposit so far, rows ``start .. stop-1`` are written.
    support : (N, 3) int64, in/out
        Three support codes per sphere (see the module docstring).
    state : (N_STATE,) float64, in/out
        Slots of :class:`Deposit3DState`.
    start, stop : int
        Range to place (chunks let the caller show progress and stop on Ctrl-C).
    work_f : (N, 6 + COVER_LEVELS) float64, in/out
        Per-sphere cache: best owned candidate ``z, x, y`` (``z = inf``: none below the
        threshold of the search), the radius it is for, the envelope bound of
        :func:`_min_cover_levels` at ``rmin`` (radius-independent), and the cached lower bound for that radius
        (the best height, or the search threshold when none was found).  The spheres are
        searched in the order of a lower bound on their owned candidates (the envelope
        bound plus ``r - rmin``, ``z_s`` where no floor position is near, the cached
        bound), and the search stops once it exceeds the best height found.  Columns
        ``6 ..``: the envelope bound of every level (:func:`_min_cover_levels`).
    work_i : (N + ncx * ncy + N, ...) int64, in/out
        Packed integer state: see :func:`make_work`.
    cov : (mx * my * (1 + COVER_LEVELS),) float64, in/out
        Covered-height lower bound of the fine column grid: ``rmin`` first, then the levels
        interleaved per cell (``[mx * my + c * COVER_LEVELS + j]``).
    grid : tuple ``(gd, head, ent_next, ent_sph, stamp, counters, buf, tops)``
        The all-sphere cell grid of :mod:`.roll3d` (:func:`make_grid_3d`; spheres ``< start``
        registered), for the overlap test of the overhang fallback and the last-resort roll.
    slot_of, slot_r, cache_f, cache_i
        Per-radius candidate caches (:func:`make_cache`): the slot of each sphere's radius, the
        largest radius of each slot, and per alive sphere and slot the fields ``C_*`` (float) and
        the supports of the cached candidates (int).  Columns 0-3 and 5 of ``work_f`` are unused
        (the single cache before issue 35).

    Returns
    -------
    int
        :class:`Deposit3DStatus` code.
    """
    n = rad.shape[0]
    L = np.empty(2)
    L[0] = params[Deposit3DParam.LX]
    L[1] = params[Deposit3DParam.LY]
    per = np.empty(2, np.bool_)
    per[0] = params[Deposit3DParam.PERIODIC_X] > 0.5
    per[1] = params[Deposit3DParam.PERIODIC_Y] > 0.5
    tol = params[Deposit3DParam.TOL]
    rmax = params[Deposit3DParam.RMAX]
    hcol = params[Deposit3DParam.COLUMN_CELL]
    rmin = rad.min()
    ncx = max(1, int(L[0] // (2.0 * rmax)))
    ncy = max(1, int(L[1] // (2.0 * rmax)))
    hcell = np.array([L[0] / ncx, L[1] / ncy])
    mx = max(1, int(L[0] // hcol))
    my = max(1, int(L[1] // hcol))
    hc = np.array([L[0] / mx, L[1] / my])
    nlev = int(params[Deposit3DParam.COVER_LEVELS])
    search_all = params[Deposit3DParam.SEARCH_ALL] > 0.5
    rho, lreach = _level_radii(rmin, rmax, nlev)
    rho_min = np.full(1, rmin)  # the bound at rmin, used by every sphere: one level reaching rmax
    reach_max = np.full(1, rmax)
    cov0 = cov[:mx * my]
    covl = cov[mx * my:]
    # envelope-bound margin: a strict candidate may sit below a grazed cap by ~ sqrt(2 tol) R
    lmargin = 2.0 * math.sqrt(tol) * (2.0 * rmax) + tol * rmax
    # integer work layout: head (ncx*ncy) | nxt (n) | prv (n) | cell (n) | alive_list (n) | alive_pos (n)
    #                      | bsup (3n) | n_alive (1)
    o_head = 0
    o_nxt = ncx * ncy
    o_prv = o_nxt + n
    o_cell = o_prv + n
    o_al = o_cell + n
    o_ap = o_al + n
    o_bs = o_ap + n
    o_na = o_bs + 3 * n
    head = work_i[o_head:o_nxt]
    nxt = work_i[o_nxt:o_prv]
    prv = work_i[o_prv:o_cell]
    cell = work_i[o_cell:o_al]
    alive = work_i[o_al:o_ap]
    apos = work_i[o_ap:o_bs]
    bsup_all = work_i[o_bs:o_na].reshape((n, 3))
    n_alive = work_i[o_na]
    planes = np.empty(6, np.int64)
    nplanes = 0
    planes[nplanes] = FLOOR
    nplanes += 1
    for a in range(2):  # x then y: a periodic seam, or the two walls
        if per[a]:
            planes[nplanes] = _SEAM_X if a == 0 else _SEAM_Y
            nplanes += 1
        else:
            planes[nplanes] = WALL_X0 if a == 0 else WALL_Y0
            planes[nplanes + 1] = WALL_X1 if a == 0 else WALL_Y1
            nplanes += 2
    best = np.empty(6)
    bsup = np.empty(3, np.int64)
    gbest = np.empty(6)
    rstate = np.zeros(5)  # RollState of the last-resort rolls
    gsup = np.empty(3, np.int64)
    nb = np.empty((max(n, 16), 6))
    nbh = np.empty((max(n, 16), 4))
    nrm = np.zeros((3, 3))
    p = np.empty(3)
    nslots = cache_f.shape[1]
    cmargin = 1e-6 * rmax
    dead = np.empty(max(n, 1), np.int64)
    status = 0
    for i in range(start, stop):
        r = rad[i]
        c = slot_of[i]
        lev = _level_of(r, rho, nlev) if nlev > 0 else 0
        gbest[0] = np.inf
        gbest[1] = np.inf
        gbest[2] = np.inf
        gbest[3] = np.inf
        for strict in (True, False):
            _global_candidates(r, pos, rad, L, per, tol, strict, planes, nplanes, head, nxt, hcell, ncx, ncy, rmax,
                               gbest, gsup, nrm, grid)
            fo = C_R if strict else C_NR  # this pass's fields of the slot cache
            io = 0 if strict else 3
            # lower bound on each alive sphere's owned candidates for this radius
            keys = np.empty(n_alive)
            for q in range(n_alive):
                s = alive[q]
                if strict:
                    lb = work_f[s, 4] + (r - rmin)
                    if nlev > 0:
                        # the bound at the level of r: U_r >= U_rho + (r - rho) near s
                        lbl = work_f[s, 6 + lev] + (r - rho[lev]) - lmargin
                        if lbl > lb:
                            lb = lbl
                    if work_f[s, 4] > rmin + tol * rmin:
                        # no floor position near s: every owned candidate is at or above z_s
                        zb = pos[s, 2] - 2.0 * math.sqrt(tol) * (r + rad[s])
                        if zb > lb:
                            lb = zb
                else:
                    lb = r * (1.0 - tol)  # under an overhang: only the floor bounds a position
                if (strict or not search_all) and cache_f[s, c, fo] == r and cache_f[s, c, fo + 4] > lb:
                    # cached: the best owned height, or none below it (search_all: the order of the searches
                    # only, which decides between candidates equal within the tie tolerance, as before)
                    lb = cache_f[s, c, fo + 4]
                keys[q] = lb
            if search_all and not strict:
                order = np.arange(n_alive)
            else:
                order = np.argsort(keys)
            for qq in range(n_alive):
                s = alive[order[qq]]
                if not search_all and keys[order[qq]] > gbest[0] + tol * r:
                    break  # every remaining candidate lies above the best one
                valid = not search_all and cache_f[s, c, fo] == r
                if valid and cache_f[s, c, fo + 1] < np.inf:
                    best[0] = cache_f[s, c, fo + 1]
                    best[1] = cache_f[s, c, fo + 2]
                    best[2] = cache_f[s, c, fo + 3]
                    bsup[0] = cache_i[s, c, io]
                    bsup[1] = cache_i[s, c, io + 1]
                    bsup[2] = cache_i[s, c, io + 2]
                elif valid and cache_f[s, c, fo + 4] == np.inf:
                    # searched without a threshold since the last change near s: no owned candidate at all
                    best[1] = np.inf
                    if strict and cache_f[s, c, C_UZ] < gbest[3]:
                        gbest[3] = cache_f[s, c, C_UZ]
                        gbest[4] = cache_f[s, c, C_UZ + 1]
                        gbest[5] = cache_f[s, c, C_UZ + 2]
                else:
                    thr = gbest[0] + tol * r if not search_all else np.inf
                    floor_ok = (not strict) or search_all or work_f[s, 4] <= rmin + tol * rmin
                    best[3] = np.inf
                    _candidates_of(s, r, pos, rad, L, per, tol, strict, planes, nplanes, head, nxt, hcell, ncx,
                                   ncy, rmax, best, bsup, nb, nrm, thr, floor_ok, nbh, grid)
                    if best[3] < gbest[3]:
                        gbest[3] = best[3]
                        gbest[4] = best[4]
                        gbest[5] = best[5]
                    state[Deposit3DState.N_RECOMPUTED] += 1
                    if best[1] < np.inf:
                        state[Deposit3DState.N_IMPROVED] += 1
                    if strict or not search_all:
                        cache_f[s, c, fo] = r
                        if best[1] < np.inf:
                            cache_f[s, c, fo + 1] = best[0]
                            cache_f[s, c, fo + 2] = best[1]
                            cache_f[s, c, fo + 3] = best[2]
                            cache_f[s, c, fo + 4] = best[0]
                            cache_i[s, c, io] = bsup[0]
                            cache_i[s, c, io + 1] = bsup[1]
                            cache_i[s, c, io + 2] = bsup[2]
                        else:
                            cache_f[s, c, fo + 1] = np.inf
                            cache_f[s, c, fo + 4] = thr  # no owned candidate below thr
                            if strict:
                                # complete only without a threshold (thr = inf), the only case it is read
                                cache_f[s, c, C_UZ] = best[3]
                                cache_f[s, c, C_UZ + 1] = best[4]
                                cache_f[s, c, C_UZ + 2] = best[5]
                if best[1] < np.inf and _better(best[0], best[1], best[2], gbest[0], gbest[1], gbest[2], tol * r):
                    gbest[0] = best[0]
                    gbest[1] = best[1]
                    gbest[2] = best[2]
                    gsup[0] = bsup[0]
                    gsup[1] = bsup[1]
                    gsup[2] = bsup[2]
            if gbest[0] < np.inf:
                if not strict:
                    state[Deposit3DState.N_OVERHANG] += 1
                break
        if gbest[0] < np.inf:
            pos[i, 0] = gbest[1]
            pos[i, 1] = gbest[2]
            pos[i, 2] = gbest[0]
            for a in range(3):
                support[i, a] = _report(gsup[a])
        elif gbest[3] < np.inf and per[0] and per[1]:
            # last resort (large size ratios): no stable pocket, reachable or under an overhang, free of
            # overlaps; drop at the column of the lowest reachable point and roll from there (roll3d)
            roll_one(i, gbest[4], gbest[5], rad, pos, support, grid[0], grid[1], grid[2], grid[3], grid[7], grid[4],
                     grid[5], grid[6], rstate, tol)
            state[Deposit3DState.N_ROLLED] += 1
        elif gbest[3] < np.inf:
            # walls: rest at the lowest reachable point (on the envelope: no overlap), unsupported
            pos[i, 0] = gbest[4]
            pos[i, 1] = gbest[5]
            pos[i, 2] = gbest[3]
            for a in range(3):
                support[i, a] = NO_SUPPORT
            state[Deposit3DState.N_ROLLED] += 1
        else:
            status = 1
            state[Deposit3DState.N_PLACED] = i
            break
        if not grid_insert(i, pos, rad, grid[0], grid[1], grid[2], grid[3], grid[7], grid[5]):
            status = 2
            state[Deposit3DState.N_PLACED] = i
            break
        # surface update: cover, invalidate caches nearby, bury dead spheres, add the new one
        p[0] = pos[i, 0]
        p[1] = pos[i, 1]
        p[2] = pos[i, 2]
        _cover_levels(p, r, cov0, rho_min, 1, hc, mx, my, L, per)
        if nlev > 0:
            _cover_levels(p, r, covl, rho, nlev, hc, mx, my, L, per)
        cx, cy = _cell_of(p[0], p[1], hcell, ncx, ncy)
        _link(i, cx * ncy + cy, head, nxt, prv, cell)
        alive[n_alive] = i
        apos[i] = n_alive
        n_alive += 1
        for cc in range(nslots):
            cache_f[i, cc, C_R] = -1.0
            cache_f[i, cc, C_NR] = -1.0
        reach = r + 3.0 * rmax
        n_dead = 0
        reach_cov = r + 2.0 * rmax + 1.5 * (hc[0] + hc[1])
        x_lo, x_hi, y_lo, y_hi = _window(p[0], p[1], reach, hcell, ncx, ncy, per)
        for qx in range(x_lo, x_hi + 1):
            ax = qx % ncx
            for qy in range(y_lo, y_hi + 1):
                ay = qy % ncy
                k = head[ax * ncy + ay]
                while k >= 0:
                    k_next = nxt[k]
                    d0 = _mi(pos[k, 0] - p[0], L[0], per[0])
                    d1 = _mi(pos[k, 1] - p[1], L[1], per[1])
                    h2 = d0 * d0 + d1 * d1
                    for cc in range(nslots):
                        # a candidate of k for the slot's radius r_c lies within r_k + r_c of k, and
                        # the spheres that decide it within r_c + r_j of it: the new sphere matters
                        # within r_k + 2 r_c + r (as a support, a blocker or an overlap)
                        if h2 <= (rad[k] + r + 2.0 * slot_r[cc] + cmargin) ** 2:
                            cache_f[k, cc, C_R] = -1.0
                            cache_f[k, cc, C_NR] = -1.0
                    # the cells raised by _cover_levels lie within r + rmax of p; k's bounds read the
                    # cells within r_k + rmax of k: elsewhere they are unchanged
                    if h2 <= (rad[k] + reach_cov) ** 2:
                        _min_cover_levels(k, pos, rad, cov0, reach_max, 1, hc, mx, my, L, per, work_f[k, 4:5])
                        low = work_f[k, 4]
                        if nlev > 0:
                            _min_cover_levels(k, pos, rad, covl, lreach, nlev, hc, mx, my, L, per, work_f[k, 6:])
                        if low > pos[k, 2] + rad[k] + rmin:
                            dead[n_dead] = k
                            n_dead += 1
                            _unlink(k, head, nxt, prv, cell)
                            q = apos[k]
                            last = alive[n_alive - 1]
                            alive[q] = last
                            apos[last] = q
                            n_alive -= 1
                    k = k_next
        for q in range(n_dead):
            # a dead sphere no longer supports the positions under an overhang of its alive
            # neighbours (the fallback searches alive spheres only): forget them
            _forget_overhang(dead[q], pos, rad, L, per, head, nxt, hcell, ncx, ncy, rmax, cache_f, slot_r, cmargin)
        if n_alive > state[Deposit3DState.ALIVE_MAX]:
            state[Deposit3DState.ALIVE_MAX] = n_alive
        state[Deposit3DState.N_PLACED] = i + 1
    work_i[o_na] = n_alive
    state[Deposit3DState.N_ALIVE] = n_alive
    return status


def make_work(n, lx, ly, rmax, column_cell, levels=0):
    """Work arrays of :func:`deposit_spheres` for ``n`` spheres: ``(work_f, work_i, cov)``.

    ``levels`` must equal ``params[COVER_LEVELS]``.
    """
    ncx = max(1, int(lx // (2.0 * rmax)))
    ncy = max(1, int(ly // (2.0 * rmax)))
    mx = max(1, int(lx // column_cell))
    my = max(1, int(ly // column_cell))
    work_f = np.full((n, 6 + levels), -1.0)
    work_i = np.full(ncx * ncy + 8 * n + 1, -1, np.int64)
    work_i[-1] = 0
    cov = np.zeros(mx * my * (1 + levels))
    return work_f, work_i, cov


def make_cache(rad, max_slots=16, max_entries=2_000_000):
    """Per-radius candidate caches of :func:`deposit_spheres`: ``(slot_of, slot_r, cache_f, cache_i)``.

    One slot per distinct radius when there are at most ``max_slots`` of them (a bidisperse or
    discretised stream alternates radii; each keeps its own cached searches), at most
    ``max_entries`` slot rows in all; otherwise the radii share the slots (``slot_of`` = class
    modulo the number of slots; a slot serves the radius it was last filled for), one slot for a
    continuous distribution.  ``slot_r``: the largest radius a slot serves (its invalidation reach).
    """
    rad = np.asarray(rad, dtype=np.float64)
    n = max(rad.size, 1)
    uniq, cls = np.unique(rad, return_inverse=True)
    nslots = uniq.size if uniq.size <= max_slots else 1
    nslots = max(1, min(nslots, max_entries // n))
    slot_of = (cls % nslots).astype(np.int64)
    slot_r = np.zeros(nslots)
    np.maximum.at(slot_r, slot_of, rad)
    cache_f = np.full((n, nslots, N_CACHE_F), -1.0)
    cache_i = np.full((n, nslots, N_CACHE_I), NO_SUPPORT, np.int64)
    return slot_of, slot_r, cache_f, cache_i


def make_grid_3d(rad, lx, ly, periodic):
    """The all-sphere cell grid tuple of :func:`deposit_spheres` for the radii ``rad`` (all of them)."""
    from . import roll3d as kr

    rad = np.asarray(rad, dtype=np.float64)
    height = float(4.0 / 3.0 * np.pi * np.sum(rad**3) / (lx * ly * 0.5)) + 4.0 * float(rad.max())
    gd = kr.grid_layout(lx, ly, float(rad.min()), float(rad.max()), height, periodic)
    head, ent_next, ent_sph, tops, stamp, counters = kr.make_grid(rad.size, gd, kr.grid_capacity(rad, gd))
    return (gd, head, ent_next, ent_sph, stamp, counters, np.zeros(max(rad.size, 1), np.int64), tops)


def warmup():
    """Compile the kernel on a tiny input."""
    n = 30
    rad = np.full(n, 0.5)
    params = np.array([5.0, 5.0, 1.0, 0.0, 1e-10, 0.5, 0.25, 4.0, 0.0])
    pos = np.zeros((n, 3))
    support = np.zeros((n, 3), np.int64)
    state = np.zeros(Deposit3DState.N_STATE)
    work_f, work_i, cov = make_work(n, 5.0, 5.0, 0.5, 0.25, 4)
    deposit_spheres(rad, params, pos, support, state, 0, n, work_f, work_i, cov, make_grid_3d(rad, 5.0, 5.0, True),
                    *make_cache(rad))
