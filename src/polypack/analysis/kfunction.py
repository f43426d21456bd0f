"""Ripley's K function K(r) and the partial K_km(r) with toroidal edge correction.

Eq. (2) of 000_2cedc098acbd866b.txt and Eq. (5) of 000_2cedc098acbd866b.txt: in a periodic box the toroidal
correction has ``w_ij = 1`` and every sphere sees all its neighbours through the
minimum image.
"""

from __future__ import annotations

import numpy as np

from ..geometry import ball_volume
from ._base import PairCountEstimator, PairMap, to_jsonable
from ._paircounts import pair_counts, pair_norms

__all__ = ["KFunction"]


class KFunction(PairCountEstimator):
    """Second-order intensity (Ripley's K) function, total and per species pair.

    Parameters
    ----------
    r_max : float
        Largest radius (at most half the smallest box length).
    dr : float, optional
        Grid step; K is reported at ``r = dr, 2 dr, ..., r_max``.
    bins : int, optional
        Number of grid steps (alternative to ``dr``).
    scale : {"distance", "contact"}
        ``"contact"``: K of the contact-scaled distance ``d_ij / (r_i + r_j)``, with
        the ideal pair number weighted by ``(r_i + r_j)^3`` (Poisson: ``4 pi x^3 / 3``).
    normalization : {"finite_size", "seed"}
        ``V / (N_k (N_m - delta_km))`` (default, unbiased: a Poisson pattern of fixed
        N gives ``E K = 4 pi r^3 / 3``) or ``V / (N_k N_m)`` as printed in Eq. (2) of 000_2cedc098acbd866b.txt and Eq. (5) of 000_2cedc098acbd866b.txt.

    Notes
    -----
    ``K_km(r) = V / W_km * #{(i, j): i in k, j in m, j != i, d_ij < r}`` with
    ``W_km`` the ideal pair number. At exact lattice distances this is the left
    limit of Eq. (2) of 000_2cedc098acbd866b.txt (which counts ``d_ij <= r``); for random packs the two agree
    with probability one. The mean number of m neighbours of a k sphere within r
    is ``(N_m - delta_km) K_km(r) / V``.
    """

    _count_key = "cum"

    def compute(self, packing, reset=True):
        """Accumulate the pair counts of ``packing``; returns ``self``."""
        self._begin(packing, reset, "KFunction")
        ns = packing.n_species
        c = pair_counts(packing, self._r_max, self._nbins, self.scale).reshape(ns, ns, self._nbins)
        cum = np.cumsum(c, axis=-1)
        w, wtot = pair_norms(packing, self.scale, self.normalization)
        vol = packing.box_volume
        frame = {"cum": cum, "dens": w / vol, "dens_total": wtot / vol}
        with np.errstate(divide="ignore", invalid="ignore"):
            frame["K"] = cum / frame["dens"][..., None]
            frame["K_total"] = cum.sum(axis=(0, 1)) / frame["dens_total"]
        self._frames.append(frame)
        return self

    @property
    def r(self) -> np.ndarray:
        """Grid ``dr, 2 dr, ..., r_max``."""
        return np.arange(1, self._nbins + 1) * self._dr

    @property
    def K(self) -> np.ndarray:
        """Total K(r), pooled over realizations."""
        cum, _, dens_t = self._pooled()
        return cum.sum(axis=(0, 1)) / dens_t

    @property
    def partial(self) -> PairMap:
        """Partial ``K_km(r)`` keyed by species pair (both orders)."""
        cum, dens, _ = self._pooled()
        with np.errstate(divide="ignore", invalid="ignore"):
            k = cum / dens[..., None]
        return PairMap.from_array(k, "KFunction.partial")

    @property
    def L(self) -> np.ndarray:
        """Besag's ``L(r) = (3 K(r) / 4 pi)^(1/3)`` (2D: ``sqrt(K / pi)``; equals r for a Poisson process)."""
        return _besag(self.K, self._dim)

    @property
    def K_err(self) -> np.ndarray:
        """Standard error of K: between realizations if several, else Poisson counting."""
        self._require()
        if self.n_realizations >= 2:
            return self._stderr(self._stack("K_total"))
        cum, _, dens_t = self._pooled()
        tot = cum.sum(axis=(0, 1)).astype(np.float64)
        return np.sqrt(2.0 * tot) / dens_t

    @property
    def poisson(self) -> np.ndarray:
        """``4 pi r^3 / 3`` (2D: ``pi r^2``), K of a Poisson process at :attr:`r`."""
        self._require()
        return ball_volume(self.r, self._dim)

    def to_dict(self) -> dict:
        self._require()
        part = self.partial
        ns = int(np.sqrt(len(part)))
        return to_jsonable(
            {
                "estimator": "KFunction",
                "scale": self.scale,
                "normalization": self.normalization,
                "r_max": self.r_max,
                "dr": self.dr,
                "n_realizations": self.n_realizations,
                "r": self.r,
                "K": self.K,
                "K_err": self.K_err,
                "partial": {(a, b): part[(a, b)] for a in range(ns) for b in range(a, ns)},
            }
        )

    def plot(self, ax=None, partials=True, centred=True):
        """Plot K (or, with ``centred=True``, ``L(r) - r``, which is 0 for Poisson).

        Returns
        -------
        matplotlib.axes.Axes
        """
        self._require()
        ax = self._axes(ax)
        r = self.r

        def tr(k):
            return _besag(k, self._dim) - r if centred else k

        ax.plot(r, tr(self.K), color="k", lw=1.5, label="total")
        part = self.partial
        ns = int(np.sqrt(len(part)))
        if partials and ns > 1:
            for a in range(ns):
                for b in range(a, ns):
                    ax.plot(r, tr(part[(a, b)]), lw=1.0, label=f"$K_{{{a}{b}}}$")
        if centred:
            ax.axhline(0.0, color="0.6", lw=0.5)
            ax.set_ylabel("L(r) - r")
        else:
            ax.plot(r, self.poisson, color="0.6", ls="--", lw=0.8, label="Poisson")
            ax.set_ylabel("K(r)")
        ax.set_xlabel("r / (a_i + a_j)" if self.scale == "contact" else "r")
        ax.legend()
        return ax


def _besag(k, dim):
    """Besag's L transform: the radius of the ball of volume K (``dim`` 3 or 2)."""
    if dim == 3:
        return np.cbrt(3.0 * k / (4.0 * np.pi))
    return np.sqrt(np.asarray(k, dtype=np.float64) / np.pi)
