"""Run functions of the protocols ``[protocol] kind = "brownian"`` and ``"deposit"``.

Declared in :mod:`polypack.generate._capabilities` (options, checks); each adapts the
resolved ``[protocol]`` table and the study's sizes to one public generator.

``brownian``
    :func:`polypack.brownian`: a coagulated colloidal gel by Brownian dynamics with DLVO
    forces (§2.2 of 003_873b69fc71c74cf6.txt).  The study's ``[psd]`` gives the number of
    spheres and their size, which must be one size (``model = "monodisperse"``).  The
    simulation runs in SI units with the physical radius ``protocol.radius`` (default
    0.25 µm, seed 003 Table 1); the gel is then scaled so that its radius is the
    ``[psd]`` one (``d / 2``), like every other protocol of a study, so ``r_max`` of the
    analyses is in the study's length unit.  ``meta["length_scale"]`` is that factor
    (study length per metre), ``meta["brownian"]`` keeps the simulation's SI values, and
    ``meta["bonds"]`` the bonds formed by the dynamics (scale-free: indices and periodic
    images), which ``[analysis.elastic]`` uses by default.  Set ``[psd] d = 5e-7`` to keep
    the gel in metres.  A gel whose structure was not stable within the time or step
    budget gets ``status = "time_budget"`` and is left out of the ensemble averages.
``deposit``
    :func:`polypack.deposit`: a 2D pack of disks or a 3D pack of spheres (the size set's
    dimension) by sequential deposition (§2.4 of
    001_ad5bae0acea940c4.txt); the study's ``[psd]`` must have ``dim = 2``.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError

__all__ = ["run_brownian", "run_deposit", "check_brownian", "preflight_brownian", "preflight_deposit"]


def _equal_radius(radii, path="protocol"):
    r = np.asarray(radii, dtype=np.float64)
    if r.size and np.ptp(r) > 1e-12 * float(r.max()):
        raise InvalidInputError(
            f'{path}.kind = "brownian": makes equal spheres, but [psd] gives radii from {r.min():.4g} to '
            f'{r.max():.4g}; use [psd] model = "monodisperse"')
    if r.size < 16:
        raise InvalidInputError(f'{path}.kind = "brownian": needs at least 16 spheres; [psd] n gives {r.size}')
    return float(r[0])


def check_brownian(pr: dict, path: str = "protocol") -> None:
    """Cross-key checks of a resolved ``brownian`` table: the DLVO parameters (cheap, no dynamics)."""
    from .dlvo import dlvo_parameters

    if not (0.0 < pr["volume_fraction"] <= 0.55):
        raise InvalidInputError(f"{path}.volume_fraction = {pr['volume_fraction']!r}: brownian needs (0, 0.55]")
    from .brownian import check_used

    check_used(pr, sep=" = ", prefix=f"{path}.")
    import inspect

    physical = inspect.signature(dlvo_parameters).parameters  # the DLVO keys of the table
    kw = {k: pr[k] for k in physical if k in pr and k != "surface_potential"}
    try:
        dlvo_parameters(pr["surface_potential"], **kw)
    except InvalidInputError as exc:
        raise InvalidInputError(f"{path}: {exc}") from None


def preflight_brownian(pr: dict, info: dict, path: str = "protocol") -> None:
    """Before a study runs: one size and at least 16 spheres."""
    _equal_radius(info["radii"], path)


def run_brownian(sizes, pr: dict, seed, monitor=None):
    """A BD gel of ``len(sizes)`` equal spheres, scaled to the study's radius (module docstring)."""
    from ..packing import Packing
    from .brownian import brownian

    r_study = _equal_radius(sizes.radii)
    # every field of BrownianOptions is a keyword of pp.brownian (one declaration, no key list)
    gel = brownian(int(np.asarray(sizes.radii).size), seed=seed, progress=False, **pr)
    a = float(gel.radii[0])
    s = r_study / a
    meta = dict(gel.meta)
    meta["length_scale"] = s
    meta["status"] = "target" if meta["brownian"]["converged"] else "time_budget"
    return Packing(np.asarray(gel.positions) * s, np.full(gel.n, r_study), np.asarray(gel.box) * s, meta=meta)


def preflight_deposit(pr: dict, info: dict, path: str = "protocol") -> None:
    """Before a study runs: ``floor_rule = "centred"`` needs 2D sizes (``[psd] dim = 2``), ``rule = "roll"`` 3D
    sizes and a periodic footprint."""
    dim = info.get("dim", 3)
    if pr.get("rule") == "roll" and dim != 3:
        raise InvalidInputError(f'{path}.rule = "roll": only for 3D deposits (set [psd] dim = 3; the sizes are '
                                f"for dim={dim})")
    if pr.get("rule") == "roll" and pr.get("boundary", "periodic") != "periodic":
        raise InvalidInputError(f'{path}.rule = "roll": needs boundary = "periodic"')
    if pr.get("floor_rule") not in (None, "left") and dim != 2:
        raise InvalidInputError(
            f'{path}.floor_rule = "{pr["floor_rule"]}": only for 2D deposits (set [psd] dim = 2; the sizes are '
            f"for dim={dim})")


def run_deposit(sizes, pr: dict, seed, monitor=None):
    """A deposit of the study's disks (2D) or spheres (3D) (:func:`polypack.deposit`), in a random order from ``seed``.

    The dimension is the size set's (``[psd] dim``); in 3D ``width`` is the side of a
    square footprint.
    """
    from .deposit import deposit

    return deposit(sizes, seed=seed, progress=False, **pr)  # the fields of DepositOptions are its keywords
