"""The sparse solvers of :func:`polypack.mechanics.elastic_tensor`: the relaxation ``H x = -Xi`` of a
periodic bonded network, apart from the tensor that is built from its solution.

``"direct"`` (:func:`_solve_direct`): a symmetric factorization (MKL PARDISO through pypardiso
when it is installed, else SciPy SuperLU) that counts the floppy modes by Sylvester's law of
inertia and solves by iterative refinement or, for soft modes, by factor-preconditioned
conjugate gradients; the floppy modes are projected out of the fields (:func:`_floppy_basis`,
:func:`_remove_floppy`) and random vectors of the floppy space drawn (:func:`_null_samples`).
``"cg"`` / ``"amg"`` (:func:`_solve_cg`): conjugate gradients preconditioned by block Jacobi or
by a smoothed-aggregation algebraic multigrid cycle (:class:`_Multigrid`). :func:`_auto_solver`
picks one from the size and the coordination.
"""
from __future__ import annotations

import os

import numpy as np

# Largest system (unknowns) solved by the sparse factorization under solver="auto" when
# only SciPy's SuperLU is available: its fill on 3D networks grows fast (48 000 unknowns:
# minutes), CG does not.
_DIRECT_MAX = 6000
# With MKL PARDISO (pypardiso; a supernodal, nested-dissection LDL^T), solver="auto" also
# factorizes networks of up to this many unknowns when they are near-isostatic (see
# _ISOSTATIC_MARGIN): measured, one core, N = 8000 (48 000 unknowns): phi = 0.4, Z = 4.7,
# 2.7 s factorization against 57 s of block-Jacobi CG; jammed, Z = 6.6, 10 s against 3.2 s
# of AMG-CG (more fill, and CG converges fast there).
_PARDISO_MAX = 150000
# Largest number of collective floppy modes (beyond the local two-bond spins) projected out
# of the non-affine fields by the dense subspace iteration of _floppy_basis.
_FLOPPY_BASIS_MAX = 400
# With PARDISO, every network up to this many unknowns is factorized (measured, jammed
# N = 2000, 12 000 unknowns: 1.0 s against 1.1 s of block-Jacobi CG; the count of floppy
# modes comes free).
_PARDISO_ANY_MAX = 12000
# "Near-isostatic": mean coordination of the relaxing backbone below this factor times the
# isostatic one (2 nd / 3: 4 with rotations, 2 without; each bond pins 3 relative displacements).
_ISOSTATIC_MARGIN = 1.4
# Smallest system solved by AMG-preconditioned CG under solver="auto": below it the
# multigrid setup costs more than block-Jacobi CG saves (measured, one core: N = 1200
# jammed, 7 200 unknowns: cg 0.6 s, amg 1.3 s; N = 8000, 48 000 unknowns: cg 7.8 s, amg 3.2 s).
_AMG_MIN = 24000
# Coarsest AMG level: at most this many particle blocks (solved by a pseudo-inverse).
_AMG_MAX_COARSE = 300


_MKL_RT = []


def _pardiso_module():
    """:mod:`pypardiso` (MKL PARDISO) if it is installed and loads, else None."""
    try:
        import pypardiso
    except Exception:  # noqa: BLE001 - optional accelerator (x86-64 wheels only)
        return None
    return pypardiso


def _mkl_runtime():
    """Path of the MKL runtime beside this interpreter (the ``mkl`` wheel), or None.

    Handed to pypardiso through ``PYPARDISO_MKL_RT``: its own search walks the whole
    ``lib`` tree (seconds) on every solver it makes.
    """
    if not _MKL_RT:
        import glob
        import sys

        found = sorted(glob.glob(os.path.join(sys.prefix, "lib", "libmkl_rt.so*")), key=len)
        _MKL_RT.append(found[0] if found else None)
    return _MKL_RT[0]


# PARDISO controls (1-based, as in the MKL manual): user values; METIS nested dissection;
# no internal iterative refinement (done here against the unshifted matrix); pivot
# perturbation 1e-8; Bunch-Kaufman 1x1/2x2 pivoting (symmetric indefinite); classic
# sequential factorization.
_PARDISO_IPARM = {1: 1, 2: 2, 8: 0, 10: 8, 21: 1, 24: 0}


class _Pardiso:
    """MKL PARDISO factorization of a real symmetric (``mtype`` 2: positive definite,
    Cholesky; -2: indefinite, Bunch-Kaufman pivoting) matrix, nested-dissection (METIS)
    ordering, one thread. ``negative`` is the inertia count of negative pivots."""

    def __init__(self, a, mtype):
        import scipy.sparse as sp

        mod = _pardiso_module()
        rt = _mkl_runtime()
        saved = os.environ.get("PYPARDISO_MKL_RT")
        if rt and not saved:
            os.environ["PYPARDISO_MKL_RT"] = rt
        try:
            self._s = mod.PyPardisoSolver(mtype=mtype)
        finally:
            if rt and not saved:
                del os.environ["PYPARDISO_MKL_RT"]
        try:
            self._s.libmkl.MKL_Set_Num_Threads(1)
        except AttributeError:  # pragma: no cover - older MKL runtimes
            pass
        for key, value in _PARDISO_IPARM.items():
            self._s.set_iparm(key, value)
        self._a = sp.triu(a, format="csr")
        self._a.sort_indices()
        self._s.factorize(self._a)
        self.negative = int(self._s.get_iparm(23))
        self.perturbed = int(self._s.get_iparm(14))

    def solve(self, b):
        return self._s.solve(self._a, np.ascontiguousarray(b, dtype=np.float64))

    def free(self):
        self._s.free_memory(everything=True)


class _SuperLU:
    """SciPy SuperLU in symmetric mode without pivoting (an LDL^T-type factorization)."""

    def __init__(self, a, mtype):
        import scipy.sparse.linalg as sla

        self._lu = sla.splu(a.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                            options={"SymmetricMode": True})
        self.negative = None
        if np.array_equal(self._lu.perm_r, self._lu.perm_c):
            self.negative = int(np.count_nonzero(self._lu.U.diagonal() < 0))
        self.perturbed = 0

    def solve(self, b):
        return self._lu.solve(b)

    def free(self):
        self._lu = None


def _refine(h, b, bn, solve, tol, max_refine):
    """Iterative refinement ``x += F^-1 (b - h x)``; returns x and the residual."""
    x = solve(b)
    res = np.inf
    for _ in range(max_refine):
        r = b - h @ x
        new = float((np.linalg.norm(r, axis=0) / bn).max())
        if new <= tol or new >= 0.9 * res:
            res = min(res, new)
            break
        res = new
        x = x + solve(r)
    return x, res


def _solve_direct(h, b, ref, tau=1e-9, tol=1e-12, max_refine=50, local_modes=None, backend=None,
                  krylov_tau=1e-12, max_krylov=2000, energy=None, samples=0, sample_out=None):
    """Solve the consistent singular PSD system ``h x = b`` and count its zero modes.

    The floppy modes are counted exactly by Sylvester's law of inertia: a symmetric
    factorization of ``h - tau D`` (``D = diag h``) has one negative pivot per eigenvalue
    of ``D^-1/2 h D^-1/2`` below ``tau``. With MKL PARDISO (``backend="pardiso"``, the
    default when installed) that one indefinite, pivoted factorization also solves, by
    iterative refinement against ``h``: the error of a mode of generalized eigenvalue
    ``mu`` (``h v = mu D v``) shrinks by ``tau / (mu - tau)`` per step, and ``b`` has no
    component along the exact zero modes (``mu = 0``).

    Refinement does not relax a *soft* mode (``0 < mu < tau``, the near-floppy networks
    close to the rigidity transition): it moves it by ``b_v / (mu - tau)`` instead of
    ``b_v / mu`` at every step, so its load ``b_v`` stays in the residual. The refined
    solution is therefore kept only when its residual is below ``tol`` (then the energy
    error ``r^T h^+ r`` is negligible on every mode with a load) and at most
    :data:`_FLOPPY_BASIS_MAX` collective modes lie below ``tau``. Otherwise (and always
    with the SuperLU backend, whose symmetric mode does not pivot and so solves only
    positive definite matrices stably), the positive definite ``h + krylov_tau D`` is
    factorized and preconditions conjugate gradients (:func:`_solve_cg` with energy
    control, ``energy`` a map from iterates to twice their energy per column), which
    relax soft modes too: the preconditioned operator has eigenvalues
    ``mu / (mu + krylov_tau)``.

    ``local_modes`` (sparse, orthonormal columns of known floppy modes, e.g. the free spin
    of a particle with two bonds) lets the floppy basis be found by inverse subspace
    iteration on the few remaining modes only. The returned basis holds only the modes
    that carry no energy in the solution (Ritz value times squared component below 1e-12
    of the column's energy): soft modes are response, not floppy.
    Returns ``(x, floppy, open_residual, residual, basis, backend, cg_iterations)``
    (``open_residual``: see :func:`_solve_cg`; the residual itself after refinement).

    ``samples > 0`` with a dict ``sample_out``: before the factor is freed, that many
    random vectors of the (near-)null space are drawn with it (:func:`_null_samples`)
    and stored as ``sample_out["z"]`` ((n, samples)), with the diagonal ``"d"`` and the
    factor's ``"shift"`` (for :func:`polypack.mechanics.rigidity`).
    """
    import scipy.sparse as sp

    if backend is None:
        backend = "pardiso" if _pardiso_module() is not None else "superlu"
    d = h.diagonal()
    scale = float(np.abs(d).max())
    bn = np.maximum(np.linalg.norm(b, axis=0), ref)
    if local_modes is not None and np.abs(h @ local_modes).max() > 1e-10 * scale:
        local_modes = None  # not null vectors of h (cannot happen for contact bonds): find all modes
    known = 0 if local_modes is None else local_modes.shape[1]
    shifted = None
    if backend == "pardiso":
        try:
            shifted = _Pardiso(h - sp.diags(tau * d), -2)
        except (ImportError, OSError):  # pypardiso installed but its MKL runtime does not load
            backend = "superlu"
    cls = _Pardiso if backend == "pardiso" else _SuperLU
    if shifted is None:
        shifted = cls(h - sp.diags(tau * d), -2)
    floppy = shifted.negative
    fac = shifted
    krylov = backend != "pardiso" or floppy is None or floppy - known > _FLOPPY_BASIS_MAX
    basis = ritz = None
    if not krylov:
        x, res = _refine(h, b, bn, shifted.solve, tol, max_refine)
        # a loaded soft mode keeps its load in the residual (refinement leaves it there),
        # so a residual below tol also bounds its energy error, r^T h^+ r
        krylov = res > tol
        if not krylov and floppy > known:
            basis, ritz = _floppy_basis(shifted.solve, h, floppy, local_modes)
    iterations = 0
    open_res = None
    if krylov:
        shifted.free()
        fac = _positive_factor(cls, h, d, krylov_tau)
        x, open_res, res, iterations = _solve_cg(h, b, ref, tol=tol, maxiter=max_krylov, prec=fac.solve,
                                                 energy=energy)
        if floppy and floppy - known <= _FLOPPY_BASIS_MAX:
            basis, ritz = _floppy_basis(fac.solve, h, floppy, local_modes)
    if basis is not None and basis[1] is not None:
        # modes below tau that carry energy in the solution are soft, not floppy: they are
        # response and stay in the fields (w c^2: Ritz value times the squared component)
        carried = np.maximum(ritz, 0.0)[:, None] * (basis[1].T @ x) ** 2
        e_now = energy(x) if energy is not None else np.full(x.shape[1], np.inf)
        zero = np.all(carried <= 1e-12 * e_now[None, :], axis=1) & (ritz <= 1e-9 * scale)
        basis = (basis[0], basis[1][:, zero] if zero.any() else None)
    elif basis is None and floppy and local_modes is not None:
        # dense subspace iteration over thousands of collective modes costs O(n k^2)
        # (tens of CPU minutes at N = 8000): the moduli do not depend on it (a floppy
        # mode carries no stress); only the local modes leave the non-affine fields
        basis = (local_modes, None)
    if samples and sample_out is not None:
        # fac is the shifted indefinite factor of h - tau D, or the positive one of h + s D
        shift = -tau if fac is shifted else fac.shift
        sample_out.update(z=_null_samples(fac.solve, d, shift, samples), d=d, shift=abs(shift))
    fac.free()
    return x, floppy, res if open_res is None else open_res, res, basis, backend, iterations


def _positive_factor(cls, h, d, shift, tries=3):
    """Factor of the positive definite ``h + shift D``; a zero pivot (a soft spectrum at the
    round-off floor, MKL error -4) retries with a 1000 times larger shift."""
    import scipy.sparse as sp

    for attempt in range(tries):
        try:
            fac = cls(h + sp.diags(shift * d), 2)
            fac.shift = shift
            return fac
        except Exception:  # noqa: BLE001 - pypardiso raises its own PyPardisoError
            if attempt == tries - 1:
                raise
            shift *= 1e3


def _null_samples(solve, d, shift, k, sweeps=3, seed=20261204):
    """``k`` random vectors of the near-null space of ``h`` by shifted inverse iteration.

    ``solve`` applies the inverse of ``h + shift D`` (``D = diag d``; ``shift < 0``: the
    indefinite factor of ``h - |shift| D``). Starting from ``D^-1/2 g`` (``g`` standard
    normal), each sweep ``z <- shift solve(D z)`` keeps the component along every mode
    of ``h v = mu D v`` with ``mu = 0`` and multiplies the others by
    ``shift / (mu + shift)``: after ``sweeps`` sweeps a stiff mode (``mu >> |shift|``) is
    gone to ``(|shift| / mu)^sweeps``. With ``D``-orthonormal null modes ``v_k`` the
    result is ``sum_k v_k g_k`` with independent standard normal ``g_k``, so
    ``E |D^1/2 z|^2`` summed over the unknowns of a particle is that particle's share
    of the null space (their sum over all unknowns is its dimension: Hutchinson's
    trace estimator). Deterministic (fixed seed).
    """
    rng = np.random.default_rng(seed)
    dd = np.maximum(np.asarray(d, dtype=np.float64), 1e-300)
    z = rng.standard_normal((dd.size, int(k))) / np.sqrt(dd)[:, None]
    for _ in range(sweeps):
        z = shift * solve(dd[:, None] * z)
    return z


def _floppy_basis(solve, h, k, local=None, sweeps=6):
    """Orthonormal basis of the ``k`` floppy modes by inverse subspace iteration.

    A factor of ``h -+ tau D`` amplifies the null space of ``h`` by ~1/tau over every
    stiff mode, so a few sweeps from a random block converge; Rayleigh-Ritz keeps the
    ``k`` softest directions. Known modes ``local`` (sparse orthonormal columns in the
    null space) are deflated: the iteration runs on the ``k - local.shape[1]`` others
    only. Returns ``((local, rest), ritz)``: the known modes (sparse or None) and the
    others (dense or None), together orthonormal, and the Ritz values of ``rest``.
    """
    rng = np.random.default_rng(0)
    if local is not None and local.shape[1] > k:
        local = None  # not all null vectors after all: find every mode
    known = 0 if local is None else local.shape[1]
    rest = k - known
    if rest <= 0:
        return (local, None), None

    def deflate(v):
        return v if local is None else v - local @ (local.T @ v)

    v = deflate(rng.standard_normal((h.shape[0], rest + 4)))
    scale = float(np.abs(h.diagonal()).max())
    for _ in range(sweeps):
        v, _ = np.linalg.qr(deflate(solve(v)))
        # converged when the rest + 4 directions hold the floppy ones: the rest softest
        # Ritz vectors then have no energy left beyond round-off
        if np.sort(np.linalg.norm(h @ v, axis=0))[rest - 1] <= 1e-10 * scale:
            break
    w, q = np.linalg.eigh(v.T @ (h @ v))
    return (local, v @ q[:, :rest]), w[:rest]


def _remove_floppy(x, basis, keep, centre, lab, clusters, n, nd):
    """``x`` (centred per cluster) minus its projection on the centred floppy modes.

    With ``V`` the orthonormal floppy basis and ``C`` the centring projector, the
    projector on ``span(C V)`` is ``C V G^+ V^T C`` with the Gram matrix
    ``G = V^T C V = I - sum_c T_c^T T_c / n_c`` (``T_c`` the summed translations of
    the modes over cluster ``c``): no dense orthogonalisation of the (many) local modes.
    """
    import scipy.sparse as sp

    blocks = [b for b in basis if b is not None]
    pos = np.flatnonzero(keep)
    embed = sp.csr_matrix((np.ones(pos.size), (pos, np.arange(pos.size))), shape=(n * nd, pos.size))
    # summed translations per cluster: rows (cluster, axis)
    cl_index = np.searchsorted(clusters, lab)
    rows = (cl_index[:, None] * 3 + np.arange(3)[None, :]).ravel()
    cols = (np.arange(n)[:, None] * nd + np.arange(3)[None, :]).ravel()
    agg = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(3 * clusters.size, n * nd)) @ embed
    counts = np.repeat(np.bincount(cl_index, minlength=clusters.size), 3).astype(np.float64)
    t = np.hstack([np.asarray((agg @ b).todense()) if sp.issparse(b) else agg @ b for b in blocks])
    g = np.eye(t.shape[1]) - t.T @ (t / counts[:, None])
    y = np.vstack([np.asarray(b.T @ x[keep]) for b in blocks])  # V^T C x = V^T x
    z = np.linalg.lstsq(g, y, rcond=1e-10)[0]
    vz = np.zeros((n * nd, x.shape[1]))
    off = 0
    for b in blocks:
        vz[keep] += b @ z[off:off + b.shape[1]]
        off += b.shape[1]
    return x - centre(vz)


def _local_spin_modes(n, nd, keep, bi, bj, arm_i, arm_j, ell):
    """The free spin of every unpinned particle with exactly two bonds (rotations only).

    Rotating such a particle by ``theta`` about the line through its two contact points
    ``a_1, a_2`` (lever arms from its centre), with the translation ``u = a_1 x theta``
    that keeps ``a_1`` in place, moves neither contact point, so the mode costs no energy
    whatever its neighbours do. The modes have disjoint supports: unit columns of a
    sparse matrix over the kept degrees of freedom.
    """
    import scipy.sparse as sp

    if nd != 6:
        return None
    deg = np.bincount(bi, minlength=n) + np.bincount(bj, minlength=n)
    ends = np.concatenate([bi, bj])
    arms = np.concatenate([arm_i, arm_j])
    order = np.argsort(ends, kind="stable")
    ends, arms = ends[order], arms[order]
    start = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(ends, minlength=n), out=start[1:])
    p = np.flatnonzero(deg == 2)
    pinned = ~keep.reshape(n, nd)[:, :3].all(axis=1)
    p = p[~pinned[p]]
    if p.size == 0:
        return None
    a1, a2 = arms[start[p]], arms[start[p] + 1]
    e = a2 - a1
    norm = np.linalg.norm(e, axis=1)
    ok = norm > 1e-12 * ell
    p, a1, e = p[ok], a1[ok], e[ok] / norm[ok, None]
    vec = np.hstack([np.cross(a1, e), ell * e])
    vec /= np.linalg.norm(vec, axis=1, keepdims=True)
    pos = np.full(n * nd, -1, np.int64)
    pos[keep] = np.arange(int(keep.sum()))
    rows = pos[(p[:, None] * nd + np.arange(nd)[None, :])]
    # a spin on unknowns left out of the solve (untouched by any bond) is not a column here
    inside = np.all((rows >= 0) | (vec == 0.0), axis=1)
    rows, vec = rows[inside], vec[inside]
    if rows.shape[0] == 0:
        return None
    nz = vec != 0.0
    cols = np.repeat(np.arange(rows.shape[0]), nd).reshape(rows.shape)
    return sp.csc_matrix((vec[nz], (rows[nz], cols[nz])), shape=(int(keep.sum()), rows.shape[0]))


def _block_jacobi(h, nd):
    """Inverses of the (regularised) diagonal blocks of a BSR matrix, shape (n, nd, nd)."""
    n = h.shape[0] // nd
    rows = np.repeat(np.arange(n), np.diff(h.indptr))
    on = h.indices == rows
    blocks = np.zeros((n, nd, nd))
    np.add.at(blocks, rows[on], h.data[on])
    # a block can be singular (e.g. two collinear bonds leave a spin free): regularise
    tr = np.trace(blocks, axis1=1, axis2=2) / nd
    blocks += (1e-8 * np.maximum(tr, 1e-300))[:, None, None] * np.eye(nd)
    return np.linalg.inv(blocks)


def _solve_cg(h, b, ref, tol=1e-10, maxiter=None, nd=6, progress=None, prec=None, energy=None,
              energy_tol=1e-11, stall=30, max_restarts=20):
    """Preconditioned conjugate gradients, all right-hand sides at once.

    ``h`` is symmetric positive semi-definite and every column of ``b`` lies in its
    range, so CG started from zero converges to the minimum-energy solution; floppy
    directions are never excited. ``prec`` (a symmetric positive definite map of
    ``(n nd, k)`` blocks) defaults to block Jacobi on the ``nd x nd`` particle blocks.

    ``energy`` (a map from iterates ``(n nd, k)`` to one value per column: twice the
    elastic energy of the relaxed state, a sum of non-negative bond energies, never below
    its minimum) switches on energy control: the energy is evaluated every iteration, the
    lowest-energy iterate of each column is returned, and a column also stops once, over
    ``stall`` iterations, its energy has dropped by less than ``energy_tol`` times itself
    and its residual has reached no new low. This is what near-floppy networks need: there the preconditioner (a
    factor of ``h`` plus a tiny shift) amplifies the round-off of the residual along the
    zero modes by the inverse shift, so the residual stalls above ``tol`` and the search
    directions drift into the zero modes until CG breaks down (``p^T h p <= 0``) or loses
    orthogonality (the energy rises), while soft modes still hold energy. A column that
    does either restarts from its best iterate (true residual, steepest-descent step); after
    ``max_restarts`` restarts it is taken as settled.
    (The quadratic form ``x^T h x - 2 b^T x`` is no substitute: along a zero mode it
    falls without bound on the round-off part of ``b``.)

    Returns ``(x, open_residual, residual, iterations)``: ``residual`` is the largest
    ``|b_j - h x_j| / max(|b_j|, ref)`` of the returned iterate, ``open_residual`` the
    largest over the columns that did not settle by that energy rule (0 if all did). A
    settled column's residual may stay well above ``tol``: on a near-floppy N = 8000 VEM
    network 1.5e-6, with a lower, i.e. better, energy than any shifted solve down to a
    1e-15 shift.
    """
    k = b.shape[1]
    if prec is None:
        h = h.tobsr(blocksize=(nd, nd))
        h.sort_indices()
        n = h.shape[0] // nd
        minv = _block_jacobi(h, nd)

        def prec(r):
            return np.matmul(minv, r.reshape(n, nd, k)).reshape(n * nd, k)

    def dot(u, v):
        return np.einsum("ij,ij->j", u, v)

    x = np.zeros_like(b)
    r = b.copy()
    bn = np.maximum(np.linalg.norm(b, axis=0), ref)
    live = np.ones(k, bool)
    z = prec(r)
    p = z.copy()
    rz = dot(r, z)
    maxiter = maxiter or max(1000, 10 * (h.shape[0] // nd))
    it = 0
    res = np.linalg.norm(r, axis=0) / bn
    live &= res > tol
    if energy is not None:
        best_e = energy(x)  # x = 0: the affine energy
        best_x = x.copy()
        since = np.zeros(k, np.int64)  # iterations since the energy last dropped by energy_tol
        mark = best_e.copy()
        best_r = res.copy()
        best_xr = res.copy()  # residual of best_x
        since_r = np.zeros(k, np.int64)  # iterations since the residual last reached a new low
    settled = np.zeros(k, bool)  # stopped because energy and residual stalled
    restarts = np.zeros(k, np.int64)
    while it < maxiter and live.any():
        q = h @ p
        pq = dot(p, q)
        alpha = np.where(live & (pq > 0), rz / np.where(pq > 0, pq, 1.0), 0.0)
        x += p * alpha
        r -= q * alpha
        it += 1
        res = np.linalg.norm(r, axis=0) / bn
        if energy is None:
            live &= (res > tol) & (pq > 0)
        else:
            live &= res > tol
            e_now = energy(x)
            # lower energy, or the same within energy_tol (round-off) and a lower residual
            slack = energy_tol * np.abs(best_e)
            better = (e_now < best_e - slack) | ((e_now <= best_e + slack) & (res < best_xr))
            best_e = np.where(better, np.minimum(e_now, best_e), best_e)
            best_xr = np.where(better, res, best_xr)
            best_x[:, better] = x[:, better]
            dropped = best_e < mark - energy_tol * np.abs(best_e)
            mark = np.where(dropped, best_e, mark)
            since = np.where(dropped, 0, since + 1)
            lower = res < best_r
            best_r = np.where(lower, res, best_r)
            since_r = np.where(lower, 0, since_r + 1)
            settled |= live & (since >= stall) & (since_r >= stall)
            # breakdown (no curvature left along p: it has drifted into the zero modes) or
            # a rise of the energy (lost orthogonality): restart from the best iterate
            broke = live & ~settled & ((pq <= 0) | (e_now > best_e + slack))
            restarts += broke
            settled |= broke & (restarts > max_restarts)
            live &= ~settled
            broke &= live
            if broke.any():
                x[:, broke] = best_x[:, broke]
                r[:, broke] = b[:, broke] - h @ x[:, broke]
        if not live.any():
            break
        z = prec(r)
        rz_new = dot(r, z)
        beta = np.where(rz > 0, rz_new / np.where(rz > 0, rz, 1.0), 0.0)
        if energy is not None:
            beta[broke] = 0.0  # restarted columns: steepest descent step
        p = z + p * beta
        rz = rz_new
        if progress is not None:
            progress(it, float(res.max()))
    if energy is not None:
        x = best_x
    res = np.linalg.norm(b - h @ x, axis=0) / bn
    return x, float(res[~settled].max(initial=0.0)), float(res.max()), it


class _Multigrid:
    """Smoothed-aggregation AMG V-cycle applied to several right-hand sides at once.

    The hierarchy (aggregates, prolongators, Galerkin coarse matrices) comes from
    :func:`pyamg.smoothed_aggregation_solver` on the ``nd x nd`` particle blocks with the
    six rigid-body motions of the particles (translations; rotations ``u = theta x x``,
    ``w = ell theta``) as near-null-space candidates. The smoother is a Chebyshev
    polynomial of degree ``degree`` in ``D^-1 A`` (``D`` the block diagonal) on
    ``[rho/30, rho]``, the same before and after the coarse correction, and the
    coarsest level is solved by a pseudo-inverse (it may be singular: floppy modes).
    The cycle is a fixed symmetric positive (semi-)definite linear map, so it is a
    valid CG preconditioner; only vectorised sparse products on ``(n, k)`` blocks, so
    the six strain modes share every pass over the matrices.
    """

    def __init__(self, h, nd, positions, ell, degree=2, max_coarse=None):
        import pyamg

        hb = h.tobsr(blocksize=(nd, nd))
        hb.sort_indices()
        n = hb.shape[0] // nd
        cand = np.zeros((n, nd, 6))
        for k in range(3):
            cand[:, k, k] = 1.0
            axis = np.zeros(3)
            axis[k] = 1.0
            cand[:, :3, 3 + k] = np.cross(axis, positions)
            if nd == 6:
                cand[:, 3 + k, 3 + k] = ell
        ml = pyamg.smoothed_aggregation_solver(
            hb, B=cand.reshape(n * nd, -1), max_coarse=max_coarse or _AMG_MAX_COARSE, max_levels=10,
            presmoother=None, postsmoother=None, keep=False,
        )
        self.degree = int(degree)
        self.levels = []
        rng = np.random.default_rng(0)
        last = len(ml.levels) - 1
        for lev, L in enumerate(ml.levels):
            a = L.A.tocsr()
            entry = {"A": a}
            if lev < last:
                bs = L.A.blocksize[0] if hasattr(L.A, "blocksize") else 1
                entry["bs"] = bs
                entry["Dinv"] = _block_jacobi(L.A.tobsr(blocksize=(bs, bs)), bs)
                entry["P"] = L.P.tocsr()
                entry["R"] = L.P.T.tocsr()
                # largest eigenvalue of D^-1 A by power iteration (10 % margin)
                v = rng.standard_normal((a.shape[0], 1))
                lam = 1.0
                for _ in range(15):
                    w = self._dinv(entry, a @ v)
                    lam = float(np.linalg.norm(w) / np.linalg.norm(v))
                    v = w / np.linalg.norm(w)
                entry["rho"] = 1.1 * lam
            else:
                entry["Cinv"] = np.linalg.pinv(a.toarray(), hermitian=True)
            self.levels.append(entry)

    @staticmethod
    def _dinv(e, r):
        k = r.shape[1]
        return np.matmul(e["Dinv"], r.reshape(-1, e["bs"], k)).reshape(-1, k)

    def _chebyshev(self, e, x, r, need_residual=True):
        """``degree`` Chebyshev steps from ``x`` (None: zero) with residual ``r``; returns x and its residual."""
        lmax = e["rho"]
        lmin = lmax / 30.0
        theta, delta = 0.5 * (lmax + lmin), 0.5 * (lmax - lmin)
        sigma = theta / delta
        rho_old = 1.0 / sigma
        d = self._dinv(e, r) / theta
        x = d if x is None else x + d
        for _ in range(1, self.degree):
            r = r - e["A"] @ d
            rho_new = 1.0 / (2.0 * sigma - rho_old)
            d = rho_new * rho_old * d + (2.0 * rho_new / delta) * self._dinv(e, r)
            rho_old = rho_new
            x = x + d
        return x, (r - e["A"] @ d) if need_residual else None

    def _cycle(self, lev, b):
        e = self.levels[lev]
        if "Cinv" in e:
            return e["Cinv"] @ b
        x, r = self._chebyshev(e, None, b)
        c = e["P"] @ self._cycle(lev + 1, e["R"] @ r)
        x = x + c
        r = r - e["A"] @ c
        x, _ = self._chebyshev(e, x, r, need_residual=False)
        return x

    def __call__(self, r):
        return self._cycle(0, r)

    @property
    def sizes(self):
        return [e["A"].shape[0] for e in self.levels]


def _auto_solver(unknowns, z, nd):
    """The solver ``solver="auto"`` picks for ``unknowns`` unknowns at backbone coordination ``z``.

    * up to :data:`_DIRECT_MAX` unknowns (:data:`_PARDISO_ANY_MAX` with MKL PARDISO):
      the factorization (exact floppy-mode count);
    * with MKL PARDISO installed, near-isostatic networks (``z`` below
      :data:`_ISOSTATIC_MARGIN` times ``2 nd / 3``) of up to :data:`_PARDISO_MAX` unknowns:
      the factorization too (CG needs thousands of iterations there);
    * otherwise block-Jacobi CG below :data:`_AMG_MIN` unknowns and AMG-CG above.
    """
    if unknowns <= _DIRECT_MAX:
        return "direct"
    if _pardiso_module() is not None and (
            unknowns <= _PARDISO_ANY_MAX
            or (unknowns <= _PARDISO_MAX and z < _ISOSTATIC_MARGIN * 2.0 * nd / 3.0)):
        return "direct"
    return "cg" if unknowns < _AMG_MIN else "amg"
