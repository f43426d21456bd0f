"""Size classes and a representative discrete set of sizes, §1.2 of 001_ad5bae0acea940c4.txt.

Steps (Eq. (6) of 001_ad5bae0acea940c4.txt to Eq. (11) of 001_ad5bae0acea940c4.txt): split ``[d_min, d_max]`` into ``N_c`` classes (regular, geometric
Eq. (11) of 001_ad5bae0acea940c4.txt or isochoric); uncumulate the grading curve into class volume fractions
``f_v^i`` (Eq. (6) of 001_ad5bae0acea940c4.txt); estimate the particles per unit volume of each class from its
median diameter under the uniform-by-volume law (Eq. (7) of 001_ad5bae0acea940c4.txt); scale so the poorest class
holds ``N_{p/c}^min`` particles (Eq. (8) of 001_ad5bae0acea940c4.txt) and the total reaches ``N_p^min`` (Eq. (9) of 001_ad5bae0acea940c4.txt);
refuse totals above the accessibility limit ``N_p^max`` (§2.3); finally draw the sizes of
each class from the uniform-by-volume law of the class (Eq. (4) of 001_ad5bae0acea940c4.txt).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._util import as_seed_sequence, seed_record
from .. import _validate as _v
from ..errors import InfeasibleError, InvalidInputError
from .models import Mixture, SizeDistribution, uv_mean_volume, uv_ppf

__all__ = ["SPACINGS", "class_bounds", "class_volume_fractions", "ClassCounts", "class_counts", "discretize"]

SPACINGS = ("geometric", "regular", "isochoric", "modes")
COUNT_BASES = ("median", "mean")


def _check_int(name, v, lo=1):
    """An integer ``>= lo`` (the shared check of :mod:`polypack._validate`)."""
    return int(_v.check(name, v, _v.int_min(lo)))


def class_bounds(model, n_classes=10, spacing="geometric"):
    """Class boundaries ``d_min = b_0 < ... < b_Nc = d_max``.

    ``"regular"``: equal widths; ``"geometric"``: ratio ``r = exp((ln d_max - ln d_min)/N_c)``
    (Eq. (11) of 001_ad5bae0acea940c4.txt); ``"isochoric"``: equal volume fractions,
    ``b_i = h^{-1}(i / N_c)``.
    """
    n_classes = _check_int("n_classes", n_classes)
    if spacing not in SPACINGS[:3]:
        raise InvalidInputError(f"spacing={spacing!r}: allowed are {', '.join(SPACINGS)}")
    lo, hi = model.d_min, model.d_max
    if not lo < hi:
        raise InvalidInputError(f"model range [{lo!r}, {hi!r}] has zero width: use spacing='modes' or sample()")
    if spacing == "regular":
        b = np.linspace(lo, hi, n_classes + 1)
    elif spacing == "geometric":
        r = np.exp((np.log(hi) - np.log(lo)) / n_classes)
        b = lo * r ** np.arange(n_classes + 1)
    else:
        b = np.asarray(model.quantile(np.linspace(0.0, 1.0, n_classes + 1)), float)
        b[0], b[-1] = lo, hi
        if np.any(np.diff(b) <= 0):
            raise InvalidInputError(
                f"isochoric classes collapse for {model!r} with n_classes={n_classes}: use fewer classes")
    b[0], b[-1] = lo, hi
    return b


def class_volume_fractions(model, bounds):
    """Volume fraction of each class, ``f_v^i = h(d_max^i) - h(d_min^i)`` (Eq. (6) of 001_ad5bae0acea940c4.txt)."""
    h = np.asarray(model.grading(np.asarray(bounds, float)), float)
    fv = np.diff(h)
    fv[fv < 0] = 0.0
    return fv


@dataclass
class ClassCounts:
    """Result of the counting step (Eq. (6) of 001_ad5bae0acea940c4.txt to Eq. (9) of 001_ad5bae0acea940c4.txt).

    ``lower``/``upper`` are the class bounds (equal for a monodisperse mode), ``fv`` the class
    volume fractions, ``n_unit`` the non-integer counts ``n^i`` of Eq. (7) of 001_ad5bae0acea940c4.txt, ``first`` the
    counts ``N'_i`` of Eq. (8) of 001_ad5bae0acea940c4.txt, ``counts`` the final ``N_i`` of Eq. (9) of 001_ad5bae0acea940c4.txt; ``total`` = ``Σ N_i``.
    """

    lower: np.ndarray
    upper: np.ndarray
    fv: np.ndarray
    n_unit: np.ndarray
    first: np.ndarray
    counts: np.ndarray
    spacing: str
    components: list = field(default_factory=list)

    @property
    def total(self) -> int:
        return int(self.counts.sum())

    def to_dict(self):
        return {"lower": self.lower.tolist(), "upper": self.upper.tolist(), "volume_fractions": self.fv.tolist(),
                "n_unit_volume": self.n_unit.tolist(), "first_estimate": self.first.tolist(),
                "counts": self.counts.tolist(), "total": self.total, "spacing": self.spacing}


def class_counts(model, n_classes=10, spacing="geometric", min_per_class=10, min_total=2000,
                 dim=None, count_basis="median", bounds=None):
    """Particle counts per class from the representativity criteria, Eq. (6) of 001_ad5bae0acea940c4.txt to Eq. (9) of 001_ad5bae0acea940c4.txt.

    Eq. (7) of 001_ad5bae0acea940c4.txt: ``n^i = f_v^i / V(d_m^i)`` with ``d_m^i`` the median of the uniform-by-volume
    law of the class (``count_basis="median"``, as in the seed) or, with
    ``count_basis="mean"``, the exact mean particle volume of that law (then the expected
    class volume fractions of the set equal ``f_v^i``). Eq. (8) of 001_ad5bae0acea940c4.txt: ``N'_i = E(N_{p/c}^min n^i
    / min n)``. Eq. (9) of 001_ad5bae0acea940c4.txt: if ``Σ N'_i < N_p^min``, ``N_i = E(N_p^min N'_i / N'_p)``, and the
    (fewer than ``N_c``) particles lost to the integer parts go to the classes with the
    largest remainders so that ``N_p = N_p^min`` exactly. Empty classes (``f_v^i = 0``)
    get no particles and are ignored by the criteria. No limit is applied here; see
    :func:`discretize` for ``max_total``.
    """
    if not isinstance(model, SizeDistribution):
        raise InvalidInputError(f"{type(model).__name__}: expected a size-distribution model")
    min_per_class = _check_int("min_per_class", min_per_class)
    min_total = _check_int("min_total", min_total)
    if count_basis not in COUNT_BASES:
        raise InvalidInputError(f"count_basis={count_basis!r}: allowed are {', '.join(COUNT_BASES)}")
    dim = model.dim if dim is None else dim
    if dim not in (2, 3):
        raise InvalidInputError(f"dim={dim!r}: allowed are 2 and 3")
    comps = []
    if spacing == "modes" or (bounds is None and model.has_atoms):
        if not isinstance(model, Mixture):
            raise InvalidInputError(f"spacing='modes' needs a Mixture/Bimodal/SieveTable model, got {model!r}")
        comps = list(model.components)
        lower = np.array([c.d_min for c in comps])
        upper = np.array([c.d_max for c in comps])
        fv = np.asarray(model.volume_fractions, float).copy()
        vmean = np.array([c.moment(dim, "number") for c in comps])
        vmed = np.array([float(np.asarray(c.number_quantile(0.5))) ** dim for c in comps])
        spacing = "modes"
    else:
        if bounds is None:
            b = class_bounds(model, n_classes, spacing)
        else:
            b = np.asarray(bounds, float).ravel()
            if b.size < 2 or np.any(np.diff(b) <= 0) or b[0] <= 0:
                raise InvalidInputError(f"bounds={b.tolist()}: must be positive and strictly increasing")
            spacing = "custom"
        lower, upper = b[:-1], b[1:]
        fv = class_volume_fractions(model, b)
        vmed = uv_ppf(0.5, lower, upper, dim) ** dim
        vmean = uv_mean_volume(lower, upper, dim)
    vol = vmed if count_basis == "median" else vmean
    n_unit = np.where(fv > 0, fv / vol, 0.0)
    live = n_unit > 0
    if not np.any(live):
        raise InvalidInputError(f"{model!r}: no class carries volume")
    nmin = n_unit[live].min()
    exact1 = min_per_class * n_unit / nmin
    need = float(np.sum(exact1))
    if not np.isfinite(need) or need > 1e18:
        raise InfeasibleError(
            f"the representativity criteria (n_classes={len(fv)}, spacing={spacing!r}, min_per_class={min_per_class}) "
            f"need N_p={need:.3g} particles for {model!r}: beyond any computation")
    first = np.floor(exact1 * (1 + 1e-12)).astype(np.int64)
    first[~live] = 0
    total1 = int(first.sum())
    if total1 < min_total:
        exact = min_total * first / total1
        counts = np.floor(exact * (1 + 1e-12)).astype(np.int64)
        short = min_total - int(counts.sum())
        if short > 0:
            rem = np.where(live, exact - counts, -1.0)
            counts[np.argsort(-rem, kind="stable")[:short]] += 1
    else:
        counts = first.copy()
    return ClassCounts(lower, upper, fv, n_unit, first, counts, spacing, comps)


def discretize(model, n_classes=10, spacing="geometric", min_per_class=10, min_total=2000, max_total=10**5,
               seed=None, method="random", dim=None, count_basis="median", bounds=None):
    """Representative discrete set of sizes from a model, §1.2 of 001_ad5bae0acea940c4.txt.

    Parameters
    ----------
    model : SizeDistribution
        Any model of :mod:`polypack.psd` (diameters).
    n_classes : int
        Number of size classes ``N_c``.
    spacing : {"geometric", "regular", "isochoric", "modes"}
        Class boundaries (Eq. (11) of 001_ad5bae0acea940c4.txt for geometric). ``"modes"`` (automatic for discrete
        mixtures such as :class:`Bimodal`) uses the mixture's modes as classes and draws
        each mode from its own law.
    min_per_class, min_total : int
        ``N_{p/c}^min`` and ``N_p^min`` of Eq. (8) of 001_ad5bae0acea940c4.txt to Eq. (9) of 001_ad5bae0acea940c4.txt.
    max_total : int or None
        Accessibility limit ``N_p^max`` (§2.3); exceeding it raises
        :class:`~polypack.InfeasibleError` stating the number needed.
    seed : int or SeedSequence, optional
        Recorded in ``report["seed"]``; each class gets a spawned child seed.
    method : {"random", "quantiles"}
        Sizes in a class by inverse sampling of the uniform-by-volume law with random
        ``y`` (Eq. (4) of 001_ad5bae0acea940c4.txt), or at the deterministic quantiles ``y_j = (j + 1/2)/N_i``.
    dim : {3, 2}, optional
        Volume law used for the classes (default: the model's). ``dim=2`` uses Eq. (4) of 001_ad5bae0acea940c4.txt
        literally (``f ∝ d**-2``, disks); ``dim=3`` its sphere analogue ``f ∝ d**-3``.
    count_basis : {"median", "mean"}
        Particle volume of a class in Eq. (7) of 001_ad5bae0acea940c4.txt (see :func:`class_counts`).
    bounds : array, optional
        Explicit class boundaries (overrides ``n_classes`` and ``spacing``).

    Returns
    -------
    SizeSet
        ``species`` = class index (0 = finest class; mode index for ``"modes"``);
        ``radii = d / 2``; the report holds the classes, counts, descriptors, ``Cr`` and the seed.
    """
    from .descriptors import with_descriptors
    from .sizeset import SizeSet

    if method not in ("random", "quantiles"):
        raise InvalidInputError(f"method={method!r}: allowed are 'random' and 'quantiles'")
    if max_total is not None:
        max_total = _check_int("max_total", max_total)
    dim = model.dim if dim is None else dim
    cc = class_counts(model, n_classes, spacing, min_per_class, min_total, dim, count_basis, bounds)
    if max_total is not None and cc.total > max_total:
        raise InfeasibleError(
            f"the representativity criteria (n_classes={len(cc.counts)}, spacing={cc.spacing!r}, "
            f"min_per_class={min_per_class}, min_total={min_total}) need N_p={cc.total} particles, "
            f"more than max_total={max_total}; raise max_total or lower min_per_class/n_classes")
    if method == "random":
        ss = as_seed_sequence(np.random.SeedSequence() if seed is None else seed)
        children = ss.spawn(len(cc.counts))
    ds, sp = [], []
    for i, c in enumerate(cc.counts):
        c = int(c)
        if c == 0:
            continue
        if method == "random":
            rng = np.random.default_rng(children[i])
        if cc.spacing == "modes":
            comp = cc.components[i]
            d = comp.sample_diameters(c, seed=children[i] if method == "random" else None, method=method)
        else:
            y = (np.arange(c) + 0.5) / c if method == "quantiles" else rng.random(c)
            d = uv_ppf(y, cc.lower[i], cc.upper[i], dim)
        ds.append(np.clip(d, cc.lower[i], cc.upper[i]))
        sp.append(np.full(c, i, np.int64))
    report = {"generator": "discretize", "method": method, "model": model.params(), "dim": dim,
              "parameters": {"n_classes": len(cc.counts), "spacing": cc.spacing, "min_per_class": min_per_class,
                             "min_total": min_total, "max_total": max_total, "count_basis": count_basis},
              "classes": cc.to_dict()}
    if method == "random":
        report["seed"] = seed_record(ss)
    return with_descriptors(SizeSet.from_diameters(np.concatenate(ds), np.concatenate(sp), report=report, model=model,
                                                   dim=dim), model)
