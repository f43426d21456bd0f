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


# --------------------------------------------------------------------------- a toy protocol (issue 30)
# One options dataclass + one run function + one register call: `polypack toy-lattice`, the study's
# [protocol] kind = "toy_lattice", `polypack run --check`, its statistics in records and summary.csv
# and its labelled report rows all come from these three.
@dataclass(frozen=True)
class ToyLatticeOptions:
    volume_fraction: float = option(0.3, v.fraction_open, "volume fraction c of the lattice pack")
    jitter: float = option(0.0, v.non_negative, "random displacement of each sphere, in units of the "
                                                "largest clearance (0: the exact lattice)", unit="clearance")


def run_toy_lattice(sizes, opts, seed, monitor=None):
    """The spheres on a simple cubic lattice of k^3 >= N sites in the periodic cube of fraction c."""
    import numpy as np

    from polypack import Packing

    r = np.asarray(sizes.radii, dtype=np.float64)
    n = r.size
    side = (float(np.sum(4.0 / 3.0 * np.pi * r**3)) / opts["volume_fraction"]) ** (1.0 / 3.0)
    k = int(round(n ** (1.0 / 3.0)))
    k += k**3 < n
    a = side / k
    sites = np.stack(np.meshgrid(*[np.arange(k)] * 3, indexing="ij"), -1).reshape(-1, 3)[:n] * a + 0.5 * a
    rng = np.random.default_rng(seed)
    clearance = max(0.5 * a - float(r.max()), 0.0)
    step = rng.uniform(-1.0, 1.0, (n, 3)) * opts["jitter"] * clearance / np.sqrt(3.0)
    meta = {"generator": "toy_lattice", "status": "target",
            "toy_lattice": {"cells": k, "spacing": a, "clearance": clearance}}
    return Packing(np.mod(sites + step, side), r, np.full(3, side), meta=meta)


register("protocol", "toy_lattice", ToyLatticeOptions, run_toy_lattice,
         Outputs(meta=("toy_lattice",), labels={"toy_lattice.cells": "lattice cells per side",
                                                "toy_lattice.spacing": "lattice spacing (length units)"}),
         doc="spheres on a simple cubic lattice (plugin)", label="Toy lattice")


# --------------------------------------------------------------------------- a toy mechanics stage
@dataclass(frozen=True)
class ToySpringOptions:
    stiffness: float = option(2.0, v.positive, "spring constant per contact", unit="N/m")
    epsilon: float = option(0.05, v.non_negative, "springs join pairs closer than (1 + epsilon)(r_i + r_j)")


def run_toy_spring(packing, opts, seed):
    """A spring on every near-contact pair (brute force): their number and stiffness per volume."""
    import numpy as np

    x, r, box = np.asarray(packing.positions), np.asarray(packing.radii), np.asarray(packing.box)
    d = x[:, None, :] - x[None, :, :]
    d -= box * np.round(d / box)
    near = np.sqrt((d * d).sum(-1)) < (1.0 + opts["epsilon"]) * (r[:, None] + r[None, :])
    count = int(np.triu(near, 1).sum())
    return {"estimator": "ToySpring", "n_springs": count,
            "stiffness_density": opts["stiffness"] * count / float(np.prod(box))}


register("mechanics", "toy_spring", ToySpringOptions, run_toy_spring,
         Outputs(labels={"n_springs": "springs (near-contact pairs)"}),
         doc="springs on the near-contact pairs (plugin)")
