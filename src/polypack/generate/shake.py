"""Monte-Carlo shaking and the shaking collective rearrangement model (SCRM).

Implements §3.2 of 000_2cedc098acbd866b.txt: every sphere in turn is given a small
random displacement inside its shake window ``|x' - x_i| < R_sh^(k) a^(k)`` and
the move is kept if the sphere overlaps no neighbour (the "global shake" passes
once over all spheres).  Shaking destroys the dense "locked" local arrangements
that growth algorithms (CRM, :func:`polypack.pack`) leave behind: the contact peak
``g(2a+)`` falls and the window counts ``p(n_h)`` narrow (§5 and Figs. 1, 2, 4 of
000_2cedc098acbd866b.txt).  :func:`scrm` alternates growth and shaking.

The numerical engine is :mod:`polypack._kernels.shake`.
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import time
from dataclasses import dataclass

import numpy as np

from .. import _interrupt
from .. import _validate as _v
from .._util import as_seed_sequence, progress_bar, seed_record
from ..errors import InfeasibleError, Interrupted, InvalidInputError, OverlapError
from ..packing import Packing

__all__ = ["shake", "scrm", "METHODS"]

METHODS = ("paper", "collision", "metropolis")
_METHOD_CODE = {"paper": 0, "collision": 1, "metropolis": 2}
_ORDER_CODE = {"sequential": 0, "random": 1}
_DEFAULT_RADIUS = {"paper": 0.02, "collision": 0.05, "metropolis": 0.05}
_DEFAULT_TRIALS = {"paper": 150, "collision": 1, "metropolis": 1}
_DEFAULT_ORDER = {"paper": "sequential", "collision": "sequential", "metropolis": "random"}
_RSH_MIN = 1e-4
#: Relative overlap tolerated in an *input* pack (round-off of a touching pair).
INPUT_OVERLAP_TOLERANCE = 1e-12

# inside options_check(): shake() judges its options and returns before any kernel runs
_OPTIONS_ONLY = contextvars.ContextVar("polypack_shake_options_only", default=False)


@contextlib.contextmanager
def options_check():
    """Within this block :func:`shake` only judges its options (the same errors) and returns
    the packing unchanged, before any numba kernel is compiled or loaded: the option checks
    of ``polypack run`` and :func:`scrm` on a two-sphere pack cost no compilation
    (issue 33: cold start)."""
    token = _OPTIONS_ONLY.set(True)
    try:
        yield
    finally:
        _OPTIONS_ONLY.reset(token)


def _per_species(name, value, n_species, kind=float):
    """Broadcast a scalar or per-species sequence to a (K,) array."""
    arr = np.atleast_1d(np.asarray(value, dtype=object))
    if arr.ndim != 1 or (arr.size != 1 and arr.size != n_species):
        raise InvalidInputError(
            f"{name}={value!r}: give one value or one per species ({n_species} species)"
        )
    try:
        out = np.array([kind(v) for v in arr], dtype=np.float64 if kind is float else np.int64)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name}={value!r}: must be numeric") from None
    if kind is int and not all(float(v) == int(v) for v in arr):
        raise InvalidInputError(f"{name}={value!r}: must be integers")
    if out.size == 1:
        out = np.full(n_species, out[0], dtype=out.dtype)
    return out


def _check_int(name, value, minimum):
    """An integer ``>= minimum`` (the shared check of :mod:`polypack._validate`)."""
    return int(_v.check(name, value, _v.int_min(minimum)))


@dataclass(frozen=True)
class ShakeTuning:
    """Speed knobs of :func:`shake`: both neighbour structures give identical results.

    Attributes
    ----------
    skin : float, optional
        Verlet-list margin (see :func:`shake`).
    neighbours : {"auto", "verlet", "cells"}
        Neighbour structure for the overlap test.
    """

    skin: float | None = None
    neighbours: str = "auto"

    def __post_init__(self):
        if self.skin is not None:
            object.__setattr__(self, "skin", _v.check("skin", self.skin, _v.positive))
        _v.check("neighbours", self.neighbours, _v.choice("auto", "verlet", "cells"))


def shake(
    packing,
    *,
    global_shakes=60,
    shake_radius=None,
    max_trials=None,
    method="paper",
    seed=None,
    order=None,
    adaptive=False,
    adapt_shakes=None,
    adapt_factor=0.05,
    target_acceptance=0.4,
    monitor=None,
    monitor_every=None,
    callback=None,
    tuning=None,
    progress=None,
) -> Packing:
    """Monte-Carlo shaking of a hard-sphere pack (§3.2 of 000_2cedc098acbd866b.txt).

    One *global shake* visits every sphere once.  A visit of sphere ``i`` of species
    ``k`` tries to move its centre inside the shake window of radius
    ``R_sh^(k) a_i`` and keeps the move if the sphere overlaps no other sphere.
    The overlap test is exact: it uses a size-aware Verlet list that is rebuilt
    whenever a sphere could reach a partner outside it, which is equivalent to the
    seed's testing window ``r_t^(km) = (1 + R_sh^(k)) a^(k) + a^(m)`` re-estimated
    after every local shake.

    Parameters
    ----------
    packing : Packing
        A non-overlapping pack (relative overlaps up to ``1e-12`` from round-off
        are tolerated and never made worse).
    global_shakes : int
        ``M``, the number of passes over all spheres (default 60, as in §5.3 of
        000_2cedc098acbd866b.txt).
    shake_radius : float or sequence of float, optional
        ``R_sh^(k)``, the shake-window radius in units of the sphere radius
        (dimensionless, > 0), one value or one per species.  Defaults: 0.02 for
        ``"paper"`` (the seed's optimum), 0.05 otherwise.
    max_trials : int or sequence of int, optional
        ``N_sh^(k)``: trials per visit (``"paper"``: default 150, the seed's value;
        ``"collision"``: number of random directions of which the one with the
        longest free flight is taken, default 1; ``"metropolis"``: must be 1).
    method : {"paper", "collision", "metropolis"}
        ``"paper"``: displacement uniform in the shake window, retried until the
        sphere fits or ``N_sh`` trials fail (the seed's procedure).
        ``"collision"``: the collision-limited shake of Eq. (9) of
        000_2cedc098acbd866b.txt: a random direction ``u``, the free flight ``Δt``
        to the first contact along it, an amplitude uniform in
        ``[0, min(Δt, R_sh a_i)]``.
        ``"metropolis"``: one trial per visit with a symmetric proposal, accepted
        iff no overlap; satisfies detailed balance (random order) or balance
        (sequential order) and samples the equilibrium hard-sphere fluid.
    seed : int or numpy.random.SeedSequence, optional
        Recorded in ``meta["shake"]["seed"]``; the result is reproducible bit for
        bit for a given seed and input on one platform.
    progress : bool, optional
        Progress bar over global shakes (default: only on a terminal).
    order : {"sequential", "random"}, optional
        Visit the spheres in index order (the seed's "each sphere in turn";
        default for paper and collision) or pick ``N`` spheres uniformly at random
        per global shake (default for metropolis).
    adaptive : bool
        Adapt ``R_sh^(k)``.  Paper and collision: as the seed describes, after each
        visit compare the free flight along the (first) trial direction with the
        window ``R_sh a_i``: grow ``R_sh^(k)`` by the factor ``1 + adapt_factor`` if
        it is longer, shrink it otherwise (``R_sh`` tends to the median free
        flight).  Metropolis: after each global shake scale ``R_sh^(k)`` by the
        ratio of the measured to the target acceptance (clipped to [0.7, 1.4]).
        Adaptation stops after ``adapt_shakes`` global shakes.
    adapt_shakes : int, optional
        Global shakes during which ``R_sh`` adapts: default all for paper and
        collision; ``global_shakes // 2`` for metropolis, whose later shakes then
        run with a fixed step (detailed balance) — use them for sampling.
    adapt_factor : float
        Growth factor per visit of the seed's adaptation (default 0.05).
    target_acceptance : float
        Target acceptance of the Metropolis adaptation (default 0.4).
    tuning : ShakeTuning, optional
        Speed knobs. ``skin``: relative Verlet skin ``s`` (pairs with
        ``d <= (1 + s)(r_i + r_j)`` are listed); default ``max(0.5, 4 max R_sh)``,
        capped by the box, and widened while running if the list has to be rebuilt
        often; the overlap test is exact for any skin, so results do not depend on it.
        ``neighbours``: ``"verlet"`` (the size-aware Verlet list), ``"cells"`` (linked
        cell lists of side ``2 r_max`` plus the largest step, cheaper for large steps,
        e.g. Metropolis in a dilute fluid, but only for similar sizes) or ``"auto"``
        (cells when ``r_max <= 2 r_min`` and ``max R_sh >= 0.25``); both tests are
        exact, so the results are identical.
    monitor : callable, optional
        Convergence monitor ``monitor(packing) -> {key: float}``, e.g.
        :class:`polypack.analysis.ContactValueMonitor` (the contact values
        ``g_km(a_k + a_m)+`` per species pair ``"k-m"``).  Its values are recorded in
        ``meta["shake"]["monitor"][monitor.name]`` (``name`` attribute, default
        ``"values"``) with ``monitor.options`` (if any).  Default: no monitor.  The
        generators never import :mod:`polypack.analysis`; ``polypack run`` passes the
        contact-value monitor.
    monitor_every : int, optional
        With a ``monitor``: record every this many global shakes; default ``None``
        records only before and after, ``0`` never.
    callback : callable, optional
        ``callback(m, packing)`` after every global shake ``m = 1..M``.

    Returns
    -------
    Packing
        Same N, radii, species and box; new positions.  ``meta["shake"]`` holds
        the run record: ``method``, ``seed``, ``global_shakes``, ``shake_radius``
        (initial) and ``final_shake_radius`` per species, ``max_trials``,
        ``order``, ``skin``, per global shake and species ``acceptance_rate``
        (accepted / trials), ``moved_fraction`` (visits with a move / visits),
        ``mean_displacement`` (mean accepted ``|Δx| / a_i``), ``shake_radius_history``;
        ``grown_fraction`` (per shake and species, while the seed's adaptation runs: the
        fraction of visits whose free flight exceeded the window, which the adaptation
        drives to 1/2; ``None`` otherwise);
        ``net_displacement``: rows ``[m, per-species rms displacement since the start
        over a_i]`` (after every shake when monitoring, else at the end);
        ``monitor`` (``global_shake`` and the monitor's values, e.g. ``contact_value`` per
        pair ``"k-m"``; None without a monitor),
        ``trials``, ``accepted``, ``acceptance`` (overall), ``trial_moves_per_second``,
        ``wall_time``, ``rebuilds``,
        ``min_gap``.  ``meta["history"]`` gets a summary entry.

    Raises
    ------
    InvalidInputError
        Bad parameters (non-positive shake radius, zero trials, unknown method, ...).
    OverlapError
        If the input pack overlaps, or (never expected) the output does.
    polypack.errors.Interrupted
        Ctrl-C (SIGINT): shaking stops after the current kernel call (at most 20
        global shakes; every sphere at an accepted position) and the exception
        carries that pack in ``.partial`` (``meta["status"] == "interrupted"``).
    """
    from .._kernels import shake as kern

    wall0 = time.perf_counter()
    o = _check_shake(packing, global_shakes=global_shakes, shake_radius=shake_radius, max_trials=max_trials,
                     method=method, seed=seed, order=order, adaptive=adaptive, adapt_shakes=adapt_shakes,
                     adapt_factor=adapt_factor, target_acceptance=target_acceptance, monitor=monitor,
                     monitor_every=monitor_every, callback=callback, tuning=tuning)
    radii = np.ascontiguousarray(packing.radii, dtype=np.float64)
    box = np.ascontiguousarray(packing.box, dtype=np.float64)
    species = np.ascontiguousarray(packing.species, dtype=np.int64)
    options_only = _OPTIONS_ONLY.get()
    gap_in, pair_in = (0.0, None) if options_only else packing.closest_pair()
    if gap_in < -INPUT_OVERLAP_TOLERANCE:
        raise OverlapError(
            f"input pack overlaps: spheres {pair_in[0]} and {pair_in[1]} have relative gap {gap_in:.3e} "
            f"(allowed >= {-INPUT_OVERLAP_TOLERANCE:g}); shaking needs a non-overlapping pack"
        )
    s, s_cap = _verlet_skin(o["skin"], box, radii, o["rsh"])
    if options_only:
        return packing
    pos = np.array(packing.positions, dtype=np.float64, order="C")
    rng = o["ss"].generate_state(4, np.uint64)
    nb = _Neighbours(kern, pos, radii, box, species, o["rsh"], s, s_cap, o["skin"], o["neighbours"])
    nb.arrange()
    nb.rebuilds = 0
    mon = _MonitorLog(monitor)
    if o["monitor_every"] != 0:
        mon.record(0, packing)
    rsh0 = o["rsh"].copy()
    run = _sweep(kern, packing, pos, nb, rng, mon, o, callback, progress)

    meta = dict(packing.meta)
    history = list(meta.get("history", []))
    out = Packing(pos, radii, box, species=species, meta=meta)
    gap_out, pair_out = out.closest_pair()
    if gap_out < min(gap_in, 0.0):
        raise OverlapError(
            f"shaking produced an overlap: spheres {pair_out[0]} and {pair_out[1]} with relative gap "
            f"{gap_out:.3e}; please report this"
        )
    monitor_every = o["monitor_every"]
    if monitor_every is None or (monitor_every and o["global_shakes"] % monitor_every != 0):
        mon.record(o["global_shakes"], out)
    rec = _shake_record(o, nb, rsh0, run, mon, gap_in, gap_out)
    rec["wall_time"] = time.perf_counter() - wall0
    hist = run["hist"]
    summary = {k: v for k, v in rec.items() if k not in hist and k != "monitor"}
    if rec["monitor"] is not None:
        summary[f"{mon.name}_final"] = {k: v[-1] for k, v in mon.log[mon.name].items()}
    history.append(summary)
    meta["shake"] = rec
    meta["history"] = history
    meta["min_gap"] = float(gap_out)
    out.meta = meta
    return out


# ---------------------------------------------------------------- shake: the steps
def _check_shake(packing, *, global_shakes, shake_radius, max_trials, method, seed, order, adaptive, adapt_shakes,
                 adapt_factor, target_acceptance, monitor, monitor_every, callback, tuning):
    """The options of :func:`shake` checked and normalised (per-species ``rsh`` and ``trials``
    arrays, the method's defaults filled in, the seed sequence ``ss``) as a dict."""
    if not isinstance(packing, Packing):
        raise InvalidInputError(
            f"shake needs a polypack.Packing, got {type(packing).__name__}; build one with polypack.Packing(...)"
        )
    if packing.dim != 3 or not packing.fully_periodic:
        raise InvalidInputError(
            f"shake supports 3D fully periodic packings only; got a {packing.dim}D packing with "
            f"periodic={packing.periodic}"
        )
    if packing.n < 2:
        raise InvalidInputError(f"shake needs at least 2 spheres, got {packing.n}")
    if tuning is None:
        tuning = ShakeTuning()
    elif not isinstance(tuning, ShakeTuning):
        raise InvalidInputError(f"tuning={tuning!r}: must be a polypack.generate.ShakeTuning")
    skin, neighbours = tuning.skin, tuning.neighbours
    if method not in _METHOD_CODE:
        raise InvalidInputError(f"method={method!r}: allowed are {', '.join(map(repr, METHODS))}")
    global_shakes = _check_int("global_shakes", global_shakes, 0)
    ns = packing.n_species
    rsh = _per_species("shake_radius", _DEFAULT_RADIUS[method] if shake_radius is None else shake_radius, ns)
    if not np.all(np.isfinite(rsh)) or np.any(rsh <= 0):
        bad = float(rsh[~(np.isfinite(rsh) & (rsh > 0))][0])
        raise InvalidInputError(
            f"shake_radius={bad!r}: must be finite and > 0 (in units of the sphere radius)"
        )
    trials = _per_species("max_trials", _DEFAULT_TRIALS[method] if max_trials is None else max_trials, ns, int)
    if np.any(trials < 1):
        raise InvalidInputError(f"max_trials={max_trials!r}: must be >= 1 trial per visit")
    if method == "metropolis" and np.any(trials != 1):
        raise InvalidInputError(
            f"max_trials={max_trials!r}: metropolis makes exactly one trial per move (retrying breaks detailed "
            "balance); use method='paper' for repeated trials"
        )
    order = _DEFAULT_ORDER[method] if order is None else order
    if order not in _ORDER_CODE:
        raise InvalidInputError(f"order={order!r}: allowed are 'sequential' and 'random'")
    if adapt_shakes is None:
        adapt_shakes = global_shakes // 2 if method == "metropolis" else global_shakes
    adapt_shakes = _check_int("adapt_shakes", adapt_shakes, 0)
    adapt_factor = float(adapt_factor)
    if not (0 < adapt_factor < 1):
        raise InvalidInputError(f"adapt_factor={adapt_factor!r}: must be in (0, 1)")
    target_acceptance = float(target_acceptance)
    if not (0 < target_acceptance < 1):
        raise InvalidInputError(f"target_acceptance={target_acceptance!r}: must be in (0, 1)")
    if monitor_every is not None:
        monitor_every = _check_int("monitor_every", monitor_every, 0)
    if monitor is not None and not callable(monitor):
        raise InvalidInputError(f"monitor={monitor!r}: must be callable as monitor(packing) -> dict of floats")
    if monitor is None:
        monitor_every = 0
    if neighbours not in ("auto", "verlet", "cells"):
        raise InvalidInputError(f"neighbours={neighbours!r}: allowed are 'auto', 'verlet' and 'cells'")
    if callback is not None and not callable(callback):
        raise InvalidInputError(f"callback={callback!r}: must be callable as callback(m, packing)")
    ss = as_seed_sequence(seed)
    return dict(method=method, global_shakes=global_shakes, ns=ns, rsh=rsh, trials=trials, order=order,
                adaptive=adaptive, adapt_shakes=adapt_shakes, adapt_factor=adapt_factor,
                target_acceptance=target_acceptance, monitor_every=monitor_every, skin=skin, neighbours=neighbours,
                ss=ss)


def _verlet_skin(skin, box, radii, rsh):
    """``(s, s_cap)``: the relative Verlet skin (at least the largest window, default ``max(0.5,
    4 max R_sh)``) and its cap, which keeps the list reach below ``L / 2``."""
    s_cap = float(box.min()) / (4.0 * float(radii.max())) - 1.0
    rsh_top = float(rsh.max())
    if skin is None:
        s = min(max(0.5, 4.0 * rsh_top), s_cap)
    else:
        s = float(skin)
        if not (np.isfinite(s) and s > 0):
            raise InvalidInputError(f"skin={skin!r}: must be finite and > 0")
        if s > s_cap:
            raise InvalidInputError(f"skin={s:g} exceeds {s_cap:g}, the largest the box allows")
    if rsh_top > s:
        raise InvalidInputError(
            f"shake_radius={rsh_top:g} exceeds the neighbour skin {s:g} (the box allows at most "
            f"{s_cap:g}); use a smaller shake_radius or a larger pack"
        )
    return s, s_cap


class _Neighbours:
    """The neighbour structure of the overlap test: the size-aware Verlet list (``start``, ``idx``
    with relative skin ``s``; ``since`` the displacements since its build) or linked cells of
    side ``h`` (``cgrid``, ``links``). ``rsh`` is the live (adapted in place) window array."""

    def __init__(self, kern, pos, radii, box, species, rsh, s, s_cap, skin, neighbours):
        self.kern, self.pos, self.radii, self.box, self.rsh = kern, pos, radii, box, rsh
        self.s_cap, self.skin, self.neighbours = s_cap, skin, neighbours
        self.since = np.zeros_like(pos)
        self.r_max, r_min = float(radii.max()), float(radii.min())
        # per-species largest radius: the largest absolute step of species k is rsh[k] * a_max^(k)
        self.r_max_sp = np.array([radii[species == k].max() if np.any(species == k) else 0.0
                                  for k in range(rsh.shape[0])])
        self.similar = self.r_max <= 2.0 * r_min
        self.mode, self.s, self.ncell, self.start, self.idx = None, s, None, None, None
        self.t_build, self.rebuilds, self.h = 0.0, 0, 0.0
        self.cgrid, self.links = np.ones(3, np.int64), None

    def verlet(self, s_new):
        from ..neighbors import choose_cells

        self.s = s_new
        reach_small = 2.0 * (1.0 + s_new) * float(np.percentile(self.radii, 10))
        self.ncell = np.ascontiguousarray(choose_cells(self.box, self.pos.shape[0], reach_small), dtype=np.int64)
        t = time.perf_counter()
        self.start, self.idx = self.kern.build_list(self.pos, self.radii, self.box, s_new, self.ncell)
        self.t_build = time.perf_counter() - t
        self.since[:] = 0.0
        self.mode = "verlet"
        self.rebuilds += 1

    def cells(self, step_abs):
        # cell side >= 2 r_max + the largest step: the 27 cells around a sphere hold every partner
        self.h = 2.0 * self.r_max + 1.5 * step_abs
        self.cgrid = np.maximum(1, np.floor(self.box / self.h)).astype(np.int64)
        self.links = self.kern.build_links(self.pos, self.box, self.cgrid)
        self.mode = "cells"

    def arrange(self):
        """Pick and (re)build the neighbour structure for the current windows."""
        rsh, skin = self.rsh, self.skin
        step_abs = float(np.max(rsh * self.r_max_sp))
        want = self.neighbours == "cells" or (self.neighbours == "auto" and self.similar and float(rsh.max()) >= 0.25)
        if want:
            if self.mode != "cells" or 2.0 * self.r_max + step_abs > self.h:
                self.cells(step_abs)
        elif self.mode != "verlet":
            self.verlet(self.s)
        elif float(rsh.max()) > self.s or (skin is None and 3.0 * float(rsh.max()) > self.s and self.s < self.s_cap):
            # the window grew: widen the skin (it must never be below the window)
            top = float(rsh.max())
            self.verlet(min(self.s_cap, 4.0 * top) if skin is None else max(self.s, top))


class _MonitorLog:
    """The values of a convergence monitor per recorded global shake (``log``, keyed ``name``)."""

    def __init__(self, monitor):
        self.monitor = monitor
        self.name = str(getattr(monitor, "name", "values"))
        self.log = {"global_shake": [], self.name: {}}
        if getattr(monitor, "options", None) is not None:
            self.log["options"] = dict(monitor.options)

    def record(self, m, pk):
        self.log["global_shake"].append(m)
        vals = self.monitor(pk)
        for key, v in vals.items():
            self.log[self.name].setdefault(str(key), []).append(float(v))


def _nanlist(a):
    return [None if not math.isfinite(x) else float(x) for x in a]


def _sweep(kern, packing, pos, nb, rng, mon, o, callback, progress):
    """The global shakes: kernel calls of up to 20 shakes (one while adapting, monitoring or
    calling back), Ctrl-C deferred to their ends.

    Returns the run's counters: ``hist`` (per-shake statistics), ``trials``, ``accepted``,
    ``kernel_time`` and ``rebuilds`` (inside the kernel).

    Raises
    ------
    polypack.errors.Interrupted
        On Ctrl-C, with the pack at the end of the last kernel call in ``.partial``.
    """
    method, global_shakes, ns, rsh = o["method"], o["global_shakes"], o["ns"], o["rsh"]
    adaptive, adapt_shakes, monitor_every = o["adaptive"], o["adapt_shakes"], o["monitor_every"]
    radii = nb.radii
    species = np.ascontiguousarray(packing.species, dtype=np.int64)
    net = np.zeros_like(pos)
    dummy_i = np.zeros(1, np.int64)
    counts = np.bincount(species, minlength=ns).astype(np.float64)
    run = {"hist": {"acceptance_rate": [], "moved_fraction": [], "mean_displacement": [], "net_displacement": [],
                    "shake_radius_history": [], "grown_fraction": []},
           "trials": 0.0, "accepted": 0.0, "kernel_time": 0.0, "rebuilds": 0}
    code, ocode = _METHOD_CODE[method], _ORDER_CODE[o["order"]]
    r2 = radii**2
    bar = progress_bar(total=global_shakes, desc=f"shake ({method})", progress=progress, unit="shake")
    m = 0
    window_sweeps = window_rebuilds = 0
    window_time = 0.0
    # Ctrl-C is deferred to the end of the current kernel call (a safe point: every
    # sphere sits at an accepted, non-overlapping position)
    with _interrupt.deferred():
        try:
            while m < global_shakes:
                if _interrupt.consume():
                    partial = packing.replace(positions=pos.copy())
                    partial.meta = dict(packing.meta, status="interrupted",
                                        shake={"generator": "polypack.shake", "interrupted": True,
                                               "global_shakes": global_shakes, "global_shakes_done": m,
                                               "seed": seed_record(o["ss"])})
                    raise Interrupted(
                        f"shake interrupted after {m} of {global_shakes} global shakes "
                        "(the partial pack is in .partial)",
                        partial=partial,
                    )
                adapting = bool(adaptive) and m + 1 <= adapt_shakes
                per_shake = adapting or callback is not None or bool(monitor_every)
                if per_shake:
                    chunk = 1
                else:
                    chunk = min(global_shakes - m, 20)
                stats = np.zeros((chunk, ns, kern.N_STATS))
                use_cells = nb.mode == "cells"
                if use_cells:
                    head, nxt, prv, cell = nb.links
                    start, idx, ncell = dummy_i, dummy_i, nb.cgrid
                    cap = (nb.h - 2.0 * nb.r_max) / nb.r_max
                else:
                    head = nxt = prv = cell = dummy_i
                    start, idx, ncell = nb.start, nb.idx, nb.ncell
                    cap = 0.5 * nb.s
                t0 = time.perf_counter()
                start, idx, nreb = kern.shake_sweeps(
                    pos, nb.since, radii, species, nb.box, rsh, start, idx, nb.s, ncell, code, ocode, o["trials"],
                    chunk, adapting and method != "metropolis", o["adapt_factor"], _RSH_MIN, cap, rng, net, stats,
                    use_cells, nb.cgrid, head, nxt, prv, cell,
                )
                elapsed = time.perf_counter() - t0
                run["kernel_time"] += elapsed
                if not use_cells:
                    nb.start, nb.idx = start, idx
                run["rebuilds"] += int(nreb)
                window_sweeps += chunk
                window_rebuilds += int(nreb)
                window_time += elapsed
                if window_sweeps >= 20:
                    # rebuilds take more than ~1/4 of the time: a wider skin pays off
                    frequent = window_rebuilds * nb.t_build > 0.25 * window_time
                    window_sweeps = window_rebuilds = 0
                    window_time = 0.0
                else:
                    frequent = False
                if nb.skin is None and frequent and nb.mode == "verlet" and nb.s < nb.s_cap:
                    nb.verlet(min(nb.s_cap, 1.4 * nb.s))
                m, acc = _record_shakes(kern, stats, run, m, rsh, adapting and method != "metropolis")
                with np.errstate(invalid="ignore", divide="ignore"):
                    netd = np.sqrt(np.bincount(species, weights=(net * net).sum(axis=1) / r2, minlength=ns) / counts)
                run["hist"]["net_displacement"].append([m, _nanlist(netd)])
                if adapting and method == "metropolis":
                    st = stats[-1]
                    for k in range(ns):
                        if st[k, kern.ST_TRIALS] > 0:
                            fac = min(1.4, max(0.7, acc[k] / o["target_acceptance"]))
                            rsh[k] = min(nb.s_cap, max(_RSH_MIN, rsh[k] * fac))
                    run["hist"]["shake_radius_history"][-1] = [float(x) for x in rsh]
                if adapting:
                    nb.arrange()
                if per_shake:
                    cur = packing.replace(positions=pos)
                    if monitor_every and m % monitor_every == 0:
                        mon.record(m, cur)
                    if callback is not None:
                        callback(m, cur)
                bar.update(chunk)
                if not bar.disable:
                    bar.set_postfix(acc=f"{np.nanmean(acc):.3f}")
        finally:
            bar.close()
    return run


def _record_shakes(kern, stats, run, m, rsh, seed_adapting):
    """Add the kernel statistics of each global shake in ``stats`` to ``run``; returns the shake
    count after them and the acceptance per species of the last one."""
    hist = run["hist"]
    for st in stats:
        m += 1
        run["trials"] += float(st[:, kern.ST_TRIALS].sum())
        run["accepted"] += float(st[:, kern.ST_ACCEPTED].sum())
        with np.errstate(invalid="ignore", divide="ignore"):
            acc = st[:, kern.ST_ACCEPTED] / st[:, kern.ST_TRIALS]
            moved = st[:, kern.ST_MOVED] / st[:, kern.ST_VISITS]
            mdisp = st[:, kern.ST_DISP] / st[:, kern.ST_ACCEPTED]
            grown = st[:, kern.ST_GROW] / st[:, kern.ST_VISITS]
        hist["acceptance_rate"].append(_nanlist(acc))
        hist["moved_fraction"].append(_nanlist(moved))
        hist["mean_displacement"].append(_nanlist(mdisp))
        hist["grown_fraction"].append(_nanlist(grown) if seed_adapting else None)
        hist["shake_radius_history"].append([float(x) for x in rsh])
    return m, acc


def _shake_record(o, nb, rsh0, run, mon, gap_in, gap_out):
    """``meta["shake"]`` of a finished run (``wall_time`` left None for the caller)."""
    adaptive, method = o["adaptive"], o["method"]
    total_trials, total_accepted, kernel_time = run["trials"], run["accepted"], run["kernel_time"]
    return {
        "generator": "polypack.shake",
        "method": method,
        "seed": seed_record(o["ss"]),
        "global_shakes": o["global_shakes"],
        "shake_radius": [float(x) for x in rsh0],
        "final_shake_radius": [float(x) for x in o["rsh"]],
        "max_trials": [int(x) for x in o["trials"]],
        "order": o["order"],
        "adaptive": bool(adaptive),
        "adapt_shakes": o["adapt_shakes"] if adaptive else 0,
        "target_acceptance": o["target_acceptance"] if (adaptive and method == "metropolis") else None,
        "skin": nb.s,
        "neighbours": o["neighbours"],
        "final_neighbour_structure": nb.mode,
        "trials": int(total_trials),
        "accepted": int(total_accepted),
        "acceptance": total_accepted / total_trials if total_trials else None,
        "trial_moves_per_second": total_trials / kernel_time if kernel_time > 0 else None,
        "rebuilds": run["rebuilds"] + nb.rebuilds,
        "wall_time": None,
        "min_gap": float(gap_out),
        "input_min_gap": float(gap_in),
        "monitor": mon.log if o["monitor_every"] != 0 else None,
        **run["hist"],
    }


def _check_shake_options(options):
    """Judge the shake options of :func:`scrm` before any growth runs."""
    import inspect

    allowed = set(inspect.signature(shake).parameters) - {"packing", "global_shakes", "seed", "progress"}
    unknown = set(options) - allowed
    if unknown:
        raise InvalidInputError(f"unknown scrm option(s) {sorted(unknown)}; allowed shake options: {sorted(allowed)}")
    from ..packing import Packing

    tiny = Packing(np.array([[0.0, 0.0, 0.0], [2.5, 2.5, 2.5]]), np.array([0.5, 0.5]), np.full(3, 5.0))
    opts = {k: v for k, v in options.items() if k not in ("callback",)}
    if "shake_radius" in opts or "max_trials" in opts:  # per-species values: judged on the real pack
        opts.pop("shake_radius", None)
        opts.pop("max_trials", None)
    with _interrupt.deferred(), options_check():
        shake(tiny, global_shakes=0, seed=0, progress=False, **{**opts, "monitor_every": 0})


def scrm(
    sizes,
    volume_fraction=0.6,
    *,
    seed=None,
    growth_steps=10,
    start_fraction=None,
    schedule=None,
    stage_shakes=1,
    global_shakes=60,
    growth_rate=None,
    max_pressure=None,
    pressure_window=None,
    fast_growth=None,
    fast_growth_until=None,
    pack_tuning=None,
    shake_radius=None,
    max_trials=None,
    method=None,
    order=None,
    adaptive=None,
    adapt_shakes=None,
    adapt_factor=None,
    target_acceptance=None,
    shake_tuning=None,
    monitor=None,
    monitor_every=None,
    progress=None,
) -> Packing:
    """Shaking collective rearrangement model (SCRM, §3.2 of 000_2cedc098acbd866b.txt).

    CRM growth (:func:`polypack.pack`, §3.1) interleaved with shaking: the pack is
    grown to each volume fraction of a schedule in turn and shaken
    ``stage_shakes`` times after each growth stage; at the target fraction it is
    shaken ``global_shakes`` more times.

    Parameters
    ----------
    sizes : SizeSet, array_like of radii or Packing
        As for :func:`polypack.pack`.
    volume_fraction : float
        Target ``c``.
    seed : int or numpy.random.SeedSequence, optional
        Split into independent child seeds for every growth and shaking stage
        (recorded in ``meta``).
    growth_steps : int
        Number of growth stages (default 10) when no ``schedule`` is given; the
        stage fractions are spaced evenly from ``start_fraction`` to the target.
    start_fraction : float, optional
        First stage fraction (default ``0.8 * volume_fraction``).
    schedule : sequence of float, optional
        Explicit increasing stage fractions; the last must equal the target.
    stage_shakes : int
        Global shakes after each growth stage (default 1).
    global_shakes : int
        ``M``, global shakes at the target (default 60).
    growth_rate, max_pressure, pressure_window, fast_growth, fast_growth_until : optional
        Options of every growth stage, as for :func:`polypack.pack` (``None``: its default).
    pack_tuning : PackTuning, optional
        Speed knobs of the growth stages (``tuning`` of :func:`polypack.pack`).
    shake_radius, max_trials, method, order, adaptive, adapt_shakes, adapt_factor, target_acceptance : optional
        Options of every shaking stage, as for :func:`shake` (``None``: its default).
    shake_tuning : ShakeTuning, optional
        Speed knobs of the shaking stages (``tuning`` of :func:`shake`).
    monitor, monitor_every : optional
        Convergence monitor of the final ``M`` global shakes (see :func:`shake`).
    progress : bool, optional
        Progress bar over stages.

    Returns
    -------
    Packing
        ``meta["scrm"]`` records the schedule (stage fractions, shakes per stage,
        acceptance per stage, times) and the seeds; ``meta["shake"]`` is the record
        of the final ``M`` global shakes; ``meta["history"]`` lists every stage.

    Raises
    ------
    InvalidInputError
        Bad schedule or shake options (judged before any growth runs).
    InfeasibleError
        A growth stage jammed below its target or ended on a budget.
    polypack.errors.Interrupted
        Ctrl-C (SIGINT): the running growth or shake stops at its next safe point and
        no later stage runs; ``.partial`` is the pack of the last finished step (or
        None), marked ``meta["status"] == "interrupted"``.
    """
    if isinstance(volume_fraction, str) or not isinstance(volume_fraction, (int, float, np.floating)):
        raise InvalidInputError(f"volume_fraction={volume_fraction!r}: scrm needs a number in (0, 1)")
    c = float(volume_fraction)
    if not (0 < c < 1):
        raise InvalidInputError(f"volume_fraction={c!r}: must be in (0, 1)")
    stage_shakes = _check_int("stage_shakes", stage_shakes, 0)
    global_shakes = _check_int("global_shakes", global_shakes, 0)
    fractions = _scrm_schedule(c, growth_steps, start_fraction, schedule)
    given = dict(shake_radius=shake_radius, max_trials=max_trials, method=method, order=order, adaptive=adaptive,
                 adapt_shakes=adapt_shakes, adapt_factor=adapt_factor, target_acceptance=target_acceptance)
    shake_options = {k: v for k, v in given.items() if v is not None}
    if shake_tuning is not None:
        shake_options["tuning"] = shake_tuning
    if monitor is not None:
        shake_options["monitor"] = monitor
    if monitor_every is not None:
        shake_options["monitor_every"] = monitor_every
    grow = dict(max_pressure=max_pressure, pressure_window=pressure_window, fast_growth=fast_growth,
                fast_growth_until=fast_growth_until)
    pack_options = {k: v for k, v in grow.items() if v is not None}
    if pack_tuning is not None:
        pack_options["tuning"] = pack_tuning
    _check_shake_options(shake_options)
    ss = as_seed_sequence(seed)
    children = ss.spawn(2 * len(fractions) + 1)
    wall0 = time.perf_counter()
    pk, stages = _scrm_stages(sizes, fractions, children, stage_shakes, global_shakes, growth_rate, pack_options,
                              shake_options, progress)
    meta = dict(pk.meta)
    meta["scrm"] = {
        "generator": "polypack.scrm",
        "volume_fraction": c,
        "schedule": fractions,
        "stage_shakes": stage_shakes,
        "global_shakes": global_shakes,
        "growth_rate": growth_rate,
        "stages": stages,
        "seed": seed_record(ss),
        "shake_options": {k: (v if isinstance(v, (int, float, str, bool, type(None))) else repr(v))
                          for k, v in shake_options.items() if k not in ("monitor", "tuning", "monitor_every")},
        "wall_time": time.perf_counter() - wall0,
    }
    pk.meta = meta
    return pk


def _scrm_schedule(c, growth_steps, start_fraction, schedule):
    """The checked stage fractions of :func:`scrm` up to its target volume fraction ``c``."""
    if schedule is None:
        growth_steps = _check_int("growth_steps", growth_steps, 1)
        c0 = 0.8 * c if start_fraction is None else float(start_fraction)
        if not (0 < c0 <= c):
            raise InvalidInputError(f"start_fraction={start_fraction!r}: must be in (0, volume_fraction]")
        fractions = [c] if growth_steps == 1 else list(np.linspace(c0, c, growth_steps))
    else:
        fractions = [float(x) for x in schedule]
        if not fractions or any(not (0 < x < 1) for x in fractions):
            raise InvalidInputError(f"schedule={schedule!r}: needs fractions in (0, 1)")
        if any(b <= a for a, b in zip(fractions, fractions[1:])):
            raise InvalidInputError(f"schedule={schedule!r}: fractions must increase")
        if abs(fractions[-1] - c) > 1e-12:
            raise InvalidInputError(f"schedule ends at {fractions[-1]!r}; it must end at volume_fraction={c!r}")
    return fractions


def _scrm_stages(sizes, fractions, children, stage_shakes, global_shakes, growth_rate, pack_options, shake_options,
                 progress):
    """Grow to each stage fraction and shake, then the final global shakes; ``(pack, stage records)``.

    One deferred section over all stages: a Ctrl-C stops the running growth or shake at its
    next safe point, and scrm never carries on with a stage after an interrupted one.
    """
    from . import pack

    stages = []
    pk = sizes
    bar = progress_bar(total=len(fractions) + 1, desc="scrm", progress=progress, unit="stage")
    where = "before the first growth stage"
    try:
        with _interrupt.deferred():
            for s_i, frac in enumerate(fractions):
                where = f"in growth stage {s_i + 1} of {len(fractions)} (to {frac:.6g})"
                _interrupt.check(f"scrm interrupted {where}", partial=None if s_i == 0 else pk)
                t0 = time.perf_counter()
                pk = pack(pk, volume_fraction=frac, seed=children[2 * s_i], growth_rate=growth_rate,
                          progress=False, **pack_options)
                t1 = time.perf_counter()
                reached = pk.volume_fraction
                status = pk.meta.get("status")
                rec = {"stage": s_i, "target": frac, "reached": reached, "pack_status": status,
                       "pack_time": t1 - t0, "shakes": 0}
                if stage_shakes:
                    where = f"in the shakes after growth stage {s_i + 1} of {len(fractions)}"
                    _interrupt.check(f"scrm interrupted {where}", partial=pk)
                    pk = shake(pk, global_shakes=stage_shakes, seed=children[2 * s_i + 1], progress=False,
                               **{**shake_options, "monitor_every": 0})
                    sh = pk.meta["shake"]
                    rec.update(shakes=stage_shakes, shake_time=sh["wall_time"],
                               acceptance_rate=sh["acceptance_rate"][-1])
                stages.append(rec)
                bar.update(1)
                _check_stage(status, reached, frac, s_i)
            where = f"in the {global_shakes} final global shakes"
            _interrupt.check(f"scrm interrupted {where}", partial=pk)
            pk = shake(pk, global_shakes=global_shakes, seed=children[-1], progress=False, **shake_options)
            bar.update(1)
    except Interrupted as exc:
        part = exc.partial
        if part is not None:
            part.meta = dict(part.meta, status="interrupted")
        raise Interrupted(f"scrm interrupted {where}: {exc}" if str(exc) and "scrm" not in str(exc)
                          else str(exc) or f"scrm interrupted {where}", partial=part) from None
    finally:
        bar.close()
    return pk, stages


def _check_stage(status, reached, frac, s_i):
    """Refuse a growth stage that jammed below its target or ended on a budget."""
    if status == "jammed" and reached < frac - 1e-9:
        raise InfeasibleError(
            f"growth jammed at volume fraction {reached:.4f} below the stage target {frac:.4f}; "
            "lower volume_fraction or use a gentler schedule"
        )
    if status not in ("target", "jammed"):
        raise InfeasibleError(
            f"growth stage {s_i + 1} ended with status {status!r} at volume fraction {reached:.4f} "
            f"(target {frac:.4f})"
        )
