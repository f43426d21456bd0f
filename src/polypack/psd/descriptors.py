"""Descriptors of a size distribution or a generated size set (§2.1-2.2 of 001_ad5bae0acea940c4.txt)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import InvalidInputError

__all__ = ["hazen", "regression_coefficient", "moment", "polydispersity", "skewness", "describe", "with_descriptors"]

#: What a size-distribution model offers the descriptors (duck-typed: this module does not import
#: polypack.psd.models, which calls it to describe the sets it draws).
_MODEL_API = ("quantile", "grading", "moment", "d_min", "d_max")


def _kind(obj):
    from .sizeset import SizeSet

    if isinstance(obj, SizeSet):
        return "set"
    if hasattr(obj, "radii"):
        return "radii"
    if all(hasattr(obj, a) for a in _MODEL_API):
        return "model"
    raise InvalidInputError(f"{type(obj).__name__}: expected a size-distribution model or a SizeSet")


def _as_set(obj):
    from .sizeset import SizeSet

    k = _kind(obj)
    if k == "radii":
        return SizeSet(obj.radii, getattr(obj, "species", None))
    return obj


def hazen(obj) -> dict:
    """Characteristic diameters and Hazen coefficients, Eq. (18) of 001_ad5bae0acea940c4.txt to Eq. (20) of 001_ad5bae0acea940c4.txt.

    ``d_x`` is the diameter below which lies ``x %`` of the particle volume (the inverse
    grading curve); ``Cu = d60 / d10`` and ``Cc = d30**2 / (d10 d60)``. For a SizeSet (or
    any object with ``radii``), ``d_x`` is the smallest particle diameter at which the
    set's cumulative volume reaches ``x %``.

    Returns
    -------
    dict with keys d10, d30, d50, d60, Cu, Cc.
    """
    src = obj if _kind(obj) == "model" else _as_set(obj)
    d10, d30, d50, d60 = (float(v) for v in np.atleast_1d(src.quantile(np.array([0.1, 0.3, 0.5, 0.6]))))
    return {"d10": d10, "d30": d30, "d50": d50, "d60": d60, "Cu": d60 / d10, "Cc": d30**2 / (d10 * d60)}


def regression_coefficient(sizes, model, k=100, d_min=None, d_max=None) -> float:
    """Regression coefficient ``Cr`` of Eq. (21) of 001_ad5bae0acea940c4.txt.

    ``Cr = sqrt(Σ (y_exp(d_i) - h(d_i))**2 / Σ y_exp(d_i)**2)`` over ``k`` sizes ``d_i``
    in geometric progression between ``d_min`` and ``d_max`` (the model's range by
    default); ``y_exp`` is the grading curve of the generated set and ``h`` the model's.
    0 means perfect agreement.
    """
    s = _as_set(sizes)
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 2:
        raise InvalidInputError(f"k={k!r}: must be an integer >= 2")
    lo = model.d_min if d_min is None else float(d_min)
    hi = model.d_max if d_max is None else float(d_max)
    if not (0 < lo < hi):
        raise InvalidInputError(f"d_min={lo!r}, d_max={hi!r}: need 0 < d_min < d_max for Cr")
    d = np.geomspace(lo, hi, int(k))
    y = s.grading(d)
    h = model.grading(d)
    den = float(np.sum(y**2))
    return float(math.sqrt(np.sum((y - h) ** 2) / den)) if den > 0 else float("inf")


def moment(obj, k, basis="number", variable="diameter") -> float:
    """Raw moment ``E[x**k]`` of diameters (or radii) weighted by number or by volume."""
    if basis not in ("number", "volume"):
        raise InvalidInputError(f"basis={basis!r}: allowed are 'number' and 'volume'")
    if variable not in ("diameter", "radius"):
        raise InvalidInputError(f"variable={variable!r}: allowed are 'diameter' and 'radius'")
    scale = 0.5**k if variable == "radius" else 1.0
    if _kind(obj) == "model":
        return scale * obj.moment(k, basis)
    s = _as_set(obj)
    d = s.diameters
    if basis == "number":
        return scale * float(np.mean(d ** float(k)))
    w = d**s.dim
    return scale * float(np.sum(w * d ** float(k)) / np.sum(w))


def polydispersity(obj) -> float:
    """Polydispersity ``δ = std(r) / mean(r)`` of the radii by number."""
    m1 = moment(obj, 1)
    m2 = moment(obj, 2)
    return float(math.sqrt(max(m2 - m1 * m1, 0.0)) / m1)


def skewness(obj) -> float:
    """Skewness of the radii by number (third standardised central moment)."""
    if _kind(obj) != "model":
        r = _as_set(obj).radii
        from scipy import stats  # imported here: scipy.stats takes seconds to import

        return float(stats.skew(r)) if r.size > 2 and np.ptp(r) > 1e-12 * r.max() else 0.0
    m1, m2, m3 = (moment(obj, k) for k in (1, 2, 3))
    var = m2 - m1 * m1
    if var <= 0:
        return 0.0
    return float((m3 - 3 * m1 * m2 + 2 * m1**3) / var**1.5)


def describe(obj) -> dict:
    """All descriptors as plain data: Hazen (Eq. (18) of 001_ad5bae0acea940c4.txt to Eq. (20) of 001_ad5bae0acea940c4.txt), moments, polydispersity, skewness."""
    out = dict(hazen(obj))
    if _kind(obj) == "model":
        out["d_min"], out["d_max"] = float(obj.d_min), float(obj.d_max)
    else:
        s = _as_set(obj)
        out["n"] = s.n
        out["d_min"], out["d_max"] = float(s.diameters.min()), float(s.diameters.max())
        counts = np.bincount(s.species)
        vol = np.bincount(s.species, weights=s.diameters**s.dim)
        out["species_counts"] = counts.tolist()
        out["species_volume_fractions"] = (vol / vol.sum()).tolist()
    out["span"] = (out["d_max"] - out["d_min"]) / (out["d_max"] + out["d_min"])
    out["mean_diameter_number"] = moment(obj, 1, "number")
    out["mean_diameter_volume"] = moment(obj, 1, "volume")
    out["number_moments"] = {str(k): moment(obj, k, "number") for k in (1, 2, 3)}
    out["volume_moments"] = {str(k): moment(obj, k, "volume") for k in (1, 2, 3)}
    out["sauter_diameter"] = moment(obj, 3, "number") / moment(obj, 2, "number")
    out["polydispersity"] = polydispersity(obj)
    out["skewness"] = skewness(obj)
    return out


def with_descriptors(sizes, model=None):
    """Add the descriptors of a generated set to its report and return it.

    ``sizes.report["descriptors"]`` = :func:`describe` of the set, with ``Cr`` (Eq. (21) of
    001_ad5bae0acea940c4.txt, :func:`regression_coefficient`) against ``model`` when the model
    has no atoms, and ``model`` = :func:`describe` of the model. A report that already holds
    descriptors keeps them. Used by the generators (``model.sample``, ``discretize``): the
    :class:`~polypack.psd.SizeSet` itself is data only.
    """
    sizes.report.setdefault("descriptors", describe(sizes))
    if model is not None:
        if not model.has_atoms:
            sizes.report["descriptors"]["Cr"] = regression_coefficient(sizes, model)
        sizes.report["descriptors"]["model"] = describe(model)
    return sizes
