"""Monte-Carlo shaking kernels (§3.2 of 000_2cedc098acbd866b.txt).

Flat arrays in, flat arrays out.  One call runs ``n_sweeps`` global shakes (passes
over all spheres) of one of three move types:

``METHOD_PAPER`` (0)
    The seed's local shake: the centre is moved to a point uniform in the shake
    window of radius ``R_sh^(k) a_i``; a move is accepted if the sphere overlaps no
    other; otherwise it is retried, up to ``N_sh^(k)`` trials.
``METHOD_COLLISION`` (1)
    The collision-limited shake of Eq. (9) of 000_2cedc098acbd866b.txt: a random
    direction, the free flight to the first contact along it (smaller positive root
    of Eq. (9) of 000_2cedc098acbd866b.txt, minimum image), the best of ``N_sh`` directions, and an amplitude
    uniform in ``[0, min(free flight, R_sh a_i)]``.
``METHOD_METROPOLIS`` (2)
    Standard Metropolis for hard spheres: the paper move with exactly one trial
    (symmetric proposal, accept iff no overlap).

Neighbours: a Verlet list of all pairs with ``d_ij <= (1 + s)(r_i + r_j)`` built with
the size-aware cell kernel :func:`polypack._kernels.cells.pairs_within`.  Each
sphere's displacement since the last build is tracked; before a sphere is visited
the list is rebuilt if that displacement plus its largest possible step exceeds
``s r_i``.  Every accepted position therefore lies within ``s r_i`` of its build
position, so a pair missing from the list is farther apart than ``r_i + r_j`` for
every position a trial can reach: the overlap test against the list is exact, the
same answer as re-estimating the testing window ``r_t^(km)`` after every local
shake as the seed does.

Accepted positions satisfy ``d_ij^2 >= (1 + 1e-13) (r_i + r_j)^2`` against every
neighbour (a margin far below any physical gap that keeps round-off from turning
a touching pair into an overlap).

Random numbers: xoshiro256+ with an explicit ``(4,) uint64`` state updated in
place, seeded from a :class:`numpy.random.SeedSequence` by the caller, so a run is
reproducible bit for bit on one platform and independent of how the sweeps are
split into calls.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .cells import min_image, pairs_within
from .csr import pair_offsets

METHOD_PAPER = 0
METHOD_COLLISION = 1
METHOD_METROPOLIS = 2

ORDER_SEQUENTIAL = 0
ORDER_RANDOM = 1

#: Columns of the per-sweep, per-species statistics array.
ST_VISITS, ST_TRIALS, ST_ACCEPTED, ST_MOVED, ST_DISP, ST_FLIGHT, ST_GROW = range(7)
N_STATS = 7

CONTACT_MARGIN = 1e-13


# --------------------------------------------------------------------- RNG
@njit(cache=True)
def _rotl(x, k):
    return (x << np.uint64(k)) | (x >> np.uint64(64 - k))


@njit(cache=True)
def rng_next(s):
    """xoshiro256+ step: next 64-bit output, state ``s`` ((4,) uint64) updated in place."""
    result = s[0] + s[3]
    t = s[1] << np.uint64(17)
    s[2] ^= s[0]
    s[3] ^= s[1]
    s[1] ^= s[2]
    s[0] ^= s[3]
    s[2] ^= t
    s[3] = _rotl(s[3], 45)
    return result


@njit(cache=True)
def rng_uniform(s):
    """Uniform double in ``[0, 1)`` from the top 53 bits."""
    return float(rng_next(s) >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit(cache=True)
def _ball(s):
    """Uniform point in the unit ball (rejection from the cube)."""
    while True:
        x = 2.0 * rng_uniform(s) - 1.0
        y = 2.0 * rng_uniform(s) - 1.0
        z = 2.0 * rng_uniform(s) - 1.0
        r2 = x * x + y * y + z * z
        if r2 <= 1.0:
            return x, y, z, r2


@njit(cache=True)
def _direction(s):
    """Uniform unit vector."""
    while True:
        x, y, z, r2 = _ball(s)
        if r2 > 1e-12:
            inv = 1.0 / np.sqrt(r2)
            return x * inv, y * inv, z * inv


# -------------------------------------------------------- neighbour lists
@njit(cache=True)
def build_list(pos, radii, box, skin, ncell):
    """CSR Verlet list of all pairs with ``d_ij <= (1 + skin)(r_i + r_j)``: ``(start, idx)``."""
    n = pos.shape[0]
    pi, pj, pd = pairs_within(pos, radii, box, 1.0 + skin, 0.0, ncell)
    m = pi.shape[0]
    start, fill = pair_offsets(n, pi, pj)
    idx = np.empty(2 * m, np.int64)
    key = np.empty(2 * m, np.float64)
    for q in range(m):
        a = pi[q]
        b = pj[q]
        gap = pd[q] / (radii[a] + radii[b])
        idx[fill[a]] = b
        key[fill[a]] = gap
        fill[a] += 1
        idx[fill[b]] = a
        key[fill[b]] = gap
        fill[b] += 1
    # closest partners first: a rejected trial is found after fewer tests
    for i in range(n):
        for q in range(start[i] + 1, start[i + 1]):
            kq = key[q]
            jq = idx[q]
            p = q - 1
            while p >= start[i] and key[p] > kq:
                key[p + 1] = key[p]
                idx[p + 1] = idx[p]
                p -= 1
            key[p + 1] = kq
            idx[p + 1] = jq
    return start, idx


@njit(cache=True)
def _wrap1(x, length):
    if x >= length:
        x -= length
        if x >= length:
            x -= length * np.floor(x / length)
    elif x < 0.0:
        x += length
        if x < 0.0:
            x -= length * np.floor(x / length)
        if x >= length:  # -tiny + L rounds to L
            x = 0.0
    return x


@njit(cache=True, inline="always")  # numba-level inlining: as fast as written-out code
def _overlaps(j, x, y, z, ri, pos, radii, lx, ly, lz, fac):
    """True if sphere ``j`` overlaps a sphere of radius ``ri`` centred at ``(x, y, z)``
    (minimum image, ``|d| < L`` for wrapped positions; contact margin ``fac``)."""
    dx = pos[j, 0] - x
    dy = pos[j, 1] - y
    dz = pos[j, 2] - z
    dx -= lx * np.rint(dx / lx)
    dy -= ly * np.rint(dy / ly)
    dz -= lz * np.rint(dz / lz)
    sig = ri + radii[j]
    return dx * dx + dy * dy + dz * dz < sig * sig * fac


@njit(cache=True, inline="always")
def _contact_time(j, x, y, z, ux, uy, uz, ri, pos, radii, lx, ly, lz):
    """Distance along the unit vector ``u`` from ``(x, y, z)`` (radius ``ri``) to contact with
    sphere ``j``: the smaller positive root of ``|x + u t - x_j| = r_i + r_j`` (Eq. (9) of
    000_2cedc098acbd866b.txt), minimum image; ``inf`` if the path misses ``j`` or leads away."""
    wx = x - pos[j, 0]
    wy = y - pos[j, 1]
    wz = z - pos[j, 2]
    wx -= lx * np.rint(wx / lx)
    wy -= ly * np.rint(wy / ly)
    wz -= lz * np.rint(wz / lz)
    b = ux * wx + uy * wy + uz * wz
    sig = ri + radii[j]
    c = wx * wx + wy * wy + wz * wz - sig * sig
    disc = b * b - c
    t = c / (-b + np.sqrt(max(disc, 0.0)))  # stable form of the smaller root
    return t if (b < 0.0 and disc >= 0.0) else np.inf  # approaching and hitting


@njit(cache=True)
def _no_overlap(i, x, y, z, pos, radii, box, start, idx):
    """True if sphere ``i`` centred at ``(x, y, z)`` overlaps none of its listed neighbours."""
    ri = radii[i]
    fac = 1.0 + CONTACT_MARGIN
    lx = box[0]
    ly = box[1]
    lz = box[2]
    for q in range(start[i], start[i + 1]):
        if _overlaps(idx[q], x, y, z, ri, pos, radii, lx, ly, lz, fac):
            return False
    return True


@njit(cache=True)
def _free_flight(i, ux, uy, uz, pos, radii, box, start, idx):
    """Distance along the unit vector ``u`` to the first contact of sphere ``i``.

    Smaller positive root of ``|x_i + u t - x_j| = r_i + r_j`` (Eq. (9) of
    000_2cedc098acbd866b.txt) over the listed neighbours, minimum image; ``inf`` if
    no neighbour lies on the path.  A pair already in contact (round-off) that the
    move would close gives 0.  Written without data-dependent branches (half of the
    neighbours lie behind the direction of motion, an unpredictable branch).
    """
    x = pos[i, 0]
    y = pos[i, 1]
    z = pos[i, 2]
    ri = radii[i]
    lx = box[0]
    ly = box[1]
    lz = box[2]
    best = np.inf
    for q in range(start[i], start[i + 1]):
        best = min(best, _contact_time(idx[q], x, y, z, ux, uy, uz, ri, pos, radii, lx, ly, lz))
    return max(best, 0.0)



# ------------------------------------------------------------- cell links
@njit(cache=True)
def _cell_of(x, y, z, box, ncell):
    cx = int(x / box[0] * ncell[0])
    cy = int(y / box[1] * ncell[1])
    cz = int(z / box[2] * ncell[2])
    if cx >= ncell[0]:
        cx = ncell[0] - 1
    if cy >= ncell[1]:
        cy = ncell[1] - 1
    if cz >= ncell[2]:
        cz = ncell[2] - 1
    return (cx * ncell[1] + cy) * ncell[2] + cz


@njit(cache=True)
def build_links(pos, box, ncell):
    """Doubly linked cell lists ``(head, nxt, prv, cell)`` of wrapped positions."""
    n = pos.shape[0]
    nc = ncell[0] * ncell[1] * ncell[2]
    head = np.full(nc, -1, np.int64)
    nxt = np.full(n, -1, np.int64)
    prv = np.full(n, -1, np.int64)
    cell = np.empty(n, np.int64)
    for i in range(n):
        c = _cell_of(pos[i, 0], pos[i, 1], pos[i, 2], box, ncell)
        cell[i] = c
        nxt[i] = head[c]
        if head[c] >= 0:
            prv[head[c]] = i
        head[c] = i
    return head, nxt, prv, cell


@njit(cache=True)
def _relink(i, c, head, nxt, prv, cell):
    """Move sphere ``i`` to cell ``c`` (O(1))."""
    old = cell[i]
    if old == c:
        return
    if prv[i] >= 0:
        nxt[prv[i]] = nxt[i]
    else:
        head[old] = nxt[i]
    if nxt[i] >= 0:
        prv[nxt[i]] = prv[i]
    nxt[i] = head[c]
    prv[i] = -1
    if head[c] >= 0:
        prv[head[c]] = i
    head[c] = i
    cell[i] = c


@njit(cache=True)
def _no_overlap_cells(i, x, y, z, pos, radii, box, ncell, head, nxt):
    """As :func:`_no_overlap`, scanning the 27 cells around ``(x, y, z)`` (cell side >= 2 r_max)."""
    ri = radii[i]
    fac = 1.0 + CONTACT_MARGIN
    lx = box[0]
    ly = box[1]
    lz = box[2]
    c0 = _cell_of(x, y, z, box, ncell)
    cz0 = c0 % ncell[2]
    cy0 = (c0 // ncell[2]) % ncell[1]
    cx0 = c0 // (ncell[1] * ncell[2])
    for ox in range(-1, 2):
        cx = (cx0 + ox) % ncell[0]
        for oy in range(-1, 2):
            cy = (cy0 + oy) % ncell[1]
            for oz in range(-1, 2):
                cz = (cz0 + oz) % ncell[2]
                j = head[(cx * ncell[1] + cy) * ncell[2] + cz]
                while j >= 0:
                    if j != i and _overlaps(j, x, y, z, ri, pos, radii, lx, ly, lz, fac):
                        return False
                    j = nxt[j]
    return True


@njit(cache=True)
def _free_flight_cells(i, ux, uy, uz, pos, radii, box, ncell, head, nxt):
    """As :func:`_free_flight` over the 27 cells around sphere ``i`` (exact up to the window)."""
    x = pos[i, 0]
    y = pos[i, 1]
    z = pos[i, 2]
    ri = radii[i]
    lx = box[0]
    ly = box[1]
    lz = box[2]
    best = np.inf
    c0 = _cell_of(x, y, z, box, ncell)
    cz0 = c0 % ncell[2]
    cy0 = (c0 // ncell[2]) % ncell[1]
    cx0 = c0 // (ncell[1] * ncell[2])
    for ox in range(-1, 2):
        cx = (cx0 + ox) % ncell[0]
        for oy in range(-1, 2):
            cy = (cy0 + oy) % ncell[1]
            for oz in range(-1, 2):
                cz = (cz0 + oz) % ncell[2]
                j = head[(cx * ncell[1] + cy) * ncell[2] + cz]
                while j >= 0:
                    if j != i:
                        best = min(best, _contact_time(j, x, y, z, ux, uy, uz, ri, pos, radii, lx, ly, lz))
                    j = nxt[j]
    return max(best, 0.0)


# ------------------------------------------------------------------ sweeps
@njit(cache=True)
def shake_sweeps(pos, since, radii, species, box, rsh, start, idx, skin, ncell, method, order,
                 max_trials, n_sweeps, adapt, adapt_factor, rsh_min, rsh_max, rng, net, stats,
                 use_cells, cgrid, head, nxt, prv, cell):
    """Run ``n_sweeps`` global shakes in place.

    Parameters
    ----------
    pos : (N, 3) float64
        Centres in ``[0, L)``; updated in place (kept wrapped).
    since : (N, 3) float64
        Displacement of every sphere since the last list build; updated.
    radii : (N,) float64
    species : (N,) int64
    box : (3,) float64
    rsh : (K,) float64
        Shake radius ``R_sh^(k)`` per species, in units of the sphere radius;
        updated in place when ``adapt`` (paper and collision methods).
    start, idx : int64
        CSR neighbour list (from :func:`build_list` with the same ``skin``).
    skin : float
        Relative list skin ``s``; must be >= ``rsh_max``.
    ncell : (3,) int64
        Cell grid for rebuilds.
    method, order, max_trials : int
        Move type, sphere order (0 sequential, 1 random), ``N_sh`` per species
        ((K,) int64).
    n_sweeps : int
    adapt : bool
        Adapt ``R_sh`` per visit by comparing the free flight with ``R_sh a_i``
        (grow by ``1 + adapt_factor`` if larger, shrink otherwise), clipped to
        ``[rsh_min, rsh_max]``.
    rng : (4,) uint64
        xoshiro256+ state, advanced in place.
    net : (N, 3) float64
        Accumulated (unwrapped) displacement since the start of the run; updated.
    use_cells : bool
        Test against linked cell lists (``cgrid`` cells per axis, side at least
        ``2 r_max`` plus the largest step; ``head, nxt, prv, cell`` from
        :func:`build_links`, updated) instead of the Verlet list: better for
        large steps of similar spheres.  Same results either way.
    stats : (n_sweeps, K, 7) float64
        Output: visits, trials, accepted trials, spheres moved, sum of accepted
        ``|dx| / r_i``, sum of the free flight over ``r_i`` (collision/adaptive),
        visits whose free flight exceeded the window.

    Returns
    -------
    start, idx : the (possibly rebuilt) neighbour list
    rebuilds : int
    """
    n = pos.shape[0]
    rebuilds = 0
    for sweep in range(n_sweeps):
        for v in range(n):
            if order == 1:
                i = int(rng_uniform(rng) * n)
                if i >= n:
                    i = n - 1
            else:
                i = v
            k = species[i]
            ri = radii[i]
            step = rsh[k] * ri
            # keep the list exact for every position this visit can reach
            dsx = since[i, 0]
            dsy = since[i, 1]
            dsz = since[i, 2]
            if not use_cells and np.sqrt(dsx * dsx + dsy * dsy + dsz * dsz) + step > skin * ri:
                start, idx = build_list(pos, radii, box, skin, ncell)
                since[:, :] = 0.0
                rebuilds += 1
            st = stats[sweep, k]
            st[ST_VISITS] += 1.0
            x0 = pos[i, 0]
            y0 = pos[i, 1]
            z0 = pos[i, 2]
            moved = False
            dxa = 0.0
            dya = 0.0
            dza = 0.0
            if method == 1:
                # collision-limited amplitude, Eq. (9) of 000_2cedc098acbd866b.txt: best of N_sh directions
                bestf = -1.0
                bx = 0.0
                by = 0.0
                bz = 0.0
                for trial in range(max_trials[k]):
                    ux, uy, uz = _direction(rng)
                    if use_cells:
                        f = _free_flight_cells(i, ux, uy, uz, pos, radii, box, cgrid, head, nxt)
                    else:
                        f = _free_flight(i, ux, uy, uz, pos, radii, box, start, idx)
                    if f > bestf:
                        bestf = f
                        bx = ux
                        by = uy
                        bz = uz
                st[ST_TRIALS] += 1.0
                tau = bestf if bestf < step else step
                amp = rng_uniform(rng) * tau
                st[ST_FLIGHT] += (bestf if bestf < skin * ri else skin * ri) / ri
                if bestf > step:
                    st[ST_GROW] += 1.0
                if amp > 0.0:
                    dxa = bx * amp
                    dya = by * amp
                    dza = bz * amp
                    xn = _wrap1(x0 + dxa, box[0])
                    yn = _wrap1(y0 + dya, box[1])
                    zn = _wrap1(z0 + dza, box[2])
                    # short of the first contact by more than round-off: free by construction;
                    # otherwise test exactly
                    if bestf - amp > 1e-9 * ri:
                        free = True
                    elif use_cells:
                        free = _no_overlap_cells(i, xn, yn, zn, pos, radii, box, cgrid, head, nxt)
                    else:
                        free = _no_overlap(i, xn, yn, zn, pos, radii, box, start, idx)
                    if free:
                        pos[i, 0] = xn
                        pos[i, 1] = yn
                        pos[i, 2] = zn
                        moved = True
                        st[ST_ACCEPTED] += 1.0
                        st[ST_DISP] += amp / ri
                if adapt:
                    if bestf > step:
                        rsh[k] *= 1.0 + adapt_factor
                    else:
                        rsh[k] /= 1.0 + adapt_factor
            else:
                ntr = 1 if method == 2 else max_trials[k]
                f = np.inf
                for trial in range(ntr):
                    bx, by, bz, r2 = _ball(rng)
                    dxa = bx * step
                    dya = by * step
                    dza = bz * step
                    st[ST_TRIALS] += 1.0
                    if adapt and trial == 0:
                        if r2 > 1e-24:
                            inv = 1.0 / np.sqrt(r2)
                            if use_cells:
                                f = _free_flight_cells(i, bx * inv, by * inv, bz * inv, pos, radii, box, cgrid,
                                                       head, nxt)
                            else:
                                f = _free_flight(i, bx * inv, by * inv, bz * inv, pos, radii, box, start, idx)
                        st[ST_FLIGHT] += (f if f < skin * ri else skin * ri) / ri
                        if f > step:
                            st[ST_GROW] += 1.0
                    xn = _wrap1(x0 + dxa, box[0])
                    yn = _wrap1(y0 + dya, box[1])
                    zn = _wrap1(z0 + dza, box[2])
                    if use_cells:
                        free = _no_overlap_cells(i, xn, yn, zn, pos, radii, box, cgrid, head, nxt)
                    else:
                        free = _no_overlap(i, xn, yn, zn, pos, radii, box, start, idx)
                    if free:
                        pos[i, 0] = xn
                        pos[i, 1] = yn
                        pos[i, 2] = zn
                        moved = True
                        st[ST_ACCEPTED] += 1.0
                        st[ST_DISP] += np.sqrt(r2) * rsh[k]
                        break
                if adapt:
                    # the seed's rule: compare the free flight with the window
                    if f > step:
                        rsh[k] *= 1.0 + adapt_factor
                    else:
                        rsh[k] /= 1.0 + adapt_factor
            if adapt:
                if rsh[k] > rsh_max:
                    rsh[k] = rsh_max
                elif rsh[k] < rsh_min:
                    rsh[k] = rsh_min
            if moved:
                if use_cells:
                    _relink(i, _cell_of(pos[i, 0], pos[i, 1], pos[i, 2], box, cgrid), head, nxt, prv, cell)
                st[ST_MOVED] += 1.0
                since[i, 0] += dxa
                since[i, 1] += dya
                since[i, 2] += dza
                net[i, 0] += dxa
                net[i, 1] += dya
                net[i, 2] += dza
    return start, idx, rebuilds


@njit(cache=True)
def min_list_gap(pos, radii, box, start, idx):
    """Smallest ``d_ij^2 / (r_i + r_j)^2 - 1`` over the listed pairs (debugging aid)."""
    best = np.inf
    n = pos.shape[0]
    for i in range(n):
        for q in range(start[i], start[i + 1]):
            j = idx[q]
            dx = min_image(pos[j, 0] - pos[i, 0], box[0])
            dy = min_image(pos[j, 1] - pos[i, 1], box[1])
            dz = min_image(pos[j, 2] - pos[i, 2], box[2])
            sig = radii[i] + radii[j]
            g = (dx * dx + dy * dy + dz * dz) / (sig * sig) - 1.0
            if g < best:
                best = g
    return best


def warmup():
    """Compile the kernels of this module on a tiny input (a simple cubic lattice).

    ``radii``, ``species`` and ``box`` are read-only, as :func:`polypack.shake` passes a
    Packing's arrays: numba compiles a separate version for writable arrays, which a
    study's first run would otherwise compile again in every worker (issue 33).
    """
    g = np.arange(3, dtype=np.float64) + 0.5
    pos = np.array([[x, y, z] for x in g for y in g for z in g], dtype=np.float64) * 2.0
    n = pos.shape[0]
    radii = np.full(n, 0.4)
    species = np.zeros(n, np.int64)
    box = np.full(3, 6.0)
    for a in (radii, species, box):
        a.setflags(write=False)
    ncell = np.array([2, 2, 2], np.int64)
    skin = 0.5
    start, idx = build_list(pos, radii, box, skin, ncell)
    rng = np.array([1, 2, 3, 4], dtype=np.uint64)
    cgrid = np.array([3, 3, 3], np.int64)
    for method in (0, 1, 2):
        for adapt in (False, True):
            for use_cells in (False, True):
                stats = np.zeros((1, 1, N_STATS))
                head, nxt, prv, cell = build_links(pos, box, cgrid)
                shake_sweeps(pos, np.zeros((n, 3)), radii, species, box, np.array([0.1]), start, idx, skin, ncell,
                             method, method % 2, np.array([3], np.int64), 1, adapt, 0.05, 1e-4, skin, rng,
                             np.zeros((n, 3)), stats, use_cells, cgrid, head, nxt, prv, cell)
