"""Event-driven molecular dynamics of growing hard disks (2D Lubachevsky–Stillinger).

The 2D twin of :mod:`polypack._kernels.edmd`, with the same data layout, named
parameter/state slots (``P_*``, ``S_*``, :func:`make_params`) and
:class:`~polypack._kernels.edmd.ChunkStatus` codes, so the Python driver
(:func:`polypack.generate.lubachevsky.pack`) runs both engines the same way.
Internal units as in 3D: mean radius 1 at the reference time, thermal speed
``sqrt(kT/m) = 1`` (unit masses), disk ``i`` has radius ``g[i] * t`` at time ``t``
(the growth law of §3.1 of 000_2cedc098acbd866b.txt in the plane).

What is shared with the 3D engine (imported, not copied): the collision and
shell-exit roots (:func:`~polypack._kernels.edmd.pair_time` and
:func:`~polypack._kernels.edmd.exit_time` with a zero third component, which is
exact), the indexed 4-ary event heap, the shell widths
(:func:`~polypack._kernels.edmd.shell_reach`,
:func:`~polypack._kernels.edmd._shell_radius`), the size levels of the multi-level
grid and its linked-list moves, the slab neighbour lists built from the pairs
(:func:`~polypack._kernels.edmd._slab_lists`), and the global pair search
(:func:`polypack._kernels.cells.pairs_within` on the disks embedded as a one-cell
slab ``z = 0``).  What is 2D here: positions ``x`` (N,2) and velocities ``v``
(N,2), the cell grids of shell centres (``nc[lv]`` two cells counts), the
prediction/update loops and the thermostat (kinetic energy ``N kT``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .cells import min_image, pairs_within, stable_argsort
from .edmd import (BOX_LIMIT, CHUNK_DONE, EVENT_BUDGET, INF, JAMMED, N_PARAMS, N_STATE, P_ALPHA,  # noqa: F401
                   P_DILUTE, P_MARGIN_CAP, P_MAX_COLLISIONS, P_MAX_EVENTS, P_MAX_PRESSURE, P_PRESSURE_WINDOW,
                   P_SPEED, P_SYNC_EVERY, P_T_REF, P_T_STOP, REACHED_T_STOP, S_COLLISIONS, S_EVENTS,
                   S_KE_INTEGRAL, S_LOCAL_REBUILDS, S_REBUILDS, S_STATUS, S_TIME, S_VIRIAL, ChunkStatus,
                   _axis_cell, _close_window, _end_chunk, _grid_move, _heap_build, _heap_update, _largest, _levels,
                   _list_pair, _median, _shell_radius, _slab_lists, _sync_all, _thermalise, _unlist, _wrap, exit_time,
                   kinetic_energy, make_params, pair_time, shell_reach)

__all__ = ["ChunkStatus", "make_params", "run_chunk", "next_event_brute", "N_STATE", "N_PARAMS"]


@njit(cache=True)
def _choose_ncell(box, n, reach_small):
    """Cells per axis of a one-cell-thick slab grid for the global pair search."""
    area = box[0] * box[1]
    h = max(reach_small, (area / max(2 * n, 1)) ** 0.5, 1e-300)
    nc = np.ones(3, np.int64)
    for k in range(2):
        nc[k] = max(1, int(math.floor(box[k] / h)))
    while nc[0] * nc[1] > 4 * n + 27:
        for k in range(2):
            nc[k] = max(1, nc[k] // 2)
    return nc


@njit(cache=True)
def build_lists(x, rho, box, level, nlev, pad):
    """Neighbour lists of shell-overlap pairs ``d_ij <= rho_i + rho_j``, both directions.

    Same slab layout and capacities as :func:`polypack._kernels.edmd.build_lists`;
    the pairs come from the 3D cell search on the disks embedded at ``z = 0`` in a
    slab one cell thick (the z separation is exactly 0).
    """
    n = x.shape[0]
    x3 = np.zeros((n, 3))
    for i in range(n):
        x3[i, 0] = x[i, 0]
        x3[i, 1] = x[i, 1]
    box3 = np.empty(3)
    box3[0] = box[0]
    box3[1] = box[1]
    box3[2] = max(box[0], box[1])
    reach_small = 2.0 * rho[stable_argsort(rho)[n // 2]]  # not np.sort: seconds of compilation (issue 33)
    nc = _choose_ncell(box, n, reach_small)
    pi, pj, _ = pairs_within(x3, rho, box3, 1.0, 0.0, nc)
    return _slab_lists(pi, pj, n, level, nlev, pad)


@njit(cache=True)
def _predict(i, t, x, v, tl, g, box, off, nn, nbr, xb, rho, cnt, ev_t, ev_p, ev_c):
    """Sync disk ``i`` to ``t`` and schedule its next event (collision or shell exit)."""
    dt = t - tl[i]
    xi0 = x[i, 0] + v[i, 0] * dt
    xi1 = x[i, 1] + v[i, 1] * dt
    x[i, 0] = xi0
    x[i, 1] = xi1
    tl[i] = t
    vi0 = v[i, 0]
    vi1 = v[i, 1]
    gi = g[i]
    d0 = min_image(xi0 - xb[i, 0], box[0])
    d1 = min_image(xi1 - xb[i, 1], box[1])
    best = exit_time(d0, d1, 0.0, vi0, vi1, 0.0, gi, rho[i] * (1.0 - 1e-12) - gi * t)
    partner = -1
    base = off[i]
    for k in range(base, base + nn[i]):
        j = nbr[k]
        dtj = t - tl[j]
        dx = min_image(x[j, 0] + v[j, 0] * dtj - xi0, box[0])
        dy = min_image(x[j, 1] + v[j, 1] * dtj - xi1, box[1])
        G = gi + g[j]
        s = pair_time(dx, dy, 0.0, v[j, 0] - vi0, v[j, 1] - vi1, 0.0, G, G * t)
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
def _cell_index(p0, p1, box, nc, lv):
    c0 = _axis_cell(p0, box[0], nc[lv, 0])
    c1 = _axis_cell(p1, box[1], nc[lv, 1])
    return c0 * nc[lv, 1] + c1


@njit(cache=True)
def _grid_build(xb, level, box, rho_max_lv, nlev, n):
    """One cell grid of shell centres per size level (multi-level grid, O(N) for any size ratio)."""
    area = box[0] * box[1]
    counts = np.zeros(nlev, np.int64)
    for i in range(n):
        counts[level[i]] += 1
    nc = np.ones((nlev, 2), np.int64)
    coff = np.zeros(nlev + 1, np.int64)
    for lv in range(nlev):
        if counts[lv] == 0:
            coff[lv + 1] = coff[lv] + 1
            continue
        h = max(2.0 * rho_max_lv[lv], (area / (2.0 * counts[lv])) ** 0.5)
        for k in range(2):
            nc[lv, k] = max(1, int(math.floor(box[k] / h)))
        while nc[lv, 0] * nc[lv, 1] > 4 * counts[lv] + 27:
            for k in range(2):
                nc[lv, k] = max(1, nc[lv, k] // 2)
        coff[lv + 1] = coff[lv] + nc[lv, 0] * nc[lv, 1]
    head = np.empty(coff[nlev], np.int64)
    for c in range(coff[nlev]):
        head[c] = -1
    nxt = np.empty(n, np.int64)
    prv = np.empty(n, np.int64)
    for i in range(n):
        nxt[i] = -1
        prv[i] = -1
    cell = np.empty(n, np.int64)
    for i in range(n):
        lv = level[i]
        ci = coff[lv] + _cell_index(xb[i, 0], xb[i, 1], box, nc, lv)
        cell[i] = ci
        h0 = head[ci]
        nxt[i] = h0
        if h0 >= 0:
            prv[h0] = i
        head[ci] = i
    return nc, coff, head, nxt, prv, cell


@njit(cache=True)
def _local_rebuild(i, rho_new, x, box, xb, rho, off, nn, nbr, level, nlev, rho_max_lv, nc, coff, head, nxt, prv,
                   cell):
    """New shell for disk ``i`` at its current position; symmetric list update.

    Returns False if a neighbour slab overflowed (the caller then rebuilds globally).
    """
    _unlist(i, off, nn, nbr)
    xb[i, 0] = x[i, 0]
    xb[i, 1] = x[i, 1]
    rho[i] = rho_new
    lv_i = level[i]
    if rho_new > rho_max_lv[lv_i]:
        rho_max_lv[lv_i] = rho_new
    _grid_move(i, coff[lv_i] + _cell_index(xb[i, 0], xb[i, 1], box, nc, lv_i), head, nxt, prv, cell)
    ok = True
    xi0 = xb[i, 0]
    xi1 = xb[i, 1]
    ri = rho[i]
    for lv in range(nlev):
        reach = ri + rho_max_lv[lv]
        n0 = nc[lv, 0]
        n1 = nc[lv, 1]
        r0 = int(math.ceil(reach / (box[0] / n0)))
        r1 = int(math.ceil(reach / (box[1] / n1)))
        full0 = 2 * r0 + 1 >= n0
        full1 = 2 * r1 + 1 >= n1
        c0 = _axis_cell(xi0, box[0], n0)
        c1 = _axis_cell(xi1, box[1], n1)
        lo0 = 0 if full0 else c0 - r0 + n0
        hi0 = n0 - 1 if full0 else c0 + r0 + n0
        lo1 = 0 if full1 else c1 - r1 + n1
        hi1 = n1 - 1 if full1 else c1 + r1 + n1
        base = coff[lv]
        for q0 in range(lo0, hi0 + 1):
            a0 = q0 - n0 if q0 >= n0 else q0
            if a0 >= n0:
                a0 -= n0
            row = base + a0 * n1
            for q1 in range(lo1, hi1 + 1):
                a1 = q1 - n1 if q1 >= n1 else q1
                if a1 >= n1:
                    a1 -= n1
                j = head[row + a1]
                while j >= 0:
                    if j != i:
                        dx = min_image(xb[j, 0] - xi0, box[0])
                        dy = min_image(xb[j, 1] - xi1, box[1])
                        lim = ri + rho[j]
                        if dx * dx + dy * dy <= lim * lim:
                            if not _list_pair(i, j, off, nn, nbr):
                                ok = False
                    j = nxt[j]
    return ok


@njit(cache=True)
def run_chunk(x, v, g, box, state, params, hist):
    """Advance the growing hard-disk system by up to ``params[P_MAX_COLLISIONS]`` collisions.

    Parameters, returns and collision rule as :func:`polypack._kernels.edmd.run_chunk`
    with ``x, v`` of shape (N, 2) and ``box`` of shape (2,).  The thermostat resets
    the kinetic energy to ``N kT`` (two degrees of freedom per disk).  The reduced
    pressure over a window, ``Z = PA/(N kT) = 1 + sum(J sigma) / (2 integral(KE dt))``,
    is the 2D virial theorem (``PA = N kT + (1/2) <sum r_ij . f_ij>``, with
    ``2 KE = 2 N kT``) and has the same form as in 3D.
    """
    n = x.shape[0]
    t = state[S_TIME]
    t_stop = params[P_T_STOP]
    max_coll = int(params[P_MAX_COLLISIONS])
    p_max = params[P_MAX_PRESSURE]
    window = int(params[P_PRESSURE_WINDOW])
    t_ref = params[P_T_REF]
    dilute = params[P_DILUTE]
    alpha = params[P_ALPHA]
    max_events = int(params[P_MAX_EVENTS])
    sync_every = int(params[P_SYNC_EVERY])
    speed = params[P_SPEED]
    if sync_every <= 0:
        sync_every = 4 * n

    tl = np.empty(n)
    for i in range(n):
        tl[i] = t
    cnt = np.zeros(n, np.int64)
    ev_t = np.empty(n)
    ev_p = np.empty(n, np.int64)
    ev_c = np.empty(n, np.int64)
    hk = np.empty(n)
    hi = np.empty(n, np.int64)
    hpos = np.empty(n, np.int64)
    xb = np.empty((n, 2))
    rho = np.empty(n)
    level, nlev, gmax_lv = _levels(g)
    gmax = _largest(g)  # written-out g.max() and np.median(g), bit for bit (issue 33: cold start)
    g_margin = params[P_MARGIN_CAP] * _median(g)

    n_hist = 0
    status = CHUNK_DONE
    coll = 0
    events = 0
    w_coll = 0
    w_vir = 0.0
    w_ke = 0.0
    t_last = t
    ke = 0.0
    need_rebuild = True
    need_sync = False
    since_sync = 0
    off = np.zeros(n + 1, np.int64)
    nn = np.zeros(n, np.int64)
    nbr = np.zeros(0, np.int32)
    pad = 8
    rho_cap = 0.249 * min(box[0], box[1])
    rho_max_lv = np.zeros(nlev)
    nc, coff, head, nxt, prv, cell = _grid_build(x, level, box, gmax_lv, nlev, n)

    while True:
        if need_rebuild or need_sync:
            _sync_all(x, v, tl, t)
            ke = kinetic_energy(v)
            w_ke += ke * (t - t_last)
            t_last = t
            _thermalise(v, speed)
            ke = kinetic_energy(v)
            since_sync = 0
            if need_rebuild:
                _wrap(x, box)
                if gmax * t >= rho_cap * (1.0 - 1e-9):
                    status = BOX_LIMIT
                    break
                D = shell_reach(t, t_ref, alpha, dilute)
                for lv in range(nlev):
                    rho_max_lv[lv] = 0.0
                for i in range(n):
                    xb[i, 0] = x[i, 0]
                    xb[i, 1] = x[i, 1]
                    rho[i] = _shell_radius(g[i], t, D, g_margin, rho_cap)
                    if rho[i] > rho_max_lv[level[i]]:
                        rho_max_lv[level[i]] = rho[i]
                off, nn, nbr = build_lists(x, rho, box, level, nlev, pad)
                nc, coff, head, nxt, prv, cell = _grid_build(xb, level, box, rho_max_lv, nlev, n)
                state[S_REBUILDS] += 1
            for i in range(n):
                cnt[i] = 0
            for i in range(n):
                _predict(i, t, x, v, tl, g, box, off, nn, nbr, xb, rho, cnt, ev_t, ev_p, ev_c)
            _heap_build(hk, hi, hpos, ev_t, n)
            need_rebuild = False
            need_sync = False

        if coll >= max_coll:
            status = CHUNK_DONE
            break
        if events >= max_events:
            status = EVENT_BUDGET
            break

        i = hi[0]
        te = hk[0]
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
            dt = t - tl[i]
            x[i, 0] += v[i, 0] * dt
            x[i, 1] += v[i, 1] * dt
            tl[i] = t
            if g[i] * t >= rho_cap * (1.0 - 1e-9):
                status = BOX_LIMIT
                break
            rho_new = _shell_radius(g[i], t, shell_reach(t, t_ref, alpha, dilute), g_margin, rho_cap)
            ok = _local_rebuild(i, rho_new, x, box, xb, rho, off, nn, nbr, level, nlev, rho_max_lv, nc, coff,
                                head, nxt, prv, cell)
            state[S_LOCAL_REBUILDS] += 1
            if not ok:
                pad = min(2 * pad, 1024)
                need_rebuild = True
                continue
            _predict(i, t, x, v, tl, g, box, off, nn, nbr, xb, rho, cnt, ev_t, ev_p, ev_c)
            _heap_update(hk, hi, hpos, i, ev_t[i], n)
            continue
        if cnt[j] != ev_c[i]:
            _predict(i, t, x, v, tl, g, box, off, nn, nbr, xb, rho, cnt, ev_t, ev_p, ev_c)
            _heap_update(hk, hi, hpos, i, ev_t[i], n)
            continue
        for p in (i, j):
            dt = t - tl[p]
            x[p, 0] += v[p, 0] * dt
            x[p, 1] += v[p, 1] * dt
            tl[p] = t
        dx = min_image(x[j, 0] - x[i, 0], box[0])
        dy = min_image(x[j, 1] - x[i, 1], box[1])
        d = math.sqrt(dx * dx + dy * dy)
        G = g[i] + g[j]
        if d > 0.0:
            nx = dx / d
            ny = dy / d
            u = (v[j, 0] - v[i, 0]) * nx + (v[j, 1] - v[i, 1]) * ny
            J = G - u
            if J <= 0.0:
                J = 1e-12 * (1.0 + abs(u))
            v[i, 0] -= J * nx
            v[i, 1] -= J * ny
            v[j, 0] += J * nx
            v[j, 1] += J * ny
            w_ke += ke * (t - t_last)
            t_last = t
            ke += J * (u + J)
            w_vir += J * d
        cnt[i] += 1
        cnt[j] += 1
        coll += 1
        w_coll += 1
        since_sync += 1
        _predict(i, t, x, v, tl, g, box, off, nn, nbr, xb, rho, cnt, ev_t, ev_p, ev_c)
        _heap_update(hk, hi, hpos, i, ev_t[i], n)
        _predict(j, t, x, v, tl, g, box, off, nn, nbr, xb, rho, cnt, ev_t, ev_p, ev_c)
        _heap_update(hk, hi, hpos, j, ev_t[j], n)
        if since_sync >= sync_every:
            need_sync = True
        if w_coll >= window:
            w_ke += ke * (t - t_last)
            t_last = t
            p, n_hist = _close_window(t, w_ke, w_vir, w_coll, hist, n_hist, state)
            w_coll = 0
            w_vir = 0.0
            w_ke = 0.0
            if p > p_max:
                status = JAMMED
                break

    _end_chunk(x, v, tl, t, box, state, coll, events, w_vir, w_ke + ke * (t - t_last), status)
    return status, n_hist


@njit(cache=True)
def next_event_brute(x, v, g, box, t, images=3):
    """Oracle: earliest disk collision over all pairs and periodic images ``-images..images``.

    O(N^2 (2 images + 1)^2); for tests of the prediction and list bookkeeping.
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
                    dx = x[j, 0] + ix * box[0] - x[i, 0]
                    dy = x[j, 1] + iy * box[1] - x[i, 1]
                    s = pair_time(dx, dy, 0.0, v[j, 0] - v[i, 0], v[j, 1] - v[i, 1], 0.0, G, G * t)
                    if s < best:
                        best = s
                        bi = i
                        bj = j
    return t + best, bi, bj


def warmup():
    """Compile the kernels of this module on a tiny input."""
    rng = np.random.default_rng(0)
    n = 16
    box = np.full(2, 8.0)
    x = rng.random((n, 2)) * 8.0
    v = rng.normal(size=(n, 2))
    g = np.full(n, 0.01)
    state = np.zeros(N_STATE)
    params = make_params(50.0, 100.0, 1e6, 16.0, 50.0, 0.3, 1e6, 0.0, 0.5, 3.0)
    hist = np.zeros((16, 3))
    run_chunk(x, v, g, box, state, params, hist)
    next_event_brute(x, v, g, box, state[S_TIME])
