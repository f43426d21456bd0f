"""Bonded networks for the DEM tests: lattices and random packs.

``network(packing, i, j, shift, ...)`` builds a network with the attributes of the
BondNetwork contract of polypack.mechanics.network (i, j, shift, rest_length,
per-contact stiffnesses and strengths, packing).
"""

from __future__ import annotations

import numpy as np

import polypack as pp
from polypack.neighbors import pairs_within


class _Network:
    def __init__(self, packing, i, j, shift, rest, kn, ks, fnb, fsb):
        self.packing = packing
        self.i = np.asarray(i, np.int64)
        self.j = np.asarray(j, np.int64)
        self.shift = np.asarray(shift, np.int64)
        m = self.i.shape[0]
        self.rest_length = np.asarray(rest, float)
        self.normal_stiffness = np.full(m, float(kn))
        self.shear_stiffness = np.full(m, float(ks))
        self.normal_strength = np.full(m, float(fnb))
        self.shear_strength = np.full(m, float(fsb))
        self.n_bonds = m


def network(packing, i, j, shift=None, kn=100.0, ks=10.0, fnb=1e-4, fsb=1e-6, reference="stress-free"):
    pos = np.asarray(packing.positions)
    box = np.asarray(packing.box)
    i = np.asarray(i, np.int64)
    j = np.asarray(j, np.int64)
    if shift is None:
        shift = -np.round((pos[j] - pos[i]) / box).astype(np.int64)
    b = pos[j] + shift * box - pos[i]
    d = np.linalg.norm(b, axis=1)
    rest = d if reference == "stress-free" else packing.radii[i] + packing.radii[j]
    return _Network(packing, i, j, shift, rest, kn, ks, fnb, fsb)


def bonded(packing, epsilon=0.01, **kw):
    """Bonds between spheres closer than (1 + epsilon)(r_i + r_j)."""
    i, j, _ = pairs_within(packing.positions, packing.radii, packing.box, a=1.0 + epsilon)
    return network(packing, i, j, **kw)


_BASIS = {
    "fcc": (np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]]), np.sqrt(2.0)),
    "sc": (np.array([[0.0, 0.0, 0.0]]), 1.0),
    "bcc": (np.array([[0, 0, 0], [0.5, 0.5, 0.5]]), 2.0 / np.sqrt(3.0)),
}


def lattice(kind, cells, d=1.0, **kw):
    """Nearest-neighbour bonded lattice of spheres of diameter d (touching)."""
    basis, a_over_d = _BASIS[kind]
    a = a_over_d * d
    g = np.arange(cells)
    cell = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    pos = ((cell[:, None, :] + basis[None, :, :]).reshape(-1, 3) + 0.25) * a
    pk = pp.Packing(pos, np.full(pos.shape[0], 0.5 * d), np.full(3, cells * a))
    return bonded(pk, epsilon=1e-6, **kw)
