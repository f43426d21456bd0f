"""Registry declarations of the descriptors of §2 of 000_2cedc098acbd866b.txt (``[analysis.*]``).

Each run function adapts the resolved ``[analysis.X]`` table to one estimator and
returns it computed; the runner stores ``estimator.to_dict()``, takes the summary
scalars and curves the declaration names, and plots the ensemble curves.
"""

from __future__ import annotations

from dataclasses import dataclass

from .. import _validate as v
from ..registry import Curves, Outputs, option, register


@dataclass(frozen=True)
class RDFOptions:
    r_max: float = option(3.0, v.positive, "largest distance, user length units")
    dr: float = option(0.02, v.positive, "bin width, user length units")
    method: str = option(None, v.string, "estimator variant (see polypack.analysis.RDF)", unset="'histogram'")
    scale: str = option(None, v.string, "'distance' or 'contact' (reduced R = r/(a_k + a_m))", unset="'distance'")


@dataclass(frozen=True)
class KFunctionOptions:
    r_max: float = option(3.0, v.positive, "largest distance, user length units")
    dr: float = option(0.02, v.positive, "step, user length units")
    scale: str = option(None, v.string, "'distance' or 'contact'", unset="'distance'")


@dataclass(frozen=True)
class WindowsOptions:
    window_radius: float = option(2.5, v.positive_or_list, "R_h in units of the reference sphere radius (or a list)")
    reference: str = option(None, v.string, "which radius R_h is measured in (see polypack.analysis.WindowCounts)",
                            unset="'species' (the species' mean radius, the seed's convention)")


@dataclass(frozen=True)
class ContactsOptions:
    tolerance: float = option(0.01, v.non_negative, "relative gap below which two spheres touch")
    min_contacts: int = option(None, v.int_min(0), "spheres with fewer contacts are rattlers", unset="4")


@dataclass(frozen=True)
class PoresOptions:
    n_points: int = option(100_000, v.int_min(100), "random test points")
    n_grid: int = option(None, v.int_min(10), "points of the survival-function grid", unset="200")


@dataclass(frozen=True)
class DepositOptions:
    margin: float = option(None, v.non_negative, "distance excluded from floor, walls and free surface",
                           unset="4 d_max (eight largest radii)")
    contact_tolerance: float = option(None, v.non_negative, "relative gap below which two disks touch", unset="1e-9")
    n_bins: int = option(None, v.int_min(1), "height bins of the profiles", unset="40")
    small_split: float = option(None, v.positive, "3D: radius separating small from large spheres in the "
                                "segregation profile (sqrt(r_min r_max))", unset="sqrt(r_min r_max)")
    small_layers: int = option(None, v.int_min(2), "3D: window layers of the small-volume fraction profile", unset="8")


def run_rdf(packing, opts, seed):
    import polypack.analysis as pa

    kw = {k: opts[k] for k in ("dr", "method", "scale") if k in opts}
    return pa.RDF(opts["r_max"], **kw).compute(packing)


def run_kfunction(packing, opts, seed):
    import polypack.analysis as pa

    kw = {k: opts[k] for k in ("dr", "scale") if k in opts}
    return pa.KFunction(opts["r_max"], **kw).compute(packing)


def run_windows(packing, opts, seed):
    import polypack.analysis as pa

    radii = opts["window_radius"]
    kw = {k: opts[k] for k in ("reference",) if k in opts}
    if isinstance(radii, list):
        return [pa.WindowCounts(window_radius=r, **kw).compute(packing) for r in radii]
    return pa.WindowCounts(window_radius=radii, **kw).compute(packing)


def run_contacts(packing, opts, seed):
    import polypack.analysis as pa

    kw = {k: opts[k] for k in ("tolerance", "min_contacts") if k in opts}
    return pa.Contacts(**kw).compute(packing)


def run_pores(packing, opts, seed):
    import polypack.analysis as pa

    kw = {k: opts[k] for k in ("n_grid",) if k in opts}
    return pa.PoreSizes(n_points=opts["n_points"], seed=seed, **kw).compute(packing)


def preflight_deposit_analysis(opts, info, path):
    """Before a study runs: the window statistics need a deposit (a floor): ``protocol.kind = "deposit"``."""
    from ..errors import InvalidInputError

    kind = info.get("protocol")
    if kind is not None and kind != "deposit":
        raise InvalidInputError(f'{path}: measures a deposit (floor and free surface); protocol.kind = "{kind}" makes '
                                'a fully periodic pack (use protocol.kind = "deposit")')


def run_deposit(packing, opts, seed):
    """Window statistics of a deposit (2D or 3D), with its height profiles as top-level curves."""
    import polypack.analysis as pa

    est = pa.DepositStatistics(**opts).compute(packing)
    d = est.to_dict()
    prof = d.pop("profile")
    d.update(height=prof["height"], fraction=prof["fraction"], mean_diameter=prof["mean_diameter"])
    if "small_fraction" in prof:
        d["small_fraction"] = prof["small_fraction"]
    return d


def check_r_max(opts, info, path):
    """``r_max`` beyond half the box (known before packing from N and c) is an error at once."""
    from ..errors import InvalidInputError

    half = info.get("half_box")
    if half is not None and opts["r_max"] > half:
        raise InvalidInputError(
            f"{path}.r_max = {opts['r_max']!r}: exceeds half the box length {half:.4g} of this study "
            f"(N={info['n']} at volume fraction {info['volume_fraction']}); use r_max <= {half:.4g} or more particles"
        )


_A = "polypack.analysis:"
register("analysis", "rdf", RDFOptions, run_rdf,
         Outputs(curves=Curves("r", "distance r (user length units)", "g(r)")),
         doc="radial distribution functions g(r), g_km(r): Eq. (4) of 000_2cedc098acbd866b.txt",
         requires=(_A + "RDF",), preflight=check_r_max, kernels=("polypack._kernels.cells", "polypack._kernels.analysis"))
register("analysis", "kfunction", KFunctionOptions, run_kfunction,
         Outputs(curves=Curves("r", "distance r (user length units)", "K(r)", partials=False)),
         doc="Ripley K functions K(r), K_km(r): Eq. (2) of 000_2cedc098acbd866b.txt",
         requires=(_A + "KFunction",), preflight=check_r_max,
         kernels=("polypack._kernels.cells", "polypack._kernels.analysis"))
register("analysis", "windows", WindowsOptions, run_windows,
         Outputs(curves=Curves("n_h", "spheres in the window n_h", "p(n_h)", style="points", histogram=True)),
         doc="window histograms p(n_h) (Fig. 4 of 000_2cedc098acbd866b.txt)",
         requires=(_A + "WindowCounts",), kernels=("polypack._kernels.cells", "polypack._kernels.analysis"))
register("analysis", "contacts", ContactsOptions, run_contacts,
         Outputs(flatten=("per_species",)),
         doc="coordination numbers per species pair, rattlers", requires=(_A + "Contacts",),
         kernels=("polypack._kernels.cells",))
register("analysis", "pores", PoresOptions, run_pores,
         Outputs(flatten=("fit",), curves=Curves("r", "pore radius r (user length units)", "P(r_P > r)",
                                                  plot=("survival",))),
         doc="pore-size distribution and degree of heterogeneity, Eq. (6) of 003_873b69fc71c74cf6.txt", requires=(_A + "PoreSizes",),
         kernels=("polypack._kernels.cells", "polypack._kernels.analysis"))
register("analysis", "deposit", DepositOptions, run_deposit,
         Outputs(scalars=("packing_fraction", "packing_fraction_err", "coordination", "small_fraction_slope",
                          "small_fraction_slope_err", "small_fraction_mean"), flatten=("contact_shares",),
                 curves=Curves("height", "height above the floor y (user length units)",
                               "packing fraction of the strip", plot=("fraction",))),
         doc="packing fraction, coordination and height profiles of a deposit (2D or 3D) in a bulk window (§2.4 of "
             "001_ad5bae0acea940c4.txt)", requires=(_A + "DepositStatistics",), preflight=preflight_deposit_analysis)
