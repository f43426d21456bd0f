"""The seed's relaxation of a bonded network (§2.2 of 003_873b69fc71c74cf6.txt): :func:`relax`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._util import progress_bar
from ..errors import InvalidInputError
from ._dem_system import _NO_LAYER_SAMPLES, _NO_LAYERS, DEFAULTS, _network, _omega_max, _params, _System


@dataclass
class RelaxResult:
    """Outcome of :func:`relax`: relaxed positions and the unbalanced-force history."""

    positions: np.ndarray
    steps: int
    unbalanced_force: np.ndarray  # mean |F| over spheres at each check
    contact_force: np.ndarray  # mean contact force at each check
    criterion: str
    converged: bool
    time_step: float
    max_displacement: float = 0.0
    mean_displacement: float = 0.0

    @property
    def unbalanced_ratio(self) -> float:
        """Final mean unbalanced force over the mean contact force (PFC's ratio)."""
        cf = self.contact_force[-1] if self.contact_force.size else 0.0
        return float(self.unbalanced_force[-1] / cf) if cf > 0 else 0.0

    def to_dict(self) -> dict:
        return {"steps": self.steps, "criterion": self.criterion, "converged": self.converged,
                "max_displacement": self.max_displacement, "mean_displacement": self.mean_displacement,
                "time_step": self.time_step, "unbalanced_ratio": self.unbalanced_ratio,
                "unbalanced_force": self.unbalanced_force.tolist(),
                "contact_force": self.contact_force.tolist()}


def relax(network, check_every: int = 100, tolerance: float = 1e-3, patience: int = 3,
          max_steps: int = 200_000, density: float = DEFAULTS["density"], progress=None) -> RelaxResult:
    """The seed's relaxation: steps with all velocities reset to zero after each one.

    §2.2 of 003_873b69fc71c74cf6.txt relaxes the bonded structures (bonds installed at
    ``d < (1 + ε) 2 r0``; with PFC's zero reference gap they start in tension) by
    calculation steps after each of which the translational and rotational velocities
    are set to zero, "aborted as soon as the mean unbalanced force in the structure has
    decreased to a constant value".  Criterion used here: every ``check_every`` steps
    the mean unbalanced force ``F̄_u`` (mean ``|F|`` over spheres) is compared with its
    smallest earlier value; the run stops when it has failed to fall by more than the
    relative ``tolerance`` at ``patience`` consecutive checks, or when it is below
    ``1e-12`` of the mean contact force, or after ``max_steps``.

    Each step is a gradient step ``x += F dt² / m`` with ``dt`` 0.9 times the stability
    limit ``sqrt(2) / ω_max`` of this iteration (independent of the density, which only
    rescales ``dt``).

    Returns
    -------
    RelaxResult
        ``positions`` (unwrapped centres), the history and the criterion met.
    """
    from .._kernels import dem as K

    net = _network(network)
    for name, v, lo in (("check_every", check_every, 1), ("patience", patience, 1), ("max_steps", max_steps, 1)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
            raise InvalidInputError(f"{name}={v!r}: must be an integer >= {lo}")
    if not (tolerance > 0):
        raise InvalidInputError(f"tolerance={tolerance!r}: must be > 0")
    dt = 0.9 * math.sqrt(2.0) / _omega_max(net, density)
    sys_ = _System(net, net.pos.copy(), density, "lees-edwards", 2, 0, 0.0)
    sys_.reach = 0.0  # no unbonded contacts during relaxation (none exist in a non-overlapping pack)
    p = _params(K, dt, 1.0, 0.0, 1.0, 0.0, 0.0, float(np.prod(net.box)), net.box[2], 0, 2, K.MODE_RELAX,
                check_every, 0.0)
    cap = max_steps // check_every + 2
    samples = np.zeros((cap, K.N_S))
    ns = 0
    best = np.inf
    bad = 0
    criterion = f"max_steps={max_steps} reached"
    converged = False
    bar = progress_bar(total=max_steps, desc="relax", progress=progress, unit="step")
    try:
        done = 0
        while done < max_steps:
            nstep = min(check_every, max_steps - done)
            _, steps, ns = K.run(nstep, sys_.pos, sys_.vel, sys_.omg, sys_.radii, sys_.mass, sys_.inertia,
                                 sys_.kind, sys_.pos0, sys_.h0, *sys_.contacts.args(), p, sys_.st, samples, ns,
                                 sys_.xbuild, _NO_LAYERS, _NO_LAYER_SAMPLES)
            done += steps
            bar.update(steps)
            fu = samples[ns - 1, K.S_UNBALANCED]
            fc = samples[ns - 1, K.S_CONTACT_FORCE]
            if fc > 0 and fu <= 1e-12 * fc:
                criterion = "mean unbalanced force below 1e-12 of the mean contact force"
                converged = True
                break
            if fu < best * (1.0 - tolerance):
                best = fu
                bad = 0
            else:
                bad += 1
                if bad >= patience:
                    criterion = (f"mean unbalanced force stopped decreasing (less than {tolerance:g} relative "
                                 f"over {patience} checks of {check_every} steps)")
                    converged = True
                    break
    finally:
        bar.close()
    out = np.empty_like(net.pos)
    out[sys_.perm] = sys_.pos[: net.pos.shape[0]]
    moved = np.linalg.norm(out - net.pos, axis=1)
    return RelaxResult(out, int(sys_.st[K.ST_STEP]),
                       samples[:ns, K.S_UNBALANCED].copy(), samples[:ns, K.S_CONTACT_FORCE].copy(), criterion,
                       converged, dt, float(moved.max()), float(moved.mean()))
