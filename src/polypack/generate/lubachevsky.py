"""Lubachevsky–Stillinger collective rearrangement: exact event-driven growth packing.

Implements the collective rearrangement model (CRM) of §3.1 of
000_2cedc098acbd866b.txt: spheres start as points at random centres with random
velocities, move ballistically and grow in proportion, ``a^(k)(t) = a_0^(k) t``;
collision times follow from Eq. (8) of 000_2cedc098acbd866b.txt with periodic
images, and collisions conserve momentum.  The kinetic energy is kept fixed by
rescaling the velocities at every synchronisation.  The numerical engine lives in
:mod:`polypack._kernels.edmd`.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from .._util import as_seed_sequence, progress_bar, rng_from, seed_record
from .. import _interrupt
from ..errors import InfeasibleError, Interrupted, InvalidInputError, OverlapError
from ..geometry import unit_ball_volume
from ..packing import Packing

__all__ = ["pack", "PackTuning", "carnahan_starling"]


_STATUS = {0: "running", 1: "target", 2: "jammed", 3: "box_limit", 4: "event_budget"}

_SPHERE = unit_ball_volume(3)


def default_skin(radii):
    """Default shell margin of :func:`pack`, as a fraction of each sphere's radius.

    ``0.25 * clip(r_V / r_med, 1, 2.4)`` with ``r_V = sum(r^4) / sum(r^3)`` the
    volume-weighted mean radius and ``r_med`` the median radius.  Margins are
    proportional to the radius, but the fines of a mixture move through gaps set by
    the coarse spheres that hold most of the volume, so their thin shells would be
    left (and rebuilt) after every few collisions.  Equal spheres get 0.25; seed
    000's bimodal pack (``r_V / r_med = 2.6``) and a half-volume mixture of diameter
    ratio 10 get 0.6, half-volume ratio 3 gets 0.5.  Measured wall times (this
    machine): seed 000 to c = 0.6, 0.76 s at 0.25 vs 0.58 s at 0.6; ratio 3,
    N = 3000, jammed, 7.6 s vs 5.8 s; equal spheres, N = 1e4 to 0.64, 11.5 s at
    0.25, 11.8 s at 0.4, 16.6 s at 0.6.  Only the speed depends on it.
    """
    r = np.asarray(radii, dtype=np.float64)
    r_v = float(np.sum(r**4) / np.sum(r**3))
    return 0.25 * min(max(r_v / float(np.median(r)), 1.0), 2.4)


def carnahan_starling(volume_fraction):
    """Carnahan–Starling compressibility factor ``Z = (1+η+η²−η³)/(1−η)³`` of the hard-sphere fluid."""
    eta = np.asarray(volume_fraction, dtype=np.float64)
    return (1 + eta + eta**2 - eta**3) / (1 - eta) ** 3


def _check_dim(dim, own, what):
    """The packing dimension: ``dim`` if given (it must agree with ``own`` when that is known), else ``own``."""
    if dim is not None:
        if isinstance(dim, bool) or dim not in (2, 3):
            raise InvalidInputError(f"dim={dim!r}: allowed are 2 (disks) and 3 (spheres)")
        dim = int(dim)
        if own is not None and own != dim:
            raise InvalidInputError(f"dim={dim} but the {what} is {own}D; leave dim out or pass {what}s for dim={dim}")
        return dim
    return 3 if own is None else int(own)


def _parse_sizes(sizes, species, dim=None):
    """Radii, species, (for a continuation) the starting Packing, and the dimension."""
    start = None
    if isinstance(sizes, Packing):
        dim = _check_dim(dim, sizes.dim, "packing")
        if not sizes.fully_periodic:
            raise InvalidInputError(
                f"pack continues fully periodic packings only; got a {sizes.dim}D packing with "
                f"periodic={sizes.periodic}"
            )
        start = sizes
        radii = np.array(sizes.radii, dtype=np.float64)
        sp = np.array(sizes.species, dtype=np.int64)
        if species is not None:
            raise InvalidInputError("species= cannot be given together with a Packing; the Packing's species are used")
        return radii, sp, start, dim
    if hasattr(sizes, "radii"):
        dim = _check_dim(dim, int(getattr(sizes, "dim", 3)), "size set")
        radii = np.array(sizes.radii, dtype=np.float64)
        sp = getattr(sizes, "species", None) if species is None else species
    else:
        dim = _check_dim(dim, None, "size set")
        if isinstance(sizes, (int, np.integer)) and not isinstance(sizes, bool):
            raise InvalidInputError(
                f"sizes={sizes}: pass an array of radii (e.g. numpy.full({sizes}, 1.0)) or a SizeSet, not a count"
            )
        try:
            radii = np.array(sizes, dtype=np.float64)
        except (TypeError, ValueError):
            raise InvalidInputError(
                f"sizes of type {type(sizes).__name__}: allowed are a SizeSet, an array of radii or a Packing"
            ) from None
        sp = species
    if radii.ndim != 1:
        raise InvalidInputError(f"radii must be a 1-D array, got shape {radii.shape}")
    n = radii.size
    if n < 2:
        raise InvalidInputError(f"{n} sphere(s): packing needs at least 2")
    bad = ~np.isfinite(radii) | (radii <= 0)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InvalidInputError(f"radius of sphere {k} is {radii[k]!r}; radii must be finite and > 0")
    if sp is None:
        sp = np.zeros(n, dtype=np.int64)
    else:
        sp = np.asarray(sp)
        if sp.shape != (n,):
            raise InvalidInputError(f"species must have shape ({n},), got {sp.shape}")
        if sp.dtype.kind == "f" and np.any(sp != np.round(sp)):
            raise InvalidInputError("species must be integers")
        sp = sp.astype(np.int64)
        if sp.min() < 0:
            raise InvalidInputError(f"species {int(sp.min())} is negative; species must be >= 0")
    return radii, sp, start, dim


@dataclass(frozen=True)
class PackTuning:
    """Speed knobs of :func:`pack`: how fast a pack is made, not which statistics it has.

    Different values give different (equally valid) trajectories for the same seed; the
    defaults are tuned for speed. See :func:`pack` for their meaning.

    Attributes
    ----------
    skin : float, optional
        Neighbour-shell margin as a fraction of the radius (default :func:`default_skin`).
    dilute_skin : float, optional
        The same at the start of the run (default ``skin``).
    chunk_collisions : int, optional
        Collisions per compiled call between progress updates and budget or Ctrl-C
        checks (default ``20 N`` clipped to [2e5, 1e7]).
    sync_every : int, optional
        Collisions between full synchronisations (default ``4 N``).
    margin_cap : float
        Shell margin of a large sphere at most this many times that of a median sphere.
    """

    skin: float | None = None
    dilute_skin: float | None = None
    chunk_collisions: int | None = None
    sync_every: int | None = None
    margin_cap: float = 1.0

    def __post_init__(self):
        from .. import _validate as v

        for name, check in (("skin", v.positive), ("dilute_skin", v.positive), ("chunk_collisions", v.int_min(1)),
                            ("sync_every", v.int_min(0)), ("margin_cap", v.positive)):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, v.check(name, value, check))


def pack(
    sizes,
    volume_fraction=0.6,
    *,
    seed=None,
    species=None,
    growth_rate=None,
    max_collisions=None,
    max_seconds=None,
    max_events=None,
    max_pressure=1e6,
    pressure_window=None,
    jammed_reference_fraction=0.5,
    fast_growth=10.0,
    fast_growth_until=0.3,
    tuning=None,
    progress=None,
    dim=None,
) -> Packing:
    """Random dense pack of polydisperse spheres by Lubachevsky–Stillinger growth (exact EDMD).

    The collective rearrangement model of §3.1 of 000_2cedc098acbd866b.txt: random
    centres, random velocities, radii growing in proportion ``a^(k)(t) = a_0^(k) t``,
    exact collision times from Eq. (8) of 000_2cedc098acbd866b.txt with periodic
    images (minimum image inside a periodic box).

    Parameters
    ----------
    sizes : SizeSet, array_like or Packing
        Radii (user units) with optional species: an object with ``.radii`` and
        ``.species`` (a :class:`polypack.psd.SizeSet`), an array of radii, or a
        :class:`~polypack.Packing` to continue from (its positions are the start,
        e.g. to compress a shaken pack further).
    dim : {3, 2}, optional
        3 packs spheres in a periodic cube, 2 packs disks in a periodic square
        (the 2D engine :mod:`polypack._kernels.edmd2d`; "volume fraction" is then the
        area fraction).  Default: the dimension of the size set or Packing, else 3.
    volume_fraction : float or "jammed"
        Target volume fraction ``c``, hit exactly (growth stops at the moment it is
        reached), or ``"jammed"`` to grow until the reduced pressure exceeds
        ``max_pressure``.  A target above what the sizes can reach ends with status
        ``"jammed"`` at the reached fraction.
    seed : int or numpy.random.SeedSequence, optional
        Seeds the centres and velocities (recorded in ``meta["seed"]``).
    growth_rate : float, optional
        Dimensionless growth rate ``Γ = (d<d>/dt) / v_th``: while a sphere at the
        thermal speed ``v_th = sqrt(kT/m)`` moves one mean diameter the mean
        diameter grows by the fraction ``Γ``.  Default 0.02.  Slower growth gives
        denser, more equilibrated packs and costs ~1/Γ more collisions.
    max_collisions : int, optional
        Collision budget; status ``"collision_budget"`` when used up.
    max_seconds : float, optional
        Wall-clock budget; status ``"time_budget"``.
    progress : bool, optional
        Progress bar (volume fraction, reduced pressure, collisions/s); default:
        only on a terminal.
    species : array_like of int, optional
        Species of each sphere when ``sizes`` is an array of radii.
    max_events : int, optional
        Event budget (collisions and shell exits); status ``"event_budget"``.
    max_pressure : float
        Jamming threshold on the reduced pressure ``Z = PV/(NkT)`` (default 1e6, > 3).
    pressure_window : int, optional
        Collisions per pressure estimate (default ``N``).
    jammed_reference_fraction : float
        Reference fraction of the jamming estimate (0.5).
    fast_growth : float
        Growth this many times faster than ``growth_rate`` during the dilute start
        (default 10; 1 grows at one rate throughout).
    fast_growth_until : float
        Volume fraction where the fast start ends (default 0.3, at most half the target).
    tuning : PackTuning, optional
        Speed knobs (neighbour-shell margins, chunk size, synchronisation period):
        ``skin`` defaults to :func:`default_skin` (0.25 for equal spheres, up to 0.6 when
        most of the volume is in spheres much larger than the median one, whose mobile
        fines make shell exits the main cost); the trajectory depends on
        ``chunk_collisions``, never on the clock.

    Returns
    -------
    Packing
        Radii exactly as given, the box following from N, radii and the reached
        fraction; ``meta`` holds ``status`` ("target", "jammed", "collision_budget",
        "time_budget"), ``collisions``, ``events``, ``wall_time``,
        ``collisions_per_second``, ``pressure_history`` (rows ``volume_fraction,
        reduced_pressure``), ``reduced_pressure``, ``jamming_estimate``
        (``φ/(1 − d/p)``, ``d`` the dimension: Skoge et al.'s estimate), ``growth_rate``, ``seed``, ``min_gap``,
        ``shrink_factor``.

    Raises
    ------
    InvalidInputError
        Fewer than 2 spheres, radii <= 0, an unknown option, a target outside
        (0, 1) or below the fraction of a Packing to continue from.
    InfeasibleError
        A sphere whose diameter would exceed half the box at the target (too few
        spheres for the size ratio).
    OverlapError
        Never expected: the final exact check found a real overlap.
    polypack.errors.Interrupted
        Ctrl-C (SIGINT): growth stops at the end of the current chunk (a safe point,
        every sphere synchronised) and the exception carries the pack grown so far in
        ``.partial`` (``meta["status"] == "interrupted"``, exact, non-overlapping), or
        None if nothing had grown.  It is a :class:`KeyboardInterrupt`, never a result.

    Notes
    -----
    Collisions are elastic in the frame of the growing surfaces (see
    :func:`polypack._kernels.edmd.run_chunk`); the kinetic energy is reset to
    ``3N kT/2`` at every synchronisation.  Before returning, the exact minimum gap
    is computed and any round-off overlap is removed by a uniform shrink of all
    radii (recorded in ``meta["shrink_factor"]``), undone by enlarging the box so
    the radii stay exactly as given.

    The radii grow as ``a_0^(k) t`` (§3.1 of 000_2cedc098acbd866b.txt) at the
    rate ``growth_rate`` from ``fast_growth_until`` on; below it (a dilute fluid
    that relaxes in a few collision times) they grow ``fast_growth`` times faster
    per distance travelled, which skips most of the free flight of the start
    without changing the dense packs (jamming densities agree within their
    scatter, tested).  ``meta["fast_start"]`` records it; the pressure history
    starts where it ends.
    """
    opt = _pack_options(tuning, species=species, max_pressure=max_pressure, pressure_window=pressure_window,
                        jammed_reference_fraction=jammed_reference_fraction, max_events=max_events,
                        fast_growth=fast_growth, fast_growth_until=fast_growth_until)
    wall0 = time.perf_counter()
    radii, species, start, dim = _parse_sizes(sizes, opt["species"], dim)
    c = _check_pack_args(volume_fraction, growth_rate, max_collisions, max_seconds, opt, radii)
    ss = as_seed_sequence(seed)
    s = _set_up(radii, dim, start, c, opt, rng_from(ss))
    chunk = _chunk_size(opt, s.n)
    status, code, hist_rows, run_time = _run_chunks(s, c, opt, chunk, max_collisions, max_seconds, progress, wall0)
    pos, box_out, gap, shrink = _to_user_units(s, c, status, code)
    meta = _record(s, c, start, ss, status, hist_rows, box_out, gap, shrink, wall0, run_time)
    out = Packing(pos, radii, box_out, species=species, meta=meta)
    if status == "interrupted":
        raise Interrupted(
            f"pack interrupted at volume fraction {meta['volume_fraction']:.6g} after {meta['collisions']} collisions "
            "(the partial pack is in .partial, status 'interrupted')",
            partial=out,
        )
    return out


def _pack_options(tuning, **options):
    """The options of :func:`pack` with the speed knobs of ``tuning`` (a :class:`PackTuning` or None) in one dict."""
    if tuning is None:
        tuning = PackTuning()
    elif not isinstance(tuning, PackTuning):
        raise InvalidInputError(f"tuning={tuning!r}: must be a polypack.generate.PackTuning")
    return dict(**options, **dataclasses.asdict(tuning))


def _edmd_engine(dim):
    """The EDMD kernel module of the dimension (:mod:`polypack._kernels.edmd2d` or :mod:`polypack._kernels.edmd`)."""
    if dim == 2:
        from .._kernels import edmd2d as edmd
    else:
        from .._kernels import edmd
    return edmd


def _check_pack_args(volume_fraction, growth_rate, max_collisions, max_seconds, opt, radii):
    """Check the run options of :func:`pack`; the checked values as a namespace.

    ``target`` (None for ``"jammed"``), ``gamma``, ``p_max``, ``skin``, ``dilute_skin``,
    ``window``, ``fast`` and ``phi_fast`` (before it is capped at half the target).
    """
    n = radii.size
    jammed_mode = isinstance(volume_fraction, str)
    if jammed_mode:
        if volume_fraction != "jammed":
            raise InvalidInputError(f"volume_fraction={volume_fraction!r}: allowed are a number in (0, 1) or 'jammed'")
        target = None
    else:
        try:
            target = float(volume_fraction)
        except (TypeError, ValueError):
            raise InvalidInputError(
                f"volume_fraction={volume_fraction!r}: allowed are a number in (0, 1) or 'jammed'"
            ) from None
        if not (0.0 < target < 1.0):
            raise InvalidInputError(f"volume_fraction={target}: must be in (0, 1) or 'jammed'")
    gamma = 0.02 if growth_rate is None else float(growth_rate)
    if not (gamma > 0.0 and math.isfinite(gamma)):
        raise InvalidInputError(f"growth_rate={growth_rate!r}: must be finite and > 0")
    for name, val in (("max_collisions", max_collisions), ("max_seconds", max_seconds)):
        if val is not None and not (float(val) > 0):
            raise InvalidInputError(f"{name}={val!r}: must be > 0 or None")
    p_max = float(opt["max_pressure"])
    if not p_max > 3.0:
        raise InvalidInputError(f"max_pressure={p_max}: must be > 3")
    if not float(opt["margin_cap"]) > 0:
        raise InvalidInputError(f"margin_cap={opt['margin_cap']}: must be > 0")
    skin = float(opt["skin"] if opt["skin"] is not None else default_skin(radii))
    if not (0.0 < skin <= 5.0):
        raise InvalidInputError(f"skin={skin}: must be in (0, 5]")
    dilute_skin = float(opt["dilute_skin"] if opt["dilute_skin"] is not None else skin)
    if not (0.0 < dilute_skin <= 5.0):
        raise InvalidInputError(f"dilute_skin={dilute_skin}: must be in (0, 5]")
    window = int(opt["pressure_window"] or max(n, 100))
    fast = float(opt["fast_growth"])
    if not (math.isfinite(fast) and fast >= 1.0):
        raise InvalidInputError(f"fast_growth={opt['fast_growth']!r}: must be a finite number >= 1")
    phi_fast = float(opt["fast_growth_until"])
    if not (0.0 <= phi_fast < 1.0):
        raise InvalidInputError(f"fast_growth_until={opt['fast_growth_until']!r}: must be in [0, 1)")
    return SimpleNamespace(target=target, gamma=gamma, p_max=p_max, skin=skin, dilute_skin=dilute_skin,
                           window=window, fast=fast, phi_fast=phi_fast)


class _PackRun(SimpleNamespace):
    """Internal state of one :func:`pack` run (internal units: mean radius 1 at ``t_unit``, thermal speed 1)."""

    def phi_at(self, t):
        return self.vol_unit * (t / self.t_unit) ** self.dim / self.box_vol


def _set_up(radii, dim, start, c, opt, rng):
    """Arrays, box and stopping times of a :func:`pack` run (draws the centres, then the velocities, from ``rng``).

    Checks a Packing to continue from (no overlap, fraction not above the target) and
    that the largest sphere stays below half the box at the target.
    """
    edmd = _edmd_engine(dim)
    n = radii.size
    target = c.target
    mean_r = float(radii.mean())
    ball = unit_ball_volume(dim)
    vol_spheres = ball * float(np.sum(radii**dim))
    # internal units: mean radius 1 at t = 2/Γ, thermal speed 1
    g = c.gamma * (radii / mean_r) / 2.0
    t_unit = 2.0 / c.gamma  # time at which internal radii equal radii/mean_r

    if start is not None:
        box = np.array(start.box, dtype=np.float64) / mean_r
        x = np.array(start.positions, dtype=np.float64) / mean_r
        t0 = t_unit
        phi0 = start.volume_fraction
        gap0, pair0 = _min_gap(start.positions, start.radii, start.box)
        if gap0 < -1e-9:
            raise OverlapError(
                f"the Packing to continue from has overlapping spheres {pair0[0]} and {pair0[1]} "
                f"(relative gap {gap0:.3e}); start from a non-overlapping pack"
            )
        if target is not None and target < phi0 * (1 - 1e-12):
            raise InvalidInputError(
                f"volume_fraction={target}: below the fraction {phi0:.6g} of the Packing to continue from"
            )
    else:
        phi_box = target if target is not None else float(opt["jammed_reference_fraction"])
        side = (vol_spheres / phi_box) ** (1.0 / dim) / mean_r
        box = np.full(dim, side)
        x = rng.random((n, dim)) * side
        t0 = 0.0
        phi0 = 0.0
    v = rng.normal(size=(n, dim))
    # work in a spatially sorted order (cache locality); undone before returning
    perm = _spatial_order(x, box)
    x = np.ascontiguousarray(x[perm])
    v = np.ascontiguousarray(v[perm])
    g = np.ascontiguousarray(g[perm])
    box_vol = float(np.prod(box))
    vol_unit = ball * float(np.sum((radii / mean_r) ** dim))  # sphere volume at t_unit

    # largest admissible time: the largest diameter must stay below half the box
    t_cap = 0.245 * float(box.min()) / float(g.max())
    if target is not None:
        t_target = t_unit * (target * box_vol / vol_unit) ** (1.0 / dim)
        if t_target > t_cap:
            dmax = 2 * float(radii.max())
            raise InfeasibleError(
                f"the largest sphere (diameter {dmax:g}) would exceed half the periodic box at "
                f"volume_fraction={target}; use more spheres than N={n} or a smaller size ratio"
            )
        t_stop = t_target
        t_ref = t_target
    else:
        t_stop = t_cap
        phi_guess = 0.64 if dim == 3 else 0.84  # typical jamming fractions (shell widths only)
        t_ref = min(t_unit * (phi_guess * box_vol / vol_unit) ** (1.0 / dim), t_cap)
    t_ref = max(t_ref, t0)
    # Fast start: below ``phi_fast`` (at most half the target) the velocities are
    # rescaled to thermal speed 1/fast, so the radii grow ``fast`` times more per
    # distance travelled.  The dilute fluid relaxes within a few collision times, and
    # the slow compression from phi_fast on erases this history; it saves the long
    # free flights of the dilute start (most of the simulated time, few collisions).
    phi_fast = min(c.phi_fast, 0.5 * target) if target is not None else c.phi_fast
    t_fast = t_unit * (phi_fast * box_vol / vol_unit) ** (1.0 / dim)
    fast_phase = c.fast > 1.0 and t_fast > t0

    state = np.zeros(edmd.N_STATE)
    state[edmd.S_TIME] = t0
    return _PackRun(edmd=edmd, n=n, dim=dim, radii=radii, mean_r=mean_r, vol_spheres=vol_spheres, t_unit=t_unit,
                    t0=t0, box=box, x=x, v=v, g=g, perm=perm, box_vol=box_vol, vol_unit=vol_unit, t_stop=t_stop,
                    t_ref=t_ref, phi_fast=phi_fast, t_fast=t_fast, fast_phase=fast_phase, state=state)


def _chunk_size(opt, n):
    """Collisions per compiled call.

    Chunks of a fixed collision count: each chunk starts with a full synchronisation
    (kinetic-energy reset), so sizing them from the measured rate would make the
    trajectory depend on the machine load.  Same seed, same pack, on any machine.
    """
    if opt["chunk_collisions"] is None:
        chunk = int(min(max(20 * n, 200_000), 10_000_000))
    else:
        chunk = int(opt["chunk_collisions"])
        if chunk < 1:
            raise InvalidInputError(f"chunk_collisions={opt['chunk_collisions']!r}: must be a positive integer")
    return chunk


def _run_chunks(s, c, opt, chunk, max_collisions, max_seconds, progress, wall0):
    """Grow in chunks of ``chunk`` collisions until a stop; ``(status, code, hist_rows, run_time)``.

    Advances ``s.x``, ``s.v`` and ``s.state`` in place.  Ctrl-C is deferred to the end
    of the current chunk (status ``"interrupted"``); the budgets are checked between chunks.
    """
    edmd = s.edmd
    state = s.state
    target = c.target
    fast = c.fast
    fast_phase = s.fast_phase
    hist_rows = []
    status = "running"
    max_events = opt["max_events"]
    t_begin_chunks = time.perf_counter()
    bar = progress_bar(total=None, desc="pack", progress=progress, unit="coll")
    last_p = float("nan")
    code = edmd.ChunkStatus.CHUNK_DONE
    # Ctrl-C is deferred to the end of the current chunk (a safe point: every sphere is
    # synchronised there), so the kernel is never torn apart mid-update
    with _interrupt.deferred():
        try:
            while True:
                if _interrupt.consume():
                    status = "interrupted"
                    break
                budget = chunk
                if max_collisions is not None:
                    budget = min(budget, int(max_collisions) - int(state[edmd.S_COLLISIONS]))
                    if budget <= 0:
                        status = "collision_budget"
                        break
                ev_budget = 1e18
                if max_events is not None:
                    ev_budget = int(max_events) - int(state[edmd.S_EVENTS])
                    if ev_budget <= 0:
                        status = "event_budget"
                        break
                params = edmd.make_params(
                    t_stop=s.t_fast if fast_phase else s.t_stop, max_collisions=float(budget), max_pressure=c.p_max,
                    pressure_window=float(c.window), t_ref=s.t_ref, alpha=c.skin, max_events=float(ev_budget),
                    sync_every=float(opt["sync_every"] or 0), dilute=c.dilute_skin,
                    margin_cap=float(opt["margin_cap"]), speed=1.0 / fast if fast_phase else 1.0,
                )
                hist = np.zeros((budget // max(c.window, 1) + 2, 3))
                c0 = state[edmd.S_COLLISIONS]
                tc = time.perf_counter()
                code, nh = edmd.run_chunk(s.x, s.v, s.g, s.box, state, params, hist)
                dtc = time.perf_counter() - tc
                if not fast_phase:  # no equation-of-state record of the fast start
                    for row in hist[:nh]:
                        hist_rows.append((s.phi_at(row[0]), row[1]))
                        last_p = row[1]
                done = state[edmd.S_COLLISIONS] - c0
                rate = done / dtc if dtc > 0 else 0.0
                bar.update(int(done))
                bar.set_postfix(phi=f"{s.phi_at(state[edmd.S_TIME]):.5f}", p=f"{last_p:.4g}", rate=f"{rate:.3g}/s")
                code = edmd.ChunkStatus(int(code))
                if fast_phase and code == edmd.ChunkStatus.REACHED_T_STOP:  # end of the fast start
                    fast_phase = False
                    continue
                if code == edmd.ChunkStatus.REACHED_T_STOP:
                    status = "target" if target is not None else "jammed"
                    if target is None:
                        code = edmd.ChunkStatus.BOX_LIMIT  # reached the box limit without jamming
                    break
                if code == edmd.ChunkStatus.JAMMED:
                    status = "jammed"
                    break
                if code == edmd.ChunkStatus.BOX_LIMIT:
                    status = "jammed"
                    break
                if code == edmd.ChunkStatus.EVENT_BUDGET:
                    status = "event_budget"
                    break
                if max_seconds is not None and time.perf_counter() - wall0 >= float(max_seconds):
                    status = "time_budget"
                    break
        finally:
            bar.close()
    run_time = time.perf_counter() - t_begin_chunks
    return status, code, hist_rows, run_time


def _to_user_units(s, c, status, code):
    """Positions and box in user units (radii exactly as given), in the caller's sphere order.

    Raises :class:`~polypack.errors.Interrupted` if nothing had grown, InfeasibleError
    for a jammed run stopped by the box limit, OverlapError beyond round-off; a
    round-off overlap is removed by a uniform shrink.  Returns ``(pos, box, gap, shrink)``.
    """
    n = s.n
    t = float(s.state[s.edmd.S_TIME])
    if status == "interrupted" and not t > 0.0:
        raise Interrupted("pack interrupted before the spheres had grown; nothing to save", partial=None)
    if status == "jammed" and code == s.edmd.ChunkStatus.BOX_LIMIT and c.target is None:
        raise InfeasibleError(
            f"{n} spheres cannot jam in a periodic box before the largest one reaches half the box; "
            "use more spheres"
        )
    # back to user units: radii exactly as given
    radii = s.radii
    perm = s.perm
    scale = s.mean_r * s.t_unit / t  # internal length -> user length
    inv = np.empty_like(perm)
    inv[perm] = np.arange(n)
    x = s.x[inv]
    pos = x * scale
    box_out = s.box * scale
    gap, pair = _min_gap(pos, radii, box_out)
    shrink = 1.0
    if gap < 0.0:
        if gap < -1e-6:
            raise OverlapError(
                f"spheres {pair[0]} and {pair[1]} overlap by relative gap {gap:.3e} after packing "
                "(round-off is < 1e-6); please report this"
            )
        shrink = (1.0 + gap) * (1.0 - 4e-16)
        while True:
            fac = 1.0 / shrink
            pos2, box2 = pos * fac, box_out * fac
            gap2, _ = _min_gap(pos2, radii, box2)
            if gap2 >= 0.0:
                pos, box_out, gap = pos2, box2, gap2
                break
            shrink *= 1.0 - 1e-15 - abs(gap2)
    return pos, box_out, gap, shrink


def _record(s, c, start, ss, status, hist_rows, box_out, gap, shrink, wall0, run_time):
    """``meta`` of the packed Packing: the run record, appended to the history of a continued Packing."""
    edmd = s.edmd
    state = s.state
    dim = s.dim
    target = c.target
    fast = c.fast
    collisions = int(state[edmd.S_COLLISIONS])
    phi_reached = s.vol_spheres / float(np.prod(box_out))
    p_last = float(hist_rows[-1][1]) if hist_rows else float("nan")
    jam = phi_reached / (1.0 - dim / p_last) if (p_last > dim and math.isfinite(p_last)) else float("nan")
    meta = {}
    if start is not None:
        meta = dict(start.meta)
    history = list(meta.get("history", []))
    run = {
        "generator": "polypack.pack",
        "method": "lubachevsky-stillinger",
        "status": status,
        "target": "jammed" if target is None else target,
        "volume_fraction": phi_reached,
        "collisions": collisions,
        "events": int(state[edmd.S_EVENTS]),
        "rebuilds": int(state[edmd.S_REBUILDS]),
        "shell_rebuilds": int(state[edmd.S_LOCAL_REBUILDS]),
        "wall_time": time.perf_counter() - wall0,
        "run_time": run_time,
        "collisions_per_second": collisions / run_time if run_time > 0 else 0.0,
        "reduced_pressure": p_last,
        "pressure_history": _thin(hist_rows, 1000),
        "jamming_estimate": jam,
        "growth_rate": c.gamma,
        "fast_start": ({"growth_factor": fast, "until_fraction": s.phi_fast}
                       if (fast > 1.0 and s.t_fast > s.t0) else None),
        "seed": seed_record(ss),
        "min_gap": float(gap),
        "shrink_factor": shrink,
        "continued": start is not None,
        "max_pressure": c.p_max,
    }
    history.append({k: val for k, val in run.items() if k != "pressure_history"})
    meta.update(run)
    meta["history"] = history
    return meta


def _spatial_order(x, box):
    """Sphere order along a coarse cell grid (neighbours close in memory)."""
    n, dim = x.shape
    m = max(1, int(round((n / 4.0) ** (1.0 / dim))))
    c = np.floor(np.mod(x, box) / box * m).astype(np.int64).clip(0, m - 1)
    key = c[:, 0] * m + c[:, 1]
    if dim == 3:
        key = key * m + c[:, 2]
    return np.argsort(key, kind="stable")


def _thin(rows, m):
    """At most about ``m`` rows, evenly spaced, always keeping the last one."""
    if len(rows) > m:
        step = int(math.ceil(len(rows) / m))
        rows = rows[::-1][::step][::-1]
    return [[float(a), float(b)] for a, b in rows]


def _min_gap(pos, radii, box):
    from ..neighbors import min_relative_gap

    return min_relative_gap(pos, radii, box)
