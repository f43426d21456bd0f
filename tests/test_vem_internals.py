"""VEM internals against hand results (issue 37): the unbalanced-force ratio of the relaxation
criterion and the overlap-removal projection (§2.2 of 003_873b69fc71c74cf6.txt).
"""

from __future__ import annotations

import numpy as np
import pytest

from polypack._kernels import vem as V
from polypack.generate.vem import _Assembly


@pytest.mark.parametrize("ov1, ov2", [(0.02, 0.01), (0.01, 0.01), (0.015, 0.0)])
def test_relaxation_ratio_of_overlapping_spheres_in_a_line_is_the_hand_value(ov1, ov2):
    """Three unit spheres on a line with overlaps ov1 (0-1) and ov2 (1-2), kn = 1: the contact
    forces are f1 = ov1, f2 = ov2, the spheres' net forces f1, |f1 - f2|, f2, so PFC's ratio
    (mean unbalanced force over mean contact force, both over what carries force) is
    (f1 + |f1 - f2| + f2) / (2 (f1 + f2)): 2/3, 1/2 and 1 here (one overlapping pair alone gives
    1).  A ratio off by a factor 2 reads 4/3, 1, 2."""
    x1 = 2.0 - ov1
    x2 = x1 + 2.0 - ov2 if ov2 > 0 else x1 + 2.5
    pos = np.array([[5.0, 10.0, 10.0], [5.0 + x1, 10.0, 10.0], [5.0 + x2, 10.0, 10.0]])
    asm = _Assembly(pos, np.ones(3), np.full(3, 20.0), 3, 1.0, 0.1, 1.0, 0.1, 0.0, 0.7, 0.4)
    steps, ratio = asm.relax(1e-12, 1, 1)
    f1, f2 = ov1, ov2
    assert steps == 1
    assert ratio == pytest.approx((f1 + abs(f1 - f2) + f2) / (2.0 * (f1 + f2)), rel=1e-9, abs=0)


def test_relaxation_stops_once_the_ratio_is_below_the_tolerance():
    """The same pair: the first check (ratio 1) stops a relaxation with tolerance 1.5, never one
    with tolerance 0.9 (which runs its whole budget)."""
    pos = np.array([[5.0, 10.0, 10.0], [6.98, 10.0, 10.0]])
    asm = _Assembly(pos.copy(), np.ones(2), np.full(3, 20.0), 2, 1.0, 0.1, 1.0, 0.1, 0.0, 0.7, 0.4)
    assert asm.relax(1.5, 1, 5) == (1, pytest.approx(1.0, rel=1e-9, abs=0))
    asm = _Assembly(pos.copy(), np.ones(2), np.full(3, 20.0), 2, 1.0, 0.1, 1.0, 0.1, 0.0, 0.7, 0.4)
    steps, _ = asm.relax(0.9, 1, 5)
    assert steps == 5


@pytest.mark.parametrize("periodic_image", [False, True])
def test_overlap_projection_moves_a_pair_apart_symmetrically_to_the_target(periodic_image):
    """One overlapping pair (radii 1 and 0.5, centre distance 1.2, along (2, 1, -2)/3): one
    projection puts it at exactly target (r_i + r_j) = 1.5 (1 + 1e-10) along its line of centres,
    each sphere moved by half the correction, the midpoint kept; a second sweep finds no overlap
    (2 sweeps, status done); the reported worst overlap is 1 - 1.2/1.5 = 0.2.  Across the
    periodic boundary the minimum image is used.  A correction off by a factor 2 overshoots to
    1.8 or stops at 1.35."""
    box = np.full(3, 10.0)
    u = np.array([2.0, 1.0, -2.0]) / 3.0
    pi_ = np.array([4.0, 5.0, 5.0])
    if periodic_image:
        pi_ = np.array([9.7, 5.0, 5.0])
    pj_ = pi_ + 1.2 * u
    pos = np.array([pi_, pj_])
    if periodic_image:
        pos[1, 0] -= 10.0  # j stored on the other side of the box
    radii = np.array([1.0, 0.5])
    target = 1.0 + 1e-10
    lim = 1.5 * target
    status, sweeps, worst = V.separate(pos, radii, box, np.array([0], np.int64), np.array([1], np.int64), target, 10)
    assert status == V.SEPARATE_DONE and sweeps == 2
    assert worst == pytest.approx(0.2, rel=1e-12, abs=0)
    mid = 0.5 * (pi_ + pj_)
    exp_i, exp_j = mid - 0.5 * lim * u, mid + 0.5 * lim * u
    if periodic_image:
        exp_j[0] -= 10.0
    np.testing.assert_allclose(pos[0], exp_i, rtol=0, atol=1e-13)
    np.testing.assert_allclose(pos[1], exp_j, rtol=0, atol=1e-13)
