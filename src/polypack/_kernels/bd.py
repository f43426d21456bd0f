"""Brownian-dynamics kernel: Ermak–McCammon steps of equal spheres with tabulated pair forces.

Reduced units: length = sphere radius ``a``, energy = ``kT``, time = ``a²/D0``.  One
step of free-draining overdamped Brownian dynamics (Ermak & McCammon 1978) is::

    x(t + dt) = x(t) + F(t) dt + sqrt(2 dt) ξ,     ξ ~ N(0, 1) per coordinate

with ``F`` the total force in units of ``kT/a``, followed by constraint projections.

* Unbonded pairs closer than ``P_R_CUT`` (centre distance) feel the central force
  ``table`` at surface separation ``h = r - 2``, linearly interpolated on a uniform
  grid from ``P_TAB_LO`` with spacing ``P_TAB_DH`` (``F`` clamped at both ends: below the
  table's start, an overlap beyond it, the force is the first entry's).  With
  ``P_CAP_DRIFT > 0`` an *attractive* pair force is capped so that it closes at most
  ``P_CAP_DRIFT`` of the gap ``h`` in one step (the deep inner side of a DLVO well is
  not resolvable with Brownian steps; the cap makes the pair approach contact
  geometrically instead of jumping through it).  One pair loop, :func:`_central_forces`, serves
  all three kernels; the flexible and tangential ones read ``F/r`` from a table in ``r²``
  resampled from this one (:func:`_force_table_r2`: no square root or division per pair, the
  forces within the interpolation error of the h table; below that table's start they take the
  h table itself), the rigid one the h table everywhere (:func:`_pair_force`).
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
* ``P_LUB_RANGE > 0``: lubrication-corrected pair mobility (:func:`_translate`): the
  relative normal mobility of every *unbonded* listed pair with gap ``u = h/a <
  P_LUB_RANGE`` is divided by the Honig, Roebersen & Wiersema (1971) factor
  ``β(u) = (6u² + 13u + 2)/(6u² + 4u)`` (tapered to 1 at the range,
  :func:`lubrication_beta`); mobility ``M = S²``, ``S = I - Σ_p k_p b_p b_pᵀ``, noise
  ``sqrt(2 dt) S ξ`` and the Itô drift ``(∇·M) dt`` (:func:`lubrication_terms`).

* :func:`run_rigid`: the same forces, but bonded clusters are rigid bodies
  (Brownian cluster dynamics with free-draining friction; see its docstring).
* :func:`run_tangential`: the flexible model plus rotational Brownian motion of every
  sphere and elastic-plastic tangential springs on each bond (sliding and rolling
  resistance with a rolling yield; see its docstring).

``P_R_CUT <= 0`` means independent spheres (no list is built).  Neighbours come from
a Verlet list (centre distance ``P_R_CUT + P_SKIN``; the pairs of
:func:`polypack._kernels.cells.pairs_within` ordered by ``i`` then ``j``, built by
:func:`_verlet_pairs` with each pair's periodic image count, so the hot loops apply the minimum
image without branches) rebuilt when a sphere has moved more than half the skin; the trajectory
does not depend on the skin, the cell grid or the rebuild times.  The projection sweeps
after the first of a step visit only the pairs that can act (:func:`_project`; same
result bit for bit).  Random numbers: xoshiro256** with an explicit ``uint64[4]``
state and ziggurat normals (:func:`next_normal`), so a run continues bit for bit across
calls.  Positions are unwrapped (never folded).
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np
from numba import njit

from .cells import axis_reach, build_cells, cell_lengths, min_image, wrap_cell

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
P_K_SLIDE = 12  # run_tangential: sliding (anchor) spring stiffness, kT / a^2
P_K_ROLL = 13  # run_tangential: rolling stiffness, kT (U = k_r |xi|^2 / 2, xi dimensionless)
P_ROLL_MAX = 14  # run_tangential: largest elastic rolling displacement |xi| (yield beyond), inf = none
P_ROTATE = 15  # run_tangential: 1 integrates rotations even without tangential springs (validation)
P_LUB_RANGE = 16  # lubrication range u_c (gap / a) of the pair mobility; 0 = free draining
P_LUB_NO_DRIFT = 17  # 1 drops the Ito drift (div M) dt of the lubricated step (validation: a wrong scheme)
N_PARAMS = 18

#: cluster labels for :func:`_central_forces` in the kernels without rigid clusters (unused there)
_NO_LABELS = np.zeros(1, np.int64)
#: r² table ``t2, tp`` for :func:`_central_forces` in the rigid kernel (unused there; no table is built)
_NO_R2_TABLE = np.zeros(2)
_NO_R2_PARAMS = np.array([0.0, 1.0, 0.0, -1.0])

#: Gap (radii) below which the Honig factor is held constant (its derivative set to zero).
LUB_U_FLOOR = 1e-4

# float state slots
S_TIME = 0
S_VIRIAL = 1  # sum over steps of sum_pairs r F (pair forces)
S_VIRIAL_STEPS = 2
S_HAVE_SPARE = 3  # unused since the ziggurat normals (no spare normal)
S_SPARE = 4  # unused
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


@njit(cache=True, inline="always")
def _rotl(x, k):
    return (x << np.uint64(k)) | (x >> np.uint64(64 - k))


@njit(cache=True, inline="always")
def _u64(s0, s1, s2, s3):
    """xoshiro256** step on a state held in four scalars: ``(result, s0, s1, s2, s3)``.

    The hot loops keep the state in locals (registers) for a whole pass and store it back once:
    through the ``uint64[4]`` array every draw reloaded and stored the state, since the compiler
    cannot tell the state array from the positions the loop writes.  Same numbers as
    :func:`next_u64`, bit for bit.
    """
    result = _rotl(s1 * np.uint64(5), 7) * np.uint64(9)
    t = s1 << np.uint64(17)
    s2 ^= s0
    s3 ^= s1
    s1 ^= s2
    s0 ^= s3
    s2 ^= t
    s3 = _rotl(s3, 45)
    return result, s0, s1, s2, s3


@njit(cache=True, inline="always")
def _rng_load(rng):
    """The generator's state ``rng`` (uint64[4]) as four scalars ``(s0, s1, s2, s3)`` for a pass (:func:`_u64`).

    Called once per pass (not per draw), so the array argument's reference count is paid once.
    """
    return rng[0], rng[1], rng[2], rng[3]


@njit(cache=True, inline="always")
def _rng_store(rng, s0, s1, s2, s3):
    """Store the state a pass held in four scalars (:func:`_rng_load`) back into ``rng`` (uint64[4])."""
    rng[0] = s0
    rng[1] = s1
    rng[2] = s2
    rng[3] = s3


@njit(cache=True, inline="always")
def next_u64(s):
    """xoshiro256** step on the state ``s`` (uint64[4])."""
    result, s[0], s[1], s[2], s[3] = _u64(s[0], s[1], s[2], s[3])
    return result


@njit(cache=True, inline="always")
def _double(s0, s1, s2, s3):
    """Uniform double in [0, 1) with 53 random bits, state in scalars (:func:`_u64`)."""
    u, s0, s1, s2, s3 = _u64(s0, s1, s2, s3)
    return float(u >> np.uint64(11)) * (1.0 / 9007199254740992.0), s0, s1, s2, s3


@njit(cache=True, inline="always")
def next_double(s):
    """Uniform double in [0, 1) with 53 random bits."""
    x, s[0], s[1], s[2], s[3] = _double(s[0], s[1], s[2], s[3])
    return x


def _ziggurat_tables(layers=256, r=3.6541528853610088, v=0.00492867323399):
    """Tables of the 256-layer normal ziggurat (Marsaglia & Tsang 2000) on 52-bit uniforms.

    Layer ``i`` has width ``x_i`` (``x_255 = r``, the tail start; ``x_0 = 0``) and area ``v``;
    ``w[i] = x_i / 2^52`` scales the integer draw to ``x``, ``k[i]`` (integer) accepts it without
    a test when ``x`` lies inside the next layer's width, ``f[i] = exp(-x_i^2 / 2)``.  Layer 0
    is the base strip with the tail beyond ``r``.
    """
    m = float(2 ** 52)
    k = np.zeros(layers, np.uint64)
    w = np.zeros(layers)
    f = np.zeros(layers)
    dn = tn = r
    q = v / np.exp(-0.5 * dn * dn)
    k[0] = np.uint64((dn / q) * m)
    w[0] = q / m
    w[layers - 1] = dn / m
    f[0] = 1.0
    f[layers - 1] = np.exp(-0.5 * dn * dn)
    for i in range(layers - 2, 0, -1):
        dn = np.sqrt(-2.0 * np.log(v / dn + np.exp(-0.5 * dn * dn)))
        k[i + 1] = np.uint64((dn / tn) * m)
        tn = dn
        f[i] = np.exp(-0.5 * dn * dn)
        w[i] = dn / m
    return k, w, f


_ZIG_K, _ZIG_W, _ZIG_F = _ziggurat_tables()
_ZIG_R = 3.6541528853610088
_ZIG_INV_R = 1.0 / _ZIG_R


@njit(cache=True, inline="always")
def _normal(s0, s1, s2, s3):
    """Standard normal: 256-layer ziggurat (Marsaglia & Tsang 2000) on one xoshiro256** draw.

    State in four scalars (:func:`_u64`): returns ``(x, s0, s1, s2, s3)``.  The low 8 bits pick
    the layer, the next bit the sign, the top 52 bits the abscissa; about 99 % of the draws return
    after one comparison, the rest take the wedge test or Marsaglia's tail algorithm beyond ``r``
    (both exact).
    """
    while True:
        u, s0, s1, s2, s3 = _u64(s0, s1, s2, s3)
        idx = np.int64(u & np.uint64(0xFF))
        u = u >> np.uint64(8)
        sign = u & np.uint64(1)
        rabs = (u >> np.uint64(1)) & np.uint64(0x000FFFFFFFFFFFFF)
        x = float(rabs) * _ZIG_W[idx]
        if sign != 0:
            x = -x
        if rabs < _ZIG_K[idx]:
            return x, s0, s1, s2, s3
        if idx == 0:  # tail beyond r (Marsaglia 1964)
            while True:
                d1, s0, s1, s2, s3 = _double(s0, s1, s2, s3)
                d2, s0, s1, s2, s3 = _double(s0, s1, s2, s3)
                xx = -_ZIG_INV_R * np.log1p(-d1)
                yy = -np.log1p(-d2)
                if yy + yy > xx * xx:
                    return (-(_ZIG_R + xx) if sign != 0 else _ZIG_R + xx), s0, s1, s2, s3
        else:
            d1, s0, s1, s2, s3 = _double(s0, s1, s2, s3)
            if (_ZIG_F[idx - 1] - _ZIG_F[idx]) * d1 + _ZIG_F[idx] < np.exp(-0.5 * x * x):
                return x, s0, s1, s2, s3


@njit(cache=True, inline="always")
def next_normal(s, state):
    """Standard normal (:func:`_normal`) on the xoshiro256** state ``s`` (uint64[4]), advanced in place.

    ``state`` is unused (it held the spare normal of the polar Box–Muller generator used before).
    """
    x, s[0], s[1], s[2], s[3] = _normal(s[0], s[1], s[2], s[3])
    return x


@njit(cache=True)
def fill_normals(s, state, out):
    """Fill ``out`` (flat float64) with standard normals (tests of the generator)."""
    for k in range(out.shape[0]):
        out[k] = next_normal(s, state)


@njit(cache=True, inline="always")
def _bonded(adj, deg, i, j):
    for q in range(deg[i]):
        if adj[i, q] == j:
            return True
    return False


@njit(cache=True)
def _image_count(d, length):
    """Number of box lengths :func:`~polypack._kernels.cells.min_image` takes off ``d`` (see :func:`_shifted`)."""
    half = 0.5 * length
    q = 0
    if d > half:
        q = 1
        d -= length
        if d > half:
            q += int(np.floor(d / length + 0.5))
    elif d < -half:
        q = -1
        d += length
        if d < -half:
            q += int(np.floor(d / length + 0.5))
    return q


@njit(cache=True)
def _shifted(d, q, length):
    """``min_image(d, length)`` of a listed pair whose image count is ``q`` (:func:`_image_count`).

    No branches on ``d``: ``q`` stays valid while the pair is within half a box of its build-time
    image (listed pairs are within the cutoff plus twice the skin, at most half the box).  Bit for
    bit ``min_image`` when ``|q| <= 1``; beyond (spheres unwrapped more than 1.5 boxes apart) one
    rounding instead of ``min_image``'s two.
    """
    return d - length * q


@njit(cache=True)
def _fill_verlet(pos, box, reach, ncell, cell_of, start, order, pi, pj, img):
    """Store the pairs of :func:`_verlet_pairs` into the buffers; returns their count (may exceed the buffers).

    The cells of each sphere are those of :func:`~polypack._kernels.cells.cells_in_reach`, in its
    order, enumerated in place (:func:`~polypack._kernels.cells.axis_reach`,
    :func:`~polypack._kernels.cells.wrap_cell`) without its output array and per-call work arrays
    (their allocation per sphere took most of a rebuild); within
    a cell the spheres are in increasing index (:func:`~polypack._kernels.cells.build_cells`), so
    the scan stops at the first ``j >= i``.  Each sphere's pairs are then sorted by ``j``
    (insertion sort of a handful), so the list order is that of the pairs themselves, not of
    the cells their spheres were in at the build.
    """
    cap = pi.shape[0]
    cl = cell_lengths(box, ncell)
    n0 = ncell[0]
    n1 = ncell[1]
    n2 = ncell[2]
    lo0, hi0, full0 = axis_reach(reach, cl[0], n0)
    lo1, hi1, full1 = axis_reach(reach, cl[1], n1)
    lo2, hi2, full2 = axis_reach(reach, cl[2], n2)
    lim2 = reach * reach
    m = 0
    for i in range(pos.shape[0]):
        m0 = m
        ic = cell_of[i]
        cz = ic % n2
        cy = (ic // n2) % n1
        cx = ic // (n1 * n2)
        xi0 = pos[i, 0]
        xi1 = pos[i, 1]
        xi2 = pos[i, 2]
        for ox in range(lo0, hi0 + 1):
            x = wrap_cell(ox, cx, n0, full0)
            for oy in range(lo1, hi1 + 1):
                y = wrap_cell(oy, cy, n1, full1)
                for oz in range(lo2, hi2 + 1):
                    z = wrap_cell(oz, cz, n2, full2)
                    c = (x * n1 + y) * n2 + z
                    for s in range(start[c], start[c + 1]):
                        j = order[s]
                        if j >= i:
                            break
                        dx = min_image(pos[j, 0] - xi0, box[0])
                        dy = min_image(pos[j, 1] - xi1, box[1])
                        dz = min_image(pos[j, 2] - xi2, box[2])
                        # branch-free append (about one candidate in eight is kept: a branch on
                        # it was mispredicted often); the slot past the kept ones is overwritten
                        if m < cap:
                            pi[m] = i
                            pj[m] = j
                        m += dx * dx + dy * dy + dz * dz <= lim2
        for a in range(m0 + 1, min(m, cap)):  # the pairs of i by increasing j
            v = pj[a]
            b = a - 1
            while b >= m0 and pj[b] > v:
                pj[b + 1] = pj[b]
                b -= 1
            pj[b + 1] = v
    for k in range(min(m, cap)):  # image counts of the kept pairs
        i = pi[k]
        j = pj[k]
        img[k, 0] = _image_count(pos[j, 0] - pos[i, 0], box[0])
        img[k, 1] = _image_count(pos[j, 1] - pos[i, 1], box[1])
        img[k, 2] = _image_count(pos[j, 2] - pos[i, 2], box[2])
    return m


@njit(cache=True)
def _verlet_pairs(pos, box, reach, ncell):
    """Pairs ``i > j`` within ``reach`` (minimum image) and their image counts ``(M, 3)``.

    The pairs of :func:`~polypack._kernels.cells.pairs_within` for equal spheres, ordered by
    ``i``, then by ``j`` (since 5 Dec 2026; before, by the cells ``i`` visits).  The order of the
    pairs that act (within the cutoff, bonded, or within reach of capture or contact) is then the
    same whatever the reach, the cell grid or the step the list was built at, so the forces and
    the Gauss–Seidel projections, and with them the trajectory, do not depend on the skin, the
    cell grid or the rebuild times, bit for bit.
    """
    cell_of, start, order = build_cells(pos, box, ncell)
    cap = max(16, 8 * pos.shape[0])
    while True:
        pi = np.empty(cap, np.int64)
        pj = np.empty(cap, np.int64)
        img = np.empty((cap, 3), np.int16)
        m = _fill_verlet(pos, box, reach, ncell, cell_of, start, order, pi, pj, img)
        if m <= cap:
            return pi[:m], pj[:m], img[:m]
        cap = m


@njit(cache=True)
def _build(pos, box, params, adj, deg, ncell):
    """Verlet list: pairs ``pi > pj`` within cutoff + skin, bonded flags, image counts."""
    if params[P_R_CUT] <= 0.0:  # no pair forces and no bonds: no neighbour list
        e = np.empty(0, np.int64)
        return e, e.copy(), np.empty(0, np.uint8), np.empty((0, 3), np.int16)
    pi, pj, img = _verlet_pairs(pos, box, params[P_R_CUT] + params[P_SKIN], ncell)
    # the pairs come grouped by i: mark i's partners once, then one look-up per pair
    flag = np.zeros(pi.shape[0], np.uint8)
    mark = np.full(pos.shape[0], -1, np.int64)
    last = -1
    for k in range(pi.shape[0]):
        i = pi[k]
        if i != last:
            last = i
            for q in range(deg[i]):
                mark[adj[i, q]] = i
        if mark[pj[k]] == i:
            flag[k] = 1
    return pi, pj, flag, img


#: Shift written into a gathered pair's ``us`` row when it is captured (:func:`_project`): its
#: distance in :func:`_central_forces` is then ~1e30, beyond any cutoff, so the loop needs no test
#: of the bonded flags.
CAPTURED_SHIFT = 1e30


@njit(cache=True)
def _unbonded(pi, pj, flag, img, box, inverse=True):
    """The listed pairs unbonded at build time, gathered for :func:`_central_forces`: ``(ui, uj, uk, us, uq)``.

    ``uk`` their list positions (in order), ``ui``/``uj`` their spheres and ``us`` (M', 3) their
    minimum-image shifts ``box * image count`` (the product :func:`_shifted` takes off); ``uq`` (M,)
    the inverse of ``uk`` (-1 for the pairs bonded at the build), with which :func:`_project` takes
    a pair it captures out of the force loop (:data:`CAPTURED_SHIFT`); with ``inverse=False``
    (the rigid kernel, which skips captured pairs by their flag) ``uq`` is empty.  The force loop
    then reads contiguous arrays and never meets a bonded pair, instead of one in three listed
    pairs in a gel (a mispredicted skip) and a flag test per pair.
    """
    m = 0
    for k in range(pi.shape[0]):
        if flag[k] == 0:
            m += 1
    ui = np.empty(m, np.int64)
    uj = np.empty(m, np.int64)
    uk = np.empty(m, np.int64)
    us = np.empty((m, 3), np.float64)
    uq = np.full(pi.shape[0] if inverse else 0, -1, np.int64)
    q = 0
    for k in range(pi.shape[0]):
        if flag[k] == 0:
            ui[q] = pi[k]
            uj[q] = pj[k]
            uk[q] = k
            if inverse:
                uq[k] = q
            us[q, 0] = box[0] * img[k, 0]
            us[q, 1] = box[1] * img[k, 1]
            us[q, 2] = box[2] * img[k, 2]
            q += 1
    return ui, uj, uk, us, uq


#: Extra gap (radii) within which an unbonded pair seen in a full projection sweep is kept for
#: the next sweeps of the step (:func:`_project`); any value gives the same result, bit for bit.
NEAR_MARGIN = 0.2


@njit(cache=True)
def _project(pos, box, params, state, istate, pi, pj, flag, img, bonds, adj, deg, near, moved, margin, uq=None,
             us=None):
    """Capture and shell projection sweeps (see module docstring); returns a Status.

    Gauss–Seidel sweeps over the listed pairs in list order.  A full sweep also collects,
    in order, the pairs that can act in the next sweeps (bonded, or within ``margin`` of the
    capture or contact distance) into ``near`` and starts the per-sphere movement tally
    ``moved`` (each correction moves both centres by half of it); the next sweeps visit only
    those while twice the largest tally stays below ``margin`` (a skipped pair cannot then
    have come within reach), and go on as a full sweep from the point where it no longer
    does.  Pairs are always visited in the order of the full list, so the result is that of
    full sweeps bit for bit, whatever ``margin`` (:data:`NEAR_MARGIN` in the kernels).
    ``near`` (M,) int64 and ``moved`` (N,) float64 are work arrays.  With ``uq, us`` of
    :func:`_unbonded` a captured pair's shift row is set to :data:`CAPTURED_SHIFT` (it leaves the
    force loop).
    """
    width = params[P_BOND_WIDTH]
    cap_lim = 2.0 + max(width, 0.0)  # width < 0 (no bond shell given) counts as 0: corr below keeps its sign
    cap2 = cap_lim * cap_lim
    sweeps = int(params[P_SWEEPS])
    tol = params[P_PROJ_TOL]
    nb = istate[I_NBONDS]
    maxdeg = adj.shape[1]
    cap = bonds.shape[0]
    overlap_only = params[P_OVERLAP_ONLY] != 0.0
    keep = (2.0 if overlap_only else cap_lim) + margin
    keep2 = keep * keep
    half_margin = 0.5 * margin
    npair = pi.shape[0]
    worst = 0.0
    nnear = -1  # length of the near list; -1: none (the next sweep is a full one)
    tally = 0.0  # largest entry of moved since the near list was collected
    for _sweep in range(sweeps):
        worst = 0.0
        use_near = nnear >= 0 and tally < half_margin  # else skipped pairs may already act
        collect = not use_near
        count = nnear if use_near else npair
        if collect:
            for i in range(moved.shape[0]):
                moved[i] = 0.0
            tally = 0.0
            nnear = 0
        q = 0
        while q < count:
            k = near[q] if use_near else q
            q += 1
            i = pi[k]
            j = pj[k]
            dx = _shifted(pos[j, 0] - pos[i, 0], img[k, 0], box[0])
            dy = _shifted(pos[j, 1] - pos[i, 1], img[k, 1], box[1])
            dz = _shifted(pos[j, 2] - pos[i, 2], img[k, 2], box[2])
            r2 = dx * dx + dy * dy + dz * dz
            if collect and (flag[k] != 0 or r2 < keep2):
                near[nnear] = k
                nnear += 1
            if overlap_only:
                if r2 >= 4.0:
                    continue
            elif flag[k] == 0:
                if r2 >= cap2:
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
                if uq is not None:
                    us[uq[k], 0] = CAPTURED_SHIFT  # out of the force loop (unbonded at the build: uq[k] >= 0)
            # overlap (r < 2) or stretched bond (r > cap_lim; with overlap_only only r < 2 gets here);
            # branch-free: after the first sweep in-shell pairs are about as frequent as out-of-shell
            # ones, and the branch was mispredicted half the time (a zero correction moves nothing,
            # x - 0 * d = x, so the positions are those of the branches bit for bit)
            r = np.sqrt(r2)
            corr = max(2.0 - r, 0.0) + min(cap_lim - r, 0.0)
            c = abs(corr)
            worst = max(worst, c)
            s = 0.5 * corr / max(r, 1e-12)
            pos[i, 0] -= s * dx
            pos[i, 1] -= s * dy
            pos[i, 2] -= s * dz
            pos[j, 0] += s * dx
            pos[j, 1] += s * dy
            pos[j, 2] += s * dz
            if collect or use_near:
                moved[i] += 0.5 * c
                moved[j] += 0.5 * c
                tally = max(tally, max(moved[i], moved[j]))
                if use_near and tally >= half_margin:
                    # skipped pairs may act from here on: the rest of this sweep is a full one
                    use_near = False
                    q = k + 1
                    count = npair
                    nnear = -1
        istate[I_SWEEPS] += 1
        if worst <= tol:
            break
    if worst > state[S_MAX_RESIDUAL]:
        state[S_MAX_RESIDUAL] = worst
    istate[I_NBONDS] = nb
    return Status.OK


@njit(cache=True, inline="always")
def _pair_force(h, table, lo, inv_dh, cap_drift, dt, uc=0.0):
    """Central DLVO pair force (kT/a, positive = repulsive) at surface separation ``h``: the model force.

    Linear interpolation of ``table`` on the grid ``lo + k / inv_dh`` (clamped at both
    ends); with ``cap_drift > 0`` an attraction is capped (:func:`_cap_attraction`).  The
    pair loop evaluates its r² resampling (:func:`_force_table_r2`); this is the force that
    table approximates and the reference of its tests.
    """
    ntab = table.shape[0]
    t = (h - lo) * inv_dh
    if t <= 0.0:
        f = table[0]
    elif t >= ntab - 1:
        f = table[ntab - 1]
    else:
        q = int(t)
        w = t - q
        f = (1.0 - w) * table[q] + w * table[q + 1]
    return _cap_attraction(f, h, cap_drift, dt, uc)


@njit(cache=True, inline="always")
def _cap_attraction(f, h, cap_drift, dt, uc):
    """The drift cap of a pair force ``f`` (kT/a) at gap ``h`` (scalars only).

    With ``cap_drift > 0`` an attraction is capped so that the pair's gap closes by at most
    ``cap_drift * h`` in one step of length ``dt`` (module docstring), at the pair's relative
    mobility ``2 / β_eff(h)`` when lubricated (``uc > 0``).
    """
    if cap_drift > 0.0 and f < 0.0 and dt > 0.0:
        # both spheres move by |f| dt: the gap closes by 2 |f| dt at most cap_drift * h
        fmax = cap_drift * max(h, 0.0) / (2.0 * dt)
        if uc > 0.0:
            fmax *= lubrication_beta(h, uc)[0]
        if -f > fmax:
            f = -fmax
    return f


#: The r² force table of the pair loop (:func:`_force_table_r2`): its spacing in ``s = r²`` is that
#: of the h table at the table's start divided by the refinement factor ``R2_REFINE`` (finer in h
#: further out, where ``ds = 2 r dh``), with at least ``R2_MIN_INTERVALS`` intervals and at most
#: ``R2_MAX_INTERVALS`` or the number that spans the h table at that spacing, whichever is larger
#: (so the limit binds only for a cutoff far beyond the h table's end, where ``F`` is constant).
R2_REFINE = 2
R2_MIN_INTERVALS = 1024
R2_MAX_INTERVALS = 1 << 18


@njit(cache=True)
def _force_table_r2(table, params):
    """The pair loop's force table: ``F(r) / r`` on a uniform grid in ``s = r²``; returns ``(t2, tp)``.

    No square root and no division per pair: the loop reads ``F(r)/r`` at ``s = r²`` by
    linear interpolation and multiplies it by the pair's vector.  The nodes
    ``s_k = s_lo + k ds`` run from ``s_lo = max(2 + lo, 1)²`` (``lo`` the h table's start) to the
    cutoff ``r_c²``; ``t2[k] = F(r_k) / r_k`` with ``F`` the h table's interpolant without the
    drift cap (:func:`_pair_force`), so the loop's force is that interpolant re-interpolated
    in ``s`` (spacing: :data:`R2_REFINE` times finer than the h table's at the start, within
    the interval counts given there; the error against the h table and against the exact DLVO
    force is bounded in tests/test_bd_kernel.py).  Below ``s_lo`` (an overlap beyond the table)
    the loop takes the h table itself (:func:`_central_forces`), so the index is clamped to
    the table only to stay inside it; ``t2`` has one padding entry, so the clamped top index
    needs no test.  ``tp`` holds ``s_lo``, ``1 / ds``, the clamp ``m`` (the number of
    intervals) and ``s_cap``: pairs with ``s <= s_cap`` take the exact drift cap
    (:func:`_cap_attraction`, a square root and a division); beyond it no interpolated
    attraction can reach the cap (checked interval by interval at the build, with the cap's
    value at each interval's inner end and ``β_eff >= 1``), so the cap is never tested there.
    ``s_cap = -1`` when there is no cap (``P_CAP_DRIFT`` or ``P_DT`` zero) or it can bind
    nowhere on the table.
    """
    lo = params[P_TAB_LO]
    dh = params[P_TAB_DH]
    inv_dh = 1.0 / dh
    r_lo = max(2.0 + lo, 1.0)
    s_lo = r_lo * r_lo
    s_hi = max(params[P_R_CUT] * params[P_R_CUT], 1.01 * s_lo)  # no pairs (r_c <= 0) or all inside the start
    ds0 = 2.0 * r_lo * dh / R2_REFINE  # the spacing asked for
    r_end = 2.0 + lo + (table.shape[0] - 1) * dh  # the h table's end
    m_table = int(np.ceil((r_end * r_end - s_lo) / ds0))  # intervals spanning the h table at that spacing
    m = int(np.ceil((s_hi - s_lo) / ds0))
    m = min(max(m, R2_MIN_INTERVALS), max(R2_MAX_INTERVALS, m_table))
    ds = (s_hi - s_lo) / m
    t2 = np.empty(m + 2)
    for k in range(m + 1):
        r = np.sqrt(s_lo + k * ds)
        t2[k] = _pair_force(r - 2.0, table, lo, inv_dh, 0.0, 0.0) / r
    t2[m + 1] = t2[m]
    cap_drift = params[P_CAP_DRIFT]
    dt = params[P_DT]
    s_cap = -1.0
    if cap_drift > 0.0 and dt > 0.0:
        # below s_lo the loop takes the h table with its exact cap (_central_forces): no test needed there
        for k in range(m):
            att = max(-t2[k], -t2[k + 1])  # largest attraction / r of the interpolant on the interval
            if att > 0.0:
                r0 = np.sqrt(s_lo + k * ds)
                r1 = np.sqrt(s_lo + (k + 1) * ds)
                if att * r1 >= cap_drift * max(r0 - 2.0, 0.0) / (2.0 * dt):
                    s_cap = s_lo + (k + 2) * ds  # one interval of margin for the rounding of the index
    tp = np.empty(4)
    tp[0] = s_lo
    tp[1] = 1.0 / ds
    tp[2] = float(m)
    tp[3] = s_cap
    return t2, tp


@njit(cache=True)
def _below_table(r, table, lo, inv_dh, cap_drift, dt, uc):
    """``F / r`` of a pair below the r² table's start (:func:`_central_forces`): the h table's force, capped.

    Not inlined: the rare branch then costs the hot loop one call instead of the interpolation's code.
    """
    return _pair_force(r - 2.0, table, lo, inv_dh, cap_drift, dt, uc) / r


@njit(cache=True)
def _central_forces(pos, box, params, ui, uj, uk, us, flag, table, t2, tp, force, lab, rigid):
    """Add the tabulated central pair force of every unbonded listed pair to ``force``; returns sum r F.

    The one pair-force loop of the three kernels, over the pairs unbonded at the list build
    (``ui, uj, uk, us`` of :func:`_unbonded`, in list order; those captured since are skipped:
    by their :data:`CAPTURED_SHIFT`, or by ``flag`` in the rigid kernel).

    The flexible and tangential kernels (``rigid=False``) read the r² force table ``t2, tp`` of
    :func:`_force_table_r2` (``F/r`` at ``s = r²`` by linear interpolation, times the pair's
    vector: no square root or division per pair).  Only the pairs with ``s <= max(s_cap, s_lo)``
    take a rare branch with a square root: within ``s_cap`` the drift cap
    (:func:`_cap_attraction`, with the lubrication range of ``params``), below the table's
    start ``s_lo`` (an overlap beyond the table) the h table's force itself (:func:`_pair_force`,
    capped), so the three kernels agree there.  Each pair's minimum image comes from the gathered
    shifts ``us`` of the Verlet list (:func:`_shifted`, ``min_image`` bit for bit for spheres
    unwrapped up to 1.5 boxes apart).

    The rigid kernel (``rigid=True``) keeps the h table (:func:`_pair_force` at ``h = r - 2``,
    divided by ``r``; its runs are those before the r² table bit for bit; ``t2, tp`` unused),
    skips the pairs inside one rigid cluster (``lab``, see :func:`_internal`; their forces
    cancel in the cluster's force and torque), takes the plain minimum image (its clusters are
    shifted by box vectors on merging, so stored image counts would go stale) and caps without
    lubrication; ``lab`` is unused otherwise.  The branch is loop-invariant, so each kernel
    runs its own copy of the loop.
    """
    dt = params[P_DT]
    rc2 = params[P_R_CUT] * params[P_R_CUT]
    cap_drift = params[P_CAP_DRIFT]
    lo = params[P_TAB_LO]
    inv_dh = 1.0 / params[P_TAB_DH]
    uc = params[P_LUB_RANGE] if not rigid else 0.0
    s_lo = tp[0]
    inv_ds = tp[1]
    top = tp[2]
    s_slow = max(tp[3], s_lo)  # the rare branch: drift cap (s <= s_cap) or below the table (s < s_lo)
    vir = 0.0
    for q in range(ui.shape[0]):
        i = ui[q]
        j = uj[q]
        if rigid:
            if flag[uk[q]]:  # captured since the build
                continue
            if _internal(pos, box, i, j, lab):
                continue
            dx = min_image(pos[j, 0] - pos[i, 0], box[0])
            dy = min_image(pos[j, 1] - pos[i, 1], box[1])
            dz = min_image(pos[j, 2] - pos[i, 2], box[2])
        else:
            # _shifted, with the product gathered; a pair captured since the build has us[q, 0] =
            # CAPTURED_SHIFT (_project) and fails the cutoff test
            dx = (pos[j, 0] - pos[i, 0]) - us[q, 0]
            dy = (pos[j, 1] - pos[i, 1]) - us[q, 1]
            dz = (pos[j, 2] - pos[i, 2]) - us[q, 2]
        r2 = dx * dx + dy * dy + dz * dz
        if r2 >= rc2:
            continue
        if rigid:
            r = np.sqrt(r2)
            f = _pair_force(r - 2.0, table, lo, inv_dh, cap_drift, dt)
            vir += f * r
            fr = f / r
        else:
            t = min(max((r2 - s_lo) * inv_ds, 0.0), top)  # clamped: the index stays inside t2
            c = int(t)
            w = t - c
            fr = (1.0 - w) * t2[c] + w * t2[c + 1]  # F / r
            if r2 <= s_slow:
                r = max(np.sqrt(r2), 1e-12)  # (coincident centres: no force, as the vector is zero)
                if r2 < s_lo:  # below the table (an overlap beyond it): the h table's force, capped
                    fr = _below_table(r, table, lo, inv_dh, cap_drift, dt, uc)
                else:  # the drift cap may bind: exact, at r
                    fr = _cap_attraction(fr * r, r - 2.0, cap_drift, dt, uc) / r
            vir += fr * r2
        force[i, 0] -= fr * dx
        force[i, 1] -= fr * dy
        force[i, 2] -= fr * dz
        force[j, 0] += fr * dx
        force[j, 1] += fr * dy
        force[j, 2] += fr * dz
    return vir


@njit(cache=True)
def _trap_forces(pos, box, ktrap, force):
    """Add the harmonic trap ``-ktrap (x - L/2)`` per coordinate (minimum image) to ``force``."""
    cx = 0.5 * box[0]
    cy = 0.5 * box[1]
    cz = 0.5 * box[2]
    for i in range(pos.shape[0]):
        force[i, 0] -= ktrap * min_image(pos[i, 0] - cx, box[0])
        force[i, 1] -= ktrap * min_image(pos[i, 1] - cy, box[1])
        force[i, 2] -= ktrap * min_image(pos[i, 2] - cz, box[2])


@njit(cache=True)
def _max_displacement2(pos, ref, box, periodic_image):
    """Largest squared displacement since the last list build (minimum image if ``periodic_image``)."""
    maxd2 = 0.0
    for i in range(pos.shape[0]):
        d2 = 0.0
        for c in range(3):
            e = pos[i, c] - ref[i, c]
            if periodic_image:
                e = min_image(e, box[c])
            d2 += e * e
        if d2 > maxd2:
            maxd2 = d2
    return maxd2


@njit(cache=True, inline="always")
def _internal(pos, box, i, j, lab):
    """True if i and j are in one cluster and see each other at their stored (unwrapped) image."""
    if lab[i] != lab[j]:
        return False
    for c in range(3):
        d = pos[j, c] - pos[i, c]
        if abs(d - min_image(d, box[c])) > 0.5 * box[c]:
            return False
    return True


# ----------------------------------------------------------------------------------------
# Translation step: free draining or lubrication-corrected pair mobility
# ----------------------------------------------------------------------------------------
#
# Mobility (reduced, sphere mobility 1):  M = S S,  S = I - sum_p k_p b_p b_p^T  over the
# lubricated pairs p = (i, j) (unbonded, gap u = r - 2 < u_c), b_p = (e_i - e_j) (x) n_p,
# n_p = (x_j - x_i) / r_p, k_p = (1 - beta_p^(-1/2)) / 2.  For an isolated pair S has the
# eigenvalue 1 - 2 k_p = beta^(-1/2) on b_p and 1 elsewhere, so M divides the relative
# normal mobility by beta (Honig et al. 1971) and leaves the centre of mass and the
# tangential relative motion free draining; M is positive semi-definite for any set of
# pairs.  One Euler-Maruyama (Ito) step is
#     dx = M F dt + sqrt(2 dt) S xi + (div M) dt,
# covariance 2 dt S S^T = 2 dt M (fluctuation-dissipation).  div M, derived in
# docs/brownian.md: with c_p = 2 k_p (1 - k_p) = (1 - 1/beta_p) / 2,
#   pair terms    +(2 c_p' + 4 c_p / r_p) n_p on i, the opposite on j;
#   cross terms   for every particle m and ordered pairs p != q through m, with
#                 s = +1 (first) / -1 (second) the side of m in each pair, sigma = s_p s_q,
#                 c = n_p . n_q:
#                 g = -k_p' k_q c^2 - 2 sigma k_p k_q' c - k_p k_q (1 - c^2) / r_p
#                     - 4 sigma k_p k_q c / r_q,
#                 w = g n_p - k_p k_q c (n_q - c n_p) / r_p,   +w on i_p, -w on j_p.
# (' = d/dr.)  The kT factor is 1; noise-free steps (P_NOISE = 0) drop the thermal drift.


@njit(cache=True)
def lubrication_beta(u, uc):
    """Honig factor ``β_eff(u)`` and ``dβ_eff/du`` of the implemented pair mobility.

    ``β(u) = (6u² + 13u + 2) / (6u² + 4u)`` (Honig, Roebersen & Wiersema 1971; ``u`` =
    surface gap / radius) times a smooth taper of ``β - 1``: ``β_eff = 1 + (β - 1) s``,
    ``s = 1`` for ``u <= uc/2``, ``s = 1 - t² (3 - 2t)`` with ``t = 2u/uc - 1`` up to
    ``uc`` and 0 beyond (``uc <= 0``: ``β_eff = 1``).  Below ``LUB_U_FLOOR`` the factor is
    held at its floor value.
    """
    if uc <= 0.0 or u >= uc:
        return 1.0, 0.0
    uu = max(u, LUB_U_FLOOR)
    den = 6.0 * uu * uu + 4.0 * uu
    b = (6.0 * uu * uu + 13.0 * uu + 2.0) / den
    db = -(54.0 * uu * uu + 24.0 * uu + 8.0) / (den * den) if u > LUB_U_FLOOR else 0.0
    x = u / uc
    if x <= 0.5:
        return b, db
    t = 2.0 * x - 1.0
    sfac = 1.0 - t * t * (3.0 - 2.0 * t)
    dsfac = -6.0 * t * (1.0 - t) * 2.0 / uc
    return 1.0 + (b - 1.0) * sfac, db * sfac + (b - 1.0) * dsfac


@njit(cache=True)
def _lub_collect(pos, box, pi, pj, flag, uc, lp, lv, lr, lk, ldk, lc, ldc):
    """Fill the lubricated pairs (unbonded listed pairs with gap < uc); returns their count."""
    m = 0
    lim = 2.0 + uc
    for k in range(pi.shape[0]):
        if flag[k]:
            continue
        i = pi[k]
        j = pj[k]
        dx = min_image(pos[j, 0] - pos[i, 0], box[0])
        dy = min_image(pos[j, 1] - pos[i, 1], box[1])
        dz = min_image(pos[j, 2] - pos[i, 2], box[2])
        r2 = dx * dx + dy * dy + dz * dz
        if r2 >= lim * lim:
            continue
        r = max(np.sqrt(r2), 1e-300)
        b, db = lubrication_beta(r - 2.0, uc)
        if b <= 1.0:
            continue
        lp[m, 0] = i
        lp[m, 1] = j
        lv[m, 0] = dx / r
        lv[m, 1] = dy / r
        lv[m, 2] = dz / r
        lr[m] = r
        rb = 1.0 / np.sqrt(b)
        lk[m] = 0.5 * (1.0 - rb)
        ldk[m] = 0.25 * rb * rb * rb * db
        lc[m] = 0.5 * (1.0 - 1.0 / b)
        ldc[m] = 0.5 * db / (b * b)
        m += 1
    return m


@njit(cache=True)
def _lub_pairs(pos, box, pi, pj, flag, uc):
    """Arrays of :func:`_lub_collect` sized for the listed pairs; returns ``(m, lp, lv, lr, lk, ldk, lc, ldc)``."""
    npair = pi.shape[0]
    lp = np.empty((npair, 2), np.int64)
    lv = np.empty((npair, 3))
    lr = np.empty(npair)
    lk = np.empty(npair)
    ldk = np.empty(npair)
    lc = np.empty(npair)
    ldc = np.empty(npair)
    m = _lub_collect(pos, box, pi, pj, flag, uc, lp, lv, lr, lk, ldk, lc, ldc)
    return m, lp, lv, lr, lk, ldk, lc, ldc


@njit(cache=True)
def _lub_apply_s(m, lp, lv, lk, v, out):
    """``out = S v`` (``out`` may not alias ``v``)."""
    for i in range(v.shape[0]):
        for c in range(3):
            out[i, c] = v[i, c]
    for p in range(m):
        i = lp[p, 0]
        j = lp[p, 1]
        bv = 0.0
        for c in range(3):
            bv += lv[p, c] * (v[i, c] - v[j, c])
        s = lk[p] * bv
        for c in range(3):
            out[i, c] -= s * lv[p, c]
            out[j, c] += s * lv[p, c]


@njit(cache=True)
def _lub_divergence(n, m, lp, lv, lr, lk, ldk, lc, ldc, div):
    """``div = ∇·M`` of the lubricated mobility (formulas above :func:`lubrication_beta`)."""
    for i in range(n):
        for c in range(3):
            div[i, c] = 0.0
    cnt = np.zeros(n + 1, np.int64)
    for p in range(m):
        w = 2.0 * ldc[p] + 4.0 * lc[p] / lr[p]
        i = lp[p, 0]
        j = lp[p, 1]
        for c in range(3):
            div[i, c] += w * lv[p, c]
            div[j, c] -= w * lv[p, c]
        cnt[i + 1] += 1
        cnt[j + 1] += 1
    for i in range(n):
        cnt[i + 1] += cnt[i]
    ent = np.empty(2 * m, np.int64)
    side = np.empty(2 * m, np.float64)
    fill = cnt[:n].copy()
    for p in range(m):
        for e in range(2):
            q = lp[p, e]
            ent[fill[q]] = p
            side[fill[q]] = 1.0 if e == 0 else -1.0
            fill[q] += 1
    w = np.empty(3)
    for x in range(n):
        for a in range(cnt[x], cnt[x + 1]):
            p = ent[a]
            for b in range(cnt[x], cnt[x + 1]):
                if b == a:
                    continue
                q = ent[b]
                sg = side[a] * side[b]
                cc = lv[p, 0] * lv[q, 0] + lv[p, 1] * lv[q, 1] + lv[p, 2] * lv[q, 2]
                kk = lk[p] * lk[q]
                g = (-ldk[p] * lk[q] * cc * cc - 2.0 * sg * lk[p] * ldk[q] * cc - kk * (1.0 - cc * cc) / lr[p]
                     - 4.0 * sg * kk * cc / lr[q])
                for c in range(3):
                    w[c] = g * lv[p, c] - kk * cc * (lv[q, c] - cc * lv[p, c]) / lr[p]
                i = lp[p, 0]
                j = lp[p, 1]
                for c in range(3):
                    div[i, c] += w[c]
                    div[j, c] -= w[c]


@njit(cache=True)
def lubrication_terms(pos, box, uc, pi, pj, flag, v, sv, div):
    """``sv = S v`` and ``div = ∇·M`` for the pairs ``(pi, pj)`` (``flag`` 1 = bonded, skipped).

    Validation entry point of the lubricated mobility (the step uses the same helpers).
    Returns the number of lubricated pairs.
    """
    m, lp, lv, lr, lk, ldk, lc, ldc = _lub_pairs(pos, box, pi, pj, flag, uc)
    _lub_apply_s(m, lp, lv, lk, v, sv)
    _lub_divergence(pos.shape[0], m, lp, lv, lr, lk, ldk, lc, ldc, div)
    return m


@njit(cache=True)
def _translate(pos, box, params, pi, pj, flag, force, rng, state):
    """One translation step of every centre: free draining, or with the lubricated mobility."""
    n = pos.shape[0]
    dt = params[P_DT]
    noise = params[P_NOISE]
    uc = params[P_LUB_RANGE]
    if uc <= 0.0 or pi.shape[0] == 0:
        s0, s1, s2, s3 = _rng_load(rng)  # the generator's state in registers for the pass (_u64)
        for i in range(n):
            for c in range(3):
                x = pos[i, c] + force[i, c] * dt
                if noise != 0.0:
                    g, s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
                    x += noise * g
                pos[i, c] = x
        _rng_store(rng, s0, s1, s2, s3)
        return
    m, lp, lv, lr, lk, ldk, lc, ldc = _lub_pairs(pos, box, pi, pj, flag, uc)
    a = np.empty((n, 3))
    b = np.empty((n, 3))
    _lub_apply_s(m, lp, lv, lk, force, a)
    _lub_apply_s(m, lp, lv, lk, a, b)  # b = M F
    for i in range(n):
        for c in range(3):
            pos[i, c] += b[i, c] * dt
    if noise == 0.0:
        return
    s0, s1, s2, s3 = _rng_load(rng)
    for i in range(n):
        for c in range(3):
            a[i, c], s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
    _rng_store(rng, s0, s1, s2, s3)
    _lub_apply_s(m, lp, lv, lk, a, b)  # b = S xi
    if params[P_LUB_NO_DRIFT] != 0.0:
        a[:, :] = 0.0
    else:
        _lub_divergence(n, m, lp, lv, lr, lk, ldk, lc, ldc, a)
    for i in range(n):
        for c in range(3):
            pos[i, c] += noise * b[i, c] + a[i, c] * dt


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
        Time, virial accumulators, (unused slots), constraint residual; step,
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
    ktrap = params[P_TRAP_K]

    t2, tp = _force_table_r2(table, params)
    pi, pj, flag, img = _build(pos, box, params, adj, deg, ncell)
    ui, uj, uk, us, uq = _unbonded(pi, pj, flag, img, box)
    near = np.empty(pi.shape[0], np.int64)
    moved = np.zeros(n, np.float64)
    ref = pos.copy()
    force = np.zeros((n, 3), np.float64)
    for _step in range(nsteps):
        for i in range(n):
            force[i, 0] = 0.0
            force[i, 1] = 0.0
            force[i, 2] = 0.0
        vir = _central_forces(pos, box, params, ui, uj, uk, us, flag, table, t2, tp, force, _NO_LABELS, False)
        if ktrap != 0.0:
            _trap_forces(pos, box, ktrap, force)
        state[S_VIRIAL] += vir
        state[S_VIRIAL_STEPS] += 1.0
        _translate(pos, box, params, pi, pj, flag, force, rng, state)
        if bonding:
            status = _project(pos, box, params, state, istate, pi, pj, flag, img, bonds, adj, deg, near, moved,
                              NEAR_MARGIN, uq, us)
            if status != Status.OK:
                return status
        state[S_TIME] += dt
        istate[I_STEPS] += 1
        maxd2 = _max_displacement2(pos, ref, box, False)
        if maxd2 > half_skin2 and rc2 > 0.0:
            pi, pj, flag, img = _build(pos, box, params, adj, deg, ncell)
            ui, uj, uk, us, uq = _unbonded(pi, pj, flag, img, box)
            if near.shape[0] < pi.shape[0]:
                near = np.empty(pi.shape[0], np.int64)
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
    deg[:] = 0
    istate[:] = 0
    params[P_K_SLIDE] = 10.0
    params[P_K_ROLL] = 10.0
    params[P_ROLL_MAX] = 0.1
    orient = np.zeros((8, 3))
    orient[:, 2] = 1.0
    run_tangential(pos, box, params, state, istate, table, bonds, adj, deg, np.array([2, 2, 2], np.int64),
                   rng_state, 3, np.zeros((32, 6)), orient)


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


@njit(cache=True, inline="always")
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


@njit(cache=True, inline="always")
def _rodrigues(tx, ty, tz):
    """The nine entries (row by row) of the rotation matrix of the rotation vector (tx, ty, tz)
    (Rodrigues' formula); scalars in and out, so an inlined call costs no reference counts."""
    th = np.sqrt(tx * tx + ty * ty + tz * tz)
    if th < 1e-300:
        return 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    kx = tx / th
    ky = ty / th
    kz = tz / th
    c = np.cos(th)
    s = np.sin(th)
    v = 1.0 - c
    return (c + kx * kx * v, kx * ky * v - kz * s, kx * kz * v + ky * s,
            ky * kx * v + kz * s, c + ky * ky * v, ky * kz * v - kx * s,
            kz * kx * v - ky * s, kz * ky * v + kx * s, c + kz * kz * v)


@njit(cache=True, inline="always")
def _rotation(tx, ty, tz, out):
    """Rotation matrix of the rotation vector (tx, ty, tz) (:func:`_rodrigues`), written to ``out`` (3, 3)."""
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = _rodrigues(tx, ty, tz)
    out[0, 0] = r00
    out[0, 1] = r01
    out[0, 2] = r02
    out[1, 0] = r10
    out[1, 1] = r11
    out[1, 2] = r12
    out[2, 0] = r20
    out[2, 1] = r21
    out[2, 2] = r22


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
    ktrap = params[P_TRAP_K]

    pi, pj, flag, img = _build(pos, box, params, adj, deg, ncell)
    ui, uj, uk, us, _ = _unbonded(pi, pj, flag, img, box, False)  # captured pairs skipped by their flag
    ref = pos.copy()
    force = np.zeros((n, 3), np.float64)
    for _step in range(nsteps):
        for i in range(n):
            force[i, 0] = 0.0
            force[i, 1] = 0.0
            force[i, 2] = 0.0
        vir = _central_forces(pos, box, params, ui, uj, uk, us, flag, table, _NO_R2_TABLE, _NO_R2_PARAMS, force,
                              lab, True)
        if ktrap != 0.0:
            _trap_forces(pos, box, ktrap, force)
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
        maxd2 = _max_displacement2(pos, ref, box, True)
        if maxd2 > half_skin2 and rc2 > 0.0:
            pi, pj, flag, img = _build(pos, box, params, adj, deg, ncell)
            ui, uj, uk, us, _ = _unbonded(pi, pj, flag, img, box, False)
            for i in range(n):
                for c in range(3):
                    ref[i, c] = pos[i, c]
            istate[I_REBUILDS] += 1
    return Status.OK


# ----------------------------------------------------------------------------------------
# Tangential bonds: sliding and rolling resistance (rotational Brownian dynamics)
# ----------------------------------------------------------------------------------------
#
# Every bond b = (i, j) carries two unit "anchor" vectors in the lab frame, anchors[b, 0:3] = u
# (a material direction of sphere i, rotating with i) and anchors[b, 3:6] = w (of sphere j),
# set at capture to u = n, w = -n (n the unit vector from i to j).  With radius 1:
#
#   sliding    d  = x_j - x_i + w - u       (separation of the two surface material points that
#                                            touched at capture; zero at capture up to the gap)
#   rolling    xi = (u + w) / 2             (the rolling displacement of Dominik & Tielens 1995,
#                                            in units of the radius, for equal spheres)
#   U = k_s |d|^2 / 2 + k_r |xi|^2 / 2
#
# Forces and torques are the exact gradients: F_i = k_s d = -F_j, tau_i = k_s u x d,
# tau_j = -k_s w x d, tau_i = -(k_r / 4) u x w = -tau_j.  A rigid-body motion of the pair
# leaves d and xi unchanged; rolling without slipping changes xi only, sliding changes d only;
# twisting about n is free.  Rolling yields (Dominik & Tielens): when |xi| exceeds P_ROLL_MAX
# the anchors are turned (about u x w, symmetrically) back to |xi| = P_ROLL_MAX, so the rolling
# moment (k_r / 2) |xi| never exceeds (k_r / 2) P_ROLL_MAX.  Rotations: free-draining rotational
# friction 8 pi eta a^3 = (4/3) in reduced units (mobility 3/4), rotational noise sqrt(2 (3/4) dt).

SPHERE_ROT_MOBILITY = 1.0 / SPHERE_ROT_FRICTION


@njit(cache=True)
def _init_anchors(pos, box, bonds, anchors, first, last):
    """Anchors of the bonds ``first <= b < last`` (new captures): u = n, w = -n."""
    for b in range(first, last):
        i = bonds[b, 0]
        j = bonds[b, 1]
        dx = min_image(pos[j, 0] - pos[i, 0], box[0])
        dy = min_image(pos[j, 1] - pos[i, 1], box[1])
        dz = min_image(pos[j, 2] - pos[i, 2], box[2])
        r = max(np.sqrt(dx * dx + dy * dy + dz * dz), 1e-300)
        anchors[b, 0] = dx / r
        anchors[b, 1] = dy / r
        anchors[b, 2] = dz / r
        anchors[b, 3] = -dx / r
        anchors[b, 4] = -dy / r
        anchors[b, 5] = -dz / r


@njit(cache=True)
def _tangential_forces(pos, box, params, bonds, nb, anchors, force, torque):
    """Sliding and rolling spring forces/torques of every bond (module comment); applies the rolling yield."""
    ks = params[P_K_SLIDE]
    kr = params[P_K_ROLL]
    xmax = params[P_ROLL_MAX]
    for b in range(nb):
        i = bonds[b, 0]
        j = bonds[b, 1]
        ux = anchors[b, 0]
        uy = anchors[b, 1]
        uz = anchors[b, 2]
        wx = anchors[b, 3]
        wy = anchors[b, 4]
        wz = anchors[b, 5]
        if kr > 0.0:
            xx = 0.5 * (ux + wx)
            xy = 0.5 * (uy + wy)
            xz = 0.5 * (uz + wz)
            xn = np.sqrt(xx * xx + xy * xy + xz * xz)
            if xn > xmax:
                # yield: u = c m + s e, w = -c m + s e with m = (u - w)/|u - w|, e = xi/|xi|, s = xmax
                mx = ux - wx
                my = uy - wy
                mz = uz - wz
                mn = max(np.sqrt(mx * mx + my * my + mz * mz), 1e-300)
                mx /= mn
                my /= mn
                mz /= mn
                s = min(xmax, 1.0)
                c = np.sqrt(1.0 - s * s)
                ex = xx / xn
                ey = xy / xn
                ez = xz / xn
                ux = c * mx + s * ex
                uy = c * my + s * ey
                uz = c * mz + s * ez
                wx = -c * mx + s * ex
                wy = -c * my + s * ey
                wz = -c * mz + s * ez
                anchors[b, 0] = ux
                anchors[b, 1] = uy
                anchors[b, 2] = uz
                anchors[b, 3] = wx
                anchors[b, 4] = wy
                anchors[b, 5] = wz
            g = 0.25 * kr
            cx = uy * wz - uz * wy
            cy = uz * wx - ux * wz
            cz = ux * wy - uy * wx
            torque[i, 0] -= g * cx
            torque[i, 1] -= g * cy
            torque[i, 2] -= g * cz
            torque[j, 0] += g * cx
            torque[j, 1] += g * cy
            torque[j, 2] += g * cz
        if ks > 0.0:
            dx = min_image(pos[j, 0] - pos[i, 0], box[0]) + wx - ux
            dy = min_image(pos[j, 1] - pos[i, 1], box[1]) + wy - uy
            dz = min_image(pos[j, 2] - pos[i, 2], box[2]) + wz - uz
            force[i, 0] += ks * dx
            force[i, 1] += ks * dy
            force[i, 2] += ks * dz
            force[j, 0] -= ks * dx
            force[j, 1] -= ks * dy
            force[j, 2] -= ks * dz
            torque[i, 0] += ks * (uy * dz - uz * dy)
            torque[i, 1] += ks * (uz * dx - ux * dz)
            torque[i, 2] += ks * (ux * dy - uy * dx)
            torque[j, 0] -= ks * (wy * dz - wz * dy)
            torque[j, 1] -= ks * (wz * dx - wx * dz)
            torque[j, 2] -= ks * (wx * dy - wy * dx)


@njit(cache=True)
def run_tangential(pos, box, params, state, istate, table, bonds, adj, deg, ncell, rng, nsteps, anchors,
                   orient):
    """Advance ``nsteps`` steps of the flexible model with tangential bond springs (in place).

    Arguments as :func:`run`, plus ``anchors`` (B, 6) float64 (the two anchor unit
    vectors of each bond row, see the comment above :func:`_init_anchors`; rows of new
    bonds are set at capture) and ``orient`` (N, 3) float64, one body-fixed unit vector
    per sphere (rotated with it; diagnostics such as rotational diffusion).

    Each step: DLVO forces of the unbonded pairs, sliding/rolling spring forces and
    torques of the bonds (rolling yield applied first), an Ermak–McCammon step of every
    centre (mobility 1) and of every orientation (rotation vector
    ``(3/4) tau dt + sqrt(2 (3/4) dt) xi``, Rodrigues rotation of the sphere's anchors
    and ``orient``), then the capture and shell projections of :func:`run`.  With both
    stiffnesses zero and ``P_ROTATE = 0`` no rotation is integrated and the trajectory
    is that of :func:`run` bit for bit.
    """
    n = pos.shape[0]
    dt = params[P_DT]
    noise = params[P_NOISE]
    rc2 = params[P_R_CUT] * params[P_R_CUT]
    half_skin2 = 0.25 * params[P_SKIN] * params[P_SKIN]
    bonding = params[P_BOND_WIDTH] >= 0.0
    ktrap = params[P_TRAP_K]
    springs = params[P_K_SLIDE] > 0.0 or params[P_K_ROLL] > 0.0
    rotate = springs or params[P_ROTATE] != 0.0
    rnoise = noise * np.sqrt(SPHERE_ROT_MOBILITY)

    t2, tp = _force_table_r2(table, params)
    pi, pj, flag, img = _build(pos, box, params, adj, deg, ncell)
    ui, uj, uk, us, uq = _unbonded(pi, pj, flag, img, box)
    near = np.empty(pi.shape[0], np.int64)
    moved = np.zeros(n, np.float64)
    ref = pos.copy()
    force = np.zeros((n, 3), np.float64)
    torque = np.zeros((n, 3), np.float64)
    rot = np.zeros((n, 3, 3), np.float64)
    for _step in range(nsteps):
        for i in range(n):
            for c in range(3):
                force[i, c] = 0.0
                torque[i, c] = 0.0
        vir = _central_forces(pos, box, params, ui, uj, uk, us, flag, table, t2, tp, force, _NO_LABELS, False)
        if springs:
            _tangential_forces(pos, box, params, bonds, istate[I_NBONDS], anchors, force, torque)
        if ktrap != 0.0:
            _trap_forces(pos, box, ktrap, force)
        state[S_VIRIAL] += vir
        state[S_VIRIAL_STEPS] += 1.0
        _translate(pos, box, params, pi, pj, flag, force, rng, state)
        if rotate:
            s0, s1, s2, s3 = _rng_load(rng)  # the generator's state in registers for the pass (_u64)
            for i in range(n):
                tx = SPHERE_ROT_MOBILITY * torque[i, 0] * dt
                ty = SPHERE_ROT_MOBILITY * torque[i, 1] * dt
                tz = SPHERE_ROT_MOBILITY * torque[i, 2] * dt
                if noise != 0.0:
                    g, s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
                    tx += rnoise * g
                    g, s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
                    ty += rnoise * g
                    g, s0, s1, s2, s3 = _normal(s0, s1, s2, s3)
                    tz += rnoise * g
                # the Rodrigues matrix and its product with orient[i] in scalars (a helper's array
                # arguments cost a reference count per sphere)
                r00, r01, r02, r10, r11, r12, r20, r21, r22 = _rodrigues(tx, ty, tz)
                rot[i, 0, 0] = r00
                rot[i, 0, 1] = r01
                rot[i, 0, 2] = r02
                rot[i, 1, 0] = r10
                rot[i, 1, 1] = r11
                rot[i, 1, 2] = r12
                rot[i, 2, 0] = r20
                rot[i, 2, 1] = r21
                rot[i, 2, 2] = r22
                x = orient[i, 0]
                y = orient[i, 1]
                z = orient[i, 2]
                orient[i, 0] = r00 * x + r01 * y + r02 * z
                orient[i, 1] = r10 * x + r11 * y + r12 * z
                orient[i, 2] = r20 * x + r21 * y + r22 * z
            _rng_store(rng, s0, s1, s2, s3)
            nb = istate[I_NBONDS]
            for b in range(nb):
                i = bonds[b, 0]
                j = bonds[b, 1]
                u0 = anchors[b, 0]
                u1 = anchors[b, 1]
                u2 = anchors[b, 2]
                w0 = anchors[b, 3]
                w1 = anchors[b, 4]
                w2 = anchors[b, 5]
                anchors[b, 0] = rot[i, 0, 0] * u0 + rot[i, 0, 1] * u1 + rot[i, 0, 2] * u2
                anchors[b, 1] = rot[i, 1, 0] * u0 + rot[i, 1, 1] * u1 + rot[i, 1, 2] * u2
                anchors[b, 2] = rot[i, 2, 0] * u0 + rot[i, 2, 1] * u1 + rot[i, 2, 2] * u2
                anchors[b, 3] = rot[j, 0, 0] * w0 + rot[j, 0, 1] * w1 + rot[j, 0, 2] * w2
                anchors[b, 4] = rot[j, 1, 0] * w0 + rot[j, 1, 1] * w1 + rot[j, 1, 2] * w2
                anchors[b, 5] = rot[j, 2, 0] * w0 + rot[j, 2, 1] * w1 + rot[j, 2, 2] * w2
        if bonding:
            nb_old = istate[I_NBONDS]
            status = _project(pos, box, params, state, istate, pi, pj, flag, img, bonds, adj, deg, near, moved,
                              NEAR_MARGIN, uq, us)
            _init_anchors(pos, box, bonds, anchors, nb_old, istate[I_NBONDS])
            if status != Status.OK:
                return status
        state[S_TIME] += dt
        istate[I_STEPS] += 1
        maxd2 = _max_displacement2(pos, ref, box, False)
        if maxd2 > half_skin2 and rc2 > 0.0:
            pi, pj, flag, img = _build(pos, box, params, adj, deg, ncell)
            ui, uj, uk, us, uq = _unbonded(pi, pj, flag, img, box)
            if near.shape[0] < pi.shape[0]:
                near = np.empty(pi.shape[0], np.int64)
            for i in range(n):
                for c in range(3):
                    ref[i, c] = pos[i, c]
            istate[I_REBUILDS] += 1
    return Status.OK
