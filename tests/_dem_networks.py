"""Bonded networks for the DEM tests: lattices and random packs (BondNetwork)."""

from __future__ import annotations

import numpy as np

import polypack as pp
from polypack.mechanics import BondNetwork


def bonded(packing, epsilon=0.01, kn=100.0, ks=10.0, fnb=1e-4, fsb=1e-6, reference="stress-free"):
    """Bonds between spheres closer than (1 + epsilon)(r_i + r_j)."""
    return BondNetwork.from_packing(packing, epsilon=epsilon, normal_stiffness=kn, shear_stiffness=ks,
                                    normal_strength=fnb, shear_strength=fsb, reference=reference)


_BASIS = {
    "fcc": (np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]]), np.sqrt(2.0)),
    "sc": (np.array([[0.0, 0.0, 0.0]]), 1.0),
    "bcc": (np.array([[0, 0, 0], [0.5, 0.5, 0.5]]), 2.0 / np.sqrt(3.0)),
}


def lattice(kind, cells, d=1.0, **kw):
    """Nearest-neighbour bonded lattice of touching spheres of diameter d."""
    basis, a_over_d = _BASIS[kind]
    a = a_over_d * d
    g = np.arange(cells)
    cell = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    pos = ((cell[:, None, :] + basis[None, :, :]).reshape(-1, 3) + 0.25) * a
    pk = pp.Packing(pos, np.full(pos.shape[0], 0.5 * d), np.full(3, cells * a))
    return bonded(pk, epsilon=1e-6, **kw)


class EmptyNetwork:
    """An object with the BondNetwork attributes and no bonds (BondNetwork itself refuses)."""

    def __init__(self, packing):
        self.packing = packing
        self.i = self.j = np.zeros(0, np.int64)
        self.shift = np.zeros((0, 3), np.int64)
        self.rest_length = self.normal_stiffness = self.shear_stiffness = np.zeros(0)
        self.normal_strength = self.shear_strength = np.zeros(0)
