"""Brownian-dynamics kernel: Ermak–McCammon steps of equal spheres with tabulated pair forces.

Reduced units: length = sphere radius ``a``, energy = ``kT``, time = ``a²/D0``.  One
step of free-draining overdamped Brownian dynamics (Ermak & McCammon 1978) is::

    x(t + dt) = x(t) + F(t) dt + sqrt(2 dt) ξ,     ξ ~ N(0, 1) per coordinate

with ``F`` the total force in units of ``kT/a``, followed by constraint projections.

* Unbonded pairs closer than ``P_R_CUT`` (centre distance) feel the central force
  ``table`` at surface separation ``h = r - 2``, linearly interpolated on a uniform
  grid from ``P_TAB_LO`` with spacing ``P_TAB_DH`` (clamped at both ends).  With
  ``P_CAP_DRIFT > 0`` an *attractive* pair force is capped so that it closes at most
  ``P_CAP_DRIFT`` of the gap ``h`` in one step (the deep inner side of a DLVO well is
  not resolvable with Brownian steps; the cap makes the pair approach contact
  geometrically instead of jumping through it).
* Bonds (``P_BOND_WIDTH >= 0``): after each step, Gauss–Seidel sweeps over the
  Verlet pairs (at most ``P_SWEEPS``, until the largest correction is below
  ``P_PROJ_TOL``) bond every unbonded pair with ``h < P_BOND_WIDTH`` (capture into the
  primary minimum, permanent) and project every bonded pair back into the shell
  ``0 <= h <= P_BOND_WIDTH`` by moving both centres symmetrically along the line of
  centres (the overlap removal of Heyes & Melrose 1993 plus a tether).  Bonds carry
  no tangential constraint: bonded spheres roll freely on each other.
  ``P_BOND_WIDTH < 0`` disables bonds (purely soft pair forces).
* ``P_OVERLAP_ONLY = 1``: the sweeps only remove overlaps (no capture, no tether);
  used to finish a gel whose bond shells cannot all be satisfied at once.
* Optional harmonic trap ``-P_TRAP_K (x - L/2)`` per coordinate (validation).

* :func:`run_rigid`: the same forces, but bonded clusters are rigid bodies
  (Brownian cluster dynamics with free-draining friction; see its docstring).

``P_R_CUT <= 0`` means independent spheres (no list is built).  Neighbours come from
a Verlet list (centre distance ``P_R_CUT + P_SKIN``) built by
:func:`polypack._kernels.cells.pairs_within` and rebuilt when a sphere has moved more
than half the skin.  Random numbers: xoshiro256** with an explicit ``uint64[4]``
state and polar Box–Muller normals (the spare normal is kept in the state array),
so a run continues bit for bit across calls.  Positions are unwrapped (never folded).
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np
from numba import njit

from .cells import min_image, pairs_within

# parameter slots
P_DT = 0
P_NOISE = 1  # sqrt(2 dt) or 0 (noise-free)
P_R_CUT = 2
P_SKIN = 3
P_BOND_WIDTH = 4
P_CAP_DRIFT = 5
P_SWEEPS = 6
P_PROJ_TOL = 7
P_TAB_LO = 8
P_TAB_DH = 9
P_TRAP_K = 10
P_OVERLAP_ONLY = 11  # 1: projections remove overlaps only (no capture, no tether)
N_PARAMS = 12

# float state slots
S_TIME = 0
S_VIRIAL = 1  # sum over steps of sum_pairs r F (pair forces)
S_VIRIAL_STEPS = 2
S_HAVE_SPARE = 3
S_SPARE = 4
S_MAX_RESIDUAL = 5  # largest constraint violation left after the sweeps of a step
N_STATE = 6

# int state slots
I_STEPS = 0
I_NBONDS = 1
I_REBUILDS = 2
I_SWEEPS = 3
N_ISTATE = 4


class Status(IntEnum):
    OK = 0
    BOND_CAPACITY = 1  # the bond arrays are full
    PARTICLE_BONDS = 2  # a sphere reached the per-sphere bond limit


@njit(cache=True)
def _rotl(x, k):
    return (x << np.uint64(k)) | (x >> np.uint64(64 - k))


@njit(cache=True)
def next_u64(s):
    """xoshiro256** step on the state ``s`` (uint64[4])."""
    result = _rotl(s[1] * np.uint64(5), 7) * np.uint64(9)
    t = s[1] << np.uint64(17)
    s[2] ^= s[0]
    s[3] ^= s[1]
    s[1] ^= s[2]
    s[0] ^= s[3]
    s[2] ^= t
    s[3] = _rotl(s[3], 45)
    return result


@njit(cache=True)
def next_double(s):
    """Uniform double in [0, 1) with 53 random bits."""
    return float(next_u64(s) >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@njit(cache=True)
def next_normal(s, state):
    """Standard normal (polar Box–Muller, spare kept in ``state``)."""
    if state[S_HAVE_SPARE] != 0.0:
        state[S_HAVE_SPARE] = 0.0
        return state[S_SPARE]
    while True:
        u = 2.0 * next_double(s) - 1.0
        v = 2.0 * next_double(s) - 1.0
        q = u * u + v * v
        if 0.0 < q < 1.0:
            break
    f = np.sqrt(-2.0 * np.log(q) / q)
    state[S_SPARE] = v * f
    state[S_HAVE_SPARE] = 1.0
    return u * f


@njit(cache=True)
def fill_normals(s, state, out):
    """Fill ``out`` (flat float64) with standard normals (tests of the generator)."""
    for k in range(out.shape[0]):
        out[k] = next_normal(s, state)


@njit(cache=True)
def _bonded(adj, deg, i, j):
    for q in range(deg[i]):
        if adj[i, q] == j:
            return True
    return False


@njit(cache=True)
def _build(pos, box, params, adj, deg, ncell):
    n = pos.shape[0]
    if params[P_R_CUT] <= 0.0:  # no pair forces and no bonds: no neighbour list
        e = np.empty(0, np.int64)
        return e, e.copy(), np.empty(0, np.uint8)
    ones = np.ones(n, np.float64)
    pi, pj, _ = pairs_within(pos, ones, box, 0.0, params[P_R_CUT] + params[P_SKIN], ncell)
    flag = np.zeros(pi.shape[0], np.uint8)
    for k in range(pi.shape[0]):
        i = pi[k]
        j = pj[k]
        if deg[i] <= deg[j]:
            if _bonded(adj, deg, i, j):
                flag[k] = 1
        elif _bonded(adj, deg, j, i):
            flag[k] = 1
    return pi, pj, flag


@njit(cache=True)
def _project(pos, box, params, state, istate, pi, pj, flag, bonds, adj, deg):
    """Capture and shell projection sweeps (see module docstring); returns a Status."""
    width = params[P_BOND_WIDTH]
    cap_lim = 2.0 + width
    sweeps = int(params[P_SWEEPS])
    tol = params[P_PROJ_TOL]
    nb = istate[I_NBONDS]
    maxdeg = adj.shape[1]
    cap = bonds.shape[0]
    overlap_only = params[P_OVERLAP_ONLY] != 0.0
    worst = 0.0
    for _sweep in range(sweeps):
        worst = 0.0
        for k in range(pi.shape[0]):
            i = pi[k]
            j = pj[k]
            dx = min_image(pos[j, 0] - pos[i, 0], box[0])
            dy = min_image(pos[j, 1] - pos[i, 1], box[1])
            dz = min_image(pos[j, 2] - pos[i, 2], box[2])
            r2 = dx * dx + dy * dy + dz * dz
            if overlap_only:
                if r2 >= 4.0:
                    continue
            elif flag[k] == 0:
                if r2 >= cap_lim * cap_lim:
                    continue
                if nb >= cap:
                    istate[I_NBONDS] = nb
                    return Status.BOND_CAPACITY
                if deg[i] >= maxdeg or deg[j] >= maxdeg:
                    istate[I_NBONDS] = nb
                    return Status.PARTICLE_BONDS
                bonds[nb, 0] = i
                bonds[nb, 1] = j
                nb += 1
                adj[i, deg[i]] = j
                deg[i] += 1
                adj[j, deg[j]] = i
                deg[j] += 1
                flag[k] = 1
            r = np.sqrt(r2)
            if r < 2.0:
                corr = 2.0 - r
            elif r > cap_lim and not overlap_only:
                corr = cap_lim - r
            else:
                continue
            if abs(corr) > worst:
                worst = abs(corr)
            s = 0.5 * corr / max(r, 1e-12)
            pos[i, 0] -= s * dx
            pos[i, 1] -= s * dy
            pos[i, 2] -= s * dz
            pos[j, 0] += s * dx
            pos[j, 1] += s * dy
            pos[j, 2] += s * dz
        istate[I_SWEEPS] += 1
        if worst <= tol:
            break
    if worst > state[S_MAX_RESIDUAL]:
        state[S_MAX_RESIDUAL] = worst
    istate[I_NBONDS] = nb
    return Status.OK


@njit(cache=True)
def run(pos, box, params, state, istate, table, bonds, adj, deg, ncell, rng, nsteps):
    """Advance ``nsteps`` Ermak–McCammon steps in place.

    Parameters
    ----------
    pos : (N, 3) float64
        Unwrapped centres (reduced units), updated in place.
    box : (3,) float64
    params : (N_PARAMS,) float64
    state : (N_STATE,) float64, istate : (N_ISTATE,) int64
        Time, virial accumulators, Box–Muller spare, constraint residual; step,
        bond, rebuild and sweep counts.
    table : (M,) float64
        Pair force (kT/a, positive = repulsive) on the separation grid.
    bonds : (B, 2) int64
        Bond list; the first ``istate[I_NBONDS]`` rows are used, new bonds appended.
    adj : (N, K) int64, deg : (N,) int64
        Bonded partners of each sphere.
    ncell : (3,) int64
        Cell grid of the neighbour search.
    rng : (4,) uint64
        xoshiro256** state, advanced in place.

    Returns
    -------
    int
        A :class:`Status`.
    """
    n = pos.shape[0]
    dt = params[P_DT]
    noise = params[P_NOISE]
    rc2 = params[P_R_CUT] * params[P_R_CUT]
    half_skin2 = 0.25 * params[P_SKIN] * params[P_SKIN]
    bonding = params[P_BOND_WIDTH] >= 0.0
    cap_drift = params[P_CAP_DRIFT]
    lo = params[P_TAB_LO]
    inv_dh = 1.0 / params[P_TAB_DH]
    ntab = table.shape[0]
    ktrap = params[P_TRAP_K]
    cx = 0.5 * box[0]
    cy = 0.5 * box[1]
    cz = 0.5 * box[2]

    pi, pj, flag = _build(pos, box, params, adj, deg, ncell)
    ref = pos.copy()
    force = np.zeros((n, 3), np.float64)
    for _step in range(nsteps):
        for i in range(n):
            force[i, 0] = 0.0
            force[i, 1] = 0.0
            force[i, 2] = 0.0
        vir = 0.0
        for k in range(pi.shape[0]):
            if flag[k]:
                continue
            i = pi[k]
            j = pj[k]
            dx = min_image(pos[j, 0] - pos[i, 0], box[0])
            dy = min_image(pos[j, 1] - pos[i, 1], box[1])
            dz = min_image(pos[j, 2] - pos[i, 2], box[2])
            r2 = dx * dx + dy * dy + dz * dz
            if r2 >= rc2:
                continue
            r = np.sqrt(r2)
            h = r - 2.0
            t = (h - lo) * inv_dh
            if t <= 0.0:
                f = table[0]
            elif t >= ntab - 1:
                f = table[ntab - 1]
            else:
                q = int(t)
                w = t - q
                f = (1.0 - w) * table[q] + w * table[q + 1]
            if cap_drift > 0.0 and f < 0.0 and dt > 0.0:
                # both spheres move by |f| dt: the gap closes by 2 |f| dt at most cap_drift * h
                fmax = cap_drift * max(h, 0.0) / (2.0 * dt)
                if -f > fmax:
                    f = -fmax
            vir += f * r
            fr = f / r
            force[i, 0] -= fr * dx
            force[i, 1] -= fr * dy
            force[i, 2] -= fr * dz
            force[j, 0] += fr * dx
            force[j, 1] += fr * dy
            force[j, 2] += fr * dz
        if ktrap != 0.0:
            for i in range(n):
                force[i, 0] -= ktrap * min_image(pos[i, 0] - cx, box[0])
                force[i, 1] -= ktrap * min_image(pos[i, 1] - cy, box[1])
                force[i, 2] -= ktrap * min_image(pos[i, 2] - cz, box[2])
        state[S_VIRIAL] += vir
        state[S_VIRIAL_STEPS] += 1.0
        for i in range(n):
            for c in range(3):
                x = pos[i, c] + force[i, c] * dt
                if noise != 0.0:
                    x += noise * next_normal(rng, state)
                pos[i, c] = x
        if bonding:
            status = _project(pos, box, params, state, istate, pi, pj, flag, bonds, adj, deg)
            if status != Status.OK:
                return status
        state[S_TIME] += dt
        istate[I_STEPS] += 1
        maxd2 = 0.0
        for i in range(n):
            d2 = 0.0
            for c in range(3):
                e = pos[i, c] - ref[i, c]
                d2 += e * e
            if d2 > maxd2:
                maxd2 = d2
        if maxd2 > half_skin2 and rc2 > 0.0:
            pi, pj, flag = _build(pos, box, params, adj, deg, ncell)
            for i in range(n):
                for c in range(3):
                    ref[i, c] = pos[i, c]
            istate[I_REBUILDS] += 1
    return Status.OK


@njit(cache=True)
def _find(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@njit(cache=True)
def cluster_labels(n, bonds, nb):
    """Connected components of the bond graph: (labels 0..K-1, sizes (K,))."""
    parent = np.arange(n)
    for b in range(nb):
        ri = _find(parent, bonds[b, 0])
        rj = _find(parent, bonds[b, 1])
        if ri != rj:
            if ri < rj:
                parent[rj] = ri
            else:
                parent[ri] = rj
    label = -np.ones(n, np.int64)
    k = 0
    for i in range(n):
        r = _find(parent, i)
        if label[r] < 0:
            label[r] = k
            k += 1
        label[i] = label[r]
    sizes = np.zeros(k, np.int64)
    for i in range(n):
        sizes[label[i]] += 1
    return label, sizes


@njit(cache=True)
def wrapping_axes(pos, box, bonds, nb):
    """Axes along which some bonded cluster wraps around the periodic box.

    Walks every cluster from a root assigning each sphere an unwrapped position
    along the bonds (minimum-image bond vectors); a bond whose two ends already
    have unwrapped positions differing from its minimum-image vector by a box
    length closes a loop around the box: the cluster percolates along that axis.

    Returns
    -------
    (3,) bool
    """
    n = pos.shape[0]
    deg = np.zeros(n, np.int64)
    for b in range(nb):
        deg[bonds[b, 0]] += 1
        deg[bonds[b, 1]] += 1
    start = np.zeros(n + 1, np.int64)
    for i in range(n):
        start[i + 1] = start[i] + deg[i]
    fill = start[:-1].copy()
    nbr = np.empty(2 * nb, np.int64)
    for b in range(nb):
        i = bonds[b, 0]
        j = bonds[b, 1]
        nbr[fill[i]] = j
        fill[i] += 1
        nbr[fill[j]] = i
        fill[j] += 1
    up = np.zeros((n, 3), np.float64)
    seen = np.zeros(n, np.bool_)
    stack = np.empty(n, np.int64)
    out = np.zeros(3, np.bool_)
    for root in range(n):
        if seen[root]:
            continue
        seen[root] = True
        for c in range(3):
            up[root, c] = pos[root, c]
        top = 0
        stack[0] = root
        top = 1
        while top > 0:
            top -= 1
            i = stack[top]
            for s in range(start[i], start[i + 1]):
                j = nbr[s]
                for c in range(3):
                    d = min_image(pos[j, c] - pos[i, c], box[c])
                    if seen[j]:
                        if abs(up[j, c] - (up[i, c] + d)) > 0.5 * box[c]:
                            out[c] = True
                if not seen[j]:
                    seen[j] = True
                    for c in range(3):
                        up[j, c] = up[i, c] + min_image(pos[j, c] - pos[i, c], box[c])
                    stack[top] = j
                    top += 1
    return out


def warmup():
    """Compile the kernels of this module on a tiny input."""
    rng_state = np.array([1, 2, 3, 4], np.uint64)
    pos = np.random.default_rng(0).random((8, 3)) * 8.0
    box = np.full(3, 8.0)
    params = np.zeros(N_PARAMS)
    params[P_DT] = 1e-4
    params[P_NOISE] = np.sqrt(2e-4)
    params[P_R_CUT] = 2.5
    params[P_SKIN] = 0.4
    params[P_BOND_WIDTH] = 0.004
    params[P_CAP_DRIFT] = 0.25
    params[P_SWEEPS] = 20
    params[P_PROJ_TOL] = 1e-9
    params[P_TAB_LO] = -0.1
    params[P_TAB_DH] = 0.1
    state = np.zeros(N_STATE)
    istate = np.zeros(N_ISTATE, np.int64)
    table = np.zeros(7)
    bonds = np.zeros((32, 2), np.int64)
    adj = np.zeros((8, 8), np.int64)
    deg = np.zeros(8, np.int64)
    run(pos, box, params, state, istate, table, bonds, adj, deg, np.array([2, 2, 2], np.int64), rng_state, 3)
    cluster_labels(8, bonds, istate[I_NBONDS])
    wrapping_axes(pos, box, bonds, istate[I_NBONDS])
    fill_normals(rng_state, state, np.empty(4))
    lab, nxt, head, tail, csize = (np.zeros(8, np.int64) for _ in range(5))
    frozen = np.zeros(8, np.uint8)
    init_clusters(8, lab, nxt, head, tail, csize, frozen)
    deg[:] = 0
    istate[:] = 0
    run_rigid(pos, box, params, state, istate, table, bonds, adj, deg, np.array([2, 2, 2], np.int64), rng_state, 3,
              lab, nxt, head, tail, csize, frozen)


# ----------------------------------------------------------------------------------------
# Rigid bonds: Brownian cluster dynamics
# ----------------------------------------------------------------------------------------
#
# Cluster state (flat int64/uint8 arrays of length N, kept by the caller between calls):
#   lab[i]    label of the cluster of sphere i (the index of one member, the cluster's root)
#   nxt[i]    next member of the same cluster (-1 ends the list)
#   head[c], tail[c], csize[c]   first/last member and size of the cluster labelled c
#   frozen[c] 1 if cluster c wraps the periodic box (bonded to its own image): immobile
# Positions inside a cluster are kept mutually unwrapped: the bond vector of i-j is the
# plain difference x[j] - x[i] (a merge shifts the smaller cluster by a box vector).
# A sphere has rotational friction 8 pi eta a^3 = (4/3) zeta a^2 (reduced: 4/3).

SPHERE_ROT_FRICTION = 4.0 / 3.0


@njit(cache=True)
def init_clusters(n, lab, nxt, head, tail, csize, frozen):
    """Every sphere its own cluster."""
    for i in range(n):
        lab[i] = i
        nxt[i] = -1
        head[i] = i
        tail[i] = i
        csize[i] = 1
        frozen[i] = 0


@njit(cache=True)
def _translate_cluster(pos, c, head, nxt, sx, sy, sz):
    m = head[c]
    while m >= 0:
        pos[m, 0] += sx
        pos[m, 1] += sy
        pos[m, 2] += sz
        m = nxt[m]


@njit(cache=True)
def _merge(pos, box, i, j, lab, nxt, head, tail, csize, frozen):
    """Merge the clusters of i and j (bond i-j at its minimum image); the smaller is shifted."""
    ci = lab[i]
    cj = lab[j]
    # keep the larger label; shift the smaller cluster by a box vector so that the bond
    # vector becomes the minimum-image one
    if csize[ci] >= csize[cj]:
        keep, move, a, b = ci, cj, i, j
    else:
        keep, move, a, b = cj, ci, j, i
    sx = min_image(pos[b, 0] - pos[a, 0], box[0]) - (pos[b, 0] - pos[a, 0])
    sy = min_image(pos[b, 1] - pos[a, 1], box[1]) - (pos[b, 1] - pos[a, 1])
    sz = min_image(pos[b, 2] - pos[a, 2], box[2]) - (pos[b, 2] - pos[a, 2])
    sx = box[0] * np.round(sx / box[0])
    sy = box[1] * np.round(sy / box[1])
    sz = box[2] * np.round(sz / box[2])
    m = head[move]
    while m >= 0:
        pos[m, 0] += sx
        pos[m, 1] += sy
        pos[m, 2] += sz
        lab[m] = keep
        m = nxt[m]
    nxt[tail[keep]] = head[move]
    tail[keep] = tail[move]
    csize[keep] += csize[move]
    if frozen[move]:
        frozen[keep] = 1
    head[move] = -1
    tail[move] = -1
    csize[move] = 0
    frozen[move] = 0


@njit(cache=True)
def _internal(pos, box, i, j, lab):
    """True if i and j are in one cluster and see each other at their stored (unwrapped) image."""
    if lab[i] != lab[j]:
        return False
    for c in range(3):
        d = pos[j, c] - pos[i, c]
        if abs(d - min_image(d, box[c])) > 0.5 * box[c]:
            return False
    return True


@njit(cache=True)
def _rigid_overlaps(pos, box, params, state, istate, pi, pj, lab, head, nxt, csize, frozen):
    """Remove overlaps between different clusters by rigid translations (mobility 1/n)."""
    sweeps = int(params[P_SWEEPS])
    tol = params[P_PROJ_TOL]
    worst = 0.0
    for _sweep in range(sweeps):
        worst = 0.0
        for k in range(pi.shape[0]):
            i = pi[k]
            j = pj[k]
            dx = min_image(pos[j, 0] - pos[i, 0], box[0])
            dy = min_image(pos[j, 1] - pos[i, 1], box[1])
            dz = min_image(pos[j, 2] - pos[i, 2], box[2])
            r2 = dx * dx + dy * dy + dz * dz
            if r2 >= 4.0:
                continue
            ci = lab[i]
            cj = lab[j]
            r = np.sqrt(r2)
            corr = 2.0 - r
            if ci == cj:  # a cluster touching its own image (or an internal overlap): not movable
                if corr > worst:
                    worst = corr
                continue
            wi = 0.0 if frozen[ci] else 1.0 / csize[ci]
            wj = 0.0 if frozen[cj] else 1.0 / csize[cj]
            if wi + wj == 0.0:
                if corr > worst:
                    worst = corr
                continue
            if corr > worst:
                worst = corr
            s = corr / (max(r, 1e-12) * (wi + wj))
            if wi > 0.0:
                _translate_cluster(pos, ci, head, nxt, -s * wi * dx, -s * wi * dy, -s * wi * dz)
            if wj > 0.0:
                _translate_cluster(pos, cj, head, nxt, s * wj * dx, s * wj * dy, s * wj * dz)
        istate[I_SWEEPS] += 1
        if worst <= tol:
            break
    if worst > state[S_MAX_RESIDUAL]:
        state[S_MAX_RESIDUAL] = worst


@njit(cache=True)
def _rigid_capture(pos, box, params, istate, pi, pj, flag, bonds, adj, deg, lab, nxt, head, tail, csize,
                   frozen):
    """Bond every unbonded pair closer than the bond width; merge clusters; flag wrapping."""
    cap_lim = 2.0 + params[P_BOND_WIDTH]
    nb = istate[I_NBONDS]
    maxdeg = adj.shape[1]
    cap = bonds.shape[0]
    for k in range(pi.shape[0]):
        if flag[k]:
            continue
        i = pi[k]
        j = pj[k]
        dx = min_image(pos[j, 0] - pos[i, 0], box[0])
        dy = min_image(pos[j, 1] - pos[i, 1], box[1])
        dz = min_image(pos[j, 2] - pos[i, 2], box[2])
        if dx * dx + dy * dy + dz * dz >= cap_lim * cap_lim:
            continue
        if nb >= cap:
            istate[I_NBONDS] = nb
            return Status.BOND_CAPACITY
        if deg[i] >= maxdeg or deg[j] >= maxdeg:
            istate[I_NBONDS] = nb
            return Status.PARTICLE_BONDS
        bonds[nb, 0] = i
        bonds[nb, 1] = j
        nb += 1
        adj[i, deg[i]] = j
        deg[i] += 1
        adj[j, deg[j]] = i
        deg[j] += 1
        flag[k] = 1
        if lab[i] != lab[j]:
            _merge(pos, box, i, j, lab, nxt, head, tail, csize, frozen)
        elif not _internal(pos, box, i, j, lab):
            frozen[lab[i]] = 1  # bonded to its own periodic image: the cluster spans the box
    istate[I_NBONDS] = nb
    return Status.OK


@njit(cache=True)
def _rotation(tx, ty, tz, out):
    """Rotation matrix of the rotation vector (tx, ty, tz) (Rodrigues), written to ``out`` (3, 3)."""
    th = np.sqrt(tx * tx + ty * ty + tz * tz)
    if th < 1e-300:
        for p in range(3):
            for q in range(3):
                out[p, q] = 1.0 if p == q else 0.0
        return
    kx = tx / th
    ky = ty / th
    kz = tz / th
    c = np.cos(th)
    s = np.sin(th)
    v = 1.0 - c
    out[0, 0] = c + kx * kx * v
    out[0, 1] = kx * ky * v - kz * s
    out[0, 2] = kx * kz * v + ky * s
    out[1, 0] = ky * kx * v + kz * s
    out[1, 1] = c + ky * ky * v
    out[1, 2] = ky * kz * v - kx * s
    out[2, 0] = kz * kx * v - ky * s
    out[2, 1] = kz * ky * v + kx * s
    out[2, 2] = c + kz * kz * v


@njit(cache=True)
def _move_clusters(pos, params, state, force, rng, lab, nxt, head, csize, frozen):
    """One free-draining rigid-body Brownian step of every mobile cluster."""
    n = pos.shape[0]
    dt = params[P_DT]
    noise = params[P_NOISE]
    xi = np.zeros((3, 3))
    rot = np.zeros((3, 3))
    for c in range(n):
        if lab[c] != c or head[c] < 0 or frozen[c]:
            continue
        m = csize[c]
        if m == 1:
            for q in range(3):
                x = pos[c, q] + force[c, q] * dt
                if noise != 0.0:
                    x += noise * next_normal(rng, state)
                pos[c, q] = x
            continue
        # centre, total force, torque, friction tensor (units zeta = 1)
        rx = 0.0
        ry = 0.0
        rz = 0.0
        i = head[c]
        while i >= 0:
            rx += pos[i, 0]
            ry += pos[i, 1]
            rz += pos[i, 2]
            i = nxt[i]
        rx /= m
        ry /= m
        rz /= m
        fx = 0.0
        fy = 0.0
        fz = 0.0
        tqx = 0.0
        tqy = 0.0
        tqz = 0.0
        for p in range(3):
            for q in range(3):
                xi[p, q] = SPHERE_ROT_FRICTION * m if p == q else 0.0
        i = head[c]
        while i >= 0:
            ux = pos[i, 0] - rx
            uy = pos[i, 1] - ry
            uz = pos[i, 2] - rz
            gx = force[i, 0]
            gy = force[i, 1]
            gz = force[i, 2]
            fx += gx
            fy += gy
            fz += gz
            tqx += uy * gz - uz * gy
            tqy += uz * gx - ux * gz
            tqz += ux * gy - uy * gx
            u2 = ux * ux + uy * uy + uz * uz
            xi[0, 0] += u2 - ux * ux
            xi[1, 1] += u2 - uy * uy
            xi[2, 2] += u2 - uz * uz
            xi[0, 1] -= ux * uy
            xi[0, 2] -= ux * uz
            xi[1, 2] -= uy * uz
            i = nxt[i]
        xi[1, 0] = xi[0, 1]
        xi[2, 0] = xi[0, 2]
        xi[2, 1] = xi[1, 2]
        w, v = np.linalg.eigh(xi)
        # translation: friction m, so drift F/m and noise sqrt(2 dt / m)
        sm = 1.0 / np.sqrt(m)
        dx = fx / m * dt
        dy = fy / m * dt
        dz = fz / m * dt
        if noise != 0.0:
            dx += noise * sm * next_normal(rng, state)
            dy += noise * sm * next_normal(rng, state)
            dz += noise * sm * next_normal(rng, state)
        # rotation: dtheta = Xi^-1 T dt + sqrt(2 dt) Xi^-1/2 xi  (in the eigenbasis of Xi)
        tx = 0.0
        ty = 0.0
        tz = 0.0
        for e in range(3):
            proj = v[0, e] * tqx + v[1, e] * tqy + v[2, e] * tqz
            amp = proj / w[e] * dt
            if noise != 0.0:
                amp += noise / np.sqrt(w[e]) * next_normal(rng, state)
            tx += amp * v[0, e]
            ty += amp * v[1, e]
            tz += amp * v[2, e]
        _rotation(tx, ty, tz, rot)
        i = head[c]
        while i >= 0:
            ux = pos[i, 0] - rx
            uy = pos[i, 1] - ry
            uz = pos[i, 2] - rz
            pos[i, 0] = rx + dx + rot[0, 0] * ux + rot[0, 1] * uy + rot[0, 2] * uz
            pos[i, 1] = ry + dy + rot[1, 0] * ux + rot[1, 1] * uy + rot[1, 2] * uz
            pos[i, 2] = rz + dz + rot[2, 0] * ux + rot[2, 1] * uy + rot[2, 2] * uz
            i = nxt[i]


@njit(cache=True)
def run_rigid(pos, box, params, state, istate, table, bonds, adj, deg, ncell, rng, nsteps,
              lab, nxt, head, tail, csize, frozen):
    """Advance ``nsteps`` steps of Brownian cluster dynamics (rigid bonds) in place.

    Arguments as :func:`run`, plus the cluster arrays (see :func:`init_clusters`).
    Each step: DLVO forces of the unbonded pairs (pairs inside one rigid cluster are
    skipped: their forces cancel in the cluster's force and torque); every mobile
    cluster makes a free-draining rigid-body Ermak–McCammon step (translation with
    friction ``n``, rotation with the friction tensor ``sum_i (|u_i|^2 I - u_i u_i^T)
    + (4/3) n I`` about its centre, ``u_i`` = centre offsets, noise ``sqrt(2 dt)``
    times the inverse square root of the friction); overlaps between different
    clusters are removed by rigid translations weighted by the mobilities ``1/n``
    (wrapping clusters are immobile); then every pair closer than the bond width is
    bonded and the two clusters merge.  ``P_NOISE = 0`` and ``P_DT = 0`` give a pure
    overlap removal and capture pass.
    """
    n = pos.shape[0]
    dt = params[P_DT]
    rc2 = params[P_R_CUT] * params[P_R_CUT]
    half_skin2 = 0.25 * params[P_SKIN] * params[P_SKIN]
    cap_drift = params[P_CAP_DRIFT]
    lo = params[P_TAB_LO]
    inv_dh = 1.0 / params[P_TAB_DH]
    ntab = table.shape[0]
    ktrap = params[P_TRAP_K]
    cx = 0.5 * box[0]
    cy = 0.5 * box[1]
    cz = 0.5 * box[2]

    pi, pj, flag = _build(pos, box, params, adj, deg, ncell)
    ref = pos.copy()
    force = np.zeros((n, 3), np.float64)
    for _step in range(nsteps):
        for i in range(n):
            force[i, 0] = 0.0
            force[i, 1] = 0.0
            force[i, 2] = 0.0
        vir = 0.0
        for k in range(pi.shape[0]):
            if flag[k]:
                continue
            i = pi[k]
            j = pj[k]
            if _internal(pos, box, i, j, lab):
                continue
            dx = min_image(pos[j, 0] - pos[i, 0], box[0])
            dy = min_image(pos[j, 1] - pos[i, 1], box[1])
            dz = min_image(pos[j, 2] - pos[i, 2], box[2])
            r2 = dx * dx + dy * dy + dz * dz
            if r2 >= rc2:
                continue
            r = np.sqrt(r2)
            h = r - 2.0
            t = (h - lo) * inv_dh
            if t <= 0.0:
                f = table[0]
            elif t >= ntab - 1:
                f = table[ntab - 1]
            else:
                q = int(t)
                w = t - q
                f = (1.0 - w) * table[q] + w * table[q + 1]
            if cap_drift > 0.0 and f < 0.0 and dt > 0.0:
                fmax = cap_drift * max(h, 0.0) / (2.0 * dt)
                if -f > fmax:
                    f = -fmax
            vir += f * r
            fr = f / r
            force[i, 0] -= fr * dx
            force[i, 1] -= fr * dy
            force[i, 2] -= fr * dz
            force[j, 0] += fr * dx
            force[j, 1] += fr * dy
            force[j, 2] += fr * dz
        if ktrap != 0.0:
            for i in range(n):
                force[i, 0] -= ktrap * min_image(pos[i, 0] - cx, box[0])
                force[i, 1] -= ktrap * min_image(pos[i, 1] - cy, box[1])
                force[i, 2] -= ktrap * min_image(pos[i, 2] - cz, box[2])
        state[S_VIRIAL] += vir
        state[S_VIRIAL_STEPS] += 1.0
        _move_clusters(pos, params, state, force, rng, lab, nxt, head, csize, frozen)
        if params[P_BOND_WIDTH] >= 0.0 and rc2 > 0.0:
            _rigid_overlaps(pos, box, params, state, istate, pi, pj, lab, head, nxt, csize, frozen)
            status = _rigid_capture(pos, box, params, istate, pi, pj, flag, bonds, adj, deg, lab, nxt, head,
                                    tail, csize, frozen)
            if status != Status.OK:
                return status
        state[S_TIME] += dt
        istate[I_STEPS] += 1
        maxd2 = 0.0
        for i in range(n):
            d2 = 0.0
            for c in range(3):
                e = min_image(pos[i, c] - ref[i, c], box[c])
                d2 += e * e
            if d2 > maxd2:
                maxd2 = d2
        if maxd2 > half_skin2 and rc2 > 0.0:
            pi, pj, flag = _build(pos, box, params, adj, deg, ncell)
            for i in range(n):
                for c in range(3):
                    ref[i, c] = pos[i, c]
            istate[I_REBUILDS] += 1
    return Status.OK
