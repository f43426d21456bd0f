"""Event-driven molecular dynamics of growing hard spheres (Lubachevsky–Stillinger).

Kernels for :mod:`polypack.generate.lubachevsky`.  All lengths and times are in
internal units: the mean radius at the reference time is 1, the thermal speed
``sqrt(kT/m)`` is 1 (unit masses), and sphere ``i`` has radius ``g[i] * t`` at
time ``t`` (proportional growth ``a^(k)(t) = a_0^(k) t`` of §3.1 of
000_2cedc098acbd866b.txt).

Data layout (flat arrays, C-like):

* ``x`` (N,3) positions at the particle's own time ``tl[i]`` (lazy update),
  unwrapped between full synchronisations and folded into the box at each one
  (minimum image for every separation, so there is no drift of periodic images);
* ``v`` (N,3) velocities; ``cnt[i]`` collision counter for invalidation;
* one scheduled event per sphere (``ev_t``, ``ev_p`` partner or -1 for a shell
  exit, ``ev_c`` partner counter at prediction time) in an indexed 4-ary
  min-heap whose slots hold the event times themselves (``hk``, sphere ``hi``,
  slot of a sphere ``hpos``): the four children of a slot share a cache line
  and a sift never chases a pointer to read a key;
* in the event loop each sphere's state is two 64-byte records: its motion ``P``
  (position, velocity, own time, growth speed) and ``E`` (shell, event, list slab,
  counters, heap slot; columns ``E_*``, ``I_*``), and the heap's keys and spheres
  are interleaved (``HEAP_ROW0``); the helpers index strided views of them as if
  they were separate arrays;
* per-sphere shells: sphere ``i`` stays inside the ball ``(xb_i, rho_i)`` until
  its shell-exit event (exact time from a quadratic), with ``rho_i = g_i D(t)``
  at the build time ``t`` (a margin proportional to the radius, see
  :func:`shell_reach`; for spheres larger than the median the margin is capped
  at a multiple of the median margin, :func:`_shell_radius`).  Spheres whose
  shells do not overlap cannot collide, so the symmetric lists of shell-overlap
  pairs are complete;
* the event loop numbers the spheres along a Morton curve of the box
  (:func:`_curve_order`, renewed at each global rebuild) and keeps its per-sphere
  arrays in that order; ``x``, ``v``, ``g`` stay in the caller's order, and the pack
  is bit for bit the one without renumbering (``make_params(renumber=False)``);
* neighbour lists in slabs (``off``, ``nn``, ``nbr``; int32), built at each full
  synchronisation with the size-aware cell search
  :func:`polypack._kernels.cells.pairs_within` (criterion ``d <= rho_i + rho_j``);
* a shell exit rebuilds only that sphere's shell and list, found in a multi-level
  cell grid of shell centres (one grid per factor 2 in radius), so finding
  neighbours costs the same at any size ratio (predicting a large sphere's next
  event still scans the small spheres around it, about (R/r)^2 of them).
"""

from __future__ import annotations

import math
import types as pytypes

from enum import IntEnum

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from .cells import min_image, pairs_within, stable_argsort

INF = np.inf


@intrinsic
def _prefetch_row(typingctx, arr, row):
    """Hint the processor to load the cache line of ``arr[row, 0, ...]`` (LLVM ``llvm.prefetch``:
    read, keep in all cache levels); no effect on any value."""
    sig = types.void(arr, row)

    def codegen(context, builder, signature, args):
        aryty, rowty = signature.args
        ary = context.make_array(aryty)(context, builder, args[0])
        r = context.cast(builder, args[1], rowty, types.intp)
        ptr = cgutils.get_item_pointer2(context, builder, data=ary.data, shape=cgutils.unpack_tuple(builder, ary.shape),
                                        strides=cgutils.unpack_tuple(builder, ary.strides), layout=aryty.layout,
                                        inds=[r] + [context.get_constant(types.intp, 0)] * (aryty.ndim - 1),
                                        wraparound=False)
        i8p = ir.IntType(8).as_pointer()
        i32 = ir.IntType(32)
        name = "llvm.prefetch.p0" if str(i8p) == "ptr" else "llvm.prefetch.p0i8"  # opaque or typed pointers
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32]), name)
        builder.call(fn, [builder.bitcast(ptr, i8p), i32(0), i32(3), i32(1)])
        return context.get_dummy_value()

    return sig, codegen



class ChunkStatus(IntEnum):
    """Status returned by :func:`run_chunk` (also stored in ``state[S_STATUS]``)."""

    CHUNK_DONE = 0  # collision budget of the chunk used up
    REACHED_T_STOP = 1
    JAMMED = 2
    BOX_LIMIT = 3
    EVENT_BUDGET = 4


# the same codes as plain ints for the compiled code
CHUNK_DONE = int(ChunkStatus.CHUNK_DONE)
REACHED_T_STOP = int(ChunkStatus.REACHED_T_STOP)
JAMMED = int(ChunkStatus.JAMMED)
BOX_LIMIT = int(ChunkStatus.BOX_LIMIT)
EVENT_BUDGET = int(ChunkStatus.EVENT_BUDGET)

# slots of the ``params`` array of run_chunk
(P_T_STOP, P_MAX_COLLISIONS, P_MAX_PRESSURE, P_PRESSURE_WINDOW, P_T_REF, P_ALPHA, P_MAX_EVENTS, P_SYNC_EVERY,
 P_DILUTE, P_MARGIN_CAP, P_SPEED, P_RENUMBER) = range(12)
N_PARAMS = 12
# slots of the ``state`` array of run_chunk (counts accumulate across chunks)
(S_TIME, S_COLLISIONS, S_EVENTS, S_REBUILDS, S_VIRIAL, S_KE_INTEGRAL, S_LOCAL_REBUILDS, S_STATUS) = range(8)
N_STATE = 8


def make_params(t_stop, max_collisions, max_pressure, pressure_window, t_ref, alpha, max_events, sync_every,
                dilute, margin_cap, speed=1.0, renumber=True):
    """The ``params`` array of :func:`run_chunk` from named values (slots ``P_*``).

    ``renumber`` (slot ``P_RENUMBER``, 3D only): number the spheres of the event loop along a
    space-filling curve (:func:`_curve_order`); the pack is the same bit for bit either way.
    """
    p = np.empty(N_PARAMS)
    p[P_T_STOP] = t_stop
    p[P_MAX_COLLISIONS] = max_collisions
    p[P_MAX_PRESSURE] = max_pressure
    p[P_PRESSURE_WINDOW] = pressure_window
    p[P_T_REF] = t_ref
    p[P_ALPHA] = alpha
    p[P_MAX_EVENTS] = max_events
    p[P_SYNC_EVERY] = sync_every
    p[P_DILUTE] = dilute
    p[P_MARGIN_CAP] = margin_cap
    p[P_SPEED] = speed
    p[P_RENUMBER] = 1.0 if renumber else 0.0
    return p


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


@njit(cache=True, inline="always")
def pair_time_below(dx, dy, dz, dvx, dvy, dvz, G, sig0, best):
    """:func:`pair_time` where it is below ``best``, else some value ``>= best``.

    The same arithmetic as :func:`pair_time` (bit for bit) with one shortcut: for an
    approaching pair with ``A >= 0`` the root ``C / (-B + sqrt(B^2 - A C))`` is at least
    ``C / (-2 B)`` (``sqrt(fl(B^2)) = |B|`` in IEEE arithmetic), so when that bound,
    with a relative margin of 1e-9 for the rounding of the test, is not below ``best``
    the square root and division are skipped and ``inf`` returned.  In the prediction
    loop (keep the smallest time) this changes nothing but the cost of the neighbours
    that cannot be next (issue 33).  Inlined into :func:`_predict`.

    The usual outcomes (separating and not growing into each other, or approaching but
    not before ``best``) are tested first as one combined condition: a branch on the
    sign of ``B`` alone is a coin toss per neighbour, which the processor mispredicts
    half of the time.  The results are those of :func:`pair_time` wherever it is below
    ``best`` (tests/test_edmd_hot.py).
    """
    A = dvx * dvx + dvy * dvy + dvz * dvz - G * G
    B = dx * dvx + dy * dvy + dz * dvz - sig0 * G
    C = dx * dx + dy * dy + dz * dz - sig0 * sig0
    if (A >= 0.0) & ((B >= 0.0) | ((C > 0.0) & (C >= best * (-2.0 * B) * (1.0 + 1e-9)))):
        return INF
    if B < 0.0:
        if C <= 0.0:
            return 0.0
        D = B * B - A * C
        if D < 0.0:
            return INF
        return C / (-B + math.sqrt(D))
    D = B * B - A * C  # A < 0 here: they grow into each other
    if D < 0.0:
        D = 0.0
    return (B + math.sqrt(D)) / (-A)


@njit(cache=True)
def exit_time(d0, d1, d2, v0, v1, v2, g, r0):
    """Smallest ``s >= 0`` with ``|d + v s| = r0 - g s`` (a sphere leaving its shell).

    ``d`` is the displacement from the shell centre, ``r0`` the displacement still
    allowed now; written as ``A s^2 + 2 B s + C = 0`` with ``A = v^2 - g^2``,
    ``B = d.v + r0 g``, ``C = d^2 - r0^2`` and solved without cancellation.
    """
    A = v0 * v0 + v1 * v1 + v2 * v2 - g * g
    B = d0 * v0 + d1 * v1 + d2 * v2 + r0 * g
    C = d0 * d0 + d1 * d1 + d2 * d2 - r0 * r0
    if C >= 0.0 or r0 <= 0.0:
        return 0.0
    D = B * B - A * C
    if D < 0.0:
        D = 0.0
    if B > 0.0:
        return -C / (B + math.sqrt(D))
    if A > 0.0:
        return (-B + math.sqrt(D)) / A
    return 0.0


@njit(cache=True, _nrt=False)  # no reference counting (see _event_loop)
def _sift_up(hk, hi, hpos, k):
    """Move heap slot ``k`` towards the root (4-ary min-heap, keys stored inline)."""
    key = hk[k]
    idx = hi[k]
    while k > 0:
        p = (k - 1) >> 2
        kp = hk[p]
        if kp <= key:
            break
        hk[k] = kp
        j = hi[p]
        hi[k] = j
        hpos[j] = k
        k = p
    hk[k] = key
    hi[k] = idx
    hpos[idx] = k


@njit(cache=True, _nrt=False)  # no reference counting (see _event_loop)
def _sift_down(hk, hi, hpos, k, n):
    """Move heap slot ``k`` towards the leaves (4-ary min-heap, keys stored inline).

    A call (heap builders, :func:`_heap_update`, the 2D engine); the 3D event loop runs the same
    code inlined (:func:`_sift_down_hot`, :func:`_inlined_copy`).
    """
    key = hk[k]
    idx = hi[k]
    while True:
        c = 4 * k + 1
        if c >= n:
            break
        # the children's children (16 slots, 4 cache lines) are requested before the choice
        # among the children: the next level's keys are then on their way, not one miss per level
        g = 4 * c + 1
        for q in range(g, min(g + 16, n), 4):
            _prefetch_row(hk, q)
        if c + 3 < n:
            # the smallest of four children by a tournament of selects, no branch on the keys
            # (a choice among four event times is a coin toss the processor mispredicts); on
            # equal keys the first child wins, as in the scan below
            k0 = hk[c]
            k1 = hk[c + 1]
            k2 = hk[c + 2]
            k3 = hk[c + 3]
            l1 = k1 < k0
            a = c + 1 if l1 else c
            ka = k1 if l1 else k0
            l3 = k3 < k2
            b = c + 3 if l3 else c + 2
            kb = k3 if l3 else k2
            lb = kb < ka
            best = b if lb else a
            bk = kb if lb else ka
        else:
            best = c
            bk = hk[c]
            for q in range(c + 1, n):
                kq = hk[q]
                if kq < bk:
                    bk = kq
                    best = q
        if bk >= key:
            break
        hk[k] = bk
        j = hi[best]
        hi[k] = j
        hpos[j] = k
        k = best
    hk[k] = key
    hi[k] = idx
    hpos[idx] = k


@njit(cache=True, _nrt=False)  # no reference counting (see _event_loop)
def _heap_update(hk, hi, hpos, i, key, n):
    """Set the key of sphere ``i`` and restore the heap order (a call: the 2D engine's;
    the 3D event loop inlines :func:`_heap_update_hot`)."""
    k = hpos[i]
    old = hk[k]
    hk[k] = key
    if key < old:
        _sift_up(hk, hi, hpos, k)
    else:
        _sift_down(hk, hi, hpos, k, n)


def _inlined_copy(fn, name, **callees):
    """The compiled function ``fn`` again, under ``name``, compiled into its callers (``inline="always"``,
    no reference counting): the same source, hence the same arithmetic, for the one hot call site of
    :func:`_event_loop`, while the other callers (heap builders, :func:`run_chunk`, the 2D engine) call
    ``fn`` and do not compile its code once more (issue 33: compile time). ``callees`` (global name ->
    function) replace the functions the copy calls, e.g. with their own inlined copies."""
    f = fn.py_func
    env = dict(f.__globals__, **callees) if callees else f.__globals__
    g = pytypes.FunctionType(f.__code__, env, name, f.__defaults__, f.__closure__)
    g.__qualname__ = name  # its own entry in numba's cache
    g.__doc__ = f":func:`{f.__name__}` inlined (:func:`_inlined_copy`)."
    return njit(cache=True, _nrt=False, inline="always")(g)


_sift_down_hot = _inlined_copy(_sift_down, "_sift_down_hot")
# the event loop's reschedule site: _heap_update inlined, calling the inlined sift-down
_heap_update_hot = _inlined_copy(_heap_update, "_heap_update_hot", _sift_down=_sift_down_hot)


@njit(cache=True)
def _heap_build(hk, hi, hpos, key, n):
    """Heap of spheres ``0..n-1`` keyed by ``key`` (bottom-up, O(n))."""
    for i in range(n):
        hk[i] = key[i]
        hi[i] = i
        hpos[i] = i
    for k in range((n - 2) // 4, -1, -1):
        _sift_down(hk, hi, hpos, k, n)


@njit(cache=True)
def _heap_build_order(hk, hi, hpos, key, new, n):
    """:func:`_heap_build` with slot ``k`` first holding sphere ``new[k]``.

    With ``new`` the renumbering of :func:`_curve_order` the heap is, slot for slot, the one
    :func:`_heap_build` makes in the caller's numbering, so events with equal times leave the
    heap in the same order (bit for bit the same pack).
    """
    for k in range(n):
        i = new[k]
        hk[k] = key[i]
        hi[k] = i
        hpos[i] = k
    for k in range((n - 2) // 4, -1, -1):
        _sift_down(hk, hi, hpos, k, n)


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
def build_lists(x, rho, box, level, nlev, pad, new):
    """Neighbour lists of shell-overlap pairs ``d_ij <= rho_i + rho_j``, both directions.

    Stored as slabs: sphere ``i`` owns ``nbr[off[i] : off[i+1]]`` of which the first
    ``nn[i]`` are used; the capacity ``2 max(count_i, mean count of its size level)
    + pad`` leaves room for the list to grow in local rebuilds.  ``x`` and ``rho`` are in
    the caller's numbering; the lists are in the event loop's (sphere ``k`` is ``new[k]``,
    ``level`` indexed by it), the slabs in that order and each list in the order of the
    caller's numbering would give (:func:`_curve_order`).
    """
    n = x.shape[0]
    reach_small = 2.0 * rho[stable_argsort(rho)[n // 2]]
    nc = _choose_ncell(box, n, reach_small)
    pi, pj, _ = pairs_within(x, rho, box, 1.0, 0.0, nc)
    for k in range(pi.shape[0]):
        pi[k] = new[pi[k]]
        pj[k] = new[pj[k]]
    return _slab_lists(pi, pj, n, level, nlev, pad)


@njit(cache=True)
def _slab_lists(pi, pj, n, level, nlev, pad):
    """Symmetric slab lists ``(off, nn, nbr)`` of the pairs ``(pi[k], pj[k])`` (layout and
    capacities of :func:`build_lists`; also used by the 2D engine)."""
    m = pi.shape[0]
    cnt = np.zeros(n, np.int64)
    for k in range(m):
        cnt[pi[k]] += 1
        cnt[pj[k]] += 1
    lsum = np.zeros(nlev)
    lnum = np.zeros(nlev)
    for i in range(n):
        lsum[level[i]] += cnt[i]
        lnum[level[i]] += 1.0
    off = np.zeros(n + 1, np.int64)
    for i in range(n):
        mean_l = lsum[level[i]] / max(lnum[level[i]], 1.0)
        off[i + 1] = off[i] + int(2.0 * max(cnt[i], mean_l)) + pad
    if off[n] > 2147483647:  # checked before the allocation (it would be 8 GB and more)
        raise ValueError("neighbour lists above 2^31 entries (int32 slab offsets of the records): "
                         "pack fewer spheres per run or a narrower size distribution")
    nbr = np.empty(off[n], np.int32)  # int32: half the bytes of the lists (issue 33: cache misses)
    nn = np.zeros(n, np.int64)
    for k in range(m):
        i = pi[k]
        j = pj[k]
        nbr[off[i] + nn[i]] = j
        nn[i] += 1
        nbr[off[j] + nn[j]] = i
        nn[j] += 1
    return off, nn, nbr


# columns of the per-sphere records ``P`` of the event loop: position 0..2, velocity 3..5,
# own time, growth speed (8 doubles: one 64-byte cache line per sphere)
R_X = 0
R_V = 3
R_T = 6
R_G = 7
N_REC = 8
# the second record of a sphere, ``E`` (8 doubles, one cache line): what an event at the sphere
# reads and writes besides its motion.  Float columns: shell centre 0..2, shell radius, time of the
# scheduled event; int32 columns of the view ``E.view(np.int32)`` (16 per row): slab offset and
# length of the neighbour list, scheduled partner and its collision count at prediction time, the
# sphere's collision count, its slot in the event heap.  The event loop's helpers see them as
# strided 1D views (``xb = E[:, E_XB:E_XB + 3]``, ``off = Ei[:, I_OFF]``, ...): the code is that of
# separate arrays, the memory one line per sphere instead of nine (issue 33: cache misses).
E_XB = 0
E_RHO = 3
E_T = 4
I_OFF = 10
I_NN = 11
I_P = 12
I_C = 13
I_CNT = 14
I_HPOS = 15
# the event heap: slot ``s`` in row ``s + HEAP_ROW0`` of an (n + HEAP_ROW0 + 1, 2) float64 array
# (key in column 0, sphere in column 1 of its int64 view); with 16-byte rows from a 64-byte
# boundary the four children ``4s+1 .. 4s+4`` of a slot fill one cache line, keys and spheres alike
HEAP_ROW0 = 3


@njit(cache=True)
def _aligned_rows(n, m):
    """An (n, m) float64 array whose row ``r`` starts ``8 m r`` bytes after a 64-byte boundary."""
    buf = np.empty(m * n + 8)
    first = ((64 - buf.ctypes.data % 64) % 64) // 8
    return buf[first:first + m * n].reshape((n, m))


@njit(cache=True)
def _to_records(P, x, v, tl, g, orig):
    """Copy the state of every sphere into its record: record ``i`` is the caller's sphere ``orig[i]``."""
    for i in range(x.shape[0]):
        o = orig[i]
        for k in range(3):
            P[i, R_X + k] = x[o, k]
            P[i, R_V + k] = v[o, k]
        P[i, R_T] = tl[o]
        P[i, R_G] = g[o]


@njit(cache=True)
def _from_records(P, x, v, tl, orig):
    """Copy positions, velocities and own times back out of the records (the caller's numbering)."""
    for i in range(x.shape[0]):
        o = orig[i]
        for k in range(3):
            x[o, k] = P[i, R_X + k]
            v[o, k] = P[i, R_V + k]
        tl[o] = P[i, R_T]


@njit(cache=True)
def _curve_order(x, box, orig, new):
    """Number the spheres along a Morton (Z-order) curve of a cell grid (issue 33: memory locality).

    The grid has about one sphere per cell; the cells are ordered by interleaving the bits
    of their three indices (as many bits per axis as that axis needs), the spheres of a cell
    keep the caller's order (stable sort).  Fills ``orig`` (the caller's index of the event
    loop's sphere ``i``) and ``new`` (its inverse).  Neighbours in space are then mostly
    neighbours in memory: their records and neighbour-list slabs share cache lines and pages.

    Only memory addresses change: the event loop sees the same events in the same order
    (lists, cell chains and heap are built in the caller's order, see :func:`build_lists`,
    :func:`_grid_build`, :func:`_heap_build_order`), and the sums over spheres of a
    synchronisation run in the caller's numbering, so the pack is bit for bit the same.
    """
    n = x.shape[0]
    h = (box[0] * box[1] * box[2] / max(n, 1)) ** (1.0 / 3.0)
    ncl = np.empty(3, np.int64)
    bits = np.empty(3, np.int64)
    top = 0
    for k in range(3):
        m = 1 if h <= 0.0 else max(1, min(int(box[k] / h), 1 << 17))
        ncl[k] = m
        b = 0
        while (1 << b) < m:
            b += 1
        bits[k] = b
        if b > top:
            top = b
    keys = np.empty(n)
    for i in range(n):
        code = 0
        shift = 0
        c0 = _axis_cell(x[i, 0], box[0], ncl[0])
        c1 = _axis_cell(x[i, 1], box[1], ncl[1])
        c2 = _axis_cell(x[i, 2], box[2], ncl[2])
        for b in range(top):
            if b < bits[0]:
                code |= ((c0 >> b) & 1) << shift
                shift += 1
            if b < bits[1]:
                code |= ((c1 >> b) & 1) << shift
                shift += 1
            if b < bits[2]:
                code |= ((c2 >> b) & 1) << shift
                shift += 1
        keys[i] = code  # below 2^51: exact as a float (the sort already compiled for floats)
    o = stable_argsort(keys)
    for i in range(n):
        orig[i] = o[i]
        new[o[i]] = i


@njit(cache=True, _nrt=False, inline="always")
def _prefetch_neighbours(i, P, off, nn, nbr):
    """Request the records ``P`` of all neighbours of ``i`` at once (:func:`_prefetch_row`), so
    that their cache misses overlap instead of following one another through the pair loop's
    branches (a mispredicted branch discards the loads issued after it)."""
    base = off[i]
    for k in range(base, base + nn[i]):
        _prefetch_row(P, nbr[k])


@njit(cache=True, _nrt=False)  # no reference counting (see _event_loop)
def _predict(i, t, P, box, off, nn, nbr, xb, rho, cnt, ev_t, ev_p, ev_c):
    """Sync sphere ``i`` to ``t`` and schedule its next event (collision or shell exit).

    ``P`` holds one 64-byte record per sphere (position, velocity, own time, growth
    speed: columns ``R_X..R_G``), so a neighbour costs one cache line, not four; the
    neighbours' records are requested first (:func:`_prefetch_neighbours`).  A call from
    :func:`run_chunk`; :func:`_event_loop` runs the same code inlined (:func:`_predict_hot`):
    a call passes its 11 arrays on the stack.
    """
    _prefetch_neighbours(i, P, off, nn, nbr)
    base = off[i]
    nn_i = nn[i]
    dt = t - P[i, R_T]
    xi0 = P[i, 0] + P[i, 3] * dt
    xi1 = P[i, 1] + P[i, 4] * dt
    xi2 = P[i, 2] + P[i, 5] * dt
    P[i, 0] = xi0
    P[i, 1] = xi1
    P[i, 2] = xi2
    P[i, R_T] = t
    vi0 = P[i, 3]
    vi1 = P[i, 4]
    vi2 = P[i, 5]
    gi = P[i, R_G]
    # shell exit: the sphere stays inside ball(xb_i, rho_i) while
    # |x_i - xb_i| + g_i t <= rho_i; exact first crossing of the quadratic
    d0 = min_image(xi0 - xb[i, 0], box[0])
    d1 = min_image(xi1 - xb[i, 1], box[1])
    d2 = min_image(xi2 - xb[i, 2], box[2])
    best = exit_time(d0, d1, d2, vi0, vi1, vi2, gi, rho[i] * (1.0 - 1e-12) - gi * t)
    partner = -1
    for k in range(base, base + nn_i):
        j = nbr[k]
        dtj = t - P[j, R_T]
        dx = min_image(P[j, 0] + P[j, 3] * dtj - xi0, box[0])
        dy = min_image(P[j, 1] + P[j, 4] * dtj - xi1, box[1])
        dz = min_image(P[j, 2] + P[j, 5] * dtj - xi2, box[2])
        G = gi + P[j, R_G]
        s = pair_time_below(dx, dy, dz, P[j, 3] - vi0, P[j, 4] - vi1, P[j, 5] - vi2, G, G * t, best)
        if s < best:
            best = s
            partner = j
    ev_t[i] = t + best
    ev_p[i] = partner
    if partner >= 0:
        ev_c[i] = cnt[partner]
    else:
        ev_c[i] = 0


_predict_hot = _inlined_copy(_predict, "_predict_hot")


@njit(cache=True, _nrt=False)  # no reference counting (see _event_loop)
def _axis_cell(y, L, m):
    y -= L * math.floor(y / L)
    ck = int(y / L * m)
    if ck >= m:
        ck = m - 1
    if ck < 0:
        ck = 0
    return ck


@njit(cache=True, _nrt=False)  # no reference counting (see _event_loop)
def _cell_index(p0, p1, p2, box, nc, lv):
    c0 = _axis_cell(p0, box[0], nc[lv, 0])
    c1 = _axis_cell(p1, box[1], nc[lv, 1])
    c2 = _axis_cell(p2, box[2], nc[lv, 2])
    return (c0 * nc[lv, 1] + c1) * nc[lv, 2] + c2


@njit(cache=True)
def _grid_build(xb, level, box, rho_max_lv, nlev, n, new):
    """One cell grid of shell centres per size level (multi-level grid, O(N) for any size ratio).

    The spheres enter their cells' chains in the order ``new[0], new[1], ...`` (the caller's
    numbering, :func:`_curve_order`), so each chain lists the same spheres in the same order
    whatever the numbering of the event loop.
    """
    vol = box[0] * box[1] * box[2]
    counts = np.zeros(nlev, np.int64)
    for i in range(n):
        counts[level[i]] += 1
    nc = np.empty((nlev, 3), np.int64)
    for lv in range(nlev):
        for k in range(3):
            nc[lv, k] = 1
    coff = np.zeros(nlev + 1, np.int64)
    for lv in range(nlev):
        if counts[lv] == 0:
            coff[lv + 1] = coff[lv] + 1
            continue
        h = max(2.0 * rho_max_lv[lv], (vol / (2.0 * counts[lv])) ** (1.0 / 3.0))
        for k in range(3):
            nc[lv, k] = max(1, int(math.floor(box[k] / h)))
        while nc[lv, 0] * nc[lv, 1] * nc[lv, 2] > 4 * counts[lv] + 27:
            for k in range(3):
                nc[lv, k] = max(1, nc[lv, k] // 2)
        coff[lv + 1] = coff[lv] + nc[lv, 0] * nc[lv, 1] * nc[lv, 2]
    head = np.empty(coff[nlev], np.int64)
    for c in range(coff[nlev]):
        head[c] = -1
    nxt = np.empty(n, np.int64)
    prv = np.empty(n, np.int64)
    cell = np.empty(n, np.int64)
    for i in range(n):
        nxt[i] = -1
        prv[i] = -1
    for k in range(n):
        i = new[k]
        lv = level[i]
        ci = coff[lv] + _cell_index(xb[i, 0], xb[i, 1], xb[i, 2], box, nc, lv)
        cell[i] = ci
        h0 = head[ci]
        nxt[i] = h0
        if h0 >= 0:
            prv[h0] = i
        head[ci] = i
    return nc, coff, head, nxt, prv, cell


@njit(cache=True, _nrt=False)  # no reference counting (see _event_loop)
def _grid_move(i, ci_new, head, nxt, prv, cell):
    ci = cell[i]
    if ci == ci_new:
        return
    p = prv[i]
    q = nxt[i]
    if p >= 0:
        nxt[p] = q
    else:
        head[ci] = q
    if q >= 0:
        prv[q] = p
    h0 = head[ci_new]
    nxt[i] = h0
    prv[i] = -1
    if h0 >= 0:
        prv[h0] = i
    head[ci_new] = i
    cell[i] = ci_new


@njit(cache=True, _nrt=False)  # no reference counting (see _event_loop)
def _unlist(i, off, nn, nbr):
    """Drop ``i`` from its neighbours' lists (swap-remove) and empty its own.

    The neighbours' slab offsets, then their slabs, are requested first (:func:`_prefetch_row`,
    loops without branches), so that their cache misses overlap."""
    for k in range(off[i], off[i] + nn[i]):
        _prefetch_row(off, nbr[k])
    for k in range(off[i], off[i] + nn[i]):
        _prefetch_row(nbr, off[nbr[k]])
    for k in range(off[i], off[i] + nn[i]):
        j = nbr[k]
        b = off[j]
        e = b + nn[j]
        for q in range(b, e):
            if nbr[q] == i:
                nbr[q] = nbr[e - 1]
                nn[j] -= 1
                break
    nn[i] = 0


@njit(cache=True, inline="always")  # in the scan of a local rebuild
def _list_pair(i, j, off, nn, nbr):
    """Add the pair ``(i, j)`` to both lists; False (nothing added) if either slab is full."""
    if nn[i] < off[i + 1] - off[i] and nn[j] < off[j + 1] - off[j]:
        nbr[off[i] + nn[i]] = j
        nn[i] += 1
        nbr[off[j] + nn[j]] = i
        nn[j] += 1
        return True
    return False


@njit(cache=True, _nrt=False, inline="always")  # in the scan of a local rebuild
def _cell_gap(y, L, m, c, k):
    """Squared gap along one axis between a centre at ``y`` (in cell ``c`` of ``m`` cells of
    the period ``L``) and cell ``k`` (``c - r .. c + r``, not wrapped), shrunk by ``1e-9 L``."""
    y -= L * math.floor(y / L)
    w = L / m
    if k < c:
        gap = y - (k + 1) * w
    elif k > c:
        gap = k * w - y
    else:
        return 0.0
    gap -= 1e-9 * L
    return gap * gap if gap > 0.0 else 0.0


@njit(cache=True, _nrt=False)  # no reference counting (see _event_loop)
def _local_rebuild(i, rho_new, P, box, xb, rho, off, nn, nbr, level, nlev, rho_max_lv, nc, coff, head, nxt, prv,
                   cell):
    """New shell for sphere ``i`` at its current position (``P[i, 0:3]``); symmetric list update.

    Returns False if a neighbour slab overflowed (the caller then rebuilds globally).
    """
    _unlist(i, off, nn, nbr)
    for k in range(3):
        xb[i, k] = P[i, k]
    rho[i] = rho_new
    lv_i = level[i]
    if rho_new > rho_max_lv[lv_i]:
        rho_max_lv[lv_i] = rho_new
    _grid_move(i, coff[lv_i] + _cell_index(xb[i, 0], xb[i, 1], xb[i, 2], box, nc, lv_i), head, nxt, prv, cell)
    ok = True
    xi0 = xb[i, 0]
    xi1 = xb[i, 1]
    xi2 = xb[i, 2]
    ri = rho[i]
    for lv in range(nlev):
        reach = ri + rho_max_lv[lv]
        n0 = nc[lv, 0]
        n1 = nc[lv, 1]
        n2 = nc[lv, 2]
        r0 = int(math.ceil(reach / (box[0] / n0)))
        r1 = int(math.ceil(reach / (box[1] / n1)))
        r2 = int(math.ceil(reach / (box[2] / n2)))
        full0 = 2 * r0 + 1 >= n0
        full1 = 2 * r1 + 1 >= n1
        full2 = 2 * r2 + 1 >= n2
        c0 = _axis_cell(xi0, box[0], n0)
        c1 = _axis_cell(xi1, box[1], n1)
        c2 = _axis_cell(xi2, box[2], n2)
        lo0 = 0 if full0 else c0 - r0 + n0
        hi0 = n0 - 1 if full0 else c0 + r0 + n0
        lo1 = 0 if full1 else c1 - r1 + n1
        hi1 = n1 - 1 if full1 else c1 + r1 + n1
        lo2 = 0 if full2 else c2 - r2 + n2
        hi2 = n2 - 1 if full2 else c2 + r2 + n2
        base = coff[lv]
        # cells of the block farther than ``reach`` from the centre hold no partner: skipped
        # (the corners of the 3x3x3 block, about a quarter of its cells); the gaps are shrunk
        # by 1e-9 L for the rounding of the cell of a centre, so only cells that surely hold
        # none are skipped and the list is the same, in the same order
        reach2 = reach * reach
        for q0 in range(lo0, hi0 + 1):
            a0 = q0 - n0 if q0 >= n0 else q0
            if a0 >= n0:
                a0 -= n0
            g0 = 0.0 if full0 else _cell_gap(xi0, box[0], n0, c0, q0 - n0)
            for q1 in range(lo1, hi1 + 1):
                a1 = q1 - n1 if q1 >= n1 else q1
                if a1 >= n1:
                    a1 -= n1
                g01 = g0 + (0.0 if full1 else _cell_gap(xi1, box[1], n1, c1, q1 - n1))
                if g01 > reach2:
                    continue
                row = base + (a0 * n1 + a1) * n2
                for q2 in range(lo2, hi2 + 1):
                    a2 = q2 - n2 if q2 >= n2 else q2
                    if a2 >= n2:
                        a2 -= n2
                    if not full2 and g01 + _cell_gap(xi2, box[2], n2, c2, q2 - n2) > reach2:
                        continue
                    j = head[row + a2]
                    while j >= 0:
                        if j != i:
                            dx = min_image(xb[j, 0] - xi0, box[0])
                            dy = min_image(xb[j, 1] - xi1, box[1])
                            dz = min_image(xb[j, 2] - xi2, box[2])
                            lim = ri + rho[j]
                            if dx * dx + dy * dy + dz * dz <= lim * lim:
                                if not _list_pair(i, j, off, nn, nbr):
                                    ok = False
                        j = nxt[j]
    return ok


# The helpers below serve the 3D kernel and the 2D one (polypack._kernels.edmd2d): they
# loop over the ``dim = x.shape[1]`` coordinates in the same order as written-out code,
# so results are bit for bit those of a separate copy per dimension.
@njit(cache=True)
def _sync_all(x, v, tl, t):
    """Advance every sphere (disk) from its own time ``tl[i]`` to ``t``."""
    n = x.shape[0]
    for i in range(n):
        dt = t - tl[i]
        for k in range(x.shape[1]):
            x[i, k] += v[i, k] * dt
        tl[i] = t


@njit(cache=True)
def _wrap(x, box):
    """Fold the centres into ``[0, L)`` on every axis."""
    n = x.shape[0]
    for i in range(n):
        for k in range(x.shape[1]):
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
    """``sum_i |v_i|^2 / 2`` (unit masses), any dimension."""
    e = 0.0
    for i in range(v.shape[0]):
        s = 0.0
        for k in range(v.shape[1]):
            s += v[i, k] * v[i, k]
        e += s
    return 0.5 * e


@njit(cache=True)
def _thermalise(v, speed=1.0):
    """Remove net momentum and rescale to kinetic energy ``dim N speed^2 / 2`` (kT = speed^2, m = 1)."""
    n = v.shape[0]
    dim = v.shape[1]
    for k in range(dim):
        s = 0.0
        for i in range(n):
            s += v[i, k]
        s /= n
        for i in range(n):
            v[i, k] -= s
    ke = kinetic_energy(v)
    if ke > 0.0:
        f = speed * math.sqrt(0.5 * dim * n / ke)
        for i in range(n):
            for k in range(dim):
                v[i, k] *= f


@njit(cache=True)
def _close_window(t, w_ke, w_vir, w_coll, hist, n_hist, state):
    """End a pressure window; returns ``(p, n_hist)``.

    ``p = 1 + sum J d / (2 int KE dt)``, the reduced collisional virial pressure
    ``PV/(N kT)`` in 3D and ``PA/(N kT)`` in 2D alike (``KE = dim N kT / 2``), is
    recorded in ``hist`` while it has room; the window's sums go into ``state``.
    """
    p = 1.0 + w_vir / (2.0 * w_ke) if w_ke > 0.0 else INF
    if n_hist < hist.shape[0]:
        hist[n_hist, 0] = t
        hist[n_hist, 1] = p
        hist[n_hist, 2] = w_coll
        n_hist += 1
    state[S_VIRIAL] += w_vir
    state[S_KE_INTEGRAL] += w_ke
    return p, n_hist


@njit(cache=True)
def _end_chunk(x, v, tl, t, box, state, coll, events, w_vir, w_ke, status):
    """Close a chunk (3D and 2D alike): every particle synchronised at ``t`` and folded into
    the box; the chunk's collisions, events, open-window sums ``w_vir`` and ``w_ke`` (its
    kinetic-energy integral up to ``t``) and ``status`` go into ``state``.
    """
    _sync_all(x, v, tl, t)
    _wrap(x, box)
    state[S_TIME] = t
    state[S_COLLISIONS] += coll
    state[S_EVENTS] += events
    state[S_VIRIAL] += w_vir
    state[S_KE_INTEGRAL] += w_ke
    state[S_STATUS] = status


@njit(cache=True)
def shell_reach(t, t_ref, alpha, dilute):
    """``D(t)``: a shell built at ``t`` has radius ``rho_i = min(g_i D, 0.249 L)``.

    ``D`` goes linearly from ``(1 + dilute) t_ref`` at ``t = 0`` to
    ``(1 + alpha) t_ref`` at ``t_ref`` and is at least ``(1 + alpha) t``: wide
    shells while the spheres are small and fly far between collisions, shells
    ``alpha`` times the radius when dense.  The cap at a quarter of the box keeps
    ``rho_i + rho_j < L/2`` (minimum image) and applies per sphere, so the small
    spheres keep their wide shells when a large one is capped.
    """
    u = t / t_ref if t_ref > 0.0 else 1.0
    if u > 1.0:
        u = 1.0
    D = t_ref * ((1.0 + dilute) * (1.0 - u) + (1.0 + alpha) * u)
    return max(D, (1.0 + alpha) * t)


@njit(cache=True)
def _shell_radius(gi, t, D, g_margin, rho_cap):
    """Shell radius ``min(g_i D, g_i t + g_margin (D - t), rho_cap)``.

    The margin ``g_i (D - t)`` is proportional to the radius, but for spheres much
    larger than the typical one it is limited to ``g_margin (D - t)`` (a few
    typical margins): a thinner shell around a large sphere holds far fewer small
    neighbours, which keeps its predictions cheap.
    """
    r = gi * D
    r2 = gi * t + g_margin * (D - t)
    if r2 < r:
        r = r2
    if r > rho_cap:
        r = rho_cap
    return r


@njit(cache=True)
def _largest(a):
    """``a.max()`` of a non-empty 1D array (a loop: numba's ``max`` costs a second to compile)."""
    m = a[0]
    for i in range(1, a.shape[0]):
        if a[i] > m:
            m = a[i]
    return m


@njit(cache=True)
def _median(a):
    """``np.median(a)`` of a non-empty 1D array without NaN: the middle value, or the mean
    ``(lo + hi) / 2`` of the two middle ones (bit for bit numba's ``np.median``)."""
    o = stable_argsort(a)
    h = a.shape[0] >> 1
    if a.shape[0] & 1 == 0:
        return (a[o[h - 1]] + a[o[h]]) / 2
    return a[o[h]]


@njit(cache=True)
def _levels(g):
    """Size levels for the multi-level grid: level l holds g in (gmax/2^(l+1), gmax/2^l]."""
    n = g.shape[0]
    gmax = _largest(g)
    level = np.empty(n, np.int64)
    nlev = 1
    for i in range(n):
        lv = int(math.floor(math.log2(gmax / g[i]))) if g[i] > 0 else 7
        if lv > 7:
            lv = 7
        if lv < 0:
            lv = 0
        level[i] = lv
        if lv + 1 > nlev:
            nlev = lv + 1
    gmax_lv = np.zeros(nlev)
    for i in range(n):
        if g[i] > gmax_lv[level[i]]:
            gmax_lv[level[i]] = g[i]
    return level, nlev, gmax_lv


# what :func:`_event_loop` asks of :func:`run_chunk` when it returns
LOOP_STOP = 0  # chunk over (``status`` says why)
LOOP_SYNC = 1  # full synchronisation due
LOOP_REBUILD = 2  # global rebuild (a neighbour slab overflowed)


@njit(cache=True, _nrt=False)  # no reference counting (see _event_loop)
def _event_loop(P, box, state, hist, off, nn, nbr, xb, rho, cnt, ev_t, ev_p, ev_c, hk, hi, hpos, level,
                nlev, rho_max_lv, nc, coff, head, nxt, prv, cell, fs, ks, t_stop, max_coll, p_max, window, t_ref,
                alpha, dilute, max_events, sync_every, g_margin, rho_cap):
    """The event loop of :func:`run_chunk` between two full synchronisations.

    Split out of :func:`run_chunk` (which allocates) so that it and the per-event helpers
    it calls (:func:`_predict`, :func:`_heap_update`, :func:`_local_rebuild`, ...) can be
    compiled without numba's reference counting (``_nrt=False``: they allocate nothing,
    and every array they see is kept alive by :func:`run_chunk`).  With reference
    counting every call incremented and decremented the counts of its array arguments
    with atomic instructions; ``perf`` put a third of the samples of a run of 10^4
    equal spheres to 0.62 on those two instructions (issue 33).  The arithmetic and the
    order of events are unchanged (tests/test_golden.py).

    :func:`_predict`, :func:`_heap_update` and :func:`_sift_down` are inlined here, and only
    here (their copies :func:`_predict_hot`, :func:`_heap_update_hot`, :func:`_sift_down_hot`
    with ``inline="always"``), at one site, the loop over the one or two spheres an event
    reschedules (``i``, then ``j`` after a collision), so their code is compiled into it once:
    a call passed each array as about seven machine words on the stack, and ``perf`` put a
    fifth of the loop's own samples on those pushes (issue 33; 7 % less time at N = 10^4).
    Their other callers (:func:`run_chunk`, the heap builders, the 2D engine
    :mod:`polypack._kernels.edmd2d`) call the plain versions.

    The running scalars travel in ``fs = (t, w_vir, w_ke, t_last, ke)`` and ``ks = (coll,
    events, w_coll, since_sync, pad, n_hist, status)``.  Returns ``LOOP_STOP``,
    ``LOOP_SYNC`` or ``LOOP_REBUILD``.
    """
    n = P.shape[0]
    t = fs[0]
    w_vir = fs[1]
    w_ke = fs[2]
    t_last = fs[3]
    ke = fs[4]
    coll = ks[0]
    events = ks[1]
    w_coll = ks[2]
    since_sync = ks[3]
    pad = ks[4]
    n_hist = ks[5]
    status = ks[6]
    out = LOOP_STOP
    while True:
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
        j = np.int64(ev_p[i])  # int32 in the record
        q2 = -1  # the second sphere of a valid collision (predicted after i)
        if j < 0:
            # shell exit: new shell and neighbour list for sphere i only
            dt = t - P[i, R_T]
            for k in range(3):
                P[i, k] += P[i, 3 + k] * dt
            P[i, R_T] = t
            if P[i, R_G] * t >= rho_cap * (1.0 - 1e-9):
                status = BOX_LIMIT
                break
            rho_new = _shell_radius(P[i, R_G], t, shell_reach(t, t_ref, alpha, dilute), g_margin, rho_cap)
            ok = _local_rebuild(i, rho_new, P, box, xb, rho, off, nn, nbr, level, nlev, rho_max_lv, nc, coff,
                                head, nxt, prv, cell)
            state[S_LOCAL_REBUILDS] += 1
            if not ok:
                pad = min(2 * pad, 1024)
                state[S_REBUILDS] += 0  # overflow: global rebuild with more room
                out = LOOP_REBUILD
                break
        elif cnt[j] == ev_c[i]:
            # valid collision of i and j at time t; the neighbours of both are requested now, so
            # that the misses of j's list and records overlap with i's prediction
            _prefetch_neighbours(i, P, off, nn, nbr)
            _prefetch_neighbours(j, P, off, nn, nbr)
            for p in (i, j):
                dt = t - P[p, R_T]
                for k in range(3):
                    P[p, k] += P[p, 3 + k] * dt
                P[p, R_T] = t
            dx = min_image(P[j, 0] - P[i, 0], box[0])
            dy = min_image(P[j, 1] - P[i, 1], box[1])
            dz = min_image(P[j, 2] - P[i, 2], box[2])
            d = math.sqrt(dx * dx + dy * dy + dz * dz)
            G = P[i, R_G] + P[j, R_G]
            if d > 0.0:
                nx = dx / d
                ny = dy / d
                nz = dz / d
                u = (P[j, 3] - P[i, 3]) * nx + (P[j, 4] - P[i, 4]) * ny + (P[j, 5] - P[i, 5]) * nz
                J = G - u
                if J <= 0.0:
                    J = 1e-12 * (1.0 + abs(u))
                P[i, 3] -= J * nx
                P[i, 4] -= J * ny
                P[i, 5] -= J * nz
                P[j, 3] += J * nx
                P[j, 4] += J * ny
                P[j, 5] += J * nz
                w_ke += ke * (t - t_last)
                t_last = t
                ke += J * (u + J)
                w_vir += J * d
            cnt[i] += 1
            cnt[j] += 1
            coll += 1
            w_coll += 1
            since_sync += 1
            q2 = j
        # the new event of i (after a shell exit, an invalidated event or a collision), then
        # that of j after a collision: one call site, so that the inlined _predict and
        # _heap_update are compiled once
        q = i
        for r in range(2):
            _predict_hot(q, t, P, box, off, nn, nbr, xb, rho, cnt, ev_t, ev_p, ev_c)
            _heap_update_hot(hk, hi, hpos, q, ev_t[q], n)
            if q2 < 0 or r == 1:
                break
            q = q2
        if q2 < 0:
            continue
        if since_sync >= sync_every:
            out = LOOP_SYNC
        if w_coll >= window:
            w_ke += ke * (t - t_last)
            t_last = t
            p, n_hist = _close_window(t, w_ke, w_vir, w_coll, hist, n_hist, state)
            w_coll = 0
            w_vir = 0.0
            w_ke = 0.0
            if p > p_max:
                status = JAMMED
                out = LOOP_STOP
                break
        if out != LOOP_STOP:
            break
    fs[0] = t
    fs[1] = w_vir
    fs[2] = w_ke
    fs[3] = t_last
    fs[4] = ke
    ks[0] = coll
    ks[1] = events
    ks[2] = w_coll
    ks[3] = since_sync
    ks[4] = pad
    ks[5] = n_hist
    ks[6] = status
    return out


@njit(cache=True)
def run_chunk(x, v, g, box, state, params, hist):
    """Advance the growing hard-sphere system by up to ``params[P_MAX_COLLISIONS]`` collisions.

    Parameters
    ----------
    x, v : (N, 3) float64
        Positions (all at time ``state[S_TIME]``) and velocities; updated in place and
        left synchronised at the returned time, positions folded into the box.
    g : (N,) float64
        Growth speeds: radius ``g_i t``.
    box : (3,) float64
    state : (N_STATE,) float64, in/out
        Slots ``S_TIME, S_COLLISIONS, S_EVENTS, S_REBUILDS, S_VIRIAL,
        S_KE_INTEGRAL, S_LOCAL_REBUILDS, S_STATUS`` (counts accumulate across chunks).
    params : (N_PARAMS,) float64 (see :func:`make_params`)
        Slots ``P_T_STOP, P_MAX_COLLISIONS`` (this chunk), ``P_MAX_PRESSURE,
        P_PRESSURE_WINDOW, P_T_REF, P_ALPHA, P_MAX_EVENTS`` (this chunk),
        ``P_SYNC_EVERY, P_DILUTE, P_MARGIN_CAP, P_SPEED`` (shell widths: :func:`shell_reach`,
        :func:`_shell_radius` with ``g_margin = margin_cap * median(g)``; ``speed``, default 1, is the thermal
        speed the velocities are rescaled to at each synchronisation: a speed ``s``
        makes the growth per distance travelled ``1/s`` times faster).
    hist : (H, 3) float64
        Output rows ``(t, reduced pressure, window collisions)``, one per window.

    Returns
    -------
    (status, n_hist) : :class:`ChunkStatus` code (int) and number of rows written to ``hist``.

    Notes
    -----
    Collision rule (equal masses): with ``n`` the unit vector from ``i`` to ``j``
    at contact, ``u = (v_j - v_i).n`` and ``G = g_i + g_j`` the growth speed of the
    contact distance, the normal relative velocity is reflected in the frame of
    the growing surfaces, ``u' - G = -(u - G)``.  The impulse ``J = G - u > 0`` is
    given to ``j`` along ``n`` and taken from ``i``: momentum is conserved, the
    pair separates faster than the contact distance grows, and the kinetic energy
    rises by ``J G``.  The energy is reset to ``3N/2`` (thermal speed 1) with the
    net momentum removed at every full synchronisation (chunk start, every
    ``sync_every`` collisions, global rebuilds).  Reduced pressure over a window
    of collisions: ``Z = PV/(N kT) = 1 + sum(J sigma) / (2 integral(KE dt))``.

    Each sphere owns a shell ``ball(xb_i, rho_i)`` that contains it until its
    shell-exit event; spheres whose shells do not overlap cannot collide, so the
    lists of shell-overlap pairs are complete.  A shell exit rebuilds only that
    sphere's shell and list (multi-level cell grid of shell centres).
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
    speed = params[P_SPEED] if params.shape[0] > P_SPEED else 1.0
    renumber = params[P_RENUMBER] != 0.0 if params.shape[0] > P_RENUMBER else True
    if sync_every <= 0:
        sync_every = 4 * n

    tl = np.empty(n)
    for i in range(n):
        tl[i] = t
    # per-sphere event and shell state in one record per sphere (``E``, columns ``E_*`` and
    # ``I_*``), the heap's keys and spheres side by side; the helpers see strided views
    E = _aligned_rows(n + 1, 8)
    Ei = E.view(np.int32)
    xb = E[:n, E_XB:E_XB + 3]
    rho = E[:n, E_RHO]
    ev_t = E[:n, E_T]
    off = Ei[:, I_OFF]
    nn = Ei[:n, I_NN]
    ev_p = Ei[:n, I_P]
    ev_c = Ei[:n, I_C]
    cnt = Ei[:n, I_CNT]
    hpos = Ei[:n, I_HPOS]
    for i in range(n + 1):
        for k in range(16):
            Ei[i, k] = 0
    H = _aligned_rows(n + HEAP_ROW0 + 1, 2)
    hk = H[HEAP_ROW0:HEAP_ROW0 + n, 0]
    hi = H.view(np.int64)[HEAP_ROW0:HEAP_ROW0 + n, 1]
    rho_o = np.empty(n)  # shell radii in the caller's numbering (global rebuilds)
    level, nlev, gmax_lv = _levels(g)
    gmax = _largest(g)
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
    nbr = np.zeros(0, np.int32)
    pad = np.int64(8)  # an int64, not the literal 8: build_lists compiles once
    rho_cap = 0.249 * min(box[0], min(box[1], box[2]))
    rho_max_lv = np.zeros(nlev)
    fs = np.empty(5)
    ks = np.empty(7, np.int64)
    P = _aligned_rows(n, N_REC)
    # the event loop numbers the spheres along a space-filling curve (renewed at each global
    # rebuild, where every list, shell and event is made anew): its sphere i is the caller's
    # orig[i], the caller's k is its new[k]; x, v, tl and g stay in the caller's numbering
    orig = np.empty(n, np.int64)
    new = np.empty(n, np.int64)
    for i in range(n):
        orig[i] = i
        new[i] = i
    lev = level.copy()  # size levels in the event loop's numbering
    nc, coff, head, nxt, prv, cell = _grid_build(x, level, box, gmax_lv, nlev, n, new)

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
                if renumber:
                    _curve_order(x, box, orig, new)
                for i in range(n):
                    lev[i] = level[orig[i]]
                D = shell_reach(t, t_ref, alpha, dilute)
                for lv in range(nlev):
                    rho_max_lv[lv] = 0.0
                for k in range(n):
                    r = _shell_radius(g[k], t, D, g_margin, rho_cap)
                    rho_o[k] = r
                    i = new[k]
                    for c in range(3):
                        xb[i, c] = x[k, c]
                    rho[i] = r
                    if r > rho_max_lv[level[k]]:
                        rho_max_lv[level[k]] = r
                off_b, nn_b, nbr = build_lists(x, rho_o, box, lev, nlev, pad, new)  # checks the int32 range
                for i in range(n):
                    off[i] = off_b[i]
                    nn[i] = nn_b[i]
                off[n] = off_b[n]
                nc, coff, head, nxt, prv, cell = _grid_build(xb, lev, box, rho_max_lv, nlev, n, new)
                state[S_REBUILDS] += 1
            _to_records(P, x, v, tl, g, orig)
            for i in range(n):
                cnt[i] = 0
            for i in range(n):
                _predict(i, t, P, box, off, nn, nbr, xb, rho, cnt, ev_t, ev_p, ev_c)
            _heap_build_order(hk, hi, hpos, ev_t, new, n)
            need_rebuild = False
            need_sync = False

        fs[0] = t
        fs[1] = w_vir
        fs[2] = w_ke
        fs[3] = t_last
        fs[4] = ke
        ks[0] = coll
        ks[1] = events
        ks[2] = w_coll
        ks[3] = since_sync
        ks[4] = pad
        ks[5] = n_hist
        ks[6] = status
        out = _event_loop(P, box, state, hist, off, nn, nbr, xb, rho, cnt, ev_t, ev_p, ev_c, hk, hi, hpos,
                          lev, nlev, rho_max_lv, nc, coff, head, nxt, prv, cell, fs, ks, t_stop, max_coll, p_max,
                          window, t_ref, alpha, dilute, max_events, sync_every, g_margin, rho_cap)
        _from_records(P, x, v, tl, orig)
        t = fs[0]
        w_vir = fs[1]
        w_ke = fs[2]
        t_last = fs[3]
        ke = fs[4]
        coll = ks[0]
        events = ks[1]
        w_coll = ks[2]
        since_sync = ks[3]
        pad = ks[4]
        n_hist = ks[5]
        status = ks[6]
        if out == LOOP_STOP:
            break
        if out == LOOP_REBUILD:
            need_rebuild = True
        else:
            need_sync = True

    _end_chunk(x, v, tl, t, box, state, coll, events, w_vir, w_ke + ke * (t - t_last), status)
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
    """Compile the kernel :func:`polypack.generate.pack` runs (:func:`run_chunk`) on a tiny input.

    The test oracle :func:`next_event_brute` is left to the tests that call it: a study's
    first run compiles what its stages run and nothing else (issue 33, cold start).
    """
    rng = np.random.default_rng(0)
    n = 16
    box = np.full(3, 6.0)
    x = rng.random((n, 3)) * 6.0
    v = rng.normal(size=(n, 3))
    g = np.full(n, 0.01)
    state = np.zeros(N_STATE)
    params = make_params(50.0, 100.0, 1e6, 16.0, 50.0, 0.3, 1e6, 0.0, 0.5, 3.0)
    hist = np.zeros((16, 3))
    run_chunk(x, v, g, box, state, params, hist)
