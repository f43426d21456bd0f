"""The hot path of the 3D event-driven packer (issue 33): the pruned pair time gives the same
next event as the plain one, the event loop keeps its calendar (heap and fresh predictions) after
every event (the split event loop is covered bit for bit by tests/test_golden.py and its
synchronisation returns by test_pack_options_change_speed_not_physics)."""

import numpy as np
import pytest
from numba import njit

from polypack._kernels import edmd


@njit(cache=False)
def _both(a, best):
    out = np.empty((a.shape[0], 2))
    for k in range(a.shape[0]):
        r = a[k]
        out[k, 0] = edmd.pair_time(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7])
        out[k, 1] = edmd.pair_time_below(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], best[k])
    return out


def test_pair_time_below_is_pair_time_where_it_is_below_best():
    rng = np.random.default_rng(7)
    m = 20000
    a = np.empty((m, 8))
    u = rng.normal(size=(m, 3))
    a[:, :3] = u / np.linalg.norm(u, axis=1)[:, None] * rng.uniform(2.05, 6.0, m)[:, None]  # separation, no overlap
    # relative velocity: mostly towards each other, so that many pairs meet
    a[:, 3:6] = -a[:, :3] / 3.0 * rng.uniform(0.0, 2.0, m)[:, None] + 0.7 * rng.normal(size=(m, 3))
    a[:, 6] = rng.uniform(0.0, 0.1, m)  # growth speed of the contact distance
    a[:, 7] = rng.uniform(0.5, 2.0, m)  # contact distance now
    # a quarter of the pairs grow faster than they move (A < 0): separating ones meet again too
    q = m // 4
    a[:q, 3:6] = 0.3 * rng.normal(size=(q, 3))
    a[:q, 6] = rng.uniform(0.5, 3.0, q)
    exact = _both(a, np.full(m, np.inf))[:, 0]
    finite = np.isfinite(exact) & (exact > 0)
    assert finite.sum() > 2000  # the test reaches the square-root branch often
    dv2 = (a[:, 3:6] ** 2).sum(axis=1)
    separating = (a[:, :3] * a[:, 3:6]).sum(axis=1) - a[:, 7] * a[:, 6] >= 0
    assert (finite & separating & (dv2 < a[:, 6] ** 2)).sum() > 200  # ... and the root of separating pairs
    # best just above, at and just below the true time, and random ones
    shortcut = 0
    for best in (exact * (1 + 1e-12), exact, exact * (1 - 1e-12), rng.uniform(0, 5, m)):
        best = np.where(np.isfinite(best), best, 1.0)
        got = _both(a, best)
        below = got[:, 0] < best
        assert np.array_equal(got[below, 1], got[below, 0])  # bit for bit where it counts
        assert np.all(got[~below, 1] >= best[~below])  # never a false smaller time
        shortcut += (got[:, 1] == np.inf).sum() - (got[:, 0] == np.inf).sum()
    assert shortcut > 500  # the shortcut is taken (with the random best)


def _event_loop_setup(x, v, g, box, t, t_ref=100.0, alpha=0.3, dilute=0.5, margin_cap=3.0):
    """The state :func:`edmd.run_chunk` hands its event loop after a global rebuild (the same
    record and heap views, renumbering, lists, shell grid, first predictions and heap), built in
    Python so that a test can run the loop one event at a time and look at its calendar."""
    n = g.shape[0]
    E = edmd._aligned_rows(n + 1, 8)
    Ei = E.view(np.int32)
    Ei[:] = 0
    xb, rho, ev_t = E[:n, edmd.E_XB:edmd.E_XB + 3], E[:n, edmd.E_RHO], E[:n, edmd.E_T]
    off, nn, ev_p, ev_c = Ei[:, edmd.I_OFF], Ei[:n, edmd.I_NN], Ei[:n, edmd.I_P], Ei[:n, edmd.I_C]
    cnt, hpos = Ei[:n, edmd.I_CNT], Ei[:n, edmd.I_HPOS]
    H = edmd._aligned_rows(n + edmd.HEAP_ROW0 + 1, 2)
    hk = H[edmd.HEAP_ROW0:edmd.HEAP_ROW0 + n, 0]
    hi = H.view(np.int64)[edmd.HEAP_ROW0:edmd.HEAP_ROW0 + n, 1]
    level, nlev, _ = edmd._levels(g)
    g_margin = margin_cap * float(np.median(g))
    rho_cap = 0.249 * float(box.min())
    orig, new = np.empty(n, np.int64), np.empty(n, np.int64)
    edmd._curve_order(x, box, orig, new)
    lev = level[orig].copy()
    D = edmd.shell_reach(t, t_ref, alpha, dilute)
    rho_o = np.array([edmd._shell_radius(g[k], t, D, g_margin, rho_cap) for k in range(n)])
    xb[new] = x
    rho[new] = rho_o
    rho_max_lv = np.zeros(nlev)
    np.maximum.at(rho_max_lv, level, rho_o)
    off_b, nn_b, nbr = edmd.build_lists(x, rho_o, box, lev, nlev, np.int64(8), new)
    off[:] = off_b
    nn[:] = nn_b
    nc, coff, head, nxt, prv, cell = edmd._grid_build(xb, lev, box, rho_max_lv, nlev, n, new)
    P = edmd._aligned_rows(n, edmd.N_REC)
    edmd._to_records(P, x, v, np.full(n, t), g, orig)
    for i in range(n):
        edmd._predict(i, t, P, box, off, nn, nbr, xb, rho, cnt, ev_t, ev_p, ev_c)
    edmd._heap_build_order(hk, hi, hpos, ev_t, new, n)
    return dict(P=P, box=box, off=off, nn=nn, nbr=nbr, xb=xb, rho=rho, cnt=cnt, ev_t=ev_t, ev_p=ev_p, ev_c=ev_c,
                hk=hk, hi=hi, hpos=hpos, lev=lev, nlev=nlev, rho_max_lv=rho_max_lv,
                grid=(nc, coff, head, nxt, prv, cell),
                t_ref=t_ref, alpha=alpha, dilute=dilute, g_margin=g_margin, rho_cap=rho_cap)


def test_event_calendar_after_every_event():
    """The event loop one event at a time (``max_events`` one more per call) on 30 growing spheres
    of two sizes: after every event each sphere's heap slot holds its event time, the 4-ary heap is
    ordered, no event lies before the present, and the sphere(s) the event moved hold a fresh
    prediction: after a collision both partners, after a shell exit or a stale event the one
    sphere (their events re-predicted from the state the loop left must come out the same, bit for
    bit).  A collision whose second sphere kept its old event fails here within one event, where a
    whole pack would run on with a wrong calendar (issue 33: the reschedule loop of the inlined
    prediction)."""
    rng = np.random.default_rng(4)
    n, t = 30, 100.0
    g = np.where(np.arange(n) % 5 == 0, 0.02, 0.01)  # radii 2 and 1 at t = 100: two size levels
    L = (4.0 / 3.0 * np.pi * ((g * t) ** 3).sum() / 0.25) ** (1.0 / 3.0)  # volume fraction 0.25
    box = np.full(3, L)
    x = np.empty((n, 3))
    for k in range(n):  # random sequential addition, no overlap
        while True:
            p = rng.random(3) * L
            d = x[:k] - p
            d -= L * np.round(d / L)
            if np.all((d ** 2).sum(axis=1) > (g[:k] * t + g[k] * t + 0.01) ** 2):
                break
        x[k] = p
    v = rng.normal(size=(n, 3))
    v -= v.mean(axis=0)
    s = _event_loop_setup(x, v, g, box, t)
    P, hk, hi, hpos, cnt, ev_t, ev_p, ev_c = (s[k] for k in ("P", "hk", "hi", "hpos", "cnt", "ev_t", "ev_p", "ev_c"))
    state = np.zeros(edmd.N_STATE)
    hist = np.zeros((4, 3))
    fs = np.array([t, 0.0, 0.0, t, 0.5 * (v ** 2).sum()])
    ks = np.array([0, 0, 0, 0, 8, 0, edmd.CHUNK_DONE], np.int64)
    seen = {"collision": 0, "exit": 0, "stale": 0}

    def repredicted_same(q):
        before = (ev_t[q], ev_p[q], ev_c[q])
        edmd._predict(q, fs[0], P, box, s["off"], s["nn"], s["nbr"], s["xb"], s["rho"], cnt, ev_t, ev_p, ev_c)
        return before == (ev_t[q], ev_p[q], ev_c[q])

    for step in range(600):
        i = hi[0]
        te = hk[0]
        j = ev_p[i]
        kind = "exit" if j < 0 else "collision" if cnt[j] == ev_c[i] else "stale"
        cnt0 = cnt.copy()
        out = edmd._event_loop(P, box, state, hist, s["off"], s["nn"], s["nbr"], s["xb"], s["rho"], cnt, ev_t, ev_p,
                               ev_c, hk, hi, hpos, s["lev"], s["nlev"], s["rho_max_lv"], *s["grid"], fs, ks, np.inf,
                               10 ** 9, np.inf, 10 ** 9, s["t_ref"], s["alpha"], s["dilute"], int(ks[1]) + 1, 10 ** 9,
                               s["g_margin"], s["rho_cap"])
        assert out == edmd.LOOP_STOP and ks[6] == edmd.EVENT_BUDGET, (step, out, ks[6])
        assert fs[0] == te, step
        seen[kind] += 1
        moved = [i, j] if kind == "collision" else [i]
        if kind == "collision":
            cnt0[moved] += 1
        assert np.array_equal(cnt, cnt0), (step, kind)
        # the calendar: every sphere's key in its slot, the heap ordered, nothing in the past
        assert np.array_equal(hi[hpos], np.arange(n)), step
        assert np.array_equal(hk[hpos], ev_t), step
        assert np.all(hk[(np.arange(1, n) - 1) // 4] <= hk[1:]), step
        assert np.all(ev_t >= fs[0]), step
        for q in moved:
            assert P[q, edmd.R_T] == fs[0], (step, kind, q)
            assert repredicted_same(q), (step, kind, q)
    assert seen["collision"] >= 100 and seen["exit"] >= 20 and seen["stale"] >= 5, seen  # every branch, often



def test_curve_order_is_a_local_permutation():
    """The renumbering of the event loop (edmd._curve_order) is a permutation with its inverse,
    and spheres next to each other in it are close in space (Morton order of ~1-sphere cells):
    the mean distance between consecutive spheres is a few cell sides, not a fraction of the box."""
    rng = np.random.default_rng(5)
    n = 4000
    box = np.array([20.0, 20.0, 10.0])
    x = rng.random((n, 3)) * box
    orig = np.empty(n, np.int64)
    new = np.empty(n, np.int64)
    edmd._curve_order(x, box, orig, new)
    assert np.array_equal(np.sort(orig), np.arange(n))
    assert np.array_equal(new[orig], np.arange(n))
    d = x[orig[1:]] - x[orig[:-1]]
    d -= box * np.round(d / box)
    step = np.sqrt((d ** 2).sum(axis=1)).mean()
    cell = (box.prod() / n) ** (1 / 3)  # 1.36
    assert step < 2.5 * cell  # random order: about 0.66 * 20 = 13; Morton measured 1.9 cells
    assert not np.array_equal(orig, np.arange(n))


_MAKE_PARAMS = edmd.make_params


def _pack_with(monkeypatch, renumber, **kw):
    import polypack as pp

    monkeypatch.setattr(edmd, "make_params", lambda *a, **k: _MAKE_PARAMS(*a, **k, renumber=renumber))
    return pp.pack(**kw)


def test_renumbering_is_undone_bit_for_bit(monkeypatch):
    """The event loop runs on spheres renumbered along a space-filling curve (issue 33: memory
    locality); the caller gets its own numbering back and the very same pack as without the
    renumbering: positions, radii, pressure history and every count bit for bit (a bidisperse mix
    of size ratio 2.5,
    chunks of 3000 collisions and a synchronisation every 700, so that renumbering, rebuilds and
    synchronisations alternate many times; the default path is the golden record's)."""
    from polypack.generate import PackTuning

    radii = np.where(np.arange(400) % 10 == 0, 2.5, 1.0)  # two size levels of the shell grid
    kw = dict(sizes=radii, volume_fraction=0.6, seed=11, growth_rate=0.05, progress=False,
              tuning=PackTuning(chunk_collisions=3000, sync_every=700))
    a = _pack_with(monkeypatch, False, **kw)
    b = _pack_with(monkeypatch, True, **kw)
    assert a.meta["collisions"] > 15000 and a.meta["rebuilds"] > 6
    for key in ("collisions", "events", "rebuilds", "shell_rebuilds"):
        assert a.meta[key] == b.meta[key], key
    assert np.array_equal(a.positions, b.positions)
    assert np.array_equal(a.radii, b.radii)
    assert np.array_equal(np.array(a.meta["pressure_history"]), np.array(b.meta["pressure_history"]))


def test_records_and_heap_rows_are_cache_line_aligned():
    """The layout the event loop's speed rests on (issue 33): each sphere's records ``P`` and ``E``
    are one 64-byte line, and the heap's rows put the four children of every slot (slots
    4s+1 .. 4s+4, in rows 4s+1+HEAP_ROW0 ..) in one line."""
    for n in (1, 7, 1000, 4097):
        P = edmd._aligned_rows(n, edmd.N_REC)
        assert P.shape == (n, 8) and P.strides == (64, 8) and P.ctypes.data % 64 == 0
        H = edmd._aligned_rows(n + edmd.HEAP_ROW0 + 1, 2)
        assert H.strides == (16, 8)
        for s in range(0, min(n, 50)):
            first_child_row = 4 * s + 1 + edmd.HEAP_ROW0
            assert (H.ctypes.data + 16 * first_child_row) % 64 == 0
    # the int32 columns of E lie after its five float columns, inside the row
    assert min(edmd.I_OFF, edmd.I_NN, edmd.I_P, edmd.I_C, edmd.I_CNT, edmd.I_HPOS) * 4 >= (edmd.E_T + 1) * 8
    assert len({edmd.I_OFF, edmd.I_NN, edmd.I_P, edmd.I_C, edmd.I_CNT, edmd.I_HPOS}) == 6


def test_slab_lists_refuse_int32_overflow_before_allocating():
    """The int32 slab offsets of the records: lists beyond 2^31 entries raise before the (>= 8 GB)
    allocation, and a list just inside the range would be laid out (offsets, not memory, checked)."""
    pi = np.array([0], np.int64)
    pj = np.array([1], np.int64)
    level = np.zeros(2, np.int64)
    with pytest.raises(ValueError, match="2\\^31"):
        edmd._slab_lists(pi, pj, 2, level, 1, np.int64(2 ** 30))  # 2 x (2 + 2^30) > 2^31 - 1
    off, nn, nbr = edmd._slab_lists(pi, pj, 2, level, 1, np.int64(8))
    assert list(off) == [0, 10, 20] and list(nn) == [1, 1] and nbr[0] == 1 and nbr[10] == 0


def _sift_down_scan(hk, hi, hpos, k, n):
    """The heap's sift-down as it was written before the select tournament (plain Python): the
    first of the smallest children wins, the oracle of the slot-for-slot test below."""
    key, idx = hk[k], hi[k]
    while 4 * k + 1 < n:
        c = 4 * k + 1
        best = c
        for q in range(c + 1, min(c + 4, n)):
            if hk[q] < hk[best]:
                best = q
        if hk[best] >= key:
            break
        hk[k], hi[k] = hk[best], hi[best]
        hpos[hi[k]] = k
        k = best
    hk[k], hi[k], hpos[idx] = key, idx, k


@pytest.mark.parametrize("n", [6, 13, 200])
def test_sift_down_tournament_keeps_the_heap_slot_for_slot(n):
    """``_sift_down`` chooses among four children by selects (issue 33); with many equal keys
    (ties decide which of two simultaneous events comes first, hence the pack) every slot of
    the heap must be that of the scan it replaced, after builds and after root updates."""
    rng = np.random.default_rng(n)
    key = rng.integers(0, 5, n).astype(float)  # few distinct values: ties at every level
    hk, hi, hpos = np.empty(n), np.empty(n, np.int64), np.empty(n, np.int64)
    edmd._heap_build(hk, hi, hpos, key, n)
    rk, ri, rp = key.copy(), np.arange(n), np.arange(n)
    for k in range((n - 2) // 4, -1, -1):
        _sift_down_scan(rk, ri, rp, k, n)
    assert np.array_equal(hk, rk) and np.array_equal(hi, ri) and np.array_equal(hpos, rp)
    for step in range(300):
        i = hi[0] if step % 3 else rng.integers(n)
        new = float(hk[hpos[i]] + rng.integers(0, 3))  # later or equal: a sift towards the leaves
        edmd._heap_update(hk, hi, hpos, i, new, n)
        k = rp[i]
        rk[k] = new
        _sift_down_scan(rk, ri, rp, k, n)
        assert np.array_equal(hk, rk) and np.array_equal(hi, ri) and np.array_equal(hpos, rp), step
