"""Shared machinery of the analysis estimators: input checks, realization bookkeeping,
species-pair maps, JSON conversion.

Every estimator follows the same protocol (freud style): ``compute(packing,
reset=True)`` returns ``self``; ``reset=False`` adds the packing as one more
realization of an ensemble, the results are then pooled over realizations and
standard errors come from the spread between realizations.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

import contextlib
import warnings

from ..errors import InvalidInputError, NotComputedError, OverlapError, OverlapWarning
from ..packing import Packing

#: What the estimators do with overlapping input: "warn" (default), "error" or "ignore".
_OVERLAP = {"policy": "warn"}
#: Relative gap below which a pair counts as overlapping (round-off of touching pairs is fine).
OVERLAP_TOLERANCE = 1e-9
_POLICIES = ("warn", "error", "ignore")


@contextlib.contextmanager
def overlap_policy(policy):
    """Within the block, estimators ``"warn"`` (default), raise (``"error"``) or stay quiet
    (``"ignore"``, e.g. for ideal-gas test points) on overlapping input.

    Also usable as a plain call, ``set_overlap_policy("error")``, to change it for good.
    """
    old = _OVERLAP["policy"]
    set_overlap_policy(policy)
    try:
        yield
    finally:
        _OVERLAP["policy"] = old


def set_overlap_policy(policy) -> str:
    """Set what the estimators do with overlapping input; returns the previous policy."""
    if policy not in _POLICIES:
        raise InvalidInputError(f"overlap policy {policy!r}: allowed are {', '.join(map(repr, _POLICIES))}")
    old = _OVERLAP["policy"]
    _OVERLAP["policy"] = policy
    return old


def check_overlaps(packing, what="analysis"):
    """Apply the overlap policy to ``packing`` (see :func:`overlap_policy`)."""
    policy = _OVERLAP["policy"]
    if policy == "ignore" or packing.n < 2:
        return
    gap, pair = packing.closest_pair()
    if not gap < -OVERLAP_TOLERANCE:
        return
    msg = (f"{what}: the pack has overlapping spheres (spheres {pair[0]} and {pair[1]}, relative gap {gap:.3g}); "
           "its statistics are not those of a hard-sphere pack")
    if policy == "error":
        raise OverlapError(msg)
    warnings.warn(msg, OverlapWarning, stacklevel=3)

__all__ = [
    "PairMap",
    "Estimator",
    "GridEstimator",
    "PairCountEstimator",
    "check_packing",
    "check_positive",
    "check_r_max",
    "check_grid",
    "check_scale",
    "check_normalization",
    "to_jsonable",
]

SCALES = ("distance", "contact")
NORMALIZATIONS = ("finite_size", "seed")


def check_packing(packing, min_n=1, what="analysis", dims=(3,), walls=False):
    """Return ``packing`` if it is a :class:`~polypack.Packing` with at least ``min_n`` spheres.

    ``dims`` are the space dimensions the caller supports and ``walls`` whether it
    supports non-periodic axes; other packings get an :class:`InvalidInputError`.
    """
    if not isinstance(packing, Packing):
        raise InvalidInputError(
            f"{what} needs a polypack.Packing, got {type(packing).__name__}; "
            "build one with polypack.Packing(positions, radii, box)"
        )
    if packing.dim not in dims:
        raise InvalidInputError(
            f"{what} supports {' and '.join(f'{d}D' for d in dims)} packings only; got a {packing.dim}D packing"
        )
    if not walls and not packing.fully_periodic:
        raise InvalidInputError(
            f"{what} needs a box periodic on every axis; got periodic={packing.periodic}"
        )
    if packing.n < min_n:
        raise InvalidInputError(f"{what} needs a pack with at least {min_n} spheres, got {packing.n}")
    check_overlaps(packing, what)
    return packing


def check_positive(name, value):
    """``float(value)`` if finite and > 0, else an :class:`InvalidInputError`."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name}={value!r} must be a number > 0") from None
    if not np.isfinite(v) or v <= 0:
        raise InvalidInputError(f"{name}={value!r} must be finite and > 0")
    return v


def check_r_max(r_max, box, what="r_max"):
    """Reject cutoffs beyond half the smallest box length (minimum image no longer unique)."""
    half = 0.5 * float(np.min(box))
    if r_max > half * (1 + 1e-12):
        raise InvalidInputError(
            f"{what}={r_max:g} exceeds half the smallest box length {half:g}; "
            "use r_max <= L/2 or a larger pack"
        )


def check_grid(r_max, dr, bins):
    """``(r_max, dr, nbins)`` of a radial grid from ``dr`` or ``bins``; ``r_max`` rounded down to whole steps."""
    r_max = check_positive("r_max", r_max)
    if dr is None and bins is None:
        raise InvalidInputError("give the bin width dr (> 0) or the number of bins")
    if dr is not None:
        dr = check_positive("dr", dr)
        if dr > r_max:
            raise InvalidInputError(f"dr={dr:g} exceeds r_max={r_max:g}; need dr <= r_max")
        nbins = int(np.floor(r_max / dr + 1e-9))
    else:
        if int(bins) != bins or bins < 1:
            raise InvalidInputError(f"bins={bins!r} must be an integer >= 1")
        nbins = int(bins)
        dr = r_max / nbins
    return nbins * dr, dr, nbins


def check_scale(scale):
    if scale not in SCALES:
        raise InvalidInputError(f"scale={scale!r}: allowed are {', '.join(map(repr, SCALES))}")
    return scale


def check_normalization(normalization):
    if normalization not in NORMALIZATIONS:
        raise InvalidInputError(
            f"normalization={normalization!r}: allowed are {', '.join(map(repr, NORMALIZATIONS))}"
        )
    return normalization


class PairMap(Mapping):
    """Read-only mapping ``(k, m) -> array`` over species pairs with clear errors.

    Any order of a pair is accepted for symmetric quantities only if it was stored;
    unknown pairs raise :class:`~polypack.InvalidInputError` naming the allowed pairs.
    """

    def __init__(self, data, what="partial"):
        self._d = dict(data)
        self._what = what

    @classmethod
    def from_array(cls, arr, what="partial"):
        """Map every ordered pair ``(k, m)`` to ``arr[k, m]`` of a ``(K, K, ...)`` array."""
        ns = arr.shape[0]
        return cls({(k, m): arr[k, m] for k in range(ns) for m in range(ns)}, what)

    def __getitem__(self, key):
        try:
            k, m = key
            key = (int(k), int(m))
        except (TypeError, ValueError):
            raise InvalidInputError(
                f"{self._what} key {key!r} must be a species pair (k, m)"
            ) from None
        if key not in self._d:
            allowed = ", ".join(str(p) for p in self._d) or "none (compute first)"
            raise InvalidInputError(f"unknown species pair {key} for {self._what}; allowed: {allowed}")
        return self._d[key]

    def __iter__(self):
        return iter(self._d)

    def __len__(self):
        return len(self._d)

    def __repr__(self):
        return f"PairMap({list(self._d)})"


def to_jsonable(obj):
    """Convert numpy arrays/scalars, tuples and pair-keyed dicts to plain JSON data."""
    if isinstance(obj, np.ndarray):
        return [to_jsonable(v) for v in obj.tolist()] if obj.dtype.kind == "f" else obj.tolist()
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if np.isfinite(v) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, Mapping):
        out = {}
        for k, v in obj.items():
            if isinstance(k, tuple):
                k = "-".join(str(int(x)) for x in k)
            out[str(k)] = to_jsonable(v)
        return out
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    return obj


def _init_params(cls) -> tuple:
    """Names of the constructor parameters of ``cls`` and its bases (its estimator parameters)."""
    import inspect

    names = []
    for klass in cls.__mro__:
        init = klass.__dict__.get("__init__")
        if init is None:
            continue
        init = getattr(init, "__wrapped__", init)
        for p in list(inspect.signature(init).parameters)[1:]:
            if p not in names and p not in ("args", "kwargs"):
                names.append(p)
    return tuple(names)


def _guarded(name, prop):
    """A property that raises NotComputedError before compute() and caches its value per state."""

    def fget(self):
        if not self._frames:
            raise NotComputedError(
                f"{type(self).__name__}.{name} is not computed yet; call compute(packing) first"
            )
        token = (id(self._frames), len(self._frames), self._version)
        cache = self.__dict__.setdefault("_cache", {})
        if cache.get("__token__") != token:
            cache.clear()
            cache["__token__"] = token
        if name not in cache:
            value = prop.fget(self)
            if isinstance(value, np.ndarray):
                value.setflags(write=False)
            cache[name] = value
        return cache[name]

    fget.__doc__ = prop.__doc__
    fget.__name__ = name
    return property(fget, doc=prop.__doc__)


class Estimator:
    """Base class of every estimator: the one protocol all of them follow.

    * ``compute(packing, reset=True)`` returns ``self``; ``reset=False`` adds the packing
      as one more realization.
    * Every result property raises :class:`~polypack.NotComputedError` before the first
      ``compute`` and is computed once per state (cached until the next ``compute`` or
      ``reset``); array results are read-only.
    * The parameters (the constructor's arguments) are read-only after construction:
      make a new estimator to change them.
    * ``repr`` shows the parameters and the number of realizations; ``to_dict()`` gives
      plain JSON data.

    Subclasses get this automatically: public properties whose name is not a constructor
    parameter are results.
    """

    _params: tuple = ()

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        cls._params = _init_params(cls)
        for name, attr in list(cls.__dict__.items()):
            if isinstance(attr, property) and not name.startswith("_") and name not in cls._params \
                    and name != "n_realizations" and attr.fset is None:
                setattr(cls, name, _guarded(name, attr))
        init = cls.__dict__.get("__init__")
        if init is not None and not getattr(init, "_freezes", False):
            import functools

            @functools.wraps(init)
            def __init__(self, *args, __init=init, **kwargs):
                depth = self.__dict__.get("_init_depth", 0)
                object.__setattr__(self, "_init_depth", depth + 1)
                try:
                    __init(self, *args, **kwargs)
                finally:
                    object.__setattr__(self, "_init_depth", depth)
                if depth == 0:
                    object.__setattr__(self, "_frozen", True)

            __init__._freezes = True
            cls.__init__ = __init__

    def __init__(self):
        self._frames = []
        self._version = 0

    def __setattr__(self, name, value):
        if not name.startswith("_") and self.__dict__.get("_frozen", False):
            raise AttributeError(
                f"{type(self).__name__}.{name} is read-only after construction; create a new "
                f"{type(self).__name__}(...) with the parameters you want"
            )
        object.__setattr__(self, name, value)

    def __repr__(self) -> str:
        parts = []
        for p in self._params:
            try:
                v = getattr(self, p)
            except Exception:  # a parameter kept under another name
                continue
            parts.append(f"{p}={v!r}")
        parts.append(f"n_realizations={self.n_realizations}")
        return f"{type(self).__name__}({', '.join(parts)})"

    def reset(self):
        """Forget all accumulated realizations."""
        self._frames = []
        self._version = getattr(self, "_version", 0) + 1
        return self

    @property
    def n_realizations(self) -> int:
        """Number of packings accumulated since the last reset."""
        return len(self._frames)

    def _require(self):
        if not self._frames:
            raise NotComputedError(f"{type(self).__name__} has no results yet; call compute(packing) first")

    def _stack(self, name):
        return np.stack([f[name] for f in self._frames])

    def _sum(self, name):
        return np.sum(self._stack(name), axis=0)

    @staticmethod
    def _stderr(stack):
        """Standard error of the mean over realizations (axis 0); NaN for one realization."""
        p = stack.shape[0]
        if p < 2:
            return np.full(stack.shape[1:], np.nan)
        with np.errstate(invalid="ignore"):
            return np.nanstd(stack, axis=0, ddof=1) / np.sqrt(p)

    def _axes(self, ax):
        if ax is None:
            import matplotlib.pyplot as plt

            _, ax = plt.subplots()
        return ax


class GridEstimator(Estimator):
    """Estimator on the radial grid ``dr, 2 dr, ..., r_max`` (see :func:`check_grid`)."""

    def __init__(self, r_max, dr=None, bins=None):
        super().__init__()
        self._r_max, self._dr, self._nbins = check_grid(r_max, dr, bins)

    @property
    def r_max(self) -> float:
        return self._r_max

    @property
    def dr(self) -> float:
        return self._dr


class PairCountEstimator(GridEstimator):
    """Grid estimator built on pair counts per species pair (K functions and RDFs).

    Holds ``scale`` and ``normalization``, checks that accumulated packs have the same
    number of species, and pools the per-realization counts (frame key ``_count_key``)
    and ideal pair densities (``"dens"``, ``"dens_total"``).
    """

    _count_key = "counts"

    def __init__(self, r_max, dr=None, bins=None, scale="distance", normalization="finite_size"):
        super().__init__(r_max, dr, bins)
        self.scale = check_scale(scale)
        self.normalization = check_normalization(normalization)
        self._dim = 3

    def _begin(self, packing, reset, what):
        """Input checks and reset before adding ``packing`` as a realization (3D or 2D, periodic)."""
        check_packing(packing, min_n=2, what=what, dims=(2, 3))
        if reset:
            self.reset()
        elif self._frames and self._frames[0][self._count_key].shape[0] != packing.n_species:
            raise InvalidInputError(
                f"pack has {packing.n_species} species but earlier realizations had "
                f"{self._frames[0][self._count_key].shape[0]}; use reset=True"
            )
        elif self._frames and self._dim != packing.dim:
            raise InvalidInputError(
                f"pack is {packing.dim}D but earlier realizations were {self._dim}D; use reset=True"
            )
        self._dim = packing.dim  # shell volumes are dim-dimensional

    def _pooled(self):
        """Summed counts, ideal pair densities per species pair, and the total density."""
        self._require()
        counts = self._sum(self._count_key)
        dens = self._sum("dens")
        dens_t = float(np.sum([f["dens_total"] for f in self._frames]))
        return counts, dens, dens_t
