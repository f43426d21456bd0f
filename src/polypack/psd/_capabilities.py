"""Registry declarations of the size-distribution models (the ``[psd]`` table's ``model``).

Sizes are **diameters** as in 001_ad5bae0acea940c4.txt; ``dim`` = 3 (spheres, default)
or 2 (disks). The generation keys shared by every model (``sampling``, ``n``, ``method``,
size-class keys) are declared in :class:`Generation`; :mod:`polypack.psd.config` resolves
one ``[psd]`` table for both ``polypack psd`` and ``polypack run``.
"""

from __future__ import annotations

from dataclasses import dataclass

from .. import _validate as v
from ..registry import REQUIRED, option, register

_DIM = dict(check=v.dimension, doc="3 (spheres) or 2 (disks)")


@dataclass(frozen=True)
class Generation:
    """Keys of the ``[psd]`` table shared by every model."""

    model: str = option("bimodal", v.string, "size-distribution model (registered name or alias)")
    sampling: str = option(None, v.choice("sample", "discretize"),
                           "'sample': n particles from the number law; 'discretize': size classes "
                           "(§1.2 of 001_ad5bae0acea940c4.txt)",
                           unset="'sample', or 'discretize' when size-class keys are given without n")
    n: int = option(None, v.int_min(2), "number of particles (sampling = 'sample')", unset="2000 (sampling = 'sample')")
    method: str = option("random", v.choice("random", "quantiles"), "random draws or deterministic quantiles")
    seed: int = option(None, v.int_min(0), "random seed (polypack psd only)",
                       study=False, unset="fresh entropy, recorded in the report (a study: a child of study.seed)")
    n_classes: int = option(None, v.int_min(1), "number of size classes N_c", unset="10")
    spacing: str = option(None, v.choice("geometric", "regular", "isochoric", "modes"),
                          "class boundaries: Eq. (11) of 001_ad5bae0acea940c4.txt for geometric",
                          unset="'geometric'; 'modes' for a model of sharp modes (mixture, bimodal, sieve)")
    min_per_class: int = option(None, v.int_min(1), "N_p/c^min, Eq. (8) of 001_ad5bae0acea940c4.txt", unset="10")
    min_total: int = option(None, v.int_min(1), "N_p^min, Eq. (9) of 001_ad5bae0acea940c4.txt", unset="2000")
    max_total: int = option(None, v.int_min(2), "accessibility limit N_p^max", unset="100000")
    count_basis: str = option(None, v.choice("median", "mean"),
                              "class size used for counts: 'median' (Eq. (7) of 001_ad5bae0acea940c4.txt) or 'mean'",
                              unset="'median'")


CLASS_KEYS = ("n_classes", "spacing", "min_per_class", "min_total", "max_total", "count_basis")


@dataclass(frozen=True)
class BimodalOptions:
    size_ratio: float = option(0.313, v.size_ratio, "λ = a2/a1 <= 1 (000_2cedc098acbd866b.txt)")
    volume_ratio: float = option(0.333, v.positive, "ξ = c2/c1")
    d_large: float = option(1.0, v.positive, "diameter of the large spheres")
    spread: float = option(None, v.number_or_list(v.non_negative), "log-sd of each mode (one value or a list)",
                           unset="sharp modes (every sphere of a mode the same size)")
    dim: int = option(None, **_DIM, unset="3")


@dataclass(frozen=True)
class CumulativeBetaOptions:
    a: float = option(1.0, v.positive, "shape a > 0, Eq. (12) of 001_ad5bae0acea940c4.txt")
    b: float = option(1.0, v.positive, "shape b > 0, Eq. (12) of 001_ad5bae0acea940c4.txt")
    span: float = option(None, v.fraction_open, "span s = (d_max - d_min)/(d_max + d_min), Eq. (13) of 001_ad5bae0acea940c4.txt",
                         unset="from d_min and d_max (give two of span, d_min, d_max)")
    d_min: float = option(None, v.positive, "smallest diameter", unset="from span and d_max")
    d_max: float = option(None, v.positive, "largest diameter", unset="from span and d_min; 1.0 with span alone")
    dim: int = option(None, **_DIM, unset="3")


@dataclass(frozen=True)
class UniformOptions:
    d_min: float = option(None, v.positive, "smallest diameter", unset="from span and d_max")
    d_max: float = option(None, v.positive, "largest diameter", unset="from span and d_min; 1.0 with span alone")
    span: float = option(None, v.fraction_open, "span s = (d_max - d_min)/(d_max + d_min)",
                         unset="from d_min and d_max (give two of span, d_min, d_max)")
    dim: int = option(None, **_DIM, unset="3")


@dataclass(frozen=True)
class LogNormalOptions:
    median: float = option(1.0, v.positive, "median diameter")
    sigma: float = option(0.2, v.positive, "standard deviation of ln d")
    d_min: float = option(None, v.positive, "truncation: smallest diameter", unset="median exp(-3 sigma)")
    d_max: float = option(None, v.positive, "truncation: largest diameter", unset="median exp(3 sigma)")
    basis: str = option(None, v.choice("number", "volume"), "law given by number or by volume", unset="'number'")
    dim: int = option(None, **_DIM, unset="3")


@dataclass(frozen=True)
class NormalOptions:
    mean: float = option(1.0, v.positive, "mean diameter")
    std: float = option(0.1, v.positive, "standard deviation of d")
    d_min: float = option(None, v.positive, "truncation: smallest diameter", unset="mean - 3 std")
    d_max: float = option(None, v.positive, "truncation: largest diameter", unset="mean + 3 std")
    basis: str = option(None, v.choice("number", "volume"), "law given by number or by volume", unset="'number'")
    dim: int = option(None, **_DIM, unset="3")


@dataclass(frozen=True)
class MonodisperseOptions:
    d: float = option(1.0, v.positive, "diameter")
    dim: int = option(None, **_DIM, unset="3")


@dataclass(frozen=True)
class MixtureOptions:
    sizes: list = option(REQUIRED, v.number_list(v.positive), "diameter of each mode, e.g. [1.0, 0.3]")
    volume_fractions: list = option(REQUIRED, v.number_list(v.positive), "volume fraction of each mode (sum 1)")
    spread: float = option(None, v.number_or_list(v.non_negative), "log-sd of each mode (one value or a list)",
                           unset="sharp modes (every sphere of a mode the same size)")
    dim: int = option(None, **_DIM, unset="3")


@dataclass(frozen=True)
class SieveOptions:
    sieve: str = option(REQUIRED, v.string, "path of a CSV with columns size, passing")
    percent: bool = option(None, v.boolean, "passing given in percent",
                           unset="percent if the last passing value exceeds 1")
    dim: int = option(None, **_DIM, unset="3")


def build_monodisperse(d=1.0, dim=None):
    """One-mode mixture of diameter ``d`` (discretizable with ``spacing = "modes"``)."""
    from . import models as m

    dim = 3 if dim is None else dim
    return m.Mixture([m.Monodisperse(d, dim)], [1.0], dim=dim)


def build_mixture(sizes, volume_fractions, spread=None, dim=None):
    from . import models as m

    return m.Mixture.from_modes(sizes, volume_fractions, spread=spread, dim=3 if dim is None else dim)


def build_sieve(sieve, percent=None, dim=None):
    from . import models as m

    return m.SieveTable.from_csv(sieve, percent=percent, dim=3 if dim is None else dim)


_M = "polypack.psd.models:"
register("psd", "bimodal", BimodalOptions, _M + "Bimodal",
         doc="two lognormal or sharp modes of size ratio λ and volume ratio ξ (000_2cedc098acbd866b.txt)")
register("psd", "cumulative_beta", CumulativeBetaOptions, _M + "CumulativeBeta", aliases=("cb", "beta"),
         doc="cumulative beta grading, Eq. (12) of 001_ad5bae0acea940c4.txt")
register("psd", "uniform_volume", UniformOptions, _M + "UniformVolume", doc="uniform in volume between d_min and d_max")
register("psd", "uniform_size", UniformOptions, _M + "UniformSize", doc="uniform in diameter between d_min and d_max")
register("psd", "lognormal", LogNormalOptions, _M + "LogNormal", doc="log-normal diameters")
register("psd", "normal", NormalOptions, _M + "Normal", doc="normal diameters (truncated)")
register("psd", "monodisperse", MonodisperseOptions, build_monodisperse, doc="equal spheres of diameter d")
register("psd", "mixture", MixtureOptions, build_mixture, doc="discrete modes with volume fractions")
register("psd", "sieve", SieveOptions, build_sieve, aliases=("sieve_table",), doc="measured sieve table (CSV)")
