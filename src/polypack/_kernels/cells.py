"""Size-aware periodic neighbour search (cell lists).

The pair criterion is ``d_ij <= a * (r_i + r_j) + b`` with minimum image in an
orthorhombic periodic box.  ``a = 1, b = gap`` finds pairs whose surfaces are
closer than ``gap``; ``a = 1 + eps, b = 0`` pairs within a relative gap; ``a = 0,
b = r_c`` pairs with centre distance below ``r_c``.

Size robustness: each pair is searched from its *larger* sphere only (ties broken
by index), so sphere ``i`` scans a neighbourhood of radius ``2 a r_i + b``.  The
total number of cells scanned is then proportional to the volume of the spheres,
not to ``N`` times the volume of the largest sphere, and the cost stays linear for
any size ratio.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def min_image(dx, length):
    """Minimum-image component of a separation ``dx`` in a periodic box of ``length``."""
    half = 0.5 * length
    if dx > half:
        dx -= length
        if dx > half:
            dx -= length * np.floor(dx / length + 0.5)
    elif dx < -half:
        dx += length
        if dx < -half:
            dx -= length * np.floor(dx / length + 0.5)
    return dx


@njit(cache=True)
def build_cells(pos, box, ncell):
    """Counting-sort the spheres into an ``ncell[0] x ncell[1] x ncell[2]`` grid.

    Returns ``(cell_of, start, order)``: the flat cell index of every sphere, the
    start offset of every cell in ``order`` (length ``ncells + 1``), and the sphere
    indices sorted by cell.
    """
    n = pos.shape[0]
    nc = ncell[0] * ncell[1] * ncell[2]
    cell_of = np.empty(n, np.int64)
    counts = np.zeros(nc + 1, np.int64)
    for i in range(n):
        ic = 0
        for k in range(3):
            ck = int(np.floor(pos[i, k] / box[k] * ncell[k]))
            if ck < 0:
                ck += ncell[k] * ((-ck) // ncell[k] + 1)
            ic = ic * ncell[k] + ck % ncell[k]
        cell_of[i] = ic
        counts[ic + 1] += 1
    for c in range(nc):
        counts[c + 1] += counts[c]
    start = counts.copy()
    fill = counts[:-1].copy()
    order = np.empty(n, np.int64)
    for i in range(n):
        ic = cell_of[i]
        order[fill[ic]] = i
        fill[ic] += 1
    return cell_of, start, order


@njit(cache=True)
def _larger(i, j, radii):
    """True if sphere ``i`` owns pair (i, j): larger radius, ties by index."""
    if radii[i] > radii[j]:
        return True
    if radii[i] < radii[j]:
        return False
    return i > j


@njit(cache=True)
def cell_lengths(box, ncell):
    """Edge lengths of one cell of the grid."""
    cl = np.empty(3, np.float64)
    for k in range(3):
        cl[k] = box[k] / ncell[k]
    return cl


@njit(cache=True)
def cells_in_reach(ic, reach, cl, ncell, out):
    """Flat indices of every cell within ``reach`` of cell ``ic``, each listed once.

    Along an axis where the reach wraps around the whole box every cell is listed
    (periodic images never make a cell appear twice).  Writes into ``out`` (length
    at least the number of cells) and returns how many were written.  The offsets
    along each axis are those of :func:`axis_reach`, wrapped by :func:`wrap_cell`.
    """
    cz = ic % ncell[2]
    cy = (ic // ncell[2]) % ncell[1]
    cx = ic // (ncell[1] * ncell[2])
    lo0, hi0, full0 = axis_reach(reach, cl[0], ncell[0])
    lo1, hi1, full1 = axis_reach(reach, cl[1], ncell[1])
    lo2, hi2, full2 = axis_reach(reach, cl[2], ncell[2])
    m = 0
    for ox in range(lo0, hi0 + 1):
        x = wrap_cell(ox, cx, ncell[0], full0)
        for oy in range(lo1, hi1 + 1):
            y = wrap_cell(oy, cy, ncell[1], full1)
            for oz in range(lo2, hi2 + 1):
                z = wrap_cell(oz, cz, ncell[2], full2)
                out[m] = (x * ncell[1] + y) * ncell[2] + z
                m += 1
    return m


@njit(cache=True, inline="always")
def axis_reach(reach, length, ncell):
    """``(lo, hi, full)``: the cell offsets ``lo .. hi`` within ``reach`` along one axis of
    ``ncell`` cells of ``length``; ``full`` when the reach wraps the whole axis (then the
    offsets are the cells ``0 .. ncell - 1`` themselves, each once)."""
    r = int(np.ceil(reach / length))
    if 2 * r + 1 >= ncell:
        return 0, ncell - 1, True
    return -r, r, False


@njit(cache=True, inline="always")
def wrap_cell(o, c, ncell, full):
    """Cell ``(c + o) % ncell`` for ``|o| < ncell`` by one comparison (``o`` itself along a fully
    scanned axis, :func:`axis_reach`)."""
    if full:
        return o
    x = c + o
    if x < 0:
        x += ncell
    elif x >= ncell:
        x -= ncell
    return x


@njit(cache=True)
def separation2(pos, i, j, box):
    """Squared minimum-image distance between centres ``i`` and ``j``."""
    dx = min_image(pos[j, 0] - pos[i, 0], box[0])
    dy = min_image(pos[j, 1] - pos[i, 1], box[1])
    dz = min_image(pos[j, 2] - pos[i, 2], box[2])
    return dx * dx + dy * dy + dz * dz


@njit(cache=True)
def _pair_distance(pos, radii, box, a, b, i, j):
    """Centre distance of (i, j) if ``d_ij <= a (r_i + r_j) + b``, else -1."""
    d2 = separation2(pos, i, j, box)
    lim = a * (radii[i] + radii[j]) + b
    if d2 <= lim * lim:
        return np.sqrt(d2)
    return -1.0


@njit(cache=True)
def stable_argsort(keys):
    """Indices that sort ``keys`` ascending, equal keys in index order (bottom-up merge sort).

    The permutation of ``np.argsort(keys, kind="stable")`` for keys without NaN, written
    out because numba's ``argsort`` and ``sort`` cost seconds of compilation in every
    kernel that calls them (issue 33: cold start).
    """
    n = keys.shape[0]
    a = np.empty(n, np.int64)
    b = np.empty(n, np.int64)
    for k in range(n):
        a[k] = k
    width = 1
    while width < n:
        for lo in range(0, n, 2 * width):
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            i = lo
            j = mid
            k = lo
            while i < mid and j < hi:
                if keys[a[j]] < keys[a[i]]:  # strict: ties keep the left (lower index) first
                    b[k] = a[j]
                    j += 1
                else:
                    b[k] = a[i]
                    i += 1
                k += 1
            while i < mid:
                b[k] = a[i]
                i += 1
                k += 1
            while j < hi:
                b[k] = a[j]
                j += 1
                k += 1
        a, b = b, a
        width *= 2
    return a


@njit(cache=True)
def owner_rank(radii):
    """Rank of each sphere in the pair-ownership order of :func:`_larger`.

    ``rank[i] > rank[j]`` exactly when sphere ``i`` owns pair (i, j) (larger radius,
    ties by index): one integer comparison per candidate in the inner loops.
    """
    n = radii.shape[0]
    order = stable_argsort(radii)  # stable: equal radii stay in index order
    rank = np.empty(n, np.int64)
    for k in range(n):
        rank[order[k]] = k
    return rank


@njit(cache=True)
def _fill_pairs(pos, radii, box, a, b, ncell, cell_of, start, order, pi, pj, pd):
    """Store the pairs of :func:`pairs_within` into preallocated buffers.

    Returns the number of pairs found, which exceeds the buffer length when they did
    not all fit (only the first ``len(pi)`` are stored then).
    """
    cap = pi.shape[0]
    m = 0
    cl = cell_lengths(box, ncell)
    visit = np.empty(start.shape[0] - 1, np.int64)
    rank = owner_rank(radii)
    for i in range(pos.shape[0]):
        nv = cells_in_reach(cell_of[i], 2.0 * a * radii[i] + b, cl, ncell, visit)
        rank_i = rank[i]
        xi0 = pos[i, 0]
        xi1 = pos[i, 1]
        xi2 = pos[i, 2]
        ri = radii[i]
        for q in range(nv):
            c = visit[q]
            for s in range(start[c], start[c + 1]):
                j = order[s]
                if rank[j] >= rank_i:  # pair owned by j (or j == i)
                    continue
                dx = min_image(pos[j, 0] - xi0, box[0])
                dy = min_image(pos[j, 1] - xi1, box[1])
                dz = min_image(pos[j, 2] - xi2, box[2])
                d2 = dx * dx + dy * dy + dz * dz
                lim = a * (ri + radii[j]) + b
                if d2 <= lim * lim:
                    if m < cap:
                        pi[m] = i
                        pj[m] = j
                        pd[m] = np.sqrt(d2)
                    m += 1
    return m


@njit(cache=True)
def pairs_within(pos, radii, box, a, b, ncell):
    """All pairs with ``d_ij <= a (r_i + r_j) + b`` (minimum image), each once.

    Parameters
    ----------
    pos : (N, 3) float64
        Centres, any real values (wrapped internally by the cell index).
    radii : (N,) float64
    box : (3,) float64
        Box lengths; the reach ``2 a max(r) + b`` must not exceed half of the
        smallest length for the minimum image to be the only image.
    a, b : float
        Pair criterion coefficients (see module docstring).
    ncell : (3,) int64
        Cells per axis (at least 1).

    Returns
    -------
    i, j : (M,) int64
        Pair indices with sphere ``i`` the larger of the two.
    d : (M,) float64
        Centre distances.
    """
    cell_of, start, order = build_cells(pos, box, ncell)
    cap = max(16, 8 * pos.shape[0])
    while True:
        pi = np.empty(cap, np.int64)
        pj = np.empty(cap, np.int64)
        pd = np.empty(cap, np.float64)
        m = _fill_pairs(pos, radii, box, a, b, ncell, cell_of, start, order, pi, pj, pd)
        if m <= cap:
            break
        cap = m  # too many pairs for the buffers: rerun with the exact size
    return pi[:m].copy(), pj[:m].copy(), pd[:m].copy()


@njit(cache=True)
def pairs_brute(pos, radii, box, a, b):
    """O(N^2) oracle for :func:`pairs_within` (tests and tiny systems)."""
    n = pos.shape[0]
    m = 0
    for i in range(n):
        for j in range(n):
            if j != i and _larger(i, j, radii) and _pair_distance(pos, radii, box, a, b, i, j) >= 0.0:
                m += 1
    pi = np.empty(m, np.int64)
    pj = np.empty(m, np.int64)
    pd = np.empty(m, np.float64)
    m = 0
    for i in range(n):
        for j in range(n):
            if j == i or not _larger(i, j, radii):
                continue
            d = _pair_distance(pos, radii, box, a, b, i, j)
            if d >= 0.0:
                pi[m] = i
                pj[m] = j
                pd[m] = d
                m += 1
    return pi[:m].copy(), pj[:m].copy(), pd[:m].copy()


def warmup():
    """Compile :func:`pairs_within` on a tiny input as :func:`polypack.neighbors.pairs_within`
    and :func:`polypack._kernels.edmd.build_lists` call it: every array writable (numba
    compiles one version per writability of the arguments).  In ``polypack run``'s pool this
    runs beside the packer's compilation, which then loads the version from the cache.

    The O(N^2) oracle :func:`pairs_brute` is left to the calls that use it (issue 33, cold start).
    """
    pos = np.random.default_rng(0).random((8, 3)) * 4.0
    rad = np.full(8, 0.3)
    box = np.full(3, 4.0)
    pairs_within(pos, rad, box, 1.0, 0.1, np.array([2, 2, 2], np.int64))
