"""A tiny third-party plugin: the analysis ``[analysis.largest]`` (largest and mean radius).

Installed plugins are found through the entry-point group ``polypack.capabilities``; the
test puts this folder (with its ``.dist-info``) on ``sys.path`` instead of installing it.
"""

from dataclasses import dataclass

from polypack import _validate as v
from polypack.registry import Outputs, option, register


@dataclass(frozen=True)
class LargestOptions:
    scale: float = option(1.0, v.positive, "factor applied to the radii")


def run_largest(packing, opts, seed):
    r = packing.radii * opts["scale"]
    return {"estimator": "Largest", "largest": float(r.max()), "mean": float(r.mean())}


register("analysis", "largest", LargestOptions, run_largest, Outputs(), doc="largest and mean radius (plugin)")
