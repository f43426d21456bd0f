"""Heterogeneous packs by the void expansion method (VEM, §2.2 of 003_873b69fc71c74cf6.txt).

Method (Schenker et al. 2009, 2010)
-----------------------------------
``N`` structure spheres are placed at random in the periodic cube of Eq. (5) of
003_873b69fc71c74cf6.txt, ``L = r0 (4 N π / (3 Φ))^(1/3)``; ``N_V = void_ratio N`` much
smaller *void* spheres are placed at random in the space between them.  The void
radius is then increased stage by stage; after each increase the assembly is relaxed
by damped soft-contact dynamics (the discrete-element engine of
:mod:`polypack._kernels.dem` with the linear contact law of Eq. (1) of
003_873b69fc71c74cf6.txt and the local damping of Eq. (3) of
003_873b69fc71c74cf6.txt), so that the expanding voids push the structure spheres
together.  When the assembly of structure and void spheres jams, the voids are
deleted, the structure is relaxed, and its residual overlaps are removed: the
structure spheres of the returned pack are hard (no overlap beyond
:data:`OVERLAP_TOLERANCE`) and the volume fraction is exactly Φ (the radii and the box
never change).  Few voids give large pores and a heterogeneous structure (large DOH
parameter ``a`` of Eq. (6) of 003_873b69fc71c74cf6.txt); many voids a more homogeneous
one (Table 2 of the seed).

Choices (documented in ``docs/vem.md`` and recorded in ``meta["vem"]``)
------------------------------------------------------------------------
Start
    The structure spheres start as an equilibrium hard-sphere fluid at Φ (random
    placement without overlaps; Lubachevsky-Stillinger growth, :func:`polypack.pack`);
    the voids, of radius ``initial_void_radius`` r0 (default 0.1 r0: "much smaller"),
    at uniformly random points outside every structure sphere.
Contact law
    Frictionless by default (``friction = 0``, as in the seed's DEM, §2.1), linear
    springs per contact: structure-structure ``kn = normal_stiffness`` (100 N/m, Table 1
    of the seed), ``ks = shear_stiffness``; every contact involving a void ``kn,V =
    void_normal_stiffness`` = 1e2 N/m and ``ks,V = void_shear_stiffness`` = 1e-2 N/m (§2.2
    of the seed).  Only the stiffness ratio ``kn,V / kn`` shapes the structure: the run is
    quasi-static, so masses are scaled to one common value for every sphere (a standard
    density scaling of quasi-static DEM) and the time step is ``0.2 sqrt(m / k_max)``.
Growth factor
    The void radius is multiplied by ``growth_factor`` = 1.02 per stage (a 6 % increase of
    the void volume; small enough that each stage is a small perturbation of a relaxed
    state, the quasi-static expansion of the VEM papers).
Relaxation criterion (per stage)
    Damped dynamics (local damping ``damping`` = 0.9, the coefficient of the seed and its
    references [10, 27]) until PFC's mean unbalanced-force ratio (mean ``|F|`` over the
    spheres divided by the mean contact force, both over the spheres and contacts that
    carry force) falls below ``ratio_tolerance`` = 0.01 (the ratio of PFC's ``solve``
    command), or the contacts are unloaded (summed relative overlap per sphere below
    :data:`UNLOADED`), checked every ``check_every`` steps, at most ``stage_steps``
    steps.
Stop criterion
    Schenker et al. (2009) characterise the expansion by the structure's mean
    coordination number, which jumps from a low to a high value at a void radius where
    the total volume fraction (structure plus voids) is slightly below random close
    packing: the assembly jams.  The expansion stops at the first stage after which the
    relaxation can no longer unload the contacts: the summed relative overlap
    ``(r_i + r_j - d) / (r_i + r_j)`` of the void contacts, per void, stays above
    ``jam_overlap`` (default 1e-3) after the relaxation, i.e. the assembly carries a
    finite pressure.  (Below jamming the relaxation unloads every contact, to below
    :data:`UNLOADED` per sphere.)  The evolution of the coordination
    number (structure-structure contacts carrying force, 2 M / N) is recorded per stage.
Structure contacts
    Frictionless by default; ``structure_contacts = "sticky"`` bonds a structure pair at
    its first touch for the rest of the run (a model of coagulation; measured against
    Table 2 of the seed in ``docs/vem.md``: it lowers both ``a`` and C, so it is not the default).
Restructuring
    ``restructure = "coagulation"`` (default ``"none"``) lets the finished structure coagulate
    by Brownian dynamics with DLVO forces (:func:`_coagulate`; the experiment VEM mimics
    coagulates, §2.2 of 003_873b69fc71c74cf6.txt) until its bond coordination is stable;
    measured against Table 2 in ``docs/vem.md``.  ``restructure = "adhesive"`` bonds the
    structure's contacts (PFC contact bonds at d < 1.01 (r_i + r_j), the seed's bond rule) and
    lets a weak short-range attraction fold the floppy parts of the network to mechanical
    equilibrium, new contacts adhesive with Coulomb friction (:class:`_Adhesive`): C ends near
    4.6-4.8 at every void ratio (``docs/vem.md``).
Finish
    Voids deleted; the residual structure overlaps (about 1 % of the diameter at the
    stop) are removed by projections (:func:`polypack._kernels.vem.separate`), the
    smallest moves that make the spheres hard, so every compressed contact ends exactly
    touching.  ``final_relaxation = "dynamics"`` first relaxes the structure by the
    seed's steps after each of which all velocities are zeroed (§2.2), which unloads
    the contacts and opens some of them.

References
----------
Schenker, I., Filser, F. T., Herrmann, H. J. & Gauckler, L. J., Generation of porous
particle structures using the void expansion method, Granular Matter 11, 201 (2009).
Schenker, I., Filser, F. T. & Gauckler, L. J., Stochastic generation of particle
structures with controlled degree of heterogeneity, Granular Matter 12, 437 (2010).
Cundall, P. A. & Strack, O. D. L., Géotechnique 29, 47 (1979).
Heyes, D. M. & Melrose, J. R., J. Non-Newtonian Fluid Mech. 46, 1 (1993).
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np

from .. import _validate as _v
from .. import registry as _registry
from .._util import as_seed_sequence, progress_bar, seed_record
from ..errors import InfeasibleError, InvalidInputError, OverlapError
from ..packing import Packing
from ._capabilities import VEM_MAX_VOLUME_FRACTION, VEMOptions

__all__ = ["vem", "OVERLAP_TOLERANCE", "MAX_VOLUME_FRACTION", "VEM_DEFAULTS", "STRUCTURE_CONTACTS", "RESTRUCTURE"]

#: Largest relative overlap ``1 - d_ij / (r_i + r_j)`` tolerated between structure spheres
#: of a returned pack (the final projections remove every overlap; this bounds round-off).
OVERLAP_TOLERANCE = 1e-9
#: Largest structure volume fraction accepted: the voids must still find room to expand
#: before the assembly jams slightly below random close packing (Schenker et al. 2009
#: generate 0.4 ... 0.6).
MAX_VOLUME_FRACTION = VEM_MAX_VOLUME_FRACTION
#: Smallest number of structure spheres.
MIN_SPHERES = 32
#: A stage's relaxation also ends when the summed relative overlap of all contacts per
#: sphere is below this (the contacts are unloaded: the assembly is not jammed).
UNLOADED = 1e-5

#: Contact models of the structure spheres during the expansion: ``"frictionless"``
#: (linear repulsion only, contacts open freely) or ``"sticky"`` (a structure pair that
#: touches is bonded for good, the bond carrying tension and shear).
STRUCTURE_CONTACTS = ("frictionless", "sticky")

#: Restructuring after the voids go: ``"none"`` (the repulsive VEM), ``"coagulation"``
#: (Brownian dynamics with DLVO forces from the VEM structure, :func:`_coagulate`) or
#: ``"adhesive"`` (bonded VEM contacts, attraction-driven folding to equilibrium, :class:`_Adhesive`).
RESTRUCTURE = ("none", "coagulation", "adhesive")
#: Coagulation stop rule: the bond coordination changed by at most this fraction over
#: ``restructure_window`` (the rule of :func:`polypack.brownian`, on a shorter window).
RESTRUCTURE_TOLERANCE = 0.01
#: Coagulation: simulated time between two records of the coordination (a²/D0).
RESTRUCTURE_RECORD = 0.01

#: Defaults of :func:`vem`: those declared by the options dataclass
#: :class:`polypack.generate._capabilities.VEMOptions` (the one declaration of the API, the
#: study's ``[protocol] kind = "vem"`` and ``polypack vem``).
VEM_DEFAULTS = _registry.defaults(VEMOptions)


def _record(options, ns, n_void, r0, run) -> dict:
    """``meta["vem"]``: the options as checked (VEMOptions' order), the sizes, then the run's statistics."""
    head = ("volume_fraction", "void_ratio")
    return {**{k: options[k] for k in head}, "n_structure": ns, "n_void": n_void, "radius": r0,
            **{k: x for k, x in options.items() if k not in head}, **run}


def _separate(pos, red, box, ns, skin):
    """Remove the structure's overlaps left when the voids go: rounds of projections
    (:func:`polypack._kernels.vem.separate`) over a fresh candidate list until a round starts
    without overlap (large overlaps move spheres by more than the list's skin).

    Returns ``(positions wrapped into the box, status, sweeps, worst overlap before)``.
    """
    from .._kernels import vem as V
    from .._kernels.cells import pairs_within
    from ..neighbors import choose_cells

    wpos = np.mod(pos, box)
    wpos = np.minimum(wpos, np.nextafter(box, 0))
    ncell = np.asarray(choose_cells(box, ns, 2.0 * float(red.min()) + skin), np.int64)
    sweeps, worst, status = 0, 0.0, None
    for rnd in range(50):
        pi, pj, _ = pairs_within(wpos, red, box, 1.0, skin, ncell)
        status, k, first = V.separate(wpos, red, box, pi, pj, 1.0 + 1e-10, 100000)
        sweeps += k
        if rnd == 0:
            worst = first
        wpos = np.minimum(np.mod(wpos, box), np.nextafter(box, 0))
        if first == 0.0 and status == V.SEPARATE_DONE:
            break
    return wpos, status, sweeps, worst


def _structure_radii(n, radius):
    """Structure radii and species from ``n`` (int, SizeSet, array of radii)."""
    if isinstance(n, (int, np.integer)) and not isinstance(n, bool):
        n = _v.check("n", n, _v.int_min(MIN_SPHERES))
        r = _v.check("radius", radius, _v.positive)
        return np.full(n, r), np.zeros(n, np.int64)
    if hasattr(n, "radii"):
        radii = np.asarray(n.radii, dtype=np.float64)
        species = np.asarray(getattr(n, "species", np.zeros(radii.size)), dtype=np.int64)
    else:
        try:
            radii = np.asarray(n, dtype=np.float64).ravel()
        except (TypeError, ValueError):
            raise InvalidInputError(f"n={n!r}: give a number of spheres, a SizeSet or an array of radii") from None
        species = np.zeros(radii.size, np.int64)
    if radii.size < MIN_SPHERES:
        raise InvalidInputError(f"n={radii.size}: VEM needs at least {MIN_SPHERES} structure spheres")
    if not np.all(np.isfinite(radii)) or np.any(radii <= 0):
        raise InvalidInputError("radii: must be finite and > 0")
    return radii, species


def _damped_params(K, dt, damping, friction, box, skin):
    """The DEM kernel's parameter vector for damped dynamics without a drive (Lees–Edwards mode at zero
    amplitude): time step ``dt``, local damping α of Eq. (3) of 003_873b69fc71c74cf6.txt, Coulomb
    friction, neighbour skin; no sampling."""
    p = np.zeros(K.N_P)
    p[K.P_DT] = dt
    p[K.P_OMEGA] = 1.0
    p[K.P_RAMP] = 1.0
    p[K.P_ALPHA] = damping
    p[K.P_MU] = friction
    p[K.P_VOLUME] = float(np.prod(box))
    p[K.P_LENGTH] = box[2]
    p[K.P_AXIS_A] = 0
    p[K.P_AXIS_G] = 2
    p[K.P_MODE] = K.MODE_LEES_EDWARDS
    p[K.P_SAMPLE_EVERY] = 0
    p[K.P_SKIN] = skin
    return p


def _run_dem(sys, steps, sample, rebuild):
    """Advance ``sys`` (an :class:`_Assembly` or :class:`_Adhesive`) by ``steps`` steps of the DEM
    contact kernel (contact law Eq. (1) of 003_873b69fc71c74cf6.txt, local damping Eq. (3) of
    003_873b69fc71c74cf6.txt), calling ``rebuild()`` whenever the kernel asks for new contact lists;
    ``sample``: the kernel records its samples on every step."""
    K = sys.K
    done = 0
    sys.p[K.P_SAMPLE_EVERY] = 1 if sample else 0
    while done < steps:
        status, k, _ = K.run(steps - done, sys.pos, sys.vel, sys.omg, sys.radii, sys.mass, sys.inertia,
                             sys.kind, sys.pos, sys.h0, sys.ci, sys.cj, sys.cshift, sys.ckn, sys.cks,
                             sys.crest, sys.cfnb, sys.cfsb, sys.cstate, sys.cfs, sys.cfn, sys.p,
                             sys.st, sys.samples, 0, sys.xbuild, sys._no_edges, sys._no_layers)
        done += k
        if status == K.STATUS_REBUILD:
            rebuild()
    sys.p[K.P_SAMPLE_EVERY] = 0


def _unbalanced_ratio(samples, K, n, active):
    """PFC's unbalanced-force ratio Σ|F_i| / (2 Σ|f_c|) from the DEM kernel's last sample (``n`` spheres,
    ``active`` force-carrying contacts); 0 when no contact carries force."""
    fu = samples[0, K.S_UNBALANCED] * n
    fc = samples[0, K.S_CONTACT_FORCE] * active
    return fu / (2.0 * fc) if fc > 0 else 0.0


class _Assembly:
    """Structure + void spheres in reduced units (mean structure radius 1, kn = 1, mass 1)."""

    def __init__(self, pos, radii, box, n_struct, kn, ks, knv, ksv, friction, damping, skin, sticky=False,
                 void_void=None):
        from .._kernels import dem as K

        self.K = K
        self.pos = np.ascontiguousarray(pos, dtype=np.float64)
        self.radii = np.ascontiguousarray(radii, dtype=np.float64)
        self.box = np.asarray(box, dtype=np.float64)
        self.h0 = np.diag(self.box)
        self.ns = int(n_struct)
        # per-contact springs: structure-structure (kn, ks), structure-void (knv, ksv) and
        # void-void (void_void, default the structure-void pair: the per-contact semantics)
        self.kn, self.ks, self.knv, self.ksv = kn, ks, knv, ksv
        self.knvv, self.ksvv = (knv, ksv) if void_void is None else void_void
        n = self.pos.shape[0]
        self.n_key = np.int64(n)  # fixed for the keys (the voids are dropped at the end)
        self.sticky = bool(sticky)
        self.bond_keys = np.zeros(0, np.int64)  # sorted keys of the structure pairs bonded so far
        self.mass = np.ones(n)
        self.inertia = 0.4 * self.radii**2
        self.vel = np.zeros_like(self.pos)
        self.omg = np.zeros_like(self.pos)
        self.kind = np.zeros(n, np.int64)
        self.st = np.zeros(K.N_ST)
        self.skin = skin
        kmax = max(kn, knv, ks, ksv, self.knvv, self.ksvv)
        self.dt = 0.2 / math.sqrt(kmax)
        p = _damped_params(K, self.dt, damping, friction, self.box, skin)
        self.p = p
        self.samples = np.zeros((1, K.N_S))
        self._no_edges = np.zeros(0)
        self._no_layers = np.zeros((1, 0))
        self.rebuilds = 0
        self.rebuild()

    # contact list -------------------------------------------------------------------
    def rebuild(self):
        from .._kernels.cells import pairs_within
        from .._kernels.contacts import BONDED, CONTACT
        from ..neighbors import choose_cells

        pos, radii, box = self.pos, self.radii, self.box
        k = np.floor(pos / box)
        w = np.clip(pos - k * box, 0.0, np.nextafter(box, 0))
        ncell = choose_cells(box, pos.shape[0], 2.0 * float(radii.min()) + self.skin)
        pi, pj, _ = pairs_within(w, radii, box, 1.0, self.skin, np.asarray(ncell, np.int64))
        # canonical order i < j so that the shear history keeps its sign across rebuilds
        sw = pi > pj
        i = np.where(sw, pj, pi)
        j = np.where(sw, pi, pj)
        shift = -np.round((w[j] - w[i]) / box) - k[j] + k[i]
        old_keys = getattr(self, "_keys", None)
        keys = self._keys_of(i, j, shift)
        if self.bond_keys.size:
            # a bond stays in the list however far it is stretched
            lost = np.setdiff1d(self.bond_keys, keys, assume_unique=False)
            if lost.size:
                bi, bj, bs = self._pair_of(lost)
                i, j = np.concatenate([i, bi]), np.concatenate([j, bj])
                shift = np.concatenate([shift, bs])
                keys = np.concatenate([keys, lost])
        order = np.argsort(keys, kind="stable")
        i, j, shift, keys = i[order], j[order], shift[order], keys[order]
        m = i.shape[0]
        struct = (i < self.ns) & (j < self.ns)
        cfs = np.zeros((m, 3))
        if old_keys is not None and old_keys.size and m:
            pos_in_old = np.searchsorted(old_keys, keys)
            pos_in_old = np.minimum(pos_in_old, old_keys.size - 1)
            hit = old_keys[pos_in_old] == keys
            cfs[hit] = self.cfs[pos_in_old[hit]]
        self._keys = keys
        self.ci = i.astype(np.int64)
        self.cj = j.astype(np.int64)
        self.cshift = np.ascontiguousarray(shift, dtype=np.float64)
        voids = (i >= self.ns) & (j >= self.ns)
        self.ckn = np.where(struct, self.kn, np.where(voids, self.knvv, self.knv))
        self.cks = np.where(struct, self.ks, np.where(voids, self.ksvv, self.ksv))
        self.crest = radii[i] + radii[j]
        self.cfnb = np.full(m, np.inf)
        self.cfsb = np.full(m, np.inf)
        self.cstate = np.full(m, CONTACT, np.int64)
        if self.bond_keys.size:
            self.cstate[np.isin(keys, self.bond_keys, assume_unique=False)] = BONDED
        self.cfs = cfs
        self.cfn = np.zeros(m)
        self.xbuild = self.pos.copy()
        self.rebuilds += 1

    def _keys_of(self, i, j, shift):
        s = np.clip(shift.astype(np.int64) + 8, 0, 16)
        n = self.n_key
        return ((i.astype(np.int64) * n + j) * 17 + s[:, 0]) * 289 + s[:, 1] * 17 + s[:, 2]

    def _pair_of(self, keys):
        """Inverse of :meth:`_keys_of`: ``(i, j, shift)`` of the given keys."""
        keys = np.asarray(keys, np.int64)
        s2 = keys % 17
        s1 = (keys // 17) % 17
        rest = keys // 289
        s0 = rest % 17
        ij = rest // 17
        i, j = ij // self.n_key, ij % self.n_key
        shift = np.stack([s0, s1, s2], axis=1).astype(np.float64) - 8.0
        return i.astype(np.int64), j.astype(np.int64), shift

    def bond_new_contacts(self):
        """Sticky structure contacts: bond every structure pair that touches now.

        The bond is a PFC contact bond about the touching distance (``rest = r_i + r_j``),
        unbreakable, carrying tension and shear; it holds through the rest of the expansion.
        Returns the number of new bonds.
        """
        from .._kernels.contacts import BONDED, CONTACT

        new = ((self.cstate == CONTACT) & (self.ci < self.ns) & (self.cj < self.ns) & (self.cfn > 0.0))
        if not np.any(new):
            return 0
        self.cstate[new] = BONDED
        self.bond_keys = np.union1d(self.bond_keys, self._keys[new])
        return int(np.count_nonzero(new))

    # dynamics ---------------------------------------------------------------------
    def _run(self, steps, sample):
        _run_dem(self, steps, sample, self.rebuild)

    def relax(self, tolerance, check_every, max_steps, overlap_floor=0.0):
        """Run until the unbalanced-force ratio < tolerance (or no contact carries force).

        The ratio is ``sum_i |F_i| / (2 sum_c |f_c|)`` (in [0, 1]; 0 in static equilibrium):
        PFC's mean unbalanced force over the mean contact force, with both means taken
        over the spheres and contacts that carry force, so that spheres without contacts
        do not dilute it.  Returns ``(steps, ratio)``.
        """
        from .._kernels import vem as V

        K = self.K
        steps = 0
        ratio = np.inf
        n = self.pos.shape[0]
        while steps < max_steps:
            k = min(check_every, max_steps - steps)
            if k > 1:
                self._run(k - 1, False)
            self._run(1, True)
            steps += k
            if self.sticky:
                self.bond_new_contacts()
            st = self.stats()
            active = st[V.C_STRUCT_CONTACTS] + st[V.C_VOID_CONTACTS]
            ratio = _unbalanced_ratio(self.samples, K, n, active)
            if ratio < tolerance:  # 0 when no contact carries force (tolerance > 0)
                break
            if overlap_floor > 0.0 and (st[V.C_STRUCT_OVERLAP_SUM] + st[V.C_VOID_OVERLAP_SUM]) <= overlap_floor * n:
                break  # contacts unloaded: summed relative overlap per sphere below the floor
        return steps, ratio

    def stats(self):
        from .._kernels import vem as V

        out = np.zeros(V.N_C)
        V.classify(self.pos, self.radii, self.h0, self.ci, self.cj, self.cshift, self.ns, out)
        return out

    def grow_voids(self, factor):
        self.radii[self.ns:] *= factor
        self.inertia = 0.4 * self.radii**2
        self.rebuild()

    def drop_voids(self):
        self.pos = np.ascontiguousarray(self.pos[: self.ns])
        self.radii = np.ascontiguousarray(self.radii[: self.ns])
        self.mass = self.mass[: self.ns]
        self.inertia = self.inertia[: self.ns]
        self.vel = np.zeros_like(self.pos)
        self.omg = np.zeros_like(self.pos)
        self.kind = self.kind[: self.ns]
        self.rebuild()  # structure keys do not change (fixed n_key): shear histories and bonds carry over


def _coagulate(wpos, r_red, box, o, seed):
    """Coagulation of a VEM structure (``restructure = "coagulation"``).

    Brownian dynamics with DLVO forces (:class:`polypack.generate.brownian.BrownianSimulation`,
    DLVO parameters :data:`polypack.generate.dlvo.DLVO_DEFAULTS`: r0 = 0.25 µm, the seed's
    scale) from the hard structure ``wpos`` (reduced units, radius ``r_red``): touching pairs
    bond at the first step, near pairs close under the van der Waals attraction, free spheres
    diffuse and attach.  The coordination ``2 M / N`` of the bonds is recorded every
    :data:`RESTRUCTURE_RECORD` a²/D0; the run stops when it changed by at most
    :data:`RESTRUCTURE_TOLERANCE` (relative) over ``restructure_window``, or at
    ``restructure_time``.  The bond constraints are then relaxed (noise-free projections).

    Returns ``(positions in reduced units, record)``.
    """
    from .brownian import BrownianSimulation
    from .dlvo import dlvo_parameters

    p = dlvo_parameters(o["restructure_potential"])
    a, tau = p.radius, p.brownian_time
    scale = a / r_red
    sim = BrownianSimulation(np.asarray(wpos) * scale, np.asarray(box) * scale, p, seed=seed,
                             bonds=o["restructure_bonds"])
    per = max(1, int(round(RESTRUCTURE_RECORD * tau / sim.time_step)))
    t_end, window = o["restructure_time"], o["restructure_window"]
    nwin = max(1, int(round(window / (per * sim.time_step / tau))))
    times, coord = [0.0], [0.0]
    reason = f"restructure_time = {t_end:g} a²/D0 reached"
    while sim.time / tau < t_end * (1.0 - 1e-12):
        left = int(math.ceil((t_end * tau - sim.time) / sim.time_step - 1e-9))
        sim.run(max(1, min(per, left)))
        times.append(sim.time / tau)
        coord.append(sim.coordination)
        m = len(coord) - 1
        if m >= nwin and coord[m] > 0 and abs(coord[m] - coord[m - nwin]) <= RESTRUCTURE_TOLERANCE * coord[m]:
            reason = (f"stable: bond coordination changed by <= {RESTRUCTURE_TOLERANCE:g} over "
                      f"{window:g} a²/D0")
            break
    sim.relax_constraints()
    rec = {"time": float(sim.time / tau), "steps": int(sim.steps), "time_step": float(sim.time_step / tau),
           "stop_reason": reason, "bond_coordination": float(sim.coordination), "n_bonds": int(sim.n_bonds),
           "dlvo": p.to_dict(), "bonds": o["restructure_bonds"],
           "series": {"time": [float(x) for x in times], "coordination": [float(x) for x in coord]}}
    return sim.positions / scale, rec


#: ``restructure = "adhesive"``: attraction per unbonded structure pair within ``restructure_range``,
#: in units of kn r0 (reduced units).  Small, so that a rigid bonded network deforms by about this
#: strain only; but it sets how fast the floppy parts fold (with inertia: a sphere meets a new contact
#: with an overlap of about sqrt(2 f_a h / kn)), and faster folding makes more contacts (N = 1000:
#: C lower by 0.1-0.15 at 1e-4, 0.15-0.25 at 1e-5; docs/vem.md), so it is calibrated with the
#: friction and the range.
ADHESION_FORCE = 1e-3
#: ``restructure = "adhesive"``: relative gap within which the VEM's structure pairs are bonded at the
#: start (the seed's bond rule, d < (1 + ε) 2 r0 with ε = 0.01, §2.2 of 003_873b69fc71c74cf6.txt).
ADHESION_BOND_GAP = 0.01
#: ``restructure = "adhesive"``: stop when PFC's unbalanced-force ratio is below this (the forces are
#: weak, so ten times below the per-stage value of the expansion).
ADHESION_RATIO = 1e-3
#: ``restructure = "adhesive"``: DEM steps between two checks, and the step budget.
ADHESION_CHECK = 100
ADHESION_MAX_STEPS = 1_000_000


class _Adhesive:
    """Rigidity-limited restructuring of a hard structure (``restructure = "adhesive"``).

    Structure spheres only, reduced units (mean radius 1, structure kn = 1, mass 1), the DEM engine of
    :mod:`polypack._kernels.dem` (local damping, Eq. (3) of 003_873b69fc71c74cf6.txt).  Per structure
    pair in the neighbour list one *main* contact entry:

    * pairs closer than ``(1 + ADHESION_BOND_GAP)(r_i + r_j)`` at the start carry a PFC contact bond
      (normal and shear springs, no moment: the bonded spheres roll freely), installed at its
      distance (no initial force), unbreakable: the VEM network as the seed's bonds hold it;
    * every other pair is a linear contact (kn, ks) with Coulomb friction ``mu``: new contacts slide.

    and, for every unbonded pair with a gap below ``rng`` (r0) at the last neighbour rebuild, a
    second, *attraction* entry: a central spring of stiffness ``f_a / L`` about the length
    ``r_i + r_j - L`` (L = 1: a nearly constant pull ``f_a (1 + gap / L)``), which breaks at the gap
    ``rng``.  The attraction makes the floppy parts of the network fold until every sphere is held;
    the rigid parts deform by about ``f_a`` only.  New contacts are adhesive (the attraction holds them
    closed) and frictional.
    """

    def __init__(self, pos, radii, box, ks, mu, rng, damping):
        from .._kernels import dem as K

        self.K = K
        n = pos.shape[0]
        self.n = n
        self.pos = np.ascontiguousarray(pos, dtype=np.float64)
        self.radii = np.ascontiguousarray(radii, dtype=np.float64)
        self.box = np.asarray(box, dtype=np.float64)
        self.h0 = np.diag(self.box)
        self.mass = np.ones(n)
        self.inertia = 0.4 * self.radii**2
        self.vel = np.zeros((n, 3))
        self.omg = np.zeros((n, 3))
        self.kind = np.zeros(n, np.int64)
        self.ks, self.rng, self.lever = float(ks), float(rng), 1.0
        self.skin = max(0.2, self.rng + 0.1)
        self.st = np.zeros(K.N_ST)
        p = _damped_params(K, 0.2 / math.sqrt(max(1.0, ks)), damping, mu, self.box, 0.5 * self.skin)
        self.p = p
        self.samples = np.zeros((1, K.N_S))
        self._no_edges = np.zeros(0)
        self._no_layers = np.zeros((1, 0))
        self.rebuilds = 0
        self.keys = np.zeros(0, np.int64)
        self.cfs = np.zeros((0, 3))
        i, j, shift, d, keys = self._pairs()
        bond = d <= (1.0 + ADHESION_BOND_GAP) * (self.radii[i] + self.radii[j])
        self.bond_keys = keys[bond]  # sorted (keys come sorted)
        self.bond_rest = np.maximum(d[bond], self.radii[i[bond]] + self.radii[j[bond]])
        self.build()

    def _pairs(self):
        """Pairs within the list's reach: ``(i, j, shift, distance, key)``, sorted by key, i < j."""
        from .._kernels.cells import pairs_within
        from ..neighbors import choose_cells

        pos, box = self.pos, self.box
        k = np.floor(pos / box)
        w = np.clip(pos - k * box, 0.0, np.nextafter(box, 0))
        ncell = np.asarray(choose_cells(box, self.n, 2.0 * float(self.radii.min()) + self.skin), np.int64)
        pi, pj, _ = pairs_within(w, self.radii, box, 1.0, self.skin, ncell)
        sw = pi > pj
        i = np.where(sw, pj, pi).astype(np.int64)
        j = np.where(sw, pi, pj).astype(np.int64)
        shift = -np.round((w[j] - w[i]) / box) - k[j] + k[i]
        b = pos[j] + shift * box - pos[i]
        d = np.sqrt(np.einsum("ij,ij->i", b, b))
        s = np.clip(shift.astype(np.int64) + 8, 0, 16)
        keys = ((i * self.n + j) * 17 + s[:, 0]) * 289 + s[:, 1] * 17 + s[:, 2]
        o = np.argsort(keys, kind="stable")
        return i[o], j[o], shift[o], d[o], keys[o]

    def build(self):
        """Contact arrays from a fresh pair list (shear histories carried over by pair key)."""
        from .._kernels.contacts import BONDED, CONTACT

        i, j, shift, d, keys = self._pairs()
        m = i.size
        at = np.searchsorted(self.bond_keys, keys)
        at = np.minimum(at, max(self.bond_keys.size - 1, 0))
        bonded = (self.bond_keys[at] == keys) if self.bond_keys.size else np.zeros(m, bool)
        rest = np.where(bonded, self.bond_rest[at] if self.bond_keys.size else 0.0, self.radii[i] + self.radii[j])
        cfs = np.zeros((m, 3))
        if self.keys.size and m:
            old = np.minimum(np.searchsorted(self.keys, keys), self.keys.size - 1)
            hit = self.keys[old] == keys
            cfs[hit] = self.cfs[old[hit]]
        gap = d - self.radii[i] - self.radii[j]
        att = (~bonded) & (gap < self.rng)
        na = int(np.count_nonzero(att))
        kap = ADHESION_FORCE / self.lever
        self.nmain = m
        self.keys = keys
        self.ci = np.ascontiguousarray(np.concatenate([i, i[att]]))
        self.cj = np.ascontiguousarray(np.concatenate([j, j[att]]))
        self.cshift = np.ascontiguousarray(np.concatenate([shift, shift[att]]), dtype=np.float64)
        self.ckn = np.concatenate([np.ones(m), np.full(na, kap)])
        self.cks = np.concatenate([np.full(m, self.ks), np.zeros(na)])
        self.crest = np.concatenate([rest, self.radii[i[att]] + self.radii[j[att]] - self.lever])
        self.cfnb = np.concatenate([np.full(m, np.inf), np.full(na, kap * (self.lever + self.rng))])
        self.cfsb = np.full(m + na, np.inf)
        self.cstate = np.concatenate([np.where(bonded, BONDED, CONTACT), np.full(na, BONDED)]).astype(np.int64)
        self.cfs = np.ascontiguousarray(np.concatenate([cfs, np.zeros((na, 3))]))
        self.cfn = np.zeros(m + na)
        self.xbuild = self.pos.copy()
        self.rebuilds += 1

    def _run(self, steps, sample):
        _run_dem(self, steps, sample, self._rebuild_contacts)

    def _rebuild_contacts(self):
        self.cfs = self.cfs[: self.nmain]
        self.build()

    def relax(self):
        """Damped dynamics until PFC's unbalanced-force ratio is below :data:`ADHESION_RATIO`;
        returns ``(steps, ratio, reason)``."""
        from .. import _interrupt

        K = self.K
        steps, ratio = 0, math.inf
        reason = f"step budget {ADHESION_MAX_STEPS} used up"
        while steps < ADHESION_MAX_STEPS:
            _interrupt.check("vem interrupted in the adhesive restructuring")
            self._run(ADHESION_CHECK - 1, False)
            self._run(1, True)
            steps += ADHESION_CHECK
            ratio = _unbalanced_ratio(self.samples, K, self.n, max(int(np.count_nonzero(self.cfn)), 1))
            if ratio < ADHESION_RATIO:
                reason = f"equilibrium: unbalanced-force ratio {ratio:.3g} < {ADHESION_RATIO:g}"
                break
        return steps, ratio, reason


def _adhere(wpos, red, box, o):
    """``restructure = "adhesive"``: :class:`_Adhesive` from the hard VEM structure ``wpos`` (reduced
    units) to mechanical equilibrium.  Returns ``(positions, record)``."""
    ks = o["shear_stiffness"] / o["normal_stiffness"]  # the same ratio per contact or per particle
    t0 = time.process_time()
    sim = _Adhesive(wpos, red, box, ks, o["restructure_friction"], o["restructure_range"], o["damping"])
    bonds0 = 2.0 * sim.bond_keys.size / red.size
    steps, ratio, reason = sim.relax()
    m = sim.nmain
    b = sim.pos[sim.cj[:m]] + sim.cshift[:m] * box - sim.pos[sim.ci[:m]]
    touching = np.sqrt(np.einsum("ij,ij->i", b, b)) <= (1.0 + ADHESION_BOND_GAP) * (red[sim.ci[:m]] + red[sim.cj[:m]])
    rec = {"steps": int(steps), "ratio": float(ratio), "stop_reason": reason, "bond_coordination": float(bonds0),
           "coordination": float(2.0 * np.count_nonzero(touching) / red.size), "friction": o["restructure_friction"],
           "range": o["restructure_range"], "adhesion_force": ADHESION_FORCE, "neighbour_rebuilds": int(sim.rebuilds),
           "cpu_time": time.process_time() - t0}
    return sim.pos, rec


def _initial_structure(radii, box, seed):
    """A hard-sphere fluid of the structure spheres at Φ (Lubachevsky-Stillinger growth)."""
    from .lubachevsky import pack

    pk = pack(radii, volume_fraction=float(np.sum(4.0 / 3.0 * np.pi * radii**3) / np.prod(box)), seed=seed,
              progress=False)
    scale = float(box[0]) / float(pk.box[0])
    return np.asarray(pk.positions, dtype=np.float64) * scale


def _initial_voids(n_void, struct_pos, struct_radii, box, rv0, rng):
    """``n_void`` uniformly random points whose void sphere misses every structure sphere."""
    from scipy.spatial import cKDTree

    tree = cKDTree(np.mod(struct_pos, box), boxsize=box)
    reach = float(struct_radii.max()) + rv0
    out = np.empty((0, 3))
    tries = 0
    while out.shape[0] < n_void:
        tries += 1
        if tries > 1000:
            raise InfeasibleError("vem: no room for the void spheres between the structure spheres")
        cand = rng.random((2 * (n_void - out.shape[0]) + 16, 3)) * box
        cand = np.minimum(cand, np.nextafter(box, 0))
        near = tree.query_ball_point(cand, reach)
        ok = np.ones(cand.shape[0], bool)
        for q, lst in enumerate(near):
            if lst:
                d = np.linalg.norm((struct_pos[lst] - cand[q] + 0.5 * box) % box - 0.5 * box, axis=1)
                ok[q] = bool(np.all(d >= struct_radii[lst] + rv0))
        out = np.concatenate([out, cand[ok]])[:n_void]
    return out


def vem(
    n,
    volume_fraction=VEM_DEFAULTS["volume_fraction"],
    void_ratio=VEM_DEFAULTS["void_ratio"],
    *,
    seed=None,
    radius=1.0,
    growth_factor=VEM_DEFAULTS["growth_factor"],
    initial_void_radius=VEM_DEFAULTS["initial_void_radius"],
    normal_stiffness=VEM_DEFAULTS["normal_stiffness"],
    shear_stiffness=VEM_DEFAULTS["shear_stiffness"],
    void_normal_stiffness=VEM_DEFAULTS["void_normal_stiffness"],
    void_shear_stiffness=VEM_DEFAULTS["void_shear_stiffness"],
    friction=VEM_DEFAULTS["friction"],
    damping=VEM_DEFAULTS["damping"],
    ratio_tolerance=VEM_DEFAULTS["ratio_tolerance"],
    jam_overlap=VEM_DEFAULTS["jam_overlap"],
    check_every=VEM_DEFAULTS["check_every"],
    stage_steps=VEM_DEFAULTS["stage_steps"],
    max_stages=VEM_DEFAULTS["max_stages"],
    final_relaxation=VEM_DEFAULTS["final_relaxation"],
    structure_contacts=VEM_DEFAULTS["structure_contacts"],
    stiffness=VEM_DEFAULTS["stiffness"],
    restructure=VEM_DEFAULTS["restructure"],
    restructure_time=VEM_DEFAULTS["restructure_time"],
    restructure_window=VEM_DEFAULTS["restructure_window"],
    restructure_potential=VEM_DEFAULTS["restructure_potential"],
    restructure_bonds=VEM_DEFAULTS["restructure_bonds"],
    restructure_friction=VEM_DEFAULTS["restructure_friction"],
    restructure_range=VEM_DEFAULTS["restructure_range"],
    progress=None,
) -> Packing:
    """Heterogeneous pack by the void expansion method (VEM).

    The VEM structure set of §2.2 of 003_873b69fc71c74cf6.txt: structure spheres in the
    periodic cube of Eq. (5) of 003_873b69fc71c74cf6.txt are rearranged by the damped
    expansion of ``void_ratio * N`` void spheres (contact law Eq. (1) of
    003_873b69fc71c74cf6.txt, local damping Eq. (3) of 003_873b69fc71c74cf6.txt), which
    are deleted at the end.  The method, the growth factor, the relaxation and stop
    criteria are described in the module docstring of :mod:`polypack.generate.vem`
    and in ``docs/vem.md``.

    Parameters
    ----------
    n : int, SizeSet or array_like
        Number of structure spheres (>= 32, radius ``radius``), or their radii.
    volume_fraction : float
        Structure volume fraction Φ in (0, 0.6]; the seed uses 0.4.  Met exactly.
    void_ratio : float
        ``N_V / N`` > 0; the seed uses N_V = 1000 ... 16000 for N = 8000 (0.125 ... 2).
        Fewer voids give a more heterogeneous structure.
    seed : int or numpy.random.SeedSequence, optional
        Seeds the start (hard-sphere fluid and void positions); the run is deterministic
        after that, so one seed gives the same pack bit for bit on one platform.
    radius : float
        Structure sphere radius (user units) when ``n`` is a number (seed: r0 = 0.25 µm;
        the result depends on it only through the length scale).
    growth_factor : float
        Factor (> 1, <= 1.5) applied to the void radius per stage.
    initial_void_radius : float
        Initial void radius in units of the mean structure radius (0 < r_V0 <= 0.5).
    normal_stiffness, shear_stiffness : float
        kn, ks of structure-structure contacts (N/m; Table 1 of the seed: 100, 10).
    void_normal_stiffness, void_shear_stiffness : float
        kn,V and ks,V of every contact involving a void (N/m; seed: 1e2, 1e-2).
    friction : float
        Coulomb friction of the contacts (>= 0; default 0, frictionless).
    damping : float
        Local damping coefficient α in [0, 1).
    ratio_tolerance : float
        Relaxation criterion per stage: mean unbalanced force / mean contact force.
    jam_overlap : float
        Stop criterion: mean relative overlap of the void contacts left after a
        stage's relaxation at which the assembly counts as jammed.
    check_every, stage_steps, max_stages : int
        Steps between checks, steps per stage at most, stages at most.
    final_relaxation : {"project", "dynamics"}
        After the voids are deleted: ``"project"`` removes the overlaps by projections
        only (smallest moves; every compressed contact ends exactly touching);
        ``"dynamics"`` first relaxes the structure by the seed's zero-velocity steps
        (contacts unload and some open), then projects.
    structure_contacts : {"frictionless", "sticky"}
        Structure-structure contacts during the expansion: ``"frictionless"`` (default;
        the linear repulsive contact of the seed's DEM, contacts open freely) or
        ``"sticky"``: a structure pair that touches is bonded for good (a PFC contact bond
        about the touching distance, unbreakable, carrying tension and shear), a model of
        coagulating particles.  ``docs/vem.md`` compares both with Table 2 of the seed
        (sticky contacts lower both ``a`` and C).
    stiffness : {"contact", "particle"}
        Meaning of the four stiffnesses: ``"contact"`` (default) the springs of the
        contacts as described above; ``"particle"`` per-ball values combined in series
        per contact, ``k = k_1 k_2 / (k_1 + k_2)`` (the PFC 4 linear model of the seed,
        Table 1 of 003_873b69fc71c74cf6.txt): structure-structure ``kn / 2``,
        structure-void ``kn kn,V / (kn + kn,V)``, void-void ``kn,V / 2`` (shear alike).
    restructure : {"none", "coagulation", "adhesive"}
        After the voids are deleted and the overlaps removed: ``"none"`` (default, the
        repulsive VEM), ``"adhesive"`` (below, ``restructure_friction``) or
        ``"coagulation"``: the structure coagulates by the Brownian
        dynamics of :class:`polypack.generate.brownian.BrownianSimulation` (DLVO forces of
        :mod:`polypack.generate.dlvo` at the seed's scale r0 = 0.25 µm, surface potential
        ``restructure_potential``, bond model ``restructure_bonds``) until the bond
        coordination changes by less than 1 % over ``restructure_window`` or
        ``restructure_time`` is used up; then the overlaps are removed again.  Equal
        spheres only.  The seed's VEM mimics coagulation with swelling polymer particles
        (§2.2 of 003_873b69fc71c74cf6.txt); ``docs/vem.md`` compares both with Table 2.
    restructure_time, restructure_window : float
        Longest coagulation and its stability window, in Brownian times a²/D0.
    restructure_potential : float
        Surface potential Ψ0 (V) of the coagulation's DLVO forces (0: van der Waals only).
    restructure_bonds : {"tangential", "flexible"}
        Bond model of the coagulation (:func:`polypack.brownian`): ``"tangential"``
        (default; bonds resist sliding and rolling, rolling yields at a critical moment)
        or ``"flexible"`` (central bonds, free rolling: the structure keeps densifying, so
        the run lasts ``restructure_time``).
    restructure_friction, restructure_range : float
        ``restructure = "adhesive"`` (:class:`_Adhesive`): the structure pairs closer than
        ``1.01 (r_i + r_j)`` (the seed's bond rule, §2.2 of 003_873b69fc71c74cf6.txt) get PFC
        contact bonds (normal and shear springs ``kn``, ``ks``, no moment, unbreakable); every
        other pair with a surface gap below ``restructure_range`` (units of r0; default 0.3)
        attracts weakly (1e-3 kn r0), and new contacts are linear with Coulomb friction
        ``restructure_friction`` (default 0.1).  Damped DEM (Eq. (3) of
        003_873b69fc71c74cf6.txt) until PFC's unbalanced-force ratio is below 1e-3: the floppy
        parts of the network fold until every sphere is held, the rigid parts stay.  Any sizes.
    progress : bool, optional
        Progress bar (void diameter, coordination, unbalanced-force ratio); default when
        stderr is a terminal.

    Returns
    -------
    Packing
        Structure spheres only (positions folded into the box, the given radii and
        species), box of Eq. (5) of 003_873b69fc71c74cf6.txt, ``meta["vem"]`` with every parameter, the stop reason,
        the final void diameter, the stage history ``series`` (keys ``stage``,
        ``void_diameter`` in user units, ``total_fraction``, ``coordination``,
        ``void_contacts``, ``void_overlap``, ``structure_overlap``, ``ratio``, ``steps``)
        and ``meta["min_gap"]``.

    Raises
    ------
    InvalidInputError
        ``void_ratio <= 0``, Φ outside (0, 0.6], fewer than 32 spheres, bad parameters.
    InfeasibleError
        The box is too small for the voids (N too small), or the voids never jam within
        ``max_stages``.
    OverlapError
        If the returned structure has an overlap beyond :data:`OVERLAP_TOLERANCE`.
    KeyboardInterrupt
        Ctrl-C is deferred to the end of a kernel chunk and raised there as
        :class:`polypack.errors.Interrupted`; no partial pack is returned.
    """
    from .. import _interrupt

    radii, species = _structure_radii(n, radius)
    ns = radii.size
    # one declaration: every option is checked by its field of VEMOptions (as in a study and the CLI)
    o = _registry.check_call(VEMOptions, dict(
        volume_fraction=volume_fraction, void_ratio=void_ratio, growth_factor=growth_factor,
        initial_void_radius=initial_void_radius, normal_stiffness=normal_stiffness, shear_stiffness=shear_stiffness,
        void_normal_stiffness=void_normal_stiffness, void_shear_stiffness=void_shear_stiffness, friction=friction,
        damping=damping, ratio_tolerance=ratio_tolerance, jam_overlap=jam_overlap, check_every=check_every,
        stage_steps=stage_steps, max_stages=max_stages, final_relaxation=final_relaxation,
        structure_contacts=structure_contacts, stiffness=stiffness, restructure=restructure,
        restructure_time=restructure_time, restructure_window=restructure_window,
        restructure_potential=restructure_potential, restructure_bonds=restructure_bonds,
        restructure_friction=restructure_friction, restructure_range=restructure_range))
    _check_restructure(o, radii)
    n_void = int(round(o["void_ratio"] * ns))
    if n_void < 1:
        raise InvalidInputError(f"void_ratio={void_ratio!r}: gives {n_void} voids for N={ns}; need at least 1")

    ss = as_seed_sequence(seed)
    s_fluid, s_void = ss.spawn(2)
    t_wall = time.perf_counter()
    r0 = float(np.mean(radii))
    red = radii / r0
    asm, box, skin = _vem_assembly(red, ns, n_void, o, structure_contacts, s_fluid, s_void)
    bar = progress_bar(total=None, desc=f"vem N_V/N={o['void_ratio']:g}", progress=progress, unit="stage")
    with _interrupt.deferred():
        try:
            series, reason, stage, steps_total = _grow_voids(asm, red, box, ns, n_void, r0, skin, o, bar)
            _interrupt.check(f"vem interrupted after stage {stage}")
            fin = _finish_structure(asm, red, box, ns, skin, o, final_relaxation, ss)
        finally:
            bar.close()
    wpos = np.mod(fin["wpos"], box)
    wpos = np.minimum(wpos, np.nextafter(box, 0))
    wall = time.perf_counter() - t_wall
    scale = r0
    run = {
        "bonds_at_jamming": int(fin["n_bonds_jam"]),
        "mass_scaling": "one common mass for all spheres; time step 0.2 sqrt(m / k_max)",
        "stop_reason": reason,
        "stages": len(series["stage"]),
        "final_void_diameter": fin["void_diameter"] * r0,
        "coordination_at_jamming": series["coordination"][-1],
        "final_relaxation_steps": int(fin["fsteps"]),
        "final_relaxation_ratio": float(fin["fratio"]),
        "separation_sweeps": int(fin["sweeps"]),
        "separation_converged": bool(fin["status"] == fin["done"]),
        "overlap_before_separation": float(fin["worst"]),
        "steps": int(steps_total + fin["fsteps"]),
        "neighbour_rebuilds": int(asm.rebuilds),
        "wall_time": wall,
        "series": series,
    }
    if fin["coag"] is not None and o["restructure"] == "adhesive":
        run["adhesive_steps"] = fin["coag"]["steps"]
        run["adhesive_stop_reason"] = fin["coag"]["stop_reason"]
        run["restructure_record"] = fin["coag"]
    elif fin["coag"] is not None:  # the scalars also at the top level: a study's record keeps those of meta["vem"]
        coag = fin["coag"]
        run["coagulation_time"] = coag["time"]
        run["coagulation_bond_coordination"] = coag["bond_coordination"]
        run["coagulation_stop_reason"] = coag["stop_reason"]
        run["restructure_record"] = coag
    meta = {"generator": "vem", "seed": seed_record(ss), "vem": _record(o, ns, n_void, r0, run)}
    out = Packing(wpos * scale, radii, box * scale, species=species, meta=meta)
    gap = out.min_gap()
    out.meta["min_gap"] = float(gap)
    if gap < -OVERLAP_TOLERANCE:
        raise OverlapError(f"vem structure has a relative overlap {-gap:.3g} > tolerance {OVERLAP_TOLERANCE:g}")
    if fin["status"] != fin["done"]:
        warnings.warn("vem: overlap removal used its sweep budget", RuntimeWarning, stacklevel=2)
    return out


# ---------------------------------------------------------------- vem: the steps
def _check_restructure(o, radii):
    """Each restructuring's options are used only with it (``restructure='coagulation'`` or
    ``'adhesive'``); the coagulation needs equal spheres."""
    for key in ("restructure_time", "restructure_window", "restructure_potential", "restructure_bonds"):
        if o["restructure"] != "coagulation" and o[key] != VEM_DEFAULTS[key]:
            raise InvalidInputError(f"{key}={o[key]!r}: only used with restructure = 'coagulation'")
    for key in ("restructure_friction", "restructure_range"):
        if o["restructure"] != "adhesive" and o[key] != VEM_DEFAULTS[key]:
            raise InvalidInputError(f"{key}={o[key]!r}: only used with restructure = 'adhesive'")
    if o["restructure"] == "coagulation" and not np.all(radii == radii[0]):
        raise InvalidInputError(f"restructure='coagulation': needs equal spheres (the Brownian engine is "
                                f"monodisperse); radii range {radii.min():g} ... {radii.max():g}")


def _vem_assembly(red, ns, n_void, o, structure_contacts, s_fluid, s_void):
    """``(assembly, box, skin)`` in reduced units (mean radius 1): the box of Eq. (5) of
    003_873b69fc71c74cf6.txt, the fluid structure, the voids in its holes and their contacts."""
    phi, rv0 = o["volume_fraction"], o["initial_void_radius"]
    kn, ks, knv, ksv = o["normal_stiffness"], o["shear_stiffness"], o["void_normal_stiffness"], o["void_shear_stiffness"]
    mu, alpha = o["friction"], o["damping"]
    box_len = (float(np.sum(4.0 / 3.0 * np.pi * red**3)) / phi) ** (1.0 / 3.0)  # Eq. (5) of 003_873b69fc71c74cf6.txt (reduced units)
    box = np.full(3, box_len)
    rmax = float(red.max())
    skin = 0.2 * float(red.min())
    if 2.0 * (2.0 * rmax + skin) >= box_len:
        raise InfeasibleError(f"n={ns}: box of {box_len:.3g} radii too small for minimum-image contacts; use more "
                              "spheres")
    pos_s = _initial_structure(red, box, s_fluid)
    rng = np.random.default_rng(s_void)
    pos_v = _initial_voids(n_void, pos_s, red, box, rv0, rng)
    pos = np.concatenate([pos_s, pos_v])
    allr = np.concatenate([red, np.full(n_void, rv0)])
    if o["stiffness"] == "particle":
        # per-ball values in series per contact (PFC 4); reduced units: the structure contact is 1
        ser = lambda a, b: a * b / (a + b) if a + b > 0 else 0.0  # noqa: E731
        kss = ser(kn, kn)
        asm = _Assembly(pos, allr, box, ns, 1.0, ser(ks, ks) / kss, ser(kn, knv) / kss, ser(ks, ksv) / kss, mu,
                        alpha, skin, sticky=structure_contacts == "sticky",
                        void_void=(ser(knv, knv) / kss, ser(ksv, ksv) / kss))
    else:
        asm = _Assembly(pos, allr, box, ns, 1.0, ks / kn, knv / kn, ksv / kn, mu, alpha, skin,
                        sticky=structure_contacts == "sticky")
    return asm, box, skin


def _grow_voids(asm, red, box, ns, n_void, r0, skin, o, bar):
    """Grow the voids stage by stage, relaxing after each, until their mean relative overlap
    reaches ``jam_overlap``; returns ``(series, stop reason, stages, steps)``."""
    from .. import _interrupt
    from .._kernels import vem as V

    gf, tol, jam = o["growth_factor"], o["ratio_tolerance"], o["jam_overlap"]
    check_every, stage_steps, max_stages = o["check_every"], o["stage_steps"], o["max_stages"]
    box_len = float(box[0])
    rmax = float(red.max())
    vol = float(np.prod(box))
    vs = float(np.sum(4.0 / 3.0 * np.pi * red**3))
    series = {k: [] for k in ("stage", "void_diameter", "total_fraction", "coordination", "bonds", "void_contacts",
                              "void_overlap", "structure_overlap", "ratio", "steps")}
    steps_total = 0
    stage = 0
    while True:
        _interrupt.check(f"vem interrupted at stage {stage}")
        rv = float(asm.radii[ns]) if n_void else 0.0
        if 2.0 * (2.0 * max(rmax, rv * gf) + skin) >= box_len:
            raise InfeasibleError(
                f"n={ns}: the voids (radius {rv:.3g} r0) outgrow the box of {box_len:.3g} r0 before "
                "jamming; use more spheres or a larger void_ratio")
        asm.grow_voids(gf)
        stage += 1
        steps, ratio = asm.relax(tol, check_every, stage_steps, overlap_floor=UNLOADED)
        steps_total += steps
        st = asm.stats()
        rv = float(asm.radii[ns])
        c = 2.0 * st[V.C_STRUCT_CONTACTS] / ns
        vov = st[V.C_VOID_OVERLAP_SUM] / n_void  # summed relative void-contact overlap per void
        sov = st[V.C_STRUCT_OVERLAP_SUM] / st[V.C_STRUCT_CONTACTS] if st[V.C_STRUCT_CONTACTS] else 0.0
        total = (vs + n_void * 4.0 / 3.0 * np.pi * rv**3) / vol
        for key, val in (("stage", stage), ("void_diameter", 2.0 * rv * r0), ("total_fraction", total),
                         ("coordination", c), ("bonds", 2.0 * asm.bond_keys.size / ns),
                         ("void_contacts", 2.0 * st[V.C_VOID_CONTACTS] / (ns + n_void)),
                         ("void_overlap", vov), ("structure_overlap", sov), ("ratio", ratio),
                         ("steps", steps)):
            series[key].append(float(val) if key != "stage" and key != "steps" else int(val))
        bar.update(1)
        bar.set_postfix_str(f"d_V={2 * rv * r0:.3g} C={c:.2f} ratio={ratio:.2g} Φ_tot={total:.3f}")
        if vov >= jam:
            reason = (f"jammed: mean relative void overlap {vov:.3g} >= jam_overlap={jam:g} after the "
                      f"relaxation of stage {stage}")
            return series, reason, stage, steps_total
        if stage >= max_stages:
            raise InfeasibleError(f"vem: the voids did not jam within max_stages={max_stages} stages")


def _finish_structure(asm, red, box, ns, skin, o, final_relaxation, ss):
    """Remove the voids, relax (``final_relaxation``), separate the structure spheres and, with
    ``restructure='coagulation'``, restructure it; a dict of the positions and statistics."""
    from .. import _interrupt
    from .._kernels import vem as V

    void_diameter = 2.0 * float(asm.radii[ns])
    n_bonds_jam = asm.bond_keys.size
    asm.drop_voids()
    fsteps, fratio = 0, float("nan")
    if final_relaxation == "dynamics":
        asm.p[asm.K.P_MODE] = asm.K.MODE_RELAX
        fsteps, fratio = asm.relax(o["ratio_tolerance"], o["check_every"], 20 * o["stage_steps"],
                                   overlap_floor=UNLOADED)
    _interrupt.check("vem interrupted in the final relaxation")
    wpos, status, sweeps, worst = _separate(asm.pos, red, box, ns, skin)
    coag = None
    if o["restructure"] == "coagulation":
        wpos, coag = _coagulate(wpos, float(red[0]), box, o, ss.spawn(1)[0])
        _interrupt.check("vem interrupted in the coagulation")
        wpos, status, s2, _ = _separate(wpos, red, box, ns, skin)
        sweeps += s2
    elif o["restructure"] == "adhesive":
        wpos, coag = _adhere(wpos, red, box, o)
        _interrupt.check("vem interrupted in the adhesive restructuring")
        wpos, status, s3, _ = _separate(wpos, red, box, ns, skin)
        sweeps += s3
    return dict(wpos=wpos, status=status, done=V.SEPARATE_DONE, sweeps=sweeps, worst=worst, coag=coag,
                void_diameter=void_diameter, n_bonds_jam=n_bonds_jam, fsteps=fsteps, fratio=fratio)
