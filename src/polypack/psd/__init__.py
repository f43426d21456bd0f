"""Particle-size distributions: grading curves, size classes, representativity, Hazen descriptors.

Implements 001_ad5bae0acea940c4.txt (models of particle size distribution: inverse
sampling Eq. (1) of 001_ad5bae0acea940c4.txt to Eq. (4) of 001_ad5bae0acea940c4.txt, classes Eq. (6) of 001_ad5bae0acea940c4.txt to Eq. (11) of 001_ad5bae0acea940c4.txt, cumulative beta model Eq. (12) of 001_ad5bae0acea940c4.txt to Eq. (17) of 001_ad5bae0acea940c4.txt, Hazen
coefficients Eq. (18) of 001_ad5bae0acea940c4.txt to Eq. (20) of 001_ad5bae0acea940c4.txt, regression coefficient Eq. (21) of 001_ad5bae0acea940c4.txt, accessible domain Fig. 8)
and the bimodal description (size ratio λ, volume ratio ξ) of 000_2cedc098acbd866b.txt.

Conventions: models are written in particle **diameters** ``d`` (as seed 001);
``SizeSet.radii = d / 2``. Volume-based quantities use ``V ∝ d**dim`` with ``dim=3``
(spheres) by default and ``dim=2`` (disks, seed 001's simulations) on request.
``SizeSet.species`` is the class index (0 = finest) for :func:`discretize` and the mode
index for mixtures (:class:`Bimodal`: 0 = large/coarse, 1 = small, i.e. seed 000's modes 1, 2).
"""

from importlib import import_module as _import_module

_LAZY = {
    "ClassCounts": "classes",
    "class_bounds": "classes",
    "class_counts": "classes",
    "class_volume_fractions": "classes",
    "discretize": "classes",
    "describe": "descriptors",
    "hazen": "descriptors",
    "moment": "descriptors",
    "polydispersity": "descriptors",
    "regression_coefficient": "descriptors",
    "skewness": "descriptors",
    "AccessibleDomain": "domain",
    "accessible_domain": "domain",
    "Bimodal": "models",
    "CumulativeBeta": "models",
    "LogNormal": "models",
    "Mixture": "models",
    "Monodisperse": "models",
    "Normal": "models",
    "SieveTable": "models",
    "SizeDistribution": "models",
    "UniformSize": "models",
    "UniformVolume": "models",
    "number_to_volume_fractions": "models",
    "ratio_from_span": "models",
    "span_from_ratio": "models",
    "uv_cdf": "models",
    "uv_ppf": "models",
    "volume_to_number_fractions": "models",
    "plot_class_histogram": "plots",
    "plot_grading": "plots",
    "plot_hazen_vs_span": "plots",
    "SizeSet": "sizeset",
}

__all__ = [
    "SizeDistribution", "CumulativeBeta", "UniformVolume", "UniformSize", "LogNormal", "Normal",
    "Monodisperse", "Mixture", "Bimodal", "SieveTable", "ratio_from_span", "span_from_ratio", "uv_cdf", "uv_ppf",
    "volume_to_number_fractions", "number_to_volume_fractions",
    "SizeSet", "class_bounds", "class_volume_fractions", "class_counts", "ClassCounts", "discretize",
    "hazen", "regression_coefficient", "moment", "polydispersity", "skewness", "describe",
    "accessible_domain", "AccessibleDomain", "plot_grading", "plot_class_histogram", "plot_hazen_vs_span",
]


def __getattr__(name):
    """Import the public names on first use (the package imports scipy; the registry does not need it)."""
    if name in _LAZY:
        return getattr(_import_module(f"{__name__}.{_LAZY[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
