"""Classical effective-moduli estimates and bounds against closed forms and identities."""

import math

import numpy as np
import pytest

import polypack as pp
from polypack.errors import InfeasibleError, InvalidInputError
from polypack.mechanics import Phase, dilute, hashin_shtrikman, mori_tanaka, self_consistent, three_point_bounds

RIGID = Phase(bulk=math.inf, shear=math.inf)


def test_phase_conversions_round_trip():
    p = Phase.from_young(3.01e9, 0.394)
    assert p.young == pytest.approx(3.01e9, rel=1e-14)
    assert p.poisson == pytest.approx(0.394, rel=1e-14)
    assert p.bulk == pytest.approx(3.01e9 / (3 * (1 - 2 * 0.394)), rel=1e-14)
    inc = Phase.from_young(1.0, 0.5)
    assert math.isinf(inc.bulk) and inc.poisson == 0.5 and inc.young == pytest.approx(1.0)


@pytest.mark.parametrize(
    "kwargs",
    [dict(bulk=-1.0, shear=1.0), dict(bulk=1.0, shear=-2.0), dict(bulk=float("nan"), shear=1.0)],
)
def test_phase_rejects_negative_moduli(kwargs):
    with pytest.raises(InvalidInputError, match="must be >= 0"):
        Phase(**kwargs)


@pytest.mark.parametrize("nu", [0.5000001, 0.7, -1.0, -2.0])
def test_from_young_rejects_poisson_out_of_range(nu):
    with pytest.raises(InvalidInputError, match=r"\(-1, 0.5\]"):
        Phase.from_young(1.0, nu)


def test_fractions_checked():
    m, f = Phase(1, 1), Phase(2, 2)
    with pytest.raises(InvalidInputError, match="sum to 1.2"):
        mori_tanaka(m, [f, f], [0.6, 0.6])
    with pytest.raises(InvalidInputError, match="sum to"):
        hashin_shtrikman([m, f], [0.5, 0.4])
    with pytest.raises(InvalidInputError, match="one per phase"):
        mori_tanaka(m, [f], [0.1, 0.2])
    with pytest.raises(InvalidInputError, match="Phase"):
        mori_tanaka(m, [(1, 2)], [0.1])


@pytest.mark.parametrize("c", [0.05, 0.2, 0.45, 0.7])
def test_mt_rigid_spheres_incompressible_matrix(c):
    # closed form G/G0 = (2 + 3c) / (2 (1 - c)); K stays infinite
    m = Phase.from_young(1.0, 0.5)
    e = mori_tanaka(m, RIGID, c)
    assert e.shear / m.shear == pytest.approx((2 + 3 * c) / (2 * (1 - c)), rel=1e-13)
    assert math.isinf(e.bulk)


def test_mt_voids_closed_form():
    # voids, nu0 = 0.3, c = 0.3: K/K0 = 8/17, G/G0 = 0.55 (exact fractions of the MT formula)
    m = Phase.from_young(1.0, 0.3)
    e = mori_tanaka(m, Phase(0.0, 0.0), 0.3)
    assert e.bulk / m.bulk == pytest.approx(8 / 17, rel=1e-13)
    assert e.shear / m.shear == pytest.approx(0.55, rel=1e-13)


def test_dilute_einstein_and_first_order_agreement():
    m = Phase.from_young(1.0, 0.5)
    for c in (1e-3, 0.01, 0.1):
        assert dilute(m, RIGID, c).shear / m.shear == pytest.approx(1 + 2.5 * c, rel=1e-13)
    # MT and SC agree with the dilute estimate to first order: the gap is O(c^2)
    m, f = Phase.from_young(1.0, 0.35), Phase.from_young(20.0, 0.2)
    for c in (1e-3, 1e-4):
        d, mt, sc = dilute(m, f, c), mori_tanaka(m, f, c), self_consistent(m, f, c)
        assert abs(mt.shear - d.shear) / m.shear < 3 * c * c
        assert abs(sc.shear - d.shear) / m.shear < 30 * c * c


def test_mt_is_hs_lower_for_softest_matrix_and_swap_gives_upper():
    rng = np.random.default_rng(4)
    for _ in range(200):
        k0, g0 = rng.uniform(0.5, 2.0, 2)
        k1, g1 = k0 * rng.uniform(1, 50), g0 * rng.uniform(1, 50)  # well ordered, matrix softest
        m, f = Phase(k0, g0), Phase(k1, g1)
        c = rng.uniform(0.01, 0.99)
        lo, up = hashin_shtrikman([m, f], [1 - c, c])
        mt = mori_tanaka(m, f, c)
        assert mt.bulk == pytest.approx(lo.bulk, rel=1e-12)
        assert mt.shear == pytest.approx(lo.shear, rel=1e-12)
        swapped = mori_tanaka(f, m, 1 - c)
        assert swapped.bulk == pytest.approx(up.bulk, rel=1e-12)
        assert swapped.shear == pytest.approx(up.shear, rel=1e-12)


def test_multi_family_mt_equals_merged_family_and_identical_split():
    m, f = Phase.from_young(3.01e9, 0.394), Phase.from_young(76e9, 0.23)
    one = mori_tanaka(m, [f], [0.5])
    two = mori_tanaka(m, [f, f], [0.2, 0.3])
    assert two.shear == pytest.approx(one.shear, rel=1e-14)
    assert two.bulk == pytest.approx(one.bulk, rel=1e-14)
    # Benveniste's strain-concentration form written out for two distinct families
    g = Phase.from_young(10e9, 0.3)
    c = np.array([0.2, 0.25])
    k0, g0 = m.bulk, m.shear
    z0 = g0 * (9 * k0 + 8 * g0) / (6 * (k0 + 2 * g0))
    tk = [(k0 + 4 * g0 / 3) / (p.bulk + 4 * g0 / 3) for p in (f, g)]
    tg = [(g0 + z0) / (p.shear + z0) for p in (f, g)]
    c0 = 1 - c.sum()
    kb = (c0 * k0 + c[0] * f.bulk * tk[0] + c[1] * g.bulk * tk[1]) / (c0 + c[0] * tk[0] + c[1] * tk[1])
    gb = (c0 * g0 + c[0] * f.shear * tg[0] + c[1] * g.shear * tg[1]) / (c0 + c[0] * tg[0] + c[1] * tg[1])
    e = mori_tanaka(m, [f, g], c)
    assert e.bulk == pytest.approx(kb, rel=1e-13) and e.shear == pytest.approx(gb, rel=1e-13)


def test_hs_walpole_not_well_ordered_is_wider_than_min_max_zeta():
    # phase A stiff in bulk, soft in shear; phase B the reverse
    a, b = Phase(10.0, 0.5), Phase(1.0, 5.0)
    lo, up = hashin_shtrikman([a, b], [0.5, 0.5])
    zetas = [p.shear * (9 * p.bulk + 8 * p.shear) / (6 * (p.bulk + 2 * p.shear)) for p in (a, b)]
    narrow_lo = 1 / (0.5 / (a.shear + min(zetas)) + 0.5 / (b.shear + min(zetas))) - min(zetas)
    narrow_up = 1 / (0.5 / (a.shear + max(zetas)) + 0.5 / (b.shear + max(zetas))) - max(zetas)
    assert lo.shear < narrow_lo - 1e-3 and up.shear > narrow_up + 1e-3


def test_estimates_within_hs_bounds():
    rng = np.random.default_rng(7)
    for _ in range(300):
        m = Phase(*rng.uniform(0.1, 10, 2))
        incs = [Phase(*(10 ** rng.uniform(-2, 2, 2))) for _ in range(2)]
        f = rng.dirichlet([1, 1, 1])[:2] * rng.uniform(0.05, 0.95)
        lo, up = hashin_shtrikman([m] + incs, [1 - f.sum(), *f])
        for est in (mori_tanaka(m, incs, f), self_consistent(m, incs, f)):
            assert lo.bulk * (1 - 1e-10) <= est.bulk <= up.bulk * (1 + 1e-10)
            assert lo.shear * (1 - 1e-10) <= est.shear <= up.shear * (1 + 1e-10)


def test_self_consistent_closed_forms():
    # SC for voids in an incompressible-like matrix vanishes at c = 1/2 (its percolation threshold)
    m = Phase.from_young(1.0, 0.2)
    assert self_consistent(m, Phase(0.0, 0.0), 0.55).shear == 0.0
    assert self_consistent(m, Phase(0.0, 0.0), 0.3).shear > 0.0
    # rigid spheres in an incompressible matrix: G*/G0 = 1/(1 - 5c/2) (Roscoe/Brinkman form of SC)
    inc = Phase.from_young(1.0, 0.5)
    for c in (0.1, 0.2, 0.3):
        sc = self_consistent(inc, Phase(math.inf, 1e12), c)
        assert sc.shear / inc.shear == pytest.approx(1 / (1 - 2.5 * c), rel=1e-6)



def test_three_point_bounds_reduce_to_hs_at_zero_and_one():
    m, f = Phase.from_young(3.01, 0.394), Phase.from_young(76, 0.23)
    for c in (0.1, 0.4, 0.7):
        lo, up = hashin_shtrikman([m, f], [1 - c, c])
        l0, u0 = three_point_bounds(m, f, c, 0.0, 0.0)
        l1, u1 = three_point_bounds(m, f, c, 1.0, 1.0)
        assert l0.bulk == pytest.approx(lo.bulk, rel=1e-12) and u0.bulk == pytest.approx(lo.bulk, rel=1e-12)
        assert l1.bulk == pytest.approx(up.bulk, rel=1e-12) and u1.bulk == pytest.approx(up.bulk, rel=1e-12)


def test_three_point_bounds_second_order_in_contrast():
    # for nearly equal phases both bulk bounds agree with the exact second-order expansion
    # K* = <K> - phi1 phi2 dK^2 / (K + 4G/3) + O(d^3)
    k, g = 2.0, 1.0
    for d in (1e-2, 1e-3):
        m, f = Phase(k, g), Phase(k * (1 + d), g * (1 + d))
        c = 0.3
        exact2 = (1 - c) * k + c * f.bulk - c * (1 - c) * (k * d) ** 2 / (k + 4 * g / 3)
        lo, up = three_point_bounds(m, f, c, 0.2, 0.5)
        assert abs(lo.bulk - exact2) < 5 * d**3 and abs(up.bulk - exact2) < 5 * d**3


def test_three_point_bulk_bounds_inside_hs_and_narrower():
    rng = np.random.default_rng(3)
    for _ in range(60):
        m = Phase(*rng.uniform(0.5, 2, 2))
        f = Phase(m.bulk * 10 ** rng.uniform(-2, 2), m.shear * 10 ** rng.uniform(-2, 2))
        c = rng.uniform(0.02, 0.65)
        z2, e2 = rng.uniform(0.0, 1.0, 2)
        try:
            lo, up = three_point_bounds(m, f, c, z2, e2)
        except InfeasibleError:  # (zeta2, eta2) that no microstructure has: the shear bounds cross
            assert abs(z2 - e2) > 0.1
            continue
        hl, hu = hashin_shtrikman([m, f], [1 - c, c])
        assert hl.bulk * (1 - 1e-12) <= lo.bulk <= up.bulk * (1 + 1e-12) <= hu.bulk * (1 + 2e-12)
        # shear: the Milton-Phan-Thien bounds, also for phases that are not well ordered
        assert hl.shear * (1 - 1e-9) <= lo.shear <= up.shear * (1 + 1e-9) <= hu.shear * (1 + 1e-9)
    # hard-sphere-like zeta2 shrinks the bulk window well below the HS one for glass/epoxy
    m, f = Phase.from_young(3.01, 0.394), Phase.from_young(76, 0.23)
    lo, up = three_point_bounds(m, f, 0.5, 0.0937, 0.3)
    hl, hu = hashin_shtrikman([m, f], [0.5, 0.5])
    assert (up.bulk - lo.bulk) < 0.5 * (hu.bulk - hl.bulk)


def test_three_point_input_checks():
    m, f = Phase(1, 1), Phase(2, 2)
    with pytest.raises(InvalidInputError, match="zeta2"):
        three_point_bounds(m, f, 0.3, 1.5, 0.2)
    with pytest.raises(InvalidInputError, match="finite"):
        three_point_bounds(m, RIGID, 0.3, 0.1, 0.2)


def test_public_names():
    assert pp.mechanics.Phase is Phase
    assert pp.mechanics.mori_tanaka is mori_tanaka
