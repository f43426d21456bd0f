"""Registry declarations of the mechanics stages (``[analysis.elastic]``, ...).

The code lives in :mod:`polypack.mechanics.stages`; the summary scalars of each stage are
listed here (names ``elastic.<key>`` in ``summary.csv`` and ``ensemble/scalars.json``;
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
        normal_stiffness=option(100.0, v.positive, "k_n per contact (seed 003 Table 1: 100 N/m)", unit="N/m"),
        shear_stiffness=option(None, v.positive, "k_s per contact (default k_n / 10, seed 003 Table 1)", unit="N/m"),
    )


_B = _bond_fields()


@dataclass(frozen=True)
class ElasticOptions:
    bonds: str = _B["bonds"]
    epsilon: float = _B["epsilon"]
    normal_stiffness: float = _B["normal_stiffness"]
    shear_stiffness: float = _B["shear_stiffness"]
    rotations: bool = option(True, v.boolean, "particles rotate (False: translations only)")
    radius: float = option(0.25e-6, v.non_negative,
                           "mean radius the lengths are rescaled to, m (moduli in Pa; seed 003: 0.25 µm); "
                           "0 keeps the pack's length unit", unit="m")
    solver: str = option("auto", v.choice("auto", "direct", "cg"), "sparse factorization or conjugate gradients")


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
)

register(
    "analysis", "elastic", ElasticOptions, "polypack.mechanics.stages:run_elastic",
    Outputs(scalars=ELASTIC_SCALARS, flatten=("shear_moduli",)),
    doc="exact elastic tensor of the bonded network (static limit of the shear test of 003_873b69fc71c74cf6.txt §2.4)",
    requires=("polypack.mechanics:elastic_tensor",),
    kernels=("polypack._kernels.cells", "polypack._kernels.network"),
)
