"""Lubrication-corrected pair mobility of ``pp.brownian(..., hydrodynamics="lubrication")``.

Validated against: Honig, Roebersen & Wiersema's β(u) pointwise; the Fuchs stability ratio
by quadrature (formula written here, not taken from the code); finite differences of the
dense many-body mobility for its Itô divergence; the Boltzmann distribution of a trapped
pair; and the mean first-passage time of a pair over the 15 mV DLVO barrier.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid, quad

import polypack as pp
from polypack._kernels import bd
from polypack.errors import InvalidInputError
from polypack.generate.brownian import BrownianSimulation, relative_mobility
from polypack.generate.dlvo import dlvo_parameters

A = 0.25e-6


def _honig(u):
    return (6 * u * u + 13 * u + 2) / (6 * u * u + 4 * u)


def _taper(u, uc):
    """β - 1 is multiplied by 1 up to uc/2, by 1 - t²(3 - 2t), t = 2u/uc - 1, up to uc, and by 0 beyond."""
    t = np.clip(2 * np.asarray(u, float) / uc - 1, 0, 1)
    return 1 - t * t * (3 - 2 * t)


def test_relative_mobility_is_honig():
    u = np.array([1e-3, 4e-3, 0.01, 0.04, 0.1, 0.2, 0.25])
    assert np.allclose(relative_mobility(u * A), 1 / _honig(u), rtol=1e-12)
    # near contact 1/β -> 2u (Reynolds squeeze film between equal spheres)
    assert float(relative_mobility(1e-3 * A)) == pytest.approx(2e-3, rel=0.01)
    # tapered to free draining at the range (default a/2), continuous and monotone
    uu = np.linspace(0.2, 0.6, 4001)
    m = relative_mobility(uu * A)
    assert np.all(np.diff(m) >= 0) and np.max(np.abs(np.diff(m))) < 1e-3
    assert np.all(m[uu >= 0.5] == 1.0)
    assert np.allclose(m, 1 / (1 + (_honig(uu) - 1) * _taper(uu, 0.5)), rtol=1e-12)
    # unbounded range: Honig at every gap
    assert float(relative_mobility(3 * A, lubrication_range=math.inf)) == pytest.approx(1 / _honig(3.0), rel=1e-12)


def _fuchs(psi, mobility):
    """W = R ∫_R^∞ β(u) exp(V/kT) / r² dr, R = 2a + 1 nm (capture at the bond width)."""
    kT = dlvo_parameters(psi).kT
    R = 2 * A + 1e-9

    def f(r):
        v = pp.generate.dlvo_potential(np.array([r]), surface_potential=psi)[0] / kT
        return mobility((r - 2 * A) / A) * math.exp(v) / r**2

    pts = [R, R + 20e-9, 2.125 * A, 2.25 * A, 2.5 * A, 4 * A, 50 * A]
    tot = sum(quad(f, pts[k], pts[k + 1], limit=400)[0] for k in range(len(pts) - 1))
    tot += quad(f, 50 * A, np.inf, limit=200)[0]
    return R * tot


def test_fuchs_stability_ratio():
    """Free draining W = 0.84 / 1.79 and Honig W = 1.43 / 14.3 at 0 / 15 mV (docs/brownian.md).

    The implemented mobility (range a/2) keeps the near-contact and barrier part: W = 0.936 at
    0 mV (the 1.5/u far-field tail of Honig's fit beyond a/2 is left out) and 13.8 at 15 mV,
    so 15 mV coagulates 14.7 times slower than 0 mV (free draining: 2.1 times).
    """
    free = [_fuchs(psi, lambda u: 1.0) for psi in (0.0, 0.015)]
    honig = [_fuchs(psi, _honig) for psi in (0.0, 0.015)]
    assert free[0] == pytest.approx(0.84, abs=0.005) and free[1] == pytest.approx(1.79, abs=0.005)
    assert honig[0] == pytest.approx(1.43, abs=0.005) and honig[1] == pytest.approx(14.3, abs=0.05)
    code = [_fuchs(psi, lambda u: 1.0 / float(relative_mobility(u * A))) for psi in (0.0, 0.015)]
    ref = [_fuchs(psi, lambda u: 1 + (_honig(u) - 1) * _taper(u, 0.5)) for psi in (0.0, 0.015)]
    assert code == pytest.approx(ref, rel=1e-6)
    assert code[0] == pytest.approx(0.936, abs=0.002) and code[1] == pytest.approx(13.80, abs=0.02)
    assert code[1] / code[0] > 14.0 and free[1] / free[0] < 2.2


def _cluster(n, seed, gaps=(0.02, 0.15)):
    """``n`` spheres, each added at a nearest-neighbour gap (in radii) within ``gaps``."""
    rng = np.random.default_rng(seed)
    pos = np.array([[20.0, 20.0, 20.0]])
    while len(pos) < n:
        c = pos[rng.integers(len(pos))] + rng.normal(size=3)
        d = np.linalg.norm(pos - c, axis=1)
        if 2.0 + gaps[0] < d.min() < 2.0 + gaps[1]:
            pos = np.vstack([pos, c])
    return pos


def _dense_mobility(pos, box, uc, pi, pj, flag):
    n = pos.shape[0]
    M = np.zeros((3 * n, 3 * n))
    s1, s2, dv = (np.zeros((n, 3)) for _ in range(3))
    for b in range(3 * n):
        e = np.zeros((n, 3))
        e.flat[b] = 1.0
        bd.lubrication_terms(pos, box, uc, pi, pj, flag, e, s1, dv)
        bd.lubrication_terms(pos, box, uc, pi, pj, flag, s1.copy(), s2, dv)
        M[:, b] = s2.ravel()
    return M


@pytest.mark.parametrize("seed, gaps", [(3, (0.02, 0.15)), (7, (0.02, 0.15)), (5, (0.27, 0.48))])
def test_mobility_and_ito_drift_against_finite_differences(seed, gaps):
    """M = S² is symmetric positive definite; its divergence (pair and cross terms) equals central
    differences of the dense M to 1e-7 (6-sphere clusters, several pairs through one sphere).
    Gaps near contact, and gaps in the taper uc/2 < u < uc, where dβ_eff/du has the taper's own
    chain-rule term (central differences at eps = 1e-6: truncation ~1e-11, round-off ~1e-10)."""
    n, uc = 6, 0.5
    pos = _cluster(n, seed, gaps)
    box = np.full(3, 50.0)
    pi, pj = (x.astype(np.int64) for x in np.triu_indices(n, 1))
    flag = np.zeros(pi.size, np.uint8)
    flag[0] = 1  # one bonded pair: excluded from lubrication
    m = bd.lubrication_terms(pos, box, uc, pi, pj, flag, np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)))
    M = _dense_mobility(pos, box, uc, pi, pj, flag)
    gap = np.linalg.norm(pos[pj] - pos[pi], axis=1) - 2
    lub = (gap < uc) & (flag == 0)
    assert m == lub.sum() and np.bincount(np.r_[pi[lub], pj[lub]]).max() >= 2  # cross terms exercised
    if gaps[0] > uc / 2:
        assert np.count_nonzero(lub & (gap > uc / 2)) >= 3  # the taper is exercised
    assert np.abs(M - M.T).max() < 1e-14 and np.linalg.eigvalsh(M).min() > 0
    # an isolated lubricated pair: relative normal mobility 2/β, centre of mass and tangents free
    two = np.array([[20.0, 20.0, 20.0], [22.05, 20.0, 20.0]])
    M2 = _dense_mobility(two, box, uc, np.array([0]), np.array([1]), np.zeros(1, np.uint8))
    bvec = np.array([-1, 0, 0, 1, 0, 0.0])
    assert bvec @ M2 @ bvec == pytest.approx(2 / _honig(0.05), rel=1e-12)
    assert np.allclose(M2 @ np.array([1, 0, 0, 1, 0, 0.0]), [1, 0, 0, 1, 0, 0], atol=1e-14)
    assert M2[1, 1] == pytest.approx(1.0) and M2[1, 4] == pytest.approx(0.0, abs=1e-15)
    eps = 1e-6
    fd = np.zeros(3 * n)
    for b in range(3 * n):
        xp, xm = pos.copy(), pos.copy()
        xp.flat[b] += eps
        xm.flat[b] -= eps
        fd += (_dense_mobility(xp, box, uc, pi, pj, flag)[:, b] - _dense_mobility(xm, box, uc, pi, pj, flag)[:, b]) / (2 * eps)
    div = np.zeros((n, 3))
    bd.lubrication_terms(pos, box, uc, pi, pj, flag, np.zeros((n, 3)), np.zeros((n, 3)), div)
    assert np.abs(fd).max() > 0.1
    assert np.abs(div.ravel() - fd).max() < 1e-7


def _trapped_pair(p, hydrodynamics, k_red, frac, seed, bond_width=None, u0=0.06):
    a = p.radius
    pos0 = np.array([[20 * a - (1 + u0 / 2) * a, 20 * a, 20 * a], [20 * a + (1 + u0 / 2) * a, 20 * a, 20 * a]])
    dt = (frac * p.debye_length) ** 2 / (2 * p.diffusion_coefficient)
    return BrownianSimulation(pos0, 40 * a, p, bond_width=bond_width, trap_stiffness=k_red * p.kT / a**2, seed=seed,
                              hydrodynamics=hydrodynamics, time_step=dt)


@pytest.mark.slow
def test_trapped_pair_samples_boltzmann():
    """A pair with a soft double-layer repulsion (6 mV, no van der Waals) in a harmonic trap
    (k = 40 kT/a² per sphere: the relative coordinate feels k r²/4) samples
    r² exp(-V(r)/kT - k r²/4): mean gap 0.0762 a, a quarter of the time below 0.05 a, where
    β = 8-30.  Checked with lubrication to 4 block standard errors plus 2 % for the Euler
    step; the same scheme without the Itô drift (div M) dt spends a third of the time below
    0.05 a (the test catches it), and free draining samples the same distribution."""
    psi, k = 0.006, 40.0
    p = dlvo_parameters(psi, hamaker=0.0)
    a = p.radius
    u = np.linspace(1e-6, 1.0, 400001)
    r = 2 + u
    w = r**2 * np.exp(-pp.generate.dlvo_potential(r * a, surface_potential=psi, hamaker=0.0) / p.kT - k * (r**2 - 4) / 4)
    w /= np.trapezoid(w, u)
    mean_exact = np.trapezoid(u * w, u)
    low_exact = np.trapezoid(np.where(u < 0.05, w, 0.0), u)
    assert mean_exact == pytest.approx(0.0762, abs=1e-4) and low_exact == pytest.approx(0.253, abs=1e-3)

    def sample(hydro, no_drift=False):
        vals = []
        for seed in (1, 2, 3, 4):
            sim = _trapped_pair(p, hydro, k, 0.15, seed)
            if no_drift:
                sim._params[bd.P_LUB_NO_DRIFT] = 1.0
            for _ in range(16000):
                sim.run(50)
                x = sim.positions
                vals.append(np.linalg.norm(x[1] - x[0]) / a - 2)
        g = np.array(vals)
        out = []
        for y in (g, (g < 0.05).astype(float)):  # mean gap, fraction below 0.05 a; 40 block means
            blocks = y[: y.size // 40 * 40].reshape(40, -1).mean(axis=1)
            out += [y.mean(), blocks.std(ddof=1) / math.sqrt(40)]
        return out

    m, se, low, se_low = sample("lubrication")
    assert abs(m - mean_exact) < 4 * se + 0.02 * mean_exact, (m, se)
    assert abs(low - low_exact) < 4 * se_low + 0.02, (low, se_low)
    m_nd, se_nd, low_nd, se_low_nd = sample("lubrication", no_drift=True)
    assert low_nd - low_exact > 4 * se_low_nd + 0.02, (low_nd, se_low_nd)
    m_f, se_f, low_f, se_low_f = sample("free")
    assert abs(m_f - mean_exact) < 4 * se_f + 0.02 * mean_exact, (m_f, se_f)
    assert abs(low_f - low_exact) < 4 * se_low_f + 0.02, (low_f, se_low_f)


def _mfpt_quadrature(p, k, u0, mobility):
    """Mean first-passage time (a²/D0) from gap u0 to capture at 1 nm of radial diffusion with
    D(r) = 2 mobility(u) in U = V/kT + k r²/4: T = ∫_R^{r0} e^U / (r² D) ∫_r^∞ r'² e^{-U} dr' dr."""
    a = p.radius
    R = 2 + 1e-9 / a
    r = np.linspace(R, 5.0, 600001)
    U = pp.generate.dlvo_potential(r * a, surface_potential=p.surface_potential) / p.kT + k * r**2 / 4
    U -= U.min()
    tail = -cumulative_trapezoid((np.exp(-U) * r**2)[::-1], r[::-1], initial=0)[::-1]
    f = np.exp(U) / (r**2 * 2 * mobility(r - 2)) * tail
    sel = r <= 2 + u0
    return np.trapezoid(f[sel], r[sel])


@pytest.mark.slow
def test_first_passage_over_the_15mV_barrier():
    """A pair started at gap a/4 in a weak trap (k = 10 kT/a²) is captured (bonded at 1 nm) after
    the mean first-passage time of radial diffusion with D(r) = 2 D0/β_eff over the 15 mV DLVO
    barrier: quadrature 0.169 (free) and 2.21 a²/D0 (lubrication), 13 times slower (Fuchs W
    ratio 7.7 for this range).  Each mean is within 4 standard errors (σ_T ≈ T: 9 % at 120 free,
    7 % at 200 lubricated trials) plus 8 % for the time step (rms 0.2 Debye lengths)."""
    p = dlvo_parameters(0.015)
    k, u0 = 10.0, 0.25
    t_free = _mfpt_quadrature(p, k, u0, lambda u: np.ones_like(u))
    t_lub = _mfpt_quadrature(p, k, u0, lambda u: relative_mobility(u * p.radius))
    assert t_free == pytest.approx(0.1687, rel=2e-3) and t_lub == pytest.approx(2.207, rel=2e-3)
    for hydro, trials, t_exact in (("free", 120, t_free), ("lubrication", 200, t_lub)):
        times = []
        for seed in range(trials):
            sim = _trapped_pair(p, hydro, k, 0.2, seed, bond_width=1e-9, u0=u0)
            while sim.n_bonds == 0:
                sim.run(20)
            times.append(sim.time / p.brownian_time)
        times = np.array(times)
        se = times.std(ddof=1) / math.sqrt(trials)
        assert abs(times.mean() - t_exact) < 4 * se + 0.08 * t_exact, (hydro, times.mean(), se, t_exact)


def test_lubricated_gel_and_bad_input():
    with pytest.warns(RuntimeWarning, match="not stable"):
        pk = pp.brownian(64, 0.4, 0.0, seed=2, hydrodynamics="lubrication", bonds="tangential", max_time=2e-3)
    rec = pk.meta["brownian"]
    assert rec["hydrodynamics"] == "lubrication" and rec["lubrication_range"] == pytest.approx(0.5 * A)
    assert rec["coordination"] > 2.0 and pk.min_gap() > -1e-6
    p = dlvo_parameters(0.0)
    pos = np.array([[0.0, 0, 0], [3 * A, 0, 0]])
    with pytest.raises(InvalidInputError, match="hydrodynamics"):
        BrownianSimulation(pos, 20 * A, p, hydrodynamics="stokesian")
    with pytest.raises(InvalidInputError, match="rigid"):
        BrownianSimulation(pos, 20 * A, p, hydrodynamics="lubrication", bonds="rigid")
    with pytest.raises(InvalidInputError, match="lubrication_range"):
        BrownianSimulation(pos, 20 * A, p, hydrodynamics="lubrication", lubrication_range=0.8 * A)
    with pytest.raises(InvalidInputError, match="lubrication_range"):
        BrownianSimulation(pos, 20 * A, p, lubrication_range=0.1 * A)
