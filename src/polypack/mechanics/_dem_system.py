"""The DEM system of :func:`polypack.mechanics.dem.oscillatory_shear` and :func:`polypack.mechanics.dem.relax`:
the network read into plain arrays, the contact lists (bonds, then unbonded candidate pairs) and the
spheres with the plate copies, in the memory order of :mod:`polypack._kernels.dem`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidInputError

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
_NO_LAYERS = np.zeros(0)
_NO_LAYER_SAMPLES = np.zeros((1, 1))


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
