"""numba kernels of :mod:`polypack.analysis`: pair histograms, window counts, nearest surfaces.

All kernels take flat float64/int64 arrays, use the cell grid of
:mod:`polypack._kernels.cells` (``build_cells``) and its ``min_image``; no pair list
is stored, so memory stays O(N + bins) however many pairs fall within the cutoff.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .cells import build_cells, cell_lengths, cells_in_reach, min_image, owner_rank, separation2


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
    cl = cell_lengths(box, ncell)
    visit = np.empty(start.shape[0] - 1, np.int64)
    rank = owner_rank(radii)
    h = x_max / nbins
    inv_h = 1.0 / h
    for i in range(n):
        if scaled:
            reach = 2.0 * x_max * radii[i]
        else:
            reach = x_max
        si = species[i]
        rank_i = rank[i]
        nv = cells_in_reach(cell_of[i], reach, cl, ncell, visit)
        for q in range(nv):
            c = visit[q]
            for s in range(start[c], start[c + 1]):
                j = order[s]
                if rank[j] >= rank_i:  # pair owned by j (or j == i)
                    continue
                d = np.sqrt(separation2(pos, i, j, box))
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
    An axis with a single cell (the slab axis of an embedded 2D pack) needs no offset
    along it: every pair along it shares the cell.  Returns ``(M, 3)`` int64, or an
    empty array when a grid axis is too short for the offsets to be distinct
    (``1 < ncell < 2 R + 1``).
    """
    rr = np.empty(3, np.int64)
    for k in range(3):
        rr[k] = int(np.ceil(r_max / cl[k]))
        if ncell[k] == 1:
            rr[k] = 0
        elif ncell[k] < 2 * rr[k] + 1:
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
    cl = cell_lengths(box, ncell)
    visit = np.empty(start.shape[0] - 1, np.int64)
    for i in range(n):
        reach = window[i]
        r2 = reach * reach
        nv = cells_in_reach(cell_of[i], reach, cl, ncell, visit)
        for q in range(nv):
            c = visit[q]
            for s in range(start[c], start[c + 1]):
                j = order[s]
                if j != i and separation2(pos, i, j, box) <= r2:
                    out[i, species[j]] += 1
    return out


@njit(cache=True)
def _wrap_cell(c, nc):
    """Cell index ``c`` in ``-nc..2 nc - 1`` folded into ``0..nc - 1``."""
    if c < 0:
        return c + nc
    if c >= nc:
        return c - nc
    return c


@njit(cache=True)
def _axis_gap_one(o, f, cl):
    if o > 0:
        return o * cl - f
    if o < 0:
        return (-o - 1) * cl + f
    return 0.0


@njit(cache=True)
def _axis_gap(o, f, cl, nc):
    """Periodic distance along one axis from a point at offset ``f`` in its cell to the cell ``o`` away.

    The cell ``o`` away is also the cell ``o -/+ nc`` away on the other side of the
    box; the nearer of the two is the gap (with an even number of cells the cell at
    ``o = -nc/2`` can be nearer through the other side).
    """
    g = _axis_gap_one(o, f, cl)
    if o < 0:
        g = min(g, _axis_gap_one(o + nc, f, cl))
    elif o > 0:
        g = min(g, _axis_gap_one(o - nc, f, cl))
    return g


@njit(cache=True)
def nearest_surface(points, pos, radii, box, ncell, r_max_radius, cls):
    """Signed distance from each test point to the nearest sphere *surface*.

    ``min_j (|p - x_j| - r_j)`` under minimum image, exact for polydisperse spheres.
    Size-aware search: the spheres are split into radius classes ``cls``; every
    class has its own cell grid (``ncell[c]``, cells at least as wide as the class
    diameter) and is scanned in growing cubic shells of cells around the point. A
    cell is skipped when its box is farther from the point than ``best + r_max``
    of the class (no surface inside can be closer than ``best``), and the shells stop
    when a whole shell is that far.

    Parameters
    ----------
    points : (M, 3) float64, inside ``[0, L)``
    pos, radii : sphere centres and radii
    box : (3,) float64
    ncell : (C, 3) int64
        Cells per axis for each radius class.
    r_max_radius : (C,) float64
        Largest radius in each class.
    cls : (N,) int64
        Class index of each sphere.

    Returns
    -------
    dist : (M,) float64
        Negative inside a sphere (minus the depth), positive in the void.
    """
    m = points.shape[0]
    nclass = ncell.shape[0]
    n = pos.shape[0]
    out = np.empty(m, np.float64)
    # per-class cell lists, concatenated: sphere data sorted by (class, cell)
    cbase = np.zeros(nclass + 1, np.int64)  # offset of each class in the sphere arrays
    sbase = np.zeros(nclass + 1, np.int64)  # offset of each class in the start array
    for i in range(n):
        cbase[cls[i] + 1] += 1
    for c in range(nclass):
        cbase[c + 1] += cbase[c]
        sbase[c + 1] = sbase[c] + ncell[c, 0] * ncell[c, 1] * ncell[c, 2] + 1
    sx = np.empty(n)
    sy = np.empty(n)
    sz = np.empty(n)
    sr = np.empty(n)
    starts = np.empty(sbase[nclass], np.int64)
    for c in range(nclass):
        cnt = cbase[c + 1] - cbase[c]
        sub = np.empty((cnt, 3), np.float64)
        idx = np.empty(cnt, np.int64)
        t = 0
        for i in range(n):
            if cls[i] == c:
                sub[t, 0] = pos[i, 0]
                sub[t, 1] = pos[i, 1]
                sub[t, 2] = pos[i, 2]
                idx[t] = i
                t += 1
        _, st, od = build_cells(sub, box, ncell[c])
        for q in range(st.shape[0]):
            starts[sbase[c] + q] = st[q] + cbase[c]
        for q in range(cnt):
            j = idx[od[q]]
            sx[cbase[c] + q] = pos[j, 0]
            sy[cbase[c] + q] = pos[j, 1]
            sz[cbase[c] + q] = pos[j, 2]
            sr[cbase[c] + q] = radii[j]
    for p in range(m):
        best = np.inf
        qx = points[p, 0]
        qy = points[p, 1]
        qz = points[p, 2]
        for c in range(nclass):
            nc0 = ncell[c, 0]
            nc1 = ncell[c, 1]
            nc2 = ncell[c, 2]
            cl0 = box[0] / nc0
            cl1 = box[1] / nc1
            cl2 = box[2] / nc2
            sb = sbase[c]
            rmax = r_max_radius[c]
            px = min(int(qx / cl0), nc0 - 1)
            py = min(int(qy / cl1), nc1 - 1)
            pz = min(int(qz / cl2), nc2 - 1)
            fx = qx - px * cl0
            fy = qy - py * cl1
            fz = qz - pz * cl2
            h0 = (nc0 - 1) // 2
            h1 = (nc1 - 1) // 2
            h2 = (nc2 - 1) // 2
            hmax = max(h0, max(h1, h2))
            # offsets beyond h_k would revisit cells (periodic); the far half is covered
            # by the negative offsets down to -(nc - 1 - h)
            shell = 0
            while True:
                lx = max(-shell, -(nc0 - 1 - h0))
                hx = min(shell, h0)
                ly = max(-shell, -(nc1 - 1 - h1))
                hy = min(shell, h1)
                lz = max(-shell, -(nc2 - 1 - h2))
                hz = min(shell, h2)
                any_close = False
                lim = best + rmax
                for ox in range(lx, hx + 1):
                    gx = _axis_gap(ox, fx, cl0, nc0)
                    onx = ox == -shell or ox == shell
                    for oy in range(ly, hy + 1):
                        gy = _axis_gap(oy, fy, cl1, nc1)
                        ony = oy == -shell or oy == shell
                        for oz in range(lz, hz + 1):
                            if not (onx or ony or oz == -shell or oz == shell):
                                continue
                            gz = _axis_gap(oz, fz, cl2, nc2)
                            g2 = gx * gx + gy * gy + gz * gz
                            if lim <= 0.0 or g2 >= lim * lim:
                                continue
                            any_close = True
                            x = _wrap_cell(px + ox, nc0)
                            y = _wrap_cell(py + oy, nc1)
                            z = _wrap_cell(pz + oz, nc2)
                            cidx = sb + (x * nc1 + y) * nc2 + z
                            for s in range(starts[cidx], starts[cidx + 1]):
                                dx = min_image(sx[s] - qx, box[0])
                                dy = min_image(sy[s] - qy, box[1])
                                dz = min_image(sz[s] - qz, box[2])
                                dd = np.sqrt(dx * dx + dy * dy + dz * dz) - sr[s]
                                if dd < best:
                                    best = dd
                                    lim = best + rmax
                if shell > 0 and not any_close:
                    break
                if shell >= hmax + 1:
                    break
                shell += 1
        out[p] = best
    return out


def warmup():
    """Compile the kernels of this module on a tiny input.

    Positions, radii, species and box are read-only, as the estimators pass a Packing's
    arrays: numba compiles a separate version for writable arrays, which a study's
    first run would otherwise compile again in every worker (issue 33).
    """
    rng = np.random.default_rng(0)
    pos = rng.random((8, 3)) * 4.0
    rad = np.full(8, 0.3)
    sp = np.zeros(8, np.int64)
    box = np.full(3, 4.0)
    cls = sp.copy()
    for a in (pos, rad, sp, box):
        a.setflags(write=False)
    nc = np.array([2, 2, 2], np.int64)
    pair_histogram(pos, rad, sp, box, 1, 1.5, 10, False, nc)
    pair_histogram(pos, rad, sp, box, 1, 1.5, 10, True, nc)
    nc3 = np.array([3, 3, 3], np.int64)
    off = half_shell_offsets(nc3, box / 3.0, 1.0)
    pair_histogram_distance(pos, sp, box, 1, 1.0, 10, nc3, off)
    window_counts(pos, rad, sp, box, 1, np.full(8, 1.0), nc)
    nearest_surface(rng.random((4, 3)) * 4.0, pos, rad, box, nc.reshape(1, 3), np.array([0.3]), cls)
