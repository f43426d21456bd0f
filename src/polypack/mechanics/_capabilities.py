"""Registry declarations of the mechanics stages (``[analysis.elastic]``, ``[analysis.shear]``, ``[analysis.rigidity]``).

Kind ``"mechanics"`` (:data:`polypack.registry.STAGE_KINDS`): a study names them in
``[analysis.NAME]`` tables beside the analyses, and they run on the finished pack.

The code lives in :mod:`polypack.mechanics.stages`; the summary scalars of each stage are
listed here (names ``elastic.<key>`` / ``shear.<key>`` in ``summary.csv`` and ``ensemble/scalars.json``;
documented in ``docs/mechanics.md``, "Study stages").
"""

from __future__ import annotations

from dataclasses import dataclass

from .. import _validate as v
from ..registry import Outputs, option, register


def _bond_fields():
    return dict(
        bonds=option("auto", v.choice("auto", "distance", "protocol"),
                     "bonds: the protocol's (BD) if the pack has them, else the epsilon rule ('auto'); "
                     "'distance' always the epsilon rule; 'protocol' only the protocol's"),
        epsilon=option(0.01, v.non_negative, "bond pairs closer than (1 + epsilon)(r_i + r_j) (seed 003: 0.01)"),
        normal_stiffness=option(100.0, v.positive, "k_n per contact, or per particle with stiffness = \"particle\" "
                                "(seed 003 Table 1: 100 N/m)", unit="N/m"),
        shear_stiffness=option(None, v.positive, "k_s per contact", unit="N/m", unset="k_n / 10 (seed 003 Table 1)"),
        stiffness=option("contact", v.choice("contact", "particle"),
                         "meaning of normal_stiffness/shear_stiffness: per contact, or per particle combined in "
                         "series per contact (k_a k_b / (k_a + k_b): PFC 4, seed 003 Table 1)", fill=False),
    )


_B = _bond_fields()


@dataclass(frozen=True)
class ElasticOptions:
    bonds: str = _B["bonds"]
    epsilon: float = _B["epsilon"]
    normal_stiffness: float = _B["normal_stiffness"]
    shear_stiffness: float = _B["shear_stiffness"]
    stiffness: str = _B["stiffness"]
    rotations: bool = option(True, v.boolean, "particles rotate (False: translations only)")
    radius: float = option(0.25e-6, v.non_negative,
                           "mean radius the lengths are rescaled to, m (moduli in Pa; seed 003: 0.25 µm); "
                           "0 keeps the pack's length unit", unit="m")
    solver: str = option("auto", v.choice("auto", "direct", "amg", "cg"), "sparse factorization, AMG- or block-Jacobi-preconditioned CG")


#: Summary scalars of ``[analysis.elastic]`` (``elastic.<key>``); keep these names stable.
ELASTIC_SCALARS = (
    "shear_modulus",          # G: isotropic (Voigt) average of the relaxed tensor, Pa (or pack units)
    "bulk_modulus",           # K: the same for the bulk modulus
    "affine_shear_modulus",   # G_aff: affine (no relaxation) bound
    "affine_bulk_modulus",
    "relaxation_ratio",       # G / G_aff
    "plate_shear_modulus",    # mean of C44, C55, C66 (the seed's six plate directions)
    "shear_modulus_MPa", "bulk_modulus_MPa",
    "coordination",           # Z: mean bonds per particle (all particles)
    "n_rattlers",             # particles with < 2 bonds, removed recursively
    "n_bonds",
    "floppy_modes",
    "floppy",                 # 1 when the network is floppy (G = 0 exactly; ElasticTensor.rigid), else 0
    "floppy_strains",         # strain modes of zero modulus (0 rigid ... 6)
)

register(
    "mechanics", "elastic", ElasticOptions, "polypack.mechanics.stages:run_elastic",
    Outputs(scalars=ELASTIC_SCALARS, flatten=("shear_moduli",),
            labels={"floppy": "floppy networks (1: G = 0 exactly; the mean is their fraction)",
                    "floppy_strains": "strain modes of zero modulus (0 rigid ... 6)"}),
    doc="exact elastic tensor of the bonded network (static limit of the shear test of 003_873b69fc71c74cf6.txt §2.4)",
    requires=("polypack.mechanics:elastic_tensor",), preflight="polypack.mechanics.stages:preflight_3d",
    kernels=("polypack._kernels.cells", "polypack._kernels.network"),
)


def _directions(x):
    """``6`` (or ``"all"``): the seed's six directions; else an array of [plate-normal axis, shear axis] pairs."""
    if x == 6 or x == "all":
        return 6
    if not isinstance(x, (list, tuple)) or not x:
        raise v.Bad('expected 6 (all six), "all", or pairs such as [[2, 0]] (plate normal z, sheared along x)')
    out = []
    for p in x:
        if (not isinstance(p, (list, tuple)) or len(p) != 2
                or not all(isinstance(e, int) and not isinstance(e, bool) and 0 <= e <= 2 for e in p) or p[0] == p[1]):
            raise v.Bad(f"pair {p!r}: give [plate-normal axis, shear axis], two different axes of 0, 1, 2")
        out.append([int(p[0]), int(p[1])])
    return out


_directions.describe = '6, "all" or an array of [normal, shear] axis pairs'


# The defaults of the DEM test below are those of polypack.mechanics.oscillatory_shear and
# BondNetwork (seed 003 Table 1 and §2.4), declared here for the docs, the CLI and the
# signature test (tests/test_declarations.py); fill=False keeps them out of a resolved study
# (studies written before they were declared keep their fingerprint).
@dataclass(frozen=True)
class ShearOptions:
    bonds: str = _B["bonds"]
    epsilon: float = _B["epsilon"]
    normal_stiffness: float = _B["normal_stiffness"]
    shear_stiffness: float = _B["shear_stiffness"]
    stiffness: str = _B["stiffness"]
    normal_strength: float = option(1e-4, v.positive, "bond normal strength F_nB (seed 003 Table 1)", unit="N",
                                    fill=False)
    shear_strength: float = option(1e-6, v.positive, "bond shear strength F_sB (seed 003 Table 1)", unit="N",
                                   fill=False)
    reference: str = option("stress-free", v.choice("stress-free", "zero-gap"),
                            "bond rest length: current ('stress-free') or r_i + r_j ('zero-gap', relaxed first)",
                            fill=False)
    radius: float = option(0.25e-6, v.non_negative, "mean radius the lengths are rescaled to, m (stresses in Pa); "
                                                    "0 keeps the pack's length unit", unit="m")
    boundary: str = option("lees-edwards", v.choice("lees-edwards", "plates"), "Lees-Edwards cell or the seed's plates",
                           fill=False)
    directions: list = option(6, _directions, "6 (the seed's six) or [[normal, shear], ...] axis pairs", fill=False)
    frequency: float = option(1.0, v.positive, "drive frequency f", unit="Hz", fill=False)
    amplitude: float = option(1e-3, v.positive, "peak shear strain (1e-3: 0.1 % of the box)", fill=False)
    cycles: int = option(10, v.int_min(1), "oscillation cycles per direction", fill=False)
    ramp_cycles: int = option(None, v.int_min(0), "cycles of the amplitude ramp",
                              unset="all cycles (the seed's linearly increasing deflection)")
    discard_cycles: int = option(1, v.int_min(0), "cycles left out of the fit", fill=False)
    steps_per_cycle: int = option(4000, v.int_min(10), "time steps per cycle (the masses are scaled to it)",
                                  fill=False)
    samples_per_cycle: int = option(100, v.int_min(4), "stress samples per cycle (at most steps_per_cycle)",
                                    fill=False)
    safety: float = option(0.5, v.fraction_closed, "time step over the critical step when scaling masses",
                           fill=False)
    mass_scale: float = option(None, v.positive, "fixed density scale factor",
                               unset="chosen so that the time step 1/(frequency steps_per_cycle) is safety times the "
                                     "critical step")
    damping: float = option(0.9, v.fraction_closed, "local damping coefficient alpha", fill=False)
    friction: float = option(0.0, v.non_negative, "friction coefficient of unbonded contacts", fill=False)
    density: float = option(3690.0, v.positive, "particle density before mass scaling", unit="kg/m³", fill=False)
    relax_first: bool = option(None, v.boolean, "relax before shearing",
                               unset="when the mean unbalanced force exceeds that of a bond stretched by 1e-6 of its "
                                     "length (prestressed)")
    layers: int = option(3, v.int_min(1), "plate thickness in mean diameters (plates)", fill=False)
    measurement_layers: int = option(5, v.int_min(1), "stress-measurement slabs across the sample (plates)",
                                     fill=False)
    realizations: int = option(None, v.int_min(1), "run the test on realizations 0 .. N-1 of a study only "
                                                    "(the others have no [analysis.shear] record; issue 32)",
                               cli=False, unset="every realization")


#: Summary scalars of ``[analysis.shear]`` (``shear.<key>``; per direction ``shear.direction.<g>-<a>.<key>``).
SHEAR_SCALARS = (
    "storage_modulus", "loss_modulus",          # G', G'': means over the directions run
    "storage_modulus_sd", "loss_modulus_sd",    # their standard deviations over the directions (seed Table 2)
    "complex_modulus", "phase_angle",           # |G*| and the phase angle delta (rad), means over directions
    "storage_modulus_MPa", "loss_modulus_MPa",
    "breakages", "n_bonds", "coordination",
    "time_step", "mass_scale", "steps_per_cycle", "inertial_error",
    "floppy",                                   # 1: the network is floppy (G' = 0, no DEM run), else 0
    "converged",                                # 1: status "ok"; 0: floppy or not converged (moduli None)
    "static_storage_modulus",                   # the exact static limit of G' (elastic_tensor)
)

register(
    "mechanics", "shear", ShearOptions, "polypack.mechanics.stages:run_shear",
    Outputs(scalars=SHEAR_SCALARS, flatten=("direction",),
            labels={"floppy": "floppy networks (1: G' = 0, no DEM run; the mean is their fraction)",
                    "converged": "converged elastic responses (1: status ok; 0: floppy or not converged, moduli None)",
                    "static_storage_modulus": "static limit of G' (exact tensor, directions run)"}),
    doc="oscillatory shear test by bonded DEM: G', G'' (§2.4 of 003_873b69fc71c74cf6.txt)",
    requires=("polypack.mechanics:oscillatory_shear",), preflight="polypack.mechanics.stages:preflight_shear",
    kernels=("polypack._kernels.cells", "polypack._kernels.network", "polypack._kernels.contacts", "polypack._kernels.dem"),
)


# --------------------------------------------------------------------------- [analysis.homogenize] (issue 34)
def _young_pair(x):
    """``[E, nu]``: Young's modulus >= 0 and Poisson's ratio in (-1, 0.5)."""
    x = v._split(x)
    if not isinstance(x, (list, tuple)) or len(x) != 2 or any(isinstance(e, (list, tuple)) for e in x):
        raise v.Bad("expected [E, nu] (Young's modulus, Poisson's ratio), e.g. [3.01e9, 0.394]")
    e, nu = (v.number(float(t) if isinstance(t, str) else t) for t in x)
    if not e >= 0 or e == float("inf"):
        raise v.Bad(f"Young's modulus {e!r} must be finite and >= 0")
    if not -1.0 < nu < 0.5:
        raise v.Bad(f"Poisson's ratio {nu!r} must lie in (-1, 0.5) (a voxel solver needs a finite bulk modulus)")
    return [e, nu]


_young_pair.describe = "[E, nu] with E >= 0, -1 < nu < 0.5"


def _young_pairs(x):
    if isinstance(x, (list, tuple)) and x and all(isinstance(e, (list, tuple)) for e in x):
        return [_young_pair(e) for e in x]
    return [_young_pair(x)]


_young_pairs.describe = "[E, nu] or an array of [E, nu], one per species"

#: Named material systems of ``[analysis.homogenize] materials`` (matrix [E, nu], inclusion [E, nu]).
MATERIALS = {
    "glass/epoxy": ([3.01e9, 0.394], [76e9, 0.23]),       # seed 000 Figs. 8-9 (contrast E 25)
    "AP/HTPB": ([0.6e6, 0.499], [32.45e9, 0.1433]),       # propellant: contrast E 5.4e4, near-incompressible binder
}


def _materials(x):
    x = [x] if isinstance(x, str) else x
    if not isinstance(x, (list, tuple)) or not all(isinstance(e, str) for e in x):
        raise v.Bad(f"expected names from {sorted(MATERIALS)}")
    for e in x:
        if e not in MATERIALS:
            raise v.Bad(f"unknown material system {e!r}; allowed: {', '.join(sorted(MATERIALS))}")
    return list(x)


_materials.describe = "material systems: " + ", ".join(sorted(MATERIALS))


def _resolutions(x):
    xs = x if isinstance(x, (list, tuple)) else [x]
    if not xs or any(isinstance(e, bool) or not isinstance(e, int) or e < 4 for e in xs) or sorted(xs) != list(xs):
        raise v.Bad("expected an integer >= 4 or an increasing array of them (e.g. [32, 48, 64])")
    return xs if isinstance(x, (list, tuple)) else int(x)


_resolutions.describe = "voxels along the box: an integer or an increasing array (Richardson estimate)"


@dataclass(frozen=True)
class HomogenizeOptions:
    matrix: list = option(None, _young_pair, "matrix phase [E, nu] (Pa); with inclusions: one custom system",
                          unset="none: only the named materials")
    inclusions: list = option(None, _young_pairs, "inclusion phase [E, nu] for every species, or one per species",
                              unset="none: only the named materials")
    materials: list = option(None, _materials, "named systems solved as well: 'glass/epoxy', 'AP/HTPB'",
                             unset="'glass/epoxy' without matrix and inclusions, else none")
    resolution: int = option(48, _resolutions, "voxels along the longest box axis; an array gives the resolution "
                                               "series and its Richardson estimate")
    tolerance: float = option(1e-6, v.fraction_open, "CG stops at this relative residual")
    max_iterations: int = option(5000, v.int_min(1), "CG iterations per load case before giving up")
    scheme: str = option("willot", v.choice("willot", "fourier"), "discrete (rotated, Willot) or continuous Green operator")
    workers: int = option(None, v.int_min(1), "FFT threads", unset="all CPUs")
    composite: bool = option(False, v.boolean, "composite voxels (coated HS rule from sub-voxel fractions): exact "
                                                "phase volumes, no stiff bridges between near-touching spheres")
    precision: str = option("double", v.choice("double", "single"), "float64 or float32 fields and FFTs "
                                                                     "(single: half the memory, ~2x faster)")


def _check_homogenize(resolved, path):
    from ..errors import InvalidInputError

    t = resolved
    if (t.get("matrix") is None) != (t.get("inclusions") is None):
        raise InvalidInputError(f"{path}: give both matrix and inclusions, or neither (and materials)")


#: Summary scalars of ``[analysis.homogenize]`` (``homogenize.<key>``; ``homogenize<i>.<key>`` with several systems).
HOMOGENIZE_SCALARS = (
    "bulk", "shear", "young", "poisson",                 # isotropic projections of the full-field tensor, Pa
    "bulk_ratio", "shear_ratio", "young_ratio",          # over the matrix: K*/K0, mu*/mu0, E*/E0
    "volume_fraction", "voxel_volume_fraction",          # exact and voxel inclusion fractions
    "iterations", "iterations_total", "converged", "seconds", "anisotropy", "asymmetry",
)

register(
    "analysis", "homogenize", HomogenizeOptions, "polypack.mechanics.stages:run_homogenize",
    Outputs(scalars=HOMOGENIZE_SCALARS, flatten=("stiffness", "extrapolated")),
    doc="full-field effective stiffness of the pack's voxel image (FFT Lippmann-Schwinger, CG; docs/fullfield.md)",
    requires=("polypack.mechanics:homogenize",), preflight="polypack.mechanics.stages:preflight_3d",
    check=_check_homogenize, kernels=("polypack._kernels.voxel",),
)


@dataclass(frozen=True)
class RigidityOptions:
    bonds: str = _B["bonds"]
    epsilon: float = _B["epsilon"]
    normal_stiffness: float = _B["normal_stiffness"]
    shear_stiffness: float = _B["shear_stiffness"]
    stiffness: str = _B["stiffness"]
    rotations: bool = option(True, v.boolean, "particles rotate (False: translations only; Z_c = 2 instead of 4)")
    radius: float = option(0.25e-6, v.non_negative,
                           "mean radius the lengths are rescaled to, m (as [analysis.elastic]; 0 keeps the pack's unit)",
                           unit="m")
    solver: str = option("auto", v.choice("auto", "direct", "amg", "cg"),
                         "solver of the elastic tensor the backbone comes from (as [analysis.elastic])")
    force_fraction: float = option(0.01, v.positive,
                                   "backbone: bonds with a force above this fraction of the mean bond force under a unit strain")
    samples: int = option(8, v.int_min(1), "random zero-mode vectors drawn to find the rigid clusters")


#: Summary scalars of ``[analysis.rigidity]`` (``rigidity.<key>``; docs/rigidity.md).
RIGIDITY_SCALARS = (
    "floppy_modes",               # zero modes of the relaxing part (elastic_tensor's count)
    "floppy_per_particle",
    "floppy_modes_floating",      # internal zero modes of clusters that do not wrap the box
    "states_of_self_stress",      # S = F - (nd N - 3 M - 3 K) (index theorem)
    "coordination", "isostatic_coordination",
    "n_rattlers", "n_clusters",
    "largest_cluster_fraction",   # particles in the largest rigid cluster / N
    "rigid_fraction",             # particles in rigid clusters of two or more / N
    "rigid_bond_fraction",
    "percolating",                # 1 when a rigid cluster wraps every periodic axis
    "backbone_fraction",          # particles joined by a load-bearing bond under any unit strain / N
    "backbone_bond_fraction",
    "backbone_coordination",      # 2 M_b / N_b of that backbone
    "excess_coordination",        # backbone_coordination - isostatic_coordination
    "nonaffinity",                # Gamma = <|u - u_aff|^2> / (gamma^2 d^2), mean of the three shears
    "fabric_anisotropy", "backbone_fabric_anisotropy",
    "seconds",
)

register(
    "mechanics", "rigidity", RigidityOptions, "polypack.mechanics.stages:run_rigidity",
    Outputs(scalars=RIGIDITY_SCALARS,
            flatten=("shear_fabric", "backbone_shear_fabric", "nonaffinity_modes", "backbone_coordination_modes")),
    doc="rigidity of the bonded network: floppy modes, rigid clusters, percolation, load-bearing backbone, "
        "non-affinity, fabric (the intermediate step of §4 of 003_873b69fc71c74cf6.txt)",
    requires=("polypack.mechanics:rigidity",), preflight="polypack.mechanics.stages:preflight_3d",
    kernels=("polypack._kernels.cells", "polypack._kernels.network", "polypack._kernels.rigidity"),
)
