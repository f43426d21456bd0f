"""Registry declarations of the stages that combine analysis and mechanics (``[analysis.moduli]``).

:mod:`polypack.analysis` and :mod:`polypack.mechanics` are siblings that never import each
other; a stage that needs both (ζ2/η2 of the pack and the effective-medium estimates)
lives here, one layer up, next to the stage runner (code: :mod:`polypack.ensemble.moduli_stage`).
"""

from __future__ import annotations

from dataclasses import dataclass

from .. import _validate as v
from ..registry import REQUIRED, Outputs, option, register


def _pair(x):
    """``[E, nu]``: Young's modulus >= 0 and Poisson's ratio in (-1, 0.5]."""
    x = v._split(x)
    if not isinstance(x, (list, tuple)) or len(x) != 2 or any(isinstance(e, (list, tuple)) for e in x):
        raise v.Bad("expected [E, nu] (Young's modulus, Poisson's ratio), e.g. [3.01e9, 0.394]")
    e, nu = (v.number(float(t) if isinstance(t, str) else t) for t in x)
    if e < 0:
        raise v.Bad(f"Young's modulus {e!r} must be >= 0")
    if not -1.0 < nu <= 0.5:
        raise v.Bad(f"Poisson's ratio {nu!r} must lie in (-1, 0.5]")
    return [e, nu]


_pair.describe = "[E, nu] with E >= 0, -1 < nu <= 0.5"


def _pairs(x):
    """``[E, nu]`` for every species, or ``[[E1, nu1], [E2, nu2], ...]`` one per species."""
    if isinstance(x, (list, tuple)) and x and all(isinstance(e, (list, tuple)) for e in x):
        return [_pair(e) for e in x]
    return [_pair(x)]


_pairs.describe = "[E, nu] or an array of [E, nu], one per species"


@dataclass(frozen=True)
class ModuliOptions:
    matrix: list = option(REQUIRED, _pair, "matrix phase [E, nu] (E in any unit; ratios are reported)")
    inclusions: list = option(REQUIRED, _pairs, "inclusion phase [E, nu] for every species, or one [E, nu] per species")
    three_point: bool = option(True, v.boolean, "measure zeta2, eta2 on the pack and the three-point bounds "
                                                "(one inclusion phase only)")
    mefm: bool = option(True, v.boolean, "RDF-dependent pair estimate (MEFM) from the pack's partial RDFs")


#: Estimates of ``[analysis.moduli]``: summary scalars ``moduli.<estimate>.<quantity>``.
MODULI_ESTIMATES = ("mori_tanaka", "self_consistent", "hs_lower", "hs_upper", "three_point_lower",
                    "three_point_upper", "mefm")

register(
    "mechanics", "moduli", ModuliOptions, "polypack.ensemble.moduli_stage:run_moduli",
    Outputs(scalars=("volume_fraction", "zeta2", "eta2"), flatten=MODULI_ESTIMATES),
    doc="effective moduli of the composite (MT, SC, HS, three-point bounds, MEFM), §4 of 000_2cedc098acbd866b.txt",
    requires=("polypack.mechanics:mori_tanaka", "polypack.analysis:ThreePointParameters"),
    preflight="polypack.mechanics.stages:preflight_3d",
    kernels=("polypack._kernels.cells", "polypack._kernels.analysis", "polypack._kernels.threepoint"),
)
