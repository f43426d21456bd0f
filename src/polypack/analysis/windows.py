"""Window counts p(n_h) (Fig. 4) and the shell count I(r) (Eq. (18) of 000_2cedc098acbd866b.txt, Fig. 7) of
000_2cedc098acbd866b.txt."""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError
from ._base import Estimator, GridEstimator, PairMap, check_packing, check_positive, check_r_max, to_jsonable
from ._paircounts import kernel_frame, pair_counts, species_radii

__all__ = ["WindowCounts", "ShellCount", "lattice_shell_count"]

_JACK_BLOCKS = 3  # spatial blocks per axis of the single-realization jackknife of p_err


class WindowCounts(Estimator):
    """Histogram p(n_h) of the number of sphere centres in a window around each sphere.

    Periodic 3D packs or 2D packs (the window is then a disk).  The window around a
    sphere of species k is a ball of radius
    ``window_radius * a^(k)`` centred on it (Fig. 4 of 000_2cedc098acbd866b.txt uses
    ``r_h = 2.5 a``); ``n_h`` counts the *other* centres inside (``d <= r_h``), plus
    the centre sphere itself if ``include_self``.

    Parameters
    ----------
    window_radius : float
        ``R_h``, in units of the reference radius (dimensionless, > 0).
    reference : {"species", "sphere"}
        ``a^(k)`` is the mean radius of the sphere's species (seed convention) or,
        for continuous size distributions, the sphere's own radius.
    include_self : bool
        Count the central sphere (default False).

    Results
    -------
    n_h, p : the values 0..max and their fractions over all windows (pooled);
    p_err : standard error (between realizations if several, else a delete-one jackknife
    over 3 blocks per axis of the box: neighbouring windows overlap, so their
    counts are correlated and the binomial ``sqrt(p (1 - p) / N)`` would be 10-30 %
    too small for Poisson points and worse in the tails);
    partial[(k, m)] : p of the number of m centres around k spheres;
    mean, variance : of n_h.
    """

    def __init__(self, window_radius=2.5, reference="species", include_self=False):
        super().__init__()
        self.window_radius = check_positive("window_radius", window_radius)
        if reference not in ("species", "sphere"):
            raise InvalidInputError(f"reference={reference!r}: allowed are 'species' and 'sphere'")
        self.reference = reference
        self.include_self = bool(include_self)

    def compute(self, packing, reset=True):
        """Count the centres in the window of every sphere; returns ``self``."""
        from .._kernels import analysis as kern

        check_packing(packing, min_n=1, what="WindowCounts", dims=(2, 3))
        if reset:
            self.reset()
        a = species_radii(packing)[packing.species] if self.reference == "species" else packing.radii
        window = np.ascontiguousarray(self.window_radius * a, dtype=np.float64)
        check_r_max(float(window.max()), packing.box, what="window radius R_h a")
        pos, box, nc = kernel_frame(packing, 0.5 * float(np.percentile(window, 10)))
        ns = packing.n_species
        cnt = kern.window_counts(
            pos, np.ascontiguousarray(packing.radii),
            np.ascontiguousarray(packing.species, dtype=np.int64), box, ns, window, nc,
        )
        if self.include_self:
            cnt[np.arange(packing.n), packing.species] += 1
        g = np.minimum((packing.positions / packing.box * _JACK_BLOCKS).astype(np.int64), _JACK_BLOCKS - 1)
        block = np.ravel_multi_index(tuple(g.T), (_JACK_BLOCKS,) * g.shape[1])
        self._frames.append({"counts": cnt, "species": np.array(packing.species, dtype=np.int64), "ns": ns,
                             "block": block})
        return self

    def _all(self):
        self._require()
        ns = max(f["ns"] for f in self._frames)
        cnts, sps = [], []
        for f in self._frames:
            c = np.zeros((f["counts"].shape[0], ns), np.int64)
            c[:, : f["ns"]] = f["counts"]
            cnts.append(c)
            sps.append(f["species"])
        return cnts, sps, ns

    @property
    def counts(self) -> np.ndarray:
        """``n_h`` of every window (all realizations concatenated)."""
        cnts, _, _ = self._all()
        return np.concatenate([c.sum(axis=1) for c in cnts])

    @property
    def n_h(self) -> np.ndarray:
        return np.arange(int(self.counts.max()) + 1)

    @property
    def p(self) -> np.ndarray:
        """Fraction of windows with ``n_h`` centres."""
        c = self.counts
        return np.bincount(c, minlength=c.max() + 1) / c.size

    @property
    def p_err(self) -> np.ndarray:
        cnts, _, _ = self._all()
        size = int(self.counts.max()) + 1
        if len(cnts) >= 2:
            per = np.stack([np.bincount(c.sum(axis=1), minlength=size)[:size] / c.shape[0] for c in cnts])
            return self._stderr(per)
        # one realization: delete-one jackknife over spatial blocks (windows are correlated)
        nh = np.minimum(cnts[0].sum(axis=1), size - 1)
        nb = int(self._frames[0]["block"].max()) + 1
        c = np.zeros((nb, size))
        np.add.at(c, (self._frames[0]["block"], nh), 1.0)
        per_block = c.sum(axis=1)
        used = per_block > 0
        c, per_block = c[used], per_block[used]
        b = c.shape[0]
        if b < 2:
            p = self.p
            return np.sqrt(p * (1 - p) / self.counts.size)
        with np.errstate(invalid="ignore", divide="ignore"):
            pj = (c.sum(axis=0)[None] - c) / (per_block.sum() - per_block)[:, None]
        return np.sqrt((b - 1) / b * np.sum((pj - pj.mean(axis=0)) ** 2, axis=0))

    @property
    def mean(self) -> float:
        return float(self.counts.mean())

    @property
    def variance(self) -> float:
        return float(self.counts.var())

    @property
    def partial(self) -> PairMap:
        """``p`` of the number of species-m centres in windows around species-k spheres."""
        cnts, sps, ns = self._all()
        size = int(self.counts.max()) + 1
        out = {}
        for k in range(ns):
            for m in range(ns):
                vals = np.concatenate([c[s == k, m] for c, s in zip(cnts, sps)])
                out[(k, m)] = (
                    np.bincount(vals, minlength=size)[:size] / vals.size if vals.size else np.full(size, np.nan)
                )
        return PairMap(out, "WindowCounts.partial")

    def to_dict(self) -> dict:
        part = self.partial
        ns = int(np.sqrt(len(part)))
        return to_jsonable(
            {
                "estimator": "WindowCounts",
                "window_radius": self.window_radius,
                "reference": self.reference,
                "include_self": self.include_self,
                "n_realizations": self.n_realizations,
                "n_h": self.n_h,
                "p": self.p,
                "p_err": self.p_err,
                "mean": self.mean,
                "variance": self.variance,
                "partial": {(k, m): part[(k, m)] for k in range(ns) for m in range(ns)},
            }
        )

    def plot(self, ax=None, label=None):
        """Histogram p(n_h) as in Fig. 4 of 000_2cedc098acbd866b.txt; returns the Axes."""
        ax = self._axes(ax)
        ax.plot(self.n_h, self.p, marker="o", ms=3, lw=1.0, label=label or f"$R_h$ = {self.window_radius:g}")
        ax.set_xlabel("$n_h$")
        ax.set_ylabel("$p(n_h)$")
        ax.legend()
        return ax


class ShellCount(GridEstimator):
    """Mean number of centres in the shell ``[r, r + dr)`` around a sphere, Eq. (18) of 000_2cedc098acbd866b.txt.

    ``I(r, Delta r) = 4 pi n r^2 Delta r g+(r, Delta r)`` of 000_2cedc098acbd866b.txt
    with ``n = N / V``: the delta functions of a lattice RDF are integrated out and
    I is the integer shell population (6 at ``r = 2a`` for simple cubic, Fig. 7).
    2D packs are accepted (``2 pi n r Delta r g+``; 6 at ``r = 2a`` for the triangular lattice).
    ``partial[(k, m)]`` counts m centres around k spheres.
    """

    def compute(self, packing, reset=True):
        check_packing(packing, min_n=2, what="ShellCount", dims=(2, 3))
        if reset:
            self.reset()
        ns = packing.n_species
        c = pair_counts(packing, self._r_max, self._nbins, "distance").reshape(ns, ns, self._nbins)
        self._frames.append({"counts": c, "nk": packing.species_counts.astype(np.float64)})
        return self

    @property
    def r(self) -> np.ndarray:
        """Inner radii of the shells."""
        return np.arange(self._nbins) * self._dr

    @property
    def I(self) -> np.ndarray:  # noqa: E743 - the seed's name
        self._require()
        return self._sum("counts").sum(axis=(0, 1)) / self._sum("nk").sum()

    @property
    def cumulative(self) -> np.ndarray:
        """Mean number of neighbours closer than ``r + dr``."""
        return np.cumsum(self.I)

    @property
    def partial(self) -> PairMap:
        self._require()
        c = self._sum("counts")
        nk = self._sum("nk")
        with np.errstate(divide="ignore", invalid="ignore"):
            return PairMap.from_array(c / nk[:, None, None], "ShellCount.partial")

    def to_dict(self) -> dict:
        return to_jsonable(
            {"estimator": "ShellCount", "dr": self._dr, "r_max": self._r_max, "r": self.r, "I": self.I}
        )

    def plot(self, ax=None, a=None):
        """I(r) vs r (or vs r/a when the radius ``a`` is given), as Fig. 7."""
        ax = self._axes(ax)
        x = self.r if a is None else self.r / a
        ax.plot(x, self.I, lw=1.0)
        ax.set_xlabel("r" if a is None else "r / a")
        ax.set_ylabel("I(r)")
        return ax


def lattice_shell_count(packing, r_max, dr):
    """``(r, I)`` of Eq. (18) of 000_2cedc098acbd866b.txt; see :class:`ShellCount`."""
    s = ShellCount(r_max, dr=dr).compute(packing)
    return s.r, s.I
