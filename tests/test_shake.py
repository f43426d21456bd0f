"""Monte-Carlo shaking (§3.2 of 000_2cedc098acbd866b.txt): invariants, exactness,
reproducibility, adaptation, monitor, errors, CLI.  Physics validation (Carnahan–Starling
contact values, the seed's findings) is in test_shake_physics.py."""

import math

import numpy as np
import pytest

import _oracles as orc
import polypack as pp
from polypack.analysis import ContactValueMonitor
from polypack.errors import InvalidInputError, OverlapError
from polypack.generate.shake import ShakeTuning, shake
from polypack.neighbors import pairs_within

METHODS = ["paper", "collision", "metropolis"]


def simple_cubic(phi, n1=6, radius=1.0):
    """Simple cubic lattice of n1^3 spheres at volume fraction phi (phi < pi/6)."""
    spacing = (4.0 / 3.0 * math.pi * radius**3 / phi) ** (1.0 / 3.0)
    g = (np.arange(n1) + 0.5) * spacing
    pos = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T
    return pp.Packing(pos, np.full(len(pos), radius), spacing * n1)


def fcc(phi, n1=4, radius=1.0):
    """FCC lattice of 4 n1^3 spheres at volume fraction phi (phi < 0.7405)."""
    a = (16.0 / 3.0 * math.pi * radius**3 / phi) ** (1.0 / 3.0)
    base = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]]) + 0.25
    cells = np.array(np.meshgrid(*[np.arange(n1)] * 3, indexing="ij")).reshape(3, -1).T
    pos = (cells[:, None, :] + base[None, :, :]).reshape(-1, 3) * a
    return pp.Packing(pos, np.full(len(pos), radius), a * n1)


def bidisperse_1_10(seed=0):
    """8 large spheres (radius 2) on a lattice plus ~1500 small ones (radius 0.2): size ratio 1:10."""
    rng = np.random.default_rng(seed)
    L = 10.0
    g = np.array([2.5, 7.5])
    big = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T
    pos, rad = [*big], [2.0] * 8
    small = []
    while len(small) < 1500:
        cand = rng.random((4000, 3)) * L
        d = cand[:, None, :] - big[None, :, :]
        d -= L * np.round(d / L)
        ok = np.all(np.linalg.norm(d, axis=2) >= 2.2 + 1e-9, axis=1)
        for c in cand[ok]:
            if small:
                e = np.asarray(small) - c
                e -= L * np.round(e / L)
                if np.min(np.einsum("ij,ij->i", e, e)) < 0.4**2 + 1e-9:
                    continue
            small.append(c)
            if len(small) == 1500:
                break
    pos = np.vstack([np.asarray(pos), np.asarray(small)])
    rad = np.concatenate([rad, np.full(len(small), 0.2)])
    species = np.concatenate([np.zeros(8, int), np.ones(len(small), int)])
    return pp.Packing(pos, rad, L, species=species)


@pytest.fixture(scope="module")
def packs():
    return {"sc": simple_cubic(0.5), "fcc": fcc(0.6), "bi": bidisperse_1_10()}


def brute_min_gap(pk):
    """Oracle: minimum relative gap over all pairs, O(N^2) with the test's own distance code."""
    return orc.min_gap(pk.positions, pk.radii, pk.box)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("which", ["sc", "fcc", "bi"])
def test_invariants_and_no_overlap(packs, method, which):
    pk = packs[which]
    out = shake(pk, global_shakes=5, method=method, seed=3)
    assert out.n == pk.n
    assert np.array_equal(out.radii, pk.radii)
    assert np.array_equal(out.species, pk.species)
    assert np.array_equal(out.box, pk.box)
    assert out.volume_fraction == pk.volume_fraction
    assert brute_min_gap(out) >= 0.0
    assert out.min_gap() >= 0.0
    moved = np.linalg.norm(pp.neighbors.minimum_image(out.positions - pk.positions, pk.box), axis=1)
    assert np.count_nonzero(moved) > 0.5 * pk.n
    # no sphere moved farther than M windows
    step = np.asarray(out.meta["shake"]["shake_radius"])[pk.species] * pk.radii
    assert np.all(moved <= 5 * step * (1 + 1e-12))
    sh = out.meta["shake"]
    assert sh["method"] == method and sh["global_shakes"] == 5
    assert len(sh["acceptance_rate"]) == 5 and len(sh["acceptance_rate"][0]) == pk.n_species
    acc = np.array(sh["acceptance_rate"], dtype=float)
    assert np.all((acc >= 0) & (acc <= 1)) and np.all(acc.mean(axis=0) > 0)
    assert sh["trials"] >= 5 * pk.n
    assert out.meta["history"][-1]["generator"] == "polypack.shake"
    assert pk.meta == {}  # input untouched


def test_lattice_acceptance_matches_geometry():
    """Simple cubic lattice with wide gaps: every window position is free, so acceptance is 1,
    and the mean accepted displacement of a uniform point in a ball of radius R is 3R/4."""
    pk = simple_cubic(0.2, n1=5)  # gap 2*(spacing/2 - 1) ~ 0.76 radius
    out = shake(pk, global_shakes=4, shake_radius=0.05, method="metropolis", seed=1)
    acc = np.array(out.meta["shake"]["acceptance_rate"], dtype=float)
    assert np.all(acc == 1.0)
    mdisp = np.mean(np.array(out.meta["shake"]["mean_displacement"], dtype=float))
    assert mdisp == pytest.approx(0.75 * 0.05, rel=0.03)


def test_touching_pair_acceptance_exact():
    """Pairs touching through the periodic boundary (minimum image), one sequential sweep
    with a tiny window: the first sphere A of a pair is rejected iff it moves towards B
    (prob 1/2); B, visited after A, is rejected with prob 1/2 if A stayed and with prob
    1/4 if A opened a gap |dx_A| (uniform-ball x-components), so B is accepted with
    prob 5/8.  2500 independent pairs (A's are species 0 and come first in the visiting
    order, B's are species 1): binomial standard error 0.5 / sqrt(2500) = 0.01 per
    species; 4 of them (0.04) separate 5/8 from the 1/2 that updating both spheres from
    the old positions (a simultaneous-update bug) would give."""
    yz = (np.stack(np.meshgrid(np.arange(50), np.arange(50), indexing="ij"), -1).reshape(-1, 2) + 0.5) * 3.0
    a = np.column_stack([np.full(len(yz), 0.5), yz])
    b = np.column_stack([np.full(len(yz), 18.5), yz])
    m = len(yz)
    pk = pp.Packing(np.vstack([a, b]), np.ones(2 * m), [20.0, 150.0, 150.0], species=np.r_[np.zeros(m), np.ones(m)])
    acc = shake(pk, global_shakes=1, shake_radius=1e-3, method="metropolis", order="sequential", seed=1,
                monitor_every=0).meta["shake"]["acceptance_rate"][0]
    assert acc[0] == pytest.approx(0.5, abs=0.04)
    assert acc[1] == pytest.approx(5.0 / 8.0, abs=0.04)


def test_free_flight_analytic():
    """Eq. (9): free flight of sphere 0 towards sphere 1 along a direction at angle theta,
    including the periodic image across the box boundary."""
    from polypack._kernels import shake as kern

    box = np.full(3, 10.0)
    radii = np.array([1.0, 1.0])
    pos = np.array([[0.5, 5.0, 5.0], [7.5, 5.0, 5.0]])  # 3.0 apart through x = 0 = L
    start, idx = kern.build_list(pos, radii, box, 1.0, np.array([2, 2, 2], np.int64))
    for theta in (0.0, 0.3, 0.7):
        u = np.array([-math.cos(theta), math.sin(theta), 0.0])
        t = kern._free_flight(0, u[0], u[1], u[2], pos, radii, box, start, idx)
        # |w + u t| = 2 with w = (3, 0, 0) in the direction of -x: t = 3 cos(th) - sqrt(4 - 9 sin^2(th))
        disc = 4.0 - 9.0 * math.sin(theta) ** 2
        expect = 3.0 * math.cos(theta) - math.sqrt(disc) if disc >= 0 else math.inf
        assert t == pytest.approx(expect, rel=1e-12)
    t = kern._free_flight(0, 1.0, 0.0, 0.0, pos, radii, box, start, idx)
    assert t == math.inf  # moving away (no other neighbour)


def test_collision_amplitude_bounded_by_free_flight():
    """Collision-limited moves (Eq. (9)) stop short of the first contact: every trial is
    accepted (a move beyond the contact would be rejected by the exact overlap test), and
    the amplitude, uniform in [0, min(free flight, window)], averages well below the
    half window it would average if it ignored the free flight."""
    pk = fcc(0.6, n1=3)  # gaps ~0.07 radius, window 0.3 radius
    out = shake(pk, global_shakes=20, method="collision", shake_radius=0.3, seed=2, monitor_every=0)
    assert brute_min_gap(out) >= 0.0
    sh = out.meta["shake"]
    assert sh["accepted"] >= sh["trials"] - 2  # amp = 0 or an exact-test fallback at most
    md = np.array(sh["mean_displacement"], dtype=float)
    assert np.mean(md) < 0.5 * (0.3 / 2)


def test_reproducible_for_a_seed(packs):
    pk = packs["bi"]
    for method in METHODS:
        a = shake(pk, global_shakes=3, method=method, seed=11)
        b = shake(pk, global_shakes=3, method=method, seed=11, monitor=ContactValueMonitor(), monitor_every=1)
        c = shake(pk, global_shakes=3, method=method, seed=12)
        assert np.array_equal(a.positions, b.positions)
        assert not np.array_equal(a.positions, c.positions)
        for key in ("acceptance_rate", "mean_displacement", "trials", "seed"):
            assert a.meta["shake"][key] == b.meta["shake"][key]
    ss = np.random.SeedSequence(5)
    assert np.array_equal(shake(pk, global_shakes=2, seed=ss).positions, shake(pk, global_shakes=2, seed=np.random.SeedSequence(5)).positions)


def test_per_species_radius_and_trials(packs):
    pk = packs["bi"]
    out = shake(pk, global_shakes=3, shake_radius=[0.01, 0.1], max_trials=[5, 50], seed=1)
    sh = out.meta["shake"]
    assert sh["shake_radius"] == [0.01, 0.1] and sh["max_trials"] == [5, 50]
    md = np.array(sh["mean_displacement"], dtype=float)
    assert np.all(md[:, 0] <= 0.01) and np.all(md[:, 1] <= 0.1)
    assert np.mean(md[:, 1]) > 3 * np.mean(md[:, 0])


def test_metropolis_adaptation_then_fixed():
    pk = simple_cubic(0.4, n1=6)
    out = shake(pk, global_shakes=40, method="metropolis", adaptive=True, adapt_shakes=25, target_acceptance=0.4,
                seed=4, shake_radius=0.01)
    sh = out.meta["shake"]
    hist = np.array(sh["shake_radius_history"])[:, 0]
    assert np.all(hist[25:] == hist[24])  # fixed after the equilibration phase
    assert hist[24] > 0.05  # grew from 0.01
    acc = np.array(sh["acceptance_rate"], dtype=float)[25:, 0]
    assert abs(acc.mean() - 0.4) < 0.08


@pytest.mark.parametrize("method", ["paper", "collision"])
def test_seed_adaptation_tracks_free_flight(method):
    """The seed's rule (grow when the free flight exceeds the window, shrink otherwise)
    drives R_sh to the median free flight: in the end about half of the visits grow it."""
    pk = fcc(0.55, n1=4)
    out = shake(pk, global_shakes=60, method=method, adaptive=True, shake_radius=0.005, seed=3, monitor_every=0)
    sh = out.meta["shake"]
    final = sh["final_shake_radius"][0]
    assert 0.005 < final <= sh["skin"]
    assert brute_min_gap(out) >= 0.0
    # n_grow - n_shrink = log(R_end / R_start) / log(1 + f) exactly (no clipping here), so once
    # R_sh has settled, the fraction of grown visits over the last 30 shakes x 256 visits is
    # 1/2 within |log(R_30 / R_60)| / (2 * 7680 * log 1.05) < 0.01 plus the exact count
    grown = np.array(sh["grown_fraction"], dtype=float)[30:, 0]
    hist = np.array(sh["shake_radius_history"])[:, 0]
    n_visits = 30 * pk.n
    expect = 0.5 + math.log(hist[-1] / hist[29]) / (2 * n_visits * math.log(1.05))
    assert grown.mean() == pytest.approx(expect, abs=1.0 / n_visits + 1e-12)
    assert abs(grown.mean() - 0.5) < 0.05  # a shrink by (1 + 2 f) instead would settle at 0.66


def test_monitor_and_callback():
    from polypack.analysis import contact_value

    pk = fcc(0.5, n1=3)
    seen = []
    out = shake(pk, global_shakes=6, method="paper", seed=1, monitor=ContactValueMonitor(), monitor_every=2,
                callback=lambda m, p: seen.append((m, p.min_gap() >= 0)))
    mon = out.meta["shake"]["monitor"]
    assert mon["global_shake"] == [0, 2, 4, 6]
    vals = mon["contact_value"]["0-0"]
    assert len(vals) == 4
    assert vals[-1] == pytest.approx(contact_value(out, width=0.05)[(0, 0)], rel=1e-12)
    assert seen == [(m, True) for m in range(1, 7)]
    seed_est = {"width": 0.005, "n_bins": 1, "degree": 0}  # the seed's histogram g(2a+), dr = 0.01a
    first = shake(pk, global_shakes=3, method="paper", seed=1, monitor=ContactValueMonitor(**seed_est))
    mon = first.meta["shake"]["monitor"]
    assert mon["global_shake"] == [0, 3] and mon["options"] == seed_est
    assert mon["contact_value"]["0-0"][-1] == pytest.approx(contact_value(first, **seed_est)[(0, 0)], rel=1e-12)
    with pytest.raises(TypeError):
        ContactValueMonitor(bins=3)
    with pytest.raises(InvalidInputError, match="monitor="):
        shake(pk, global_shakes=1, monitor={"bins": 3})
    none = shake(pk, global_shakes=2, seed=1, monitor=ContactValueMonitor(), monitor_every=0)
    assert none.meta["shake"]["monitor"] is None
    # no monitor by default: the generators do not reach into the analysis layer
    assert shake(pk, global_shakes=2, seed=1).meta["shake"]["monitor"] is None
    # any callable is a monitor; its values are recorded under its name
    own = shake(pk, global_shakes=2, seed=1, monitor=lambda p: {"gap": p.min_gap()})
    assert own.meta["shake"]["monitor"]["values"]["gap"][-1] == pytest.approx(own.min_gap(), rel=1e-15)


def test_zero_global_shakes_is_identity(packs):
    pk = packs["fcc"]
    out = shake(pk, global_shakes=0, seed=1)
    assert np.array_equal(out.positions, pk.positions)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(shake_radius=-0.1), "shake_radius"),
        (dict(shake_radius=0.0), "shake_radius"),
        (dict(shake_radius=[0.1, 0.2, 0.3]), "shake_radius"),
        (dict(max_trials=0), "max_trials"),
        (dict(method="vibrate"), "method"),
        (dict(method="metropolis", max_trials=5), "max_trials"),
        (dict(global_shakes=-1), "global_shakes"),
        (dict(order="backwards"), "order"),
        (dict(shake_radius=50.0), "shake_radius"),
        (dict(target_acceptance=1.5), "target_acceptance"),
    ],
)
def test_bad_input(packs, kwargs, match):
    with pytest.raises(InvalidInputError, match=match):
        shake(packs["sc"], **{"global_shakes": 1, **kwargs})


def test_overlapping_input_rejected():
    pos = np.array([[1.0, 1.0, 1.0], [2.5, 1.0, 1.0], [5.0, 5.0, 5.0]])
    pk = pp.Packing(pos, [1.0, 1.0, 1.0], 10.0)
    with pytest.raises(OverlapError, match="input pack overlaps"):
        shake(pk, global_shakes=1)
    with pytest.raises(InvalidInputError, match="Packing"):
        shake(pos, global_shakes=1)


def test_cli_shake(tmp_path, capsys):
    from polypack.cli import main

    pk = fcc(0.55, n1=3)
    src, dst = tmp_path / "in.gsd", tmp_path / "out.gsd"
    pp.io.write(src, pk)
    ret = main(["shake", str(src), str(dst), "-M", "3", "--seed", "4", "--method", "collision"])
    assert not ret
    out = pp.io.read(dst)
    assert out.n == pk.n and np.array_equal(out.radii, pk.radii) and out.min_gap() >= 0
    assert out.meta["shake"]["global_shakes"] == 3 and out.meta["shake"]["method"] == "collision"
    assert "3 global shakes" in capsys.readouterr().out
    # bad input: one-line error, exit code 1
    with pytest.raises(SystemExit) as exc:
        main(["shake", str(src), str(dst), "--shake-radius", "-1"])
    assert exc.value.code == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "shake_radius=-1.0" in err


def test_cli_scrm(tmp_path, capsys):
    from polypack.cli import main

    dst = tmp_path / "scrm.gsd"
    ret = main(["scrm", "--n", "200", "-c", "0.45", "--growth-steps", "2", "-M", "2", "--seed", "3",
                "--size-ratio", "0.5", "--volume-ratio", "0.5", "-o", str(dst)])
    assert not ret
    out = pp.io.read(dst)
    assert out.n == 200 and out.n_species == 2 and out.min_gap() >= 0
    assert out.volume_fraction == pytest.approx(0.45, rel=1e-9)
    assert out.meta["scrm"]["schedule"] == pytest.approx([0.36, 0.45])
    assert "2 growth stages" in capsys.readouterr().out


def test_collision_best_of_directions_moves_farther():
    """Eq. (9) with N_sh directions (Δt = max_l Δt^l): the longest of several free flights is
    longer on average, so the mean amplitude grows with max_trials."""
    pk = fcc(0.6, n1=3)
    md = []
    for n_sh in (1, 8):
        out = shake(pk, global_shakes=10, method="collision", shake_radius=0.2, max_trials=n_sh, seed=7,
                    monitor_every=0)
        assert out.min_gap() >= 0.0
        md.append(np.mean(np.array(out.meta["shake"]["mean_displacement"], dtype=float)))
    assert md[1] > 1.2 * md[0]


def test_adaptive_size_ratio_1_10(packs):
    """Per-species adaptation in a 1:10 pack: the large spheres' R_sh settles where about
    half of their visits see a free flight longer than the window; the small ones, in a
    dilute fluid of their own (free flights longer than any window the list allows), grow
    theirs to the cap, half the Verlet skin, and stay there."""
    pk = packs["bi"]
    for method in ("paper", "collision"):
        out = shake(pk, global_shakes=30, method=method, adaptive=True, seed=8, monitor_every=0)
        sh = out.meta["shake"]
        assert brute_min_gap(out) >= 0.0
        assert all(0 < r <= sh["skin"] for r in sh["final_shake_radius"])
        grown = np.array(sh["grown_fraction"], dtype=float)[10:]
        # 20 shakes x 8 large spheres = 160 visits; the count identity of
        # test_seed_adaptation_tracks_free_flight bounds the deviation from 1/2 by
        # |log(R_sh change)| / (2 * 160 * log 1.05), < 0.09 for a change by a factor 4
        assert abs(grown[:, 0].mean() - 0.5) < 0.1, (method, grown[:, 0].mean())
        assert sh["final_shake_radius"][1] == pytest.approx(0.5 * sh["skin"], rel=1e-12)
        assert grown[:, 1].mean() > 0.9


@pytest.mark.parametrize("method", METHODS)
def test_random_order_reaches_every_sphere(method):
    """order="random" draws N spheres uniformly per global shake: in a dilute lattice where
    every move is accepted, each sphere is missed by all 25 shakes with prob e^-25, so every
    sphere moves; the visits per species follow the species counts."""
    pk = simple_cubic(0.05, n1=5)
    pk = pk.replace(species=(np.arange(pk.n) % 5 == 0).astype(int))
    out = shake(pk, global_shakes=25, method=method, order="random", shake_radius=0.05, seed=6, monitor_every=0)
    moved = orc.distance_matrix(np.vstack([out.positions, pk.positions]), pk.box)[np.arange(pk.n), pk.n + np.arange(pk.n)]
    assert np.all(moved > 0), np.flatnonzero(moved == 0)
    seq = shake(pk, global_shakes=1, method=method, order="sequential", shake_radius=0.05, seed=6, monitor_every=0)
    moved = orc.distance_matrix(np.vstack([seq.positions, pk.positions]), pk.box)[np.arange(pk.n), pk.n + np.arange(pk.n)]
    assert np.all(moved > 0)  # one sequential sweep visits every sphere once


def test_result_independent_of_skin(packs):
    """The Verlet skin only changes how often the list is rebuilt: the overlap test is exact,
    so any skin gives bit-identical trajectories (a missing neighbour would show up here)."""
    for which, method in (("bi", "metropolis"), ("fcc", "collision"), ("sc", "paper")):
        pk = packs[which]
        a = shake(pk, global_shakes=6, method=method, seed=9, tuning=ShakeTuning(skin=0.12), monitor_every=0)
        b = shake(pk, global_shakes=6, method=method, seed=9, tuning=ShakeTuning(skin=0.25), monitor_every=0)
        assert a.meta["shake"]["rebuilds"] != b.meta["shake"]["rebuilds"] or which == "sc"
        assert np.array_equal(a.positions, b.positions)


@pytest.mark.parametrize("method", METHODS)
def test_cells_and_verlet_identical(method):
    """Linked cells and the Verlet list are two exact overlap tests: identical trajectories."""
    pk = simple_cubic(0.3, n1=6)
    kw = dict(global_shakes=8, method=method, shake_radius=0.4, seed=21, monitor_every=0)
    a = shake(pk, tuning=ShakeTuning(neighbours="cells"), **kw)
    b = shake(pk, tuning=ShakeTuning(neighbours="verlet"), **kw)
    assert a.meta["shake"]["final_neighbour_structure"] == "cells"
    assert b.meta["shake"]["final_neighbour_structure"] == "verlet"
    assert np.array_equal(a.positions, b.positions)
    assert a.meta["shake"]["acceptance_rate"] == b.meta["shake"]["acceptance_rate"]
    assert a.min_gap() >= 0.0
    with pytest.raises(InvalidInputError, match="neighbours"):
        shake(pk, global_shakes=1, tuning=ShakeTuning(neighbours="octree"))
