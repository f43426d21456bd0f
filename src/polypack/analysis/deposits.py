"""Statistics of deposits (2D disks, 3D spheres): packing fraction in a bulk window, height profiles, contacts.

For the packs of §2.4 of 001_ad5bae0acea940c4.txt (disks deposited on a floor, walls
or a periodic x axis, an open top).  The packing fraction ``ρ`` of Fig. 9 is measured
in a window that excludes a margin from the floor, the side walls and the free surface,
where the deposit is not representative of the bulk.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError
from ._base import Estimator, check_packing, to_jsonable

__all__ = ["DepositStatistics", "free_surface_height", "small_fraction_profile"]


def free_surface_height(packing, bin_width=None):
    """Lowest height of the free surface: ``min`` over footprint bins of the highest top.

    The footprint (x in 2D, x and y in 3D) is cut into bins of ``bin_width`` (default:
    twice the largest diameter); in each bin the highest top ``h + r`` (of the disks or
    spheres whose centre lies in the bin, ``h`` the last coordinate) is taken; the free
    surface's lowest point is the minimum over bins.
    """
    pos, rad = packing.positions, packing.radii
    dim = pos.shape[1]
    bw = 4.0 * float(rad.max()) if bin_width is None else float(bin_width)
    flat = np.zeros(rad.size, dtype=np.int64)
    nbt = 1
    for ax in range(dim - 1):
        L = float(packing.box[ax])
        nb = max(1, int(L // bw))
        b = np.clip((pos[:, ax] / L * nb).astype(np.int64), 0, nb - 1)
        flat = flat * nb + b
        nbt *= nb
    top = np.full(nbt, -np.inf)
    np.maximum.at(top, flat, pos[:, dim - 1] + rad)
    top = top[np.isfinite(top)]
    return float(top.min())


def _slab_volume(zc, r, z0, z1):
    """Exact volume of spheres ``(zc, r)`` between the planes ``z0 < z1`` (footprint unbounded)."""
    lo = np.clip(z0 - zc, -r, r)
    hi = np.clip(z1 - zc, -r, r)
    return float(np.sum(np.pi * (r * r * (hi - lo) - (hi**3 - lo**3) / 3.0)))


def _spheres_box_volume(pos, rad, lo, hi, L, xper, n_slices=256):
    """Volume of spheres inside ``[lo, hi]`` (3D, x possibly periodic), by Gauss-Legendre slices in z.

    Each slice is a set of disks whose areas inside the x-y rectangle are exact
    (:func:`polypack._kernels.deposit.disks_rectangle_area`); the z integral has a relative
    error of a few 1e-5 (square-root kinks where a slice disk meets a window edge).
    """
    from .._kernels.deposit import disks_rectangle_area

    t, w = np.polynomial.legendre.leggauss(n_slices)
    z = 0.5 * (hi[2] - lo[2]) * t + 0.5 * (hi[2] + lo[2])
    w = 0.5 * (hi[2] - lo[2]) * w
    total = 0.0
    xy = np.ascontiguousarray(pos[:, :2])
    for zk, wk in zip(z, w):
        d = zk - pos[:, 2]
        sel = np.abs(d) < rad
        if not sel.any():
            continue
        rr = np.sqrt(rad[sel] ** 2 - d[sel] ** 2)
        total += wk * disks_rectangle_area(np.ascontiguousarray(xy[sel]), np.ascontiguousarray(rr),
                                           lo[0], hi[0], lo[1], hi[1], L, xper)
    return total


def small_fraction_profile(packing, window=None, n_layers=8, split=None, blocks=3):
    """Small-sphere volume fraction against height, with standard errors and its slope (3D deposits).

    The measure of size segregation that seed 001 §1 (001_ad5bae0acea940c4.txt) describes in
    words ("accumulation of small particles at the bottom"): in each of ``n_layers``
    horizontal layers of the window, the volume of the spheres of radius below ``split``
    over the volume of all spheres (exact spherical slabs in z; each sphere's slab counted in
    the footprint block of its centre).  The footprint is cut into ``blocks x blocks``
    columns, taken as independent samples: the standard error of a layer is the spread of
    the columns' fractions over ``sqrt(blocks^2)``, and that of the slope (least squares over
    the layers) the spread of the columns' slopes over ``sqrt(blocks^2)`` (layers of one
    column are correlated; columns far apart are nearly not).

    Parameters
    ----------
    packing : Packing
        A 3D deposit (floor at z = 0).
    window : (z0, z1), optional
        Height range measured (default: ``4 d_max`` above the floor to ``4 d_max`` below the
        free surface's lowest point).
    n_layers : int
        Layers in the window (>= 2).
    split : float, optional
        Radius separating small from large (default: ``sqrt(r_min r_max)``, which splits a
        bidisperse mix between its two sizes).
    blocks : int
        Columns per footprint axis (>= 2).

    Returns
    -------
    dict
        ``height`` (layer centres), ``fraction``, ``fraction_err``, ``slope`` (per unit
        height), ``slope_err``, ``mean`` (whole window), ``split``, ``window``, ``blocks``.
    """
    pos = np.asarray(packing.positions, dtype=np.float64)
    rad = np.asarray(packing.radii, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] != 3:
        raise InvalidInputError("small_fraction_profile takes a 3D deposit")
    if int(n_layers) != n_layers or n_layers < 2:
        raise InvalidInputError(f"n_layers={n_layers!r} must be an integer >= 2")
    if int(blocks) != blocks or blocks < 2:
        raise InvalidInputError(f"blocks={blocks!r} must be an integer >= 2")
    dmax = 2.0 * float(rad.max())
    split = float(np.sqrt(rad.min() * rad.max())) if split is None else float(split)
    if not (rad.min() < split <= rad.max()):
        raise InvalidInputError(f"split={split!r} must lie in ({rad.min():g}, {rad.max():g}] (the radii's range)")
    if window is None:
        window = (4.0 * dmax, free_surface_height(packing) - 4.0 * dmax)
    z0, z1 = float(window[0]), float(window[1])
    if not z1 > z0:
        raise InvalidInputError(f"window=({z0:g}, {z1:g}) is empty: deposit more spheres or pass a window")
    edges = np.linspace(z0, z1, int(n_layers) + 1)
    box = np.asarray(packing.box, dtype=np.float64)
    bx = np.clip((pos[:, 0] / box[0] * blocks).astype(np.int64), 0, blocks - 1)
    by = np.clip((pos[:, 1] / box[1] * blocks).astype(np.int64), 0, blocks - 1)
    col = bx * blocks + by
    nb = blocks * blocks
    small = rad < split
    vs = np.zeros((nb, n_layers))
    va = np.zeros((nb, n_layers))
    zc, r = pos[:, 2], rad
    for j in range(n_layers):
        lo = np.clip(edges[j] - zc, -r, r)
        hi = np.clip(edges[j + 1] - zc, -r, r)
        v = np.pi * (r * r * (hi - lo) - (hi**3 - lo**3) / 3.0)
        va[:, j] = np.bincount(col, weights=v, minlength=nb)
        vs[:, j] = np.bincount(col, weights=v * small, minlength=nb)
    h = 0.5 * (edges[1:] + edges[:-1])
    frac = vs.sum(0) / va.sum(0)
    with np.errstate(invalid="ignore", divide="ignore"):
        fb = vs / va
    err = np.nanstd(fb, axis=0, ddof=1) / np.sqrt(np.sum(np.isfinite(fb), axis=0))
    hc = h - h.mean()
    slope = float(np.sum(hc * (frac - frac.mean())) / np.sum(hc * hc))
    sb = []
    for b in range(nb):
        ok = np.isfinite(fb[b])
        if ok.sum() >= 2:
            hh = h[ok] - h[ok].mean()
            sb.append(np.sum(hh * (fb[b, ok] - fb[b, ok].mean())) / np.sum(hh * hh))
    slope_err = float(np.std(sb, ddof=1) / np.sqrt(len(sb))) if len(sb) >= 2 else float("nan")
    return {"height": h, "fraction": frac, "fraction_err": err, "slope": slope, "slope_err": slope_err,
            "mean": float(vs.sum() / va.sum()), "split": split, "window": (z0, z1), "blocks": int(blocks)}


class DepositStatistics(Estimator):
    """Packing fraction, profiles and contacts of a deposit (2D disks or 3D spheres), in a bulk window.

    In 3D the window spans the footprint (minus the margin at walls) between the floor
    margin and the free surface; sphere volumes in it are exact for a periodic footprint
    (spherical slabs) and from 256 Gauss-Legendre slices of exact disk areas with walls
    (relative error a few 1e-5).

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
    small_split : float, optional
        3D: radius separating small from large spheres for the segregation profile
        (default ``sqrt(r_min r_max)``; see :func:`small_fraction_profile`).
    small_layers : int
        3D: layers of the window in the small-volume fraction profile (its slope and
        standard error are ``small_fraction_slope``, ``small_fraction_slope_err``).

    Results
    -------
    window : ``(x0, x1, y0, y1)`` (3D: ``(x0, x1, y0, y1, z0, z1)``);
    packing_fraction : exact disk area inside the window (circle-rectangle areas) over its area;
    coordination : mean contact number of the disks whose centres lie in the window;
    contact_shares : dict ``n -> share`` of disks (centre in window) with ``n`` contacts;
    profile_height, profile_fraction, profile_mean_diameter : height profiles (fraction in
    horizontal strips over the window's x range; number-mean diameter of the disks whose
    centres lie in each strip).
    With ``reset=False`` the scalars are averaged over realizations
    (``packing_fraction_err``: standard error between realizations).
    """

    def __init__(self, margin=None, contact_tolerance=1e-9, n_bins=40, small_split=None, small_layers=8):
        super().__init__()
        if small_split is not None:
            try:
                small_split = float(small_split)
            except (TypeError, ValueError):
                raise InvalidInputError(f"small_split={small_split!r} must be a radius > 0") from None
            if not np.isfinite(small_split) or small_split <= 0:
                raise InvalidInputError(f"small_split={small_split!r} must be a radius > 0")
        if int(small_layers) != small_layers or small_layers < 2:
            raise InvalidInputError(f"small_layers={small_layers!r} must be an integer >= 2")
        self.small_split = small_split
        self.small_layers = int(small_layers)
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

        check_packing(packing, min_n=2, what="DepositStatistics", dims=(2, 3), walls=True)
        if packing.periodic[-1]:
            raise InvalidInputError(
                "DepositStatistics needs a deposit: the vertical (last) axis must have a floor (periodic=(.., False))")
        if packing.dim == 3:
            return self._compute_3d(packing)
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
        return self._record(np.array([x0, x1, y0, y1]), rho, zin, shares, inside, edges, frac, mean_d)

    def _record(self, window, rho, zin, shares, inside, edges, frac, mean_d, small=None, small_frac=None):
        """Append one realization's frame (the same fields in 2D and 3D) and return self."""
        self._frames.append({
            "small": small,
            "small_fraction": small_frac,
            "window": window,
            "packing_fraction": np.array(rho),
            "coordination": np.array(zin.mean() if zin.size else np.nan),
            "shares": shares,
            "n_window": np.array(int(inside.sum())),
            "edges": edges,
            "fraction": frac,
            "mean_diameter": mean_d,
        })
        return self

    def _compute_3d(self, packing):
        from ..neighbors import pairs_within

        pos = np.array(packing.positions, dtype=np.float64)
        rad = np.ascontiguousarray(packing.radii, dtype=np.float64)
        per = list(packing.periodic[:2])
        box = np.array(packing.box, dtype=np.float64)
        swapped = bool(per[1] and not per[0])
        if swapped:  # the slice kernel takes a periodic x only: swap x and y
            pos[:, [0, 1]] = pos[:, [1, 0]]
            box[[0, 1]] = box[[1, 0]]
            per = [True, False]
        margin = 8.0 * float(rad.max()) if self.margin is None else self.margin
        lo = np.array([0.0 if per[0] else margin, 0.0 if per[1] else margin, margin])
        hi = np.array([box[0] if per[0] else box[0] - margin, box[1] if per[1] else box[1] - margin,
                       free_surface_height(packing) - margin])
        if np.any(hi <= lo):
            raise InvalidInputError(
                f"the window is empty: margin={margin:g} leaves [{lo[0]:g}, {hi[0]:g}] x [{lo[1]:g}, {hi[1]:g}] x "
                f"[{lo[2]:g}, {hi[2]:g}]; deposit more spheres or lower the margin")

        def volume(z0, z1):
            if per[0] and per[1]:
                return _slab_volume(pos[:, 2], rad, z0, z1)
            return _spheres_box_volume(pos, rad, np.array([lo[0], lo[1], z0]), np.array([hi[0], hi[1], z1]),
                                       float(box[0]), bool(per[0]))

        foot = (hi[0] - lo[0]) * (hi[1] - lo[1])
        rho = volume(lo[2], hi[2]) / (foot * (hi[2] - lo[2]))
        i, j, _ = pairs_within(np.asarray(packing.positions), rad, packing.box, a=1.0 + self.contact_tolerance,
                               b=0.0, periodic=packing.periodic)
        z = np.bincount(i, minlength=rad.size) + np.bincount(j, minlength=rad.size)
        inside = np.all((pos >= lo) & (pos <= hi), axis=1)
        zin = z[inside]
        counts = np.bincount(zin, minlength=14).astype(float)
        shares = counts / max(zin.size, 1)
        edges = np.linspace(0.0, float(box[2]), self.n_bins + 1)
        frac = np.empty(self.n_bins)
        mean_d = np.full(self.n_bins, np.nan)
        infoot = np.all((pos[:, :2] >= lo[:2]) & (pos[:, :2] <= hi[:2]), axis=1)
        for b in range(self.n_bins):
            frac[b] = volume(edges[b], edges[b + 1]) / (foot * (edges[b + 1] - edges[b]))
            sel = infoot & (pos[:, 2] >= edges[b]) & (pos[:, 2] < edges[b + 1])
            if sel.any():
                mean_d[b] = 2.0 * rad[sel].mean()
        window = np.array([lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]])
        if swapped:  # report the window in the pack's own axis order
            window = window[[2, 3, 0, 1, 4, 5]]
        small = small_frac = None
        if rad.min() < rad.max():
            # segregation: small-sphere volume share in the window's layers (slope, errors) and per strip
            small = small_fraction_profile(packing, window=(lo[2], hi[2]), n_layers=self.small_layers,
                                           split=self.small_split)
            cut = small["split"]
            zc = pos[:, 2]
            small_frac = np.full(self.n_bins, np.nan)
            for b in range(self.n_bins):
                lo_ = np.clip(edges[b] - zc, -rad, rad)
                hi_ = np.clip(edges[b + 1] - zc, -rad, rad)
                v = np.pi * (rad * rad * (hi_ - lo_) - (hi_**3 - lo_**3) / 3.0)
                if v.sum() > 0:
                    small_frac[b] = float(np.sum(v[rad < cut]) / v.sum())
        return self._record(window, rho, zin, shares, inside, edges, frac, mean_d, small, small_frac)

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

    @property
    def small_profile(self):
        """3D with two sizes or more: :func:`small_fraction_profile` over the window (last realization), else None."""
        self._require()
        return self._frames[-1]["small"]

    @property
    def profile_small_fraction(self):
        """3D: small-sphere volume share in each strip of the height profile (None in 2D or for one size)."""
        self._require()
        return self._frames[-1]["small_fraction"]

    def to_dict(self):
        out = {
            "window": self.window, "packing_fraction": self.packing_fraction,
            "packing_fraction_err": self.packing_fraction_err, "coordination": self.coordination,
            "contact_shares": self.contact_shares, "n_realizations": self.n_realizations,
            "profile": {"height": self.profile_height, "fraction": self.profile_fraction,
                        "mean_diameter": self.profile_mean_diameter},
        }
        sp = self.small_profile
        if sp is not None:
            out["profile"]["small_fraction"] = self.profile_small_fraction
            out["small_fraction_slope"] = sp["slope"]
            out["small_fraction_slope_err"] = sp["slope_err"]
            out["small_fraction_mean"] = sp["mean"]
            out["small_layers"] = {k: sp[k] for k in ("height", "fraction", "fraction_err", "split")}
        return to_jsonable(out)

    def plot(self, ax=None):
        """Height profiles of packing fraction (and mean diameter on a twin axis)."""
        ax = self._axes(ax)
        h = self.profile_height
        ax.plot(self.profile_fraction, h, "-o", ms=3, label="packing fraction")
        y0, y1 = self.window[-2:]
        ax.axhspan(y0, y1, color="0.9", zorder=0, label="measurement window")
        ax.set_xlabel("packing fraction of the horizontal strip (–)")
        ax.set_ylabel("height y (length unit of the radii)")
        ax2 = ax.twiny()
        ax2.plot(self.profile_mean_diameter, h, "--", color="C1", label="mean diameter")
        ax2.set_xlabel("number-mean diameter in the strip (length unit)")
        ax.legend(loc="lower left")
        return ax
