"""Registry declarations of the packing protocols (``[protocol] kind = ...``).

``crm``   CRM growth (:func:`polypack.pack`, §3.1 of 000_2cedc098acbd866b.txt), then
          ``global_shakes`` global shakes with :func:`polypack.shake` if M > 0.
``scrm``  SCRM: CRM growth interleaved with shaking (:func:`polypack.scrm`, §3.2 of
          000_2cedc098acbd866b.txt), then ``global_shakes`` global shakes.
``brownian``  a colloidal gel by Brownian dynamics with DLVO forces (:func:`polypack.brownian`,
          §2.2 of 003_873b69fc71c74cf6.txt); run functions in :mod:`polypack.generate.protocols`.
``deposit``  sequential deposition of disks (2D) or spheres (3D) (:func:`polypack.deposit`, §2.4 of
          001_ad5bae0acea940c4.txt).

An option a protocol does not use is an error in a study (``protocol.max_seconds: not
used with protocol.kind = "scrm"``), never silently dropped.
"""

from __future__ import annotations

from dataclasses import dataclass

from .. import _validate as v
from ..registry import Outputs, option, register

def _shake_fields():
    """The options of the global shakes, shared by ``crm`` and ``scrm`` (``api``: the keyword of
    :func:`polypack.shake` when it differs from the field name)."""
    return dict(
        shake_radius=option(None, v.number_or_list(v.positive),
                            "shake-window radius R_sh in units of the sphere radius (one per species or one for all)",
                            unit="a", unset="0.02 with shake_method 'paper' (the seed's optimum), else 0.05"),
        max_trials=option(None, v.number_or_list(v.int_min(1)),
                          "trial moves per sphere and global shake N_sh (one per species or one for all)",
                          unset="150 with shake_method 'paper' (the seed's N_sh), else 1"),
        shake_method=option(None, v.choice("paper", "collision", "metropolis"), "shaking variant", api="method",
                            unset="'paper'"),
        adaptive=option(None, v.boolean, "adapt R_sh towards a target acceptance", unset="false"),
    )


#: ``[protocol]`` key -> :func:`polypack.shake` keyword, from the field declarations.
SHAKE_KEYWORDS = {k: (f.metadata["api"] or k) for k, f in _shake_fields().items()}


@dataclass(frozen=True)
class CRMOptions:
    volume_fraction: float = option(0.6, v.volume_fraction, "target volume fraction c in (0, 1), or \"jammed\"")
    growth_rate: float = option(None, v.positive, "radius growth rate of the Lubachevsky–Stillinger CRM",
                                unset="0.02 (mean diameter grows 2 % while a sphere at thermal speed moves one)")
    max_seconds: float = option(None, v.positive, "wall-clock budget of the growth, s", unset="no wall-clock limit")
    global_shakes: int = option(0, v.int_min(0), "M global shakes of the finished pack (0: none)")
    shake_radius: float = _shake_fields()["shake_radius"]
    max_trials: int = _shake_fields()["max_trials"]
    shake_method: str = _shake_fields()["shake_method"]
    adaptive: bool = _shake_fields()["adaptive"]


@dataclass(frozen=True)
class SCRMOptions:
    volume_fraction: float = option(0.6, v.volume_fraction, "target volume fraction c in (0, 1)")
    growth_rate: float = option(None, v.positive, "radius growth rate of the CRM stages", unset="0.02, as crm")
    global_shakes: int = option(60, v.int_min(0), "M global shakes at the target")
    shake_radius: float = _shake_fields()["shake_radius"]
    max_trials: int = _shake_fields()["max_trials"]
    shake_method: str = _shake_fields()["shake_method"]
    adaptive: bool = _shake_fields()["adaptive"]
    schedule: list = option(None, v.schedule, "increasing volume fractions of the growth stages (target appended)",
                            unset="growth_steps fractions evenly spaced from start_fraction to the target")
    growth_steps: int = option(10, v.int_min(1), "number of growth stages from start_fraction", fill=False)
    start_fraction: float = option(None, v.fraction_open, "first stage fraction", unset="0.8 c")
    stage_shakes: int = option(1, v.int_min(0), "global shakes after each growth stage", fill=False)


def shake_options(pr: dict) -> dict:
    """Keyword arguments of :func:`polypack.shake` from a resolved protocol table."""
    return {arg: pr[key] for key, arg in SHAKE_KEYWORDS.items() if key in pr}


def run_crm(sizes, pr: dict, seed, monitor=None):
    """CRM growth then M global shakes (the seeds of both stages spawned from ``seed``).

    ``monitor`` (a callable ``monitor(packing) -> dict``, see :func:`polypack.shake`) is
    given by the runner: the contact-value monitor of :mod:`polypack.analysis`.
    """
    from .lubachevsky import pack
    from .shake import shake

    s_pack, s_shake = seed.spawn(2)
    grow = {k: pr[k] for k in ("growth_rate", "max_seconds") if k in pr}
    m = int(pr.get("global_shakes", 0))
    pk = pack(sizes, pr["volume_fraction"], seed=s_pack, progress=False, **grow)
    if m > 0:
        pk = shake(pk, global_shakes=m, seed=s_shake, progress=False, monitor=monitor, **shake_options(pr))
    return pk


def run_scrm(sizes, pr: dict, seed, monitor=None):
    """SCRM to the target, then M global shakes (``monitor`` as for :func:`run_crm`)."""
    from .shake import scrm

    s_pack, _ = seed.spawn(2)
    return scrm(sizes, seed=s_pack, progress=False, monitor=monitor, **scrm_kwargs(pr))


def scrm_kwargs(pr: dict) -> dict:
    """Keyword arguments of :func:`polypack.scrm` from a resolved ``scrm`` table (also ``polypack scrm``):
    the target is appended to a ``schedule`` that stops below it."""
    kw = {k: x for k, x in pr.items() if k not in SHAKE_KEYWORDS and k != "schedule"}  # fields = keywords
    kw.update(shake_options(pr), global_shakes=int(pr.get("global_shakes", 0)))
    if "schedule" in pr:
        sched = list(pr["schedule"])
        if sched[-1] < pr["volume_fraction"]:
            sched.append(pr["volume_fraction"])
        kw["schedule"] = sched
    return kw


def check_crm(pr: dict, path: str = "protocol") -> None:
    """Cross-key checks of a resolved CRM table."""


def check_scrm(pr: dict, path: str = "protocol") -> None:
    """Cross-key checks of a resolved SCRM table."""
    from ..errors import InvalidInputError

    if pr["volume_fraction"] == "jammed":
        raise InvalidInputError(f'{path}.volume_fraction = "jammed": SCRM needs a number in (0, 1)')
    if "schedule" in pr and pr["schedule"][-1] > pr["volume_fraction"]:
        raise InvalidInputError(
            f"{path}.schedule = {pr['schedule']!r}: must not exceed {path}.volume_fraction = "
            f"{pr['volume_fraction']!r}"
        )


_SHAKE_WORDS = {"shake.acceptance_rate.0": "acceptance rate of the last global shake (species 0)",
                "shake.global_shakes": "global shakes M", "shake.stages": "global shakes run"}

register("protocol", "crm", CRMOptions, run_crm, Outputs(meta=("shake",), labels=_SHAKE_WORDS), label="CRM",
         doc="CRM (Lubachevsky–Stillinger growth), §3.1 of 000_2cedc098acbd866b.txt; then M global shakes",
         requires=("polypack.generate:pack",), check=check_crm,
         kernels=("polypack._kernels.cells", "polypack._kernels.edmd", "polypack._kernels.shake"))
register("protocol", "scrm", SCRMOptions, run_scrm, Outputs(meta=("shake", "scrm"), labels=_SHAKE_WORDS), label="SCRM",
         doc="SCRM: CRM growth interleaved with shaking, §3.2 of 000_2cedc098acbd866b.txt",
         requires=("polypack.generate:pack", "polypack.generate:scrm", "polypack.generate:shake"),
         check=check_scrm, kernels=("polypack._kernels.cells", "polypack._kernels.edmd", "polypack._kernels.shake"))


#: Largest structure volume fraction the voids of VEM can expand in (below random close packing).
VEM_MAX_VOLUME_FRACTION = 0.6


@dataclass(frozen=True)
class VEMOptions:
    """``[protocol] kind = "vem"`` and the keywords of :func:`polypack.vem` (one declaration for both).

    The defaults are those of §2.2 and Table 1 of 003_873b69fc71c74cf6.txt; the unset ones
    are not written into a resolved study (``fill=False``: the fingerprints of earlier VEM
    studies stay the same) and :func:`polypack.vem` applies the same declared defaults.
    """

    volume_fraction: float = option(0.4, v.between(0.0, VEM_MAX_VOLUME_FRACTION, why="the voids need room to "
                                                   "expand below random close packing"),
                                    "structure volume fraction Φ")
    void_ratio: float = option(1.0, v.positive, "void to structure sphere number ratio N_V / N")
    growth_factor: float = option(1.02, v.between(1.0, 1.5), "void radius factor per expansion stage", fill=False)
    initial_void_radius: float = option(0.1, v.between(0.0, 0.5), "initial void radius / mean structure radius",
                                        fill=False)
    normal_stiffness: float = option(100.0, v.positive, "kn of structure contacts", unit="N/m", fill=False)
    shear_stiffness: float = option(10.0, v.non_negative, "ks of structure contacts", unit="N/m", fill=False)
    void_normal_stiffness: float = option(100.0, v.positive, "kn,V of void contacts", unit="N/m", fill=False)
    void_shear_stiffness: float = option(0.01, v.non_negative, "ks,V of void contacts", unit="N/m", fill=False)
    friction: float = option(0.0, v.non_negative, "Coulomb friction of the contacts", fill=False)
    damping: float = option(0.9, v.between(0.0, 1.0, lo_open=False, hi_open=True), "local damping coefficient α",
                            fill=False)
    ratio_tolerance: float = option(0.01, v.positive, "per-stage unbalanced-force ratio", fill=False)
    jam_overlap: float = option(1e-3, v.positive, "stop: void-contact overlap per void after relaxation",
                                fill=False)
    check_every: int = option(50, v.int_min(1), "DEM steps between force-ratio checks", fill=False)
    stage_steps: int = option(3000, v.int_min(1), "largest number of DEM steps of one expansion stage", fill=False)
    max_stages: int = option(400, v.int_min(1), "largest number of expansion stages", fill=False)
    final_relaxation: str = option("project", v.choice("project", "dynamics"), "overlap removal after the voids go",
                                   fill=False)
    structure_contacts: str = option("frictionless", v.choice("frictionless", "sticky"),
                                     "structure contacts during the expansion: repulsive only, or bonded at first "
                                     "touch", fill=False)
    stiffness: str = option("contact", v.choice("contact", "particle"),
                            "meaning of the four stiffnesses: per contact, or per particle combined in series per "
                            "contact (k_a k_b / (k_a + k_b): PFC 4, seed 003 Table 1)", fill=False)
    restructure: str = option("none", v.choice("none", "coagulation", "adhesive"),
                              "after the voids go: none (the repulsive VEM), coagulation of the structure by "
                              "Brownian dynamics with DLVO forces, or adhesive (the VEM contacts bonded, a weak "
                              "short-range attraction folds the floppy parts to equilibrium; docs/vem.md)", fill=False)
    restructure_time: float = option(1.0, v.positive, "coagulation: longest duration, in Brownian times a²/D0",
                                     unit="a²/D0", fill=False)
    restructure_window: float = option(0.25, v.positive, "coagulation: stops once the coordination changed by < 1 % "
                                       "over this window", unit="a²/D0", fill=False)
    restructure_potential: float = option(0.0, v.number, "coagulation: surface potential Ψ0 of the DLVO forces",
                                          unit="V", fill=False)
    restructure_bonds: str = option("tangential", v.choice("tangential", "flexible"),
                                    "coagulation: bond model (tangential: sliding and rolling resisted, rolling "
                                    "yields; flexible: free rolling)", fill=False)
    restructure_friction: float = option(0.1, v.non_negative, "adhesive: Coulomb friction of the new (unbonded) "
                                         "contacts", fill=False)
    restructure_range: float = option(0.3, v.between(0.0, 2.0), "adhesive: surface gap within which structure "
                                      "pairs attract, in units of the mean radius r0", unit="r0", fill=False)


def run_vem(sizes, pr: dict, seed, monitor=None):
    """VEM structure of the study's sizes (§2.2 of 003_873b69fc71c74cf6.txt)."""
    from .vem import vem

    return vem(sizes, seed=seed, progress=False, **pr)


#: Words of the VEM statistics in the report (``protocol.vem.<key>`` in summary.csv).
VEM_WORDS = {
    "vem.stages": "void expansion stages", "vem.n_void": "void spheres N_V",
    "vem.coordination_at_jamming": "coordination of the structure at jamming",
    "vem.bonds_at_jamming": "structure bonds at jamming", "vem.final_void_diameter": "final void diameter (length units)",
    "vem.steps": "DEM steps", "vem.separation_sweeps": "overlap-removal sweeps",
    "vem.overlap_before_separation": "largest relative overlap before separation", "vem.wall_time": "wall time, s",
    "vem.coagulation_time": "coagulation time (restructure), a²/D0",
    "vem.coagulation_bond_coordination": "bond coordination after the coagulation",
}

register("protocol", "vem", VEMOptions, run_vem, Outputs(meta=("vem",), labels=VEM_WORDS), label="VEM",
         doc="void expansion method (VEM), §2.2 of 003_873b69fc71c74cf6.txt: heterogeneous structures at Φ",
         requires=("polypack.generate:vem",), preflight="polypack.generate.protocols:preflight_vem",
         kernels=("polypack._kernels.cells", "polypack._kernels.edmd", "polypack._kernels.contacts",
                  "polypack._kernels.dem", "polypack._kernels.vem"))


#: Named rules for ``rolling_moment`` besides a number (:mod:`polypack.generate.brownian`):
#: ``"dlvo"`` = ``ROLLING_TO_ADHESION * a * F_adh`` with F_adh the pull-off force of the whole
#: DLVO potential at contact (:func:`~polypack.generate.dlvo.adhesion_force`).
ROLLING_MOMENT_RULES = ("dlvo",)
_RULE_NAMES = ", ".join(f'"{r}"' for r in ROLLING_MOMENT_RULES)


def _rolling_moment(x):
    """A rolling moment (number > 0 or inf) or one of :data:`ROLLING_MOMENT_RULES`."""
    if isinstance(x, str):
        if x not in ROLLING_MOMENT_RULES:
            raise v.Bad(f"allowed: a number > 0, inf or {_RULE_NAMES}")
        return x
    return v.positive_or_inf(x)


_rolling_moment.describe = f"number > 0, inf or {_RULE_NAMES}"


@dataclass(frozen=True)
class BrownianOptions:
    """``[protocol] kind = "brownian"``: the options of :func:`polypack.brownian` (SI units).

    N comes from ``[psd]`` (one size); the gel is scaled to the ``[psd]`` radius
    (:mod:`polypack.generate.protocols`). Unset options take the defaults of
    :data:`polypack.generate.dlvo.DLVO_DEFAULTS` and :func:`polypack.brownian`.
    """

    volume_fraction: float = option(0.4, v.fraction_open, "volume fraction Φ in (0, 0.55] (seed 003: 0.4)")
    surface_potential: float = option(0.015, v.number, "surface potential Ψ0 (seed 003: 0, 0.012 ... 0.015)", unit="V")
    radius: float = option(None, v.positive, "physical sphere radius a of the simulation", unit="m",
                           unset="0.25e-6 m (seed 003)")
    temperature: float = option(None, v.positive, "temperature", unit="K", unset="293.15 K")
    viscosity: float = option(None, v.positive, "solvent viscosity", unit="Pa s",
                              unset="1.002e-3 Pa s (water at 20 °C)")
    relative_permittivity: float = option(None, v.positive, "relative permittivity of the solvent",
                                          unset="80.1 (water)")
    hamaker: float = option(None, v.non_negative, "Hamaker constant", unit="J", unset="3.67e-20 J")
    ionic_strength: float = option(None, v.positive, "ionic strength (or give debye_length, not both)", unit="mol/m³",
                                   unset="0.9877 mol/m³, or from debye_length")
    debye_length: float = option(None, v.positive, "Debye length 1/κ", unit="m",
                                 unset="from ionic_strength, temperature and relative_permittivity")
    minimum_separation: float = option(None, v.non_negative, "surface separation of the primary minimum", unit="m",
                                       unset="0.4e-9 m")
    model: str = option("auto", v.choice("auto", "hhf", "lsa"), "double-layer model (auto: HHF for κa >= 5, else LSA)",
                        fill=False)
    time_step: float = option(None, v.positive, "time step (an rms step above 0.5 Debye lengths is refused)", unit="s",
                              unset="an rms step of 0.2 Debye lengths per coordinate")
    bond_width: float = option(1e-9, v.positive, "capture separation and bond shell width", unit="m", fill=False)
    cutoff: float = option(None, v.positive, "centre-distance cutoff of the DLVO force", unit="m", unset="2.5 a")
    record_interval: float = option(None, v.positive, "simulated seconds between records", unit="s", unset="0.05 a²/D0")
    stable_window: float = option(None, v.positive, "seconds over which the structure must be stable",
                                  unit="s", unset="2 a²/D0")
    coordination_tolerance: float = option(0.01, v.positive, "relative change of coordination allowed over the window",
                                           fill=False)
    cluster_tolerance: float = option(0.005, v.positive, "change of the largest-cluster fraction allowed over the window",
                                      fill=False)
    min_time: float = option(None, v.non_negative, "shortest simulated time", unit="s", unset="stable_window")
    max_time: float = option(None, v.positive, "simulated-time budget", unit="s", unset="60 a²/D0")
    max_steps: int = option(None, v.int_min(1), "step budget", unset="no limit up to max_time")
    bonds: str = option("flexible", v.choice("flexible", "rigid", "tangential"), fill=False, doc=
                        "bonded spheres roll freely (flexible, default), bonded clusters move as rigid bodies "
                        "(rigid), or bonds resist sliding and rolling elastically (tangential)")
    sliding_stiffness: float = option(None, v.non_negative, "tangential bonds: sliding spring stiffness", unit="N/m",
                                      unset="the stiffest the time step integrates accurately "
                                            "(TANGENTIAL_STEP_STIFFNESS / (3.5 Δt D0/a²) kT/a²)")
    rolling_stiffness: float = option(None, v.non_negative, "tangential bonds: rolling stiffness", unit="J",
                                      unset="4 k_s a² (sliding and rolling around a partner cost the same)")
    rolling_moment: float = option(None, _rolling_moment, "tangential bonds: critical rolling moment (inf: no yield; "
                                   "\"dlvo\": a F_adh / 100 with F_adh the pull-off force of the whole DLVO potential "
                                   "at minimum_separation, falling with Ψ0)",
                                   unit="N m",
                                   unset="a F_adh / 100 (Heim et al. 1999), F_adh the van der Waals force at "
                                         "minimum_separation")
    hydrodynamics: str = option("free", v.choice("free", "lubrication"), fill=False, doc=
                                "pair mobility: free draining (default, the seed's model) or with the Honig et al. "
                                "(1971) lubrication correction of the relative normal motion of close pairs")
    lubrication_range: float = option(None, v.positive, "lubrication: gap beyond which pairs are free draining", unit="m",
                                      unset="cutoff - 2a (its maximum)")
    bond_escape: str = option("none", v.choice("none", "kramers"), fill=False, doc=
                              "primary-minimum bonds are permanent (none, default) or break by thermal escape over the "
                              "barrier at the Smoluchowski first-passage rate of the pair (kramers; needs a shallow "
                              "primary minimum, e.g. minimum_separation = bond_width = 4 nm; flexible or tangential "
                              "bonds, free draining)")


@dataclass(frozen=True)
class DepositOptions:
    """``[protocol] kind = "deposit"``: the options of :func:`polypack.deposit` (disks for ``[psd] dim = 2``, spheres for 3)."""

    width: float = option(None, v.positive, "box width W, in 3D the side of the square footprint",
                          unset="sqrt(sum of disk areas / 0.82) in 2D, (sum of sphere volumes / 0.6)^(1/3) in 3D, at "
                                "least 4.5 d_max (periodic) or 1.5 d_max (walls)")
    boundary: str = option("periodic", v.choice("periodic", "walls"), "x axis periodic or side walls")
    order: str = option("random", v.choice("random", "given"), "deposition order: random (from the seed) or as sized")
    tolerance: float = option(None, v.positive, "relative tolerance of contacts and ties (<= 1e-3)", unset="1e-10")
    floor_rule: str = option(None, v.choice("left", "centred"),
                             "2D bare floor: midpoint (centred, as LMGC90) or leftmost point (left) of the leftmost bare stretch",
                             unset="'centred'")
    rule: str = option(None, v.choice("surface", "roll"),
                       "3D: lowest stable surface pocket (surface) or drop-and-roll (roll, Visscher & "
                       "Bolsterli 1972: small spheres enter the pores; periodic only)", unset="'surface'")


_P = "polypack.generate.protocols:"
#: Words of the Brownian-dynamics statistics in the report (``protocol.brownian.<key>`` in summary.csv).
BROWNIAN_WORDS = {
    "brownian.coordination": "coordination (bonds per sphere) of the gel", "brownian.n_bonds": "bonds",
    "brownian.clusters": "clusters", "brownian.largest_cluster": "spheres in the largest cluster",
    "brownian.steps": "BD steps", "brownian.simulated_time": "simulated time, s",
    "brownian.converged": "structure stable within the budget", "brownian.time_step": "time step, s",
    "brownian.brownian_time": "Brownian time a²/D0, s", "brownian.wall_time": "wall time, s",
}

register("protocol", "brownian", BrownianOptions, _P + "run_brownian", Outputs(meta=("brownian",), labels=BROWNIAN_WORDS),
         label="Brownian",
         doc="colloidal gel by Brownian dynamics with DLVO forces, §2.2 of 003_873b69fc71c74cf6.txt",
         requires=("polypack.generate:brownian",), check=_P + "check_brownian", preflight=_P + "preflight_brownian",
         kernels=("polypack._kernels.bd",))
#: Words of the deposition statistics (top-level ``meta`` scalars: ``protocol.<key>`` in summary.csv).
DEPOSIT_WORDS = {
    "n_bed": "bed disks", "chain_length": "free-surface chain length at the end (2D)",
    "chain_max": "longest free-surface chain (2D)", "alive": "live surface spheres at the end (3D)",
    "alive_max": "most live surface spheres (3D)", "overhang_placements": "overhang placements (3D)",
    "candidate_searches": "candidate searches (3D)", "improving_searches": "improving searches (3D)",
    "rolled_placements": "spheres with no stable pocket, rolled from the lowest reachable point (3D surface rule)",
    "events": "contacts made or lost while rolling (3D roll)", "stuck": "spheres stopped by the event cap (3D roll)",
    "on_floor": "spheres on the floor (3D roll)", "neighbours_examined": "neighbour entries examined (3D roll)",
}

register("protocol", "deposit", DepositOptions, _P + "run_deposit", Outputs(meta=(), labels=DEPOSIT_WORDS),
         doc="sequential deposition of disks (2D) or spheres (3D) by potential minimisation, §2.4 of 001_ad5bae0acea940c4.txt",
         requires=("polypack.generate:deposit",), preflight=_P + "preflight_deposit",
         kernels=("polypack._kernels.deposit", "polypack._kernels.deposit3d", "polypack._kernels.roll3d"))
