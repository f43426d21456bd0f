"""Exact linear elastic response of a periodic bonded network (static limit of seed 003's shear test).

The network of :class:`~polypack.mechanics.BondNetwork` is a set of linear springs
(normal stiffness ``k_n``, Eq. (1) of 003_873b69fc71c74cf6.txt; shear stiffness
``k_s``, Eq. (2) of 003_873b69fc71c74cf6.txt) acting at the PFC contact points. A homogeneous strain
``eps`` moves every branch vector affinely, ``b -> b + eps b``; the particles then relax
(translations and, by default, rotations) to the minimum of the harmonic energy. The
relaxed energy per volume is ``eps^T C eps / 2``; ``C`` is what the slow oscillatory
test of §2.4 of 003_873b69fc71c74cf6.txt measures as ``G'_p`` in its static limit.

Method
------
Per bond ``delta = B q + A eps`` (``q`` the particle displacements and scaled rotations,
``A eps = eps b``), energy ``delta^T K delta / 2`` with ``K = k_n n n^T + k_s (I - n n^T)``.
Summing gives ``U = q^T H q / 2 + q^T Xi eps + V eps^T C_aff eps / 2``; the relaxed
stiffness is ``C = C_aff - Xi^T H^+ Xi / V``. Rattlers (recursively fewer than two
bonds) and clusters that do not wrap the periodic box relax completely and are left
out of ``H``; one particle per remaining cluster is pinned (the global translations);
what is left singular are floppy modes, counted exactly by Sylvester's law of inertia
on a sparse LDL^T-type factorization, and harmless because ``Xi eps`` is in the range
of ``H``. Each stress-free bond carries no force in the reference state, so there is no
geometric (prestress) term.

Conventions
-----------
Voigt order ``(11, 22, 33, 23, 13, 12)`` with engineering shear strains
``gamma_23 = 2 eps_23``; stress ``sigma = (1/V) sum_c f_c b_c^T`` with ``f_c`` the force
particle ``j`` exerts on ``i`` (tension positive) and ``V`` the box volume. Stresses
have the units of stiffness over length: Pa for N/m stiffnesses and lengths in metres.
"""

from __future__ import annotations

import numpy as np

from ..errors import InfeasibleError, InvalidInputError

__all__ = ["ElasticTensor", "elastic_tensor", "voigt_average", "SEED003_RADIUS"]

#: Particle radius of seed 003 Table 1 (metres).
SEED003_RADIUS = 0.25e-6

_VOIGT = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
_MODE_NAMES = ("11", "22", "33", "23", "13", "12")
# Largest system (unknowns) solved by the sparse factorization under solver="auto":
# SuperLU's fill on 3D networks grows fast (48 000 unknowns: minutes), CG does not.
_DIRECT_MAX = 6000
# Smallest system solved by AMG-preconditioned CG under solver="auto": below it the
# multigrid setup costs more than block-Jacobi CG saves (measured, one core: N = 1200
# jammed, 7 200 unknowns: cg 0.6 s, amg 1.3 s; N = 8000, 48 000 unknowns: cg 7.8 s, amg 3.2 s).
_AMG_MIN = 24000
# Coarsest AMG level: at most this many particle blocks (solved by a pseudo-inverse).
_AMG_MAX_COARSE = 300


def voigt_average(c):
    """Isotropic Voigt averages ``(K_V, G_V)`` of a 6x6 Voigt stiffness (engineering shears).

    ``K_V = [C11 + C22 + C33 + 2 (C12 + C13 + C23)] / 9`` and
    ``G_V = [C11 + C22 + C33 - (C12 + C13 + C23) + 3 (C44 + C55 + C66)] / 15``: the
    moduli of the isotropic tensor closest to ``c`` (its isotropic projection).
    """
    c = np.asarray(c, dtype=np.float64)
    a = c[0, 0] + c[1, 1] + c[2, 2]
    b = c[0, 1] + c[0, 2] + c[1, 2]
    s = c[3, 3] + c[4, 4] + c[5, 5]
    return (a + 2.0 * b) / 9.0, (a - b + 3.0 * s) / 15.0


def _reuss_average(c):
    try:
        s = np.linalg.inv(c)
    except np.linalg.LinAlgError:
        return 0.0, 0.0
    if not np.all(np.isfinite(s)) or np.linalg.eigvalsh(0.5 * (c + c.T))[0] <= 1e-12 * abs(c).max():
        return 0.0, 0.0
    a = s[0, 0] + s[1, 1] + s[2, 2]
    b = s[0, 1] + s[0, 2] + s[1, 2]
    t = s[3, 3] + s[4, 4] + s[5, 5]
    return 1.0 / (a + 2.0 * b), 15.0 / (4.0 * a - 4.0 * b + 3.0 * t)


class ElasticTensor:
    """Relaxed and affine elastic tensors of a bonded network (see :func:`elastic_tensor`).

    Attributes
    ----------
    stiffness : (6, 6) ndarray
        Relaxed (exact linear response) Voigt stiffness, engineering shear strains.
    affine_stiffness : (6, 6) ndarray
        Affine (Voigt-bound) stiffness: every bond follows the strain, no relaxation.
    bulk_modulus, shear_modulus : float
        Isotropic Voigt averages of the relaxed tensor (:func:`voigt_average`).
    affine_bulk_modulus, affine_shear_modulus : float
        The same for the affine tensor. For equal spheres of diameter ``d`` bonded at
        contact, ``G_aff = phi Z (k_n + 1.5 k_s) / (5 pi d)``.
    shear_moduli : (3,) ndarray
        ``(C44, C55, C66)``: the shear moduli of the planes yz, xz, xy (seed 003 shears
        along x with plates normal to z, i.e. C55; six directions give each twice).
    plate_shear_modulus : float
        Mean of ``shear_moduli``: the seed's ``G'_p`` averaged over its six directions.
    nonaffine_displacements : (6, N, 3) ndarray
        Displacement of every particle (beyond the affine one) per unit strain of each
        Voigt mode; NaN for rattlers and particles of clusters that do not wrap the box
        (their motion is undetermined); zero mean over each cluster.
    nonaffine_rotations : (6, N, 3) ndarray or None
        Rotation (radians) per unit strain of each mode (None for ``rotations=False``).
    floppy_modes : int or None
        Zero-energy modes of the relaxing part beyond the global translations of each
        cluster (None when an iterative solver is used).
    solver, iterations, multigrid_levels, residual : str, int or None, list or None, float
        The solver used, its CG iterations (None for the direct one), the unknowns per
        AMG level (``solver="amg"``) and the largest relative residual of the six modes.
    units : str
        ``"Pa"`` when built with ``radius=`` or SI input, else a description.
    """

    def __init__(self, **kw):
        for k, v in kw.items():
            setattr(self, k, v)

    # ---------------------------------------------------------------- moduli
    @property
    def bulk_modulus(self) -> float:
        return float(voigt_average(self.stiffness)[0])

    @property
    def shear_modulus(self) -> float:
        return float(voigt_average(self.stiffness)[1])

    @property
    def affine_bulk_modulus(self) -> float:
        return float(voigt_average(self.affine_stiffness)[0])

    @property
    def affine_shear_modulus(self) -> float:
        return float(voigt_average(self.affine_stiffness)[1])

    @property
    def reuss_moduli(self):
        """``(K_R, G_R)`` from the relaxed compliance (0, 0 if the tensor is singular)."""
        return _reuss_average(self.stiffness)

    @property
    def shear_moduli(self) -> np.ndarray:
        return np.array([self.stiffness[3, 3], self.stiffness[4, 4], self.stiffness[5, 5]])

    @property
    def plate_shear_modulus(self) -> float:
        return float(self.shear_moduli.mean())

    @property
    def relaxation_ratio(self) -> float:
        """``G / G_aff``: how much non-affine relaxation softens the shear modulus."""
        return self.shear_modulus / self.affine_shear_modulus

    @property
    def reduced_stiffness(self) -> np.ndarray:
        """Dimensionless ``C d / k_n`` (``d`` the mean diameter, ``k_n`` the mean normal stiffness)."""
        return self.stiffness * self.length_scale / self.stiffness_scale

    def stress(self, strain) -> np.ndarray:
        """Voigt stress ``C eps`` for a Voigt strain (engineering shears)."""
        return self.stiffness @ np.asarray(strain, dtype=np.float64)

    def to_dict(self) -> dict:
        """Plain data for JSON (moduli in the tensor's units and in MPa for SI)."""
        mpa = 1e-6 if self.units == "Pa" else None
        out = {
            "units": self.units,
            "stiffness": self.stiffness.tolist(),
            "affine_stiffness": self.affine_stiffness.tolist(),
            "bulk_modulus": self.bulk_modulus,
            "shear_modulus": self.shear_modulus,
            "affine_bulk_modulus": self.affine_bulk_modulus,
            "affine_shear_modulus": self.affine_shear_modulus,
            "shear_moduli": self.shear_moduli.tolist(),
            "plate_shear_modulus": self.plate_shear_modulus,
            "relaxation_ratio": self.relaxation_ratio,
            "reduced_stiffness": self.reduced_stiffness.tolist(),
            "rotations": self.rotations,
            "floppy_modes": self.floppy_modes,
            "n_particles": self.n_particles,
            "n_active": self.n_active,
            "n_bonds": self.n_bonds,
            "n_active_bonds": self.n_active_bonds,
            "n_clusters": self.n_clusters,
            "coordination": self.coordination,
            "n_rattlers": self.n_rattlers,
            "solver": self.solver,
            "residual": self.residual,
            "seconds": self.seconds,
        }
        if mpa:
            out["shear_modulus_MPa"] = self.shear_modulus * mpa
            out["bulk_modulus_MPa"] = self.bulk_modulus * mpa
            out["shear_moduli_MPa"] = (self.shear_moduli * mpa).tolist()
        return out

    def __repr__(self) -> str:
        return (f"ElasticTensor(G={self.shear_modulus:.4g}, K={self.bulk_modulus:.4g}, "
                f"G/G_aff={self.relaxation_ratio:.3f}, units={self.units!r})")


def _hessian(n, bi, bj, kn, ks, normal, branch, arm_i, arm_j, ell, rotations):
    """Sparse (BSR) Hessian, affine forces and affine stiffness sum."""
    import scipy.sparse as sp

    from .._kernels import network as knl

    diag, off, rhs, caff = knl.assemble(n, bi, bj, kn, ks, normal, branch, arm_i, arm_j, ell, rotations)
    nd = diag.shape[1]
    rows = np.concatenate([np.arange(n), bi, bj])
    cols = np.concatenate([np.arange(n), bj, bi])
    data = np.concatenate([diag, off, off.transpose(0, 2, 1)])
    order = np.lexsort((cols, rows))
    rows, cols, data = rows[order], cols[order], data[order]
    indptr = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(rows, minlength=n), out=indptr[1:])
    h = sp.bsr_matrix((data, cols, indptr), shape=(n * nd, n * nd))
    h.sum_duplicates()
    return h, rhs.reshape(n * nd, 6), caff


def _solve_direct(h, b, ref, tau=1e-9, tol=1e-12, max_refine=50):
    """Solve the consistent singular PSD system ``h x = b`` and count its zero modes.

    Solves with a factorization of ``h + tau D`` (``D = diag h``; positive definite, so
    stable without pivoting) and iterative refinement against ``h``, which converges in
    the range of ``h`` at the rate ``tau / (mu + tau)``. The floppy modes are counted
    exactly by Sylvester's law of inertia: a symmetric LDL^T-type factorization of
    ``h - tau D`` has one negative pivot per eigenvalue of ``D^-1/2 h D^-1/2`` below ``tau``.
    """
    import scipy.sparse as sp
    import scipy.sparse.linalg as sla

    d = h.diagonal()
    opts = dict(permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    shifted = sla.splu((h - sp.diags(tau * d)).tocsc(), **opts)
    floppy = None
    if np.array_equal(shifted.perm_r, shifted.perm_c):
        floppy = int(np.count_nonzero(shifted.U.diagonal() < 0))
    del shifted
    lu = sla.splu((h + sp.diags(tau * d)).tocsc(), **opts)
    x = lu.solve(b)
    bn = np.maximum(np.linalg.norm(b, axis=0), ref)
    res = np.inf
    for _ in range(max_refine):
        r = b - h @ x
        new = float((np.linalg.norm(r, axis=0) / bn).max())
        if new <= tol or new >= 0.9 * res:
            res = min(res, new)
            break
        res = new
        x = x + lu.solve(r)
    basis = _floppy_basis(lu, h, floppy) if floppy else None
    return x, floppy, res, basis


def _floppy_basis(lu, h, k, sweeps=5):
    """Orthonormal basis of the ``k`` floppy modes by inverse subspace iteration.

    The shifted factor ``(h - tau D)^-1`` amplifies the null space of ``h`` by ~1/tau
    over every stiff mode, so a few sweeps from a random block converge; Rayleigh-Ritz
    keeps the ``k`` softest directions.
    """
    rng = np.random.default_rng(0)
    v = rng.standard_normal((h.shape[0], k + 4))
    for _ in range(sweeps):
        v, _ = np.linalg.qr(lu.solve(v))
    w, q = np.linalg.eigh(v.T @ (h @ v))
    return v @ q[:, :k]


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


def _solve_cg(h, b, ref, tol=1e-10, maxiter=None, nd=6, progress=None, prec=None):
    """Preconditioned conjugate gradients, all right-hand sides at once.

    ``h`` is symmetric positive semi-definite and every column of ``b`` lies in its
    range, so CG started from zero converges to the minimum-energy solution; floppy
    directions are never excited. ``prec`` (a symmetric positive definite map of
    ``(n nd, k)`` blocks) defaults to block Jacobi on the ``nd x nd`` particle blocks.
    """
    k = b.shape[1]
    if prec is None:
        h = h.tobsr(blocksize=(nd, nd))
        h.sort_indices()
        n = h.shape[0] // nd
        minv = _block_jacobi(h, nd)

        def prec(r):
            return np.matmul(minv, r.reshape(n, nd, k)).reshape(n * nd, k)

    x = np.zeros_like(b)
    r = b.copy()
    bn = np.maximum(np.linalg.norm(b, axis=0), ref)
    live = np.ones(k, bool)
    z = prec(r)
    p = z.copy()
    rz = np.einsum("ij,ij->j", r, z)
    maxiter = maxiter or max(1000, 10 * (h.shape[0] // nd))
    it = 0
    res = np.linalg.norm(r, axis=0) / bn
    while it < maxiter and np.any(res[live] > tol):
        q = h @ p
        pq = np.einsum("ij,ij->j", p, q)
        alpha = np.where(live & (pq > 0), rz / np.where(pq > 0, pq, 1.0), 0.0)
        x += p * alpha
        r -= q * alpha
        it += 1
        res = np.linalg.norm(r, axis=0) / bn
        done = res <= tol
        z = prec(r)
        rz_new = np.einsum("ij,ij->j", r, z)
        beta = np.where(rz > 0, rz_new / np.where(rz > 0, rz, 1.0), 0.0)
        p = z + p * beta
        rz = rz_new
        live = live & ~done
        if progress is not None:
            progress(it, float(res.max()))
    r = b - h @ x
    return x, None, float((np.linalg.norm(r, axis=0) / bn).max()), it


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


def elastic_tensor(network, rotations=True, *, radius=None, solver="auto", tol=1e-10):
    """Exact linear elastic tensor of a periodic bonded network.

    The static limit of the oscillatory plate-shear test of §2.4 of
    003_873b69fc71c74cf6.txt, for the linear contact law of Eq. (1) of
    003_873b69fc71c74cf6.txt and Eq. (2) of 003_873b69fc71c74cf6.txt with contact bonds:
    every particle relaxes (translations, and rotations unless ``rotations=False``)
    under each of the six Voigt strains.

    Parameters
    ----------
    network : BondNetwork
        A stress-free network in a fully periodic 3D box.
    rotations : bool, default True
        Let particles rotate (shear forces act at the contact points and exert torques).
        ``False``: translations only (particles cannot rotate).
    radius : float, optional
        Rescale lengths so that the mean particle radius is ``radius`` metres (seed 003:
        :data:`SEED003_RADIUS` = 0.25 µm); with stiffnesses in N/m the stresses are then
        in Pa. Default: lengths as in the packing (stress in stiffness units per length
        unit; Pa when the packing is in metres).
    solver : {"auto", "direct", "amg", "cg"}
        Sparse LDL^T-type factorization (exact floppy-mode count), conjugate gradients
        preconditioned by a smoothed-aggregation algebraic multigrid cycle (pyamg;
        fewest operations on large networks) or by block Jacobi (least memory).
        ``"auto"`` picks the direct solver up to 6000 unknowns (about 1000 particles
        with rotations), block-Jacobi CG up to 24 000 and AMG above.
    tol : float, default 1e-10
        Relative residual of the relaxation.

    Returns
    -------
    ElasticTensor

    Raises
    ------
    InvalidInputError
        For a 2D packing, wall boundaries, a prestressed (``"zero-gap"``) network with
        forces in its reference state, or a bad option.
    InfeasibleError
        When no bonded cluster wraps the periodic box (a disconnected network carries no
        stress).

    References
    ----------
    .. [1] C. E. Maloney and A. Lemaitre, "Amorphous systems in athermal, quasistatic
       shear", Phys. Rev. E 74, 016118 (2006) (non-affine relaxation, C = C_aff - Xi^T H^-1 Xi).
    .. [2] D. O. Potyondy and P. A. Cundall, "A bonded-particle model for rock",
       Int. J. Rock Mech. Min. Sci. 41, 1329 (2004) (contact bonds).
    """
    import time

    from .network import BondNetwork

    t0 = time.perf_counter()
    if not isinstance(network, BondNetwork):
        raise InvalidInputError(f"network must be a BondNetwork, got {type(network).__name__}")
    if network.dim != 3:
        raise InvalidInputError(f"elastic_tensor supports 3D packings only; this network has dim={network.dim}")
    per = getattr(network.packing, "periodic", None)
    if per is not None and not all(bool(p) for p in np.atleast_1d(per)):
        raise InvalidInputError(f"elastic_tensor needs a fully periodic box; periodic={tuple(per)}")
    if solver not in ("auto", "direct", "amg", "cg"):
        raise InvalidInputError(f"solver={solver!r}: allowed are 'auto', 'direct', 'amg', 'cg'")
    if not (np.isfinite(tol) and 0 < tol < 1):
        raise InvalidInputError(f"tol={tol!r}: must be in (0, 1)")
    if network.reference != "stress-free":
        f = np.abs(network.normal_force)
        if f.max() > 1e-12 * float(np.max(network.normal_stiffness * network.length)):
            raise InvalidInputError(
                f"reference={network.reference!r} leaves bond forces up to {f.max():.3g} in the reference "
                "state; elastic_tensor linearises a stress-free network (build it with reference='stress-free')"
            )
    rad = np.asarray(network.packing.radii, dtype=np.float64)
    if radius is None:
        scale = 1.0
        units = "stiffness unit / length unit (Pa for N/m and metres)"
    else:
        radius = float(radius)
        if not (np.isfinite(radius) and radius > 0):
            raise InvalidInputError(f"radius={radius!r}: must be finite and > 0 (metres)")
        scale = radius / float(rad.mean())
        units = "Pa"
    box = np.asarray(network.packing.box, dtype=np.float64)
    volume = float(np.prod(box))
    n_all = network.n
    kn_all = np.ascontiguousarray(network.normal_stiffness)
    ks_all = np.ascontiguousarray(network.shear_stiffness)

    # affine stiffness over all bonds (rattlers included: every bond follows the strain)
    c_aff = _affine(network) / volume

    # relaxing part: backbone bonds of clusters that wrap the box
    label, spans = network.components(backbone=True)
    wrapping = spans.any(axis=1)
    if not wrapping.any():
        raise InfeasibleError(
            f"the network is disconnected: none of its {spans.shape[0]} bonded cluster(s) wraps the periodic box "
            f"(Z = {network.coordination:.3g}); it carries no stress"
        )
    active = (label >= 0) & wrapping[np.maximum(label, 0)]
    bond_on = active[network.i] & active[network.j]
    idx = np.full(n_all, -1, np.int64)
    idx[active] = np.arange(int(active.sum()))
    n = int(active.sum())
    bi = idx[network.i[bond_on]]
    bj = idx[network.j[bond_on]]
    ell = float(rad[active].mean())
    nd = 6 if rotations else 3
    h, xi, caff_on = _hessian(
        n, bi, bj, kn_all[bond_on], ks_all[bond_on],
        np.ascontiguousarray(network.normal[bond_on]), np.ascontiguousarray(network.branch[bond_on]),
        np.ascontiguousarray(network.lever_arm_i[bond_on]), np.ascontiguousarray(network.lever_arm_j[bond_on]),
        ell, bool(rotations),
    )
    # pin the translations of one particle per wrapping cluster
    clusters = np.unique(label[active])
    lab_active = label[active]
    first = np.unique(lab_active, return_index=True)[1]
    pinned = (first[:, None] * nd + np.arange(3)[None, :]).ravel()
    keep = np.ones(n * nd, bool)
    keep[pinned] = False
    rhs = -xi
    rhs[~keep] = 0.0
    method = solver
    if method == "auto":
        method = "direct" if n * nd <= _DIRECT_MAX else ("cg" if n * nd < _AMG_MIN else "amg")
    iterations = None
    levels = None
    # residual floor: a right-hand side far below the typical bond force per unit strain
    # (e.g. round-off on a lattice, whose affine forces cancel) needs no relative accuracy
    ref = 1e-6 * float(np.mean(kn_all) * np.mean(network.length)) * np.sqrt(n * nd)
    if method == "direct":
        hr = h.tocsr()[keep][:, keep].tocsc()
        x_r, floppy, res, basis = _solve_direct(hr, rhs[keep], ref, tol=min(tol, 1e-12))
    else:
        import scipy.sparse as sp

        basis = None
        # pinned rows and columns replaced by the identity (the diagonal blocks are stored)
        hp = h.tocsr()
        hp.sort_indices()
        rows = np.repeat(np.arange(hp.shape[0]), np.diff(hp.indptr))
        data = hp.data * (keep[rows] & keep[hp.indices])
        data[(rows == hp.indices) & ~keep[rows]] = 1.0
        hp = sp.csr_matrix((data, hp.indices, hp.indptr), shape=hp.shape)
        prec = None
        if method == "amg":
            mg = _Multigrid(hp, nd, np.asarray(network.packing.positions, dtype=np.float64)[active], ell)
            prec = mg
            levels = mg.sizes
        x_full, floppy, res, iterations = _solve_cg(hp, rhs, ref, tol=tol, nd=nd, prec=prec)
        x_r = x_full[keep]
    x = np.zeros((n * nd, 6))
    x[keep] = x_r
    # C = C_aff - Xi^T H^+ Xi / V = C_aff + Xi^T x / V (x = -H^+ Xi), with C_aff over the
    # relaxing bonds only: a rattler's bonds and those of clusters that do not wrap the box
    # relax completely and carry no stress (they stay in affine_stiffness, the Voigt bound)
    c_rel = caff_on / volume + (xi.T @ x) / volume
    asym = float(np.abs(c_rel - c_rel.T).max() / max(np.abs(c_rel).max(), 1e-300))
    c_rel = 0.5 * (c_rel + c_rel.T)

    # nonaffine fields: zero mean translation per cluster and, when floppy modes exist,
    # no component along them (the minimum-norm field, independent of labels and pinning)
    def centre(y):
        y = y.reshape(n, nd, -1)
        for c in clusters:
            sel = lab_active == c
            y[sel, :3] -= y[sel, :3].mean(axis=0, keepdims=True)
        return y.reshape(n * nd, -1)

    x = centre(x)
    if basis is not None:
        v = np.zeros((n * nd, basis.shape[1]))
        v[keep] = basis
        v, _ = np.linalg.qr(centre(v))
        x = x - v @ (v.T @ x)
    q = x.reshape(n, nd, 6).transpose(2, 0, 1)  # (6, n, nd)
    u = q[:, :, :3]
    disp = np.full((6, n_all, 3), np.nan)
    disp[:, active] = u * scale
    rot = None
    if rotations:
        rot = np.full((6, n_all, 3), np.nan)
        rot[:, active] = q[:, :, 3:] / ell
    kbar = float(kn_all.mean())
    return ElasticTensor(
        stiffness=c_rel / scale,
        affine_stiffness=c_aff / scale,
        nonaffine_displacements=disp,
        nonaffine_rotations=rot,
        floppy_modes=floppy,
        rotations=bool(rotations),
        units=units,
        length_scale=2.0 * float(rad.mean()) * scale,
        stiffness_scale=kbar,
        n_particles=n_all,
        n_active=n,
        n_bonds=network.n_bonds,
        n_active_bonds=int(bond_on.sum()),
        n_clusters=int(clusters.size),
        coordination=network.coordination,
        n_rattlers=int(network.rattlers.sum()),
        solver=method,
        iterations=iterations,
        multigrid_levels=levels,
        residual=float(res),
        asymmetry=asym,
        seconds=time.perf_counter() - t0,
    )


def _affine(network):
    """``sum_c A_c^T K_c A_c`` over all bonds (times 1/V: the affine stiffness)."""
    b = np.asarray(network.branch)
    n = np.asarray(network.normal)
    kn = np.asarray(network.normal_stiffness)
    ks = np.asarray(network.shear_stiffness)
    m = b.shape[0]
    a = np.zeros((m, 3, 6))
    for col, (p, r) in enumerate(_VOIGT):
        w = 1.0 if p == r else 0.5
        a[:, p, col] += w * b[:, r]
        if p != r:
            a[:, r, col] += w * b[:, p]
    k = (kn - ks)[:, None, None] * n[:, :, None] * n[:, None, :] + ks[:, None, None] * np.eye(3)
    ka = np.einsum("mij,mjk->mik", k, a)
    return np.einsum("mji,mjk->ik", a, ka)
