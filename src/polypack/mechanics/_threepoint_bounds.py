"""Three-point shear (and bulk) bounds from the classical variational principles.

The independent derivation behind :func:`polypack.mechanics.effective.three_point_bounds`,
kept as its numerical oracle (tests): ``three_point_bounds`` evaluates the closed
forms, this module evaluates the trial-field energies themselves and minimises them.

Upper bound (minimum potential energy). For a two-phase composite with phase-2
indicator χ, ``f = χ − φ2``, a reference isotropic medium ``L0`` with strain Green
operator Γ0 (Fourier symbol ``Γ̂(n)``, angular mean ``P`` = the Hill tensor of a
sphere, real-space kernel ``H(r̂)/r³`` away from the origin) and any constant
symmetric tensor ``T``, the field ``ε = ε̄ − Γ0 ∗ (f T)`` is compatible with mean
``ε̄``, so ``ε̄:L*:ε̄ ≤ ⟨ε:L:ε⟩``. For a statistically isotropic medium, exactly,

    ⟨ε:L:ε⟩ = ε̄:⟨L⟩:ε̄ − 2 φ1φ2 ε̄:δL:P:T + T:M:T,
    M = φ1φ2 ⟨Γ̂ L1 Γ̂⟩_n + φ2φ1² P δL P + (5/2) I2 M2(δL) + (9/2) I4 M4(δL),
    M_l(A) = ∫dΩ_r ∫dΩ_s H(r̂) A H(ŝ) P_l(r̂·ŝ),

with ``δL = L2 − L1`` and the three-point integrals
``I_l = ∫dr/r ∫ds/s ∫du P_l(u) [S3 − S2 S2/φ2]``, which are Torquato's parameters:
``I2 = 2 φ1φ2 ζ2/9`` and ``I4 = 7 φ1φ2 (η2 − 5ζ2/21)/150``
(:class:`polypack.analysis.ThreePointParameters`). The local part of Γ0 gives the
``P δL P`` term (``⟨χ f²⟩ = φ2 φ1²``), the two-point terms with one principal-value
kernel vanish by isotropy, and only the l = 2, 4 Legendre components of S3 survive
the angular integrals. Minimising over ``T`` gives ``ε̄:⟨L⟩:ε̄ − b:M⁻¹:b``.

Lower bound (minimum complementary energy): the same with compliances
``M_i = L_i⁻¹`` and the stress Green operator ``Δ0 = L0 − L0 Γ0 L0`` (symbol
``L0 − L0 Γ̂ L0``, kernel ``−L0 H L0``), whose fields are equilibrated with mean σ̄.

The reference medium. The result depends on L0 only through
``s = (λ0 + G0)/(λ0 + 2G0) = 1/(2(1 − ν0))`` (b ∝ 1/G0, M ∝ 1/G0²): ``Γ̂ = A − s B``
and ``H ∝ (4 − 2s) H1 + 2s H2`` are linear in ``s``, every coefficient of the energy
is a quadratic polynomial in ``s`` (for both principles), and the trial fields are
admissible for *every real* ``s`` (Γ0 ∗ τ is a strain and Δ0 ∗ τ a divergence-free
stress for any isotropic L0, positive or not), so ``s`` is a free parameter on the
whole real line, not only on the physical range ``ν0 ∈ (−1, 1/2)``. The stationarity
condition of ``b²/M`` in ``s`` is linear, with the roots

    upper:  s* = 2(3⟨K⟩_ζ + ⟨G⟩_ζ) / (6⟨K⟩_ζ + 9⟨G⟩_η − ⟨G⟩_ζ),
    lower:  s* = 16(⟨1/K⟩_ζ + 3⟨1/G⟩_ζ) / (64⟨1/K⟩_ζ + 21⟨1/G⟩_ζ + 27⟨1/G⟩_η),

(``⟨b⟩_ζ = ζ1 b1 + ζ2 b2``, ``⟨b⟩_η = η1 b1 + η2 b2``), and the energies there are the
closed forms used by ``three_point_bounds`` (``examples/derive_mpt_bounds.py`` derives
them with sympy from the coefficients below; the lower one is exactly Milton and
Phan-Thien's lower bound). Here the
energies are minimised numerically over a wide range of ``s`` instead, which is what
the tests compare with the closed forms.

Everything is isotropic, so each matrix reduces to its two eigenvalues on the bulk
(J) and deviatoric (K) projectors; the angular integrals are exact Gauss rules
(the integrands are polynomials of degree 8 on the sphere).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy.optimize import minimize_scalar

from .interaction import _J, _KDEV, _MANDEL_IDX, _MANDEL_W, _sphere_directions

_EYE = np.eye(3)
_IA = np.array([i for i, _ in _MANDEL_IDX])
_JA = np.array([j for _, j in _MANDEL_IDX])
_WW = np.outer(_MANDEL_W, _MANDEL_W)
_DIRS, _W = _sphere_directions(5)  # exact for degree <= 9 on the sphere
_U = _DIRS @ _DIRS.T
_PL = {l: (4.0 * np.pi) ** 2 * np.outer(_W, _W) * np.polynomial.legendre.Legendre.basis(l)(_U) for l in (2, 4)}
# reference parameter s = 1/(2(1 − ν0)) scanned well beyond the physical range (0.25, 1);
# s = 1 (an incompressible reference) is singular for the stress operator and skipped
_S_GRID = np.concatenate([np.linspace(-3.0, 0.98, 200), [0.99, 0.995, 0.999, 1.001, 1.005, 1.01], np.linspace(1.02, 4.0, 150)])


def _mandel_many(t):
    return t[:, _IA[:, None], _JA[:, None], _IA[None, :], _JA[None, :]] * _WW


@lru_cache(maxsize=1)
def _bases():
    """Direction-wise Mandel bases: Γ̂ = A − c B and H = (3 − 4ν0) H1 + H2 (times 1/(16π(1 − ν0)))."""
    n, d = _DIRS, _EYE
    a = (np.einsum("ik,aj,al->aijkl", d, n, n) + np.einsum("il,aj,ak->aijkl", d, n, n)
         + np.einsum("jk,ai,al->aijkl", d, n, n) + np.einsum("jl,ai,ak->aijkl", d, n, n)) / 4.0
    nnnn = np.einsum("ai,aj,ak,al->aijkl", n, n, n, n)
    nn = np.einsum("ai,aj->aij", n, n)
    h1 = np.einsum("ik,ajl->aijkl", d, 3.0 * nn - d[None])
    h2 = np.broadcast_to((np.einsum("il,jk->ijkl", d, d) + np.einsum("ij,kl->ijkl", d, d))[None], h1.shape).copy()
    h2 -= 3.0 * (np.einsum("il,akj->aijkl", d, nn) + np.einsum("kl,aij->aijkl", d, nn))
    h2 -= 3.0 * (np.einsum("ij,akl->aijkl", d, nn) + np.einsum("jk,ail->aijkl", d, nn) + np.einsum("jl,aik->aijkl", d, nn))
    h2 += 15.0 * nnnn

    def sym(t):
        t = 0.5 * (t + np.einsum("ajikl->aijkl", t))
        return 0.5 * (t + np.einsum("aijlk->aijkl", t))

    return _mandel_many(a), _mandel_many(nnnn), _mandel_many(sym(h1)), _mandel_many(sym(h2))


def _gamma_hat(s):
    """Mandel matrices of the strain Green operator symbol Γ̂(n) for G0 = 1, ``s = 1/(2(1 − ν0))``."""
    a, b, _, _ = _bases()
    return a - s * b  # (λ0 + G0)/(G0 (λ0 + 2 G0)) = s at G0 = 1


def _kernel(s):
    """Mandel matrices of H(n): Γ0(r) = H(r̂)/r³ for r ≠ 0 (strain −Γ0 ∗ τ), G0 = 1.

    ``((3 − 4ν0) H1 + H2)/(16π(1 − ν0))`` written with ``s = 1/(2(1 − ν0))``.
    """
    _, _, h1, h2 = _bases()
    return ((4.0 - 2.0 * s) * h1 + 2.0 * s * h2) / (16.0 * np.pi)


def _eig(m):
    """(J, K) eigenvalues of an isotropic Mandel matrix."""
    return float(np.trace(_J @ m)), float(np.trace(_KDEV @ m)) / 5.0


def _pair_form(pl, h, e):
    """``Σ_ab pl[a, b] h_aᵀ e h_b`` for (Q, 6, 6) ``h``."""
    y = (pl @ h.reshape(h.shape[0], 36)).reshape(h.shape)
    return np.einsum("aki,kl,alj->ij", h, e, y, optimize=True)


@lru_cache(maxsize=4096)
def _coefficients(s, complementary):
    """Phase-independent isotropic coefficients at reference parameter ``s = 1/(2(1 − ν0))`` (G0 = 1).

    Returns ``p`` (2,), ``q`` (2, 2) and ``m2``, ``m4`` (2, 2): ``p`` the eigenvalues of
    P, ``q[a, b]`` the ``a``-eigenvalue of ⟨Γ̂ E_b Γ̂⟩ for the projector ``E_b`` (J, K),
    ``m_l[a, b]`` likewise for M_l(E_b). With ``complementary`` the stress operator.
    """
    g = _gamma_hat(s)
    h = _kernel(s)
    if complementary:
        k0 = (1.0 - 2.0 * s) / (s - 1.0) + 2.0 / 3.0  # λ0 + 2G0/3 with λ0 = (1 − 2s)/(s − 1)
        l0 = 3.0 * k0 * _J + 2.0 * _KDEV
        g = l0[None] - l0[None] @ g @ l0[None]
        h = l0[None] @ h @ l0[None]
    p = np.array(_eig(np.einsum("a,aij->ij", _W, g)))
    q = np.empty((2, 2))
    m2 = np.empty((2, 2))
    m4 = np.empty((2, 2))
    wg = _W[:, None, None] * g
    for b, e in enumerate((_J, _KDEV)):
        q[:, b] = _eig(np.einsum("aki,kl,alj->ij", g, e, wg, optimize=True))
        m2[:, b] = _eig(_pair_form(_PL[2], h, e))
        m4[:, b] = _eig(_pair_form(_PL[4], h, e))
    return p, q, m2, m4


def _energy(s, a1, a2, phi2, i2, i4, mode, complementary):
    """Minimum over T of the trial energy per unit load in ``mode`` (0 bulk, 1 shear), in eigenvalues."""
    p, q, m2, m4 = _coefficients(float(s), complementary)
    phi1 = 1.0 - phi2
    da = a2 - a1
    mm = (phi1 * phi2 * (q @ a1) + phi2 * phi1**2 * p**2 * da + 2.5 * i2 * (m2 @ da) + 4.5 * i4 * (m4 @ da))[mode]
    b = phi1 * phi2 * p[mode] * da[mode]
    mean = a1[mode] + phi2 * da[mode]
    if mm <= 0.0:
        return math.inf
    return mean - b * b / mm


def variational_bound(phase1, phase2, phi2, zeta2, eta2, mode, kind):
    """Three-point bound on the bulk (``mode="bulk"``) or shear modulus, ``kind`` "upper"/"lower".

    ``phase1``, ``phase2`` are ``(K, G)`` pairs of finite positive moduli. Returns the
    modulus and the optimal reference parameter ``s = 1/(2(1 − ν0))`` (scanned on
    [−3, 4], then refined).
    """
    (k1, g1), (k2, g2) = phase1, phase2
    phi1 = 1.0 - phi2
    i2 = 2.0 * phi1 * phi2 * zeta2 / 9.0
    i4 = 7.0 * phi1 * phi2 * (eta2 - 5.0 * zeta2 / 21.0) / 150.0
    md = 0 if mode == "bulk" else 1
    comp = kind == "lower"
    if comp:  # compliance eigenvalues (Mandel): 1/(3K), 1/(2G)
        a1, a2 = np.array([1 / (3 * k1), 1 / (2 * g1)]), np.array([1 / (3 * k2), 1 / (2 * g2)])
    else:
        a1, a2 = np.array([3 * k1, 2 * g1]), np.array([3 * k2, 2 * g2])

    def f(s):
        return _energy(s, a1, a2, phi2, i2, i4, md, comp)

    vals = np.array([f(s) for s in _S_GRID])
    k = int(np.argmin(vals))
    lo = _S_GRID[max(k - 1, 0)]
    hi = _S_GRID[min(k + 1, len(_S_GRID) - 1)]
    best_s, best = float(_S_GRID[k]), float(vals[k])
    if hi > lo and not (lo < 1.0 < hi):
        r = minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": 1e-12})
        if r.fun < best:
            best_s, best = float(r.x), float(r.fun)
    # every s gives a valid bound: the minimum found is one (the tightest found)
    scale = 3.0 if md == 0 else 2.0
    value = 1.0 / (scale * best) if comp else best / scale
    return value, best_s
