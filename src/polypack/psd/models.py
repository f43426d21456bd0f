"""Continuous and discrete models of a particle-size distribution.

Every model describes particle **diameters** ``d`` (as 001_ad5bae0acea940c4.txt does); a
generated :class:`~polypack.psd.SizeSet` stores radii ``d / 2``. Two descriptions of the
same population are always available and converted exactly into each other:

* by **volume**: the grading curve ``h(d)`` (cumulative volume fraction, Eq. (5) of
  001_ad5bae0acea940c4.txt), its density and its inverse ``quantile(p)`` = ``d_p``;
* by **number**: the partition function ``F(d)`` (``number_cdf``), its density ``f(d)``
  (``number_pdf``) and ``number_quantile``.

With a particle volume ``V(d) ∝ d**dim`` (``dim=3`` spheres, ``dim=2`` disks, the setting
of the seed's Eq. (2) of 001_ad5bae0acea940c4.txt to Eq. (4) of 001_ad5bae0acea940c4.txt), Eq. (5) of 001_ad5bae0acea940c4.txt gives ``dh = d**dim f(d) dd / <d**dim>``. A model
defined in closed form on one side (its *basis*) gets the other side from the exact
identity, written in the probability variable ``p`` of the basis so the integrand is
bounded even where the density is singular::

    F(d) = ∫_0^{h(d)} q(p)**(-dim) dp / ∫_0^1 q(p)**(-dim) dp        (volume basis)
    h(d) = ∫_0^{F(d)} Q(p)**(+dim) dp / ∫_0^1 Q(p)**(+dim) dp        (number basis)

where ``q``/``Q`` is the quantile of the basis. The integrals are evaluated by composite
Gauss-Legendre quadrature on a fixed grid in ``p`` refined towards 0 and 1 (relative
accuracy about 1e-12 for the models here); models with closed forms on both sides
(uniform by volume, uniform by size, log-normal) and mixtures override them exactly.
"""

from __future__ import annotations

import csv
import io as _io
import math
from pathlib import Path

import numpy as np
from scipy import special, stats

from .._util import rng_from, seed_record
from ..errors import FormatError, InvalidInputError

__all__ = [
    "SizeDistribution",
    "CumulativeBeta",
    "UniformVolume",
    "UniformSize",
    "LogNormal",
    "Normal",
    "Monodisperse",
    "Mixture",
    "Bimodal",
    "SieveTable",
    "span_from_ratio",
    "ratio_from_span",
    "volume_to_number_fractions",
    "number_to_volume_fractions",
]

# Gauss-Legendre nodes on [0, 1] used by the composite quadrature.
_GL_X, _GL_W = np.polynomial.legendre.leggauss(12)
_GL_X = 0.5 * (_GL_X + 1.0)
_GL_W = 0.5 * _GL_W


def _p_grid(extra=()):
    """Quadrature grid on [0, 1]: uniform core plus geometric refinement at both ends."""
    core = np.linspace(0.0, 1.0, 2049)
    ends = np.geomspace(1e-14, 1.0 / 2048, 40)
    g = np.concatenate([core, ends, 1.0 - ends, np.asarray(extra, float)])
    g = np.unique(np.clip(g, 0.0, 1.0))
    return g


def _show(value):
    """repr of a user value without numpy's type wrapper (``1.5`` rather than ``np.float64(1.5)``)."""
    return repr(value.item() if isinstance(value, np.generic) else value)


def _finite_positive(name, value):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name}={_show(value)}: must be a positive finite number") from None
    if not math.isfinite(v) or v <= 0.0:
        raise InvalidInputError(f"{name}={_show(value)}: must be a positive finite number")
    return v


def _check_dim(dim):
    if dim not in (2, 3):
        raise InvalidInputError(f"dim={dim!r}: allowed are 2 (disks, V ~ d**2) and 3 (spheres, V ~ d**3)")
    return int(dim)


def ratio_from_span(span):
    """Size ratio ``R = d_max / d_min`` from the span ``s`` (inverse of Eq. (17) of 001_ad5bae0acea940c4.txt)."""
    return (1.0 + span) / (1.0 - span)


def span_from_ratio(ratio):
    """Span ``s = (d_max - d_min) / (d_max + d_min)`` = ``(R - 1)/(R + 1)``, Eq. (17) of 001_ad5bae0acea940c4.txt."""
    return (ratio - 1.0) / (ratio + 1.0)


def _bounds_from(span, d_min, d_max, default_d_max=1.0):
    """Resolve (d_min, d_max) from any two of span / d_min / d_max (Eq. (17) of 001_ad5bae0acea940c4.txt)."""
    if span is not None:
        try:
            s = float(span)
        except (TypeError, ValueError):
            raise InvalidInputError(f"span={span!r}: must be a number in (0, 1)") from None
        if not (0.0 < s < 1.0):
            raise InvalidInputError(f"span={_show(span)}: must lie in the open interval (0, 1) (Eq. (17) of 001_ad5bae0acea940c4.txt)")
        if d_min is not None and d_max is not None:
            raise InvalidInputError("give at most two of span, d_min, d_max")
        r = ratio_from_span(s)
        if d_min is not None:
            d_min = _finite_positive("d_min", d_min)
            d_max = d_min * r
        else:
            d_max = _finite_positive("d_max", default_d_max if d_max is None else d_max)
            d_min = d_max / r
    else:
        if d_min is None or d_max is None:
            raise InvalidInputError("give span, or both d_min and d_max")
        d_min = _finite_positive("d_min", d_min)
        d_max = _finite_positive("d_max", d_max)
    if not d_min < d_max:
        raise InvalidInputError(f"d_min={_show(d_min)} must be smaller than d_max={_show(d_max)}")
    return float(d_min), float(d_max)


class SizeDistribution:
    """Base class of the size-distribution models (diameters ``d`` on ``[d_min, d_max]``).

    Subclasses define the closed-form law of their ``basis`` ("volume" or "number") in
    ``_cdf``, ``_pdf`` and ``_ppf``; the other description follows exactly from Eq. (5)
    of 001_ad5bae0acea940c4.txt (see the module docstring).
    """

    basis = "volume"
    name = "distribution"

    def __init__(self, d_min, d_max, dim=3):
        self.d_min = float(d_min)
        self.d_max = float(d_max)
        self.dim = _check_dim(dim)
        self._tab = None

    # -- closed form of the basis (to be provided) ---------------------------------------
    def _cdf(self, d):
        raise NotImplementedError

    def _pdf(self, d):
        raise NotImplementedError

    def _ppf(self, p):
        raise NotImplementedError

    def _p_breaks(self):
        return ()

    # -- parameters ----------------------------------------------------------------------
    def params(self) -> dict:
        """Model name and parameters as plain data (used in reports and configs)."""
        return {"model": self.name, "d_min": self.d_min, "d_max": self.d_max, "dim": self.dim}

    def __repr__(self):
        items = ", ".join(f"{k}={v!r}" for k, v in self.params().items() if k != "model")
        return f"{type(self).__name__}({items})"

    @property
    def span(self) -> float:
        """Span ``s`` of Eq. (17) of 001_ad5bae0acea940c4.txt."""
        return (self.d_max - self.d_min) / (self.d_max + self.d_min)

    @property
    def has_atoms(self) -> bool:
        """True when some size carries a finite fraction (a discrete mode)."""
        return False

    # -- quadrature table of the conversion -----------------------------------------------
    @property
    def _w(self):
        return -self.dim if self.basis == "volume" else self.dim

    def _table(self):
        if self._tab is None:
            P = _p_grid(self._p_breaks())
            a, b = P[:-1], P[1:]
            x = a[:, None] + (b - a)[:, None] * _GL_X[None, :]
            q = self._ppf_clipped(x)
            seg = (b - a) * ((q ** self._w) @ _GL_W)
            cum = np.concatenate([[0.0], np.cumsum(seg)])
            self._tab = (P, cum, cum[-1])
            self._nodes = q  # quantiles at the quadrature nodes, reused by moment()
        return self._tab

    def _ppf_clipped(self, p):
        return np.clip(self._ppf(np.clip(p, 0.0, 1.0)), self.d_min, self.d_max)

    def _partial(self, p):
        """∫_0^p ppf(t)**w dt (not normalised), vectorised."""
        P, cum, _ = self._table()
        p = np.clip(np.asarray(p, float), 0.0, 1.0)
        j = np.clip(np.searchsorted(P, p, side="right") - 1, 0, len(P) - 2)
        a = P[j]
        h = p - a
        x = a[..., None] + h[..., None] * _GL_X
        q = self._ppf_clipped(x)
        return cum[j] + h * ((q ** self._w) @ _GL_W)

    def _other_cdf(self, d):
        _, _, norm = self._table()
        return np.clip(self._partial(self._cdf(d)) / norm, 0.0, 1.0)

    def _other_pdf(self, d):
        _, _, norm = self._table()
        d = np.asarray(d, float)
        return self._pdf(d) * np.where(d > 0, d, np.nan) ** self._w / norm

    def _other_ppf(self, u):
        """Inverse of the converted CDF: Newton in ``p`` inside the bracketing table cell."""
        P, cum, norm = self._table()
        u = np.clip(np.asarray(u, float), 0.0, 1.0)
        t = u * norm
        j = np.clip(np.searchsorted(cum, t, side="right") - 1, 0, len(P) - 2)
        lo, hi = P[j].copy(), P[j + 1].copy()
        span = np.where(cum[j + 1] > cum[j], cum[j + 1] - cum[j], 1.0)
        p = lo + (hi - lo) * np.clip((t - cum[j]) / span, 0.0, 1.0)
        for _ in range(30):
            g = self._partial(p) - t
            lo = np.where(g < 0, p, lo)
            hi = np.where(g >= 0, p, hi)
            dg = self._ppf_clipped(p) ** self._w
            step = p - g / dg
            bad = ~((step > lo) & (step < hi))
            p_new = np.where(bad, 0.5 * (lo + hi), step)
            if np.all(np.abs(p_new - p) <= 1e-15 + 1e-13 * np.abs(p)):
                p = p_new
                break
            p = p_new
        return self._ppf_clipped(p)

    def _sample_other(self, rng, n):
        """Exact rejection sampling of the converted law (envelope on the table cells)."""
        P, _, _ = self._table()
        qa = self._ppf_clipped(P) ** self._w
        env = np.maximum(qa[:-1], qa[1:])  # q is monotone: the max sits at a cell end
        mass = np.diff(P) * env
        cdf = np.cumsum(mass)
        cdf /= cdf[-1]
        out = np.empty(0)
        while out.size < n:
            m = int(1.3 * (n - out.size)) + 16
            j = np.minimum(np.searchsorted(cdf, rng.random(m), side="right"), len(env) - 1)
            p = P[j] + (P[j + 1] - P[j]) * rng.random(m)
            q = self._ppf_clipped(p)
            keep = rng.random(m) * env[j] <= q ** self._w
            out = np.concatenate([out, q[keep]])
        return out[:n]

    # -- public volume side -----------------------------------------------------------------
    def grading(self, d):
        """Grading curve ``h(d)``: cumulative volume fraction of particles smaller than ``d``.

        Eq. (5) of 001_ad5bae0acea940c4.txt. ``d`` may be a scalar or an array; values
        outside ``[d_min, d_max]`` give 0 or 1.
        """
        d = np.asarray(d, float)
        out = self._cdf(d) if self.basis == "volume" else self._other_cdf(d)
        return np.clip(out, 0.0, 1.0)

    def volume_pdf(self, d):
        """Density ``dh/dd`` of the grading curve (volume fraction per unit diameter)."""
        d = np.asarray(d, float)
        return self._pdf(d) if self.basis == "volume" else self._other_pdf(d)

    def quantile(self, p):
        """Inverse grading curve ``d_p = h^{-1}(p)`` (``d_10 = quantile(0.1)``), Eq. (19) of 001_ad5bae0acea940c4.txt to Eq. (20) of 001_ad5bae0acea940c4.txt."""
        p = _check_prob(p)
        return self._ppf_clipped(p) if self.basis == "volume" else self._other_ppf(p)

    # -- public number side -----------------------------------------------------------------
    def number_cdf(self, d):
        """Partition function ``F(d)``: fraction (by number) of particles smaller than ``d``."""
        d = np.asarray(d, float)
        out = self._cdf(d) if self.basis == "number" else self._other_cdf(d)
        return np.clip(out, 0.0, 1.0)

    def number_pdf(self, d):
        """Number density ``f(d)`` of diameters (normalised to 1)."""
        d = np.asarray(d, float)
        return self._pdf(d) if self.basis == "number" else self._other_pdf(d)

    def number_quantile(self, p):
        """Inverse partition function ``F^{-1}(p)`` (Eq. (1) of 001_ad5bae0acea940c4.txt)."""
        p = _check_prob(p)
        return self._ppf_clipped(p) if self.basis == "number" else self._other_ppf(p)

    # -- conversions ------------------------------------------------------------------------
    def fraction_between(self, d_lo, d_hi, basis="volume"):
        """Fraction of the particles (by ``basis``) with ``d_lo < d <= d_hi``.

        By volume this is ``h(d_hi) - h(d_lo)``, the class fraction of Eq. (6) of 001_ad5bae0acea940c4.txt.
        """
        basis = _check_basis(basis)
        cdf = self.grading if basis == "volume" else self.number_cdf
        return cdf(d_hi) - cdf(d_lo)

    # -- moments ----------------------------------------------------------------------------
    def moment(self, k, basis="number"):
        """Raw moment ``E[d**k]`` of the diameters weighted by number or by volume.

        Exact relation used: ``E_N[d**k] = E_V[d**(k-dim)] / E_V[d**(-dim)]``.
        """
        basis = _check_basis(basis)
        P, _, norm = self._table()
        a, b = P[:-1], P[1:]
        q = self._nodes
        if basis == self.basis:
            return float(np.sum((b - a) * ((q ** float(k)) @ _GL_W)))
        return float(np.sum((b - a) * ((q ** (float(k) + self._w)) @ _GL_W)) / norm)

    def mean(self, basis="number"):
        """Mean diameter by number or by volume."""
        return self.moment(1, basis)

    # -- sampling ---------------------------------------------------------------------------
    def sample_diameters(self, n, seed=None, method="random"):
        """``n`` diameters drawn from the number distribution.

        ``method="random"``: independent draws (inverse transform, Eq. (1) of 001_ad5bae0acea940c4.txt, or exact
        rejection on the converted law); ``"quantiles"``: the deterministic number
        quantiles ``F^{-1}((i + 1/2) / n)``, reproducible bit for bit without a seed.
        """
        n = _check_count("n", n)
        method = _check_method(method)
        if method == "quantiles":
            return self.number_quantile((np.arange(n) + 0.5) / n)
        rng = rng_from(seed)
        if self.basis == "number":
            return self._ppf_clipped(rng.random(n))
        return self._sample_other(rng, n)

    def sample(self, n=2000, seed=None, method="random"):
        """A :class:`SizeSet` of ``n`` particles from the number distribution (species all 0).

        Radii are ``d / 2``. The seed is recorded in ``report["seed"]``.
        """
        from .descriptors import with_descriptors
        from .sizeset import SizeSet

        if method == "random" and seed is None:
            seed = _fresh_seed()  # drawn once so the record below regenerates this very set
        d = self.sample_diameters(n, seed=seed, method=method)
        report = {"generator": "sample", "method": method, "n": int(n), "model": self.params()}
        if method == "random":
            report["seed"] = seed_record(seed)
        return with_descriptors(SizeSet.from_diameters(d, np.zeros(len(d), np.int64), report=report, model=self,
                                                       dim=self.dim), self)


def _fresh_seed():
    return np.random.SeedSequence()


def _check_prob(p):
    arr = np.asarray(p, float)
    if np.any(~np.isfinite(arr)) or np.any(arr < 0) or np.any(arr > 1):
        raise InvalidInputError(f"p={p!r}: probabilities must lie in [0, 1]")
    return arr


def _check_basis(basis):
    if basis not in ("number", "volume"):
        raise InvalidInputError(f"basis={basis!r}: allowed are 'number' and 'volume'")
    return basis


def _check_method(method):
    if method not in ("random", "quantiles"):
        raise InvalidInputError(f"method={method!r}: allowed are 'random' and 'quantiles'")
    return method


def _check_count(name, n):
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InvalidInputError(f"{name}={n!r}: must be a positive integer")
    return int(n)


def _uniform_draws(n, seed, method):
    """``n`` probabilities for inverse sampling: random (seeded) or the midpoints ``(i + 1/2)/n``."""
    n = _check_count("n", n)
    method = _check_method(method)
    return (np.arange(n) + 0.5) / n if method == "quantiles" else rng_from(seed).random(n)


def _inside(d, lo, hi):
    return (d >= lo) & (d <= hi)


# ------------------------------------------------------------------------------------------
class CumulativeBeta(SizeDistribution):
    """Cumulative beta (CB) model of the grading curve, Eq. (12) of 001_ad5bae0acea940c4.txt to Eq. (17) of 001_ad5bae0acea940c4.txt.

    ``h(d) = I_{d_r}(a, b)`` with the reduced diameter ``d_r = (d - d_min)/(d_max - d_min)``
    (Eq. (15) of 001_ad5bae0acea940c4.txt) and the regularised incomplete beta function ``I`` (``scipy.special.betainc``).

    Parameters
    ----------
    a, b : float
        Shape parameters, both > 0 (``a = b = 1``: uniform by volume fraction).
    span : float, optional
        ``s = (d_max - d_min)/(d_max + d_min)`` in (0, 1), Eq. (17) of 001_ad5bae0acea940c4.txt. Give two of
        ``span``, ``d_min``, ``d_max`` (``d_max`` defaults to 1 with ``span``).
    d_min, d_max : float, optional
        Diameter range.
    dim : {3, 2}
        Particle volume ``V ~ d**dim`` used for number <-> volume conversions.
    """

    name = "cumulative_beta"

    def __init__(self, a=1.0, b=1.0, span=None, d_min=None, d_max=None, dim=3):
        self.a = _finite_positive("a", a)
        self.b = _finite_positive("b", b)
        lo, hi = _bounds_from(span, d_min, d_max)
        super().__init__(lo, hi, dim)
        self._beta = stats.beta(self.a, self.b)

    def params(self):
        return {"model": self.name, "a": self.a, "b": self.b, "span": self.span, "d_min": self.d_min,
                "d_max": self.d_max, "dim": self.dim}

    def _x(self, d):
        return np.clip((np.asarray(d, float) - self.d_min) / (self.d_max - self.d_min), 0.0, 1.0)

    def _cdf(self, d):
        return special.betainc(self.a, self.b, self._x(d))

    def _pdf(self, d):
        d = np.asarray(d, float)
        val = self._beta.pdf(self._x(d)) / (self.d_max - self.d_min)
        return np.where(_inside(d, self.d_min, self.d_max), val, 0.0)

    def _ppf(self, p):
        return self.d_min + (self.d_max - self.d_min) * special.betaincinv(self.a, self.b, p)


def _power_integral(lo, hi, e):
    """``∫ d**e dd`` on ``[lo, hi]``."""
    e = float(e)
    return math.log(hi / lo) if abs(e + 1) < 1e-12 else (hi ** (e + 1) - lo ** (e + 1)) / (e + 1)


class _UniformInBasis(SizeDistribution):
    """Law uniform in ``d`` on ``[d_min, d_max]`` in its basis (shared by the two uniform models).

    Moments are closed forms on both sides: ``E_basis[d**k] = ∫ d**k dd / (d_max - d_min)`` and,
    weighting by ``d**w`` (``w = -dim`` from volume to number, ``+dim`` the other way),
    ``E_other[d**k] = ∫ d**(k+w) dd / ∫ d**w dd``.
    """

    def __init__(self, d_min=None, d_max=None, span=None, dim=3):
        lo, hi = _bounds_from(span, d_min, d_max)
        super().__init__(lo, hi, dim)

    def _cdf(self, d):
        return np.clip((np.asarray(d, float) - self.d_min) / (self.d_max - self.d_min), 0.0, 1.0)

    def _pdf(self, d):
        d = np.asarray(d, float)
        return np.where(_inside(d, self.d_min, self.d_max), 1.0 / (self.d_max - self.d_min), 0.0)

    def _ppf(self, p):
        return self.d_min + (self.d_max - self.d_min) * np.asarray(p, float)

    def moment(self, k, basis="number"):
        basis = _check_basis(basis)
        lo, hi = self.d_min, self.d_max
        if basis == self.basis:
            return _power_integral(lo, hi, k) / (hi - lo)
        return _power_integral(lo, hi, float(k) + self._w) / _power_integral(lo, hi, self._w)


class UniformVolume(_UniformInBasis):
    """Distribution uniform by volume fraction, Eq. (2) of 001_ad5bae0acea940c4.txt to Eq. (4) of 001_ad5bae0acea940c4.txt.

    Every size interval of equal width holds the same particle volume: ``h(d)`` is the
    straight line from ``(d_min, 0)`` to ``(d_max, 1)`` and ``f(d) ∝ d**(-dim)``. The
    partition function and its inverse are closed forms; for ``dim=2`` they are exactly
    Eq. (3) of 001_ad5bae0acea940c4.txt and Eq. (4) of 001_ad5bae0acea940c4.txt (whose Eq. (2) of 001_ad5bae0acea940c4.txt should read ``1/d**2`` for the stated
    normalisation), for ``dim=3``::

        F(d) = (d_min**-2 - d**-2) / (d_min**-2 - d_max**-2)
        F^{-1}(y) = (d_min**-2 - y (d_min**-2 - d_max**-2))**(-1/2)
    """

    name = "uniform_volume"

    # exact number side
    def number_cdf(self, d):
        return uv_cdf(np.clip(np.asarray(d, float), self.d_min, self.d_max), self.d_min, self.d_max, self.dim)

    def number_pdf(self, d):
        d = np.asarray(d, float)
        e = 1 - self.dim
        c = e / (self.d_max**e - self.d_min**e)  # normalises d**(-dim) on [d_min, d_max]
        return np.where(_inside(d, self.d_min, self.d_max), c * np.where(d > 0, d, 1.0) ** (-self.dim), 0.0)

    def number_quantile(self, p):
        return uv_ppf(_check_prob(p), self.d_min, self.d_max, self.dim)

    def sample_diameters(self, n, seed=None, method="random"):
        return uv_ppf(_uniform_draws(n, seed, method), self.d_min, self.d_max, self.dim)


def uv_cdf(d, d_min, d_max, dim=3):
    """Partition function of the law uniform by volume on ``[d_min, d_max]`` (Eq. (3) of 001_ad5bae0acea940c4.txt for dim=2).

    ``f ∝ d**(-dim)`` gives ``F(d) = (1 - (d_min/d)**(dim-1)) / (1 - (d_min/d_max)**(dim-1))``.
    """
    d = np.asarray(d, float)
    k = dim - 1
    return (1.0 - (d_min / d) ** k) / (1.0 - (np.asarray(d_min, float) / d_max) ** k)


def uv_ppf(y, d_min, d_max, dim=3):
    """Inverse of :func:`uv_cdf`; for ``dim=2`` exactly Eq. (4) of 001_ad5bae0acea940c4.txt.

    ``F^{-1}(y) = d_min (1 - y (1 - (d_min/d_max)**(dim-1)))**(-1/(dim-1))``.
    """
    y = np.asarray(y, float)
    d_min = np.asarray(d_min, float)
    d_max = np.asarray(d_max, float)
    if dim == 2:
        return d_max * d_min / (d_max + y * (d_min - d_max))
    k = dim - 1
    return d_min * (1.0 - y * (1.0 - (d_min / d_max) ** k)) ** (-1.0 / k)


def uv_mean_volume(d_min, d_max, dim=3):
    """Mean of ``d**dim`` by number in a class uniform by volume on ``[d_min, d_max]``."""
    e = 1 - dim
    return (d_max - d_min) * e / (d_max**e - d_min**e)


class UniformSize(_UniformInBasis):
    """Distribution uniform by size (number density of ``d`` constant on ``[d_min, d_max]``).

    Its grading curve is ``h(d) = (d**(dim+1) - d_min**(dim+1)) / (d_max**(dim+1) - d_min**(dim+1))``
    (closed form both ways). The seed's "a = 3, b = 1 uniform by particle sizes" of the CB
    model is the 2D, ``d_min -> 0`` limit of this law.
    """

    name = "uniform_size"
    basis = "number"

    def grading(self, d):
        k = self.dim + 1
        d = np.clip(np.asarray(d, float), self.d_min, self.d_max)
        return (d**k - self.d_min**k) / (self.d_max**k - self.d_min**k)

    def volume_pdf(self, d):
        k = self.dim + 1
        d = np.asarray(d, float)
        return np.where(_inside(d, self.d_min, self.d_max), k * d**self.dim / (self.d_max**k - self.d_min**k), 0.0)

    def quantile(self, p):
        k = self.dim + 1
        p = _check_prob(p)
        return (self.d_min**k + p * (self.d_max**k - self.d_min**k)) ** (1.0 / k)

class LogNormal(SizeDistribution):
    """Truncated log-normal distribution of diameters.

    ``ln d`` is normal with median ``median`` and standard deviation ``sigma`` in the
    given ``basis`` ("number" or "volume"), truncated to ``[d_min, d_max]`` (default
    ``median * exp(∓3 sigma)``). Weighting a log-normal number law by ``d**dim`` gives a
    log-normal volume law with median ``median * exp(dim sigma**2)`` (Hatch-Choate), and
    truncation only renormalises, so both sides are closed forms (``scipy.stats.truncnorm``).
    """

    name = "lognormal"

    def __init__(self, median=1.0, sigma=0.2, d_min=None, d_max=None, basis="number", dim=3):
        self.median = _finite_positive("median", median)
        self.sigma = _finite_positive("sigma", sigma)
        self.basis = _check_basis(basis)
        lo = self.median * math.exp(-3 * self.sigma) if d_min is None else _finite_positive("d_min", d_min)
        hi = self.median * math.exp(3 * self.sigma) if d_max is None else _finite_positive("d_max", d_max)
        if not lo < hi:
            raise InvalidInputError(f"d_min={_show(lo)} must be smaller than d_max={_show(hi)}")
        super().__init__(lo, hi, dim)
        mu = math.log(self.median)
        shift = self.dim * self.sigma**2
        mu_n, mu_v = (mu, mu + shift) if self.basis == "number" else (mu - shift, mu)
        self._laws = {"number": self._law(mu_n), "volume": self._law(mu_v)}

    def _law(self, mu):
        a = (math.log(self.d_min) - mu) / self.sigma
        b = (math.log(self.d_max) - mu) / self.sigma
        return stats.truncnorm(a, b, loc=mu, scale=self.sigma)

    def params(self):
        return {"model": self.name, "median": self.median, "sigma": self.sigma, "basis": self.basis,
                "d_min": self.d_min, "d_max": self.d_max, "dim": self.dim}

    def _side_cdf(self, side, d):
        d = np.clip(np.asarray(d, float), self.d_min, self.d_max)
        return self._laws[side].cdf(np.log(d))

    def _side_pdf(self, side, d):
        d = np.asarray(d, float)
        safe = np.clip(d, self.d_min, self.d_max)
        return np.where(_inside(d, self.d_min, self.d_max), self._laws[side].pdf(np.log(safe)) / safe, 0.0)

    def _side_ppf(self, side, p):
        return np.clip(np.exp(self._laws[side].ppf(p)), self.d_min, self.d_max)

    def _cdf(self, d):
        return self._side_cdf(self.basis, d)

    def _pdf(self, d):
        return self._side_pdf(self.basis, d)

    def _ppf(self, p):
        return self._side_ppf(self.basis, p)

    def grading(self, d):
        return self._side_cdf("volume", d)

    def volume_pdf(self, d):
        return self._side_pdf("volume", d)

    def quantile(self, p):
        return self._side_ppf("volume", _check_prob(p))

    def number_cdf(self, d):
        return self._side_cdf("number", d)

    def number_pdf(self, d):
        return self._side_pdf("number", d)

    def number_quantile(self, p):
        return self._side_ppf("number", _check_prob(p))

    def sample_diameters(self, n, seed=None, method="random"):
        return self._side_ppf("number", _uniform_draws(n, seed, method))


class Normal(SizeDistribution):
    """Truncated normal distribution of diameters in the given ``basis`` ("number" or "volume").

    Mean ``mean`` and standard deviation ``std`` of the untruncated normal; truncated to
    ``[d_min, d_max]`` (default ``mean ∓ 3 std``, which must stay > 0). The other basis
    follows from Eq. (5) of 001_ad5bae0acea940c4.txt by the exact conversion of the base class.
    """

    name = "normal"

    def __init__(self, mean=1.0, std=0.1, d_min=None, d_max=None, basis="number", dim=3):
        self.mean_ = _finite_positive("mean", mean)
        self.std = _finite_positive("std", std)
        self.basis = _check_basis(basis)
        lo = self.mean_ - 3 * self.std if d_min is None else d_min
        hi = self.mean_ + 3 * self.std if d_max is None else d_max
        lo = _finite_positive("d_min", lo)
        hi = _finite_positive("d_max", hi)
        if not lo < hi:
            raise InvalidInputError(f"d_min={_show(lo)} must be smaller than d_max={_show(hi)}")
        super().__init__(lo, hi, dim)
        self._law = stats.truncnorm((lo - self.mean_) / self.std, (hi - self.mean_) / self.std,
                                    loc=self.mean_, scale=self.std)

    def params(self):
        return {"model": self.name, "mean": self.mean_, "std": self.std, "basis": self.basis,
                "d_min": self.d_min, "d_max": self.d_max, "dim": self.dim}

    def _cdf(self, d):
        return self._law.cdf(np.clip(np.asarray(d, float), self.d_min, self.d_max))

    def _pdf(self, d):
        d = np.asarray(d, float)
        return np.where(_inside(d, self.d_min, self.d_max), self._law.pdf(d), 0.0)

    def _ppf(self, p):
        return self._law.ppf(p)


def volume_to_number_fractions(sizes, volume_fractions, dim=3):
    """Number fractions of monodisperse modes from their volume fractions: ``x_k ∝ c_k / d_k**dim``.

    For seed 000's bimodal mix (λ = 0.313, ξ = 0.333) the large spheres are
    ``1 / (1 + ξ/λ**3)`` = 8.4 % of the particles.
    """
    d = np.asarray(sizes, float)
    c = np.asarray(volume_fractions, float)
    x = c / d ** _check_dim(dim)
    return x / x.sum()


def number_to_volume_fractions(sizes, number_fractions, dim=3):
    """Volume fractions of monodisperse modes from their number fractions: ``c_k ∝ x_k d_k**dim``."""
    d = np.asarray(sizes, float)
    x = np.asarray(number_fractions, float)
    c = x * d ** _check_dim(dim)
    return c / c.sum()


class Monodisperse(SizeDistribution):
    """All particles of one diameter ``d`` (an atom; the modes of :class:`Bimodal`)."""

    name = "monodisperse"

    def __init__(self, d=1.0, dim=3):
        d = _finite_positive("d", d)
        super().__init__(d, d, dim)

    def params(self):
        return {"model": self.name, "d": self.d_min, "dim": self.dim}

    @property
    def has_atoms(self):
        return True

    @property
    def span(self):
        return 0.0

    def grading(self, d):
        return (np.asarray(d, float) >= self.d_min).astype(float)

    number_cdf = grading

    def volume_pdf(self, d):
        d = np.asarray(d, float)
        return np.where(d == self.d_min, np.inf, 0.0)

    number_pdf = volume_pdf

    def quantile(self, p):
        return np.full(np.shape(_check_prob(p)), self.d_min)

    number_quantile = quantile

    def moment(self, k, basis="number"):
        _check_basis(basis)
        return float(self.d_min) ** float(k)

    def sample_diameters(self, n, seed=None, method="random"):
        n = _check_count("n", n)
        _check_method(method)
        return np.full(n, self.d_min)


def _bisect(fn, p, lo, hi, iters=200):
    """Vectorised ``inf{d : fn(d) >= p}`` for a non-decreasing ``fn`` (jumps allowed)."""
    p = np.asarray(p, float)
    a = np.full(p.shape, float(lo))
    b = np.full(p.shape, float(hi))
    # fn(lo) >= p  -> answer lo
    at_lo = fn(a) >= p
    for _ in range(iters):
        m = 0.5 * (a + b)
        if np.all((b - a) <= 4 * np.finfo(float).eps * np.abs(b)):
            break
        ge = fn(m) >= p
        b = np.where(ge, m, b)
        a = np.where(ge, a, m)
    return np.where(at_lo, lo, b)


def _mode_components(sizes, spread, dim):
    """Modes of diameters ``sizes``: floats (monodisperse) or, with ``spread``, truncated
    log-normal number laws of median ``size`` and log-standard deviation ``spread`` (0 = monodisperse)."""
    if spread is None:
        return list(sizes)
    spreads = np.broadcast_to(np.asarray(spread, float), (len(sizes),))
    return [Monodisperse(s, dim) if sp == 0 else LogNormal(s, float(sp), dim=dim) for s, sp in zip(sizes, spreads)]


class Mixture(SizeDistribution):
    """Multimodal mixture: components (modes) with given **volume** fractions.

    ``h(d) = Σ_k c_k h_k(d)``; by number the weights become ``c_k Z_k / Σ_j c_j Z_j`` with
    ``Z_k = E_{V,k}[d**(-dim)]`` (number of particles per unit volume of mode ``k``), which
    is exact. ``species`` of a sample is the mode index in the order given.

    Parameters
    ----------
    components : sequence of SizeDistribution or float
        A float is a monodisperse mode of that diameter.
    volume_fractions : sequence of float
        Positive, summing to 1 (within 1e-9).
    """

    name = "mixture"

    def __init__(self, components, volume_fractions, dim=3):
        dim = _check_dim(dim)
        comps = [c if isinstance(c, SizeDistribution) else Monodisperse(_finite_positive("size", c), dim=dim)
                 for c in components]
        fr = np.asarray(volume_fractions, float).ravel()
        if len(comps) == 0 or len(fr) != len(comps):
            raise InvalidInputError(
                f"volume_fractions={list(np.atleast_1d(volume_fractions))}: need one fraction per mode ({len(comps)} modes)")
        if np.any(~np.isfinite(fr)) or np.any(fr <= 0):
            raise InvalidInputError(f"volume_fractions={fr.tolist()}: every fraction must be > 0")
        if abs(fr.sum() - 1.0) > 1e-9:
            raise InvalidInputError(f"volume_fractions={fr.tolist()}: must sum to 1 (sum is {fr.sum():.12g})")
        for c in comps:
            if c.dim != dim:
                raise InvalidInputError(f"component {c!r} has dim={c.dim}, mixture dim={dim}")
        self.components = comps
        self.volume_fractions = fr / fr.sum()
        super().__init__(min(c.d_min for c in comps), max(c.d_max for c in comps), dim)
        z = np.array([c.moment(-self.dim, "volume") for c in comps])
        nf = self.volume_fractions * z
        self.number_fractions = nf / nf.sum()

    @classmethod
    def from_modes(cls, sizes, volume_fractions, spread=None, dim=3):
        """Mixture of modes of diameters ``sizes``.

        ``spread=None`` (default) gives monodisperse modes; a float (or one per mode) gives
        each mode a truncated log-normal number law of median ``size`` and log-standard
        deviation ``spread`` (truncated at ±3 spread).
        """
        sizes = [float(s) for s in np.atleast_1d(sizes)]
        return cls(_mode_components(sizes, spread, dim), volume_fractions, dim=dim)

    def params(self):
        return {"model": self.name, "volume_fractions": self.volume_fractions.tolist(),
                "components": [c.params() for c in self.components], "dim": self.dim}

    @property
    def has_atoms(self):
        return any(c.has_atoms for c in self.components)

    @property
    def span(self):
        return (self.d_max - self.d_min) / (self.d_max + self.d_min)

    def grading(self, d):
        d = np.asarray(d, float)
        return np.clip(sum(c * m.grading(d) for c, m in zip(self.volume_fractions, self.components)), 0.0, 1.0)

    def volume_pdf(self, d):
        d = np.asarray(d, float)
        return sum(c * m.volume_pdf(d) for c, m in zip(self.volume_fractions, self.components))

    def number_cdf(self, d):
        d = np.asarray(d, float)
        return np.clip(sum(x * m.number_cdf(d) for x, m in zip(self.number_fractions, self.components)), 0.0, 1.0)

    def number_pdf(self, d):
        d = np.asarray(d, float)
        return sum(x * m.number_pdf(d) for x, m in zip(self.number_fractions, self.components))

    def quantile(self, p):
        p = _check_prob(p)
        return _bisect(self.grading, p, self.d_min, self.d_max)

    def number_quantile(self, p):
        p = _check_prob(p)
        return _bisect(self.number_cdf, p, self.d_min, self.d_max)

    def moment(self, k, basis="number"):
        basis = _check_basis(basis)
        w = self.number_fractions if basis == "number" else self.volume_fractions
        return float(sum(x * m.moment(k, basis) for x, m in zip(w, self.components)))

    def mode_counts(self, n):
        """Integer particle counts per mode for ``n`` particles in total.

        Every mode but the most numerous gets the integer part ``E(n x_k)`` of its exact
        share (the rounding rule of Eq. (8) of 001_ad5bae0acea940c4.txt to Eq. (9) of 001_ad5bae0acea940c4.txt); the most
        numerous mode takes the rest so the total is exactly ``n``. For seed 000's pack
        (``λ = 0.313``, ``ξ = 0.333``, N = 2000) this gives N⁽¹⁾ = 168 large spheres.
        """
        n = _check_count("n", n)
        share = n * self.number_fractions
        counts = np.floor(share + 1e-9).astype(np.int64)
        big = int(np.argmax(self.number_fractions))
        counts[big] = n - (counts.sum() - counts[big])
        return counts

    def sample_diameters(self, n, seed=None, method="random"):
        d, _ = self._sample_modes(n, seed, method)
        return d

    def _sample_modes(self, n, seed, method):
        method = _check_method(method)
        counts = self.mode_counts(n)
        ss = np.random.SeedSequence() if seed is None else seed
        from .._util import as_seed_sequence

        children = as_seed_sequence(ss).spawn(len(self.components))
        ds, sp = [], []
        for k, (m, c) in enumerate(zip(self.components, counts)):
            if c == 0:
                continue
            ds.append(m.sample_diameters(int(c), seed=children[k], method=method))
            sp.append(np.full(int(c), k, np.int64))
        return np.concatenate(ds), np.concatenate(sp)

    def sample(self, n=2000, seed=None, method="random"):
        """A :class:`SizeSet` with exact mode counts (:meth:`mode_counts`); species = mode index."""
        from .descriptors import with_descriptors
        from .sizeset import SizeSet

        seed = np.random.SeedSequence() if (seed is None and method == "random") else seed
        d, sp = self._sample_modes(n, seed, method)
        report = {"generator": "sample", "method": method, "n": int(n), "model": self.params(),
                  "mode_counts": self.mode_counts(n).tolist()}
        if seed is not None:
            report["seed"] = seed_record(seed)
        return with_descriptors(SizeSet.from_diameters(d, sp, report=report, model=self, dim=self.dim), self)


class Bimodal(Mixture):
    """Bimodal mixture of seed 000_2cedc098acbd866b.txt, by size ratio λ and volume ratio ξ.

    Mode 1 (large, ``species 0``) has diameter ``d_large``; mode 2 (small, ``species 1``)
    has ``size_ratio * d_large`` with ``size_ratio = λ = a⁽²⁾/a⁽¹⁾ <= 1``. The volume ratio
    ``ξ = c⁽²⁾/c⁽¹⁾`` gives the volume fractions ``c⁽¹⁾ = 1/(1+ξ)``, ``c⁽²⁾ = ξ/(1+ξ)``
    of the solid. Species numbering: seed mode k is species k-1 (0 = large/coarse).

    Parameters
    ----------
    size_ratio : float
        λ in (0, 1].
    volume_ratio : float
        ξ > 0.
    d_large : float
        Diameter of the large spheres (radius ``a⁽¹⁾ = d_large / 2``).
    spread : float or (float, float), optional
        Log-standard deviation of a truncated log-normal number law per mode.
    """

    name = "bimodal"

    def __init__(self, size_ratio=0.313, volume_ratio=0.333, d_large=1.0, spread=None, dim=3):
        lam = _finite_positive("size_ratio", size_ratio)
        if lam > 1.0:
            raise InvalidInputError(f"size_ratio={_show(size_ratio)}: must satisfy 0 < size_ratio <= 1 (λ = a2/a1)")
        xi = _finite_positive("volume_ratio", volume_ratio)
        dl = _finite_positive("d_large", d_large)
        self.size_ratio, self.volume_ratio, self.d_large, self.spread = lam, xi, dl, spread
        fr = [1.0 / (1.0 + xi), xi / (1.0 + xi)]
        super().__init__(_mode_components([dl, lam * dl], spread, dim), fr, dim=dim)

    def params(self):
        out = {"model": self.name, "size_ratio": self.size_ratio, "volume_ratio": self.volume_ratio,
               "d_large": self.d_large, "dim": self.dim}
        if self.spread is not None:
            out["spread"] = np.asarray(self.spread, float).tolist()
        return out


class SieveTable(Mixture):
    """Grading curve from a sieve analysis: sizes and cumulative % passing (by volume or mass).

    The curve is piecewise linear in ``d`` between sieve sizes, i.e. each sieve interval is a
    class uniform by volume fraction (the approximation of §1.2 of 001_ad5bae0acea940c4.txt,
    where "the consecutive sizes of the sieve meshes appear as a natural discretization").
    It is therefore a :class:`Mixture` of :class:`UniformVolume` pieces and all conversions
    are exact. Mass and volume fractions coincide for a single solid density.

    Parameters
    ----------
    sizes : sequence of float
        Sieve sizes (diameters), strictly increasing.
    passing : sequence of float
        Cumulative fraction passing, non-decreasing, from 0 at the first size to 1 (or
        100 with ``percent=True``) at the last.
    """

    name = "sieve"

    def __init__(self, sizes, passing, percent=True, dim=3):
        s = np.asarray(sizes, float).ravel()
        q = np.asarray(passing, float).ravel()
        if s.size < 2 or s.size != q.size:
            raise InvalidInputError(f"sieve table needs >= 2 rows of (size, passing); got {s.size} sizes and {q.size} values")
        if np.any(~np.isfinite(s)) or np.any(s <= 0):
            raise InvalidInputError(f"sieve sizes {s.tolist()}: must be positive and finite")
        bad = np.nonzero(np.diff(s) <= 0)[0]
        if bad.size:
            i = int(bad[0]) + 1
            raise InvalidInputError(f"sieve size {float(s[i])!r} (row {i}): sizes must be strictly increasing")
        top = 100.0 if percent else 1.0
        if np.any(~np.isfinite(q)):
            raise InvalidInputError(f"sieve passing {q.tolist()}: must be finite")
        bad = np.nonzero(np.diff(q) < 0)[0]
        if bad.size:
            i = int(bad[0]) + 1
            raise InvalidInputError(
                f"sieve passing {float(q[i])!r} at size {float(s[i])!r} (row {i}) is below the previous {float(q[i - 1])!r}: "
                "the grading curve must be non-decreasing")
        if abs(q[0]) > 1e-9 * top or abs(q[-1] - top) > 1e-9 * top:
            raise InvalidInputError(
                f"sieve passing runs from {float(q[0])!r} to {float(q[-1])!r}: must run from 0 to {top:g}"
                + (" (percent=True)" if percent else " (fractions)"))
        self.sizes, self.passing, self.percent = s, q / top, bool(percent)
        fv = np.diff(self.passing)
        keep = fv > 0
        comps = [UniformVolume(lo, hi, dim=dim) for lo, hi, k in zip(s[:-1], s[1:], keep) if k]
        super().__init__(comps, fv[keep] / fv[keep].sum(), dim=dim)
        self.d_min, self.d_max = float(s[0]), float(s[-1])

    @classmethod
    def from_csv(cls, path, percent=None, dim=3):
        """Read a two-column CSV ``size, passing`` (an optional header row is skipped).

        ``percent=None`` infers the unit: percent if the last value exceeds 1.
        """
        try:
            text = Path(path).read_text()
        except OSError as exc:
            raise FormatError(f"cannot read sieve table {path}: {exc.strerror}") from None
        rows = []
        for i, row in enumerate(csv.reader(_io.StringIO(text))):
            if not row or not "".join(row).strip() or row[0].lstrip().startswith("#"):
                continue
            try:
                rows.append((float(row[0]), float(row[1])))
            except (ValueError, IndexError):
                if rows:
                    raise FormatError(f"{path}: line {i + 1} {row!r} is not 'size, passing'") from None
                continue  # header
        if not rows:
            raise FormatError(f"{path}: no 'size, passing' rows found")
        arr = np.array(rows)
        if percent is None:
            percent = bool(arr[:, 1].max() > 1.0)
        return cls(arr[:, 0], arr[:, 1], percent=percent, dim=dim)

    @property
    def has_atoms(self):
        return False

    def params(self):
        return {"model": self.name, "sizes": self.sizes.tolist(), "passing": self.passing.tolist(), "dim": self.dim}
