"""Effective elastic moduli of particulate composites: classical estimates and bounds.

Pure functions of the phases' moduli and the microstructure's statistics (volume
fractions, the three-point parameters ζ2 and η2, radial distribution functions).
Isotropic phases, spherical inclusions, statistically isotropic composites.

Section 4 of 000_2cedc098acbd866b.txt (the micromechanics that turns the packs' RDFs
into effective moduli, its Figs. 8-9) is missing from the seed's text; this module
rebuilds it from the literature cited below.

Every estimate for spheres can be written in the Hashin-Shtrikman/Walpole form with a
reference shear ``z``::

    Λ(z) = ⟨1/(K + 4z/3)⟩⁻¹ − 4z/3,      Γ(z) = ⟨1/(G + z)⟩⁻¹ − z,
    ζ(K, G) = G (9K + 8G) / (6 (K + 2G)),

where ⟨·⟩ is the volume average over phases. Mori-Tanaka is ``(Λ(G0), Γ(ζ(K0, G0)))``
with the matrix as reference, the Hashin-Shtrikman bounds take the extreme bulk and
shear moduli *separately* (Walpole's form, valid when the phases are not well
ordered), the self-consistent estimate is the fixed point ``K* = Λ(G*)``,
``G* = Γ(ζ(K*, G*))``. The forms handle rigid (``inf``) and incompressible phases and
voids (zero moduli) by their limits.

References
----------
.. [1] Z. Hashin, S. Shtrikman, J. Mech. Phys. Solids 11, 127 (1963).
.. [2] L. J. Walpole, J. Mech. Phys. Solids 14, 151 (1966).
.. [3] J. G. Berryman, J. Acoust. Soc. Am. 68, 1809 (1980) (self-consistent form).
.. [4] T. Mori, K. Tanaka, Acta Metall. 21, 571 (1973); Y. Benveniste,
       Mech. Mater. 6, 147 (1987) (several inclusion families).
.. [5] S. Torquato, *Random Heterogeneous Materials*, Springer (2002), ch. 21-23
       (three-point bounds in terms of ζ2, η2).
.. [6] G. W. Milton, J. Mech. Phys. Solids 30, 177 (1982); G. W. Milton,
       N. Phan-Thien, Proc. R. Soc. Lond. A 380, 305 (1982).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InfeasibleError, InvalidInputError

__all__ = [
    "Phase",
    "dilute",
    "mori_tanaka",
    "hashin_shtrikman",
    "self_consistent",
    "three_point_bounds",
    "mpt_shear_parameters",
    "zeta_reference",
]

_INF = math.inf


def _modulus(name, value):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name}={value!r} must be a number >= 0 (inf for rigid)") from None
    if math.isnan(v) or v < 0:
        raise InvalidInputError(f"{name}={value!r} must be >= 0 (0 for a void, inf for rigid)")
    return v


@dataclass(frozen=True)
class Phase:
    """An isotropic elastic phase (or an effective medium) by bulk and shear modulus.

    Parameters
    ----------
    bulk, shear : float
        Bulk modulus K and shear modulus G (any consistent unit), ``>= 0``;
        ``0`` for a void, ``inf`` for a rigid phase (``bulk=inf`` alone: incompressible).

    Attributes
    ----------
    young, poisson : float
        ``E = 9KG/(3K + G)``, ``ν = (3K − 2G)/(2(3K + G))`` (limits for infinite moduli).

    Raises
    ------
    InvalidInputError
        On negative or NaN moduli.
    """

    bulk: float
    shear: float

    def __post_init__(self):
        object.__setattr__(self, "bulk", _modulus("bulk", self.bulk))
        object.__setattr__(self, "shear", _modulus("shear", self.shear))

    @classmethod
    def from_young(cls, young, poisson):
        """Phase from Young's modulus ``E >= 0`` and Poisson's ratio ``-1 < ν <= 0.5``.

        ``ν = 0.5`` gives an incompressible phase (``bulk = inf``).
        """
        e = _modulus("young", young)
        try:
            nu = float(poisson)
        except (TypeError, ValueError):
            raise InvalidInputError(f"poisson={poisson!r} must be a number in (-1, 0.5]") from None
        if not (-1.0 < nu <= 0.5):
            raise InvalidInputError(f"poisson={poisson!r} must lie in (-1, 0.5] for a stable isotropic solid")
        shear = e / (2.0 * (1.0 + nu))
        bulk = _INF if nu == 0.5 else e / (3.0 * (1.0 - 2.0 * nu))
        if e == 0.0:
            bulk = 0.0 if nu < 0.5 else _INF
        return cls(bulk=bulk, shear=shear)

    @property
    def young(self) -> float:
        k, g = self.bulk, self.shear
        if math.isinf(k) and math.isinf(g):
            return _INF
        if math.isinf(k):
            return 3.0 * g
        if math.isinf(g):
            return 9.0 * k
        if 3 * k + g == 0:
            return 0.0
        return 9.0 * k * g / (3.0 * k + g)

    @property
    def poisson(self) -> float:
        k, g = self.bulk, self.shear
        if math.isinf(k) and math.isinf(g):
            return math.nan
        if math.isinf(k):
            return 0.5
        if math.isinf(g):
            return -1.0
        if 3 * k + g == 0:
            return math.nan
        return (3.0 * k - 2.0 * g) / (2.0 * (3.0 * k + g))

    def to_dict(self):
        return {"bulk": self.bulk, "shear": self.shear, "young": self.young, "poisson": self.poisson}


def _as_phase(p, what="phase"):
    if isinstance(p, Phase):
        return p
    raise InvalidInputError(
        f"{what} must be a polypack.mechanics.Phase, got {type(p).__name__}; "
        "use Phase(bulk=..., shear=...) or Phase.from_young(E, nu)"
    )


def _as_phases(phases, what="inclusions"):
    if isinstance(phases, Phase):
        return [phases]
    if not isinstance(phases, Sequence) or len(phases) == 0:
        raise InvalidInputError(f"{what} must be a Phase or a non-empty list of Phases")
    return [_as_phase(p, what) for p in phases]


def _fractions(fractions, n, what, total=None):
    f = np.atleast_1d(np.asarray(fractions, dtype=np.float64))
    if f.ndim != 1 or f.size != n:
        raise InvalidInputError(f"{what} has {f.size} entries but there are {n} phases; give one per phase")
    if not np.all(np.isfinite(f)) or np.any(f < 0):
        raise InvalidInputError(f"{what}={f.tolist()} must be finite and >= 0")
    s = float(f.sum())
    if total is None:
        if s > 1.0 + 1e-9:
            raise InvalidInputError(f"{what}={f.tolist()} sum to {s:.6g} > 1; inclusion fractions must sum to <= 1")
    elif abs(s - total) > 1e-9:
        raise InvalidInputError(f"{what}={f.tolist()} sum to {s:.12g}; volume fractions must sum to {total}")
    return f


def zeta_reference(bulk, shear):
    """``ζ(K, G) = G (9K + 8G) / (6 (K + 2G))``, the Hashin-Shtrikman shear reference.

    Limits: ``1.5 G`` for ``K = inf``; ``inf`` for ``G = inf``; ``0`` for ``G = 0``.
    """
    k, g = float(bulk), float(shear)
    if math.isinf(g):
        return _INF
    if g == 0.0:
        return 0.0
    if math.isinf(k):
        return 1.5 * g
    return g * (9.0 * k + 8.0 * g) / (6.0 * (k + 2.0 * g))


def _inv(x):
    return 0.0 if math.isinf(x) else (_INF if x == 0.0 else 1.0 / x)


def _hs_form(moduli, c, b):
    """``⟨1/(M + b)⟩⁻¹ − b`` with limits (``b`` may be 0 or inf)."""
    if math.isinf(b):
        return float(np.dot(c, moduli)) if np.all(np.isfinite(moduli)) else _INF
    s = 0.0
    for m, ci in zip(moduli, c):
        if ci == 0.0:
            continue
        s += ci * _inv(m + b)
    if math.isinf(s):
        return 0.0
    return _inv(s) - b


def _lam(z, bulks, c):
    """Walpole's bulk function ``Λ(z)``."""
    return _hs_form(bulks, c, 4.0 * z / 3.0)


def _gam(z, shears, c):
    """Walpole's shear function ``Γ(z)``."""
    return _hs_form(shears, c, z)


def _all(matrix, inclusions, fractions):
    m = _as_phase(matrix, "matrix")
    inc = _as_phases(inclusions)
    f = _fractions(fractions, len(inc), "fractions")
    c = np.concatenate([[1.0 - f.sum()], f])
    c[0] = max(c[0], 0.0)
    phases = [m] + inc
    return m, phases, c


def mori_tanaka(matrix, inclusions, fractions):
    """Mori-Tanaka estimate for spheres of one or more families in a matrix.

    Benveniste's form for several families (each family's strain concentration is the
    dilute Eshelby one, applied to the mean matrix strain). For spheres it equals the
    Hashin-Shtrikman form with the matrix as reference medium:
    ``K = Λ(G0)``, ``G = Γ(ζ(K0, G0))``. Mori-Tanaka does not depend on the spatial
    arrangement (RDF) of the spheres.

    Parameters
    ----------
    matrix : Phase
    inclusions : Phase or sequence of Phase
    fractions : float or sequence of float
        Volume fraction of each inclusion family; they sum to ``<= 1``.

    Returns
    -------
    Phase
        The effective medium (``.bulk .shear .young .poisson``).

    References
    ----------
    .. [1] T. Mori, K. Tanaka, Acta Metall. 21, 571 (1973).
    .. [2] Y. Benveniste, Mech. Mater. 6, 147 (1987).
    """
    m, phases, c = _all(matrix, inclusions, fractions)
    if m.shear == 0.0:
        raise InvalidInputError("matrix shear=0: Mori-Tanaka needs a matrix that carries shear")
    bulks = np.array([p.bulk for p in phases])
    shears = np.array([p.shear for p in phases])
    return Phase(bulk=_lam(m.shear, bulks, c), shear=_gam(zeta_reference(m.bulk, m.shear), shears, c))


def dilute(matrix, inclusions, fractions):
    """Dilute (non-interacting Eshelby) estimate, first order in the fractions.

    ``K = K0 + Σ c_r (K_r − K0)(K0 + 4G0/3)/(K_r + 4G0/3)`` and likewise for ``G`` with
    ``ζ0 = ζ(K0, G0)``; for rigid spheres in an incompressible matrix
    ``G/G0 = 1 + 2.5 c`` (Einstein).

    Parameters, Returns: as :func:`mori_tanaka`.

    References
    ----------
    .. [1] J. D. Eshelby, Proc. R. Soc. Lond. A 241, 376 (1957).
    """
    m, phases, c = _all(matrix, inclusions, fractions)
    if m.shear == 0.0:
        raise InvalidInputError("matrix shear=0: the dilute estimate needs a matrix that carries shear")
    b = 4.0 * m.shear / 3.0
    z = zeta_reference(m.bulk, m.shear)
    k, g = m.bulk, m.shear
    for p, ci in zip(phases[1:], c[1:]):
        # (M_r - M0)(M0 + b)/(M_r + b) = (M0 + b)(1 - (M0 + b)/(M_r + b)), finite for M_r = inf
        if not math.isinf(m.bulk):
            k += ci * (m.bulk + b) * (1.0 - (m.bulk + b) * _inv(p.bulk + b))
        g += ci * (m.shear + z) * (1.0 - (m.shear + z) * _inv(p.shear + z))
    return Phase(bulk=k, shear=g)


def hashin_shtrikman(phases, fractions):
    """Hashin-Shtrikman bounds in Walpole's general form, any number of phases.

    ``K± = Λ(G_max/min)``, ``G± = Γ(ζ(K_max/min, G_max/min))`` with the extreme bulk and
    shear moduli taken separately over the phases; these are the bounds also when the
    phases are not well ordered (stiffest in bulk is not stiffest in shear).

    Parameters
    ----------
    phases : sequence of Phase
    fractions : sequence of float
        Volume fraction of each phase; must sum to 1.

    Returns
    -------
    lower, upper : Phase

    References
    ----------
    .. [1] Z. Hashin, S. Shtrikman, J. Mech. Phys. Solids 11, 127 (1963).
    .. [2] L. J. Walpole, J. Mech. Phys. Solids 14, 151 (1966).
    """
    ph = _as_phases(phases, "phases")
    c = _fractions(fractions, len(ph), "fractions", total=1.0)
    bulks = np.array([p.bulk for p in ph])
    shears = np.array([p.shear for p in ph])
    present = c > 0
    kmin, kmax = bulks[present].min(), bulks[present].max()
    gmin, gmax = shears[present].min(), shears[present].max()
    lower = Phase(bulk=_lam(gmin, bulks, c), shear=_gam(zeta_reference(kmin, gmin), shears, c))
    upper = Phase(bulk=_lam(gmax, bulks, c), shear=_gam(zeta_reference(kmax, gmax), shears, c))
    return lower, upper


def self_consistent(matrix, inclusions, fractions, tol=1e-12, max_iter=100000):
    """Self-consistent (Hill-Budiansky) estimate for spheres.

    The fixed point ``K* = Λ(G*)``, ``G* = Γ(ζ(K*, G*))``, i.e. each phase is a sphere
    embedded in the effective medium (Berryman's form). The matrix plays no special
    role. Voids above ``c = 0.5`` give zero moduli and rigid spheres above ``c = 0.4``
    infinite ones (the estimate's percolation thresholds).

    Parameters, Returns: as :func:`mori_tanaka`; ``tol`` is the relative change of the
    fixed-point iteration at convergence.

    Raises
    ------
    InfeasibleError
        If the iteration does not converge in ``max_iter`` steps.

    References
    ----------
    .. [1] R. Hill, J. Mech. Phys. Solids 13, 213 (1965); B. Budiansky, ibid. 13, 223 (1965).
    .. [2] J. G. Berryman, J. Acoust. Soc. Am. 68, 1809 (1980).
    """
    m, phases, c = _all(matrix, inclusions, fractions)
    bulks = np.array([p.bulk for p in phases])
    shears = np.array([p.shear for p in phases])
    lo, hi = hashin_shtrikman(phases, c)
    if math.isinf(hi.shear):
        # rigid phase present: iterate on compliances' scale by starting from the lower bound
        k, g = lo.bulk, lo.shear
    else:
        k, g = 0.5 * (lo.bulk + hi.bulk), 0.5 * (lo.shear + hi.shear)
    for _ in range(max_iter):
        k_new = _lam(g, bulks, c)
        g_new = _gam(zeta_reference(k, g), shears, c)
        if math.isinf(g_new) or g_new > 1e300:
            return Phase(bulk=_INF, shear=_INF)
        if g_new == 0.0 and (k_new == 0.0 or g == 0.0):
            return Phase(bulk=k_new, shear=0.0)
        dk = abs(k_new - k) / max(abs(k_new), 1e-300) if not math.isinf(k_new) else 0.0
        dg = abs(g_new - g) / max(abs(g_new), 1e-300)
        k, g = k_new, g_new
        if dk < tol and dg < tol:
            return Phase(bulk=k, shear=g)
        if g < 1e-14 * max(p.shear for p in phases if not math.isinf(p.shear)):
            return Phase(bulk=_lam(0.0, bulks, c), shear=0.0)
    raise InfeasibleError(f"self-consistent iteration did not converge in {max_iter} steps (K={k:g}, G={g:g})")


def _wavg(a1, a2, w2):
    """``(1 − w2) a1 + w2 a2`` with the convention ``0 · inf = 0``."""
    out = 0.0
    if w2 < 1.0:
        out += (1.0 - w2) * a1
    if w2 > 0.0:
        out += w2 * a2
    return out


def mpt_shear_parameters(matrix, inclusion, zeta2, eta2):
    """The ``(Ξ, Θ)`` of the three-point shear bounds (lower, upper).

    With ``⟨b⟩_ζ = ζ1 b1 + ζ2 b2`` and ``⟨b⟩_η = η1 b1 + η2 b2`` (``ζ1 = 1 − ζ2``,
    ``η1 = 1 − η2``; phase 1 the matrix)::

        Ξ = [⟨128/K + 99/G⟩_ζ + 45⟨1/G⟩_η]
            / [30⟨1/G⟩_ζ⟨6/K − 1/G⟩_ζ + 6⟨1/G⟩_η⟨2/K + 21/G⟩_ζ],
        Θ = [3⟨G⟩_η⟨6K + 7G⟩_ζ − 5⟨G⟩_ζ²] / [6⟨2K − G⟩_ζ + 30⟨G⟩_η],

    which enter ``G = ⟨G⟩ − φ1φ2(G2 − G1)²/(⟨G̃⟩ + y)`` as ``y = Ξ`` (lower) and
    ``y = Θ`` (upper). Both reduce to ``ζ(K, G) = G(9K + 8G)/(6(K + 2G))`` of the
    matrix at ``ζ2 = η2 = 0`` and of the inclusions at ``ζ2 = η2 = 1`` (the
    Hashin-Shtrikman values). See :func:`three_point_bounds`.
    """
    p1, p2 = _as_phase(matrix, "matrix"), _as_phase(inclusion, "inclusion")
    z2, e2 = float(zeta2), float(eta2)
    k1, g1, k2, g2 = p1.bulk, p1.shear, p2.bulk, p2.shear

    def z(a1, a2):
        return _wavg(a1, a2, z2)

    def e(a1, a2):
        return _wavg(a1, a2, e2)

    ig_z, ig_e = z(1 / g1, 1 / g2), e(1 / g1, 1 / g2)
    xi_num = z(128 / k1 + 99 / g1, 128 / k2 + 99 / g2) + 45 * ig_e
    xi_den = 30 * ig_z * z(6 / k1 - 1 / g1, 6 / k2 - 1 / g2) + 6 * ig_e * z(2 / k1 + 21 / g1, 2 / k2 + 21 / g2)
    kz, gz, ge = z(k1, k2), z(g1, g2), e(g1, g2)
    th_num = 3 * ge * (6 * kz + 7 * gz) - 5 * gz * gz
    th_den = 6 * (2 * kz - gz) + 30 * ge
    xi = xi_num / xi_den if xi_den != 0.0 else math.inf
    theta = th_num / th_den if th_den != 0.0 else math.inf
    return xi, theta


def three_point_bounds(matrix, inclusion, fraction, zeta2, eta2):
    """Three-point bounds of a two-phase composite from ζ2 and η2.

    Phase 1 is the matrix (fraction ``φ1 = 1 − φ2``), phase 2 the inclusions. With
    ``⟨b⟩ = φ1 b1 + φ2 b2``, ``⟨b̃⟩ = φ2 b1 + φ1 b2`` and ``⟨b⟩_ζ = ζ1 b1 + ζ2 b2``
    (``ζ1 = 1 − ζ2``) the bulk bounds (Beran-Molyneux, in Milton's simplified form) are

    ``K = ⟨K⟩ − φ1 φ2 (K2 − K1)² / (⟨K̃⟩ + y)`` with ``y = 4⟨G⟩_ζ/3`` (upper) and
    ``y = 4/(3⟨1/G⟩_ζ)`` (lower).

    They reduce to the Hashin-Shtrikman bounds at ``ζ2 = 0`` and ``1`` and are exact to
    second order in the phase contrast.

    **Shear** (Milton-Phan-Thien): ``G = ⟨G⟩ − φ1φ2(G2 − G1)²/(⟨G̃⟩ + y)`` with
    ``y = Ξ`` (lower) and ``y = Θ`` (upper),

    ``Ξ = [⟨128/K + 99/G⟩_ζ + 45⟨1/G⟩_η] / [30⟨1/G⟩_ζ⟨6/K − 1/G⟩_ζ + 6⟨1/G⟩_η⟨2/K + 21/G⟩_ζ]``,

    ``Θ = [3⟨G⟩_η⟨6K + 7G⟩_ζ − 5⟨G⟩_ζ²] / [6⟨2K − G⟩_ζ + 30⟨G⟩_η]``

    (``⟨b⟩_η = η1 b1 + η2 b2``; :func:`mpt_shear_parameters`). These are the optimal
    bounds of the classical variational principles with the trial fields
    ``ε̄ − Γ0 ∗ [(χ2 − φ2) T]`` (upper) and ``σ̄ − Δ0 ∗ [(χ2 − φ2) T]`` (lower), Γ0
    and Δ0 the strain and stress Green operators of an isotropic reference medium, χ2
    the inclusions' indicator, ``T`` a constant tensor: the trial energies are exact
    functionals of φ2, ζ2, η2 for statistically isotropic media, and their minima over
    ``T`` and over the reference medium are the closed forms above
    (:mod:`polypack.mechanics._threepoint_bounds` derives them and checks them
    numerically; the same construction for a bulk load gives the Beran-Molyneux
    bounds). Ξ is identical (symbolically) to the Milton-Phan-Thien lower bound in the
    form quoted from Torquato (2002); Θ is the upper bound of the same construction,
    which as far as we recall is also the compact form of Berryman (1995). Neither
    text could be consulted here, so Θ rests on the derivation and its checks. A
    form recalled earlier in this project,
    ``[10⟨G⟩_ζ²⟨K⟩_ζ + 5⟨G⟩_ζ⟨2K + 3G⟩_ζ⟨G⟩_η + ⟨3K + G⟩_ζ²⟨G⟩_η]/(6⟨K + 2G⟩_ζ²)``,
    is *not* a bound: with ``G2 = G1(1 + δ)``, ``K2 = K1(1 + κδ)`` its first-order
    term in δ exceeds Ξ's by ``5G1²(2K1 + 3G1)(η2 − ζ2)δ/(6(K1 + 2G1)²)``, so the two
    differ at order δ³ in G, whereas every bound valid for both signs of the contrast
    must match the exact expansion through third order; it falls below the lower
    bound for weakly contrasting soft inclusions (tests).
    Both bounds reduce to HS at ``ζ2 = η2 = 0`` and ``1``, lie inside HS, are invariant
    under relabelling the phases and agree with each other to third order in the
    contrast. For ``(ζ2, η2)`` far from those of dispersions (e.g. ``ζ2 = 0.5,
    η2 = 0``) they cross, which proves that no microstructure has them
    (``InfeasibleError``; packs of spheres have ``η2 ≈ 2.3 ζ2``), as does a bound beyond
    the opposite HS bound; where one is merely weaker than HS (also only far from
    dispersions) the HS bound is returned instead.

    Parameters
    ----------
    matrix, inclusion : Phase
    fraction : float
        Inclusion volume fraction φ2 in [0, 1].
    zeta2, eta2 : float
        Three-point parameters in [0, 1] (see :class:`polypack.analysis.ThreePointParameters`).

    Returns
    -------
    lower, upper : Phase

    Raises
    ------
    InvalidInputError
        On fractions or parameters outside [0, 1], or infinite or zero phase moduli.
    InfeasibleError
        If the shear bounds cross or leave the Hashin-Shtrikman interval (``(ζ2, η2)``
        not realizable).

    References
    ----------
    .. [1] M. J. Beran, J. Molyneux, Q. Appl. Math. 24, 107 (1966).
    .. [2] G. W. Milton, J. Mech. Phys. Solids 30, 177 (1982).
    .. [3] S. Torquato, *Random Heterogeneous Materials*, Springer (2002), ch. 21-23.
    .. [4] N. A. McCoy, in *Recent Advances in Engineering Science* 5, 235 (1970);
           G. W. Milton, N. Phan-Thien, Proc. R. Soc. Lond. A 380, 305 (1982).
    .. [5] Z. Hashin, S. Shtrikman, J. Mech. Phys. Solids 11, 127 (1963) (variational
           principles with Green operators).
    .. [6] J. G. Berryman, "Mixture theories for rock properties", in *Rock Physics
           and Phase Relations*, AGU Reference Shelf 3, 205 (1995) (compact forms of
           the three-point bounds with ζ and η averages).
    """
    p1, p2 = _as_phase(matrix, "matrix"), _as_phase(inclusion, "inclusion")
    phi2 = float(fraction)
    if not (0.0 <= phi2 <= 1.0):
        raise InvalidInputError(f"fraction={fraction!r} must lie in [0, 1]")
    z2, e2 = float(zeta2), float(eta2)
    for name, v in (("zeta2", z2), ("eta2", e2)):
        if not (0.0 <= v <= 1.0):
            raise InvalidInputError(f"{name}={v!r} must lie in [0, 1]")
    for p, name in ((p1, "matrix"), (p2, "inclusion")):
        if math.isinf(p.bulk) or math.isinf(p.shear) or p.bulk == 0.0 or p.shear == 0.0:
            raise InvalidInputError(
                f"{name} moduli (K={p.bulk:g}, G={p.shear:g}): three-point bounds need finite, "
                "non-zero moduli; use a large/small finite value for rigid phases or voids"
            )
    phi1 = 1.0 - phi2

    def form(m1, m2, y):
        mean = phi1 * m1 + phi2 * m2
        tilde = phi2 * m1 + phi1 * m2
        if phi1 * phi2 == 0.0:
            return mean
        return mean - phi1 * phi2 * (m2 - m1) ** 2 / (tilde + y)

    k1, k2 = p1.bulk, p2.bulk
    gz = _wavg(p1.shear, p2.shear, z2)
    igz = _wavg(1 / p1.shear, 1 / p2.shear, z2)
    k_up = form(k1, k2, 4.0 * gz / 3.0)
    k_lo = form(k1, k2, 4.0 / (3.0 * igz))
    if phi1 * phi2 == 0.0:
        g = phi1 * p1.shear + phi2 * p2.shear
        return Phase(bulk=k_lo, shear=g), Phase(bulk=k_up, shear=g)
    xi, theta = mpt_shear_parameters(p1, p2, z2, e2)
    g1, g2 = p1.shear, p2.shear
    g_lo, g_up = form(g1, g2, xi), form(g1, g2, theta)
    g_tilde = phi2 * g1 + phi1 * g2
    if not (g_tilde + xi > 0.0 and g_tilde + theta > 0.0):
        raise InfeasibleError(
            f"zeta2={z2:g}, eta2={e2:g} at fraction {phi2:g}: the three-point shear bounds are undefined "
            f"(Xi={xi:.6g}, Theta={theta:.6g}), so no microstructure has these parameters"
        )
    hs_lo, hs_up = hashin_shtrikman([p1, p2], [phi1, phi2])
    if g_lo > g_up * (1.0 + 1e-9):
        raise InfeasibleError(
            f"zeta2={z2:g}, eta2={e2:g} at fraction {phi2:g}: the three-point shear bounds cross "
            f"(lower {g_lo:.6g} > upper {g_up:.6g}), so no microstructure has these parameters"
        )
    if g_lo > hs_up.shear * (1.0 + 1e-9) or g_up < hs_lo.shear * (1.0 - 1e-9):
        raise InfeasibleError(
            f"zeta2={z2:g}, eta2={e2:g} at fraction {phi2:g}: a three-point shear bound (lower {g_lo:.6g}, "
            f"upper {g_up:.6g}) lies beyond the Hashin-Shtrikman bounds ({hs_lo.shear:.6g}, {hs_up.shear:.6g}), "
            "so no microstructure has these parameters"
        )
    # far from the parameters of dispersions a three-point bound can be weaker than HS; the
    # tighter of two rigorous bounds is returned
    g_lo, g_up = max(g_lo, hs_lo.shear), min(g_up, hs_up.shear)
    return Phase(bulk=k_lo, shear=g_lo), Phase(bulk=k_up, shear=g_up)
