"""Full-field homogenization of a pack's voxel image: FFT-based Lippmann–Schwinger solver.

The estimates of :mod:`polypack.mechanics.effective` (§4 of 000_2cedc098acbd866b.txt:
Mori–Tanaka, Hashin–Shtrikman, three-point bounds, MEFM) see a pack only through its
statistics. :func:`homogenize` solves the periodic cell problem of *this* pack: the
voxel image of :func:`polypack.io.voxelize` (one phase per species plus the matrix) is
loaded by a macroscopic strain ``E`` (6 independent cases; conductivity: a macroscopic
gradient, 3 cases) and the average stress of each case is a column of the effective
stiffness.

Scheme (Galerkin form of the Lippmann–Schwinger equation, conjugate gradients).
With ``ε = E + ε̃`` and ``ε̃`` a compatible periodic field of zero mean, equilibrium is
``Γ0 * [C : (E + ε̃)] = 0`` where ``Γ0`` is the periodic Green operator of an isotropic
reference medium ``C0`` (``Γ0 C0`` is the orthogonal projection on compatible fields;
Moulinec & Suquet 1998). The operator ``ε̃ ↦ Γ0 * (C : ε̃)`` is self-adjoint and
positive (semi-)definite in the inner product ``⟨a, b⟩ = Σ a : C0 : b`` on compatible
fields, so conjugate gradients solve ``Γ0 * (C : ε̃) = −Γ0 * (C : E)`` (Zeman, Vondřejc,
Novák & Marek, J. Comput. Phys. 229, 8065 (2010)). The reference ``C0`` only
preconditions: ``K0 = √(K_min K_max)``, ``G0 = √(G_min G_max)`` over the phases (zero moduli
left out), which balances bulk against shear (a near-incompressible binder otherwise
sets the condition number). Voids (``C = 0``) make the operator singular but the system
stays consistent and CG converges on the range; rigid phases are approximated by large
finite moduli (the iteration count grows slowly with contrast; docs/fullfield.md).

Discretization: by default the rotated discrete Green operator of Willot (C. R. Mécanique
343, 232 (2015)): the wave vector ``ξ`` is replaced by the symbol of the centred finite
difference on the voxel corners, ``k_j = (2/h_j) sin(θ_j/2) Π_{l≠j} cos(θ_l/2)``,
``θ_j = 2π m_j/n_j``, which removes the Gibbs oscillations of the continuous symbol and
keeps the scheme convergent at infinite contrast. ``scheme="fourier"`` uses the
continuous symbol (Moulinec–Suquet), a second discretization for cross-checks.

Stopping: the C0-norm of the CG residual relative to that of the right-hand side falls
below ``tolerance``; the effective moduli are energy-like (their error is second order in
the residual). A run that reaches ``max_iterations`` is reported with ``converged=False``
(and the stage refuses to record its numbers).

The code uses only operations common to NumPy and CuPy through a namespace ``xp`` and an
FFT module (``scipy.fft`` with ``workers`` on the CPU; ``cupyx.scipy.fft`` with
``backend="cupy"``). NumPy/SciPy is the tested reference; the CuPy path has not been run
on a GPU in this project yet.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import InfeasibleError, InvalidInputError

__all__ = ["homogenize", "Homogenized", "richardson", "isotropic_projection"]

# tensor components in Voigt order 11, 22, 33, 23, 13, 12; (i, j) -> component index
_VOIGT = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
_IDX = ((0, 5, 4), (5, 1, 3), (4, 3, 2))
_W = (1.0, 1.0, 1.0, 2.0, 2.0, 2.0)  # Frobenius weights of the off-diagonal components


def isotropic_projection(c):
    """``(K, G)`` of the isotropic tensor closest to a 6x6 Voigt stiffness (engineering shears).

    ``K = [C11 + C22 + C33 + 2 (C12 + C13 + C23)] / 9``,
    ``G = [C11 + C22 + C33 − (C12 + C13 + C23) + 3 (C44 + C55 + C66)] / 15``.
    """
    from .elastic import voigt_average

    return voigt_average(c)


def richardson(resolutions, values):
    """Richardson extrapolation of a quantity computed at several resolutions.

    Parameters
    ----------
    resolutions : sequence of int
        Voxels along the box (increasing); the voxel size is ``h ∝ 1/n``.
    values : sequence of float
        The quantity at each resolution.

    Returns
    -------
    dict
        ``value`` (continuum estimate), ``order`` (observed order ``p`` from the last three
        values when they converge monotonically, else 1 assumed), ``order_assumed``,
        ``error`` (``|value − finest|``, the estimated discretization error of the finest).
    """
    n = np.asarray(resolutions, dtype=np.float64)
    f = np.asarray(values, dtype=np.float64)
    if n.size < 2:
        return {"value": float(f[-1]), "order": None, "order_assumed": True, "error": None}
    p, assumed = 1.0, True
    if n.size >= 3:
        d1, d2 = f[-2] - f[-3], f[-1] - f[-2]
        r1, r2 = n[-2] / n[-3], n[-1] / n[-2]
        if d1 * d2 > 0 and abs(d2) < abs(d1) and abs(r1 - r2) < 1e-9:
            p, assumed = math.log(abs(d1 / d2)) / math.log(r2), False
    r = n[-1] / n[-2]
    val = f[-1] + (f[-1] - f[-2]) / (r ** p - 1.0)
    return {"value": float(val), "order": float(p), "order_assumed": assumed, "error": float(abs(val - f[-1]))}


@dataclass
class Homogenized:
    """Result of :func:`homogenize`.

    Attributes
    ----------
    property : str
        ``"elastic"`` or ``"conductivity"``.
    stiffness : ndarray (6, 6) or None
        Effective stiffness, Voigt order 11, 22, 33, 23, 13, 12 with engineering shear
        strains (``C44 = σ23/γ23``, as :func:`polypack.mechanics.elastic_tensor`), symmetrised.
    conductivity : ndarray (dim, dim) or None
        Effective conductivity tensor.
    bulk, shear : float or None
        Isotropic projections of ``stiffness`` (:func:`isotropic_projection`).
    iterations : list of int
        CG iterations per load case.
    converged : bool
        Every load case reached ``tolerance``.
    resolution : tuple of int
        Voxels per axis of the (finest) image.
    asymmetry : float
        ``max|C − Cᵀ| / max|C|`` before symmetrisation (a solver check; ~ tolerance²).
    volume_fractions : dict
        ``exact`` and ``voxel`` phase fractions (matrix first) when solved from a pack.
    convergence : list of dict
        One entry per resolution when several were asked (``resolution``, ``bulk``,
        ``shear`` or ``conductivity``, ``iterations``, ``seconds``).
    extrapolated : dict
        Richardson estimates (:func:`richardson`) of ``bulk``, ``shear`` (or ``conductivity``).
    fields : list of ndarray or None
        The local strain (gradient) field of every load case on request
        (``(6, n_x, n_y, n_z)`` tensor components, shears as ε_ij not γ_ij).
    """

    property: str
    resolution: tuple
    iterations: list
    converged: bool
    stiffness: np.ndarray | None = None
    conductivity: np.ndarray | None = None
    asymmetry: float = 0.0
    reference: dict = field(default_factory=dict)
    volume_fractions: dict = field(default_factory=dict)
    convergence: list = field(default_factory=list)
    extrapolated: dict = field(default_factory=dict)
    seconds: float = 0.0
    scheme: str = "willot"
    tolerance: float = 1e-6
    fields: list | None = None
    composite: bool = False

    @property
    def bulk(self):
        return None if self.stiffness is None else float(isotropic_projection(self.stiffness)[0])

    @property
    def shear(self):
        return None if self.stiffness is None else float(isotropic_projection(self.stiffness)[1])

    @property
    def young(self):
        k, g = self.bulk, self.shear
        return None if k is None else 9.0 * k * g / (3.0 * k + g)

    @property
    def poisson(self):
        k, g = self.bulk, self.shear
        return None if k is None else (3.0 * k - 2.0 * g) / (2.0 * (3.0 * k + g))

    @property
    def mean_conductivity(self):
        return None if self.conductivity is None else float(np.trace(self.conductivity) / self.conductivity.shape[0])

    @property
    def anisotropy(self):
        """Relative distance of the tensor from its isotropic projection (max-norm)."""
        if self.stiffness is not None:
            k, g = self.bulk, self.shear
            lam = k - 2.0 * g / 3.0
            iso = np.zeros((6, 6))
            iso[:3, :3] = lam
            iso[np.arange(3), np.arange(3)] += 2.0 * g
            iso[np.arange(3, 6), np.arange(3, 6)] = g
            return float(np.abs(self.stiffness - iso).max() / np.abs(iso).max())
        k = self.mean_conductivity
        return float(np.abs(self.conductivity - k * np.eye(self.conductivity.shape[0])).max() / k)

    def to_dict(self):
        d = {"estimator": "FFTHomogenization", "property": self.property, "resolution": list(self.resolution),
             "scheme": self.scheme, "composite": self.composite, "tolerance": self.tolerance, "converged": bool(self.converged),
             "iterations": int(max(self.iterations)) if self.iterations else 0,
             "iterations_total": int(sum(self.iterations)), "seconds": self.seconds, "asymmetry": self.asymmetry,
             "anisotropy": self.anisotropy, "reference": self.reference, "volume_fractions": self.volume_fractions,
             "convergence": self.convergence, "extrapolated": self.extrapolated}
        if self.stiffness is not None:
            d.update(stiffness=self.stiffness.tolist(), bulk=self.bulk, shear=self.shear, young=self.young,
                     poisson=self.poisson)
        else:
            d.update(conductivity=self.conductivity.tolist(), mean_conductivity=self.mean_conductivity)
        return d


# ----------------------------------------------------------------------------- backends
def _backend(name, workers):
    if name == "numpy":
        import scipy.fft as sfft

        w = workers if workers is not None else (os.cpu_count() or 1)

        def rfftn(a, axes):
            return sfft.rfftn(a, axes=axes, workers=w)

        def irfftn(a, s, axes):
            return sfft.irfftn(a, s=s, axes=axes, workers=w)

        return np, rfftn, irfftn, np.asarray
    if name == "cupy":
        try:
            import cupy as cp
            import cupyx.scipy.fft as cfft
        except ImportError:
            raise InvalidInputError("backend='cupy' needs CuPy and a CUDA GPU (pip install cupy-cuda12x); "
                                    "use backend='numpy'") from None

        def rfftn(a, axes):
            return cfft.rfftn(a, axes=axes)

        def irfftn(a, s, axes):
            return cfft.irfftn(a, s=s, axes=axes)

        return cp, rfftn, irfftn, cp.asnumpy
    raise InvalidInputError(f"backend={name!r} is unknown; allowed: 'numpy' (reference), 'cupy' (GPU)")


def _wave_directions(xp, shape, spacing, scheme, dtype=np.float64):
    """Unit vectors ``n = k/|k|`` of the (modified) wave vectors on the rfft grid (0 where k = 0)."""
    dim = len(shape)
    comps = []
    thetas = []
    for a in range(dim):
        m = np.fft.rfftfreq(shape[a]) if a == dim - 1 else np.fft.fftfreq(shape[a])
        thetas.append(2.0 * np.pi * m)
    grids = np.meshgrid(*thetas, indexing="ij", sparse=True)
    for a in range(dim):
        th = grids[a]
        if scheme == "willot":
            k = (2.0 / spacing[a]) * np.sin(th / 2.0)
            for b in range(dim):
                if b != a:
                    k = k * np.cos(grids[b] / 2.0)
        else:
            k = th / spacing[a] + 0.0 * sum(grids)
            # Nyquist frequencies of even axes carry no compatible gradient in the continuous scheme
            if shape[a] % 2 == 0:
                k = np.where(np.abs(np.abs(th) - np.pi) < 1e-12, 0.0, k)
        comps.append(np.broadcast_to(k, np.broadcast_shapes(*[g.shape for g in grids])).astype(np.float64))
    norm = np.sqrt(sum(c * c for c in comps))
    small = norm <= 1e-12 * norm.max()
    norm[small] = 1.0
    out = [np.where(small, 0.0, c / norm) for c in comps]
    return [xp.asarray(o.astype(dtype)) for o in out]


# ----------------------------------------------------------------------------- solvers
def _cg(apply_a, inner, b, tol, maxit, xp):
    """Conjugate gradients for ``A x = b`` in the inner product ``inner``; returns (x, iterations, converged, rel)."""
    x = xp.zeros_like(b)
    bb = inner(b, b)
    if not bb > 0.0:
        return x, 0, True, 0.0
    r = b.copy()
    p = r.copy()
    rr = bb
    it = 0
    rel = 1.0
    while it < maxit:
        ap = apply_a(p)
        pap = inner(p, ap)
        if not pap > 0.0:
            break
        alpha = rr / pap
        x += alpha * p
        r -= alpha * ap
        it += 1
        rr_new = inner(r, r)
        rel = math.sqrt(max(rr_new, 0.0) / bb)
        if rel < tol:
            return x, it, True, rel
        p *= rr_new / rr
        p += r
        rr = rr_new
    return x, it, rel < tol, rel


def _solve_elastic(lam, mu, spacing, tol, maxit, xp, rfftn, irfftn, lam0, mu0, scheme, keep_fields):
    shape = lam.shape
    dt = lam.dtype
    axes = (1, 2, 3)
    n = _wave_directions(xp, shape, spacing, scheme, dt)
    c0 = (lam0 + mu0) / (mu0 * (lam0 + 2.0 * mu0))
    mu2 = 2.0 * mu
    w = xp.asarray(np.array(_W, dtype=dt).reshape(6, 1, 1, 1))

    def apply_c(e):
        tr = e[0] + e[1] + e[2]
        out = mu2 * e
        lt = lam * tr
        out[0] += lt
        out[1] += lt
        out[2] += lt
        return out

    def gamma0(tau):
        th = rfftn(tau, axes)
        tn = [th[_IDX[k][0]] * n[0] + th[_IDX[k][1]] * n[1] + th[_IDX[k][2]] * n[2] for k in range(3)]
        ntn = n[0] * tn[0] + n[1] * tn[1] + n[2] * tn[2]
        for c, (i, j) in enumerate(_VOIGT):
            th[c] = (n[j] * tn[i] + n[i] * tn[j]) / (2.0 * mu0) - c0 * (n[i] * n[j]) * ntn
        return irfftn(th, shape, axes)

    def inner(a, b):
        ta = a[0] + a[1] + a[2]
        tb = b[0] + b[1] + b[2]
        return float(lam0 * xp.sum(ta * tb, dtype=xp.float64) + 2.0 * mu0 * xp.sum(w * a * b, dtype=xp.float64))

    def apply_a(p):
        return gamma0(apply_c(p))

    cols, its, conv, fields = [], [], True, []
    for m in range(6):
        e = xp.zeros((6,) + tuple(shape), dtype=dt)
        e[m] = 1.0 if m < 3 else 0.5  # engineering shear gamma = 1
        b = -gamma0(apply_c(e))
        x, it, ok, _ = _cg(apply_a, inner, b, tol, maxit, xp)
        x += e
        sig = apply_c(x)
        cols.append([float(xp.mean(sig[c], dtype=xp.float64)) for c in range(6)])
        its.append(it)
        conv = conv and ok
        if keep_fields:
            fields.append(x)
        del x, b, sig, e
    return np.array(cols).T, its, conv, fields


def _solve_conductivity(k, spacing, tol, maxit, xp, rfftn, irfftn, k0, scheme, keep_fields):
    shape = k.shape
    dim = len(shape)
    dt = k.dtype
    axes = tuple(range(1, dim + 1))
    n = _wave_directions(xp, shape, spacing, scheme, dt)

    def gamma0(tau):
        th = rfftn(tau, axes)
        tn = n[0] * th[0]
        for a in range(1, dim):
            tn = tn + n[a] * th[a]
        for a in range(dim):
            th[a] = n[a] * tn / k0
        return irfftn(th, shape, axes)

    def inner(a, b):
        return float(k0 * xp.sum(a * b, dtype=xp.float64))

    def apply_a(p):
        return gamma0(k * p)

    cols, its, conv, fields = [], [], True, []
    for m in range(dim):
        e = xp.zeros((dim,) + tuple(shape), dtype=dt)
        e[m] = 1.0
        b = -gamma0(k * e)
        x, it, ok, _ = _cg(apply_a, inner, b, tol, maxit, xp)
        x += e
        q = k * x
        cols.append([float(xp.mean(q[a], dtype=xp.float64)) for a in range(dim)])
        its.append(it)
        conv = conv and ok
        if keep_fields:
            fields.append(x)
    return np.array(cols).T, its, conv, fields


# ----------------------------------------------------------------------------- input
def _phase_list(matrix, inclusions, n_labels, prop):
    """One material per label (0 = matrix, 1 + s = species s)."""
    from .effective import Phase

    if prop == "elastic":
        def check(p, what):
            if not isinstance(p, Phase):
                raise InvalidInputError(f"{what} must be a polypack.mechanics.Phase for property='elastic', "
                                        f"got {type(p).__name__}")
            if math.isinf(p.bulk) or math.isinf(p.shear):
                raise InvalidInputError(f"{what}={p!r}: a voxel solver needs finite moduli; model a rigid or "
                                        "incompressible phase by a large finite modulus (contrast 1e4-1e6)")
            return p
    else:
        def check(p, what):
            try:
                v = float(p)
            except (TypeError, ValueError):
                raise InvalidInputError(f"{what}={p!r} must be a conductivity >= 0 for property='conductivity'") from None
            if not (v >= 0.0) or math.isinf(v):
                raise InvalidInputError(f"{what}={p!r} must be a finite conductivity >= 0")
            return v

    out = [check(matrix, "matrix")]
    ns = n_labels - 1
    if isinstance(inclusions, dict):
        for s in range(ns):
            if s not in inclusions:
                raise InvalidInputError(f"inclusions has no entry for species {s}; give one per species 0..{ns - 1}")
            out.append(check(inclusions[s], f"inclusions[{s}]"))
    elif isinstance(inclusions, (list, tuple)):
        if len(inclusions) == 1:
            out += [check(inclusions[0], "inclusions[0]")] * ns
        elif len(inclusions) == ns:
            out += [check(p, f"inclusions[{s}]") for s, p in enumerate(inclusions)]
        else:
            raise InvalidInputError(f"inclusions has {len(inclusions)} entries but the image has {ns} species; "
                                    f"give 1 or {ns}")
    else:
        out += [check(inclusions, "inclusions")] * ns
    return out


def _image(source, resolution, subsamples):
    """``(labels, spacing, fractions, fraction field or None)`` from a Packing, a VoxelImage or a label array."""
    from ..io.voxel import VoxelImage, voxelize
    from ..packing import Packing

    if isinstance(source, Packing):
        img = voxelize(source, resolution, subsamples=subsamples)
    elif isinstance(source, VoxelImage):
        img = source
    elif isinstance(source, np.ndarray):
        if source.ndim not in (2, 3) or source.dtype.kind not in "iu" or source.size == 0 or source.min() < 0:
            raise InvalidInputError(f"a label image must be a 2D or 3D array of integers >= 0, got shape "
                                    f"{source.shape} dtype {source.dtype}")
        lab = source
        counts = np.bincount(lab.ravel()) / lab.size
        return lab, np.full(lab.ndim, 1.0 / max(lab.shape)), {"voxel": counts.tolist()}, None
    else:
        raise InvalidInputError(f"homogenize needs a Packing, a polypack.io.VoxelImage or an integer label array, "
                                f"got {type(source).__name__}")
    fr = {"exact": img.exact_fractions.tolist(), "voxel": img.voxel_fractions.tolist()}
    if img.fraction is not None:
        fr["subvoxel_inclusion"] = img.subvoxel_inclusion_fraction
    return img.labels, img.spacing, fr, img.fraction


def _coated_elastic(m, f, phi):
    """Per-voxel ``(K, G)`` of the coated (matrix-reference Hashin–Shtrikman) composite-voxel rule."""
    from .effective import zeta_reference

    b = 4.0 * m.shear / 3.0
    z = zeta_reference(m.bulk, m.shear)
    dk, dg = f.bulk - m.bulk, f.shear - m.shear
    k = m.bulk + phi * dk / (1.0 + (1.0 - phi) * dk / (m.bulk + b)) if m.bulk + b > 0 else phi * f.bulk
    g = m.shear + phi * dg / (1.0 + (1.0 - phi) * dg / (m.shear + z)) if m.shear + z > 0 else phi * f.shear
    return np.asarray(k, dtype=np.float64), np.asarray(g, dtype=np.float64)


def _coated_conductivity(k0, k1, phi, dim):
    """Per-voxel Maxwell-Garnett conductivity (matrix as the coating) of the composite-voxel rule."""
    d = k1 - k0
    if k0 == 0.0:
        return np.where(phi >= 1.0, k1, 0.0)
    return k0 + phi * d * dim * k0 / (dim * k0 + (1.0 - phi) * d)


def _reference(values):
    pos = [v for v in values if v > 0.0]
    if not pos:
        return 1.0
    return math.sqrt(min(pos) * max(pos))


def homogenize(packing, matrix, inclusions=None, resolution=64, *, property="elastic", tolerance=1e-6,
               max_iterations=None, resolutions=None, scheme="willot", backend="numpy", workers=None,
               fields=False, subsamples=0, precision="double", composite=False):
    """Effective elastic stiffness (or conductivity) of a pack from its voxel image.

    Parameters
    ----------
    packing : Packing, VoxelImage or ndarray of int
        The pack (voxelized with :func:`polypack.io.voxelize`), an image, or a label array
        (0 matrix, ``1 + s`` species ``s``; voxel size ``1/max(shape)``).
    matrix : Phase or float
        Matrix phase: a :class:`~polypack.mechanics.Phase` (elastic) or a conductivity.
    inclusions : Phase, float, list or dict
        One material for every species, one per species (list), or ``{species: material}``.
    resolution : int, default 64
        Voxels along the longest box axis (ignored for images).
    property : {"elastic", "conductivity"}
        Elasticity (3D only: 6 load cases) or scalar conduction (2D or 3D: ``dim`` cases).
    tolerance : float, default 1e-6
        Relative residual (C0-norm) at which CG stops.
    max_iterations : int, optional
        Per load case (default 5000; CG needs about 20 at contrast 10, 500 at 1e4 and
        ~1000 at the AP/HTPB contrast 5e4, docs/fullfield.md); reaching it gives ``converged=False``.
    resolutions : sequence of int, optional
        Solve at each resolution (increasing) and report the convergence table and the
        Richardson estimate (:func:`richardson`); the result holds the finest solve.
    scheme : {"willot", "fourier"}
        Rotated discrete Green operator (default) or the continuous symbol.
    backend : {"numpy", "cupy"}
        Array library; CuPy needs a GPU (untested here).
    workers : int, optional
        FFT threads (``scipy.fft`` ``workers``; default all CPUs).
    fields : bool
        Keep the local strain (gradient) field of every load case.
    precision : {"double", "single"}
        Field arithmetic and FFTs in float64 (default) or float32 (half the memory, faster
        transforms; inner products still accumulate in float64; use ``tolerance >= 1e-5``).
    subsamples : int
        Passed to :func:`polypack.io.voxelize` (the sub-voxel inclusion fraction of each
        voxel; 4 when ``composite`` and not given).
    composite : bool
        Composite voxels: a voxel the sphere surface crosses, with inclusion fraction φ,
        gets the Hashin–Shtrikman moduli with the matrix as the coating (Mori–Tanaka form,
        ``K = K0 + φ(K1 − K0)/(1 + (1 − φ)(K1 − K0)/(K0 + 4G0/3))``, likewise ``G`` with
        ``ζ(K0, G0)``; Maxwell-Garnett for conductivity) instead of the label of its centre:
        the phase volumes are exact and voxels shared by two near-touching spheres do
        not bridge them with inclusion stiffness. One inclusion material only.

    Returns
    -------
    Homogenized

    Raises
    ------
    InvalidInputError
        Bad phases, property, scheme, backend, tolerance or image.
    InfeasibleError
        Only from the stage wrapper; :func:`homogenize` itself reports ``converged=False``.
    """
    tol = _check_solver_options(property, scheme, tolerance)
    if resolutions is not None:
        return _resolution_series(packing, matrix, inclusions, resolutions, property=property, tolerance=tol,
                                  max_iterations=max_iterations, scheme=scheme, backend=backend, workers=workers,
                                  fields=fields, subsamples=subsamples, precision=precision, composite=composite)

    if precision not in ("double", "single"):
        raise InvalidInputError(f"precision={precision!r} must be 'double' or 'single'")
    dtype = np.float64 if precision == "double" else np.float32
    xp, rfftn, irfftn, to_numpy = _backend(backend, workers)
    if composite not in (False, True):
        raise InvalidInputError(f"composite={composite!r} must be True or False")
    if composite and not subsamples:
        subsamples = 4
    labels, spacing, fractions, phi = _image(packing, resolution, subsamples)
    if composite and phi is None:
        raise InvalidInputError("composite=True needs a Packing or a VoxelImage voxelized with subsamples > 0 "
                                "(a label array has no sub-voxel fractions)")
    if property == "elastic" and labels.ndim != 3:
        raise InvalidInputError(f"property='elastic' needs a 3D pack or image (got {labels.ndim}D); "
                                "2D images support property='conductivity'")
    mats = _phase_list(matrix, inclusions, _label_count(packing, inclusions, labels, fractions), property)
    if composite and any(p != mats[1] for p in mats[2:]):
        raise InvalidInputError("composite=True needs one inclusion material for every species")
    maxit = int(max_iterations) if max_iterations is not None else 5000
    if maxit < 1:
        raise InvalidInputError(f"max_iterations={max_iterations!r} must be >= 1")
    t0 = time.perf_counter()
    solve = _homogenize_elastic if property == "elastic" else _homogenize_conductivity
    out, flds = solve(labels, mats, phi if composite else None, spacing, tol, maxit, dtype, xp, rfftn, irfftn,
                      scheme, fields)
    out.seconds = time.perf_counter() - t0
    out.scheme = scheme
    out.tolerance = tol
    out.volume_fractions = fractions
    out.composite = bool(composite)
    if fields:
        out.fields = [to_numpy(f) for f in flds]
    return out


# ---------------------------------------------------------------- homogenize: the steps
def _check_solver_options(property, scheme, tolerance):
    """Refuse an unknown property or scheme and a tolerance outside (0, 1); returns the tolerance."""
    if property not in ("elastic", "conductivity"):
        raise InvalidInputError(f"property={property!r} must be 'elastic' or 'conductivity'")
    if scheme not in ("willot", "fourier"):
        raise InvalidInputError(f"scheme={scheme!r} must be 'willot' (rotated discrete Green operator) or 'fourier'")
    try:
        tol = float(tolerance)
    except (TypeError, ValueError):
        tol = float("nan")
    if not 0.0 < tol < 1.0:
        raise InvalidInputError(f"tolerance={tolerance!r} must lie in (0, 1)")
    return tol


def _resolution_series(packing, matrix, inclusions, resolutions, *, property, tolerance, max_iterations, scheme,
                       backend, workers, fields, subsamples, precision, composite):
    """:func:`homogenize` at each of ``resolutions`` (increasing): the finest result with the
    ``convergence`` table and the Richardson ``extrapolated`` moduli."""
    res = list(resolutions)
    if len(res) < 1 or any(isinstance(r, bool) or int(r) != r or r < 2 for r in res) or sorted(res) != res:
        raise InvalidInputError(f"resolutions={resolutions!r} must be increasing integers >= 2")
    from ..packing import Packing

    if not isinstance(packing, Packing):
        raise InvalidInputError("resolutions=... needs a Packing (an image has one resolution)")
    runs = [homogenize(packing, matrix, inclusions, r, property=property, tolerance=tolerance,
                       max_iterations=max_iterations, scheme=scheme, backend=backend, workers=workers,
                       fields=fields and r == res[-1], subsamples=subsamples, precision=precision,
                       composite=composite) for r in res]
    best = runs[-1]
    keys = ("bulk", "shear") if property == "elastic" else ("mean_conductivity",)
    best.convergence = [{"resolution": list(r.resolution), "iterations": int(max(r.iterations)),
                         "converged": bool(r.converged), "seconds": r.seconds,
                         "voxel_inclusion_fraction": float(1.0 - r.volume_fractions["voxel"][0]),
                         **{k: getattr(r, k) for k in keys}} for r in runs]
    best.converged = all(r.converged for r in runs)
    best.extrapolated = {k: richardson(res, [getattr(r, k) for r in runs]) for k in keys}
    return best


def _label_count(packing, inclusions, labels, fractions):
    """Number of phases: the labels of the image, at least one per species (or given inclusion)."""
    n_labels = int(labels.max()) + 1
    if isinstance(packing, np.ndarray):
        n_labels = max(n_labels, 1 + (len(inclusions) if isinstance(inclusions, (list, tuple, dict)) else 1))
    elif hasattr(packing, "n_species"):
        n_labels = max(n_labels, 1 + int(packing.n_species))
    else:
        n_labels = max(n_labels, len(fractions.get("exact", [])))
    return n_labels


def _homogenize_elastic(labels, mats, phi, spacing, tol, maxit, dtype, xp, rfftn, irfftn, scheme, fields):
    """The elastic :class:`Homogenized` of a label image (``phi``: sub-voxel inclusion fractions
    of a composite-voxel run, else None) and its fields."""
    lab = xp.asarray(labels.astype(np.intp))
    ks = [p.bulk for p in mats]
    gs = [p.shear for p in mats]
    k0, g0 = _reference(ks), _reference(gs)
    lam_t = xp.asarray(np.array([k - 2.0 * g / 3.0 for k, g in zip(ks, gs)], dtype=dtype))
    mu_t = xp.asarray(np.array(gs, dtype=dtype))
    if phi is not None and len(mats) > 1:
        kc, gc = _coated_elastic(mats[0], mats[1], np.asarray(phi, dtype=np.float64))
        lam, mu = xp.asarray((kc - 2.0 * gc / 3.0).astype(dtype)), xp.asarray(gc.astype(dtype))
    else:
        lam, mu = lam_t[lab], mu_t[lab]
    del lab
    cmat, its, conv, flds = _solve_elastic(lam, mu, spacing, tol, maxit, xp, rfftn, irfftn,
                                           k0 - 2.0 * g0 / 3.0, g0, scheme, fields)
    asym = float(np.abs(cmat - cmat.T).max() / max(np.abs(cmat).max(), 1e-300))
    out = Homogenized("elastic", tuple(labels.shape), its, conv, stiffness=0.5 * (cmat + cmat.T),
                      asymmetry=asym, reference={"bulk": k0, "shear": g0})
    return out, flds


def _homogenize_conductivity(labels, mats, phi, spacing, tol, maxit, dtype, xp, rfftn, irfftn, scheme, fields):
    """The conductivity :class:`Homogenized` of a label image (``phi`` as for
    :func:`_homogenize_elastic`) and its fields."""
    lab = xp.asarray(labels.astype(np.intp))
    k0 = _reference(mats)
    if phi is not None and len(mats) > 1:
        kf = xp.asarray(_coated_conductivity(mats[0], mats[1], np.asarray(phi, dtype=np.float64),
                                             labels.ndim).astype(dtype))
    else:
        kf = xp.asarray(np.array(mats, dtype=dtype))[lab]
    del lab
    cmat, its, conv, flds = _solve_conductivity(kf, spacing, tol, maxit, xp, rfftn, irfftn, k0, scheme, fields)
    asym = float(np.abs(cmat - cmat.T).max() / max(np.abs(cmat).max(), 1e-300))
    out = Homogenized("conductivity", tuple(labels.shape), its, conv, conductivity=0.5 * (cmat + cmat.T),
                      asymmetry=asym, reference={"conductivity": k0})
    return out, flds
