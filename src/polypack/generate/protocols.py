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

__all__ = ["run_brownian", "run_deposit", "check_brownian", "preflight_brownian", "preflight_deposit",
           "preflight_vem"]


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


def _need_3d(info: dict, path: str, kind: str) -> None:
    dim = info.get("dim", 3)
    if dim != 3:
        raise InvalidInputError(f'{path}.kind = "{kind}": makes 3D sphere structures; this study\'s sizes are for '
                                f"dim={dim} (set [psd] dim = 3)")


def preflight_brownian(pr: dict, info: dict, path: str = "protocol") -> None:
    """Before a study runs: 3D sizes, one size and at least 16 spheres."""
    _need_3d(info, path, "brownian")
    _equal_radius(info["radii"], path)


def preflight_vem(pr: dict, info: dict, path: str = "protocol") -> None:
    """Before a study runs: 3D sizes, at least :data:`~polypack.generate.vem.MIN_SPHERES`
    structure spheres, at least one void, and a box of at least the minimum-image size
    (the checks :func:`polypack.vem` makes, on the study's sizes)."""
    from .vem import MIN_SPHERES

    _need_3d(info, path, "vem")
    r = np.asarray(info["radii"], dtype=np.float64)
    if r.size < MIN_SPHERES:
        raise InvalidInputError(f'{path}.kind = "vem": needs at least {MIN_SPHERES} structure spheres; [psd] n gives '
                                f"{r.size}")
    vr, phi = pr.get("void_ratio"), pr.get("volume_fraction")
    if vr is not None and int(round(vr * r.size)) < 1:
        raise InvalidInputError(f"{path}.void_ratio = {vr!r}: gives no void sphere for N = {r.size}; need at least 1")
    if phi is not None:
        red = r / float(np.mean(r))
        box_len = (float(np.sum(4.0 / 3.0 * np.pi * red**3)) / phi) ** (1.0 / 3.0)  # Eq. (5) of 003_873b69fc71c74cf6.txt
        if 2.0 * (2.0 * float(red.max()) + 0.2 * float(red.min())) >= box_len:
            raise InvalidInputError(f'{path}.kind = "vem": N = {r.size} gives a box of {box_len:.3g} mean radii, too '
                                    "small for minimum-image contacts; use more spheres ([psd] n)")


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
    width = pr.get("width")
    radii = info.get("radii")
    if width is not None and radii is not None and len(radii):
        dmax = 2.0 * float(np.max(radii))
        w = float(np.min(np.atleast_1d(np.asarray(width, dtype=np.float64))))
        if pr.get("boundary", "periodic") == "periodic" and w < 4.0 * dmax:
            raise InvalidInputError(f"{path}.width = {width!r}: below four times the largest diameter {dmax:.4g}; a "
                                    "periodic deposit needs width >= 4 d_max")
        if w < dmax:
            raise InvalidInputError(f"{path}.width = {width!r}: narrower than the largest diameter {dmax:.4g}")
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
