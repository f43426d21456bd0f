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
from . import _elastic_solvers as _sol

__all__ = ["ElasticTensor", "elastic_tensor", "voigt_average", "SEED003_RADIUS"]

#: Particle radius of seed 003 Table 1 (metres).
SEED003_RADIUS = 0.25e-6

_VOIGT = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
_MODE_NAMES = ("11", "22", "33", "23", "13", "12")
# Largest relative residual of the relaxation accepted by elastic_tensor unless the energy
# has settled (the moduli are bond energies, second order in the error; see _solve_cg);
# beyond it, with the energy still falling, InfeasibleError.
_RESIDUAL_LIMIT = 1e-6
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

    t0 = time.perf_counter()
    floppy_samples, scale, units = _check_input(network, solver, tol, floppy_samples, radius)
    rad = np.asarray(network.packing.radii, dtype=np.float64)
    volume = float(np.prod(np.asarray(network.packing.box, dtype=np.float64)))
    n_all = network.n
    kn_all = np.ascontiguousarray(network.normal_stiffness)

    # affine stiffness over all bonds (rattlers included: every bond follows the strain)
    c_aff = _affine(network) / volume

    # relaxing part: backbone bonds of clusters that wrap the box
    label, spans = network.components(backbone=True)
    wrapping = spans.any(axis=1)
    common = dict(rotations=bool(rotations), units=units, length_scale=2.0 * float(rad.mean()) * scale,
                  stiffness_scale=float(kn_all.mean()), n_particles=n_all, n_bonds=network.n_bonds,
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
    s = _RelaxingPart(network, label, wrapping, rotations)
    method = solver
    if method == "auto":
        method = _sol._auto_solver(s.n * s.nd, 2.0 * s.bi.size / max(s.n, 1), s.nd)
    x, floppy, res, basis, factorization, iterations, levels, drawn = _relax(network, s, method, tol, floppy_samples)
    # C = C_aff - Xi^T H^+ Xi / V, with C_aff over the relaxing bonds only: a rattler's
    # bonds and those of clusters that do not wrap the box relax completely and carry no
    # stress (they stay in affine_stiffness, the Voigt bound). Evaluated as the energy of
    # the relaxed bonds (knl.relaxed_gram): symmetric and positive semi-definite by
    # construction, never below the exact C, off by only the energy norm of the error of
    # x (second order; C_aff + Xi^T x / V, equal at the exact x = -H^+ Xi, is off to
    # first order), and blind to the components of x along zero modes. The asymmetry of
    # Xi^T x measures how far x is from the exact solution.
    xtx = s.xi.T @ x
    asym = float(np.abs(xtx - xtx.T).max() / max(np.abs(s.caff_on + xtx).max(), 1e-300))
    c_rel = s.relaxed_gram(x.reshape(s.n, s.nd, 6), np.arange(6, dtype=np.int64)) / volume
    c_rel = 0.5 * (c_rel + c_rel.T)
    c_rel, n_soft = _zero_floppy_strains(c_rel, c_aff)
    disp, rot = _nonaffine_fields(s, x, basis, n_all, scale, rotations)
    samples_out, metric_out = _floppy_sample_fields(s, drawn, n_all, floppy_samples)
    return ElasticTensor(
        floppy_samples=samples_out,
        floppy_metric=metric_out,
        floppy_sample_shift=drawn.get("shift"),
        active=s.active,
        stiffness=c_rel / scale,
        affine_stiffness=c_aff / scale,
        nonaffine_displacements=disp,
        nonaffine_rotations=rot,
        floppy_modes=floppy,
        n_active=s.n,
        n_active_bonds=int(s.bond_on.sum()),
        n_clusters=int(s.clusters.size),
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


# ---------------------------------------------------------------- elastic_tensor: the steps
def _check_input(network, solver, tol, floppy_samples, radius):
    """Refuse what :func:`elastic_tensor` cannot linearise; ``(floppy_samples, length scale, units)``."""
    from .network import BondNetwork

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
    return floppy_samples, scale, units


class _RelaxingPart:
    """The relaxing part of a network (backbone bonds of the clusters that wrap the box) in the
    solver's unknowns: ``n`` particles of ``nd`` unknowns (3 translations, and 3 rotations times
    the mean radius ``ell`` unless ``rotations=False``), the Hessian ``h``, the affine forces
    ``xi``, the unknowns kept in the solve (``keep``: not pinned, touched by a bond)."""

    def __init__(self, network, label, wrapping, rotations):
        rad = np.asarray(network.packing.radii, dtype=np.float64)
        kn_all = np.ascontiguousarray(network.normal_stiffness)
        ks_all = np.ascontiguousarray(network.shear_stiffness)
        n_all = network.n
        active = (label >= 0) & wrapping[np.maximum(label, 0)]
        bond_on = active[network.i] & active[network.j]
        idx = np.full(n_all, -1, np.int64)
        idx[active] = np.arange(int(active.sum()))
        self.active, self.bond_on = active, bond_on
        self.n = n = int(active.sum())
        self.bi = bi = idx[network.i[bond_on]]
        self.bj = bj = idx[network.j[bond_on]]
        self.ell = ell = float(rad[active].mean())
        self.nd = nd = 6 if rotations else 3
        self.bonds = (bi, bj, kn_all[bond_on], ks_all[bond_on], np.ascontiguousarray(network.normal[bond_on]),
                      np.ascontiguousarray(network.branch[bond_on]),
                      np.ascontiguousarray(network.lever_arm_i[bond_on]),
                      np.ascontiguousarray(network.lever_arm_j[bond_on]), ell, bool(rotations))
        self.h, self.xi, self.caff_on = _hessian(n, *self.bonds)
        # pin the translations of one particle per wrapping cluster
        self.clusters = np.unique(label[active])
        self.lab_active = lab_active = label[active]
        first = np.unique(lab_active, return_index=True)[1]
        pinned = (first[:, None] * nd + np.arange(3)[None, :]).ravel()
        keep = np.ones(n * nd, bool)
        keep[pinned] = False
        # unknowns that no bond touches (e.g. the spin of a particle about the straight line of
        # its bonds) have no stiffness and no load: floppy, left out of the solve (x = 0)
        self.untouched = (np.asarray(self.h.diagonal()) <= 0.0) & keep
        keep &= ~self.untouched
        self.keep = keep

    def relaxed_gram(self, y, strains):
        """The bond Gram matrix of the fields ``y`` (``(n, nd, k)``): :func:`polypack._kernels.network.relaxed_gram`."""
        from .._kernels import network as knl

        return knl.relaxed_gram(*self.bonds, y, strains)

    def relaxed_energy(self, y, rows=None):
        """Twice the relaxed energy per unit strain squared of each column of ``y`` (all
        unknowns, or those of ``rows``): ``diag`` of the bond Gram matrix."""
        n, nd = self.n, self.nd
        if rows is not None:
            full = np.zeros((n * nd, y.shape[1]))
            full[rows] = y
            y = full
        return np.diag(self.relaxed_gram(y.reshape(n, nd, -1), np.arange(6, dtype=np.int64)[:y.shape[1]]))


def _relax(network, s, method, tol, floppy_samples):
    """Solve ``H x = -Xi`` for the six Voigt strains with ``method`` (:mod:`._elastic_solvers`).

    Returns ``(x, floppy, residual, basis, factorization, iterations, levels, drawn)``: ``x``
    over all unknowns (0 where not kept), the floppy-mode count (direct solver only), the
    relative residual, the collective floppy basis, the factorization used, the CG iterations,
    the multigrid level sizes and the floppy-space samples drawn (empty unless asked).

    Raises
    ------
    InfeasibleError
        When a column neither reaches a relative residual of :data:`_RESIDUAL_LIMIT` nor
        stops lowering the energy.
    """
    n, nd, keep, h = s.n, s.nd, s.keep, s.h
    rhs = -s.xi
    rhs[~keep] = 0.0
    iterations = None
    levels = None
    factorization = None
    # residual floor: a right-hand side far below the typical bond force per unit strain
    # (e.g. round-off on a lattice, whose affine forces cancel) needs no relative accuracy
    ref = 1e-6 * float(np.mean(np.ascontiguousarray(network.normal_stiffness)) * np.mean(network.length)) \
        * np.sqrt(n * nd)
    drawn = {}
    if method == "direct":
        hr = h.tocsr()[keep][:, keep]
        local = _sol._local_spin_modes(n, nd, keep, s.bi, s.bj, s.bonds[6], s.bonds[7], s.ell)
        x_r, floppy, open_res, res, basis, factorization, cg_iterations = _sol._solve_direct(
            hr, rhs[keep], ref, tol=min(tol, 1e-12), local_modes=local,
            energy=lambda y: s.relaxed_energy(y, keep), samples=floppy_samples, sample_out=drawn)
        iterations = cg_iterations or None
        if floppy is not None:
            floppy += int(s.untouched.sum())
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
            mg = _sol._Multigrid(hp, nd, np.asarray(network.packing.positions, dtype=np.float64)[s.active], s.ell)
            prec = mg
            levels = mg.sizes
        x_full, open_res, res, iterations = _sol._solve_cg(hp, rhs, ref, tol=tol, nd=nd, prec=prec,
                                                           energy=s.relaxed_energy)
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
    return x, floppy, res, basis, factorization, iterations, levels, drawn


def _nonaffine_fields(s, x, basis, n_all, scale, rotations):
    """``(displacements, rotations)``, ``(6, N, 3)`` each (NaN outside the relaxing part): zero mean
    translation per cluster and, when floppy modes exist, no component along them (the
    minimum-norm field, independent of labels and pinning)."""
    n, nd = s.n, s.nd

    def centre(y):
        y = y.reshape(n, nd, -1)
        for c in s.clusters:
            sel = s.lab_active == c
            y[sel, :3] -= y[sel, :3].mean(axis=0, keepdims=True)
        return y.reshape(n * nd, -1)

    x = centre(x)
    if basis is not None:
        x = _sol._remove_floppy(x, basis, s.keep, centre, s.lab_active, s.clusters, n, nd)
    q = x.reshape(n, nd, 6).transpose(2, 0, 1)  # (6, n, nd)
    u = q[:, :, :3]
    disp = np.full((6, n_all, 3), np.nan)
    disp[:, s.active] = u * scale
    rot = None
    if rotations:
        rot = np.full((6, n_all, 3), np.nan)
        rot[:, s.active] = q[:, :, 3:] / s.ell
    return disp, rot


def _floppy_sample_fields(s, drawn, n_all, floppy_samples):
    """``(samples, metric)`` over all particles from the floppy-space vectors ``drawn`` by the
    direct solver (None, None when none were drawn)."""
    if not drawn:
        return None, None
    n, nd, keep, untouched = s.n, s.nd, s.keep, s.untouched
    # unknowns no bond touches are zero modes of their own (free, unit metric scale)
    dref = float(np.mean(drawn["d"])) if drawn["d"].size else 1.0
    zf = np.zeros((n * nd, floppy_samples))
    zf[keep] = drawn["z"]
    zf[untouched] = np.random.default_rng(7).standard_normal((int(untouched.sum()), floppy_samples)) / np.sqrt(dref)
    samples_out = np.full((floppy_samples, n_all, nd), np.nan)
    samples_out[:, s.active] = zf.reshape(n, nd, floppy_samples).transpose(2, 0, 1)
    mf = np.zeros(n * nd)
    mf[keep] = drawn["d"]
    mf[untouched] = dref
    metric_out = np.zeros((n_all, nd))
    metric_out[s.active] = mf.reshape(n, nd)
    return samples_out, metric_out


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
