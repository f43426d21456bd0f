"""numba kernels of :mod:`polypack.analysis`: pair histograms, window counts, nearest surfaces.

All kernels take flat float64/int64 arrays, use the cell grid of
:mod:`polypack._kernels.cells` (``build_cells``) and its ``min_image``; no pair list
is stored, so memory stays O(N + bins) however many pairs fall within the cutoff.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .cells import _larger, build_cells, min_image


@njit(cache=True)
def _cell_range(reach, cl, ncell, k):
    """Half-width in cells of the search along axis ``k``; -1 means the whole axis."""
    r = int(np.ceil(reach / cl[k]))
    if 2 * r + 1 >= ncell[k]:
        return -1
    return r


@njit(cache=True)
def pair_histogram(pos, radii, species, box, nspecies, x_max, nbins, scaled, ncell):
    """Ordered-pair counts per species pair in left-closed bins ``[k h, (k+1) h)``.

    A coordinate within 1e-9 bin widths below an edge counts in the bin that starts
    there, so lattice distances that sit exactly on a grid point land in the bin they
    open whatever the round-off of ``k h``.

    Parameters
    ----------
    pos : (N, 3) float64
    radii : (N,) float64
    species : (N,) int64, values in ``0..nspecies-1``
    box : (3,) float64
    nspecies : int
    x_max : float
        Largest binned coordinate; ``h = x_max / nbins``.
    nbins : int
    scaled : bool
        False: the coordinate is the centre distance ``d``. True: the contact-scaled
        distance ``d / (r_i + r_j)``.
    ncell : (3,) int64
        Cells per axis.

    Returns
    -------
    counts : (nspecies * nspecies, nbins) int64
        ``counts[k * nspecies + m, b]`` is the number of ordered pairs ``(i, j)``,
        ``i`` of species ``k``, ``j`` of species ``m``, ``j != i``, whose coordinate
        lies in bin ``b``. Each unordered pair is found once (from its larger sphere)
        and added to both orders.
    """
    n = pos.shape[0]
    counts = np.zeros((nspecies * nspecies, nbins), np.int64)
    if n < 2:
        return counts
    cell_of, start, order = build_cells(pos, box, ncell)
    cl = np.empty(3, np.float64)
    for k in range(3):
        cl[k] = box[k] / ncell[k]
    h = x_max / nbins
    inv_h = 1.0 / h
    lo = np.empty(3, np.int64)
    hi = np.empty(3, np.int64)
    full = np.zeros(3, np.bool_)
    cc = np.empty(3, np.int64)
    for i in range(n):
        if scaled:
            reach = 2.0 * x_max * radii[i]
        else:
            reach = x_max
        ic = cell_of[i]
        cc[2] = ic % ncell[2]
        cc[1] = (ic // ncell[2]) % ncell[1]
        cc[0] = ic // (ncell[1] * ncell[2])
        for k in range(3):
            r = _cell_range(reach, cl, ncell, k)
            if r < 0:
                full[k] = True
                lo[k] = 0
                hi[k] = ncell[k] - 1
            else:
                full[k] = False
                lo[k] = -r
                hi[k] = r
        si = species[i]
        for ox in range(lo[0], hi[0] + 1):
            x = ox if full[0] else (cc[0] + ox) % ncell[0]
            for oy in range(lo[1], hi[1] + 1):
                y = oy if full[1] else (cc[1] + oy) % ncell[1]
                for oz in range(lo[2], hi[2] + 1):
                    z = oz if full[2] else (cc[2] + oz) % ncell[2]
                    c = (x * ncell[1] + y) * ncell[2] + z
                    for s in range(start[c], start[c + 1]):
                        j = order[s]
                        if j == i or not _larger(i, j, radii):
                            continue
                        dx = min_image(pos[j, 0] - pos[i, 0], box[0])
                        dy = min_image(pos[j, 1] - pos[i, 1], box[1])
                        dz = min_image(pos[j, 2] - pos[i, 2], box[2])
                        d = np.sqrt(dx * dx + dy * dy + dz * dz)
                        if scaled:
                            xv = d / (radii[i] + radii[j])
                        else:
                            xv = d
                        b = int(np.floor(xv * inv_h + 1e-9))
                        if b >= nbins:
                            continue
                        sj = species[j]
                        counts[si * nspecies + sj, b] += 1
                        counts[sj * nspecies + si, b] += 1
    return counts


@njit(cache=True)
def half_shell_offsets(ncell, cl, r_max):
    """Neighbour-cell offsets for a half-shell sweep: each unordered pair of cells once.

    Offsets within ``R = ceil(r_max / cl)`` cells per axis that are lexicographically
    positive, minus those whose closest points are farther apart than ``r_max``.
    Returns ``(M, 3)`` int64, or an empty array when a grid axis is too short for the
    offsets to be distinct (``ncell < 2 R + 1``).
    """
    rr = np.empty(3, np.int64)
    for k in range(3):
        rr[k] = int(np.ceil(r_max / cl[k]))
        if ncell[k] < 2 * rr[k] + 1:
            return np.empty((0, 3), np.int64)
    cap = (2 * rr[0] + 1) * (2 * rr[1] + 1) * (2 * rr[2] + 1)
    out = np.empty((cap, 3), np.int64)
    m = 0
    for ox in range(-rr[0], rr[0] + 1):
        for oy in range(-rr[1], rr[1] + 1):
            for oz in range(-rr[2], rr[2] + 1):
                if ox < 0 or (ox == 0 and oy < 0) or (ox == 0 and oy == 0 and oz <= 0):
                    continue
                gx = max(abs(ox) - 1, 0) * cl[0]
                gy = max(abs(oy) - 1, 0) * cl[1]
                gz = max(abs(oz) - 1, 0) * cl[2]
                if gx * gx + gy * gy + gz * gz > r_max * r_max:
                    continue
                out[m, 0] = ox
                out[m, 1] = oy
                out[m, 2] = oz
                m += 1
    return out[:m].copy()


@njit(cache=True)
def pair_histogram_distance(pos, species, box, nspecies, r_max, nbins, ncell, offsets):
    """Centre-distance pair histogram by a half-shell cell sweep (fast path).

    Same result as :func:`pair_histogram` with ``scaled=False``; the spheres are
    reordered by cell for contiguous memory access and every pair of neighbouring
    cells is visited once (``offsets`` from :func:`half_shell_offsets`).
    """
    n = pos.shape[0]
    counts = np.zeros((nspecies * nspecies, nbins), np.int64)
    cell_of, start, order = build_cells(pos, box, ncell)
    x = np.empty(n)
    y = np.empty(n)
    z = np.empty(n)
    s = np.empty(n, np.int64)
    for t in range(n):
        q = order[t]
        x[t] = pos[q, 0]
        y[t] = pos[q, 1]
        z[t] = pos[q, 2]
        s[t] = species[q]
    inv_h = nbins / r_max
    r2max = r_max * r_max
    nc = ncell[0] * ncell[1] * ncell[2]
    noff = offsets.shape[0]
    lx, ly, lz = box[0], box[1], box[2]
    for c in range(nc):
        cz = c % ncell[2]
        cy = (c // ncell[2]) % ncell[1]
        cx = c // (ncell[1] * ncell[2])
        a0 = start[c]
        a1 = start[c + 1]
        if a0 == a1:
            continue
        # pairs inside the cell
        for i in range(a0, a1):
            for j in range(i + 1, a1):
                dx = min_image(x[j] - x[i], lx)
                dy = min_image(y[j] - y[i], ly)
                dz = min_image(z[j] - z[i], lz)
                d2 = dx * dx + dy * dy + dz * dz
                if d2 < r2max:
                    b = int(np.sqrt(d2) * inv_h + 1e-9)
                    if b < nbins:
                        counts[s[i] * nspecies + s[j], b] += 1
                        counts[s[j] * nspecies + s[i], b] += 1
        for o in range(noff):
            ex = (cx + offsets[o, 0]) % ncell[0]
            ey = (cy + offsets[o, 1]) % ncell[1]
            ez = (cz + offsets[o, 2]) % ncell[2]
            c2 = (ex * ncell[1] + ey) * ncell[2] + ez
            b0 = start[c2]
            b1 = start[c2 + 1]
            for i in range(a0, a1):
                xi = x[i]
                yi = y[i]
                zi = z[i]
                si = s[i] * nspecies
                for j in range(b0, b1):
                    dx = min_image(x[j] - xi, lx)
                    dy = min_image(y[j] - yi, ly)
                    dz = min_image(z[j] - zi, lz)
                    d2 = dx * dx + dy * dy + dz * dz
                    if d2 < r2max:
                        b = int(np.sqrt(d2) * inv_h + 1e-9)
                        if b < nbins:
                            counts[si + s[j], b] += 1
                            counts[s[j] * nspecies + s[i], b] += 1
    return counts


@njit(cache=True)
def window_counts(pos, radii, species, box, nspecies, window, ncell):
    """Number of other sphere centres within ``window[i]`` of each centre, per species.

    Parameters
    ----------
    window : (N,) float64
        Window radius around each sphere (``R_h a^(k)`` in Fig. 4 of seed 000).

    Returns
    -------
    counts : (N, nspecies) int64
        ``counts[i, m]``: spheres ``j != i`` of species ``m`` with ``d_ij <= window[i]``.
    """
    n = pos.shape[0]
    out = np.zeros((n, nspecies), np.int64)
    if n < 2:
        return out
    cell_of, start, order = build_cells(pos, box, ncell)
    cl = np.empty(3, np.float64)
    for k in range(3):
        cl[k] = box[k] / ncell[k]
    lo = np.empty(3, np.int64)
    hi = np.empty(3, np.int64)
    full = np.zeros(3, np.bool_)
    cc = np.empty(3, np.int64)
    for i in range(n):
        reach = window[i]
        ic = cell_of[i]
        cc[2] = ic % ncell[2]
        cc[1] = (ic // ncell[2]) % ncell[1]
        cc[0] = ic // (ncell[1] * ncell[2])
        for k in range(3):
            r = _cell_range(reach, cl, ncell, k)
            if r < 0:
                full[k] = True
                lo[k] = 0
                hi[k] = ncell[k] - 1
            else:
                full[k] = False
                lo[k] = -r
                hi[k] = r
        r2 = reach * reach
        for ox in range(lo[0], hi[0] + 1):
            x = ox if full[0] else (cc[0] + ox) % ncell[0]
            for oy in range(lo[1], hi[1] + 1):
                y = oy if full[1] else (cc[1] + oy) % ncell[1]
                for oz in range(lo[2], hi[2] + 1):
                    z = oz if full[2] else (cc[2] + oz) % ncell[2]
                    c = (x * ncell[1] + y) * ncell[2] + z
                    for s in range(start[c], start[c + 1]):
                        j = order[s]
                        if j == i:
                            continue
                        dx = min_image(pos[j, 0] - pos[i, 0], box[0])
                        dy = min_image(pos[j, 1] - pos[i, 1], box[1])
                        dz = min_image(pos[j, 2] - pos[i, 2], box[2])
                        if dx * dx + dy * dy + dz * dz <= r2:
                            out[i, species[j]] += 1
    return out


@njit(cache=True)
def nearest_surface(points, pos, radii, box, ncell, r_max_radius, order_by_radius_cells):
    """Signed distance from each test point to the nearest sphere *surface*.

    ``min_j (|p - x_j| - r_j)`` under minimum image, exact for polydisperse spheres.
    Size-aware search: the spheres are split into radius classes (see
    ``order_by_radius_cells``); within a class a cell grid is scanned in growing
    shells until no unscanned cell can hold a surface closer than the best one
    found (a cell at distance ``D`` from the point holds surfaces no closer than
    ``D - r_max`` of that class).

    Parameters
    ----------
    points : (M, 3) float64
    pos, radii : sphere centres and radii
    box : (3,) float64
    ncell : (C, 3) int64
        Cells per axis for each radius class.
    r_max_radius : (C,) float64
        Largest radius in each class.
    order_by_radius_cells : (N,) int64
        Class index of each sphere.

    Returns
    -------
    dist : (M,) float64
        Negative inside a sphere (minus the depth), positive in the void.
    """
    m = points.shape[0]
    nclass = ncell.shape[0]
    n = pos.shape[0]
    out = np.full(m, np.inf)
    # per-class cell structures, concatenated
    cls = order_by_radius_cells
    starts = []
    orders = []
    idxs = []
    for c in range(nclass):
        sel = np.flatnonzero(cls == c)
        sub = np.empty((sel.shape[0], 3), np.float64)
        for t in range(sel.shape[0]):
            for k in range(3):
                sub[t, k] = pos[sel[t], k]
        _, st, od = build_cells(sub, box, ncell[c])
        starts.append(st)
        orders.append(od)
        idxs.append(sel)
    for p in range(m):
        best = np.inf
        for c in range(nclass):
            nc0 = ncell[c, 0]
            nc1 = ncell[c, 1]
            nc2 = ncell[c, 2]
            cl0 = box[0] / nc0
            cl1 = box[1] / nc1
            cl2 = box[2] / nc2
            clmin = min(cl0, min(cl1, cl2))
            st = starts[c]
            od = orders[c]
            sel = idxs[c]
            rmax = r_max_radius[c]
            px = int(np.floor(points[p, 0] / cl0)) % nc0
            py = int(np.floor(points[p, 1] / cl1)) % nc1
            pz = int(np.floor(points[p, 2] / cl2)) % nc2
            maxshell = max(nc0, max(nc1, nc2))
            shell = 0
            while shell <= maxshell:
                # lower bound on the distance to any centre in shell >= this one
                dmin_centre = (shell - 1) * clmin
                if dmin_centre > 0.0 and dmin_centre - rmax >= best:
                    break
                lx = -shell
                hx = shell
                ly = -shell
                hy = shell
                lz = -shell
                hz = shell
                if 2 * shell + 1 > nc0:
                    lx = -(nc0 // 2)
                    hx = lx + nc0 - 1
                if 2 * shell + 1 > nc1:
                    ly = -(nc1 // 2)
                    hy = ly + nc1 - 1
                if 2 * shell + 1 > nc2:
                    lz = -(nc2 // 2)
                    hz = lz + nc2 - 1
                for ox in range(lx, hx + 1):
                    onx = ox == -shell or ox == shell
                    for oy in range(ly, hy + 1):
                        ony = oy == -shell or oy == shell
                        for oz in range(lz, hz + 1):
                            onz = oz == -shell or oz == shell
                            if not (onx or ony or onz):
                                continue
                            x = (px + ox) % nc0
                            y = (py + oy) % nc1
                            z = (pz + oz) % nc2
                            cidx = (x * nc1 + y) * nc2 + z
                            for s in range(st[cidx], st[cidx + 1]):
                                j = sel[od[s]]
                                dx = min_image(pos[j, 0] - points[p, 0], box[0])
                                dy = min_image(pos[j, 1] - points[p, 1], box[1])
                                dz = min_image(pos[j, 2] - points[p, 2], box[2])
                                dd = np.sqrt(dx * dx + dy * dy + dz * dz) - radii[j]
                                if dd < best:
                                    best = dd
                if 2 * shell + 1 >= nc0 and 2 * shell + 1 >= nc1 and 2 * shell + 1 >= nc2:
                    break
                shell += 1
        out[p] = best
    return out


def warmup():
    """Compile the kernels of this module on a tiny input."""
    rng = np.random.default_rng(0)
    pos = rng.random((8, 3)) * 4.0
    rad = np.full(8, 0.3)
    sp = np.zeros(8, np.int64)
    box = np.full(3, 4.0)
    nc = np.array([2, 2, 2], np.int64)
    pair_histogram(pos, rad, sp, box, 1, 1.5, 10, False, nc)
    pair_histogram(pos, rad, sp, box, 1, 1.5, 10, True, nc)
    nc3 = np.array([3, 3, 3], np.int64)
    off = half_shell_offsets(nc3, box / 3.0, 1.0)
    pair_histogram_distance(pos, sp, box, 1, 1.0, 10, nc3, off)
    window_counts(pos, rad, sp, box, 1, np.full(8, 1.0), nc)
    nearest_surface(rng.random((4, 3)) * 4.0, pos, rad, box, nc.reshape(1, 3), np.array([0.3]), sp)
