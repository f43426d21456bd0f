"""Pair counts per species pair on a grid, and their ideal-gas normalisations.

One kernel pass (``polypack._kernels.analysis.pair_histogram``) gives ordered-pair
counts in left-closed bins ``[k h, (k+1) h)`` for every species pair; K functions,
histogram RDFs and finite-difference RDFs all derive from these counts.

2D packs (disks) go through the same 3D kernels embedded as a slab one cell thick
(``z = 0``; the z separation is always 0, see :mod:`polypack.neighbors`), so counts
are exact in both dimensions; the normalisations use the ``dim``-dimensional
volumes.
"""

from __future__ import annotations

import numpy as np

from ..neighbors import _choose_cells_flat, choose_cells
from ._base import check_r_max


def kernel_frame(packing, reach_small):
    """``(positions, box, ncell)`` for the 3D cell kernels: 2D packs embedded as a slab.

    ``reach_small`` sets the cell size (see :func:`polypack.neighbors.choose_cells`);
    for a 2D pack the grid has one cell along the added z axis, whose length
    ``max(Lx, Ly)`` is never folded (every z separation is 0).
    """
    box = np.ascontiguousarray(packing.box, dtype=np.float64)
    pos = np.ascontiguousarray(packing.positions, dtype=np.float64)
    if packing.dim == 3:
        return pos, box, choose_cells(box, packing.n, reach_small)
    pos3 = np.ascontiguousarray(np.column_stack([pos, np.zeros(pos.shape[0])]))
    box3 = np.array([box[0], box[1], max(float(box.max()), 1.0)])
    return pos3, box3, _choose_cells_flat(box3, packing.n, reach_small)


def pair_counts(packing, x_max, nbins, scale="distance"):
    """Ordered-pair counts ``(K*K, nbins)`` in bins ``[k h, (k+1) h)``, ``h = x_max/nbins``.

    ``scale="distance"`` bins the centre distance, ``"contact"`` the contact-scaled
    distance ``d_ij / (r_i + r_j)``.
    """
    from .._kernels import analysis as kern

    box = np.ascontiguousarray(packing.box, dtype=np.float64)
    rad = np.ascontiguousarray(packing.radii, dtype=np.float64)
    sp = np.ascontiguousarray(packing.species, dtype=np.int64)
    nspecies = packing.n_species
    if scale == "distance":
        check_r_max(x_max, box)
        reach_small = 0.5 * x_max
        scaled = False
    else:
        reach = 2.0 * x_max * float(rad.max())
        check_r_max(reach, box, what=f"contact-scaled r_max={x_max:g} times the largest diameter, i.e.")
        reach_small = 2.0 * x_max * float(np.percentile(rad, 10))
        scaled = True
    pos, box, nc = kernel_frame(packing, reach_small)
    if not scaled:
        off = kern.half_shell_offsets(nc, box / nc, float(x_max))
        if off.shape[0] > 0:
            return kern.pair_histogram_distance(pos, sp, box, nspecies, float(x_max), int(nbins), nc, off)
    return kern.pair_histogram(pos, rad, sp, box, nspecies, float(x_max), int(nbins), scaled, nc)


def pair_norms(packing, scale="distance", normalization="finite_size"):
    """Ideal-gas weights ``W[k, m]`` such that expected counts are ``W * volume(x) / V``.

    For ``scale="distance"``: ``W = N_k (N_m - delta_km)`` (``"finite_size"``, unbiased for a
    Poisson process of fixed N) or ``N_k N_m`` (``"seed"``, Eq. (2) of 000_2cedc098acbd866b.txt and Eq. (5) of 000_2cedc098acbd866b.txt as printed). For ``scale="contact"``:
    ``W = sum_{i in k} sum_{j in m, j != i} (r_i + r_j)^dim`` (the ``j = i`` terms kept
    for ``"seed"``), so that the volume of a shell in the scaled coordinate
    ``x = d/(r_i + r_j)`` is ``4/3 pi (x_2^3 - x_1^3)`` (3D) or ``pi (x_2^2 - x_1^2)`` (2D).
    Also returns the total weight (all ordered pairs).
    """
    ns = packing.n_species
    sp = packing.species
    cnt = np.bincount(sp, minlength=ns).astype(np.float64)
    exact = normalization == "finite_size"
    if scale == "distance":
        w = np.outer(cnt, cnt)
        if exact:
            w -= np.diag(cnt)
        n = float(packing.n)
        total = n * (n - 1.0) if exact else n * n
        return w, total
    rad = packing.radii
    mom = np.stack([np.bincount(sp, weights=rad**p, minlength=ns) for p in range(4)])  # (4, ns)
    if packing.dim == 3:
        w = (
            np.outer(mom[3], mom[0])
            + 3.0 * np.outer(mom[2], mom[1])
            + 3.0 * np.outer(mom[1], mom[2])
            + np.outer(mom[0], mom[3])
        )
    else:  # (r_i + r_j)^2 summed over the pairs
        w = np.outer(mom[2], mom[0]) + 2.0 * np.outer(mom[1], mom[1]) + np.outer(mom[0], mom[2])
    self_terms = np.bincount(sp, weights=(2.0 * rad) ** packing.dim, minlength=ns)
    if exact:
        w -= np.diag(self_terms)
    total = float(w.sum())
    return w, total


def species_radii(packing):
    """Mean radius of each species (``a^(k)`` of seed 000); NaN for an empty label."""
    ns = packing.n_species
    cnt = np.bincount(packing.species, minlength=ns).astype(np.float64)
    s = np.bincount(packing.species, weights=packing.radii, minlength=ns)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(cnt > 0, s / np.maximum(cnt, 1), np.nan)
