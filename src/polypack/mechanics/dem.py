"""Bonded discrete-element dynamics and the oscillatory shear test of 003_873b69fc71c74cf6.txt.

The seed measures the plateau storage modulus ``G′_p`` of bonded sphere packs with
PFC3D (§2.1, §2.4 of 003_873b69fc71c74cf6.txt): linear contacts, Eq. (1) of
003_873b69fc71c74cf6.txt, incremental shear, Eq. (2) of 003_873b69fc71c74cf6.txt, contact
bonds that carry tension, local non-viscous damping, Eq. (3) of 003_873b69fc71c74cf6.txt
and Eq. (4) of 003_873b69fc71c74cf6.txt, a sample sheared sinusoidally at 1 Hz with an amplitude ramped over ten
cycles to 0.1 % of the box, and ``G′ = |G*| cos δ`` averaged over six shear directions.
:func:`oscillatory_shear` does this on a bonded network (the ``BondNetwork`` contract of
:mod:`polypack.mechanics.network`) with the numba engine of
:mod:`polypack._kernels.dem`.

Boundaries
----------
``"lees-edwards"`` (the reference)
    A deforming periodic cell: the images across the gradient axis move with the flow,
    no walls, no boundary layer.
``"plates"`` (the seed's set-up, Fig. 3 of 003_873b69fc71c74cf6.txt)
    Periodic along the two other axes; below and above the sample three particle layers
    (of mean diameter thickness) copied from the periodic images of the structure; the
    lower ones fixed, the upper ones translated rigidly along the shear axis at
    constant volume.  Bonds that crossed the gradient boundary in the periodic network
    join the sample to the plate copies (each such bond gives one bond to the upper
    plate and one to the lower).

Time step and mass scaling
--------------------------
Physical masses (``r0 = 0.25 µm``, ``ρ = 3690 kg/m³``, ``kn = 100 N/m``) give a critical
step of nanoseconds, i.e. ~10⁸ steps per 1 Hz cycle.  As in PFC the density is scaled:
the time step is ``1 / (f S)`` for ``S`` steps per cycle and the masses are scaled by
the factor that makes it ``safety`` times the critical step ``2 / ω_max`` (``ω_max`` from
the exact highest mode of the linearised network).  Mass scaling changes inertia only;
the drive must stay far below the sample's lowest shear mode.  The reported
``inertial_error`` estimates the relative bias ``(ω H / c_s)² / 3`` of a boundary-force
measurement through a layer of thickness ``H`` with the shear-wave speed
``c_s = sqrt(G′ / ρ_bulk)``; the whole-cell Love-Weber stress is affected less.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .. import _interrupt
from .._util import progress_bar
from ..errors import Interrupted, InvalidInputError
from ._dem_record import (INERTIAL_ERROR_LIMIT, LOSS_TANGENT_LIMIT, STATIC_EXCESS_LIMIT,  # noqa: F401 (public)
                          _VOIGT_INDEX, ShearResult, _assess, _direction_result, _floppy_result, _shear_record,
                          _Trajectory)
from ._dem_relax import RelaxResult, relax  # noqa: F401 (public)
from ._dem_system import _NO_LAYERS, DEFAULTS, _masses, _network, _omega_max, _params, _System

__all__ = [
    "oscillatory_shear",
    "relax",
    "ShearResult",
    "RelaxResult",
    "ShearInterrupted",
    "critical_time_step",
    "static_shear_modulus",
    "SHEAR_DIRECTIONS",
    "DEFAULTS",
]

#: The six (plate-normal axis, shear axis) pairs of §2.4 of 003_873b69fc71c74cf6.txt.
SHEAR_DIRECTIONS = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))

BOUNDARIES = ("lees-edwards", "plates")


class ShearInterrupted(Interrupted):
    """Raised when a run is interrupted (Ctrl-C, honoured at the end of a kernel chunk);
    ``.result`` (also ``.partial``) holds what was measured so far (``result.complete`` is
    False).  A :class:`polypack.errors.Interrupted`, hence a ``KeyboardInterrupt``."""

    def __init__(self, result):
        n = len(result.per_direction) if result is not None else 0
        super().__init__(f"oscillatory shear interrupted ({n} direction(s) measured, the last incomplete)",
                         partial=result)
        self.result = result


def critical_time_step(network, density: float = DEFAULTS["density"]) -> float:
    """Critical time step ``2 / ω_max`` of the central-difference scheme on ``network``.

    ``ω_max`` is the highest angular frequency of the linearised bonded network
    (translations and rotations of solid spheres of ``density``); local damping does
    not change the bound.
    """
    return 2.0 / _omega_max(_network(network), float(density))


def static_shear_modulus(network, normal: int, shear: int, *, details: bool = False):
    """Exact static modulus ``C_agag`` of a stress-free network (the DEM's own reference).

    ``normal`` is the gradient (plate-normal) axis ``g`` and ``shear`` the flow axis
    ``a``; the strain is the simple shear ``e_a e_gᵀ``.  The linearised network with
    rotations (contact law of Eq. (1) of 003_873b69fc71c74cf6.txt and Eq. (2) of
    003_873b69fc71c74cf6.txt) relaxes to its energy minimum, a least-squares problem
    solved by conjugate gradients preconditioned with a sparse factorization (see
    :func:`polypack.mechanics._dem_stiffness.static_shear_modulus`): exact also near
    floppiness, where zero-energy modes and a continuum of soft ones make a shifted
    direct solve fail.  Independent of the dynamics and of
    :func:`polypack.mechanics.elastic_tensor`.

    Parameters
    ----------
    network : BondNetwork
        A stress-free bonded network in a periodic 3D box.
    normal, shear : int
        Plate-normal and shear axes (0, 1, 2; different).
    details : bool, default False
        Also return a dict: ``affine`` (the unrelaxed value), ``residual`` and
        ``iterations`` of the solve, ``zero_modes`` (eigenvalues of the reduced
        stiffness below 1e-9 of its mean diagonal), ``rigid_modes`` (3 per bonded cluster
        wrapping the box, 6 per other cluster or unbonded sphere) and ``floppy_modes``
        (their difference; spheres hanging on a single bond count 3 each).

    Returns
    -------
    float or (float, dict)
        The modulus in stiffness units per length unit (Pa for N/m and metres).

    Raises
    ------
    InfeasibleError
        When the relaxation does not converge (the message gives the floppy-mode count).
    """
    from ._dem_stiffness import static_shear_modulus as _static

    net = _network(network)
    g, a = _check_direction((normal, shear))
    C, info = _static(net.pos, net.radii, np.diag(net.box), net.i, net.j, net.shift, net.kn, net.ks, a, g,
                      count=bool(details))
    return (C, info) if details else C


def _check_direction(d):
    try:
        g, a = (int(d[0]), int(d[1]))
        if len(d) != 2:
            raise TypeError
    except (TypeError, ValueError, IndexError):
        raise InvalidInputError(f"direction {d!r}: give (plate-normal axis, shear axis), e.g. (2, 0)") from None
    if g not in (0, 1, 2) or a not in (0, 1, 2) or g == a:
        raise InvalidInputError(f"direction {d!r}: axes must be two different values of 0, 1, 2")
    return g, a


def _rigidity(network):
    """The exact static tensor of the network's bonds (stress-free), or None when it cannot be had.

    A zero-gap (prestressed) network is linearised about its current geometry with the same
    bonds and stiffnesses: rigidity is a property of the bond topology and geometry.
    """
    from ..errors import InfeasibleError
    from .elastic import elastic_tensor
    from .network import BondNetwork

    if not isinstance(network, BondNetwork):
        return None
    net = network
    if network.reference != "stress-free":
        net = BondNetwork.from_pairs(network.packing, network.i, network.j, network.shift,
                                     normal_stiffness=network.normal_stiffness,
                                     shear_stiffness=network.shear_stiffness, reference="stress-free")
    try:
        return elastic_tensor(net)
    except InfeasibleError:  # an iterative relaxation that did not converge: rigidity unknown
        return None


# ---------------------------------------------------------------- oscillatory shear
def _directions(directions):
    if isinstance(directions, (int, np.integer)) and not isinstance(directions, bool):
        if int(directions) != 6:
            raise InvalidInputError(f"directions={directions!r}: give 6 (all) or a list of (normal, shear) pairs")
        return list(SHEAR_DIRECTIONS)
    try:
        items = list(directions)
    except TypeError:
        raise InvalidInputError(f"directions={directions!r}: give 6 or a list of (normal, shear) pairs") from None
    if not items:
        raise InvalidInputError("directions=[]: give at least one (normal, shear) pair")
    if len(items) == 2 and all(isinstance(x, (int, np.integer)) for x in items):
        items = [tuple(items)]
    return [_check_direction(d) for d in items]


def _positive(name, v, integer=False, minimum=None):
    if integer:
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < (minimum or 1):
            raise InvalidInputError(f"{name}={v!r}: must be an integer >= {minimum or 1}")
        return int(v)
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name}={v!r}: must be a number") from None
    if not math.isfinite(f) or f <= 0:
        raise InvalidInputError(f"{name}={v!r}: must be finite and > 0")
    return f


def check_protocol(directions=6, boundary="lees-edwards", frequency=DEFAULTS["frequency"],
                   amplitude=DEFAULTS["amplitude"], cycles=DEFAULTS["cycles"], ramp_cycles=None, discard_cycles=1,
                   steps_per_cycle=4000, samples_per_cycle=100, safety=0.5, damping=DEFAULTS["damping"],
                   friction=DEFAULTS["friction"], density=DEFAULTS["density"], layers=3, measurement_layers=5,
                   **_ignored):
    """The protocol options of :func:`oscillatory_shear`, checked without a network (a study's
    ``--check`` runs it before any realization); returns them normalised as a dict.

    Raises
    ------
    InvalidInputError
        The first bad value, in one line (e.g. ``amplitude >= 0.1``, ``samples_per_cycle``
        above ``steps_per_cycle``).
    """
    if boundary not in BOUNDARIES:
        raise InvalidInputError(f"boundary={boundary!r}: allowed are {', '.join(BOUNDARIES)}")
    dirs = _directions(directions)
    frequency = _positive("frequency", frequency)
    amplitude = _positive("amplitude", amplitude)
    if amplitude >= 0.1:
        raise InvalidInputError(f"amplitude={amplitude!r}: the small-strain protocol needs a strain below 0.1")
    cycles = _positive("cycles", cycles, integer=True)
    ramp = cycles if ramp_cycles is None else _positive("ramp_cycles", ramp_cycles, integer=True)
    if isinstance(discard_cycles, bool) or not isinstance(discard_cycles, (int, np.integer)) \
            or not 0 <= discard_cycles < cycles:
        raise InvalidInputError(f"discard_cycles={discard_cycles!r}: must be an integer in [0, cycles)")
    steps_per_cycle = _positive("steps_per_cycle", steps_per_cycle, integer=True, minimum=10)
    samples_per_cycle = _positive("samples_per_cycle", samples_per_cycle, integer=True, minimum=8)
    if samples_per_cycle > steps_per_cycle:
        raise InvalidInputError(f"samples_per_cycle={samples_per_cycle}: at most steps_per_cycle={steps_per_cycle}")
    every = max(1, steps_per_cycle // samples_per_cycle)
    steps_per_cycle = every * samples_per_cycle
    safety = _positive("safety", safety)
    if safety > 1.0:
        raise InvalidInputError(f"safety={safety!r}: must be in (0, 1]")
    if not (0.0 <= damping < 1.0):
        raise InvalidInputError(f"damping={damping!r}: local damping needs 0 <= alpha < 1")
    if not (friction >= 0.0):
        raise InvalidInputError(f"friction={friction!r}: must be >= 0")
    density = _positive("density", density)
    layers = _positive("layers", layers, integer=True)
    measurement_layers = _positive("measurement_layers", measurement_layers, integer=True)
    return dict(dirs=dirs, frequency=frequency, amplitude=amplitude, cycles=cycles, ramp=ramp,
                discard_cycles=discard_cycles, steps_per_cycle=steps_per_cycle, samples_per_cycle=samples_per_cycle,
                every=every, safety=safety, damping=damping, friction=friction, density=density, layers=layers,
                measurement_layers=measurement_layers)


def oscillatory_shear(network, frequency: float = DEFAULTS["frequency"], amplitude: float = DEFAULTS["amplitude"],
                      cycles: int = DEFAULTS["cycles"], directions=6, boundary: str = "lees-edwards",
                      seed=None, *, ramp_cycles: int | None = None, discard_cycles: int = 1,
                      steps_per_cycle: int = 4000, samples_per_cycle: int = 100, safety: float = 0.5,
                      mass_scale: float | None = None, damping: float = DEFAULTS["damping"],
                      friction: float = DEFAULTS["friction"], density: float = DEFAULTS["density"],
                      relax_first: bool | None = None, layers: int = 3, measurement_layers: int = 5,
                      trajectory=None, trajectory_every: int | None = None, progress=None,
                      check_rigidity: bool = True) -> ShearResult:
    """Strain-controlled oscillatory shear of a bonded network by DEM (§2.4 of 003_873b69fc71c74cf6.txt).

    The strain ``γ(t) = A_k sin(2π f t)`` has an amplitude ramped linearly over the first
    ``ramp_cycles`` cycles (default: all, as the seed's "linearly increasing deflection
    of the upper plate up to a maximum deflection of 0.1% L_box").  The shear stress is
    fitted by least squares, ``σ = G′ γ + (G″/ω) γ̇ + c0 + c1 t``, over the whole cycles
    after the first ``discard_cycles``; ``|G*| = sqrt(G′² + G″²)`` and the phase angle
    ``δ = atan2(G″, G′)`` (the seed's ``G′ = |G*| cos δ``).  The contact law is
    Eq. (1) of 003_873b69fc71c74cf6.txt and Eq. (2) of 003_873b69fc71c74cf6.txt with PFC contact bonds and the damping of
    Eq. (3) of 003_873b69fc71c74cf6.txt.

    Parameters
    ----------
    network : BondNetwork
        Bonds, per-contact stiffnesses and strengths (:mod:`polypack.mechanics.network`).
    frequency : float
        Drive frequency ``f`` (Hz if time is in s; only ``f`` over the sample's modes
        matters under mass scaling).
    amplitude : float
        Peak shear strain (deflection over the box length); seed 1e-3.
    cycles : int
        Oscillation cycles per direction (seed 10).
    directions : 6 or list of (normal, shear) pairs
        ``6`` runs the seed's six directions; ``[(2, 0)]`` shears along x with the plate
        normal along z (σ_xz, the Voigt C55).
    boundary : {"lees-edwards", "plates"}
    seed : int, optional
        Recorded only: the protocol is deterministic.
    ramp_cycles, discard_cycles : int
        Amplitude ramp length and cycles left out of the fit.
    steps_per_cycle : int
        Time steps per cycle ``S``; the masses are scaled so that ``1 / (f S)`` is
        ``safety`` times the critical step (unless ``mass_scale`` is given).
    samples_per_cycle : int
        Stress samples recorded per cycle.
    safety : float
        Time step over the critical step when the mass scale is chosen (<= 1).
    mass_scale : float, optional
        Fixed density scale factor; the time step ``1 / (f S)`` must then stay below the
        critical step.
    damping : float
        Local damping coefficient α (seed 0.9).
    friction : float
        Friction coefficient of unbonded contacts (seed 0).
    density : float
        Particle density before scaling (seed 3690 kg/m³).
    relax_first : bool, optional
        Relax with :func:`relax` before shearing; default: when the mean unbalanced force
        exceeds the force of a bond stretched by 1e-6 of its length (zero-gap references).
    layers : int
        Plate thickness in mean diameters (``"plates"``; seed 3).
    measurement_layers : int
        Slabs of equal height across the sample in which the stress is measured
        (``"plates"``; the seed's measurement spheres "in different heights"); each
        direction row gets ``measurement_layers`` (G′ per slab) and
        ``storage_modulus_sample`` (G′ of the slab mean); ``storage_modulus`` is from the
        plate force.
    trajectory : path, optional
        Write GSD frames (spheres, plate spheres, contacts with their normal and shear
        forces; see :class:`_Trajectory`) every ``trajectory_every`` steps (default 20 per
        cycle), all directions in one file, atomically at the end.
    progress : bool, optional
        Progress bar (default: when stderr is a terminal).
    check_rigidity : bool, default True
        First compute the exact static tensor of the network's bonds
        (:func:`polypack.mechanics.elastic_tensor`, seconds against the DEM's minutes): a
        floppy network (no wrapping cluster, or a zero shear modulus) is returned at once
        with ``status="floppy"`` and ``storage_modulus = 0`` (the DEM of a floppy network
        measures only inertia and damping: any number, even negative); its static moduli
        also bound the inertial error (``static_storage_modulus``).

    Returns
    -------
    ShearResult
        With ``status`` ``"ok"``, ``"floppy"`` or ``"not_converged"`` (a ``G′ <= 0``,
        ``G″ > G′``, ``inertial_error`` above :data:`INERTIAL_ERROR_LIMIT` or ``G′`` above
        its static limit by more than :data:`STATIC_EXCESS_LIMIT`; the reasons in
        ``problems``).

    Raises
    ------
    InvalidInputError
        No bonds, an unknown boundary or direction, a time step above the critical one,
        or an amplitude whose affine bond load reaches the bond strengths.
    ShearInterrupted
        On Ctrl-C, with the partial result (a ``KeyboardInterrupt``).
    """
    from .._kernels import dem as K

    t_start = time.perf_counter()
    net = _network(network)
    o = check_protocol(directions=directions, boundary=boundary, frequency=frequency, amplitude=amplitude,
                       cycles=cycles, ramp_cycles=ramp_cycles, discard_cycles=discard_cycles,
                       steps_per_cycle=steps_per_cycle, samples_per_cycle=samples_per_cycle, safety=safety,
                       damping=damping, friction=friction, density=density, layers=layers,
                       measurement_layers=measurement_layers)
    bond_length = _check_loads(net, o["dirs"], o["amplitude"], o["density"])

    # rigidity: the exact static tensor of the same bonds
    static = et = None
    if check_rigidity:
        et, static, t_rig = _static_limit(network, o["dirs"])
        if et is not None and (not et.rigid or not static > 0):
            return _floppy_result(et, net, o, boundary, seed, t_start, t_rig)

    # time step and mass scaling
    dt, dt_crit, mass_scale, t_crit = _time_step(net, o, mass_scale)
    timings = {"critical_step": t_crit, "relaxation": 0.0, "relaxation_cpu": 0.0}
    if check_rigidity:
        timings["rigidity"] = t_rig
    rho = o["density"] * mass_scale

    pos_start, relax_rec = _start_positions(network, net, rho, bond_length, relax_first, o["density"], progress,
                                            timings)

    # the drive along each direction
    per_dir, series, n_part, traj, interrupted = _run_directions(K, net, pos_start, rho, o, boundary, dt,
                                                                 trajectory, trajectory_every, progress)
    res = _shear_record(net, o, boundary, seed, per_dir, series, static=static, rigid=None if et is None else True,
                        rho=rho, dt=dt, dt_crit=dt_crit, mass_scale=mass_scale, relax_rec=relax_rec,
                        timings=timings, trajectory=trajectory, traj=traj, n_part=n_part,
                        wall=time.perf_counter() - t_start, interrupted=interrupted)
    if interrupted:
        raise ShearInterrupted(res)
    return res


# ---------------------------------------------------------------- oscillatory shear: the steps
def _check_loads(net, dirs, amplitude, density):
    """Refuse dynamics beyond float64 and an amplitude beyond the bond strengths; returns the bond lengths.

    The strength check loads the bonds with an affine shear of the full amplitude along each
    direction: more than half of them beyond their strength means the amplitude is beyond the
    bond strength (single bonds may break: breakage is part of the model).
    """
    with np.errstate(over="ignore"):  # the squared frequency k/m of the stiffest bond on the lightest sphere
        w2 = max(float(np.max(net.kn)), float(np.max(net.ks))) / float(np.min(_masses(net.radii, density)[0]))
    if not (math.isfinite(w2) and w2 < 1e250):
        raise InvalidInputError(
            f"normal_stiffness up to {float(np.max(net.kn)):.3g}, shear_stiffness up to {float(np.max(net.ks)):.3g} "
            f"over the lightest sphere's mass at density {density:.3g}: k/m = {w2:.3g} is beyond float64 dynamics "
            "(seed 003: kn = 100 N/m, 3690 kg/m³)")
    b_vec = net.pos[net.j] + net.shift * net.box - net.pos[net.i]
    d = np.linalg.norm(b_vec, axis=1)
    n_vec = b_vec / d[:, None]
    pre_tension = np.maximum(-(net.kn * (net.rest - d)), 0.0)
    for (g, a) in dirs:
        un = amplitude * d * n_vec[:, a] * n_vec[:, g]
        ut = amplitude * d * np.sqrt(np.maximum(n_vec[:, g] ** 2 - (n_vec[:, a] * n_vec[:, g]) ** 2, 0.0))
        broken = (net.kn * np.abs(un) + pre_tension >= net.fnb) | (net.ks * ut >= net.fsb)
        if broken.mean() > 0.5:
            c = int(np.argmax(net.ks * ut / net.fsb))
            raise InvalidInputError(
                f"amplitude={amplitude!r}: an affine shear ({g}, {a}) of this size loads {100 * broken.mean():.0f} % "
                f"of the bonds beyond their strength (e.g. bond {c}: {net.ks[c] * ut[c]:.3g} N shear against "
                f"{net.fsb[c]:.3g} N); lower the amplitude")
    return d


def _run_directions(K, net, pos_start, rho, o, boundary, dt, trajectory, trajectory_every, progress):
    """Every direction of ``o["dirs"]`` in turn (:func:`_run_direction`), Ctrl-C deferred to a chunk end.

    Returns ``(rows, series, particle steps, trajectory writer or None, interrupted)``; the
    trajectory file is written (atomically) only when the run was not interrupted.
    """
    total = o["steps_per_cycle"] * o["cycles"] + 1  # one more step records the state at the end of the last cycle
    if trajectory_every is None:
        trajectory_every = max(1, o["steps_per_cycle"] // 20)
    trajectory_every = _positive("trajectory_every", trajectory_every, integer=True)
    import contextlib

    stack = contextlib.ExitStack()
    traj = stack.enter_context(_Trajectory(trajectory)) if trajectory is not None else None
    per_dir, series = [], []
    bar = progress_bar(total=total * len(o["dirs"]), desc=f"shear ({boundary})", progress=progress, unit="step")
    n_part = 0
    interrupted = False
    section = _interrupt.deferred()
    section.__enter__()
    try:
        for (g, a) in o["dirs"]:
            row, ser, n_dir, interrupted = _run_direction(K, net, pos_start, rho, o, boundary, g, a, dt, total,
                                                          traj, trajectory_every, bar)
            n_part += n_dir
            if row is not None:
                per_dir.append(row)
                series.append(ser)
            if interrupted:
                break
    except BaseException as exc:
        stack.__exit__(type(exc), exc, exc.__traceback__)  # the trajectory file is not written
        section.__exit__(type(exc), exc, exc.__traceback__)
        raise
    finally:
        bar.close()
    section.__exit__(None, None, None)
    if interrupted:
        # nothing interrupted is recorded as complete: the trajectory file is not written
        stop = KeyboardInterrupt()
        stack.__exit__(KeyboardInterrupt, stop, None)
    else:
        stack.close()
    return per_dir, series, n_part, traj, interrupted


def _static_limit(network, dirs):
    """``(tensor, static, seconds)``: the exact static tensor of the network's bonds (None when it
    cannot be had) and the mean of its C44/C55/C66 over ``dirs`` (the static limit of ``G′``)."""
    t_rig = time.perf_counter()
    et = _rigidity(network)
    t_rig = time.perf_counter() - t_rig
    static = None
    if et is not None:
        voigt = [_VOIGT_INDEX[frozenset((a, g))] for (g, a) in dirs]
        static = float(np.mean([et.stiffness[k, k] for k in voigt]))
    return et, static, t_rig


def _time_step(net, o, mass_scale):
    """``(dt, dt_crit, mass_scale, seconds)``: the step ``1 / (f S)``, the critical step at the mass
    scale (chosen so that ``dt`` is ``safety`` times it unless given) and the time its estimate took."""
    t_crit0 = time.perf_counter()
    omega_max1 = _omega_max(net, o["density"])  # at the physical density
    seconds = time.perf_counter() - t_crit0
    dt_crit1 = 2.0 / omega_max1
    dt = 1.0 / (o["frequency"] * o["steps_per_cycle"])
    if mass_scale is None:
        mass_scale = (dt / (o["safety"] * dt_crit1)) ** 2
    else:
        mass_scale = _positive("mass_scale", mass_scale)
    dt_crit = dt_crit1 * math.sqrt(mass_scale)
    if dt > dt_crit:
        raise InvalidInputError(
            f"time step {dt:.3g} (1/(frequency*steps_per_cycle)) is above the critical step {dt_crit:.3g} at "
            f"mass_scale={mass_scale:.3g}; raise steps_per_cycle or mass_scale")
    return dt, dt_crit, mass_scale, seconds


def _start_positions(network, net, rho, d, relax_first, density, progress, timings):
    """``(positions, relaxation record or None)`` the shear starts from: the network's own, or
    relaxed by :func:`relax` (see ``relax_first`` of :func:`oscillatory_shear`; ``d`` are the
    bond lengths); the relaxation's wall and CPU seconds go into ``timings``."""
    relax_rec = None
    pos_start = net.pos.copy()
    if relax_first is None or relax_first:
        probe = _System(net, net.pos.copy(), rho, "lees-edwards", 2, 0, 0.0)
        acc_f = np.zeros((probe.pos.shape[0], 3))
        from .._kernels.contacts import N_ACC, contact_forces

        acc = np.zeros(N_ACC)
        contact_forces(probe.pos, probe.vel, probe.omg, probe.radii, probe.h0, np.zeros((3, 3)), 0.0,
                       *probe.contacts.args(), 0.0, acc_f, np.zeros_like(acc_f), acc)
        fu = float(np.mean(np.linalg.norm(acc_f, axis=1)))
        # force scale: a bond stretched by 1e-6 of its length (round-off of a stress-free
        # network is ~1e-16 of it)
        scale = 1e-6 * float(np.median(net.kn)) * float(np.mean(d))
        need = bool(relax_first) if relax_first is not None else fu > scale
        if need:
            t_rel0, c_rel0 = time.perf_counter(), time.process_time()
            rr = relax(network, density=density, progress=progress)
            timings["relaxation"] = time.perf_counter() - t_rel0
            timings["relaxation_cpu"] = time.process_time() - c_rel0
            pos_start = rr.positions
            relax_rec = rr.to_dict()
    return pos_start, relax_rec


def _direction_system(K, net, pos_start, rho, o, boundary, g, a, dt):
    """``(system, kernel parameters, seconds)`` of one direction: the spheres (with plate copies),
    their contacts (built in ``seconds``) and the affine flow of the first cycle as the start."""
    omega = 2.0 * np.pi * o["frequency"]
    volume = float(np.prod(net.box))
    sys_ = _System(net, pos_start.copy(), rho, boundary, g, a, o["friction"], o["layers"])
    t_rb = time.perf_counter()
    sys_.rebuild(0.0, g, a, boundary)
    t_rebuild = time.perf_counter() - t_rb
    # start on the affine flow of the first cycle (no jolt at t = 0)
    a1 = o["amplitude"] * min(1.0, 1.0 / o["ramp"])
    gdot0 = a1 * omega
    free = sys_.kind == K.KIND_FREE
    sys_.vel[free, a] = gdot0 * sys_.pos[free, g]
    c3 = 3 - a - g
    sgn = 1.0 if (g - a) % 3 == 2 else -1.0
    sys_.omg[free, c3] = 0.5 * gdot0 * sgn
    mode = K.MODE_LEES_EDWARDS if boundary == "lees-edwards" else K.MODE_PLATES
    p = _params(K, dt, omega, o["amplitude"], float(o["ramp"]), o["damping"], o["friction"], volume,
                float(net.box[g]), a, g, mode, o["every"], sys_.reach)
    return sys_, p, t_rebuild


def _run_direction(K, net, pos_start, rho, o, boundary, g, a, dt, total, traj, trajectory_every, bar):
    """Shear along one (plate-normal ``g``, flow ``a``) direction for ``total`` steps.

    Returns ``(row, series, particle steps, interrupted)``: the :func:`_direction_result` of the
    samples (None when fewer than two were recorded) with the timings of the direction, the
    particle steps run and whether Ctrl-C stopped it (at the end of a kernel chunk).
    """
    t_dir0, c_dir0 = time.perf_counter(), time.process_time()
    t_kernel = 0.0
    n_rebuild = 1
    steps_per_cycle, cycles, every = o["steps_per_cycle"], o["cycles"], o["every"]
    sys_, p, t_rebuild = _direction_system(K, net, pos_start, rho, o, boundary, g, a, dt)
    n_free = int(np.sum(sys_.kind == K.KIND_FREE))
    samples = np.zeros((cycles * o["samples_per_cycle"] + 1, K.N_S))
    if boundary == "plates":
        # measurement slabs: `measurement_layers` equal slabs across the sample [0, L)
        edges_all = np.linspace(0.0, float(net.box[g]), o["measurement_layers"] + 1)
    else:
        edges_all = _NO_LAYERS
    layer_samples = np.zeros((samples.shape[0], max(1, edges_all.shape[0] - 1)))
    ns = 0
    chunk = max(every, (2_000_000 // max(1, n_free)) // every * every)
    chunk = min(chunk, steps_per_cycle)
    if traj is not None:
        chunk = trajectory_every
        traj.write(sys_, 0.0, 0.0, g, a, boundary)
    done = 0
    n_part = 0
    interrupted = False
    t0 = time.perf_counter()
    try:
        while done < total:
            nstep = min(chunk, total - done)
            t_k = time.perf_counter()
            status, steps, ns = K.run(nstep, sys_.pos, sys_.vel, sys_.omg, sys_.radii, sys_.mass,
                                      sys_.inertia, sys_.kind, sys_.pos0, sys_.h0, *sys_.contacts.args(),
                                      p, sys_.st, samples, ns, sys_.xbuild, edges_all, layer_samples)
            t_kernel += time.perf_counter() - t_k
            done += steps
            n_part += steps * n_free
            bar.update(steps)
            if status == K.STATUS_REBUILD:
                gam = float(K.strain_at(int(sys_.st[K.ST_STEP]), p))
                t_rb = time.perf_counter()
                sys_.rebuild(gam, g, a, boundary)
                t_rebuild += time.perf_counter() - t_rb
                n_rebuild += 1
            elif traj is not None and done % trajectory_every == 0:
                stp = int(sys_.st[K.ST_STEP])
                traj.write(sys_, float(K.strain_at(stp, p)), stp * dt, g, a, boundary)
            el = time.perf_counter() - t0
            if el > 0:
                bar.set_postfix(cycle=f"{done / steps_per_cycle:.1f}/{cycles}", steps_s=f"{done / el:.3g}")
            if _interrupt.consume():  # Ctrl-C: stop at this safe point (end of a chunk)
                raise KeyboardInterrupt
    except KeyboardInterrupt:
        interrupted = True
    row, ser = _direction_result(K, samples[:ns], g, a, 2.0 * np.pi * o["frequency"], o["amplitude"], o["ramp"],
                                 o["discard_cycles"], o["samples_per_cycle"], boundary, sys_, o["frequency"],
                                 complete=not interrupted, layers=layer_samples[:ns] if boundary == "plates" else None,
                                 edges=edges_all)
    if row is not None:
        row.update(seconds=time.perf_counter() - t_dir0, cpu_seconds=time.process_time() - c_dir0,
                   kernel_seconds=t_kernel, rebuild_seconds=t_rebuild, rebuilds=n_rebuild)
    return row, ser, n_part, interrupted
