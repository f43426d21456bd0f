"""Voigt and Reuss isotropic averages of a 6x6 stiffness against closed forms.

Independent of the bonded networks: an isotropic tensor built from (K, G) must average
back to (K, G) in both schemes, and a cubic crystal has Hill's (1952) closed forms
K_V = K_R = (C11 + 2 C12) / 3, G_V = (C11 - C12 + 3 C44) / 5 and
G_R = 5 (C11 - C12) C44 / (4 C44 + 3 (C11 - C12)). Tolerance 1e-12 relative: only the
round-off of a 6x6 inverse, while a wrong coefficient (say 4 for 3 in the Reuss shear
denominator) moves G_R by 10 % or more.
"""

import numpy as np
import pytest

from polypack.mechanics import voigt_average
from polypack.mechanics.elastic import ElasticTensor


def _cubic(c11, c12, c44):
    c = np.zeros((6, 6))
    c[:3, :3] = c12
    np.fill_diagonal(c[:3, :3], c11)
    c[3, 3] = c[4, 4] = c[5, 5] = c44
    return c


def _reuss(c):
    """``(K_R, G_R)`` through the public ElasticTensor property (only the stiffness is read)."""
    return ElasticTensor(stiffness=c).reuss_moduli


@pytest.mark.parametrize("k, g", [(3.7, 1.9), (1.0, 0.05), (20.0, 11.0)])
def test_isotropic_tensor_averages_to_its_own_moduli(k, g):
    c = _cubic(k + 4.0 * g / 3.0, k - 2.0 * g / 3.0, g)  # engineering shear strains: C44 = G
    kv, gv = voigt_average(c)
    kr, gr = _reuss(c)
    assert kv == pytest.approx(k, rel=1e-12) and gv == pytest.approx(g, rel=1e-12)
    assert kr == pytest.approx(k, rel=1e-12) and gr == pytest.approx(g, rel=1e-12)


@pytest.mark.parametrize("c11, c12, c44", [(5.0, 2.0, 1.3), (1.0, 0.5, 0.9), (10.0, 1.0, 0.2)])
def test_cubic_crystal_hill_closed_forms(c11, c12, c44):
    c = _cubic(c11, c12, c44)
    kv, gv = voigt_average(c)
    kr, gr = _reuss(c)
    assert kv == pytest.approx((c11 + 2 * c12) / 3, rel=1e-12)
    assert kr == pytest.approx((c11 + 2 * c12) / 3, rel=1e-12)
    assert gv == pytest.approx((c11 - c12 + 3 * c44) / 5, rel=1e-12)
    assert gr == pytest.approx(5 * (c11 - c12) * c44 / (4 * c44 + 3 * (c11 - c12)), rel=1e-12)
    assert gr < gv  # Hill: the Reuss average lies below the Voigt one for an anisotropic crystal


def test_reuss_of_a_singular_tensor_is_zero():
    c = _cubic(1.0, 0.5, 0.0)  # no shear stiffness: a floppy network
    assert _reuss(c) == (0.0, 0.0)
