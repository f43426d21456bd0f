"""Pore sizes: exact nearest surfaces, Boolean-model exclusion probabilities, DOH fits."""

import json

import numpy as np
import pytest

import polypack as pp
from polypack.analysis.pores import doh_normalized, doh_seed, nearest_surface_distance
from polypack.errors import InvalidInputError


def brute(pk, pts):
    dv = pk.positions[None] - pts[:, None]
    dv -= pk.box * np.round(dv / pk.box)
    return (np.sqrt((dv**2).sum(-1)) - pk.radii[None]).min(1)


@pytest.mark.parametrize("ratio, n, L", [(1.0, 2000, 15.0), (10.0, 3000, 20.0), (30.0, 1500, 12.0)])
def test_nearest_surface_is_exact(ratio, n, L):
    rng = np.random.default_rng(int(ratio))
    rad = 1.2 * np.exp(rng.uniform(np.log(1 / ratio), 0, n))
    pk = pp.Packing(rng.random((n, 3)) * L, rad, L)
    pts = rng.random((2000, 3)) * L
    assert np.array_equal(nearest_surface_distance(pk, pts), brute(pk, pts))
    # points outside [0, L) are folded in
    assert np.allclose(nearest_surface_distance(pk, pts + L), brute(pk, pts))


@pytest.mark.parametrize("nbig, L", [(8, 20.0), (3, 12.0), (30, 25.0)])
def test_nearest_surface_exact_with_even_cell_grids(nbig, L):
    # few large spheres: their class grid has an even number of cells per axis (2 or 4),
    # where the cell at offset -nc/2 is nearer through the other side of the box
    rng = np.random.default_rng(nbig)
    rad = np.concatenate([np.full(nbig, 0.12 * L), np.full(300, 0.0125 * L)])
    pk = pp.Packing(rng.random((rad.size, 3)) * L, rad, L)
    pts = rng.random((5000, 3)) * L
    assert np.allclose(nearest_surface_distance(pk, pts), brute(pk, pts), rtol=0, atol=1e-12)


def test_nearest_surface_kernel_any_grid():
    from polypack._kernels.analysis import nearest_surface

    rng = np.random.default_rng(5)
    L = 10.0
    box = np.full(3, L)
    for _ in range(30):
        n = int(rng.integers(1, 6))
        pos = rng.random((n, 3)) * L
        rad = rng.uniform(0.2, 2.4, n)
        pts = rng.random((300, 3)) * L
        pk = pp.Packing(pos, rad, L)
        for nc in (1, 2, 3, 4):
            got = nearest_surface(pts, pk.positions, rad, box, np.full((1, 3), nc, np.int64),
                                  np.array([rad.max()]), np.zeros(n, np.int64))
            assert np.allclose(got, brute(pk, pts), rtol=0, atol=1e-12), nc


def _boolean(rng, counts, radii, L):
    pos = rng.random((sum(counts), 3)) * L
    rad = np.concatenate([np.full(c, r) for c, r in zip(counts, radii)])
    sp = np.concatenate([np.full(c, k) for k, c in enumerate(counts)])
    return pp.Packing(pos, rad, L, species=sp)


@pytest.mark.parametrize("counts, radii", [((4000,), (1e-4,)), ((2000,), (0.4,)), ((600, 3000), (0.8, 0.25))])
def test_exclusion_probability_of_boolean_models(counts, radii):
    """Fixed-N uniform centres: E_V(r) = prod_k (1 - 4/3 pi (r + a_k)^3 / V)^N_k."""
    rng = np.random.default_rng(sum(counts))
    L = 12.0
    p = pp.analysis.PoreSizes(n_points=4000, seed=3)
    for _ in range(40):  # the pattern fluctuates too: average over realizations
        p.compute(_boolean(rng, counts, radii, L), reset=False)
    V = L**3
    theory = np.prod([(1 - 4 / 3 * np.pi * (p.r + a) ** 3 / V) ** c for c, a in zip(counts, radii)], axis=0)
    err = p.exclusion_err
    assert np.all(np.abs(p.exclusion - theory) < 5 * err + 2e-4)
    assert np.all(err < 0.01)
    e0 = np.prod([(1 - 4 / 3 * np.pi * a**3 / V) ** c for c, a in zip(counts, radii)])
    assert p.void_fraction == pytest.approx(e0, abs=5 * err[0] + 2e-4)
    assert np.allclose(p.survival, p.exclusion / p.void_fraction)
    if len(counts) == 1 and radii[0] < 1e-3:
        lam = counts[0] / V  # Poisson limit exp(-lambda 4 pi r^3 / 3)
        assert np.all(np.abs(p.exclusion - np.exp(-lam * 4 / 3 * np.pi * p.r**3)) < 0.01)


def test_doh_fits_recover_gaussian_and_document_printed_form():
    rng = np.random.default_rng(0)
    p = pp.analysis.PoreSizes(n_points=1000, seed=1, r0=2.0)
    # inject void distances whose pore-size distribution is Gaussian: mean b r0, sd a r0
    d = np.sort(rng.normal(0.6, 0.12, 400_000) * 2.0)
    p._frames = [{"void": d[d > 0], "n": d.size, "r0": 2.0}]
    f = p.fit
    assert f["normalized"]["a"] == pytest.approx(0.12, rel=0.02)
    assert f["normalized"]["b"] == pytest.approx(0.6, rel=0.01)
    assert f["normalized"]["residual_rms"] < 0.005
    assert 0 < f["normalized"]["a_err"] < 0.01
    # the printed form is 1 - erf = 2 x survival: it cannot fit a Gaussian with b >> a
    assert f["seed"]["residual_rms"] > 5 * f["normalized"]["residual_rms"]
    # a half-normal pore size (mode at 0, as in random packs) is the printed form with b = 0
    h = np.sort(np.abs(rng.normal(0.0, 0.3, 400_000)) * 2.0)
    p._frames = [{"void": h[h > 0], "n": h.size, "r0": 2.0}]
    f = p.fit
    assert f["seed"]["a"] == pytest.approx(0.3, rel=0.02)
    assert abs(f["seed"]["b"]) < 0.01
    assert f["seed"]["residual_rms"] < 0.005
    assert f["normalized"]["residual_rms"] > 2 * f["seed"]["residual_rms"]
    x = np.linspace(-1, 3, 50)
    assert np.allclose(doh_seed(x, 0.3, 1.0), 2 * doh_normalized(x, 0.3, 1.0))


def test_seed_reproducible_accumulate_and_report():
    rng = np.random.default_rng(5)
    pk = _boolean(rng, (500,), (0.5,), 10.0)
    a = pp.analysis.PoreSizes(n_points=5000, seed=7).compute(pk)
    b = pp.analysis.PoreSizes(n_points=5000, seed=7).compute(pk)
    assert np.array_equal(a.pore_distances, b.pore_distances)
    a.compute(pk, reset=False)
    assert a.n_realizations == 2
    assert not np.array_equal(a.pore_distances, b.pore_distances)  # second child seed
    assert np.all(np.isfinite(a.survival_err))
    d = json.loads(json.dumps(a.to_dict()))
    assert {"seed", "normalized", "r0"} <= set(d["fit"]) and d["void_fraction"] > 0
    ax = a.plot()
    np.testing.assert_allclose(ax.lines[0].get_ydata(), a.survival, rtol=1e-12)
    np.testing.assert_allclose(ax.lines[0].get_xdata(), a.r / a.r0_used, rtol=1e-12)
    assert len(ax.lines) == 3  # measured and both DOH fits
    assert ax.get_xlabel() == "$r / r_0$" and ax.get_ylabel() == "$P(r_P > r)$"
    with pytest.raises(InvalidInputError, match="n_points"):
        pp.analysis.PoreSizes(n_points=10)
    with pytest.raises(InvalidInputError, match="at least 1 spheres"):
        pp.analysis.PoreSizes(n_points=1000).compute(pp.Packing(np.zeros((0, 3)), np.zeros(0), 5.0))


def test_doh_fit_through_compute_on_a_boolean_pack():
    """DOH fits computed by PoreSizes.compute on a real (boolean-model) pack agree with the
    fits of the exact pore-size distribution of the model, found here by a different
    optimiser (Nelder-Mead on the squared residuals).  r0 defaults to the number-mean
    radius; the fitted a and b are in units of r0, so doubling r0 halves both."""
    from scipy.optimize import minimize

    rng = np.random.default_rng(21)
    counts, radii, L = (300, 1500), (0.6, 0.25), 10.0
    pk = _boolean(rng, counts, radii, L)
    p = pp.analysis.PoreSizes(n_points=200_000, seed=4).compute(pk)
    r0 = float(pk.radii.mean())
    assert p.r0_used == pytest.approx(r0, rel=1e-12)
    f = p.fit
    assert f["r0"] == pytest.approx(r0, rel=1e-12)
    # exact survival of the model, E_V(r) / E_V(0), on the same grid
    V = L**3
    ev = np.prod([(1 - 4 / 3 * np.pi * (p.r + a) ** 3 / V) ** c for c, a in zip(counts, radii)], axis=0)
    surv = ev / ev[0]
    # 2e5 points: the measured curve is within ~3 binomial errors (< 0.005) of it
    assert np.max(np.abs(p.survival - surv)) < 4 * np.max(p.survival_err) + 1e-3
    x = p.r / r0
    for name, fn in (("seed", doh_seed), ("normalized", doh_normalized)):
        res = minimize(lambda q: np.sum((surv - fn(x, q[0], q[1])) ** 2), x0=[0.5, 0.1], method="Nelder-Mead",
                       options={"xatol": 1e-7, "fatol": 1e-12, "maxiter": 4000})
        a_ref, b_ref = abs(res.x[0]), res.x[1]
        # measured-vs-exact curve differences of ~0.002 move a and b by a few 1e-3
        assert f[name]["a"] == pytest.approx(a_ref, abs=0.01 * a_ref + 4 * f[name]["a_err"]), name
        assert f[name]["b"] == pytest.approx(b_ref, abs=0.01 * abs(a_ref) + 4 * f[name]["b_err"]), name
    assert f["seed"]["residual_rms"] < f["normalized"]["residual_rms"]  # mode at 0: the printed form fits better
    q = pp.analysis.PoreSizes(n_points=200_000, seed=4, r0=2 * r0).compute(pk).fit
    for name in ("seed", "normalized"):
        assert q[name]["a"] == pytest.approx(0.5 * f[name]["a"], rel=1e-4)
        assert q[name]["b"] == pytest.approx(0.5 * f[name]["b"], rel=1e-4, abs=1e-6)
