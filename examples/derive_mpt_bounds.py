"""Symbolic derivation of the three-point shear bounds used by ``three_point_bounds``.

Needs sympy (not a polypack dependency: ``pip install sympy``); about a minute.

``polypack.mechanics._threepoint_bounds`` evaluates the trial-field energies of the
classical variational principles (fields ``ε̄ − Γ0 ∗ [(χ2 − φ2)T]`` and
``σ̄ − Δ0 ∗ [(χ2 − φ2)T]``) with exact Gauss rules on the sphere. Their coefficients
are quadratic polynomials in the reference parameter ``s = 1/(2(1 − ν0))``: this
script reads them at three values of ``s``, rebuilds them as exact rationals, forms
the minimum over ``T`` of each energy symbolically, solves the stationarity
condition in ``s`` (linear) and checks that the optimum is ``Ξ`` (lower, the
Milton-Phan-Thien lower bound) and ``Θ`` (upper) of
:func:`polypack.mechanics.effective.mpt_shear_parameters`, identically in the phase
moduli, φ2, ζ2 and η2.

Usage: ``python examples/derive_mpt_bounds.py``
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import sympy as sp

from polypack.mechanics._threepoint_bounds import _coefficients

S = sp.Symbol("s")
K1, G1, K2, G2, PHI, ZETA, ETA = sp.symbols("K1 G1 K2 G2 phi zeta eta", positive=True)


def quadratic_coefficients(complementary):
    """Shear-mode coefficients (p, q_KJ, q_KK, m2_KJ, m2_KK, m4_KJ, m4_KK) as exact quadratics in s."""
    nodes = np.array([0.3, 0.6, 0.9])
    vander = np.vander(nodes, 3, increasing=True)
    vals = []
    for s in nodes:
        p, q, m2, m4 = _coefficients(float(s), complementary)
        vals.append([p[1], q[1, 0], q[1, 1], m2[1, 0], m2[1, 1], m4[1, 0], m4[1, 1]])
    coef = np.linalg.solve(vander, np.array(vals))
    polys = []
    for col in coef.T:
        terms = [sp.Rational(str(Fraction(float(c)).limit_denominator(5000))) for c in col]
        poly = sum(t * S**i for i, t in enumerate(terms))
        # the rationals must reproduce the numbers (they are exact: denominators 7, 9, 25, 45, 175)
        assert max(abs(float(poly.subs(S, x)) - v) for x, v in zip(nodes, np.array(vals)[:, len(polys)])) < 1e-12
        polys.append(poly)
    return polys


def optimum(complementary):
    """The bound at the stationary reference, as a rational function of the phase data."""
    p, q_kj, q_kk, m2_kj, m2_kk, m4_kj, m4_kk = quadratic_coefficients(complementary)
    phi1 = 1 - PHI
    if complementary:
        a1j, a1k, a2j, a2k = 1 / (3 * K1), 1 / (2 * G1), 1 / (3 * K2), 1 / (2 * G2)
    else:
        a1j, a1k, a2j, a2k = 3 * K1, 2 * G1, 3 * K2, 2 * G2
    dj, dk = a2j - a1j, a2k - a1k
    i2 = 2 * phi1 * PHI * ZETA / 9
    i4 = 7 * phi1 * PHI * (ETA - sp.Rational(5, 21) * ZETA) / 150
    mm = (phi1 * PHI * (q_kj * a1j + q_kk * a1k) + PHI * phi1**2 * p**2 * dk
          + sp.Rational(5, 2) * i2 * (m2_kj * dj + m2_kk * dk) + sp.Rational(9, 2) * i4 * (m4_kj * dj + m4_kk * dk))
    b = phi1 * PHI * p * dk
    mean = a1k + PHI * dk
    stationarity = sp.expand(2 * sp.diff(b, S) * mm - b * sp.diff(mm, S))
    assert sp.degree(stationarity, S) == 1
    (s_star,) = sp.solve(stationarity, S)
    energy = (mean - b**2 / mm).subs(S, s_star)
    modulus = 1 / (2 * energy) if complementary else energy / 2
    # back to the Hashin-Shtrikman-like parameter y of <G> - phi1 phi2 (G2 - G1)^2 / (<G~> + y)
    y = phi1 * PHI * (G2 - G1) ** 2 / ((phi1 * G1 + PHI * G2) - modulus) - (PHI * G1 + phi1 * G2)
    return sp.factor(s_star), sp.simplify(y)


def main():
    z = lambda a1, a2: (1 - ZETA) * a1 + ZETA * a2  # noqa: E731
    e = lambda a1, a2: (1 - ETA) * a1 + ETA * a2  # noqa: E731
    xi = (z(128 / K1 + 99 / G1, 128 / K2 + 99 / G2) + 45 * e(1 / G1, 1 / G2)) / (
        30 * z(1 / G1, 1 / G2) * z(6 / K1 - 1 / G1, 6 / K2 - 1 / G2)
        + 6 * e(1 / G1, 1 / G2) * z(2 / K1 + 21 / G1, 2 / K2 + 21 / G2))
    theta = (3 * e(G1, G2) * (6 * z(K1, K2) + 7 * z(G1, G2)) - 5 * z(G1, G2) ** 2) / (
        6 * (2 * z(K1, K2) - z(G1, G2)) + 30 * e(G1, G2))
    for name, comp, target in (("upper", False, theta), ("lower", True, xi)):
        s_star, y = optimum(comp)
        print(f"{name}: s* = {s_star}")
        print(f"{name}: y - closed form = {sp.simplify(y - target)}")


if __name__ == "__main__":
    main()
