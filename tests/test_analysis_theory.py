"""Theory: PY g(r) vs exact PY results, CS, Willis/Kanaun forms, mixtures, Eq. (17), peaks."""

import numpy as np
import pytest

from polypack.analysis import theory as th
from polypack.errors import InvalidInputError


@pytest.mark.parametrize("eta", [0.1, 0.25, 0.4, 0.49])
def test_percus_yevick_rdf_contact_sum_rule_and_tail(eta):
    a = 0.5  # diameter 1
    r = np.linspace(0.0, 30.0, 30001)
    g = th.percus_yevick_rdf(r, a, eta)
    assert np.all(g[r < 1.0] == 0)
    # contact value of the PY solution, computed here through the OZ inversion
    assert g[r >= 1.0][0] == pytest.approx(th.percus_yevick_contact(eta), rel=1e-5)
    # compressibility route: 1 + rho int (g - 1) dV = S(0) = (1 - eta)^4 / (1 + 2 eta)^2
    rho = 6 * eta / np.pi
    out = r >= 1.0  # the core contributes -4 pi / 3 exactly; integrate the rest from contact
    s0 = 1 + rho * (-4 * np.pi / 3 + np.trapezoid(4 * np.pi * r[out] ** 2 * (g[out] - 1), r[out]))
    assert s0 == pytest.approx((1 - eta) ** 4 / (1 + 2 * eta) ** 2, abs=2e-3)
    assert np.max(np.abs(g[r > 10] - 1)) < 2e-3
    # PY underestimates the (nearly exact) Carnahan-Starling contact value
    cs = th.carnahan_starling_contact(eta)
    assert th.percus_yevick_contact(eta) <= cs and th.percus_yevick_contact(eta) > 0.8 * cs


def test_percus_yevick_first_minimum_and_second_peak_dense():
    r = np.linspace(1.0, 3.0, 2001)
    g = th.percus_yevick_rdf(r, 0.5, 0.45)
    # PY has its first minimum near 1.5 sigma and a second peak near 2 sigma (R = 4, §5.1)
    rmin = r[np.argmin(g[r < 1.8])]
    assert 1.3 < rmin < 1.7
    second = r[(r > 1.7) & (r < 2.3)][np.argmax(g[(r > 1.7) & (r < 2.3)])]
    assert 1.85 < second < 2.1


def test_willis_and_kanaun_forms():
    a, c = 1.0, 0.575
    assert th.willis(2.0, a, c) == pytest.approx(th.percus_yevick_contact(c))
    assert th.willis(1.99, a, c) == 0
    assert th.willis(2.0, a, c, amplitude="willis") == pytest.approx(1 + 0.8006 * (8 * c - 1) / c)
    assert th.willis_g_r(2.0, a) == pytest.approx(1.0)
    assert th.kanaun_g_c(0.3, printed=True) == pytest.approx(2.3 / (2 * (1 - 0.09)) - 1)
    assert np.allclose(th.well_stirred([1.9, 2.0, 3.0], 1.0), [0, 1, 1])
    with pytest.raises(InvalidInputError, match="1/8"):
        th.willis_g_c(0.1)
    with pytest.raises(InvalidInputError, match="volume fraction"):
        th.percus_yevick_contact(1.2)


def test_mixture_contact_values():
    # identical species reproduce the one-component PY contact value
    g = th.percus_yevick_mixture_contact([1.0, 1.0], [0.2, 0.2])
    assert np.allclose(g, th.percus_yevick_contact(0.4))
    # Eq. (23) is the c2 -> 0 limit of Eqs. (21)-(22)
    for lam in (0.138, 0.313, 0.477):
        g = th.percus_yevick_mixture_contact([1.0, lam], [0.5, 1e-12])
        assert g[0, 1] == pytest.approx(th.percus_yevick_dilute_contact(0.5, lam), rel=1e-9)
    assert th.percus_yevick_dilute_contact(0.3, 1.0) == pytest.approx(th.percus_yevick_contact(0.3))
    # partial forms: contact at R_ij = 2 for every pair
    assert th.well_stirred_partial(1.0 + 0.3, 1.0, 0.3) == 1
    assert th.willis_partial(1.3, 1.0, 0.3, 2.5) == pytest.approx(2.5)
    assert th.willis_partial(1.29, 1.0, 0.3, 2.5) == 0


def test_extrapolation_eq17_is_consistent_with_willis():
    a = 1.0
    r = np.linspace(0, 8, 400)
    g1 = th.willis(r, a, 0.45)
    g2 = th.extrapolate_rdf(r, g1, a, 0.45, 0.6)
    assert np.allclose(g2, th.willis(r, a, 0.6))
    printed = th.extrapolate_rdf(r, g1, a, 0.45, 0.6, printed=True)
    assert not np.allclose(printed, th.willis(r, a, 0.6))


def test_eq17_printed_variant_by_hand():
    """Eq. (17) as printed: g(r, c2) - 1 = [g(r, c1) - 1] [g_c^W(c2) - 1] / [g_c^W(c1) - 1].
    Willis' amplitude 0.8006 (8c - 1)/c: c1 = 0.3 gives 0.8006 * 1.4 / 0.3 = 3.736133...,
    c2 = 0.5 gives 0.8006 * 3 / 0.5 = 4.8036, so the factor is 3.8036 / 2.736133... =
    1.390137...; the ratio form uses 4.8036 / 3.736133... = 1.285714... (= 9/7 exactly)."""
    r = np.array([1.9, 2.0, 2.5, 3.0])
    g = np.array([0.0, 2.2, 0.9, 1.1])
    printed = th.extrapolate_rdf(r, g, 1.0, 0.3, 0.5, amplitude="willis", printed=True)
    q = 3.8036 / (0.8006 * 1.4 / 0.3 - 1.0)
    assert q == pytest.approx(1.390137, abs=1e-6)
    np.testing.assert_allclose(printed, [0.0, 1 + 1.2 * q, 1 - 0.1 * q, 1 + 0.1 * q], rtol=1e-12)
    ratio = th.extrapolate_rdf(r, g, 1.0, 0.3, 0.5, amplitude="willis")
    np.testing.assert_allclose(ratio, [0.0, 1 + 1.2 * 9 / 7, 1 - 0.1 * 9 / 7, 1 + 0.1 * 9 / 7], rtol=1e-12)
    # Kanaun's amplitude (Percus-Yevick contact value minus 1): (1 + c/2)/(1 - c)^2 - 1
    # = 1.15 / 0.49 - 1 = 1.346939 at 0.3 and 1.25 / 0.25 - 1 = 4 at 0.5
    k = th.extrapolate_rdf(r, g, 1.0, 0.3, 0.5, printed=True)
    assert k[1] == pytest.approx(1 + 1.2 * 3.0 / (1.15 / 0.49 - 2.0), rel=1e-12)


def test_peak_positions():
    u = th.peak_positions_unimodal()
    assert u["second"] == pytest.approx(3.4641, abs=1e-4) and u["gap"] == pytest.approx(2.866, abs=1e-3)
    p = th.peak_positions_bimodal(1.0, 1.0)
    assert p["row_k"] == p["row_m"] == 4
    assert p["second_kkm"] == pytest.approx(2 * np.sqrt(3)) and p["second_kmm"] == pytest.approx(2 * np.sqrt(3))
    # seed §5.3: g_11 second peak R = 2.64 ~ 2 + 2 lambda for lambda = 0.313 (small sphere between)
    q = th.peak_positions_bimodal(1.0, 1.0, a_other=0.313)
    assert q["row_via_other"] == pytest.approx(2 + 2 * 0.313)
    assert th.peak_positions_bimodal(0.313, 1.0)["row_k"] == pytest.approx(2 * 1.313)


def test_plot():
    ax = th.plot(0.5, 0.4, measured=(np.linspace(0, 3, 50), np.ones(50)))
    assert len(ax.lines) == 4
    with pytest.raises(InvalidInputError, match="model"):
        th.plot(0.5, 0.4, models=("nope",))


@pytest.mark.parametrize("eta", [0.1, 0.3, 0.5])
def test_contact_values_satisfy_the_virial_equations_of_state(eta):
    # Z = 1 + 4 eta g(sigma+): Carnahan-Starling Z = (1 + eta + eta^2 - eta^3)/(1 - eta)^3,
    # Percus-Yevick virial route Z_v = (1 + 2 eta + 3 eta^2)/(1 - eta)^2
    z_cs = (1 + eta + eta**2 - eta**3) / (1 - eta) ** 3
    assert 1 + 4 * eta * th.carnahan_starling_contact(eta) == pytest.approx(z_cs, rel=1e-12)
    z_py = (1 + 2 * eta + 3 * eta**2) / (1 - eta) ** 2
    assert 1 + 4 * eta * th.percus_yevick_contact(eta) == pytest.approx(z_py, rel=1e-12)


def test_mixture_contact_values_match_lebowitz_in_diameters():
    # Lebowitz (1964) PY mixture, diameters s_i, xi_n = pi/6 sum rho_k s_k^n:
    # g_ij = 1/(1 - xi3) + 3 xi2 s_i s_j / ((s_i + s_j)(1 - xi3)^2)
    a = np.array([1.0, 0.313, 0.138])
    c = np.array([0.35, 0.15, 0.1])
    s = 2 * a
    rho = c / (np.pi / 6 * s**3)
    xi2, xi3 = np.pi / 6 * np.sum(rho * s**2), np.pi / 6 * np.sum(rho * s**3)
    ref = 1 / (1 - xi3) + 3 * xi2 * np.outer(s, s) / ((s[:, None] + s[None]) * (1 - xi3) ** 2)
    assert np.allclose(th.percus_yevick_mixture_contact(a, c), ref, rtol=1e-12)
