"""Tests of the Lubachevsky–Stillinger packer (polypack.pack, polypack._kernels.edmd)."""

import math
import signal

import numpy as np
import pytest

import polypack as pp
from polypack._kernels import edmd
from polypack.generate import PackTuning
from polypack.generate.lubachevsky import carnahan_starling as module_carnahan_starling


def carnahan_starling(eta):
    """Carnahan-Starling Z = (1 + eta + eta^2 - eta^3) / (1 - eta)^3, written out in the test."""
    eta = np.asarray(eta, dtype=np.float64)
    return (1 + eta + eta**2 - eta**3) / (1 - eta) ** 3


# ---------------------------------------------------------------- collision time
def _root_by_scan(dr, dv, G, sig0, s_max=50.0, steps=20000):
    """First s >= 0 where |dr + dv s| - (sig0 + G s) crosses zero from above (bisection)."""
    s = np.linspace(0.0, s_max, steps)
    f = np.linalg.norm(dr[None, :] + s[:, None] * dv[None, :], axis=1) - (sig0 + G * s)
    idx = np.flatnonzero((f[:-1] > 0) & (f[1:] <= 0))
    if idx.size == 0:
        return math.inf
    lo, hi = s[idx[0]], s[idx[0] + 1]
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        fm = np.linalg.norm(dr + mid * dv) - (sig0 + G * mid)
        if fm > 0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def test_pair_time_matches_root_scan():
    rng = np.random.default_rng(7)
    checked_finite = 0
    for _ in range(200):
        dr = rng.normal(size=3) * 3.0
        dv = rng.normal(size=3)
        G = rng.uniform(0.0, 0.6)
        sig0 = rng.uniform(0.0, 0.9) * np.linalg.norm(dr)
        s = edmd.pair_time(*dr, *dv, G, sig0)
        ref = _root_by_scan(dr, dv, G, sig0)
        if math.isinf(ref):
            # the scan window is finite: only check that no root exists within it
            assert s > 49.9
        else:
            checked_finite += 1
            assert s == pytest.approx(ref, rel=1e-7, abs=1e-9)
    assert checked_finite > 25


def test_pair_time_nearly_touching_is_stable():
    # cancellation-prone case: almost touching, slowly approaching
    dr = np.array([2.0 + 1e-12, 0.0, 0.0])
    dv = np.array([-1e-3, 0.0, 0.0])
    s = edmd.pair_time(*dr, *dv, 0.0, 2.0)
    assert s == pytest.approx(1e-9, rel=1e-6)
    # separating without growth: never
    assert math.isinf(edmd.pair_time(*dr, *(-dv), 0.0, 2.0))
    # separating slower than the contact distance grows: they meet again
    assert edmd.pair_time(3.0, 0.0, 0.0, 0.009, 0.0, 0.0, 0.01, 2.0) == pytest.approx(1000.0, rel=1e-12)
    # touching and closing in the frame of the growing surfaces: collide now
    assert edmd.pair_time(2.0, 0.0, 0.0, 0.001, 0.0, 0.0, 0.01, 2.0) == 0.0


def _earliest_collision(x, v, g, box, t, images=2):
    """Oracle written here (numpy, no kernel code): earliest contact over all pairs and images.

    Radii grow as g t, so a pair touches when |dr + dv s| = G (t + s), G = g_i + g_j:
    (dv.dv - G^2) s^2 + 2 (dr.dv - G^2 t) s + dr.dr - (G t)^2 = 0, smallest root s > 0.
    """
    n = x.shape[0]
    i, j = np.triu_indices(n, 1)
    rng_i = np.arange(-images, images + 1)
    shifts = np.stack(np.meshgrid(rng_i, rng_i, rng_i, indexing="ij"), -1).reshape(-1, 3) * box
    dr = (x[j] - x[i])[:, None, :] + shifts[None]  # (pairs, images, 3)
    dv = (v[j] - v[i])[:, None, :]
    G = (g[i] + g[j])[:, None]
    a = np.sum(dv * dv, -1) - G**2
    b = np.sum(dr * dv, -1) - G * G * t
    c = np.sum(dr * dr, -1) - (G * t) ** 2
    assert np.all(c > -1e-9 * np.sum(dr * dr, -1))  # no overlap at time t (touching: round-off)
    disc = b * b - a * c
    with np.errstate(invalid="ignore", divide="ignore"):
        sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
        r1, r2 = (-b - sq) / a, (-b + sq) / a
    # a root is a collision if the gap closes there: d/ds (gap^2) = 2 (a s + b) < 0
    roots = np.where((r1 >= 0) & np.isfinite(r1) & (a * r1 + b < 0), r1, np.inf)
    roots = np.minimum(roots, np.where((r2 >= 0) & np.isfinite(r2) & (a * r2 + b < 0), r2, np.inf))
    k = np.unravel_index(np.argmin(roots), roots.shape)
    return t + roots[k], i[k[0]], j[k[0]]


def test_next_event_agrees_with_brute_force_oracle():
    """Each collision processed by the kernel is the earliest over all pairs and images
    (an oracle that shares no code with the kernel's pair_time)."""
    rng = np.random.default_rng(11)
    for trial in range(3):
        n = 12
        side = 7.0
        x = rng.random((n, 3)) * side
        v = rng.normal(size=(n, 3))
        radii = rng.uniform(0.5, 1.5, n)
        g = 0.05 * radii
        box = np.full(3, side)
        state = np.zeros(8)
        t_stop = 0.24 * side / g.max()
        checked = 0
        for step in range(60):
            edmd._thermalise(v)
            t = state[0]
            t_ref, i_ref, j_ref = _earliest_collision(x, v, g, box, t)
            assert t_ref == pytest.approx(edmd.next_event_brute(x, v, g, box, t)[0], rel=1e-9)
            if not t_ref < t_stop:
                break
            params = np.array([t_stop, 1.0, 1e12, 1e9, t_stop, 0.3, 1e9, 0.0, 0.3, 3.0])
            hist = np.zeros((4, 3))
            edmd.run_chunk(x, v, g, box, state, params, hist)
            assert state[0] == pytest.approx(t_ref, rel=1e-9, abs=1e-12), (trial, step)
            checked += 1
        assert checked >= 20


@pytest.mark.parametrize("n", [1, 2, 5, 17, 200])
def test_event_queue_root_is_the_earliest_after_any_updates(n):
    """The 4-ary indexed heap: root = argmin of the keys, positions consistent, after random updates."""
    rng = np.random.default_rng(n)
    key = rng.random(n)
    hk, hi, hpos = np.empty(n), np.empty(n, np.int64), np.empty(n, np.int64)
    edmd._heap_build(hk, hi, hpos, key, n)
    for step in range(500):
        assert hk[0] == key.min() and key[hi[0]] == key.min()
        assert np.array_equal(hi[hpos], np.arange(n)) and np.array_equal(hk, key[hi])
        i = hi[0] if step % 2 else rng.integers(n)  # the root (as after an event) or any sphere
        key[i] = key[i] + rng.normal() if step % 3 else np.inf
        edmd._heap_update(hk, hi, hpos, i, key[i], n)


# ------------------------------------------------------------------ no overlaps
def _bidisperse(n_large, n_small, ratio):
    r = np.r_[np.full(n_large, 1.0), np.full(n_small, 1.0 / ratio)]
    sp = np.r_[np.zeros(n_large, int), np.ones(n_small, int)]
    return r, sp


@pytest.mark.parametrize("seed", range(6))
def test_no_overlap_and_exact_fraction_polydisperse(seed):
    rng = np.random.default_rng(seed)
    radii = np.exp(rng.uniform(0.0, np.log(4.0), 300))
    pk = pp.pack(radii, 0.58, seed=seed)
    assert pk.meta["status"] == "target"
    assert pk.min_gap() >= 0.0
    np.testing.assert_array_equal(pk.radii, radii)
    assert pk.volume_fraction == pytest.approx(0.58, rel=1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_no_overlap_size_ratio_10(seed):
    # diameter ratio 1:10, similar volume in both classes
    radii, sp = _bidisperse(8, 4000, 10.0)
    pk = pp.pack(radii, 0.6, seed=seed, species=sp)
    assert pk.meta["status"] == "target"
    assert pk.min_gap() >= 0.0
    np.testing.assert_array_equal(pk.species, sp)
    np.testing.assert_array_equal(pk.radii, radii)
    assert pk.volume_fraction == pytest.approx(0.6, rel=1e-9)


def test_touching_pair_across_boundary_continuation():
    rng = np.random.default_rng(3)
    side = 12.0
    n = 30
    pos = rng.random((n, 3)) * side
    radii = np.full(n, 0.5)
    # make a dilute valid start, then put spheres 0 and 1 in contact across x = 0
    pos[0] = [0.2, 6.0, 6.0]
    pos[1] = [side - 0.8, 6.0, 6.0]
    for k in range(2, n):
        while True:
            d = pp.neighbors.minimum_image(pos[:k] - pos[k], np.full(3, side))
            if np.all(np.linalg.norm(d, axis=1) > 1.05):
                break
            pos[k] = rng.random(3) * side
    start = pp.Packing(pos, radii, side)
    assert start.min_gap() == pytest.approx(0.0, abs=1e-12)
    out = pp.pack(start, volume_fraction=0.3, seed=1)
    assert out.meta["status"] == "target"
    assert out.min_gap() >= 0.0
    assert out.volume_fraction == pytest.approx(0.3, rel=1e-9)
    assert out.meta["continued"] is True


def test_continuation_reaches_next_fraction():
    radii = np.random.default_rng(2).uniform(1.0, 2.0, 400)
    a = pp.pack(radii, 0.5, seed=1)
    b = pp.pack(a, 0.56, seed=2)
    assert b.meta["status"] == "target"
    assert b.volume_fraction == pytest.approx(0.56, rel=1e-9)
    assert b.min_gap() >= 0.0
    np.testing.assert_array_equal(b.radii, radii)
    assert len(b.meta["history"]) == 2
    # the start configuration is kept: a tiny step moves spheres very little
    c = pp.pack(b, 0.5601, seed=3)
    scale = (0.5601 / 0.56) ** (1 / 3)  # box shrinks by this factor
    d = pp.neighbors.minimum_image(c.positions * scale - b.positions, b.box)
    assert np.median(np.linalg.norm(d, axis=1)) < 0.3 * radii.mean()


# ----------------------------------------------------------------- physics
def test_reduced_pressure_matches_carnahan_starling():
    """Slow growth through φ≈0.45: the collision virial gives the equilibrium fluid pressure."""
    pk = pp.pack(np.ones(500), 0.42, seed=3, growth_rate=0.05)
    pk2 = pp.pack(pk, 0.46, seed=4, growth_rate=0.001)
    h = np.array(pk2.meta["pressure_history"])
    sel = h[:, 0] > 0.44
    assert sel.sum() > 50
    ratio = np.mean(h[sel, 1] / carnahan_starling(h[sel, 0]))
    assert abs(ratio - 1.0) < 0.02, ratio
    # an ideal gas value or a virial off by a factor 2 would be far outside
    assert carnahan_starling(0.45) > 9


def test_fast_start_leaves_an_equilibrium_fluid():
    """The dilute start grows 10x faster up to φ=0.3; soon after, at the requested slow
    rate, the pressure is the equilibrium (Carnahan–Starling) one again."""
    pk = pp.pack(np.ones(500), 0.6, seed=7, growth_rate=0.01)
    assert pk.meta["fast_start"] == {"growth_factor": 10.0, "until_fraction": 0.3}
    h = np.array(pk.meta["pressure_history"])
    assert h[0, 0] >= 0.3  # no record of the fast start
    sel = (h[:, 0] > 0.3) & (h[:, 0] < 0.36)
    assert sel.sum() > 20
    ratio = np.mean(h[sel, 1] / carnahan_starling(h[sel, 0]))
    assert abs(ratio - 1.0) < 0.025, ratio  # measured +0.9 %, as without the fast start
    # at most half the target; switched off with fast_growth=1
    assert pp.pack(np.ones(200), 0.2, seed=1).meta["fast_start"]["until_fraction"] == 0.1
    assert pp.pack(np.ones(200), 0.2, seed=1, fast_growth=1).meta["fast_start"] is None
    with pytest.raises(pp.InvalidInputError, match="fast_growth"):
        pp.pack(np.ones(200), 0.2, fast_growth=0.5)


def test_jamming_density_monodisperse_fast():
    pk = pp.pack(np.ones(500), "jammed", seed=5, growth_rate=0.02)
    assert pk.meta["status"] == "jammed"
    assert 0.63 <= pk.volume_fraction <= 0.65
    assert pk.meta["reduced_pressure"] > 1e6
    assert pk.meta["jamming_estimate"] == pytest.approx(pk.volume_fraction, rel=1e-4)
    assert pk.min_gap() >= 0.0


@pytest.mark.slow
def test_jamming_density_rises_as_growth_slows():
    phis = []
    for gamma in (0.05, 0.02, 0.004):
        vals = [pp.pack(np.ones(500), "jammed", seed=s, growth_rate=gamma).volume_fraction for s in (1, 2)]
        phis.append(np.mean(vals))
    assert all(0.63 <= p <= 0.65 for p in phis), phis
    assert phis[0] < phis[1] < phis[2], phis
    assert 0.63 <= phis[1] <= 0.65


def test_seed000_bimodal_pack_keeps_species():
    # seed 000: N=2000, size ratio λ=0.313, volume ratio ξ=c2/c1=0.333 -> 168 large spheres
    n1, n = 168, 2000
    radii = np.r_[np.full(n1, 1.0), np.full(n - n1, 0.313)]
    sp = np.r_[np.zeros(n1, int), np.ones(n - n1, int)]
    pk = pp.pack(radii, 0.6, seed=1, species=sp)
    assert pk.meta["status"] == "target"
    assert pk.volume_fraction == pytest.approx(0.6, rel=1e-9)
    np.testing.assert_array_equal(pk.species_counts, [168, 1832])
    c1, c2 = pk.species_fractions
    assert c2 / c1 == pytest.approx(0.333, abs=0.002)
    assert pk.min_gap() >= 0.0


class _SizeSetLike:
    def __init__(self, radii, species):
        self.radii = radii
        self.species = species


def test_sizeset_duck_typing_and_meta():
    s = _SizeSetLike(np.r_[np.full(20, 2.0), np.full(200, 1.0)], np.r_[np.zeros(20, int), np.ones(200, int)])
    pk = pp.pack(s, 0.5, seed=9)
    np.testing.assert_array_equal(pk.species, s.species)
    m = pk.meta
    for key in ("status", "collisions", "events", "wall_time", "collisions_per_second", "pressure_history",
                "jamming_estimate", "growth_rate", "seed", "min_gap", "shrink_factor"):
        assert key in m
    assert m["seed"]["entropy"] == 9
    again = pp.pack(s, 0.5, seed=9)
    np.testing.assert_array_equal(again.positions, pk.positions)


def test_result_does_not_depend_on_the_clock(monkeypatch):
    """Same seed, same pack whether the machine is idle or loaded: chunk boundaries
    (full synchronisations) are set by collision counts, not by the measured rate."""
    from polypack.generate import lubachevsky as lub

    radii = np.where(np.arange(400) < 40, 3.0, 1.0)
    opts = dict(tuning=pp.generate.PackTuning(chunk_collisions=20_000), growth_rate=0.005)
    ref = pp.pack(radii, 0.55, seed=4, **opts)
    assert ref.meta["collisions"] > 3 * 20_000  # several chunks

    real = lub.time.perf_counter
    for slow in (1e-3, 1e3):  # a clock that runs 1000x fast or slow
        monkeypatch.setattr(lub.time, "perf_counter", lambda s=slow: real() * s)
        pk = pp.pack(radii, 0.55, seed=4, **opts)
        np.testing.assert_array_equal(pk.positions, ref.positions)
        assert pk.meta["collisions"] == ref.meta["collisions"]
    monkeypatch.undo()


def test_budgets():
    pk = pp.pack(np.ones(300), 0.6, seed=1, max_collisions=5000)
    assert pk.meta["status"] == "collision_budget"
    assert pk.meta["collisions"] == 5000
    assert pk.volume_fraction < 0.6
    assert pk.min_gap() >= 0.0


def test_infeasible_target_ends_jammed():
    pk = pp.pack(np.ones(200), 0.8, seed=1, max_pressure=1e4)
    assert pk.meta["status"] == "jammed"
    assert 0.55 < pk.volume_fraction < 0.66
    assert pk.min_gap() >= 0.0


# ----------------------------------------------------------------- errors
@pytest.mark.parametrize(
    "args, kwargs, err",
    [
        ((np.ones(1),), {}, pp.InvalidInputError),
        ((np.array([1.0, -1.0, 1.0]),), {}, pp.InvalidInputError),
        ((np.array([1.0, np.nan, 1.0]),), {}, pp.InvalidInputError),
        ((np.ones(10), 1.2), {}, pp.InvalidInputError),
        ((np.ones(10), "max"), {}, pp.InvalidInputError),
        ((np.ones(10),), {"bogus": 1}, TypeError),  # explicit keyword-only options
        ((np.ones(10),), {"growth_rate": -1.0}, pp.InvalidInputError),
        ((np.r_[10.0, np.ones(5)], 0.5), {}, pp.InfeasibleError),
        ((10,), {}, pp.InvalidInputError),
    ],
)
def test_errors(args, kwargs, err):
    with pytest.raises(err):
        pp.pack(*args, seed=1, **kwargs)


def test_error_below_continuation_fraction():
    pk = pp.pack(np.ones(100), 0.4, seed=1)
    with pytest.raises(pp.InvalidInputError, match="below"):
        pp.pack(pk, 0.3)


def test_time_budget_and_interrupt(monkeypatch):
    pk = pp.pack(np.ones(2000), "jammed", seed=1, max_seconds=0.3, tuning=pp.generate.PackTuning(chunk_collisions=20000))
    assert pk.meta["status"] == "time_budget"
    assert pk.min_gap() >= 0.0

    real = edmd.run_chunk
    calls = {"n": 0}

    def interrupting(*args):
        calls["n"] += 1
        out = real(*args)
        if calls["n"] == 2:
            signal.raise_signal(signal.SIGINT)  # a real Ctrl-C, delivered while the kernel runs
        return out

    monkeypatch.setattr(edmd, "run_chunk", interrupting)
    with pytest.raises(pp.errors.Interrupted) as info:
        pp.pack(np.ones(300), 0.6, seed=1, tuning=pp.generate.PackTuning(chunk_collisions=2000))
    assert calls["n"] == 2  # stopped at the safe point right after the chunk it arrived in
    part = info.value.partial
    assert part.meta["status"] == "interrupted"
    assert part.volume_fraction < 0.6
    assert part.min_gap() >= 0.0
    assert isinstance(info.value, KeyboardInterrupt)  # never swallowed by ``except Exception``
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # handler restored


def test_too_few_spheres_to_jam():
    with pytest.raises(pp.InfeasibleError):
        pp.pack(np.ones(3), "jammed", seed=1)


def test_overlapping_start_rejected():
    pos = np.array([[1.0, 1.0, 1.0], [1.5, 1.0, 1.0], [5.0, 5.0, 5.0]])
    start = pp.Packing(pos, np.full(3, 0.5), 10.0)
    with pytest.raises(pp.OverlapError):
        pp.pack(start, 0.1)


def test_pack_accepts_psd_sizeset():
    from polypack import psd

    s = psd.Bimodal(size_ratio=0.313, volume_ratio=0.333, d_large=1.0).sample(n=600, seed=1)
    pk = pp.pack(s, volume_fraction=0.55, seed=1)
    np.testing.assert_array_equal(pk.radii, s.radii)
    np.testing.assert_array_equal(pk.species, s.species)
    assert pk.volume_fraction == pytest.approx(0.55, rel=1e-9)
    assert pk.min_gap() >= 0.0


def test_kernel_warmup_runs():
    # warmup compiles (or loads from the cache) the kernels pack needs
    edmd.warmup()
    assert edmd.run_chunk.signatures
    # the packer's equation of state is Carnahan-Starling: 1.109/0.729, 1.363/0.343, 1.561375/0.166375
    eta = np.array([0.1, 0.3, 0.45])
    assert np.allclose(module_carnahan_starling(eta), [1.109 / 0.729, 1.363 / 0.343, 1.561375 / 0.166375], rtol=1e-12)


def test_default_skin_follows_the_volume_weighted_size():
    from polypack.generate.lubachevsky import default_skin

    assert default_skin(np.ones(10)) == 0.25
    assert default_skin(np.r_[np.full(168, 1.0), np.full(1832, 0.313)]) == pytest.approx(0.6)  # seed 000
    assert default_skin(np.r_[np.full(107, 3.0), np.ones(2893)]) == pytest.approx(0.5, abs=0.01)
    # a few coarse spheres holding little volume leave the margin of the fines alone
    assert default_skin(np.r_[np.full(2, 3.0), np.ones(2000)]) == pytest.approx(0.25, abs=0.02)


def test_event_budget_is_shared_by_all_chunks():
    """max_events caps the events of the whole run, however many chunks it takes."""
    pk = pp.pack(np.ones(300), 0.6, seed=1, max_events=20000, tuning=PackTuning(chunk_collisions=1000))
    assert pk.meta["status"] == "event_budget"
    assert pk.meta["events"] == 20000
    assert pk.meta["collisions"] > 1000  # several chunks
    assert pk.volume_fraction < 0.6
    assert pk.min_gap() >= 0.0


def test_box_limit_in_jammed_mode():
    """One sphere of radius 4 among 12 of radius 1: it reaches half the box before the
    others can jam it (the kernel's box_limit), which pack reports as InfeasibleError."""
    with pytest.raises(pp.InfeasibleError, match="before the largest one reaches half the box"):
        pp.pack(np.r_[4.0, np.ones(12)], "jammed", seed=1)


@pytest.mark.parametrize("options", [dict(skin=0.1, dilute_skin=0.1), dict(skin=1.0, dilute_skin=2.0, margin_cap=3.0),
                                     dict(sync_every=50, pressure_window=200)])
def test_pack_options_change_speed_not_physics(options):
    """Shell margins, their cap, synchronisation and the pressure window change the work
    per collision only (the default_skin docstring claims it): the same equilibrium fluid
    pressure (Carnahan-Starling, written out here, within 2 %: the scatter of the mean
    over ~100 windows of 200-500 collisions is < 0.5 %) and the same target."""
    tune = {k: v for k, v in options.items() if k != "pressure_window"}
    kw = {k: v for k, v in options.items() if k == "pressure_window"}
    pk = pp.pack(np.ones(500), 0.42, seed=3, growth_rate=0.05, tuning=PackTuning(**tune), **kw)
    pk2 = pp.pack(pk, 0.46, seed=4, growth_rate=0.001, tuning=PackTuning(**tune), **kw)
    assert pk2.volume_fraction == pytest.approx(0.46, rel=1e-9)
    assert pk2.min_gap() >= 0.0
    h = np.array(pk2.meta["pressure_history"])
    sel = h[:, 0] > 0.44
    assert sel.sum() > 50
    eta = h[sel, 0]
    cs = (1 + eta + eta**2 - eta**3) / (1 - eta) ** 3
    assert abs(np.mean(h[sel, 1] / cs) - 1.0) < 0.02
    if "pressure_window" in options:
        assert np.all(np.diff(h[:, 0]) > 0) and sel.sum() > 200  # 200-collision windows


def test_packer_kernel_boundary_is_named():
    """No raw slot numbers or status codes cross the packer's kernel boundary."""
    import re
    from pathlib import Path

    from polypack._kernels import edmd

    assert [int(s) for s in edmd.ChunkStatus] == list(range(5))
    p = edmd.make_params(t_stop=1.0, max_collisions=2.0, max_pressure=3.0, pressure_window=4.0, t_ref=5.0,
                         alpha=6.0, max_events=7.0, sync_every=8.0, dilute=9.0, margin_cap=10.0, speed=11.0)
    assert p.shape == (edmd.N_PARAMS,)
    assert [p[getattr(edmd, n)] for n in ("P_T_STOP", "P_MAX_COLLISIONS", "P_SPEED")] == [1.0, 2.0, 11.0]
    src = Path(pp.generate.lubachevsky.__file__).read_text()
    assert not re.search(r"\b(state|params)\[\d", src), "use the named slots edmd.S_* / edmd.P_*"
    assert not re.search(r"\bcode == \d", src), "use edmd.ChunkStatus"
