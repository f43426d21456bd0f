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
from dataclasses import dataclass, field

import numpy as np

from .. import _interrupt
from .._util import progress_bar
from ..errors import Interrupted, InvalidInputError

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
_VOIGT_INDEX = {frozenset((1, 2)): 3, frozenset((0, 2)): 4, frozenset((0, 1)): 5}
_VOIGT_NAME = {3: "C44", 4: "C55", 5: "C66"}

#: Seed Table 1 of 003_873b69fc71c74cf6.txt (SI units) and the protocol of its §2.4.
DEFAULTS = {
    "radius": 0.25e-6,
    "normal_stiffness": 100.0,
    "shear_stiffness": 10.0,
    "normal_strength": 1e-4,
    "shear_strength": 1e-6,
    "damping": 0.9,
    "friction": 0.0,
    "density": 3690.0,
    "volume_fraction": 0.4,
    "frequency": 1.0,
    "amplitude": 1e-3,
    "cycles": 10,
}

BOUNDARIES = ("lees-edwards", "plates")

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
_NO_LAYERS = np.zeros(0)
_NO_LAYER_SAMPLES = np.zeros((1, 1))


class ShearInterrupted(Interrupted):
    """Raised when a run is interrupted (Ctrl-C, honoured at the end of a kernel chunk);
    ``.result`` (also ``.partial``) holds what was measured so far (``result.complete`` is
    False).  A :class:`polypack.errors.Interrupted`, hence a ``KeyboardInterrupt``."""

    def __init__(self, result):
        n = len(result.per_direction) if result is not None else 0
        super().__init__(f"oscillatory shear interrupted ({n} direction(s) measured, the last incomplete)",
                         partial=result)
        self.result = result


# ---------------------------------------------------------------- network input
@dataclass
class _Net:
    pos: np.ndarray
    radii: np.ndarray
    box: np.ndarray
    i: np.ndarray
    j: np.ndarray
    shift: np.ndarray
    rest: np.ndarray
    kn: np.ndarray
    ks: np.ndarray
    fnb: np.ndarray
    fsb: np.ndarray


def _network(network) -> _Net:
    """Read the BondNetwork contract attributes, check them, return plain arrays."""
    try:
        pk = network.packing
        i = np.asarray(network.i, dtype=np.int64)
        j = np.asarray(network.j, dtype=np.int64)
        shift = np.asarray(network.shift, dtype=np.float64)
        rest = np.asarray(network.rest_length, dtype=np.float64)
        kn = np.asarray(network.normal_stiffness, dtype=np.float64)
        ks = np.asarray(network.shear_stiffness, dtype=np.float64)
        fnb = np.asarray(network.normal_strength, dtype=np.float64)
        fsb = np.asarray(network.shear_strength, dtype=np.float64)
    except AttributeError as exc:
        raise InvalidInputError(f"network={type(network).__name__}: not a BondNetwork ({exc})") from None
    pos = np.asarray(pk.positions, dtype=np.float64)
    radii = np.asarray(pk.radii, dtype=np.float64)
    box = np.asarray(pk.box, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] != 3:
        raise InvalidInputError(f"network packing has dimension {pos.shape[-1]}; the DEM needs 3-D spheres")
    periodic = getattr(pk, "periodic", (True, True, True))
    if not all(bool(p) for p in np.broadcast_to(np.asarray(periodic, dtype=bool), (3,))):
        raise InvalidInputError(f"network packing periodic={tuple(periodic)}; the DEM needs a periodic box")
    m = i.shape[0]
    if m == 0:
        raise InvalidInputError("network has no bonds: nothing to shear (raise epsilon or check the pack)")
    if shift.shape != (m, 3):
        raise InvalidInputError(f"network.shift has shape {shift.shape}; expected ({m}, 3)")
    for name, arr in (("rest_length", rest), ("normal_stiffness", kn), ("shear_stiffness", ks),
                      ("normal_strength", fnb), ("shear_strength", fsb)):
        arr = np.broadcast_to(arr, (m,))
        if np.any(~(arr >= 0)):
            raise InvalidInputError(f"network.{name} has negative or NaN entries; must be >= 0")
    bc = lambda a: np.ascontiguousarray(np.broadcast_to(a, (m,)), dtype=np.float64)  # noqa: E731
    if np.any(bc(kn) <= 0):
        raise InvalidInputError("network.normal_stiffness must be > 0 on every bond")
    return _Net(pos.copy(), radii.copy(), box.copy(), i.copy(), j.copy(), shift.copy(), bc(rest), bc(kn),
                bc(ks), bc(fnb), bc(fsb))


def _masses(radii, density):
    mass = density * 4.0 / 3.0 * np.pi * radii**3
    return mass, 0.4 * mass * radii**2


def _omega_max(net: _Net, density: float) -> float:
    from ._dem_stiffness import bond_geometry, highest_frequency, stiffness_matrix

    _, _, n, li, lj = bond_geometry(net.pos, net.radii, np.diag(net.box), net.i, net.j, net.shift)
    K = stiffness_matrix(net.pos.shape[0], net.i, net.j, n, li, lj, net.kn, net.ks)
    mass, inertia = _masses(net.radii, density)
    try:
        w = highest_frequency(K, mass, inertia)
    except Exception as exc:  # scipy's ArpackError (no common base class) on an overflowing spectrum
        w, why = math.nan, f"{type(exc).__name__}"
    else:
        why = "not finite"
    if not (math.isfinite(w) and w > 0):
        raise InvalidInputError(
            f"the highest vibration frequency of this network cannot be computed ({why}; normal_stiffness up to "
            f"{float(np.max(net.kn)):.3g}, shear_stiffness up to {float(np.max(net.ks)):.3g}, density {density:.3g}): "
            "stiffnesses and density must keep k/m within float64 range (seed 003: kn = 100 N/m, 3690 kg/m³)")
    return w


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


# ---------------------------------------------------------------- contact lists
def _key_arrays(i, j, shift):
    """Canonical (i < j) keys of contacts: the pair (j, i, -shift) is the same contact."""
    swap = i > j
    a = np.where(swap, j, i)
    b = np.where(swap, i, j)
    s = np.where(swap[:, None], -shift, shift).astype(np.int64)
    return a, b, s


def _candidate_pairs(pos, radii, cell, periodic_axes, reach):
    """Pairs within ``r_i + r_j + reach`` in a (possibly tilted) cell: ``(i, j, shift)``."""
    from .._kernels.cells import pairs_within
    from ..neighbors import choose_cells

    L = np.diag(cell).copy()
    s = pos @ np.linalg.inv(cell).T
    k = np.zeros_like(s)
    search = np.empty_like(pos)
    box = L.copy()
    tilt = float(np.max(np.abs(cell - np.diag(L)) / L[None, :])) if pos.shape[0] else 0.0
    rmax = float(radii.max())
    b = reach + tilt * (2 * rmax + reach) * 3.0
    for ax in range(3):
        if periodic_axes[ax]:
            k[:, ax] = np.floor(s[:, ax])
            search[:, ax] = (s[:, ax] - k[:, ax]) * L[ax]
        else:
            lo = pos[:, ax].min()
            search[:, ax] = pos[:, ax] - lo + 2 * (2 * rmax + b)
            box[ax] = pos[:, ax].max() - lo + 4 * (2 * rmax + b)
    search = np.clip(search, 0.0, np.nextafter(box, 0))
    ncell = choose_cells(box, pos.shape[0], 2 * rmax + b)
    pi, pj, _ = pairs_within(search, radii, box, 1.0, b, np.asarray(ncell, np.int64))
    sw = s - k
    ds = sw[pj] - sw[pi]
    shift = np.zeros((pi.shape[0], 3))
    for ax in range(3):
        if periodic_axes[ax]:
            shift[:, ax] = -np.round(ds[:, ax]) - k[pj, ax] + k[pi, ax]
    # exact distance in the tilted cell
    bvec = pos[pj] + shift @ cell.T - pos[pi]
    keep = np.linalg.norm(bvec, axis=1) <= radii[pi] + radii[pj] + reach
    return pi[keep], pj[keep], shift[keep]


class _Contacts:
    """Bonds (fixed) followed by unbonded candidate pairs (rebuilt); kernel arrays."""

    def __init__(self, i, j, shift, rest, kn, ks, fnb, fsb, default_kn, default_ks):
        from .._kernels.contacts import BONDED

        self.n_bonds = i.shape[0]
        self.default_kn = float(default_kn)
        self.default_ks = float(default_ks)
        self.ci = i.astype(np.int64)
        self.cj = j.astype(np.int64)
        self.cshift = shift.astype(np.float64)
        self.ckn = kn.copy()
        self.cks = ks.copy()
        self.crest = rest.copy()
        self.cfnb = fnb.copy()
        self.cfsb = fsb.copy()
        self.cstate = np.full(self.n_bonds, BONDED, np.int64)
        self.cfs = np.zeros((self.n_bonds, 3))
        self.cfn = np.zeros(self.n_bonds)
        a, b, s = _key_arrays(i, j, shift)
        self._bond_keys = set(zip(a.tolist(), b.tolist(), map(tuple, s.tolist())))

    def rebuild(self, pos, radii, cell, periodic_axes, reach, kind):
        from .._kernels.contacts import CONTACT

        nb = self.n_bonds
        old = {}
        if self.ci.shape[0] > nb:
            a, b, s = _key_arrays(self.ci[nb:], self.cj[nb:], self.cshift[nb:])
            sign = np.where(self.ci[nb:] > self.cj[nb:], -1.0, 1.0)
            for q, key in enumerate(zip(a.tolist(), b.tolist(), map(tuple, s.tolist()))):
                if np.any(self.cfs[nb + q] != 0.0):
                    old[key] = self.cfs[nb + q] * sign[q]
        pi, pj, sh = _candidate_pairs(pos, radii, cell, periodic_axes, reach)
        moving = (kind[pi] == 0) | (kind[pj] == 0)  # pairs of two plate spheres never matter
        pi, pj, sh = pi[moving], pj[moving], sh[moving]
        if pi.shape[0]:
            a, b, s = _key_arrays(pi, pj, sh)
            keys = list(zip(a.tolist(), b.tolist(), map(tuple, s.tolist())))
            keep = np.array([k not in self._bond_keys for k in keys], dtype=bool)
            pi, pj, sh = pi[keep], pj[keep], sh[keep]
            keys = [k for k, kk in zip(keys, keep) if kk]
        else:
            keys = []
        m = pi.shape[0]
        fs = np.zeros((m, 3))
        for q, key in enumerate(keys):
            f = old.get(key)
            if f is not None:
                fs[q] = f * (-1.0 if pi[q] > pj[q] else 1.0)
        self.ci = np.concatenate([self.ci[:nb], pi.astype(np.int64)])
        self.cj = np.concatenate([self.cj[:nb], pj.astype(np.int64)])
        self.cshift = np.concatenate([self.cshift[:nb], sh])
        self.ckn = np.concatenate([self.ckn[:nb], np.full(m, self.default_kn)])
        self.cks = np.concatenate([self.cks[:nb], np.full(m, self.default_ks)])
        self.crest = np.concatenate([self.crest[:nb], radii[pi] + radii[pj]])
        self.cfnb = np.concatenate([self.cfnb[:nb], np.full(m, np.inf)])
        self.cfsb = np.concatenate([self.cfsb[:nb], np.full(m, np.inf)])
        self.cstate = np.concatenate([self.cstate[:nb], np.full(m, CONTACT, np.int64)])
        self.cfs = np.concatenate([self.cfs[:nb], fs])
        self.cfn = np.concatenate([self.cfn[:nb], np.zeros(m)])

    def args(self):
        return (self.ci, self.cj, self.cshift, self.ckn, self.cks, self.crest, self.cfnb, self.cfsb,
                self.cstate, self.cfs, self.cfn)


# ---------------------------------------------------------------- the simulation system
class _System:
    """Spheres (sample and, for plates, the plate copies), contacts and the kernel state."""

    def __init__(self, net: _Net, pos, density_scaled, boundary, g, a, friction, layers=3):
        from .._kernels import dem as K

        self.K = K
        n = pos.shape[0]
        self.n_sample = n
        box = net.box
        # memory order: spheres sorted by cell (neighbours close in memory), bonds by first end
        ncl = np.maximum(1, np.floor(box / (4.0 * float(np.mean(net.radii)))).astype(np.int64))
        cidx = np.floor(np.mod(pos, box) / box * ncl).astype(np.int64)
        cidx = np.minimum(cidx, ncl - 1)
        perm = np.lexsort((cidx[:, 2], cidx[:, 1], cidx[:, 0]))
        inv = np.empty_like(perm)
        inv[perm] = np.arange(n)
        self.perm = perm  # system sphere k is network sphere perm[k]
        pos = pos[perm]
        radii = net.radii[perm]
        i, j = inv[net.i], inv[net.j]
        order = np.lexsort((j, i))
        self.bond_order = order  # system bond c is network bond order[c]
        i, j, shift = i[order], j[order], net.shift[order]
        rest, kn, ks, fnb, fsb = (net.rest[order], net.kn[order], net.ks[order], net.fnb[order],
                                  net.fsb[order])
        kind = np.zeros(n, np.int64)
        self.periodic_axes = [True, True, True]
        if boundary == "plates":
            self.periodic_axes[g] = False
            # wrap the sample into the cell along g, keep bonds consistent
            wrap = np.floor(pos[:, g] / box[g])
            pos = pos.copy()
            pos[:, g] -= wrap * box[g]
            shift = shift.copy()
            shift[:, g] += wrap[j] - wrap[i]
            thick = layers * 2.0 * float(np.mean(radii))
            bottom_src = np.flatnonzero(pos[:, g] > box[g] - thick)  # copied below (fixed)
            top_src = np.flatnonzero(pos[:, g] < thick)  # copied above (driven)
            ghost_pos = [pos]
            ghost_r = [radii]
            ghost_kind = [kind]
            idx_bottom = -np.ones(n, np.int64)
            idx_top = -np.ones(n, np.int64)
            nxt = n
            pb = pos[bottom_src].copy()
            pb[:, g] -= box[g]
            idx_bottom[bottom_src] = nxt + np.arange(bottom_src.size)
            nxt += bottom_src.size
            pt = pos[top_src].copy()
            pt[:, g] += box[g]
            idx_top[top_src] = nxt + np.arange(top_src.size)
            nxt += top_src.size
            ghost_pos += [pb, pt]
            ghost_r += [radii[bottom_src], radii[top_src]]
            ghost_kind += [np.full(bottom_src.size, K.KIND_FIXED), np.full(top_src.size, K.KIND_DRIVEN)]
            cross = shift[:, g] != 0
            if np.any(np.abs(shift[:, g]) > 1):
                raise InvalidInputError("a bond spans more than one box length along the plate normal")
            ii, jj, ss = [i[~cross]], [j[~cross]], [shift[~cross]]
            props = [np.arange(i.shape[0])[~cross]]
            for c in np.flatnonzero(cross):
                up = shift[c, g] > 0  # j's image lies above i
                s_in = shift[c].copy()
                s_in[g] = 0.0
                # lo sits near the top of the cell and bonds to the upper copy of hi, which sits
                # near the bottom and bonds to the lower copy of lo; s_lh: shift lo -> hi (other axes)
                lo, hi = (i[c], j[c]) if up else (j[c], i[c])
                s_lh = s_in if up else -s_in
                t_hi = idx_top[hi]
                b_lo = idx_bottom[lo]
                if t_hi < 0 or b_lo < 0:
                    raise InvalidInputError("plate layers too thin for the bonds crossing the boundary")
                ii += [np.array([lo]), np.array([hi])]
                jj += [np.array([t_hi]), np.array([b_lo])]
                ss += [s_lh[None, :], -s_lh[None, :]]
                props += [np.array([c]), np.array([c])]
            i = np.concatenate(ii)
            j = np.concatenate(jj)
            shift = np.concatenate(ss)
            pr = np.concatenate(props)
            rest, kn, ks, fnb, fsb = rest[pr], kn[pr], ks[pr], fnb[pr], fsb[pr]
            pos = np.concatenate(ghost_pos)
            radii = np.concatenate(ghost_r)
            kind = np.concatenate(ghost_kind)
            self.bond_source = order[pr]
        else:
            self.bond_source = order
        self.pos = np.ascontiguousarray(pos, dtype=np.float64)
        self.pos0 = self.pos.copy()
        self.radii = np.ascontiguousarray(radii)
        self.kind = kind
        self.mass, self.inertia = _masses(self.radii, density_scaled)
        self.vel = np.zeros_like(self.pos)
        self.omg = np.zeros_like(self.pos)
        self.h0 = np.diag(box).astype(np.float64)
        self.box = box
        self.contacts = _Contacts(i, j, shift, rest, kn, ks, fnb, fsb, float(np.median(net.kn)),
                                  float(np.median(net.ks)))
        self.reach = 0.1 * float(np.mean(net.radii))
        self.xbuild = self.pos.copy()
        self.st = np.zeros(K.N_ST)
        self.friction = friction

    def rebuild(self, gamma, g, a, boundary):
        cell = self.h0.copy()
        if boundary == "lees-edwards":
            cell[a, g] += gamma * self.box[g]
        self.contacts.rebuild(self.pos, self.radii, cell, self.periodic_axes, self.reach, self.kind)
        self.xbuild = self.pos.copy()
        self.st[self.K.ST_GAMMA_BUILD] = gamma


# ---------------------------------------------------------------- relaxation
@dataclass
class RelaxResult:
    """Outcome of :func:`relax`: relaxed positions and the unbalanced-force history."""

    positions: np.ndarray
    steps: int
    unbalanced_force: np.ndarray  # mean |F| over spheres at each check
    contact_force: np.ndarray  # mean contact force at each check
    criterion: str
    converged: bool
    time_step: float
    max_displacement: float = 0.0
    mean_displacement: float = 0.0

    @property
    def unbalanced_ratio(self) -> float:
        """Final mean unbalanced force over the mean contact force (PFC's ratio)."""
        cf = self.contact_force[-1] if self.contact_force.size else 0.0
        return float(self.unbalanced_force[-1] / cf) if cf > 0 else 0.0

    def to_dict(self) -> dict:
        return {"steps": self.steps, "criterion": self.criterion, "converged": self.converged,
                "max_displacement": self.max_displacement, "mean_displacement": self.mean_displacement,
                "time_step": self.time_step, "unbalanced_ratio": self.unbalanced_ratio,
                "unbalanced_force": self.unbalanced_force.tolist(),
                "contact_force": self.contact_force.tolist()}


def relax(network, check_every: int = 100, tolerance: float = 1e-3, patience: int = 3,
          max_steps: int = 200_000, density: float = DEFAULTS["density"], progress=None) -> RelaxResult:
    """The seed's relaxation: steps with all velocities reset to zero after each one.

    §2.2 of 003_873b69fc71c74cf6.txt relaxes the bonded structures (bonds installed at
    ``d < (1 + ε) 2 r0``; with PFC's zero reference gap they start in tension) by
    calculation steps after each of which the translational and rotational velocities
    are set to zero, "aborted as soon as the mean unbalanced force in the structure has
    decreased to a constant value".  Criterion used here: every ``check_every`` steps
    the mean unbalanced force ``F̄_u`` (mean ``|F|`` over spheres) is compared with its
    smallest earlier value; the run stops when it has failed to fall by more than the
    relative ``tolerance`` at ``patience`` consecutive checks, or when it is below
    ``1e-12`` of the mean contact force, or after ``max_steps``.

    Each step is a gradient step ``x += F dt² / m`` with ``dt`` 0.9 times the stability
    limit ``sqrt(2) / ω_max`` of this iteration (independent of the density, which only
    rescales ``dt``).

    Returns
    -------
    RelaxResult
        ``positions`` (unwrapped centres), the history and the criterion met.
    """
    from .._kernels import dem as K

    net = _network(network)
    for name, v, lo in (("check_every", check_every, 1), ("patience", patience, 1), ("max_steps", max_steps, 1)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
            raise InvalidInputError(f"{name}={v!r}: must be an integer >= {lo}")
    if not (tolerance > 0):
        raise InvalidInputError(f"tolerance={tolerance!r}: must be > 0")
    dt = 0.9 * math.sqrt(2.0) / _omega_max(net, density)
    sys_ = _System(net, net.pos.copy(), density, "lees-edwards", 2, 0, 0.0)
    sys_.reach = 0.0  # no unbonded contacts during relaxation (none exist in a non-overlapping pack)
    p = _params(K, dt, 1.0, 0.0, 1.0, 0.0, 0.0, float(np.prod(net.box)), net.box[2], 0, 2, K.MODE_RELAX,
                check_every, 0.0)
    cap = max_steps // check_every + 2
    samples = np.zeros((cap, K.N_S))
    ns = 0
    best = np.inf
    bad = 0
    criterion = f"max_steps={max_steps} reached"
    converged = False
    bar = progress_bar(total=max_steps, desc="relax", progress=progress, unit="step")
    try:
        done = 0
        while done < max_steps:
            nstep = min(check_every, max_steps - done)
            _, steps, ns = K.run(nstep, sys_.pos, sys_.vel, sys_.omg, sys_.radii, sys_.mass, sys_.inertia,
                                 sys_.kind, sys_.pos0, sys_.h0, *sys_.contacts.args(), p, sys_.st, samples, ns,
                                 sys_.xbuild, _NO_LAYERS, _NO_LAYER_SAMPLES)
            done += steps
            bar.update(steps)
            fu = samples[ns - 1, K.S_UNBALANCED]
            fc = samples[ns - 1, K.S_CONTACT_FORCE]
            if fc > 0 and fu <= 1e-12 * fc:
                criterion = "mean unbalanced force below 1e-12 of the mean contact force"
                converged = True
                break
            if fu < best * (1.0 - tolerance):
                best = fu
                bad = 0
            else:
                bad += 1
                if bad >= patience:
                    criterion = (f"mean unbalanced force stopped decreasing (less than {tolerance:g} relative "
                                 f"over {patience} checks of {check_every} steps)")
                    converged = True
                    break
    finally:
        bar.close()
    out = np.empty_like(net.pos)
    out[sys_.perm] = sys_.pos[: net.pos.shape[0]]
    moved = np.linalg.norm(out - net.pos, axis=1)
    return RelaxResult(out, int(sys_.st[K.ST_STEP]),
                       samples[:ns, K.S_UNBALANCED].copy(), samples[:ns, K.S_CONTACT_FORCE].copy(), criterion,
                       converged, dt, float(moved.max()), float(moved.mean()))


def _params(K, dt, omega, amplitude, ramp, alpha, mu, volume, length, a, g, mode, every, skin):
    p = np.zeros(K.N_P)
    p[K.P_DT] = dt
    p[K.P_OMEGA] = omega
    p[K.P_AMPLITUDE] = amplitude
    p[K.P_RAMP] = ramp
    p[K.P_ALPHA] = alpha
    p[K.P_MU] = mu
    p[K.P_VOLUME] = volume
    p[K.P_LENGTH] = length
    p[K.P_AXIS_A] = a
    p[K.P_AXIS_G] = g
    p[K.P_MODE] = mode
    p[K.P_SAMPLE_EVERY] = every
    p[K.P_SKIN] = skin
    return p


# ---------------------------------------------------------------- results
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
    dirs, frequency, amplitude, cycles, ramp = o["dirs"], o["frequency"], o["amplitude"], o["cycles"], o["ramp"]
    steps_per_cycle, samples_per_cycle, every = o["steps_per_cycle"], o["samples_per_cycle"], o["every"]
    safety, density, layers, measurement_layers = o["safety"], o["density"], o["layers"], o["measurement_layers"]
    with np.errstate(over="ignore"):  # the squared frequency k/m of the stiffest bond on the lightest sphere
        w2 = max(float(np.max(net.kn)), float(np.max(net.ks))) / float(np.min(_masses(net.radii, density)[0]))
    if not (math.isfinite(w2) and w2 < 1e250):
        raise InvalidInputError(
            f"normal_stiffness up to {float(np.max(net.kn)):.3g}, shear_stiffness up to {float(np.max(net.ks)):.3g} "
            f"over the lightest sphere's mass at density {density:.3g}: k/m = {w2:.3g} is beyond float64 dynamics "
            "(seed 003: kn = 100 N/m, 3690 kg/m³)")
    # strength check: the bond loads of an affine shear of the full amplitude along each
    # direction; more than half the bonds beyond their strength means the amplitude is
    # beyond the bond strength (single bonds may break: breakage is part of the model)
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

    # rigidity: the exact static tensor of the same bonds
    static = et = None
    if check_rigidity:
        t_rig = time.perf_counter()
        et = _rigidity(network)
        t_rig = time.perf_counter() - t_rig
    if et is not None:
        voigt = [_VOIGT_INDEX[frozenset((a, g))] for (g, a) in dirs]
        static = float(np.mean([et.stiffness[k, k] for k in voigt]))
        if not et.rigid or not static > 0:
            reason = et.floppy_reason or "the static shear moduli of the directions run are zero"
            return ShearResult(
                storage_modulus=0.0, loss_modulus=None, storage_modulus_sd=0.0, loss_modulus_sd=None,
                per_direction=[], series=[], boundary=boundary, frequency=frequency, amplitude=amplitude,
                cycles=cycles, ramp_cycles=ramp, discard_cycles=int(discard_cycles),
                time_step=1.0 / (frequency * steps_per_cycle), critical_time_step=None, mass_scale=None,
                density=density, steps_per_cycle=steps_per_cycle, inertial_error=None,
                wall_time=time.perf_counter() - t_start, particle_steps_per_second=None, complete=True,
                timings={"rigidity": t_rig}, status="floppy", problems=[f"floppy: {reason}"], rigid=False,
                static_storage_modulus=0.0, floppy_reason=reason,
                parameters={"damping": damping, "friction": friction, "safety": safety, "layers": layers,
                            "trajectory": None, "trajectory_frames": 0, "samples_per_cycle": samples_per_cycle,
                            "seed": seed, "n_bonds": int(net.i.shape[0]), "n_particles": int(net.pos.shape[0]),
                            "directions": [list(d) for d in dirs]})

    # time step and mass scaling
    t_crit0 = time.perf_counter()
    omega_max1 = _omega_max(net, density)  # at the physical density
    timings = {"critical_step": time.perf_counter() - t_crit0, "relaxation": 0.0, "relaxation_cpu": 0.0}
    if check_rigidity:
        timings["rigidity"] = t_rig
    dt_crit1 = 2.0 / omega_max1
    dt = 1.0 / (frequency * steps_per_cycle)
    if mass_scale is None:
        mass_scale = (dt / (safety * dt_crit1)) ** 2
    else:
        mass_scale = _positive("mass_scale", mass_scale)
    dt_crit = dt_crit1 * math.sqrt(mass_scale)
    if dt > dt_crit:
        raise InvalidInputError(
            f"time step {dt:.3g} (1/(frequency*steps_per_cycle)) is above the critical step {dt_crit:.3g} at "
            f"mass_scale={mass_scale:.3g}; raise steps_per_cycle or mass_scale")
    rho = density * mass_scale

    # relaxation
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

    volume = float(np.prod(net.box))
    omega = 2.0 * np.pi * frequency
    total = steps_per_cycle * cycles + 1  # one more step records the state at the end of the last cycle
    if trajectory_every is None:
        trajectory_every = max(1, steps_per_cycle // 20)
    trajectory_every = _positive("trajectory_every", trajectory_every, integer=True)
    import contextlib

    stack = contextlib.ExitStack()
    traj = stack.enter_context(_Trajectory(trajectory)) if trajectory is not None else None
    per_dir, series = [], []
    bar = progress_bar(total=total * len(dirs), desc=f"shear ({boundary})", progress=progress, unit="step")
    n_part = 0
    steps_run = 0
    interrupted = False
    section = _interrupt.deferred()
    section.__enter__()
    try:
        for (g, a) in dirs:
            t_dir0, c_dir0 = time.perf_counter(), time.process_time()
            t_kernel = t_rebuild = 0.0
            n_rebuild = 1
            sys_ = _System(net, pos_start.copy(), rho, boundary, g, a, friction, layers)
            n_free = int(np.sum(sys_.kind == K.KIND_FREE))
            t_rb = time.perf_counter()
            sys_.rebuild(0.0, g, a, boundary)
            t_rebuild += time.perf_counter() - t_rb
            # start on the affine flow of the first cycle (no jolt at t = 0)
            a1 = amplitude * min(1.0, 1.0 / ramp)
            gdot0 = a1 * omega
            free = sys_.kind == K.KIND_FREE
            sys_.vel[free, a] = gdot0 * sys_.pos[free, g]
            c3 = 3 - a - g
            sgn = 1.0 if (g - a) % 3 == 2 else -1.0
            sys_.omg[free, c3] = 0.5 * gdot0 * sgn
            mode = K.MODE_LEES_EDWARDS if boundary == "lees-edwards" else K.MODE_PLATES
            p = _params(K, dt, omega, amplitude, float(ramp), damping, friction, volume, float(net.box[g]), a, g,
                        mode, every, sys_.reach)
            samples = np.zeros((cycles * samples_per_cycle + 1, K.N_S))
            if boundary == "plates":
                # measurement slabs: `measurement_layers` equal slabs across the sample [0, L)
                edges_all = np.linspace(0.0, float(net.box[g]), measurement_layers + 1)
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
                    steps_run += steps
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
                        bar.set_postfix(cycle=f"{done / steps_per_cycle:.1f}/{cycles}",
                                        steps_s=f"{done / el:.3g}")
                    if _interrupt.consume():  # Ctrl-C: stop at this safe point (end of a chunk)
                        raise KeyboardInterrupt
            except KeyboardInterrupt:
                interrupted = True
            row, ser = _direction_result(K, samples[:ns], g, a, omega, amplitude, ramp, discard_cycles,
                                         samples_per_cycle, boundary, sys_, frequency, complete=not interrupted,
                                         layers=layer_samples[:ns] if boundary == "plates" else None,
                                         edges=edges_all)
            if row is not None:
                row.update(seconds=time.perf_counter() - t_dir0, cpu_seconds=time.process_time() - c_dir0,
                           kernel_seconds=t_kernel, rebuild_seconds=t_rebuild, rebuilds=n_rebuild)
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
    wall = time.perf_counter() - t_start
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
    res = ShearResult(
        storage_modulus=gmean, loss_modulus=float(np.mean(gpp)) if gpp.size else math.nan,
        storage_modulus_sd=sd(gp), loss_modulus_sd=sd(gpp), per_direction=per_dir, series=series,
        boundary=boundary, frequency=frequency, amplitude=amplitude, cycles=cycles, ramp_cycles=ramp,
        discard_cycles=int(discard_cycles), time_step=dt, critical_time_step=dt_crit, mass_scale=mass_scale,
        density=rho, steps_per_cycle=steps_per_cycle, inertial_error=inertial, wall_time=wall,
        particle_steps_per_second=n_part / wall if wall > 0 else math.nan, relaxation=relax_rec,
        complete=not interrupted, status=status, problems=problems,
        rigid=None if et is None else True, static_storage_modulus=static,
        timings={**timings, "directions": float(sum(r["seconds"] for r in per_dir))},
        parameters={"damping": damping, "friction": friction, "safety": safety, "layers": layers,
                    "trajectory": str(trajectory) if trajectory is not None and not interrupted else None,
                    "trajectory_frames": traj.frames if traj is not None else 0,
                    "samples_per_cycle": samples_per_cycle, "seed": seed, "n_bonds": int(net.i.shape[0]),
                    "n_particles": int(net.pos.shape[0]), "directions": [list(d) for d in dirs]},
    )
    if interrupted:
        raise ShearInterrupted(res)
    return res


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
