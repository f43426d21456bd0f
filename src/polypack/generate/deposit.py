"""Sequential deposition of disks under gravity by potential minimisation, §2.4 of 001_ad5bae0acea940c4.txt.

Seed 001 assembles its 2D packs "by the potential minimization method": the disks are
placed one at a time, each at the lowest position where it rests on the floor, a wall or
two disks of the free surface.  The geometry, the tie rule and the surface structure are
described in :mod:`polypack._kernels.deposit`.
"""

from __future__ import annotations

import math

import numpy as np

from .. import _interrupt
from .._util import as_seed_sequence, progress_bar, rng_from, seed_record
from ..errors import InvalidInputError, OverlapError
from ..packing import Packing

__all__ = ["deposit", "deposit_arrays", "deposit_arrays_3d", "deposit_arrays_roll", "DEFAULT_TOLERANCE",
           "DEFAULT_FRACTION_GUESS", "DEFAULT_FLOOR_RULE", "DEFAULT_RULE", "RULES"]

DEFAULT_TOLERANCE = 1e-10
"""Relative tolerance of the kernel's contact tests and tie rule (heights equal within ``tol * r``)."""

DEFAULT_FLOOR_RULE = "centred"
"""Bare-floor rule of 2D deposits: the midpoint of the leftmost bare stretch, as LMGC90's ``deposit2D``
(the deposition code of the seed's group).  Why, and what it implies for ρ(s < 0.05): docs/deposition.md."""

DEFAULT_FRACTION_GUESS = 0.82
"""Packing fraction used to choose a default width giving a roughly square deposit."""

DEFAULT_FRACTION_GUESS_3D = 0.6
"""The same for 3D deposits (a roughly cubic deposit)."""

_CHUNK = 2000

RULES = ("surface", "roll")
"""Deposition rules of 3D deposits: ``"surface"``, each sphere to the lowest stable pocket of the free surface
reachable by a vertical drop (:mod:`polypack._kernels.deposit3d`); ``"roll"``, drop at a random column and roll
on the spheres below until stably supported (Visscher & Bolsterli 1972, :mod:`polypack._kernels.roll3d`)."""

DEFAULT_RULE = "surface"


def _parse_radii(sizes, dim=None):
    if dim is not None and (isinstance(dim, bool) or dim not in (2, 3)):
        raise InvalidInputError(f"dim={dim!r}: allowed are 2 (disks) and 3 (spheres)")
    if isinstance(sizes, Packing):
        raise InvalidInputError("deposit takes sizes (a SizeSet or an array of radii), not a Packing")
    if hasattr(sizes, "radii"):
        own = int(getattr(sizes, "dim", 2))
        if dim is not None and own != dim:
            raise InvalidInputError(
                f"dim={dim} but the size set is for dim={own}; leave dim out or pass sizes for dim={dim}")
        dim = own
        radii = np.array(sizes.radii, dtype=np.float64)
        species = np.array(getattr(sizes, "species", np.zeros(radii.size)), dtype=np.int64)
    else:
        try:
            radii = np.array(sizes, dtype=np.float64)
        except (TypeError, ValueError):
            raise InvalidInputError(
                f"sizes of type {type(sizes).__name__}: allowed are a SizeSet or an array of radii") from None
        species = np.zeros(radii.size, dtype=np.int64)
        dim = 2 if dim is None else int(dim)
    if radii.ndim != 1 or radii.size < 1:
        raise InvalidInputError(f"radii must be a non-empty 1-D array, got shape {radii.shape}")
    bad = ~np.isfinite(radii) | (radii <= 0)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InvalidInputError(f"radius of disk {k} is {radii[k]!r}; radii must be finite and > 0")
    return radii, species, dim


def _bed_arrays(bed_positions, bed_radii, dim):
    """``(positions (M, dim), radii (M,))`` of a bed as fresh float64 arrays (empty when
    ``bed_positions`` is None), checked: as many radii as positions, radii finite and > 0,
    positions finite."""
    if bed_positions is None:
        return np.zeros((0, dim)), np.zeros(0)
    bed_p = np.array(bed_positions, dtype=np.float64).reshape(-1, dim)
    bed_r = np.array(bed_radii, dtype=np.float64).reshape(-1)
    if bed_r.shape[0] != bed_p.shape[0]:
        raise InvalidInputError(f"bed has {bed_p.shape[0]} positions but {bed_r.shape[0]} radii")
    if np.any(bed_r <= 0) or not np.all(np.isfinite(bed_r)) or not np.all(np.isfinite(bed_p)):
        raise InvalidInputError("bed radii must be finite and > 0 and bed positions finite")
    return bed_p, bed_r


def deposit_arrays(radii, width, periodic=True, bed_positions=None, bed_radii=None,
                   tolerance=DEFAULT_TOLERANCE, progress=None, floor_rule=DEFAULT_FLOOR_RULE):
    """Deposit disks of the given radii **in the given order**; plain arrays in and out.

    Parameters
    ----------
    radii : (N,) array of float
        Radii in deposition order.
    width : float
        Box width ``W`` along x.
    periodic : bool
        Periodic x axis (else walls at ``x = 0`` and ``x = W``).
    bed_positions, bed_radii : (M, 2), (M,) arrays, optional
        A fixed bed (placed first, never moved): e.g. a row of disks on the floor.
    tolerance : float
        Relative tolerance of the contact tests and of the tie rule.
    progress : bool, optional
        Progress bar (default: only on a terminal).
    floor_rule : {"centred", "left"}
        Bare-floor placement (see :func:`deposit`).

    Returns
    -------
    positions : (M + N, 2) array
        Bed first, then the deposited disks in deposition order.
    radii : (M + N,) array
    supports : (M + N, 2) int64 array
        The two supports of each disk: indices into the output, or the codes
        ``FLOOR``, ``LEFT_WALL``, ``RIGHT_WALL``, ``NO_SUPPORT`` of
        :mod:`polypack._kernels.deposit`.
    stats : dict
        Chain length statistics.
    """
    from .._kernels.deposit import DepositParam, DepositState, DepositStatus, deposit_disks

    radii = np.ascontiguousarray(radii, dtype=np.float64)
    bed_p, bed_r = _bed_arrays(bed_positions, bed_radii, 2)
    if bed_r.size:
        if np.any(bed_p[:, 1] < bed_r * (1 - 1e-12)):
            raise InvalidInputError("every bed disk must lie above the floor (y >= r)")
        if periodic:
            bed_p[:, 0] = np.mod(bed_p[:, 0], width)
        elif np.any(bed_p[:, 0] < bed_r * (1 - 1e-12)) or np.any(bed_p[:, 0] > width - bed_r * (1 - 1e-12)):
            raise InvalidInputError("every bed disk must lie between the walls (r <= x <= W - r)")
    m = bed_r.size
    rad = np.concatenate([bed_r, radii])
    n = rad.size
    pos = np.zeros((n, 2))
    pos[:m] = bed_p
    support = np.zeros((n, 2), dtype=np.int64)
    params = np.zeros(int(DepositParam.N_PARAMS))
    params[DepositParam.WIDTH] = width
    params[DepositParam.PERIODIC] = 1.0 if periodic else 0.0
    params[DepositParam.TOL] = tolerance
    params[DepositParam.RMAX] = rad.max()
    params[DepositParam.FLOOR_RULE] = float(_floor_rule_code(floor_rule))
    cap = 2 * n + 8
    cid = np.zeros(cap, dtype=np.int64)
    clo = np.zeros(cap)
    chi = np.zeros(cap)
    state = np.zeros(int(DepositState.N_STATE), dtype=np.int64)
    # Ctrl-C is deferred to the end of a chunk (a safe point: the chain is consistent)
    # and then propagates; nothing partial is returned
    with _interrupt.deferred(), progress_bar(total=n - m, desc="deposit", progress=progress, unit="disk") as bar:
        k = m
        while True:
            if _interrupt.consume():
                raise KeyboardInterrupt
            stop = min(n, max(k, m) + _CHUNK)
            status = deposit_disks(rad, m, stop, pos, support, params, cid, clo, chi, state)
            if status != DepositStatus.OK:
                raise RuntimeError(
                    f"deposition kernel stopped with {DepositStatus(status).name} at disk "
                    f"{int(state[DepositState.N_PLACED])} (please report)")
            bar.update(int(state[DepositState.N_PLACED]) - k)
            k = int(state[DepositState.N_PLACED])
            if k >= n:
                break
    stats = {"chain_length": int(state[DepositState.CHAIN_LEN]), "chain_max": int(state[DepositState.CHAIN_MAX])}
    return pos, rad, support, stats


def _floor_rule_code(floor_rule):
    from .._kernels.deposit import FLOOR_CENTRED, FLOOR_LEFT

    codes = {"left": FLOOR_LEFT, "centred": FLOOR_CENTRED}
    if floor_rule not in codes:
        raise InvalidInputError(f"floor_rule={floor_rule!r}: allowed are 'centred' and 'left'")
    return codes[floor_rule]


def deposit_arrays_3d(radii, width, periodic=True, tolerance=DEFAULT_TOLERANCE, progress=None, cover_levels=8,
                      search_all=False):
    """Deposit spheres of the given radii **in the given order** (3D); plain arrays in and out.

    Parameters
    ----------
    radii : (N,) array of float
        Radii in deposition order.
    width : (2,) floats
        Box lengths ``Lx, Ly``.
    periodic : bool
        Periodic x and y axes (else walls at 0 and ``L`` on both).
    tolerance : float
        Relative tolerance of the contact tests and of the tie rule.
    progress : bool, optional
        Progress bar (default: only on a terminal).
    cover_levels : int
        Radius levels of the envelope bound that orders the per-sphere searches (``Deposit3DParam.COVER_LEVELS``;
        0 keeps only the smallest radius). A speed setting: the pack does not depend on it.
    search_all : bool
        Search every alive sphere in full for every new sphere, without the lower bounds, thresholds,
        caches and quick rejections that prune the search (``Deposit3DParam.SEARCH_ALL``): the same pack,
        much slower; the oracle of the pruning in the tests.

    Returns
    -------
    positions : (N, 3) array
    supports : (N, 3) int64 array
        The three supports of each sphere: indices, or the codes ``FLOOR``, ``WALL_X0``,
        ``WALL_X1``, ``WALL_Y0``, ``WALL_Y1``, ``NO_SUPPORT`` of :mod:`polypack._kernels.deposit3d`.
    stats : dict
        Surface statistics (alive spheres, overhang placements, candidate searches).
    """
    from .._kernels import deposit3d as k3

    rad = np.ascontiguousarray(radii, dtype=np.float64)
    n = rad.size
    lx, ly = float(width[0]), float(width[1])
    rmax = float(rad.max())
    col = 0.5 * float(rad.min())
    # at most ~4e6 column cells
    col = max(col, math.sqrt(lx * ly / 4e6))
    params = np.zeros(int(k3.Deposit3DParam.N_PARAMS))
    params[k3.Deposit3DParam.LX] = lx
    params[k3.Deposit3DParam.LY] = ly
    params[k3.Deposit3DParam.PERIODIC_X] = 1.0 if periodic else 0.0
    params[k3.Deposit3DParam.PERIODIC_Y] = 1.0 if periodic else 0.0
    params[k3.Deposit3DParam.TOL] = tolerance
    params[k3.Deposit3DParam.RMAX] = rmax
    params[k3.Deposit3DParam.COLUMN_CELL] = col
    levels = int(cover_levels) if rad.max() > rad.min() else 0
    params[k3.Deposit3DParam.COVER_LEVELS] = levels
    params[k3.Deposit3DParam.SEARCH_ALL] = 1.0 if search_all else 0.0
    pos = np.zeros((n, 3))
    support = np.zeros((n, 3), dtype=np.int64)
    state = np.zeros(int(k3.Deposit3DState.N_STATE))
    work_f, work_i, cov = k3.make_work(n, lx, ly, rmax, col, levels)
    grid = k3.make_grid_3d(rad, lx, ly, periodic)
    slot_of, slot_r, cache_f, cache_i = k3.make_cache(rad)
    chunk = 500
    with _interrupt.deferred(), progress_bar(total=n, desc="deposit", progress=progress, unit="sphere") as bar:
        k = 0
        while k < n:
            if _interrupt.consume():
                raise KeyboardInterrupt
            stop = min(n, k + chunk)
            status = k3.deposit_spheres(rad, params, pos, support, state, k, stop, work_f, work_i, cov, grid,
                                        slot_of, slot_r, cache_f, cache_i)
            if status != k3.Deposit3DStatus.OK:
                raise RuntimeError(
                    f"3D deposition kernel stopped with {k3.Deposit3DStatus(status).name} at sphere "
                    f"{int(state[k3.Deposit3DState.N_PLACED])} (please report)")
            bar.update(stop - k)
            k = stop
    stats = {"alive": int(state[k3.Deposit3DState.N_ALIVE]), "alive_max": int(state[k3.Deposit3DState.ALIVE_MAX]),
             "overhang_placements": int(state[k3.Deposit3DState.N_OVERHANG]),
             "candidate_searches": int(state[k3.Deposit3DState.N_RECOMPUTED]),
             "improving_searches": int(state[k3.Deposit3DState.N_IMPROVED]),
             "rolled_placements": int(state[k3.Deposit3DState.N_ROLLED])}
    return pos, support, stats


def deposit_arrays_roll(radii, width, drop, tolerance=DEFAULT_TOLERANCE, progress=None, bed_positions=None,
                        bed_radii=None):
    """Drop-and-roll deposit of spheres (3D, periodic x and y) **in the given order**; plain arrays in and out.

    Parameters
    ----------
    radii : (N,) array of float
        Radii in deposition order.
    width : (2,) floats
        Box lengths ``Lx, Ly`` (periodic).
    drop : (N, 2) array of float
        Release column ``(x, y)`` of each sphere (the random drop of Visscher & Bolsterli 1972).
    tolerance : float
        Relative tolerance of the contact tests.
    progress : bool, optional
        Progress bar (default: only on a terminal).
    bed_positions, bed_radii : (M, 3), (M,) arrays, optional
        Spheres fixed before the deposition (never moved); they come first in the output.

    Returns
    -------
    positions : (M + N, 3) array
    radii : (M + N,) array
    supports : (M + N, 3) int64 array
        Up to three supports of each sphere: indices, ``FLOOR`` or ``NO_SUPPORT`` (codes of
        :mod:`polypack._kernels.roll3d`, the same values as :mod:`polypack._kernels.deposit3d`).
    stats : dict
        Motion statistics (events, spheres on the floor, neighbour entries examined).
    """
    from .._kernels import roll3d as kr

    rad_new = np.ascontiguousarray(radii, dtype=np.float64).reshape(-1)
    drop = np.ascontiguousarray(drop, dtype=np.float64).reshape(-1, 2)
    if drop.shape[0] != rad_new.size:
        raise InvalidInputError(f"drop has {drop.shape[0]} columns for {rad_new.size} spheres")
    lx, ly = float(width[0]), float(width[1])
    bed_p, bed_r = _bed_arrays(None if bed_radii is None else bed_positions, bed_radii, 3)
    if bed_r.size:
        bed_p[:, 0] = np.mod(bed_p[:, 0], lx)
        bed_p[:, 1] = np.mod(bed_p[:, 1], ly)
    m = bed_r.size
    rad = np.concatenate([bed_r, rad_new])
    n = rad.size
    pos = np.zeros((n, 3))
    pos[:m] = bed_p
    dr = np.zeros((n, 2))
    dr[m:] = np.mod(drop, [lx, ly])
    height = float(4.0 / 3.0 * np.pi * np.sum(rad**3) / (lx * ly * 0.5)) + 4.0 * float(rad.max())
    if m:
        height = max(height, float(np.max(bed_p[:, 2] + bed_r)) + height)
    gd = kr.grid_layout(lx, ly, float(rad.min()), float(rad.max()), height, True)
    head, ent_next, ent_sph, tops, stamp, counters = kr.make_grid(n, gd, kr.grid_capacity(rad, gd))
    for k in range(m):
        kr.grid_insert(k, pos, rad, gd, head, ent_next, ent_sph, tops, counters)
    support = np.full((n, 3), kr.NO_SUPPORT, dtype=np.int64)
    state = np.zeros(int(kr.RollState.N_STATE))
    buf = np.zeros(n, dtype=np.int64)
    chunk = 2000
    with _interrupt.deferred(), progress_bar(total=n - m, desc="deposit", progress=progress, unit="sphere") as bar:
        k = m
        while k < n:
            if _interrupt.consume():
                raise KeyboardInterrupt
            stop = min(n, k + chunk)
            status = kr.deposit_roll(rad, dr, pos, support, state, k, stop, gd, head, ent_next, ent_sph, tops, stamp,
                                     counters, buf, tolerance)
            if status != 0:
                raise RuntimeError("drop-and-roll kernel: cell grid pool exhausted (please report)")
            bar.update(stop - k)
            k = stop
    stats = {"events": int(state[kr.RollState.N_EVENTS]), "stuck": int(state[kr.RollState.N_STUCK]),
             "on_floor": int(state[kr.RollState.N_FLOOR]), "neighbours_examined": int(state[kr.RollState.N_GATHERED])}
    return pos, rad, support, stats


def _deposit_3d(radii, species, width, boundary, order, seed, tol, progress, rule=DEFAULT_RULE):
    periodic = boundary == "periodic"
    dmax = 2.0 * float(radii.max())
    if width is None:
        side = (float(4.0 / 3.0 * np.pi * np.sum(radii**3)) / DEFAULT_FRACTION_GUESS_3D) ** (1.0 / 3.0)
        side = max(side, 4.5 * dmax if periodic else 1.5 * dmax)
        width = (side, side)
    try:
        w = np.broadcast_to(np.asarray(width, dtype=np.float64), (2,)).astype(np.float64)
    except (TypeError, ValueError):
        raise InvalidInputError(f"width={width!r} must be a number or a pair (Lx, Ly) > 0") from None
    if not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise InvalidInputError(f"width={width!r} must be finite and > 0")
    if periodic and w.min() < 4.0 * dmax:
        raise InvalidInputError(
            f"width={w.min():g} is below four times the largest diameter {dmax:g}; a periodic deposit "
            "needs L >= 4 d_max on both axes (unique minimum image of the supports)")
    if not periodic and w.min() < dmax:
        raise InvalidInputError(f"a sphere of diameter {dmax:g} is wider than the box width={w.min():g}")
    if rule == "roll" and not periodic:
        raise InvalidInputError("rule='roll' supports boundary='periodic' only")
    ss = as_seed_sequence(seed)
    rng = rng_from(ss)
    perm = rng.permutation(radii.size) if order == "random" else np.arange(radii.size)
    rad = radii[perm]
    if rule == "roll":
        drop = rng.uniform(0.0, 1.0, (radii.size, 2)) * w
        pos, _, support, stats = deposit_arrays_roll(rad, w, drop, tol, progress)
    else:
        pos, support, stats = deposit_arrays_3d(rad, w, periodic, tol, progress)
    height = float(np.max(pos[:, 2] + rad))
    meta = {
        "protocol": "deposit",
        "method": "drop_and_roll" if rule == "roll" else "potential_minimisation",
        "rule": rule,
        "dim": 3,
        "boundary": boundary,
        "order": order,
        "width": [float(w[0]), float(w[1])],
        "tolerance": tol,
        "seed": seed_record(ss),
        "n_bed": 0,
        **stats,
    }
    pk = Packing(pos, rad, [w[0], w[1], height], species=species[perm], meta=meta,
                 periodic=(periodic, periodic, False))
    ov = pk.overlaps(1e-9)
    if len(ov):
        raise OverlapError(f"deposit produced {len(ov)} overlapping pair(s); worst relative gap {ov[0, 2]:.3e}")
    return pk


def deposit(sizes, width=None, boundary="periodic", order="random", seed=None, bed=None,
            tolerance=DEFAULT_TOLERANCE, progress=None, dim=None, floor_rule=None, rule=None):
    """Pack of disks (2D) or spheres (3D) built by sequential deposition (potential minimisation).

    Each disk, in turn, goes to the lowest centre height at which it rests on the floor,
    a wall or two disks of the free surface, reachable by a vertical drop; ties
    (heights within ``tolerance * r``) go to the leftmost position, except on bare floor
    (``floor_rule``).  This is the
    "potential minimization method" of §2.4 of 001_ad5bae0acea940c4.txt (Fig. 9 builds
    ρ(s) with it); every disk placed on two disks touches them and rests between them,
    so the mean coordination of the bulk is 4.

    Parameters
    ----------
    sizes : SizeSet or (N,) array of radii
        A SizeSet (``dim=2`` for disks, e.g. ``pp.psd.discretize(model, dim=2)``, or
        ``dim=3`` for spheres) or radii.
    dim : {2, 3}, optional
        Default: the size set's dimension; plain radii are disks (2) unless ``dim=3``.
        In 3D each sphere goes to the lowest position where it rests stably on the floor,
        the walls or three spheres, reachable by a vertical drop (the geometry, the
        stability test and the tie rule, lowest then smallest x then smallest y, are
        described in :mod:`polypack._kernels.deposit3d`); ``width`` is then ``L`` or
        ``(Lx, Ly)``, ``boundary`` applies to x and y, and ``bed`` is not supported.
    width : float, optional
        Box width ``W``.  Default: a roughly square deposit,
        ``sqrt(sum(pi r^2) / DEFAULT_FRACTION_GUESS)``.
    boundary : {"periodic", "walls"}
        x axis periodic, or rigid side walls at ``x = 0`` and ``x = W``.
    order : {"random", "given"}
        Deposition order: a random permutation drawn from ``seed``, or as given.
    seed : int or SeedSequence, optional
        Seeds the random order (recorded in ``meta["seed"]``).
    bed : Packing or (positions, radii), optional
        Disks fixed before the deposition (a rough floor); they come first in the output
        (``meta["n_bed"]``).
    tolerance : float
        Relative tolerance of the contact tests and of the tie rule.
    progress : bool, optional
        Progress bar (default: only on a terminal).
    floor_rule : {"centred", "left"}, optional
        Where a disk goes on bare floor (2D; default ``"centred"``,
        :data:`DEFAULT_FLOOR_RULE`): the midpoint of the leftmost bare stretch
        (``"centred"``: the floor fills by bisection, leaving gaps narrower than a disk, as
        the LMGC90 ``deposit2D`` routine of the seed's group does), or its leftmost point
        (``"left"``: a bare floor fills as a touching row from the left; equal disks then
        build the triangular crystal).  All other positions (pockets, walls) follow the
        same lowest-then-leftmost rule, so the two differ in the first layer only; below
        s ≈ 0.05 its memory reaches the bulk (``"centred"``: ρ depends on the width, see
        docs/deposition.md).  3D deposits have one rule (lowest, then smallest x, then
        smallest y): leave it out or pass ``"left"``.
    rule : {"surface", "roll"}, optional
        3D only (default ``"surface"``, :data:`DEFAULT_RULE`).  ``"surface"``: each sphere goes
        to the lowest stable pocket of the free surface reachable by a vertical drop (the
        global-minimum rule above; a sphere never enters the pores of the bed).  ``"roll"``:
        each sphere is released at a random column (drawn from ``seed``) and rolls on the
        spheres below it until it rests on three (or the floor), passing through every throat
        it fits through: the drop-and-roll algorithm of Visscher & Bolsterli (1972), which
        Jullien & Meakin (1990) used for the segregation of size mixtures; small spheres then
        percolate to the bottom (seed 001 §1).  Periodic boundary only.

    Returns
    -------
    Packing
        2D, ``periodic=(boundary == "periodic", False)``, box ``(W, H)`` with the floor at
        ``y = 0`` and ``H`` the top of the highest disk (an open top: no disk touches a
        wall there except the highest).  Disks are stored in deposition order (bed first;
        with ``order="given"`` that is the input order).  ``meta`` records the protocol, seed, width, boundary and chain statistics.

    Raises
    ------
    InvalidInputError
        A disk wider than the box (walls) or a periodic width below four diameters, an
        unknown boundary or order, bad radii.
    OverlapError
        If the result fails the overlap check (relative gap below ``-1e-9``; never
        expected).

    References
    ----------
    C. Voivret, F. Radjai, J.-Y. Delenne and M. S. El Youssoufi, Space-filling properties
    of polydisperse granular media, Phys. Rev. E 76, 021301 (2007).
    """
    radii, species, dim = _parse_radii(sizes, dim)
    if boundary not in ("periodic", "walls"):
        raise InvalidInputError(f"boundary={boundary!r}: allowed are 'periodic' and 'walls'")
    if order not in ("random", "given"):
        raise InvalidInputError(f"order={order!r}: allowed are 'random' and 'given'")
    try:
        tol = float(tolerance)
    except (TypeError, ValueError):
        raise InvalidInputError(f"tolerance={tolerance!r} must be a number in (0, 1e-3]") from None
    if not (0 < tol <= 1e-3):
        raise InvalidInputError(f"tolerance={tolerance!r} must be in (0, 1e-3]")
    if floor_rule not in (None, "left", "centred"):
        raise InvalidInputError(f"floor_rule={floor_rule!r}: allowed are 'centred' and 'left'")
    if rule is not None and rule not in RULES:
        raise InvalidInputError(f"rule={rule!r}: allowed are 'surface' and 'roll'")
    if dim == 3:
        if floor_rule == "centred":
            raise InvalidInputError("floor_rule='centred' is supported for 2D deposits only")
        if bed is not None:
            raise InvalidInputError("bed= is supported for 2D deposits only")
        return _deposit_3d(radii, species, width, boundary, order, seed, tol, progress,
                           DEFAULT_RULE if rule is None else rule)
    if rule not in (None, "surface"):
        raise InvalidInputError(f"rule={rule!r} is for 3D deposits; 2D deposits have the 'surface' rule only")
    if floor_rule is None:
        floor_rule = DEFAULT_FLOOR_RULE
    periodic = boundary == "periodic"
    bed_p = bed_r = None
    bed_sp = np.zeros(0, dtype=np.int64)
    if bed is not None:
        if isinstance(bed, Packing):
            if bed.dim != 2:
                raise InvalidInputError(f"bed must be a 2D Packing, got dim={bed.dim}")
            bed_p, bed_r, bed_sp = np.array(bed.positions), np.array(bed.radii), np.array(bed.species)
        else:
            try:
                bed_p, bed_r = bed
            except (TypeError, ValueError):
                raise InvalidInputError("bed must be a Packing or a pair (positions, radii)") from None
            bed_r = np.asarray(bed_r, dtype=np.float64).reshape(-1)
            bed_sp = np.zeros(bed_r.size, dtype=np.int64)
    all_r = radii if bed_r is None else np.concatenate([radii, bed_r])
    dmax = 2.0 * float(all_r.max())
    if width is None:
        width = math.sqrt(float(np.pi * np.sum(radii**2)) / DEFAULT_FRACTION_GUESS)
        width = max(width, 4.5 * dmax if periodic else 1.5 * dmax)
    try:
        width = float(width)
    except (TypeError, ValueError):
        raise InvalidInputError(f"width={width!r} must be a number > 0") from None
    if not np.isfinite(width) or width <= 0:
        raise InvalidInputError(f"width={width!r} must be finite and > 0")
    if periodic and width < 4.0 * dmax:
        raise InvalidInputError(
            f"width={width:g} is below four times the largest diameter {dmax:g}; a periodic deposit "
            "needs W >= 4 d_max (unique minimum image of the supports)")
    if not periodic and width < dmax:
        raise InvalidInputError(f"a disk of diameter {dmax:g} is wider than the box width={width:g}")
    ss = as_seed_sequence(seed)
    if order == "random":
        perm = rng_from(ss).permutation(radii.size)
    else:
        perm = np.arange(radii.size)
    pos, rad, support, stats = deposit_arrays(radii[perm], width, periodic, bed_p, bed_r, tol, progress, floor_rule)
    sp = np.concatenate([bed_sp, species[perm]])
    height = float(np.max(pos[:, 1] + rad))
    meta = {
        "protocol": "deposit",
        "method": "potential_minimisation",
        "boundary": boundary,
        "order": order,
        "floor_rule": floor_rule,
        "width": width,
        "tolerance": tol,
        "seed": seed_record(ss),
        "n_bed": int(0 if bed_r is None else bed_r.size),
        **stats,
    }
    pk = Packing(pos, rad, [width, height], species=sp, meta=meta, periodic=(periodic, False))
    ov = pk.overlaps(1e-9)
    if len(ov):
        raise OverlapError(f"deposit produced {len(ov)} overlapping pair(s); worst relative gap {ov[0, 2]:.3e}")
    return pk
