"""Deposit statistics with one periodic side axis against a grid-counted window volume (issue 37).

The bulk-window packing fraction of §2.4 of 001_ad5bae0acea940c4.txt, for a 3D deposit whose
footprint is periodic along one axis and walled along the other: a hand-built set of spheres
(some across the periodic boundary, some across the window's edges) measured by
:class:`polypack.analysis.DepositStatistics` and by counting, on a fine grid of footprint
columns, the exact chord of every sphere (and its periodic images) inside the window.
"""

from __future__ import annotations

import numpy as np
import pytest

import polypack as pp
from polypack.analysis.deposits import free_surface_height

L_PER, L_WALL, H = 6.0, 5.0, 7.0
MARGIN = 1.0

# (periodic-axis coordinate, wall-axis coordinate, height, radius): no two spheres overlap
_SPHERES = np.array([
    [0.2, 2.5, 2.0, 0.6],  # across the periodic boundary (x < r)
    [5.9, 1.0, 3.5, 0.5],  # across the periodic boundary, and across the wall-side window edge y = 1
    [3.0, 2.5, 0.5, 0.5],  # on the floor, across the floor-side window edge z = 1
    [3.0, 2.6, 2.4, 0.8],
    [1.6, 4.1, 4.6, 0.7],  # across the far wall-side window edge y = 4
    [4.4, 3.6, 4.0, 0.45],
    [2.0, 0.9, 1.3, 0.4],
    [4.6, 1.6, 1.8, 0.55],
    [3.0, 2.5, 6.5, 0.5],  # tops of the deposit
    [0.5, 4.4, 6.4, 0.5],
    [4.5, 0.5, 6.45, 0.5],
])


def _grid_volume(xy, z, r, per_len, lo, hi, m=1500):
    """Volume of the spheres inside the box [lo, hi] (footprint axis 0 periodic with length per_len):
    midpoint rule on m x m footprint columns, exact chord in z per column."""
    gx = lo[0] + (np.arange(m) + 0.5) * (hi[0] - lo[0]) / m
    gy = lo[1] + (np.arange(m) + 0.5) * (hi[1] - lo[1]) / m
    X, Y = np.meshgrid(gx, gy, indexing="ij")
    vol = 0.0
    for (cx, cy), cz, rr in zip(xy, z, r):
        for img in (-per_len, 0.0, per_len):
            rho2 = (X - cx - img) ** 2 + (Y - cy) ** 2
            inside = rho2 < rr * rr
            if not inside.any():
                continue
            half = np.sqrt(rr * rr - rho2[inside])
            top = np.minimum(cz + half, hi[2])
            bot = np.maximum(cz - half, lo[2])
            vol += float(np.sum(np.clip(top - bot, 0.0, None)))
    return vol * (hi[0] - lo[0]) * (hi[1] - lo[1]) / m / m


@pytest.mark.parametrize("periodic_axis", [0, 1])
def test_window_fraction_with_one_periodic_side_axis_equals_the_grid_count(periodic_axis):
    """The window spans the whole periodic axis, the wall axis minus the margin at both walls and
    the height from the margin to the free surface's lowest point minus the margin; the fraction
    agrees with the grid count to 2e-4 (grid error ~1e-5 measured).  Periodic axis x or y (the
    estimator swaps y to x internally): the same spheres, the same fraction, and the window
    reported in the pack's own axis order (it came back in the swapped order before issue 37)."""
    s = _SPHERES
    xy = s[:, :2]
    if periodic_axis == 1:
        pos = np.c_[s[:, 1], s[:, 0], s[:, 2]]
        box = [L_WALL, L_PER, H]
        per = (False, True, False)
    else:
        pos = s[:, :3].copy()
        box = [L_PER, L_WALL, H]
        per = (True, False, False)
    pk = pp.Packing(pos, s[:, 3], box, periodic=per)
    st = pp.analysis.DepositStatistics(margin=MARGIN).compute(pk)
    top = free_surface_height(pk) - MARGIN
    assert top > 4.5
    w = st.window
    lo = np.array([0.0, MARGIN, MARGIN])
    hi = np.array([L_PER, L_WALL - MARGIN, top])
    if periodic_axis == 1:
        np.testing.assert_allclose(w, (MARGIN, L_WALL - MARGIN, 0.0, L_PER, MARGIN, top), rtol=1e-12)
    else:
        np.testing.assert_allclose(w, (0.0, L_PER, MARGIN, L_WALL - MARGIN, MARGIN, top), rtol=1e-12)
    vol = _grid_volume(xy, s[:, 2], s[:, 3], L_PER, lo, hi)
    expected = vol / np.prod(hi - lo)
    assert 0.05 < expected < 0.5
    assert st.packing_fraction == pytest.approx(expected, rel=2e-4, abs=0)
    # spheres whose centres lie in the window (the coordination's population)
    inside = (s[:, 1] >= lo[1]) & (s[:, 1] <= hi[1]) & (s[:, 2] >= lo[2]) & (s[:, 2] <= hi[2])
    assert st.n_window == int(inside.sum())
