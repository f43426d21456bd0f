"""DLVO pair potential: formulas, limits, and the statements of §2.2 of seed 003."""

from __future__ import annotations

import math

import numpy as np
import pytest

import polypack as pp
from polypack.errors import InvalidInputError
from polypack.generate import dlvo

KB = 1.380649e-23


def test_defaults_reproduce_seed_statements():
    """Seed 003 §2.2: secondary minimum for Ψ0 >= 12 mV (not 11), barrier 5.65 kBT at 15 mV.

    The barrier is stated to two decimals, so it must round to 5.65 (|Δ| < 0.005).
    """
    ex15 = pp.generate.dlvo_extrema(0.015)
    assert ex15.has_secondary_minimum
    assert abs(ex15.barrier - 5.65) < 0.005
    for mv in (12, 13, 14, 15):
        assert pp.generate.dlvo_extrema(mv * 1e-3).has_secondary_minimum, mv
    for mv in (0, 5, 10, 11):
        assert not pp.generate.dlvo_extrema(mv * 1e-3).has_secondary_minimum, mv
    onset = dlvo.secondary_minimum_onset()
    assert 0.011 < onset <= 0.012
    # barrier grows with Ψ0
    b = [pp.generate.dlvo_extrema(mv * 1e-3).barrier for mv in (12, 13, 14, 15)]
    assert np.all(np.diff(b) > 0)


def test_defaults_are_physical():
    p = dlvo.dlvo_parameters(0.015)
    assert p.radius == 0.25e-6
    assert p.model == "hhf"
    assert 20 < p.radius / p.debye_length < 30  # κa ≫ 1: HHF applies
    # Debye length of a 1:1 salt: 0.304 nm / sqrt(I in mol/L) at 25 °C; at 20 °C within 1 %
    assert abs(p.debye_length / (0.304e-9 / math.sqrt(p.ionic_strength * 1e-3)) - 1) < 0.01
    # Stokes-Einstein
    assert abs(p.diffusion_coefficient - KB * 293.15 / (6 * math.pi * 1.002e-3 * 0.25e-6)) < 1e-25


def test_hamaker_sphere_limits():
    """Sphere-sphere Hamaker near contact and far away.

    Near contact V = -(A/6) [a/(2h) + 3/8 + ln(h/a)] + O(A h/a) (the leading term is
    Derjaguin's -A a / (12 h)); far away V -> -16 A a^6 / (9 r^6).
    """
    a, A = 0.25e-6, 3.67e-20
    kw = dict(hamaker=A, minimum_separation=0.0)
    for h in (1e-9, 5e-9):
        v = dlvo.dlvo_potential(2 * a + h, 0.0, **kw)
        near = -(A / 6) * (a / (2 * h) + 3 / 8 + math.log(h / a))
        assert abs(v - near) < 2 * (A / 6) * h / a * 10
        assert abs(v / (-A * a / (12 * h)) - 1) > 0.01  # the log term matters: not the Derjaguin form
    r = 40 * a
    v = dlvo.dlvo_potential(r, 0.0, **kw)
    assert abs(v / (-16 * A * a**6 / (9 * r**6)) - 1) < 0.01


def test_hhf_and_lsa_forms():
    a = 0.25e-6
    p = dlvo.dlvo_parameters(0.02, hamaker=0.0, model="hhf")
    eps = 80.1 * 8.8541878128e-12
    h = np.array([1e-9, 5e-9, 2e-8])
    v = dlvo.dlvo_potential(2 * a + h, p)
    np.testing.assert_allclose(v, 2 * math.pi * eps * a * 0.02**2 * np.log1p(np.exp(-h / p.debye_length)),
                               rtol=1e-12)
    # LSA for kappa a >> 1 and low potential tends to the weak-overlap form 2 pi eps a psi^2 exp(-kh)
    q = dlvo.dlvo_parameters(0.002, hamaker=0.0, model="lsa")
    h = 3 * q.debye_length
    vl = dlvo.dlvo_potential(2 * a + h, q)
    # Y = (4kT/e) tanh(e psi / 4kT) = psi (1 - O(psi^2)); geometric factor 2a / r = 1 - O(h/a)
    assert abs(vl / (2 * math.pi * eps * a * 0.002**2 * math.exp(-h / q.debye_length)) - 1) < h / a + 1e-3
    y = 4 * q.kT / 1.602176634e-19 * math.tanh(1.602176634e-19 * 0.002 / (4 * q.kT))
    assert vl == pytest.approx(4 * math.pi * eps * a * a * y * y * math.exp(-h / q.debye_length) / (2 * a + h),
                               rel=1e-12, abs=0)  # abs=0: the default abs=1e-12 J would swallow any energy
    # auto picks LSA for small kappa a
    assert dlvo.dlvo_parameters(0.01, debye_length=0.2e-6).model == "lsa"


@pytest.mark.parametrize("psi,model", [(0.0, "hhf"), (0.015, "hhf"), (0.015, "lsa"), (0.03, "hhf")])
def test_force_is_minus_derivative(psi, model):
    """Central difference of the energy against the analytic force (relative 1e-5)."""
    a = 0.25e-6
    p = dlvo.dlvo_parameters(psi, model=model)
    h = np.geomspace(1e-9, 1e-7, 25)
    r = 2 * a + h
    dr = 1e-6 * h
    num = -(dlvo.dlvo_potential(r + dr, p) - dlvo.dlvo_potential(r - dr, p)) / (2 * dr)
    f = dlvo.dlvo_force(r, p)
    np.testing.assert_allclose(f, num, rtol=1e-5, atol=1e-9 * np.abs(f).max())


def test_minimum_separation_clamps():
    a = 0.25e-6
    p = dlvo.dlvo_parameters(0.0)
    v0 = dlvo.dlvo_potential(2 * a + p.minimum_separation, p)
    assert dlvo.dlvo_potential(2 * a + 0.1e-9, p) == pytest.approx(v0, rel=1e-12, abs=0)
    assert dlvo.dlvo_force(2 * a + 0.1e-9, p) == 0.0
    assert v0 / p.kT < -300  # deep primary minimum: coagulation is irreversible


def test_extrema_are_stationary():
    ex = dlvo.dlvo_extrema(0.014)
    a = 0.25e-6
    p = dlvo.dlvo_parameters(0.014)
    scale = p.kT / p.debye_length  # typical force of the barrier region
    for h in (ex.barrier_separation, ex.secondary_separation):
        assert abs(dlvo.dlvo_force(2 * a + h, p)) < 1e-8 * scale
        # and a true extremum: the force changes sign across it
        f_in, f_out = dlvo.dlvo_force(2 * a + h * (1 - 1e-3), p), dlvo.dlvo_force(2 * a + h * (1 + 1e-3), p)
        assert f_in * f_out < 0
    assert ex.maximum_energy > ex.secondary_energy
    assert ex.barrier_separation < ex.secondary_separation


@pytest.mark.parametrize("psi,model,hc", [(0.0, "hhf", 0.4e-9), (0.0, "hhf", 4e-9), (0.012, "hhf", 4e-9),
                                           (0.015, "hhf", 4e-9), (0.015, "lsa", 4e-9), (0.03, "hhf", 2e-9)])
def test_adhesion_force_is_the_contact_slope_of_the_potential(psi, model, hc):
    """F_adh = dV/dh at the closest approach, against a one-sided second-order finite difference of
    dlvo_potential outside it (relative 1e-6; a missing double layer is off by 10-50 % here)."""
    a = 0.25e-6
    p = dlvo.dlvo_parameters(psi, model=model, minimum_separation=hc)
    d = 1e-4 * hc
    v0, v1, v2 = (dlvo.dlvo_potential(2 * a + hc + k * d, p) for k in (0, 1, 2))
    num = (-3 * v0 + 4 * v1 - v2) / (2 * d)
    assert dlvo.adhesion_force(p) == pytest.approx(num, rel=1e-6)
    # the pull-off force is the largest attraction met on the way out (monotone attraction beyond h_c)
    h = hc + np.geomspace(1e-12, 30e-9, 400)
    assert np.max(-dlvo.dlvo_force(2 * a + h, p)) <= dlvo.adhesion_force(p) * (1 + 1e-9)


def test_adhesion_force_derjaguin_identities():
    """Derjaguin: F = π a W(h_c) for equal spheres. Van der Waals alone (Ψ0 = 0): W = A/(12π h²), so
    F -> A a / (12 h_c²), the exact Hamaker force lying below it by O(h_c/a); the HHF double layer
    removes π a 2εκΨ0²/(1 + exp(κ h_c)) (constant-potential plates), exactly."""
    a = 0.25e-6
    for hc in (0.2e-9, 0.4e-9, 4e-9):
        p = dlvo.dlvo_parameters(0.0, minimum_separation=hc)
        dev = 1 - dlvo.adhesion_force(p) / (p.hamaker * a / (12 * hc**2))
        assert 0 < dev < 3 * hc / a, (hc, dev)
    for psi in (0.005, 0.012, 0.015):
        p0 = dlvo.dlvo_parameters(0.0, minimum_separation=4e-9)
        p = dlvo.dlvo_parameters(psi, minimum_separation=4e-9)
        eps = p.relative_permittivity * 8.8541878128e-12
        w_el = 2 * eps * p.kappa * psi**2 / (1 + math.exp(p.kappa * 4e-9))
        assert dlvo.adhesion_force(p0) - dlvo.adhesion_force(p) == pytest.approx(math.pi * a * w_el, rel=1e-10)
    # in kT/a at the 4 nm contact of docs/brownian.md (sixth pass): 2859, 2452, 2223 at 0, 12, 15 mV
    kt_a = [dlvo.adhesion_force(s, minimum_separation=4e-9) * a / (KB * 293.15) for s in (0.0, 0.012, 0.015)]
    np.testing.assert_allclose(kt_a, [2859.1, 2452.0, 2223.0], rtol=1e-4)


def test_adhesion_force_bad_input():
    with pytest.raises(InvalidInputError, match="minimum_separation"):
        dlvo.adhesion_force(0.0, minimum_separation=0.0)
    assert dlvo.adhesion_force(0.1, minimum_separation=4e-9) < 0  # double layer wins: no adhesion at h_c


def test_bad_input():
    with pytest.raises(InvalidInputError, match="radius"):
        dlvo.dlvo_parameters(0.01, radius=-1e-6)
    with pytest.raises(InvalidInputError, match="temperature"):
        dlvo.dlvo_parameters(0.01, temperature=-5)
    with pytest.raises(InvalidInputError, match="viscosity"):
        dlvo.dlvo_parameters(0.01, viscosity=0)
    with pytest.raises(InvalidInputError, match="model"):
        dlvo.dlvo_parameters(0.01, model="gouy")
    with pytest.raises(InvalidInputError, match="volts"):
        dlvo.dlvo_parameters(15.0)


def test_plot(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    ax = pp.generate.plot_dlvo()
    assert "kBT" in ax.get_ylabel() and "nm" in ax.get_xlabel()
    assert len(ax.get_legend().get_texts()) == 5
    ax.figure.savefig(tmp_path / "dlvo.png")
