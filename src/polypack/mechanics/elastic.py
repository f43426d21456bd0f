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

import os

import numpy as np

from ..errors import InfeasibleError, InvalidInputError

__all__ = ["ElasticTensor", "elastic_tensor", "voigt_average", "SEED003_RADIUS"]

#: Particle radius of seed 003 Table 1 (metres).
SEED003_RADIUS = 0.25e-6

_VOIGT = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
_MODE_NAMES = ("11", "22", "33", "23", "13", "12")
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
# Largest relative residual of the relaxation accepted by elastic_tensor unless the energy
# has settled (the moduli are bond energies, second order in the error; see _solve_cg);
# beyond it, with the energy still falling, InfeasibleError.
_RESIDUAL_LIMIT = 1e-6
# Coarsest AMG level: at most this many particle blocks (solved by a pseudo-inverse).
_AMG_MAX_COARSE = 300
#: A strain mode of the relaxed tensor whose modulus (eigenvalue of ``C``) is below this
#: fraction of the largest eigenvalue of the affine tensor is floppy: it costs no energy
#: beyond the numerical floor. The floor: the moduli are bond energies, second order in the
#: relaxation error, so a relaxation accepted at relative residual 1e-6 (_RESIDUAL_LIMIT)
#: leaves at most ~1e-12 of the affine scale in a floppy mode (round-off: ~1e-20 to
#: 1e-30); the softest rigid networks met (near-isostatic VEM structures, Z = 3.7) have
#: C / C_aff ~ 1e-4. Both are 4 decades away from the threshold.
FLOPPY_TOLERANCE = 1e-8


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
        cluster (None when an iterative solver is used): the eigenvalues of the diagonally
        scaled stiffness below 1e-9, which on near-floppy networks include soft modes.
    solver, iterations, multigrid_levels, residual : str, int or None, list or None, float
        The solver used, its CG iterations (for the direct one: None, or those of the
        factor-preconditioned CG that relaxes soft modes on near-floppy networks), the unknowns per
        AMG level (``solver="amg"``) and the largest relative residual of the six modes.
    factorization : str or None
        The direct solver's library: ``"pardiso"`` (MKL PARDISO through pypardiso) or
        ``"superlu"`` (SciPy, where pypardiso is not installed); None for iterative solvers.
    units : str
        ``"Pa"`` when built with ``radius=`` or SI input, else a description.
    rigid : bool
        True when a bonded cluster wraps the box and no strain mode is floppy.
    floppy_strains : int
        Number of strain modes (eigenvectors of the 6x6 relaxed tensor) whose modulus is
        below :data:`FLOPPY_TOLERANCE` times the largest affine eigenvalue (6 when no
        cluster wraps the box). Their moduli are set to exactly 0 in ``stiffness`` (the
        computed values are round-off), so a floppy network has ``G = 0``, never a
        round-off or negative number.
    status : str
        ``"rigid"`` or ``"floppy"``.
    floppy_reason : str or None
        Why the network is floppy (no wrapping cluster, or the floppy strain modes).
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
        """``G / G_aff``: how much non-affine relaxation softens the shear modulus (0 when floppy)."""
        aff = self.affine_shear_modulus
        return self.shear_modulus / aff if aff > 0 else 0.0

    @property
    def status(self) -> str:
        """``"rigid"`` or ``"floppy"``."""
        return "rigid" if self.rigid else "floppy"

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
            "rigid": self.rigid,
            "status": self.status,
            "floppy_strains": self.floppy_strains,
            "floppy_reason": self.floppy_reason,
            "floppy_tolerance": FLOPPY_TOLERANCE,
            "n_particles": self.n_particles,
            "n_active": self.n_active,
            "n_bonds": self.n_bonds,
            "n_active_bonds": self.n_active_bonds,
            "n_clusters": self.n_clusters,
            "coordination": self.coordination,
            "n_rattlers": self.n_rattlers,
            "solver": self.solver,
            "factorization": getattr(self, "factorization", None),
            "residual": self.residual,
            "seconds": self.seconds,
        }
        if mpa:
            out["shear_modulus_MPa"] = self.shear_modulus * mpa
            out["bulk_modulus_MPa"] = self.bulk_modulus * mpa
            out["shear_moduli_MPa"] = (self.shear_moduli * mpa).tolist()
        return out

    def __repr__(self) -> str:
        if not self.rigid:
            return f"ElasticTensor(floppy: {self.floppy_reason}, G={self.shear_modulus:.4g}, units={self.units!r})"
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


def elastic_tensor(network, rotations=True, *, radius=None, solver="auto", tol=1e-10, floppy_samples=0):
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
        Sparse LDL^T factorization (exact floppy-mode count; MKL PARDISO when pypardiso
        is installed, else SciPy SuperLU), conjugate gradients preconditioned by a
        smoothed-aggregation algebraic multigrid cycle (pyamg; fewest operations on
        large, well-connected networks) or by block Jacobi (least memory). ``"auto"``
        (:func:`_auto_solver`): the factorization up to 6000 unknowns (about 1000
        particles with rotations; 12 000 with PARDISO) and, with PARDISO, for near-isostatic networks
        (backbone coordination below 1.4 times the isostatic 4 with rotations, 2
        without) up to 150 000 unknowns; otherwise block-Jacobi CG up to 24 000 unknowns
        and AMG-CG above.
    tol : float, default 1e-10
        Relative residual of the relaxation.
    floppy_samples : int, default 0
        With the direct solver, also draw this many random vectors of the floppy space
        from its factorization (``et.floppy_samples``, ``(k, N, nd)`` in the solver's
        unknowns, NaN outside the relaxing part; ``et.floppy_metric`` the diagonal of
        the stiffness per unknown): what :func:`polypack.mechanics.rigidity` needs, at
        the cost of a few solves with the factor already made. Ignored by the
        iterative solvers (the attributes are then None).

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
        stress), or when the relaxation neither reaches a relative residual of 1e-6 nor
        stops lowering the energy (iterative solvers on near-floppy networks: use
        ``solver="direct"``).

    References
    ----------
    .. [1] C. E. Maloney and A. Lemaitre, "Amorphous systems in athermal, quasistatic
       shear", Phys. Rev. E 74, 016118 (2006) (non-affine relaxation, C = C_aff - Xi^T H^-1 Xi).
    .. [2] D. O. Potyondy and P. A. Cundall, "A bonded-particle model for rock",
       Int. J. Rock Mech. Min. Sci. 41, 1329 (2004) (contact bonds).
    """
    import time

    from .._kernels import network as knl
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
    if isinstance(floppy_samples, bool) or int(floppy_samples) != floppy_samples or floppy_samples < 0:
        raise InvalidInputError(f"floppy_samples={floppy_samples!r}: must be an integer >= 0")
    floppy_samples = int(floppy_samples)
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
    kbar = float(kn_all.mean())
    common = dict(rotations=bool(rotations), units=units, length_scale=2.0 * float(rad.mean()) * scale,
                  stiffness_scale=kbar, n_particles=n_all, n_bonds=network.n_bonds,
                  coordination=network.coordination, n_rattlers=int(network.rattlers.sum()))
    if not wrapping.any():
        # no bonded cluster percolates: nothing carries stress, every strain mode is floppy
        return ElasticTensor(
            stiffness=np.zeros((6, 6)), affine_stiffness=c_aff / scale,
            nonaffine_displacements=np.full((6, n_all, 3), np.nan),
            nonaffine_rotations=np.full((6, n_all, 3), np.nan) if rotations else None,
            floppy_modes=None, n_active=0, n_active_bonds=0, n_clusters=0, solver=None, factorization=None,
            iterations=None, multigrid_levels=None, residual=0.0, asymmetry=0.0, rigid=False, floppy_strains=6,
            floppy_reason=(f"disconnected: none of its {spans.shape[0]} bonded cluster(s) wraps the periodic box "
                           f"(Z = {network.coordination:.3g}); it carries no stress"),
            seconds=time.perf_counter() - t0, **common)
    active = (label >= 0) & wrapping[np.maximum(label, 0)]
    bond_on = active[network.i] & active[network.j]
    idx = np.full(n_all, -1, np.int64)
    idx[active] = np.arange(int(active.sum()))
    n = int(active.sum())
    bi = idx[network.i[bond_on]]
    bj = idx[network.j[bond_on]]
    ell = float(rad[active].mean())
    nd = 6 if rotations else 3
    bonds = (bi, bj, kn_all[bond_on], ks_all[bond_on], np.ascontiguousarray(network.normal[bond_on]),
             np.ascontiguousarray(network.branch[bond_on]), np.ascontiguousarray(network.lever_arm_i[bond_on]),
             np.ascontiguousarray(network.lever_arm_j[bond_on]), ell, bool(rotations))
    h, xi, caff_on = _hessian(n, *bonds)
    # pin the translations of one particle per wrapping cluster
    clusters = np.unique(label[active])
    lab_active = label[active]
    first = np.unique(lab_active, return_index=True)[1]
    pinned = (first[:, None] * nd + np.arange(3)[None, :]).ravel()
    keep = np.ones(n * nd, bool)
    keep[pinned] = False
    # unknowns that no bond touches (e.g. the spin of a particle about the straight line of
    # its bonds) have no stiffness and no load: floppy, left out of the solve (x = 0)
    untouched = (np.asarray(h.diagonal()) <= 0.0) & keep
    keep &= ~untouched
    rhs = -xi
    rhs[~keep] = 0.0
    method = solver
    if method == "auto":
        method = _auto_solver(n * nd, 2.0 * bi.size / max(n, 1), nd)
    iterations = None
    levels = None
    factorization = None
    # residual floor: a right-hand side far below the typical bond force per unit strain
    # (e.g. round-off on a lattice, whose affine forces cancel) needs no relative accuracy
    ref = 1e-6 * float(np.mean(kn_all) * np.mean(network.length)) * np.sqrt(n * nd)
    strains = np.arange(6, dtype=np.int64)

    def relaxed_energy(y, rows=None):
        """Twice the relaxed energy per unit strain squared of each column of ``y`` (all
        unknowns, or those of ``rows``): ``diag`` of the bond Gram matrix."""
        if rows is not None:
            full = np.zeros((n * nd, y.shape[1]))
            full[rows] = y
            y = full
        return np.diag(knl.relaxed_gram(*bonds, y.reshape(n, nd, -1), strains[:y.shape[1]]))

    drawn = {}
    if method == "direct":
        hr = h.tocsr()[keep][:, keep]
        local = _local_spin_modes(n, nd, keep, bi, bj, bonds[6], bonds[7], ell)
        x_r, floppy, open_res, res, basis, factorization, cg_iterations = _solve_direct(
            hr, rhs[keep], ref, tol=min(tol, 1e-12), local_modes=local, energy=lambda y: relaxed_energy(y, keep),
            samples=floppy_samples, sample_out=drawn)
        iterations = cg_iterations or None
        if floppy is not None:
            floppy += int(untouched.sum())
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
        x_full, open_res, res, iterations = _solve_cg(hp, rhs, ref, tol=tol, nd=nd, prec=prec, energy=relaxed_energy)
        floppy = None
        x_r = x_full[keep]
    if not open_res <= _RESIDUAL_LIMIT:
        # a column with neither a small residual nor an energy that stopped falling: not relaxed
        raise InfeasibleError(
            f"elastic_tensor: the relaxation did not converge (solver={method!r}: relative residual {open_res:.2g}"
            + (f" after {iterations} CG iterations" if iterations else "")
            + f", limit {_RESIDUAL_LIMIT:g}, energy still falling; Z = {network.coordination:.3g})"
            + ("; near-floppy networks need solver='direct'" if method != "direct" else "")
        )
    x = np.zeros((n * nd, 6))
    x[keep] = x_r
    # C = C_aff - Xi^T H^+ Xi / V, with C_aff over the relaxing bonds only: a rattler's
    # bonds and those of clusters that do not wrap the box relax completely and carry no
    # stress (they stay in affine_stiffness, the Voigt bound). Evaluated as the energy of
    # the relaxed bonds (knl.relaxed_gram): symmetric and positive semi-definite by
    # construction, never below the exact C, off by only the energy norm of the error of
    # x (second order; C_aff + Xi^T x / V, equal at the exact x = -H^+ Xi, is off to
    # first order), and blind to the components of x along zero modes. The asymmetry of
    # Xi^T x measures how far x is from the exact solution.
    xtx = xi.T @ x
    asym = float(np.abs(xtx - xtx.T).max() / max(np.abs(caff_on + xtx).max(), 1e-300))
    c_rel = knl.relaxed_gram(*bonds, x.reshape(n, nd, 6), strains) / volume
    c_rel = 0.5 * (c_rel + c_rel.T)
    c_rel, n_soft = _zero_floppy_strains(c_rel, c_aff)

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
        x = _remove_floppy(x, basis, keep, centre, lab_active, clusters, n, nd)
    q = x.reshape(n, nd, 6).transpose(2, 0, 1)  # (6, n, nd)
    u = q[:, :, :3]
    disp = np.full((6, n_all, 3), np.nan)
    disp[:, active] = u * scale
    rot = None
    if rotations:
        rot = np.full((6, n_all, 3), np.nan)
        rot[:, active] = q[:, :, 3:] / ell
    samples_out = metric_out = None
    if drawn:
        # unknowns no bond touches are zero modes of their own (free, unit metric scale)
        dref = float(np.mean(drawn["d"])) if drawn["d"].size else 1.0
        zf = np.zeros((n * nd, floppy_samples))
        zf[keep] = drawn["z"]
        zf[untouched] = np.random.default_rng(7).standard_normal((int(untouched.sum()), floppy_samples)) / np.sqrt(dref)
        samples_out = np.full((floppy_samples, n_all, nd), np.nan)
        samples_out[:, active] = zf.reshape(n, nd, floppy_samples).transpose(2, 0, 1)
        mf = np.zeros(n * nd)
        mf[keep] = drawn["d"]
        mf[untouched] = dref
        metric_out = np.zeros((n_all, nd))
        metric_out[active] = mf.reshape(n, nd)
    return ElasticTensor(
        floppy_samples=samples_out,
        floppy_metric=metric_out,
        floppy_sample_shift=drawn.get("shift"),
        active=active,
        stiffness=c_rel / scale,
        affine_stiffness=c_aff / scale,
        nonaffine_displacements=disp,
        nonaffine_rotations=rot,
        floppy_modes=floppy,
        n_active=n,
        n_active_bonds=int(bond_on.sum()),
        n_clusters=int(clusters.size),
        rigid=n_soft == 0,
        floppy_strains=n_soft,
        floppy_reason=None if n_soft == 0 else (
            f"{n_soft} of 6 strain modes cost no energy (modulus below {FLOPPY_TOLERANCE:g} of the affine one; "
            f"Z = {network.coordination:.3g}, {floppy if floppy is not None else 'uncounted'} floppy modes)"),
        **common,
        solver=method,
        factorization=factorization,
        iterations=iterations,
        multigrid_levels=levels,
        residual=float(res),
        asymmetry=asym,
        seconds=time.perf_counter() - t0,
    )


def _zero_floppy_strains(c, c_aff, tol=None):
    """``c`` with its floppy strain modes set to exactly zero; ``(c, count)``.

    The eigenvalues of the symmetric 6x6 ``c`` below ``tol`` (default
    :data:`FLOPPY_TOLERANCE`) times the largest eigenvalue of the affine tensor ``c_aff``
    are round-off of a zero-energy strain mode (see :data:`FLOPPY_TOLERANCE`); they are
    replaced by 0 in ``c = V diag(lambda) V^T``. A rigid ``c`` is returned unchanged.
    """
    tol = FLOPPY_TOLERANCE if tol is None else tol
    ref = float(np.linalg.eigvalsh(0.5 * (c_aff + c_aff.T))[-1])
    lam, vec = np.linalg.eigh(c)
    soft = lam < tol * ref
    count = int(soft.sum())
    if count == 0:
        return c, 0
    lam = np.where(soft, 0.0, lam)
    out = (vec * lam) @ vec.T
    out = 0.5 * (out + out.T)
    out[np.abs(out) < 1e-300] = 0.0
    return out, count


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
