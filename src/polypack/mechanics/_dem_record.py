"""The record of :func:`polypack.mechanics.dem.oscillatory_shear`: the per-direction fit and energy
balance, the assessment of a measurement and :class:`ShearResult`, and the GSD trajectory."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

_VOIGT_INDEX = {frozenset((1, 2)): 3, frozenset((0, 2)): 4, frozenset((0, 1)): 5}
_VOIGT_NAME = {3: "C44", 4: "C55", 5: "C66"}

#: Largest ``inertial_error`` of a converged (quasi-static) measurement. The estimate
#: ``(ω H / c_s)² / 3`` is the relative bias of a force measured through the whole box;
#: the seed's protocol on a converged N = 8000 network gives 0.13 (docs/dem.md), a drive the
#: sample cannot follow gives 4-10 and more (with ``G″ > G′``).
INERTIAL_ERROR_LIMIT = 1.0
#: Largest loss tangent ``G″ / G′`` of an elastic (solid) response: beyond it the stress
#: follows the strain rate more than the strain (phase above 45°), a viscous or
#: unconverged response, not a storage modulus.
LOSS_TANGENT_LIMIT = 1.0
#: Largest excess of the measured ``G′`` over its static limit (the exact tensor's
#: C44/C55/C66), relative: inertia stiffens the response of a sample driven too fast
#: (a near-floppy Z = 4.1 network at 1000 steps per cycle: +82 %); converged runs are
#: within a few % (Lees-Edwards ~1 %, the plates' boundary layer up to +5 % at N = 300,
#: docs/dem.md); bond breakage only lowers ``G′``.
STATIC_EXCESS_LIMIT = 0.25


def _fit(t, gamma, stress, omega, amp_of_t):
    """Least squares ``σ = G′ γ + (G″/ω) γ̇ + c0 + c1 t``; returns ``(G′, G″)``."""
    gdot = amp_of_t * omega * np.cos(omega * t)
    X = np.column_stack([gamma, gdot / omega, np.ones_like(t), t - t.mean()])
    coef, *_ = np.linalg.lstsq(X, stress, rcond=None)
    return float(coef[0]), float(coef[1])


@dataclass
class ShearResult:
    """Result of :func:`oscillatory_shear`.

    Attributes
    ----------
    storage_modulus, loss_modulus : float
        Means of ``G′`` and ``G″`` over the directions run (stress units of the network).
    storage_modulus_sd, loss_modulus_sd : float
        Standard deviations over the directions (ddof=1; 0 for one direction), the
        seed Table 2 error bars.
    per_direction : list of dict
        One row per (plate-normal, shear) pair: ``normal``, ``shear``, ``voigt``
        (C44/C55/C66), ``storage_modulus``, ``loss_modulus``, ``complex_modulus``,
        ``phase_angle`` (rad), ``cycle_storage_modulus`` (fit per cycle),
        ``cycle_peak_modulus`` (the seed's peak stress over peak strain per cycle), ``breakages``,
        ``energy`` (per-cycle balance) and ``complete``.
    series : list of dict
        Per direction: ``time``, ``strain``, ``stress`` (the measured shear stress),
        ``stress_love_weber``, ``stored_energy``, ``kinetic_energy``, ``work``,
        ``damping``, ``slip``, ``breakages`` arrays.
    time_step, critical_time_step, mass_scale, steps_per_cycle, inertial_error
        Integration settings and the estimated inertial bias (see module docstring).
    relaxation : dict or None
        The :func:`relax` record when the structure was relaxed first.
    complete : bool
        False when the run was interrupted.
    status : str
        ``"ok"``; ``"floppy"`` (the static tensor of the network has a zero shear modulus:
        no DEM is run, ``storage_modulus`` is 0 and the loss terms are None);
        ``"not_converged"`` (the response is not a converged elastic one: see
        ``problems``); ``"interrupted"``.
    problems : list of str
        Why the status is not ``"ok"``: a ``G′ <= 0``, a loss tangent ``G″/G′`` above
        :data:`LOSS_TANGENT_LIMIT`, an ``inertial_error`` above
        :data:`INERTIAL_ERROR_LIMIT`, a mean ``G′`` above its static limit by more than
        :data:`STATIC_EXCESS_LIMIT`.
    rigid : bool or None
        Whether the static tensor of the network (:func:`polypack.mechanics.elastic_tensor`
        of the stress-free network with the same bonds) is rigid; None when not checked.
    static_storage_modulus : float or None
        The static limit of ``storage_modulus``: the mean over the directions run of the
        exact tensor's C44/C55/C66 (None when not checked). ``inertial_error`` uses the
        smaller of it and the measured ``G′`` (a near-floppy network's DEM overestimates
        ``G′`` when the drive is too fast for it).
    timings : dict
        Where the time went (wall seconds, ``time.perf_counter``; ``*_cpu`` entries
        ``time.process_time``): ``critical_step`` (the highest-mode estimate),
        ``relaxation`` (0 when not relaxed) and ``directions`` (the sum of the per-direction
        ``seconds``); each ``per_direction`` row also has ``seconds``, ``cpu_seconds``,
        ``kernel_seconds`` (inside the numba time-stepping kernel), ``rebuild_seconds``
        and ``rebuilds`` (contact-list rebuilds).
    """

    storage_modulus: float
    loss_modulus: float
    storage_modulus_sd: float
    loss_modulus_sd: float
    per_direction: list
    series: list
    boundary: str
    frequency: float
    amplitude: float
    cycles: int
    ramp_cycles: int
    discard_cycles: int
    time_step: float
    critical_time_step: float
    mass_scale: float
    density: float
    steps_per_cycle: int
    inertial_error: float
    wall_time: float
    particle_steps_per_second: float
    relaxation: dict | None = None
    complete: bool = True
    parameters: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    status: str = "ok"
    problems: list = field(default_factory=list)
    rigid: bool | None = None
    static_storage_modulus: float | None = None
    floppy_reason: str | None = None

    @property
    def converged(self) -> bool:
        """True when ``status == "ok"``: a complete, rigid, elastic and quasi-static measurement."""
        return self.status == "ok"

    @property
    def complex_modulus(self):
        if self.status == "floppy":
            return 0.0
        return float(np.mean([r["complex_modulus"] for r in self.per_direction])) if self.per_direction else None

    @property
    def phase_angle(self):
        return float(np.mean([r["phase_angle"] for r in self.per_direction])) if self.per_direction else None

    def to_dict(self, series: bool = False) -> dict:
        keys = ("storage_modulus", "loss_modulus", "storage_modulus_sd", "loss_modulus_sd", "boundary",
                "frequency", "amplitude", "cycles", "ramp_cycles", "discard_cycles", "time_step",
                "critical_time_step", "mass_scale", "density", "steps_per_cycle", "inertial_error", "wall_time",
                "particle_steps_per_second", "complete", "parameters", "timings", "status", "problems", "rigid",
                "static_storage_modulus", "floppy_reason")
        out = {k: _finite_or_none(getattr(self, k)) for k in keys}
        out["converged"] = self.converged
        out["complex_modulus"] = self.complex_modulus
        out["phase_angle"] = self.phase_angle
        out["per_direction"] = self.per_direction
        out["relaxation"] = self.relaxation
        if series:
            out["series"] = [{k: np.asarray(v).tolist() for k, v in s.items()} for s in self.series]
        return out

    def plot(self, ax=None, direction: int = 0):
        """Stress (left) and strain (right) against the oscillation cycle, like Fig. 4 of
        003_873b69fc71c74cf6.txt; the fitted elastic response ``G′ γ`` beside the measurement."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(7, 4))
        s = self.series[direction]
        row = self.per_direction[direction]
        cyc = np.asarray(s["time"]) * self.frequency
        gamma = np.asarray(s["strain"])
        ax.plot(cyc, s["stress"], "s", ms=3, mfc="none", color="C0", label=f"stress σ{row['shear']+1}{row['normal']+1}")
        ax.plot(cyc, row["storage_modulus"] * gamma, "-", lw=0.8, color="k", label="fit G′ γ")
        ax.set_xlabel("oscillation cycle")
        ax.set_ylabel("shear stress (Pa if lengths in m)")
        ax2 = ax.twinx()
        ax2.plot(cyc, 100 * gamma, ".", ms=2, color="C3", label="strain γ")
        ax2.set_ylabel("shear strain γ in %")
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, loc="upper left", fontsize=8)
        ax.set_title(f"{self.boundary}: G′ = {row['storage_modulus']:.4g}, δ = {row['phase_angle']:.2e} rad")
        return ax


def _finite_or_none(v):
    """NaN and infinities never reach JSON: None instead."""
    if isinstance(v, (float, np.floating)):
        return float(v) if math.isfinite(v) else None
    return v


def _assess(per_dir, gmean, static, inertial, complete):
    """``(status, problems)`` of a measured shear result (see :class:`ShearResult`)."""
    if not complete:
        return "interrupted", ["interrupted"]
    problems = []
    for r in per_dir:
        gp, gpp = r["storage_modulus"], r["loss_modulus"]
        tag = f"direction ({r['normal']}, {r['shear']})"
        if not gp > 0:
            problems.append(f"{tag}: G' = {gp:.4g} <= 0 (not an elastic response)")
        elif gpp > LOSS_TANGENT_LIMIT * gp:
            problems.append(f"{tag}: G''/G' = {gpp / gp:.3g} > {LOSS_TANGENT_LIMIT:g} (phase "
                            f"{math.degrees(r['phase_angle']):.0f} deg: not an elastic response)")
    if static and gmean > (1.0 + STATIC_EXCESS_LIMIT) * static:
        problems.append(f"G' = {gmean:.4g} exceeds its static limit {static:.4g} by {100 * (gmean / static - 1):.0f} % "
                        f"(> {100 * STATIC_EXCESS_LIMIT:.0f} %: inertia); raise steps_per_cycle or lower the frequency")
    if inertial is None or not math.isfinite(inertial):
        problems.append("inertial error undefined (G' <= 0)")
    elif inertial > INERTIAL_ERROR_LIMIT:
        problems.append(f"inertial error {inertial:.4g} > {INERTIAL_ERROR_LIMIT:g}"
                        + (f" (static modulus {static:.4g})" if static is not None else "")
                        + ": the sample cannot follow the drive; raise steps_per_cycle or lower the frequency")
    return ("not_converged" if problems else "ok"), problems


class _Trajectory:
    """GSD frames of the shear run: spheres, bonds and bond forces (HOOMD schema).

    ``configuration/box`` carries the Lees-Edwards tilt when HOOMD can express it
    (``xy``, ``xz``, ``yz``: flow axis before the gradient axis); positions are folded into
    the cell and centred.  Per frame ``bonds/group`` (the contacts), ``log/bonds/normal_force``
    (positive in compression), ``log/bonds/shear_force`` (on ``j``), ``log/bonds/state``
    (0 unbonded contact, 1 bond, 2 broken bond) and ``log/polypack/{time, strain,
    direction}``.
    """

    def __init__(self, path):
        import gsd.hoomd

        self._gsd = gsd.hoomd
        self.path = path
        self._ctx = None
        self._fh = None
        self.frames = 0

    def __enter__(self):
        from .._util import atomic_path

        self._ctx = atomic_path(self.path)
        tmp = self._ctx.__enter__()
        self._fh = self._gsd.open(str(tmp), "w")
        return self

    def __exit__(self, et, ev, tb):
        self._fh.close()
        return self._ctx.__exit__(et, ev, tb)

    def write(self, sys_, gamma, time_, g, a, boundary):
        box = sys_.box
        cell = sys_.h0.copy()
        if boundary == "lees-edwards":
            cell[a, g] += gamma * box[g]
        s = sys_.pos @ np.linalg.inv(cell).T
        periodic = np.array(sys_.periodic_axes)
        s[:, periodic] -= np.floor(s[:, periodic])
        pos = (s - 0.5) @ cell.T
        if not periodic[g]:  # plates: keep the sample and its plates in one frame
            pos[:, g] = sys_.pos[:, g] - 0.5 * box[g]
        f = self._gsd.Frame()
        tilt = np.zeros(3)
        if boundary == "lees-edwards" and a < g:
            tilt[{(0, 1): 0, (0, 2): 1, (1, 2): 2}[(a, g)]] = gamma  # HOOMD tilt factor: h[a, g] / L_g
        f.configuration.box = np.concatenate([box, tilt])
        n = pos.shape[0]
        f.particles.N = n
        f.particles.types = ["sample", "fixed", "driven"]
        f.particles.typeid = sys_.kind.astype(np.uint32)
        f.particles.position = pos
        f.particles.diameter = 2.0 * sys_.radii
        c = sys_.contacts
        f.bonds.N = c.ci.shape[0]
        f.bonds.types = ["contact"]
        f.bonds.typeid = np.zeros(c.ci.shape[0], np.uint32)
        f.bonds.group = np.column_stack([c.ci, c.cj]).astype(np.uint32)
        f.log["bonds/normal_force"] = c.cfn.copy()
        f.log["bonds/shear_force"] = c.cfs.copy()
        f.log["bonds/state"] = c.cstate.astype(np.int32)
        f.log["polypack/time"] = np.array([time_])
        f.log["polypack/strain"] = np.array([gamma])
        f.log["polypack/direction"] = np.array([g, a], dtype=np.int64)
        self._fh.append(f)
        self.frames += 1


def _direction_result(K, s, g, a, omega, amplitude, ramp, discard, spc, boundary, sys_, frequency, complete,
                      layers=None, edges=None):
    """Fit and energy balance of one direction from its sample rows."""
    if s.shape[0] < 2:
        return None, None
    t = s[:, K.S_TIME]
    gamma = s[:, K.S_STRAIN]
    vo = K.S_STRESS + {frozenset((1, 2)): 3, frozenset((0, 2)): 4, frozenset((0, 1)): 5}[frozenset((a, g))]
    lw = s[:, vo]
    stress = s[:, K.S_PLATE_STRESS] if boundary == "plates" else lw
    period = 1.0 / frequency
    cyc = np.floor(t / period + 1e-9).astype(np.int64)
    amp = amplitude * np.minimum(1.0, (cyc + 1.0) / ramp)
    n_full = int((s.shape[0] - 1) // spc)  # complete cycles recorded (a row at each cycle's end)
    sel = (cyc >= discard) & (cyc < n_full)
    if not np.any(sel):
        sel = cyc < max(n_full, 1)
    gp, gpp = _fit(t[sel], gamma[sel], stress[sel], omega, amp[sel])
    per_cycle = []
    peak = []  # the seed's |G*| of each cycle: peak stress over peak strain (offset removed)
    for k in range(n_full):
        m = cyc == k
        if m.sum() >= 8:
            per_cycle.append(_fit(t[m], gamma[m], stress[m], omega, amp[m])[0])
            sm = stress[m] - np.mean(stress[m])
            peak.append(float(np.max(np.abs(sm)) / np.max(np.abs(gamma[m]))))
    # energy balance per complete cycle (rows at the cycle starts; last row may be missing)
    energy = []
    for k in range(n_full):
        r0 = k * spc
        r1 = (k + 1) * spc
        d = lambda col: float(s[r1, col] - s[r0, col])  # noqa: E731
        w, dmp, slp = d(K.S_WORK), d(K.S_DAMP), d(K.S_SLIP)
        du, dk = d(K.S_STORED), d(K.S_KINETIC)
        peak = float(np.max(s[r0:r1 + 1, K.S_STORED]))
        energy.append({"cycle": k, "work": w, "damping": dmp, "slip": slp, "stored_change": du,
                       "kinetic_change": dk, "residual": w - dmp - slp - du - dk, "peak_stored": peak})
    sys_n = sys_.contacts
    broken_mask = sys_n.cstate[: sys_n.n_bonds] == 2
    broken = int(np.unique(sys_.bond_source[broken_mask]).size)  # network bonds (a plate bond counts once)
    row = {
        "normal": g, "shear": a, "voigt": _VOIGT_NAME[_VOIGT_INDEX[frozenset((a, g))]],
        "storage_modulus": gp, "loss_modulus": gpp, "complex_modulus": math.hypot(gp, gpp),
        "phase_angle": math.atan2(gpp, gp), "cycle_storage_modulus": per_cycle,
        "cycle_peak_modulus": peak, "breakages": broken,
        "breakages_tension": int(sys_.st[K.ST_BREAK_TENSION]), "breakages_shear": int(sys_.st[K.ST_BREAK_SHEAR]),
        "energy": energy, "complete": bool(complete), "steps": int(sys_.st[K.ST_STEP]),
    }
    if layers is not None:
        # plates: the sample's own stress is the area-weighted mean of its measurement slabs
        # (contacts to the plates count with the part of their branch inside the sample)
        widths = np.diff(edges)
        lw = layers @ widths / widths.sum()
        row["measurement_layers"] = [
            {"bottom": float(edges[k]), "top": float(edges[k + 1]),
             "storage_modulus": _fit(t[sel], gamma[sel], layers[sel, k], omega, amp[sel])[0]}
            for k in range(layers.shape[1])]
        row["storage_modulus_sample"] = _fit(t[sel], gamma[sel], lw[sel], omega, amp[sel])[0]
    ser = {"time": t, "strain": gamma, "stress": stress,
           # Lees-Edwards: the whole-cell Love-Weber stress (the measured one); plates: the
           # mean over the measurement slabs of the sample
           "stress_love_weber": lw,
           "stored_energy": s[:, K.S_STORED], "kinetic_energy": s[:, K.S_KINETIC], "work": s[:, K.S_WORK],
           "damping": s[:, K.S_DAMP], "slip": s[:, K.S_SLIP], "breakages": s[:, K.S_BREAKS]}
    return row, ser


def _floppy_result(et, net, o, boundary, seed, t_start, t_rig):
    """The :class:`ShearResult` of a floppy network (no DEM is run): ``G′ = 0``, ``status="floppy"``."""
    reason = et.floppy_reason or "the static shear moduli of the directions run are zero"
    return ShearResult(
        storage_modulus=0.0, loss_modulus=None, storage_modulus_sd=0.0, loss_modulus_sd=None,
        per_direction=[], series=[], boundary=boundary, frequency=o["frequency"], amplitude=o["amplitude"],
        cycles=o["cycles"], ramp_cycles=o["ramp"], discard_cycles=int(o["discard_cycles"]),
        time_step=1.0 / (o["frequency"] * o["steps_per_cycle"]), critical_time_step=None, mass_scale=None,
        density=o["density"], steps_per_cycle=o["steps_per_cycle"], inertial_error=None,
        wall_time=time.perf_counter() - t_start, particle_steps_per_second=None, complete=True,
        timings={"rigidity": t_rig}, status="floppy", problems=[f"floppy: {reason}"], rigid=False,
        static_storage_modulus=0.0, floppy_reason=reason,
        parameters={"damping": o["damping"], "friction": o["friction"], "safety": o["safety"], "layers": o["layers"],
                    "trajectory": None, "trajectory_frames": 0, "samples_per_cycle": o["samples_per_cycle"],
                    "seed": seed, "n_bonds": int(net.i.shape[0]), "n_particles": int(net.pos.shape[0]),
                    "directions": [list(d) for d in o["dirs"]]})


def _shear_record(net, o, boundary, seed, per_dir, series, *, static, rigid, rho, dt, dt_crit, mass_scale, relax_rec,
                  timings, trajectory, traj, n_part, wall, interrupted):
    """The :class:`ShearResult` of a run: means and spreads over the directions, the inertial
    error (module docstring of :mod:`polypack.mechanics.dem`) and the assessment."""
    from ._dem_system import _masses

    omega = 2.0 * np.pi * o["frequency"]
    volume = float(np.prod(net.box))
    gp = np.array([r["storage_modulus"] for r in per_dir])
    gpp = np.array([r["loss_modulus"] for r in per_dir])
    sd = lambda x: float(np.std(x, ddof=1)) if x.size > 1 else 0.0  # noqa: E731
    # inertial error estimate with the measured modulus
    gmean = float(np.mean(gp)) if gp.size else math.nan
    rho_bulk = float(np.sum(_masses(net.radii, rho)[0]) / volume)
    if gp.size and gmean > 0:
        # the shear-wave speed of the sample: from its static modulus when known (a DEM
        # that cannot follow the drive overestimates G' and so would hide its own error)
        c_s = math.sqrt((min(gmean, static) if static else gmean) / rho_bulk)
        h = float(np.max(net.box))
        inertial = (omega * h / c_s) ** 2 / 3.0
    else:
        inertial = math.nan
    status, problems = _assess(per_dir, gmean, static, inertial, not interrupted)
    return ShearResult(
        storage_modulus=gmean, loss_modulus=float(np.mean(gpp)) if gpp.size else math.nan,
        storage_modulus_sd=sd(gp), loss_modulus_sd=sd(gpp), per_direction=per_dir, series=series,
        boundary=boundary, frequency=o["frequency"], amplitude=o["amplitude"], cycles=o["cycles"],
        ramp_cycles=o["ramp"], discard_cycles=int(o["discard_cycles"]), time_step=dt, critical_time_step=dt_crit,
        mass_scale=mass_scale, density=rho, steps_per_cycle=o["steps_per_cycle"], inertial_error=inertial,
        wall_time=wall, particle_steps_per_second=n_part / wall if wall > 0 else math.nan, relaxation=relax_rec,
        complete=not interrupted, status=status, problems=problems, rigid=rigid, static_storage_modulus=static,
        timings={**timings, "directions": float(sum(r["seconds"] for r in per_dir))},
        parameters={"damping": o["damping"], "friction": o["friction"], "safety": o["safety"], "layers": o["layers"],
                    "trajectory": str(trajectory) if trajectory is not None and not interrupted else None,
                    "trajectory_frames": traj.frames if traj is not None else 0,
                    "samples_per_cycle": o["samples_per_cycle"], "seed": seed, "n_bonds": int(net.i.shape[0]),
                    "n_particles": int(net.pos.shape[0]), "directions": [list(d) for d in o["dirs"]]},
    )
