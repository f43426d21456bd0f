"""Statistics of 2D deposits: packing fraction in a bulk window, height profiles, contacts.

For the packs of §2.4 of 001_ad5bae0acea940c4.txt (disks deposited on a floor, walls
or a periodic x axis, an open top).  The packing fraction ``ρ`` of Fig. 9 is measured
in a window that excludes a margin from the floor, the side walls and the free surface,
where the deposit is not representative of the bulk.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError
from ._base import Estimator, check_packing, to_jsonable

__all__ = ["DepositStatistics", "free_surface_height"]


def free_surface_height(packing, bin_width=None):
    """Lowest height of the free surface: ``min`` over x-bins of the highest disk top.

    The x axis is cut into bins of ``bin_width`` (default: twice the largest diameter);
    in each bin the highest disk top ``y + r`` (of disks whose centre lies in the bin)
    is taken; the free surface's lowest point is the minimum over bins.
    """
    pos, rad = packing.positions, packing.radii
    width = float(packing.box[0])
    bw = 4.0 * float(rad.max()) if bin_width is None else float(bin_width)
    nb = max(1, int(width // bw))
    b = np.minimum((pos[:, 0] / width * nb).astype(np.int64), nb - 1)
    top = np.full(nb, -np.inf)
    np.maximum.at(top, b, pos[:, 1] + rad)
    return float(top.min())


class DepositStatistics(Estimator):
    """Packing fraction, profiles and contacts of a 2D deposit, in a bulk window.

    Parameters
    ----------
    margin : float, optional
        Distance excluded from the floor, from each side wall (walls only) and below the
        free surface's lowest point (:func:`free_surface_height`).  Default: ``4 d_max``
        (four largest diameters), enough for the first-layer ordering at the floor and the
        unfinished top layer.
    contact_tolerance : float
        Relative gap below which two disks touch (deposits are exact: 1e-9 default).
    n_bins : int
        Height bins of the profiles (over the whole deposit height).

    Results
    -------
    window : ``(x0, x1, y0, y1)``;
    packing_fraction : exact disk area inside the window (circle-rectangle areas) over its area;
    coordination : mean contact number of the disks whose centres lie in the window;
    contact_shares : dict ``n -> share`` of disks (centre in window) with ``n`` contacts;
    profile_height, profile_fraction, profile_mean_diameter : height profiles (fraction in
    horizontal strips over the window's x range; number-mean diameter of the disks whose
    centres lie in each strip).
    With ``reset=False`` the scalars are averaged over realizations
    (``packing_fraction_err``: standard error between realizations).
    """

    def __init__(self, margin=None, contact_tolerance=1e-9, n_bins=40):
        super().__init__()
        if margin is not None:
            try:
                margin = float(margin)
            except (TypeError, ValueError):
                raise InvalidInputError(f"margin={margin!r} must be a number >= 0") from None
            if not np.isfinite(margin) or margin < 0:
                raise InvalidInputError(f"margin={margin!r} must be finite and >= 0")
        tol = float(contact_tolerance)
        if not np.isfinite(tol) or tol < 0:
            raise InvalidInputError(f"contact_tolerance={contact_tolerance!r} must be finite and >= 0")
        if int(n_bins) != n_bins or n_bins < 1:
            raise InvalidInputError(f"n_bins={n_bins!r} must be an integer >= 1")
        self.margin = margin
        self.contact_tolerance = tol
        self.n_bins = int(n_bins)

    def compute(self, packing, reset=True):
        """Measure ``packing`` (2D, x periodic or walls, y walls: floor and top); returns ``self``."""
        from .._kernels.deposit import disks_rectangle_area
        from ..neighbors import pairs_within

        check_packing(packing, min_n=2, what="DepositStatistics", dims=(2,), walls=True)
        if packing.periodic[1]:
            raise InvalidInputError("DepositStatistics needs a deposit: the y axis must have a floor (periodic=(.., False))")
        if reset:
            self.reset()
        pos = np.ascontiguousarray(packing.positions, dtype=np.float64)
        rad = np.ascontiguousarray(packing.radii, dtype=np.float64)
        width = float(packing.box[0])
        xper = bool(packing.periodic[0])
        margin = 8.0 * float(rad.max()) if self.margin is None else self.margin
        x0, x1 = (0.0, width) if xper else (margin, width - margin)
        y0 = margin
        y1 = free_surface_height(packing) - margin
        if x1 <= x0 or y1 <= y0:
            raise InvalidInputError(
                f"the window is empty: margin={margin:g} leaves x in [{x0:g}, {x1:g}], y in [{y0:g}, {y1:g}]; "
                "deposit more disks or lower the margin")
        area = disks_rectangle_area(pos, rad, x0, x1, y0, y1, width, xper)
        rho = area / ((x1 - x0) * (y1 - y0))
        # contacts
        i, j, _ = pairs_within(pos, rad, packing.box, a=1.0 + self.contact_tolerance, b=0.0,
                               periodic=packing.periodic)
        z = np.bincount(i, minlength=rad.size) + np.bincount(j, minlength=rad.size)
        inside = (pos[:, 0] >= x0) & (pos[:, 0] <= x1) & (pos[:, 1] >= y0) & (pos[:, 1] <= y1)
        zin = z[inside]
        counts = np.bincount(zin, minlength=8).astype(float)
        shares = counts / max(zin.size, 1)
        # profiles over the whole height
        top = float(packing.box[1])
        edges = np.linspace(0.0, top, self.n_bins + 1)
        frac = np.empty(self.n_bins)
        mean_d = np.full(self.n_bins, np.nan)
        for b in range(self.n_bins):
            a = disks_rectangle_area(pos, rad, x0, x1, edges[b], edges[b + 1], width, xper)
            frac[b] = a / ((x1 - x0) * (edges[b + 1] - edges[b]))
            sel = (pos[:, 1] >= edges[b]) & (pos[:, 1] < edges[b + 1]) & (pos[:, 0] >= x0) & (pos[:, 0] <= x1)
            if sel.any():
                mean_d[b] = 2.0 * rad[sel].mean()
        self._frames.append({
            "window": np.array([x0, x1, y0, y1]),
            "packing_fraction": np.array(rho),
            "coordination": np.array(zin.mean() if zin.size else np.nan),
            "shares": shares,
            "n_window": np.array(int(inside.sum())),
            "edges": edges,
            "fraction": frac,
            "mean_diameter": mean_d,
        })
        return self

    # ------------------------------------------------------------------ results
    @property
    def window(self):
        self._require()
        return tuple(float(v) for v in self._frames[-1]["window"])

    @property
    def packing_fraction(self) -> float:
        self._require()
        return float(np.mean(self._stack("packing_fraction")))

    @property
    def packing_fraction_err(self) -> float:
        self._require()
        return float(self._stderr(self._stack("packing_fraction")[:, None])[0])

    @property
    def coordination(self) -> float:
        self._require()
        return float(np.mean(self._stack("coordination")))

    @property
    def n_window(self) -> int:
        """Disks whose centres lie in the window (last realization)."""
        self._require()
        return int(self._frames[-1]["n_window"])

    @property
    def contact_shares(self) -> dict:
        self._require()
        m = max(f["shares"].size for f in self._frames)
        acc = np.zeros(m)
        for f in self._frames:
            acc[: f["shares"].size] += f["shares"]
        acc /= len(self._frames)
        return {int(k): float(v) for k, v in enumerate(acc) if v > 0}

    @property
    def profile_height(self):
        """Bin centres of the last realization's height profile."""
        self._require()
        e = self._frames[-1]["edges"]
        return 0.5 * (e[1:] + e[:-1])

    @property
    def profile_fraction(self):
        self._require()
        return self._frames[-1]["fraction"]

    @property
    def profile_mean_diameter(self):
        self._require()
        return self._frames[-1]["mean_diameter"]

    def to_dict(self):
        return to_jsonable({
            "window": self.window, "packing_fraction": self.packing_fraction,
            "packing_fraction_err": self.packing_fraction_err, "coordination": self.coordination,
            "contact_shares": self.contact_shares, "n_realizations": self.n_realizations,
            "profile": {"height": self.profile_height, "fraction": self.profile_fraction,
                        "mean_diameter": self.profile_mean_diameter},
        })

    def plot(self, ax=None):
        """Height profiles of packing fraction (and mean diameter on a twin axis)."""
        ax = self._axes(ax)
        h = self.profile_height
        ax.plot(self.profile_fraction, h, "-o", ms=3, label="packing fraction")
        x0, x1, y0, y1 = self.window
        ax.axhspan(y0, y1, color="0.9", zorder=0, label="measurement window")
        ax.set_xlabel("packing fraction of the horizontal strip (–)")
        ax.set_ylabel("height y (length unit of the radii)")
        ax2 = ax.twiny()
        ax2.plot(self.profile_mean_diameter, h, "--", color="C1", label="mean diameter")
        ax2.set_xlabel("number-mean diameter in the strip (length unit)")
        ax.legend(loc="lower left")
        return ax
