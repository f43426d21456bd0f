"""Radial distribution function g(r), partial g_km(r), contact values g(2a+).

Implements Eq. (4) of 000_2cedc098acbd866b.txt, Eq. (6) of 000_2cedc098acbd866b.txt and Eq. (14) of 000_2cedc098acbd866b.txt to Eq. (16) of 000_2cedc098acbd866b.txt with the toroidal
(periodic) edge correction, plus the scaled coordinate ``R_km`` of its §5.3.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError
from ..geometry import shell_measure, shell_volume
from ._base import PairCountEstimator, PairMap, check_packing, check_positive, to_jsonable
from ._paircounts import pair_counts, pair_norms, species_radii

__all__ = ["RDF", "contact_value", "scaled_coordinate", "size_classes"]

METHODS = ("histogram", "right", "central")


def scaled_coordinate(r, a_k, a_m):
    """Scaled distance ``R_km = (r - a^(k)) / a^(m) + 1`` of §5.3 of 000_2cedc098acbd866b.txt.

    Contact of a k sphere with an m sphere is at ``R_km = 2``; for one size
    ``R_km = r / a``.
    """
    return (np.asarray(r, dtype=np.float64) - a_k) / a_m + 1.0


def size_classes(packing, n_classes=None, edges=None, spacing="geometric"):
    """Copy of ``packing`` whose species are radius classes (for continuous distributions).

    Partial RDFs of a continuous size distribution are defined between size
    classes ("bins of species"); the contact-scaled RDF (``scale="contact"``) is the
    alternative without binning.

    Parameters
    ----------
    n_classes : int, optional
        Number of classes between the smallest and largest radius.
    edges : array_like, optional
        Explicit increasing class edges (radii); spheres outside go to the end classes.
    spacing : {"geometric", "linear"}
        Spacing of the ``n_classes`` edges.

    Returns
    -------
    Packing
        Species 0 is the *largest* class (seed 000 numbers the large spheres 1).
    """
    check_packing(packing, min_n=1, what="size_classes")
    rad = packing.radii
    if edges is None:
        if n_classes is None or int(n_classes) != n_classes or n_classes < 1:
            raise InvalidInputError(f"n_classes={n_classes!r} must be an integer >= 1 (or give edges)")
        lo, hi = float(rad.min()), float(rad.max())
        if spacing == "geometric":
            edges = np.geomspace(lo, hi, int(n_classes) + 1)
        elif spacing == "linear":
            edges = np.linspace(lo, hi, int(n_classes) + 1)
        else:
            raise InvalidInputError(f"spacing={spacing!r}: allowed are 'geometric' and 'linear'")
    edges = np.asarray(edges, dtype=np.float64)
    if edges.ndim != 1 or edges.size < 2 or np.any(np.diff(edges) <= 0):
        raise InvalidInputError("edges must be an increasing 1-D array of at least 2 radii")
    k = np.clip(np.searchsorted(edges, rad, side="right") - 1, 0, edges.size - 2)
    species = (edges.size - 2) - k
    used = np.unique(species)
    remap = np.full(edges.size - 1, -1, np.int64)
    remap[used] = np.arange(used.size)
    return packing.replace(species=remap[species])


class RDF(PairCountEstimator):
    """Radial distribution function and all partial RDFs of a periodic pack (spheres or disks).

    2D packs (disks) use circular shells (``2 pi r dr``, area ``pi (r_2^2 - r_1^2)``)
    and the box area; 3D packs spherical shells and the box volume.

    Parameters
    ----------
    r_max : float
        Largest distance (in the pack's length unit; in units of ``r_i + r_j`` when
        ``scale="contact"``). Must not exceed half the smallest box length.
    dr : float, optional
        Bin width / finite-difference step ``Delta r`` (> 0); ``r_max`` is rounded
        down to a whole number of steps.
    bins : int, optional
        Number of bins (alternative to ``dr``).
    method : {"histogram", "right", "central"}
        ``"histogram"``: counts in shells ``[r, r + dr)`` divided by the exact shell
        volume, reported at the shell centres. ``"right"``: the right difference
        g+(r, Delta r) of Eq. (14_2) of 000_2cedc098acbd866b.txt applied to the K
        function (reported at the inner radius r). ``"central"``: the central
        difference g±(r, Delta r) of Eq. (14_1) of 000_2cedc098acbd866b.txt, which at a discontinuity of K (a
        contact shell, e.g. r = 2a in a lattice) gives half of the right difference,
        Eq. (15) of 000_2cedc098acbd866b.txt to Eq. (16) of 000_2cedc098acbd866b.txt.
    scale : {"distance", "contact"}
        ``"contact"`` bins the contact-scaled distance ``d_ij / (r_i + r_j)`` of every
        pair (for continuous size distributions); contact is then at 1 for every pair.
    normalization : {"finite_size", "seed"}
        Ideal-gas pair number ``N_k (N_m - delta_km)`` (default; unbiased: a Poisson
        pattern of fixed N gives g = 1 on average; freud's ``"finite_size"`` mode) or
        ``N_k N_m`` as printed in Eq. (2) of 000_2cedc098acbd866b.txt and Eq. (5) of 000_2cedc098acbd866b.txt (biased low
        by ``1/N_m`` on the diagonal; freud's default ``"exact"`` mode).

    Notes
    -----
    The K function behind ``"right"`` and ``"central"`` counts pairs with
    ``d < r`` (the left limit of Eq. (2) of 000_2cedc098acbd866b.txt at exact lattice distances), so that a
    contact shell at ``r = 2a`` enters g+(2a, Delta r) as in §5.2 of the seed
    (simple cubic lattice: g+(2a, 0.1a) = 9.55).

    Partials: ``g_km(r) = V n_km(r) / (W_km v(r))`` with ``n_km`` the number of
    ordered pairs (i of species k, j of species m), ``v`` the shell volume and
    ``W_km`` the ideal pair number, Eq. (6) of 000_2cedc098acbd866b.txt. The total RDF uses all pairs, which
    equals the number-weighted sum of the partials. ``g_km == g_mk`` exactly.

    With ``reset=False`` the counts of all realizations are pooled; ``g_err`` is
    then the standard error of the mean over realizations. For one realization
    ``g_err`` is the Poisson counting error of the pair numbers (each unordered
    pair counted once).
    """

    def __init__(self, r_max, dr=None, bins=None, method="histogram", scale="distance", normalization="finite_size"):
        super().__init__(r_max, dr, bins, scale, normalization)
        if method not in METHODS:
            raise InvalidInputError(f"method={method!r}: allowed are {', '.join(map(repr, METHODS))}")
        self.method = method

    # --------------------------------------------------------------- compute
    def _fine(self):
        if self.method == "central":
            return 2 * self._nbins, 0.5 * self._dr
        return self._nbins, self._dr

    def compute(self, packing, reset=True):
        """Accumulate the pair counts of ``packing``; returns ``self``."""
        self._begin(packing, reset, "RDF")
        nfine, h = self._fine()
        ns = packing.n_species
        c = pair_counts(packing, nfine * h, nfine, self.scale).reshape(ns, ns, nfine)
        w, wtot = pair_norms(packing, self.scale, self.normalization)
        vol = packing.box_volume
        frame = {
            "counts": c,
            "dens": w / vol,  # ideal pair numbers per unit (scaled) volume
            "dens_total": wtot / vol,
            "a": species_radii(packing),
        }
        frame["g"], frame["g_total"] = self._estimate(c, frame["dens"], c.sum(axis=(0, 1)), frame["dens_total"])
        self._frames.append(frame)
        return self

    def _geometry(self):
        """Points r, the count-combining matrix and the volume per point."""
        nfine, h = self._fine()
        n = self._nbins
        if self.method == "histogram":
            edges = np.arange(n + 1) * h
            r = 0.5 * (edges[:-1] + edges[1:])
            vol = shell_volume(edges[:-1], edges[1:], self._dim)
            sel = [np.array([k]) for k in range(n)]
        elif self.method == "right":
            r = np.arange(1, n) * h
            vol = shell_measure(r, self._dim) * h
            sel = [np.array([k]) for k in range(1, n)]
        else:
            r = np.arange(1, n) * 2.0 * h
            vol = shell_measure(r, self._dim) * (2.0 * h)
            sel = [np.array([2 * k - 1, 2 * k]) for k in range(1, n)]
        idx = np.stack(sel)
        return r, idx, vol

    def _combine(self, counts):
        _, idx, _ = self._geometry()
        return counts[..., idx].sum(axis=-1)

    def _estimate(self, counts, dens, counts_total, dens_total):
        r, idx, vol = self._geometry()
        cp = counts[..., idx].sum(axis=-1)
        ct = counts_total[idx].sum(axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            g = cp / (dens[..., None] * vol)
            gt = ct / (dens_total * vol)
        return g, gt

    # --------------------------------------------------------------- results
    @property
    def r(self) -> np.ndarray:
        """Radii at which g is reported (shell centres for ``"histogram"``)."""
        return self._geometry()[0]

    @property
    def g(self) -> np.ndarray:
        """Total RDF g(r), pooled over realizations."""
        counts, dens, dens_t = self._pooled()
        return self._estimate(counts, dens, counts.sum(axis=(0, 1)), dens_t)[1]

    @property
    def partial(self) -> PairMap:
        """Partial RDFs ``g_km`` keyed by species pair ``(k, m)`` (both orders)."""
        counts, dens, dens_t = self._pooled()
        g = self._estimate(counts, dens, counts.sum(axis=(0, 1)), dens_t)[0]
        return PairMap.from_array(g, "RDF.partial")

    def _poisson_err(self, partial):
        counts, dens, dens_t = self._pooled()
        r, idx, vol = self._geometry()
        if partial:
            cp = counts[..., idx].sum(axis=-1).astype(np.float64)
            ns = cp.shape[0]
            diag = np.eye(ns, dtype=bool)[..., None]
            unordered = np.where(diag, cp / 2.0, cp)
            with np.errstate(divide="ignore", invalid="ignore"):
                rel = np.where(unordered > 0, 1.0 / np.sqrt(unordered), np.nan)
                return cp / (dens[..., None] * vol) * rel
        ct = counts.sum(axis=(0, 1))[idx].sum(axis=-1).astype(np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(ct > 0, 1.0 / np.sqrt(ct / 2.0), np.nan)
            return ct / (dens_t * vol) * rel

    @property
    def g_err(self) -> np.ndarray:
        """Standard error of g: between realizations if several, else Poisson."""
        self._require()
        if self.n_realizations >= 2:
            return self._stderr(self._stack("g_total"))
        return self._poisson_err(False)

    @property
    def partial_err(self) -> PairMap:
        """Standard errors of the partial RDFs (same convention as :attr:`g_err`)."""
        self._require()
        e = self._stderr(self._stack("g")) if self.n_realizations >= 2 else self._poisson_err(True)
        return PairMap.from_array(e, "RDF.partial_err")

    @property
    def species_radii(self) -> np.ndarray:
        """Mean radius ``a^(k)`` of each species (averaged over realizations)."""
        self._require()
        return np.nanmean(self._stack("a"), axis=0)

    @property
    def pair_counts(self) -> np.ndarray:
        """Pooled ordered-pair counts ``(K, K, n_points)`` behind each reported point."""
        return self._combine(self._pooled()[0])

    def R(self, k, m) -> np.ndarray:
        """Scaled coordinate ``R_km = (r - a^(k))/a^(m) + 1`` at the points :attr:`r`.

        For ``scale="contact"`` the reported ``x = d/(a_k + a_m)`` is first turned into
        the distance ``d`` with the species mean radii.
        """
        a = self.species_radii
        ns = a.shape[0]
        if not (0 <= int(k) < ns and 0 <= int(m) < ns):
            raise InvalidInputError(f"unknown species pair ({k}, {m}); species are 0..{ns - 1}")
        ak, am = a[int(k)], a[int(m)]
        d = self.r * (ak + am) if self.scale == "contact" else self.r
        return scaled_coordinate(d, ak, am)

    # ------------------------------------------------------------ reporting
    def to_dict(self) -> dict:
        """Plain JSON-able data: parameters, r, g, errors and all partials."""
        self._require()
        ns = self.species_radii.shape[0]
        part = self.partial
        perr = self.partial_err
        return to_jsonable(
            {
                "estimator": "RDF",
                "method": self.method,
                "scale": self.scale,
                "normalization": self.normalization,
                "r_max": self.r_max,
                "dr": self.dr,
                "n_realizations": self.n_realizations,
                "species_radii": self.species_radii,
                "r": self.r,
                "g": self.g,
                "g_err": self.g_err,
                "partial": {(k, m): part[(k, m)] for k in range(ns) for m in range(k, ns)},
                "partial_err": {(k, m): perr[(k, m)] for k in range(ns) for m in range(k, ns)},
            }
        )

    def plot(self, ax=None, partials=True, coordinate="r"):
        """Plot g(r) (and the partials); ``coordinate="R"`` plots each g_km vs R_km.

        Returns
        -------
        matplotlib.axes.Axes
        """
        self._require()
        if coordinate not in ("r", "R"):
            raise InvalidInputError(f"coordinate={coordinate!r}: allowed are 'r' and 'R'")
        ax = self._axes(ax)
        ns = self.species_radii.shape[0]
        if coordinate == "r":
            ax.plot(self.r, self.g, color="k", lw=1.5, label="total")
        if (partials and ns > 1) or coordinate == "R":
            part = self.partial
            for k in range(ns):
                for m in range(k, ns):
                    x = self.r if coordinate == "r" else self.R(k, m)
                    keep = x >= 0
                    lab = f"$g_{{{k}{m}}}$"
                    ax.plot(x[keep], part[(k, m)][keep], lw=1.0, label=lab)
        xl = {"r": "r / (a_i + a_j)" if self.scale == "contact" else "r", "R": "$R_{km}$"}[coordinate]
        ax.set_xlabel(xl)
        ax.set_ylabel("g")
        ax.axhline(1.0, color="0.6", lw=0.5)
        ax.legend()
        return ax


def contact_value(packing, pairs=None, width=0.05, n_bins=10, degree=1, return_error=False):
    """Contact values ``g_km(a_k + a_m)+`` per species pair by extrapolation to contact.

    The pairs with contact-scaled distance ``x = d_ij / (r_i + r_j)`` in
    ``[1, 1 + width)`` are histogrammed in ``n_bins`` left-closed bins (pairs with
    ``x`` within 1e-9 below 1, i.e. touching up to round-off, count as contact),
    converted to g in the contact-scaled coordinate (the ideal pair number uses the
    actual ``(r_i + r_j)^3`` of every pair, so polydisperse species are handled), and
    a polynomial of degree ``degree`` in ``x - 1`` is fitted by weighted least squares
    (weights from Poisson errors) and evaluated at ``x = 1``. This is the right limit
    g(2a+) of Eq. (11) of 000_2cedc098acbd866b.txt to Eq. (13) of 000_2cedc098acbd866b.txt.

    Use it to compare packs and to monitor convergence (e.g. of shaking); near
    jamming g diverges towards contact and a low-degree extrapolation over a finite
    window under-estimates the true limit: report ``width`` and ``degree`` with the
    numbers.

    Parameters
    ----------
    packing : Packing
    pairs : iterable of (k, m), optional
        Species pairs; default all pairs ``k <= m``.
    width : float
        Window in relative gap (default 0.05).
    n_bins : int
        Bins in the window (default 10).
    degree : int
        Polynomial degree; 0 gives the mean over the window.
    return_error : bool
        Also return the standard errors from the fit covariance.

    Returns
    -------
    dict ``{(k, m): value}`` (both orders), or ``(values, errors)``.
    """
    from ..neighbors import pairs_within

    check_packing(packing, min_n=2, what="contact_value", dims=(2, 3))
    width = check_positive("width", width)
    if int(n_bins) != n_bins or n_bins < degree + 1:
        raise InvalidInputError(f"n_bins={n_bins!r} must be an integer >= degree + 1 = {degree + 1}")
    n_bins = int(n_bins)
    if int(degree) != degree or degree < 0:
        raise InvalidInputError(f"degree={degree!r} must be an integer >= 0")
    ns = packing.n_species
    if pairs is None:
        pairs = [(k, m) for k in range(ns) for m in range(k, ns)]
    pairs = [(int(k), int(m)) for k, m in pairs]
    for k, m in pairs:
        if not (0 <= k < ns and 0 <= m < ns):
            raise InvalidInputError(f"unknown species pair ({k}, {m}); species are 0..{ns - 1}")
    i, j, d = pairs_within(packing.positions, packing.radii, packing.box, a=1.0 + width, b=0.0)
    x = d / (packing.radii[i] + packing.radii[j])
    x = np.where((x < 1.0) & (x >= 1.0 - 1e-9), 1.0, x)
    keep = (x >= 1.0) & (x < 1.0 + width)
    i, j, x = i[keep], j[keep], x[keep]
    si, sj = packing.species[i], packing.species[j]
    w, _ = pair_norms(packing, "contact", "finite_size")
    dens = w / packing.box_volume
    edges = 1.0 + np.linspace(0.0, width, n_bins + 1)
    vol = shell_volume(edges[:-1], edges[1:], packing.dim)
    centres = 0.5 * (edges[1:] + edges[:-1]) - 1.0
    values, errors = {}, {}
    for k, m in pairs:
        sel = ((si == k) & (sj == m)) | ((si == m) & (sj == k))
        cnt = np.histogram(x[sel], bins=edges)[0].astype(np.float64)
        ordered = cnt if k != m else 2.0 * cnt
        if dens[k, m] <= 0:
            val, err = np.nan, np.nan
        else:
            g = ordered / (dens[k, m] * vol)
            sig = np.sqrt(np.maximum(cnt, 1.0)) * g / np.maximum(cnt, 1.0)
            sig = np.where(cnt > 0, sig, (1.0 if k != m else 2.0) / (dens[k, m] * vol))
            if degree == 0:
                wts = 1.0 / sig**2
                val = float(np.sum(wts * g) / np.sum(wts))
                err = float(np.sqrt(1.0 / np.sum(wts)))
            else:
                coef, cov = np.polyfit(centres, g, degree, w=1.0 / sig, cov="unscaled")
                val = float(coef[-1])
                err = float(np.sqrt(cov[-1, -1]))
        values[(k, m)] = values[(m, k)] = val
        errors[(k, m)] = errors[(m, k)] = err
    if return_error:
        return values, errors
    return values


class ContactValueMonitor:
    """Convergence monitor for the generators: the contact values ``g_km(a_k + a_m)+`` of a pack.

    A callable ``monitor(packing) -> {"k-m": value}`` over the species pairs present,
    computed with :func:`contact_value`; pass it to :func:`polypack.shake` or
    :func:`polypack.scrm` (``monitor=``).  The generators never import the analysis
    layer; this object carries the estimator to them.

    Parameters
    ----------
    width, n_bins, degree
        Options of :func:`contact_value`; the default (linear extrapolation over a 5 %
        gap window) is what ``polypack run`` uses.  The seed's own estimator, the
        histogram value in ``[2a, 2a + 0.01a)`` (§5.1 of 000_2cedc098acbd866b.txt), is
        ``ContactValueMonitor(width=0.005, n_bins=1, degree=0)``.
    """

    name = "contact_value"

    def __init__(self, width=0.05, n_bins=10, degree=1):
        width = check_positive("width", width)
        if isinstance(n_bins, bool) or int(n_bins) != n_bins or n_bins < degree + 1:
            raise InvalidInputError(f"n_bins={n_bins!r} must be an integer >= degree + 1")
        if isinstance(degree, bool) or int(degree) != degree or degree < 0:
            raise InvalidInputError(f"degree={degree!r} must be an integer >= 0")
        self._options = {"width": width, "n_bins": int(n_bins), "degree": int(degree)}

    @property
    def options(self) -> dict:
        """The :func:`contact_value` options (a copy)."""
        return dict(self._options)

    def __call__(self, packing) -> dict:
        counts = np.bincount(packing.species, minlength=packing.n_species)
        present = [k for k in range(packing.n_species) if counts[k] > 0]
        pairs = [(k, m) for ki, k in enumerate(present) for m in present[ki:]]
        vals = contact_value(packing, pairs=pairs, **self._options)
        return {f"{k}-{m}": float(vals[(k, m)]) for k, m in pairs}

    def __repr__(self) -> str:
        o = self._options
        return f"ContactValueMonitor(width={o['width']!r}, n_bins={o['n_bins']}, degree={o['degree']})"
