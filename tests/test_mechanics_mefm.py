"""RDF-dependent pair-interaction estimate (MEFM): MT limit, splitting invariance, pair physics."""

import numpy as np
import pytest

import polypack as pp
from polypack.errors import InvalidInputError
from polypack.mechanics import Phase, mori_tanaka
from polypack.mechanics.interaction import (
    _J,
    _KDEV,
    _interaction_tensor,
    _polarization_factors,
    _sphere_directions,
    mefm,
    pair_interaction_coefficients,
    partial_rdfs,
)

EPOXY, GLASS = Phase.from_young(3.01, 0.394), Phase.from_young(76.0, 0.23)


def test_zero_rdf_is_mori_tanaka_exactly():
    incs = [GLASS, Phase.from_young(10.0, 0.3), Phase(0.0, 0.0)]
    fr = [0.2, 0.15, 0.1]
    mt = mori_tanaka(EPOXY, incs, fr)
    e = mefm(EPOXY, incs, "none", fractions=fr, radii=[1.0, 0.5, 0.3])
    assert e.bulk == pytest.approx(mt.bulk, rel=1e-13) and e.shear == pytest.approx(mt.shear, rel=1e-13)
    e = mefm(EPOXY, incs, lambda r, k, m: 0.0 * r, fractions=fr, radii=[1.0, 0.5, 0.3])
    assert e.shear == pytest.approx(mt.shear, rel=1e-13)


def test_point_dipole_tensor_is_kelvin_centre_of_dilatation():
    # -Γ0(n) : I is the strain of u = (1 - 2ν)/(8π μ (1 - ν)) x / r³ (a centre of dilatation)
    mu, nu = 1.7, 0.31
    n = np.array([0.3, -0.5, 0.8])
    n /= np.linalg.norm(n)
    g = _interaction_tensor(2.0 * n, mu, nu, 0.0)
    eye = np.array([1, 1, 1, 0, 0, 0.0])
    c = (1 - 2 * nu) / (8 * np.pi * mu * (1 - nu))
    strain = c * (np.eye(3) - 3 * np.outer(n, n)) / 8.0
    w = np.array([1, 1, 1, np.sqrt(2), np.sqrt(2), np.sqrt(2)])
    idx = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]
    expected = np.array([strain[i, j] for i, j in idx]) * w
    assert np.allclose(-g @ eye, expected, rtol=1e-12, atol=1e-15)
    # exterior field averages to zero over directions (why MT does not see g)
    d, wt = _sphere_directions(10)
    avg = sum(wi * _interaction_tensor(2.0 * di, mu, nu, 0.3) for di, wi in zip(d, wt))
    assert np.abs(avg).max() < 1e-14 * np.abs(g).max()


def test_orientation_average_equals_isotropic_projection():
    qk, qg, _, _ = _polarization_factors(EPOXY, GLASS)
    q = qk * _J + qg * _KDEV
    v = 4 / 3 * np.pi
    d, w = _sphere_directions(12)
    for r in (2.0, 2.7, 4.0):
        acc = np.zeros((6, 6))
        for di, wi in zip(d, w):
            g = _interaction_tensor(r * di, EPOXY.shear, EPOXY.poisson, 0.2)
            acc += wi * np.linalg.solve(np.eye(6) - v * v * q @ g @ q @ g, q @ (np.eye(6) - v * g @ q))
        acc -= q
        ref = pair_interaction_coefficients(EPOXY, GLASS, GLASS, 1.0, 1.0, [r])[0]
        assert np.trace(_J @ acc) == pytest.approx(ref[0], rel=1e-10)
        assert np.trace(_KDEV @ acc) / 5 == pytest.approx(ref[1], rel=1e-10)


def test_pair_term_falls_as_r_minus_six():
    dq = pair_interaction_coefficients(EPOXY, GLASS, GLASS, 1.0, 1.0, [20.0, 40.0])
    assert dq[0] / dq[1] == pytest.approx(2.0**6, rel=2e-2)


def test_splitting_a_family_changes_nothing():
    one = mefm(EPOXY, GLASS, "well_stirred", fractions=[0.45], radii=[1.0])
    two = mefm(EPOXY, [GLASS, GLASS], "well_stirred", fractions=[0.15, 0.30], radii=[1.0, 1.0])
    assert two.shear == pytest.approx(one.shear, rel=1e-12) and two.bulk == pytest.approx(one.bulk, rel=1e-12)
    # measured partials: label half the spheres of one pack as a second species
    pk = pp.pack(np.full(400, 1.0), volume_fraction=0.45, seed=4)
    rng = np.random.default_rng(1)
    split = pk.replace(species=rng.integers(0, 2, pk.n))
    a = mefm(EPOXY, [GLASS], pk)
    b = mefm(EPOXY, [GLASS, GLASS], split)
    assert b.shear == pytest.approx(a.shear, rel=1e-10) and b.bulk == pytest.approx(a.bulk, rel=1e-10)


def test_stiff_inclusions_stiffen_beyond_mt_at_second_order():
    dev = {}
    for c in (0.02, 0.04, 0.1, 0.3, 0.5):
        mt = mori_tanaka(EPOXY, GLASS, c)
        e = mefm(EPOXY, GLASS, "well_stirred", fractions=[c], radii=[1.0])
        dev[c] = e.young / mt.young - 1
    # positive, growing with c, and second order in c at low c (pair interactions)
    assert 0 < dev[0.02] < dev[0.04] < dev[0.1] < dev[0.3] < dev[0.5]
    assert dev[0.04] / dev[0.02] == pytest.approx(4.0, rel=0.15)
    # size: a few per cent at c = 0.5 for glass/epoxy (measured 5.5 %); bounded by HS upper
    assert 0.02 < dev[0.5] < 0.10
    lo, up = pp.mechanics.hashin_shtrikman([EPOXY, GLASS], [0.5, 0.5])
    assert mefm(EPOXY, GLASS, "well_stirred", fractions=[0.5], radii=[1.0]).young < up.young
    # a higher contact value (more neighbours at contact) stiffens more
    crowd = mefm(EPOXY, GLASS, lambda r, k, m: np.where(r >= 2, 1 + 2.0 * np.exp(-(r - 2) * 5), 0), fractions=[0.5],
                 radii=[1.0])
    assert crowd.young > (1 + dev[0.5]) * mori_tanaka(EPOXY, GLASS, 0.5).young


def test_partial_rdfs_of_a_pack_are_normalised():
    pk = pp.pack(np.random.default_rng(2).choice([1.0, 0.5], 800), volume_fraction=0.3, seed=2)
    pk = pk.replace(species=(pk.radii < 0.75).astype(int))
    r, g = partial_rdfs(pk, 5.0, 0.05)
    far = (r > 3.5)
    for k in range(2):
        for m in range(2):
            assert np.mean(g[k, m, far]) == pytest.approx(1.0, abs=0.05)
    # no pair closer than contact
    a = np.array([np.mean(pk.radii[pk.species == s]) for s in range(2)])
    for k in range(2):
        for m in range(2):
            assert np.all(g[k, m, r < a[k] + a[m] - 0.05] == 0)


def _partial_rdfs_from_stored_pairs(packing, r_max, dr):
    """Oracle: the former implementation (stored pair list, numpy binning, floor(d/dr))."""
    from polypack.neighbors import pairs_within

    box = np.asarray(packing.box, dtype=np.float64)
    i, j, d = pairs_within(packing.positions, packing.radii, box, a=0.0, b=float(r_max))
    sp = np.asarray(packing.species, dtype=np.int64)
    k = int(sp.max()) + 1
    nb = int(np.floor(r_max / dr + 1e-9))
    edges = np.arange(nb + 1) * dr
    counts = np.zeros((k, k, nb))
    b = np.floor(d / dr).astype(np.int64)
    ok = b < nb
    np.add.at(counts, (sp[i[ok]], sp[j[ok]], b[ok]), 1.0)
    np.add.at(counts, (sp[j[ok]], sp[i[ok]], b[ok]), 1.0)
    nk = np.bincount(sp, minlength=k).astype(np.float64)
    shell = 4.0 / 3.0 * np.pi * (edges[1:] ** 3 - edges[:-1] ** 3)
    g = counts / (nk[:, None, None] * (nk[None, :, None] / float(np.prod(box))) * shell[None, None, :])
    return 0.5 * (edges[1:] + edges[:-1]), g


def test_partial_rdfs_kernel_equals_stored_pair_histogram_and_mefm_from_g():
    # the cell-sweep kernel counts exactly the pairs of the stored pair list (bin edges are
    # hit with probability ~1e-9 per pair for random positions, so equality is exact here)
    sizes = pp.psd.Bimodal(size_ratio=0.313, volume_ratio=0.333, d_large=2.0).sample(n=1500, seed=3)
    pk = pp.pack(sizes, volume_fraction=0.55, seed=3)
    a = np.array([np.mean(pk.radii[pk.species == s]) for s in range(pk.n_species)])
    r_max, dr = min(0.5 * pk.box.min(), 10 * a.max()), 0.01 * a.min()
    r, g = partial_rdfs(pk, r_max, dr)
    r0, g0 = _partial_rdfs_from_stored_pairs(pk, r_max, dr)
    assert np.array_equal(r, r0)
    assert np.array_equal(g, g0)
    # MEFM from the measured (r, g) is the MEFM from the pack (same statistics, same quadrature)
    incs = [GLASS] * pk.n_species
    e_pack = mefm(EPOXY, incs, pk)
    fr = np.array([np.sum(4 / 3 * np.pi * pk.radii[pk.species == s] ** 3) for s in range(pk.n_species)])
    e_g = mefm(EPOXY, incs, (r, g), fractions=fr / np.prod(pk.box), radii=a)
    assert e_g.bulk == pytest.approx(e_pack.bulk, rel=1e-12) and e_g.shear == pytest.approx(e_pack.shear, rel=1e-12)
    # a small pack whose range is half the box (the all-neighbour sweep, no half-shell offsets)
    small = pp.pack(np.random.default_rng(5).choice([1.0, 0.6], 300), volume_fraction=0.4, seed=5)
    small = small.replace(species=(small.radii < 0.8).astype(int))
    half = 0.5 * float(small.box.min())
    assert np.array_equal(partial_rdfs(small, half, 0.02)[1], _partial_rdfs_from_stored_pairs(small, half, 0.02)[1])
    with pytest.raises(InvalidInputError, match=r"rdf=\(r, g\)"):
        mefm(EPOXY, incs, (r, g[0]), fractions=fr / np.prod(pk.box), radii=a)


def test_input_errors():
    with pytest.raises(InvalidInputError, match="fractions= and radii="):
        mefm(EPOXY, GLASS, "well_stirred")
    with pytest.raises(InvalidInputError, match="allowed model names"):
        mefm(EPOXY, GLASS, "willis2", fractions=[0.3], radii=[1.0])
    pk = pp.pack(np.full(50, 1.0), volume_fraction=0.2, seed=1)
    with pytest.raises(InvalidInputError, match="species"):
        mefm(EPOXY, [GLASS, GLASS], pk)
    with pytest.raises(InvalidInputError, match="finite matrix"):
        mefm(Phase.from_young(1.0, 0.5), GLASS, "well_stirred", fractions=[0.3], radii=[1.0])


def test_mefm_rejects_2d_packs():
    pk = pp.Packing(np.random.default_rng(0).random((20, 2)) * 20, np.full(20, 0.5), [20.0, 20.0])
    with pytest.raises(InvalidInputError, match="3D periodic"):
        mefm(EPOXY, GLASS, pk)


def test_voids_soften_below_mori_tanaka_and_rigid_c2_coefficient():
    # for voids MT is the HS upper bound; pair interactions lower the estimate
    m = Phase.from_young(1.0, 0.3)
    for c in (0.1, 0.3):
        assert mefm(m, Phase(0.0, 0.0), "well_stirred", fractions=[c], radii=[1.0]).young < mori_tanaka(
            m, Phase(0.0, 0.0), c).young
    # rigid spheres, nearly incompressible matrix, g = 1: G/G0 = 1 + 2.5 c + k2 c^2; MT has k2 = 2.5,
    # the exact pair solution (Chen & Acrivos 1978) 5.0; the uniform-strain pair model lies between
    m = Phase.from_young(1.0, 0.49999)
    c = 0.01
    k2 = (mefm(m, Phase.from_young(1e6, 0.3), "well_stirred", fractions=[c], radii=[1.0]).shear / m.shear
          - 1 - 2.5 * c) / c**2
    assert 3.0 < k2 < 5.0  # measured 3.40
