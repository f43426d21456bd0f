"""Event-driven molecular dynamics of growing hard spheres (Lubachevsky–Stillinger).

Kernels for :mod:`polypack.generate.lubachevsky`.  All lengths and times are in
internal units: the mean radius at the reference time is 1, the thermal speed
``sqrt(kT/m)`` is 1 (unit masses), and sphere ``i`` has radius ``g[i] * t`` at
time ``t`` (proportional growth ``a^(k)(t) = a_0^(k) t`` of §3.1 of
000_2cedc098acbd866b.txt).

Data layout (flat arrays, C-like):

* ``x`` (N,3) positions at the particle's own time ``tl[i]`` (lazy update),
  unwrapped between neighbour-list rebuilds and folded into the box at each
  rebuild (so there is no drift of periodic images);
* ``v`` (N,3) velocities; ``cnt[i]`` collision counter for invalidation;
* one scheduled event per sphere (``ev_t``, ``ev_p`` partner or -1 for a shell
  exit, ``ev_c`` partner counter at prediction time) in an indexed binary
  min-heap;
* neighbour lists in CSR form built by the size-aware cell search
  :func:`polypack._kernels.cells.pairs_within` with the criterion
  ``d_ij <= r_i + r_j + delta_i + delta_j``, ``delta_i = c g_i`` (a shell
  proportional to the radius, so the cost per collision does not depend on the
  size ratio of the neighbours a small sphere sees).  A sphere's list stays valid
  while its displacement plus growth since the build is below ``delta_i``; the
  first sphere to use up its shell triggers a rebuild (full synchronisation).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .cells import min_image, pairs_within

INF = np.inf

# status codes returned by run_chunk
CHUNK_DONE = 0  # collision budget of the chunk used up
REACHED_T_STOP = 1
JAMMED = 2
BOX_LIMIT = 3
EVENT_BUDGET = 4


@njit(cache=True)
def pair_time(dx, dy, dz, dvx, dvy, dvz, G, sig0):
    """Smallest ``s >= 0`` with ``|dr + dv s| = sig0 + G s`` while approaching.

    Eq. (8) of 000_2cedc098acbd866b.txt with ``sig0 = (a_0^(k) + a_0^(m)) t`` and
    ``G = a_0^(k) + a_0^(m)``.  Written as ``A s^2 + 2 B s + C = 0`` with
    ``A = dv^2 - G^2``, ``B = dr.dv - sig0 G``, ``C = dr^2 - sig0^2``; the root is
    taken in the cancellation-free form.  Returns ``inf`` when they never meet.
    """
    A = dvx * dvx + dvy * dvy + dvz * dvz - G * G
    B = dx * dvx + dy * dvy + dz * dvz - sig0 * G
    C = dx * dx + dy * dy + dz * dz - sig0 * sig0
    if B < 0.0:
        # contact distance shrinking now
        if C <= 0.0:
            return 0.0
        D = B * B - A * C
        if D < 0.0:
            return INF
        return C / (-B + math.sqrt(D))
    # separating now: they meet again only if growth outruns the relative speed
    if A >= 0.0:
        return INF
    D = B * B - A * C
    if D < 0.0:
        D = 0.0
    return (B + math.sqrt(D)) / (-A)


@njit(cache=True)
def _sift_up(heap, hpos, key, k):
    i = heap[k]
    ki = key[i]
    while k > 0:
        p = (k - 1) >> 1
        j = heap[p]
        if key[j] <= ki:
            break
        heap[k] = j
        hpos[j] = k
        k = p
    heap[k] = i
    hpos[i] = k


@njit(cache=True)
def _sift_down(heap, hpos, key, k, n):
    i = heap[k]
    ki = key[i]
    while True:
        c = 2 * k + 1
        if c >= n:
            break
        if c + 1 < n and key[heap[c + 1]] < key[heap[c]]:
            c += 1
        j = heap[c]
        if key[j] >= ki:
            break
        heap[k] = j
        hpos[j] = k
        k = c
    heap[k] = i
    hpos[i] = k


@njit(cache=True)
def _heap_update(heap, hpos, key, i, n):
    k = hpos[i]
    _sift_up(heap, hpos, key, k)
    _sift_down(heap, hpos, key, hpos[i], n)


@njit(cache=True)
def _choose_ncell(box, n, reach_small):
    vol = box[0] * box[1] * box[2]
    h = max(reach_small, (vol / max(2 * n, 1)) ** (1.0 / 3.0), 1e-300)
    nc = np.empty(3, np.int64)
    for k in range(3):
        nc[k] = max(1, int(math.floor(box[k] / h)))
    while nc[0] * nc[1] * nc[2] > 4 * n + 27:
        for k in range(3):
            nc[k] = max(1, nc[k] // 2)
    return nc


@njit(cache=True)
def build_lists(x, g, box, t, c):
    """CSR neighbour lists: pairs with ``d_ij <= (g_i + g_j)(t + c)``, both directions."""
    n = x.shape[0]
    a = t + c
    gs = np.sort(g)
    reach_small = 2.0 * a * gs[n // 2]
    nc = _choose_ncell(box, n, reach_small)
    pi, pj, _ = pairs_within(x, g, box, a, 0.0, nc)
    m = pi.shape[0]
    start = np.zeros(n + 1, np.int64)
    for k in range(m):
        start[pi[k] + 1] += 1
        start[pj[k] + 1] += 1
    for i in range(n):
        start[i + 1] += start[i]
    fill = start[:n].copy()
    nbr = np.empty(2 * m, np.int64)
    for k in range(m):
        i = pi[k]
        j = pj[k]
        nbr[fill[i]] = j
        fill[i] += 1
        nbr[fill[j]] = i
        fill[j] += 1
    return start, nbr


@njit(cache=True)
def _predict(i, t, x, v, tl, g, box, start, nbr, xb, tb, c, cnt, ev_t, ev_p, ev_c):
    """Sync sphere ``i`` to ``t`` and schedule its next event (collision or shell exit)."""
    dt = t - tl[i]
    xi0 = x[i, 0] + v[i, 0] * dt
    xi1 = x[i, 1] + v[i, 1] * dt
    xi2 = x[i, 2] + v[i, 2] * dt
    x[i, 0] = xi0
    x[i, 1] = xi1
    x[i, 2] = xi2
    tl[i] = t
    vi0 = v[i, 0]
    vi1 = v[i, 1]
    vi2 = v[i, 2]
    gi = g[i]
    # shell exit, lower bound: remaining / (|v| + g)
    d0 = xi0 - xb[i, 0]
    d1 = xi1 - xb[i, 1]
    d2 = xi2 - xb[i, 2]
    rem = c * gi - gi * (t - tb) - math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    speed = math.sqrt(vi0 * vi0 + vi1 * vi1 + vi2 * vi2) + gi
    best = INF
    if speed > 0.0:
        best = max(rem, 0.0) / speed
    partner = -1
    for k in range(start[i], start[i + 1]):
        j = nbr[k]
        dtj = t - tl[j]
        dx = min_image(x[j, 0] + v[j, 0] * dtj - xi0, box[0])
        dy = min_image(x[j, 1] + v[j, 1] * dtj - xi1, box[1])
        dz = min_image(x[j, 2] + v[j, 2] * dtj - xi2, box[2])
        G = gi + g[j]
        s = pair_time(dx, dy, dz, v[j, 0] - vi0, v[j, 1] - vi1, v[j, 2] - vi2, G, G * t)
        if s < best:
            best = s
            partner = j
    ev_t[i] = t + best
    ev_p[i] = partner
    if partner >= 0:
        ev_c[i] = cnt[partner]
    else:
        ev_c[i] = 0


@njit(cache=True)
def _sync_all(x, v, tl, t):
    n = x.shape[0]
    for i in range(n):
        dt = t - tl[i]
        for k in range(3):
            x[i, k] += v[i, k] * dt
        tl[i] = t


@njit(cache=True)
def _wrap(x, box):
    n = x.shape[0]
    for i in range(n):
        for k in range(3):
            L = box[k]
            y = x[i, k]
            if y < 0.0 or y >= L:
                y -= L * math.floor(y / L)
                if y >= L:
                    y -= L
                if y < 0.0:
                    y = 0.0
                x[i, k] = y


@njit(cache=True)
def kinetic_energy(v):
    e = 0.0
    for i in range(v.shape[0]):
        e += v[i, 0] * v[i, 0] + v[i, 1] * v[i, 1] + v[i, 2] * v[i, 2]
    return 0.5 * e


@njit(cache=True)
def _thermalise(v):
    """Remove net momentum and rescale to kinetic energy 3N/2 (kT = 1, m = 1)."""
    n = v.shape[0]
    for k in range(3):
        s = 0.0
        for i in range(n):
            s += v[i, k]
        s /= n
        for i in range(n):
            v[i, k] -= s
    ke = kinetic_energy(v)
    if ke > 0.0:
        f = math.sqrt(1.5 * n / ke)
        for i in range(n):
            for k in range(3):
                v[i, k] *= f


@njit(cache=True)
def shell_width(t, g, box, c_ref_total, alpha):
    """``c`` such that ``delta_i = c g_i``; neighbour reach ``(g_i+g_j)(t+c)``.

    ``c = max(c_ref_total - t, alpha t)`` keeps the absolute reach constant while
    the spheres are small, capped so that ``2 (r_max + delta_max) < L/2``.  Returns
    a value <= 0 when the largest sphere is about to exceed a quarter of the box.
    """
    gmax = 0.0
    for i in range(g.shape[0]):
        if g[i] > gmax:
            gmax = g[i]
    c = max(c_ref_total - t, alpha * t)
    lmin = min(box[0], min(box[1], box[2]))
    cap = 0.249 * lmin / gmax - t
    if c > cap:
        c = cap
    return c


@njit(cache=True)
def run_chunk(x, v, g, box, state, params, hist):
    """Advance the growing hard-sphere system by up to ``params[1]`` collisions.

    Parameters
    ----------
    x, v : (N, 3) float64
        Positions (all at time ``state[0]``) and velocities; updated in place and
        left synchronised at the returned time, positions folded into the box.
    g : (N,) float64
        Growth speeds: radius ``g_i t``.
    box : (3,) float64
    state : (8,) float64, in/out
        ``[t, collisions, events, rebuilds, virial_sum, ke_time_integral,
        window_collisions, status]`` (the first six accumulate across chunks).
    params : (8,) float64
        ``[t_stop, max_collisions_this_chunk, max_pressure, pressure_window,
        c_ref_total, alpha, max_events_this_chunk, unused]``.
    hist : (H, 3) float64
        Output rows ``(t, reduced pressure, window length)``; ``state[6]`` (the
        window position) and the number of rows written are carried in
        ``hist[0, :]``...  Use :func:`run_chunk` via the Python driver.

    Returns
    -------
    (status, n_hist) : status code and number of pressure windows written to ``hist``.

    Notes
    -----
    Collision rule (equal masses): with ``n`` the unit vector from ``i`` to ``j``
    at contact, ``u = (v_j - v_i).n`` and ``G = g_i + g_j`` the growth speed of the
    contact distance, the normal relative velocity is reflected in the frame of
    the growing surfaces, ``u' - G = -(u - G)``.  The impulse ``J = G - u > 0`` is
    given to ``j`` along ``n`` and taken from ``i``: momentum is conserved, the
    pair separates faster than the contact distance grows, and the kinetic energy
    rises by ``J G``.  The energy is reset to ``3N/2`` (thermal speed 1) with the
    net momentum removed at every full synchronisation (start of a chunk and each
    neighbour-list rebuild).  Reduced pressure over a window of collisions:
    ``Z = PV/(N kT) = 1 + sum(J sigma) / (2 integral(KE dt))``.
    """
    n = x.shape[0]
    t = state[0]
    t_stop = params[0]
    max_coll = int(params[1])
    p_max = params[2]
    window = int(params[3])
    c_ref_total = params[4]
    alpha = params[5]
    max_events = int(params[6])

    tl = np.full(n, t)
    cnt = np.zeros(n, np.int64)
    ev_t = np.empty(n)
    ev_p = np.empty(n, np.int64)
    ev_c = np.empty(n, np.int64)
    heap = np.empty(n, np.int64)
    hpos = np.empty(n, np.int64)
    xb = np.empty((n, 3))

    n_hist = 0
    h_cap = hist.shape[0]
    status = CHUNK_DONE
    coll = 0
    events = 0
    w_coll = 0
    w_vir = 0.0
    w_ke = 0.0
    t_last = t
    ke = 0.0
    need_rebuild = True
    start = np.zeros(n + 1, np.int64)
    nbr = np.zeros(0, np.int64)
    tb = t
    c = 0.0

    while True:
        if need_rebuild:
            _sync_all(x, v, tl, t)
            # energy integral up to now with the pre-rescale energy
            ke = kinetic_energy(v)
            w_ke += ke * (t - t_last)
            t_last = t
            _wrap(x, box)
            _thermalise(v)
            ke = kinetic_energy(v)
            c = shell_width(t, g, box, c_ref_total, alpha)
            if c <= 1e-9 * max(t, 1e-300):
                status = BOX_LIMIT
                break
            tb = t
            for i in range(n):
                for k in range(3):
                    xb[i, k] = x[i, k]
            start, nbr = build_lists(x, g, box, t, c)
            for i in range(n):
                cnt[i] = 0
            for i in range(n):
                _predict(i, t, x, v, tl, g, box, start, nbr, xb, tb, c, cnt, ev_t, ev_p, ev_c)
                heap[i] = i
                hpos[i] = i
            for k in range(n // 2 - 1, -1, -1):
                _sift_down(heap, hpos, ev_t, k, n)
            state[3] += 1
            need_rebuild = False

        if coll >= max_coll:
            status = CHUNK_DONE
            break
        if events >= max_events:
            status = EVENT_BUDGET
            break

        i = heap[0]
        te = ev_t[i]
        if te >= t_stop:
            w_ke += ke * (t_stop - t_last)
            t_last = t_stop
            t = t_stop
            status = REACHED_T_STOP
            break
        events += 1
        t = te
        j = ev_p[i]
        if j < 0:
            # shell exit (lower bound): rebuild only if the shell is really used up
            dt = t - tl[i]
            d2 = 0.0
            for k in range(3):
                dk = x[i, k] + v[i, k] * dt - xb[i, k]
                d2 += dk * dk
            rem = c * g[i] - g[i] * (t - tb) - math.sqrt(d2)
            if rem <= 0.02 * c * g[i]:
                need_rebuild = True
            else:
                _predict(i, t, x, v, tl, g, box, start, nbr, xb, tb, c, cnt, ev_t, ev_p, ev_c)
                _heap_update(heap, hpos, ev_t, i, n)
            continue
        if cnt[j] != ev_c[i]:
            _predict(i, t, x, v, tl, g, box, start, nbr, xb, tb, c, cnt, ev_t, ev_p, ev_c)
            _heap_update(heap, hpos, ev_t, i, n)
            continue
        # valid collision of i and j at time t
        for p in (i, j):
            dt = t - tl[p]
            for k in range(3):
                x[p, k] += v[p, k] * dt
            tl[p] = t
        dx = min_image(x[j, 0] - x[i, 0], box[0])
        dy = min_image(x[j, 1] - x[i, 1], box[1])
        dz = min_image(x[j, 2] - x[i, 2], box[2])
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        G = g[i] + g[j]
        if d > 0.0:
            nx = dx / d
            ny = dy / d
            nz = dz / d
            u = (v[j, 0] - v[i, 0]) * nx + (v[j, 1] - v[i, 1]) * ny + (v[j, 2] - v[i, 2]) * nz
            J = G - u
            if J <= 0.0:
                J = 1e-12 * (1.0 + abs(u))
            v[i, 0] -= J * nx
            v[i, 1] -= J * ny
            v[i, 2] -= J * nz
            v[j, 0] += J * nx
            v[j, 1] += J * ny
            v[j, 2] += J * nz
            w_ke += ke * (t - t_last)
            t_last = t
            ke += J * (u + J)
            w_vir += J * d
        cnt[i] += 1
        cnt[j] += 1
        coll += 1
        w_coll += 1
        _predict(i, t, x, v, tl, g, box, start, nbr, xb, tb, c, cnt, ev_t, ev_p, ev_c)
        _heap_update(heap, hpos, ev_t, i, n)
        _predict(j, t, x, v, tl, g, box, start, nbr, xb, tb, c, cnt, ev_t, ev_p, ev_c)
        _heap_update(heap, hpos, ev_t, j, n)
        if w_coll >= window:
            w_ke += ke * (t - t_last)
            t_last = t
            p = 1.0 + w_vir / (2.0 * w_ke) if w_ke > 0.0 else INF
            if n_hist < h_cap:
                hist[n_hist, 0] = t
                hist[n_hist, 1] = p
                hist[n_hist, 2] = w_coll
                n_hist += 1
            state[4] += w_vir
            state[5] += w_ke
            w_coll = 0
            w_vir = 0.0
            w_ke = 0.0
            if p > p_max:
                status = JAMMED
                break

    # leave everything synchronised at t, folded into the box
    _sync_all(x, v, tl, t)
    _wrap(x, box)
    w_ke += ke * (t - t_last)
    state[0] = t
    state[1] += coll
    state[2] += events
    state[4] += w_vir
    state[5] += w_ke
    state[6] = w_coll
    state[7] = status
    return status, n_hist


@njit(cache=True)
def next_event_brute(x, v, g, box, t, images=3):
    """Oracle: earliest collision time over all pairs and periodic images ``-images..images``.

    For tests of :func:`pair_time` and the neighbour-list bookkeeping; O(N^2).
    Returns ``(time, i, j)``.
    """
    n = x.shape[0]
    best = INF
    bi = -1
    bj = -1
    for i in range(n):
        for j in range(i + 1, n):
            G = g[i] + g[j]
            for ix in range(-images, images + 1):
                for iy in range(-images, images + 1):
                    for iz in range(-images, images + 1):
                        dx = x[j, 0] + ix * box[0] - x[i, 0]
                        dy = x[j, 1] + iy * box[1] - x[i, 1]
                        dz = x[j, 2] + iz * box[2] - x[i, 2]
                        s = pair_time(dx, dy, dz, v[j, 0] - v[i, 0], v[j, 1] - v[i, 1],
                                      v[j, 2] - v[i, 2], G, G * t)
                        if s < best:
                            best = s
                            bi = i
                            bj = j
    return t + best, bi, bj


def warmup():
    """Compile the kernels of this module on a tiny input."""
    rng = np.random.default_rng(0)
    n = 16
    box = np.full(3, 6.0)
    x = rng.random((n, 3)) * 6.0
    v = rng.normal(size=(n, 3))
    g = np.full(n, 0.01)
    state = np.zeros(8)
    params = np.array([50.0, 100.0, 1e6, 16.0, 60.0, 0.3, 1e6, 0.0])
    hist = np.zeros((16, 3))
    run_chunk(x, v, g, box, state, params, hist)
    next_event_brute(x, v, g, box, state[0])
