"""Study stages of the mechanics (``[analysis.elastic]``, ``[analysis.rigidity]``, ``[analysis.shear]`` of ``polypack run``).

Each function adapts one resolved ``[analysis.X]`` table (declared in
:mod:`polypack.mechanics._capabilities`) to the public API and returns plain data for
the realization record; the summary scalars are the numbers the declaration names.

Bonds. Both stages bond the realized pack the same way (option ``bonds``):

``"auto"`` (default)
    the bonds the protocol made, if the pack carries them (``packing.meta["bonds"]``,
    written by :func:`polypack.brownian`: bonds formed by Brownian dynamics, read with
    :func:`polypack.generate.brownian.brownian_bonds` into
    :meth:`~polypack.mechanics.BondNetwork.from_pairs`); otherwise every pair closer
    than ``(1 + epsilon)(r_i + r_j)``
    (:meth:`~polypack.mechanics.BondNetwork.from_packing`, the bonding rule of §2.4 of
    003_873b69fc71c74cf6.txt).
``"distance"``
    always the ``epsilon`` rule.
``"protocol"``
    the protocol's bonds; an error if the pack has none.

The record says which rule was used (``bonds``).  Networks are stress-free (rest
length = the current length of each bond), the reference state the exact tensor
linearises about.
"""

from __future__ import annotations

import numpy as np

from ..errors import InfeasibleError, InvalidInputError

__all__ = ["network_of", "run_elastic", "run_rigidity", "run_shear", "preflight_3d", "preflight_shear", "BOND_RULES",
           "SHEAR_KEYS"]

BOND_RULES = ("auto", "distance", "protocol")


def _stiffnesses(opts):
    kn = float(opts.get("normal_stiffness", 100.0))
    ks = opts.get("shear_stiffness")
    ks = kn / 10.0 if ks is None else float(ks)  # seed 003 Table 1: kn / ks = 10
    return kn, ks


def network_of(packing, opts, path="analysis.elastic", **strengths):
    """The stress-free :class:`~polypack.mechanics.BondNetwork` of a realized pack; ``(network, rule)``.

    ``opts`` holds ``bonds`` (:data:`BOND_RULES`), ``epsilon``, ``normal_stiffness``,
    ``shear_stiffness`` (default ``normal_stiffness / 10``) and ``stiffness`` (``"contact"``,
    the default, or ``"particle"``: per-ball values combined in series, the semantics of
    Table 1 of 003_873b69fc71c74cf6.txt); ``strengths`` go to the network
    (``normal_strength``, ``shear_strength``).
    """
    from .network import BondNetwork

    rule = opts.get("bonds", "auto")
    kn, ks = _stiffnesses(opts)
    kw = dict(normal_stiffness=kn, shear_stiffness=ks, stiffness=opts.get("stiffness", "contact"), **strengths)
    has = isinstance(packing.meta.get("bonds"), dict)
    if rule == "protocol" and not has:
        raise InvalidInputError(
            f'{path}.bonds = "protocol": this pack carries no bonds (packing.meta["bonds"], made by '
            f'protocol.kind = "brownian"); use bonds = "distance" or "auto"'
        )
    if rule != "distance" and has:
        from ..generate.brownian import brownian_bonds

        i, j, shift = brownian_bonds(packing)
        return BondNetwork.from_pairs(packing, i, j, shift, **kw), "protocol"
    return BondNetwork.from_packing(packing, epsilon=opts.get("epsilon", 0.01), **kw), "distance"


#: Protocols whose packs carry their own bonds (``packing.meta["bonds"]``).
BONDING_PROTOCOLS = ("brownian",)


def preflight_3d(opts, info, path):
    """Before a study runs: the exact tensor and the DEM need 3D spheres (``[psd] dim = 3``);
    ``bonds = "protocol"`` needs a protocol that makes bonds (:data:`BONDING_PROTOCOLS`)."""
    dim = info.get("dim", 3)
    if dim != 3:
        raise InvalidInputError(f"{path}: needs 3D spheres in a periodic box; this study's sizes are for dim={dim} "
                                "([psd] dim)")
    kind = info.get("protocol")
    if opts.get("bonds") == "protocol" and kind is not None and kind not in BONDING_PROTOCOLS:
        raise InvalidInputError(
            f'{path}.bonds = "protocol": protocol.kind = "{kind}" makes no bonds (only '
            f'{", ".join(BONDING_PROTOCOLS)} does); use bonds = "distance" or "auto"')


def preflight_shear(opts, info, path):
    """:func:`preflight_3d` and every protocol option of the DEM test
    (:func:`polypack.mechanics.dem.check_protocol`: an amplitude of 0.1 or more,
    ``steps_per_cycle`` below ``samples_per_cycle``, ...) before the first realization."""
    from .dem import check_protocol

    preflight_3d(opts, info, path)
    kw = {k: opts[k] for k in SHEAR_KEYS if opts.get(k) is not None}
    d = opts.get("directions")
    if d is not None:
        kw["directions"] = d if d == 6 else [tuple(p) for p in d]
    _prefixed(path, check_protocol, **kw)


def _prefixed(path, fn, *args, **kw):
    """Run ``fn``; its one-line InvalidInputError/InfeasibleError gets the stage's key path."""
    try:
        return fn(*args, **kw)
    except (InvalidInputError, InfeasibleError) as exc:
        msg = str(exc)
        if msg.startswith(path):
            raise
        raise type(exc)(f"{path}: {msg}") from None


def _bondless(estimator, exc):
    """The record of a pack without a single bond: floppy (G = 0), never a crash of the study.
    Any other InfeasibleError is raised."""
    if "has no bonds" not in str(exc):
        raise exc
    reason = str(exc).split(": ", 1)[-1]
    out = {"estimator": estimator, "status": "floppy", "rigid": False, "floppy": 1, "floppy_reason": reason,
           "n_bonds": 0, "coordination": 0.0}
    if estimator == "ElasticTensor":
        out.update(shear_modulus=0.0, bulk_modulus=0.0, plate_shear_modulus=0.0, shear_moduli=[0.0, 0.0, 0.0],
                   relaxation_ratio=0.0, floppy_strains=6)
    else:
        out.update(storage_modulus=0.0, static_storage_modulus=0.0, converged=0, direction={}, breakages=0,
                   problems=[f"floppy: {reason}"])
    return out


def run_elastic(packing, opts, seed):
    """``[analysis.elastic]``: the exact elastic tensor of the realized pack's bonded network.

    :func:`polypack.mechanics.elastic_tensor` of the network of :func:`network_of`
    (the static limit of the oscillatory test of §2.4 of 003_873b69fc71c74cf6.txt, for
    the contact law of Eq. (1) of 003_873b69fc71c74cf6.txt).  Returns
    :meth:`ElasticTensor.to_dict` plus the bond rule, ``epsilon`` and the stiffnesses;
    the summary scalars are listed in :mod:`polypack.mechanics._capabilities`.
    ``seed`` is unused (the tensor is deterministic).
    """
    from .elastic import elastic_tensor

    path = "analysis.elastic"
    try:
        net, rule = _prefixed(path, network_of, packing, opts, path)
    except InfeasibleError as exc:
        return _bondless("ElasticTensor", exc)
    radius = opts.get("radius", 0.25e-6)
    et = _prefixed(path, elastic_tensor, net, rotations=opts.get("rotations", True),
                   radius=radius if radius > 0 else None, solver=opts.get("solver", "auto"),
                   floppy_samples=_RIGIDITY_SAMPLES)
    _remember(packing, _tensor_key(opts), net, rule, et)
    kn, ks = _stiffnesses(opts)
    out = {"estimator": "ElasticTensor", "bonds": rule,
           "epsilon": float(opts.get("epsilon", 0.01)) if rule == "distance" else None,
           "normal_stiffness": kn, "shear_stiffness": ks, "stiffness_semantics": net.stiffness,
           "contact_normal_stiffness": float(np.mean(net.normal_stiffness)),
           "radius_m": radius if radius > 0 else None}
    out.update(et.to_dict())
    out["floppy"] = int(not et.rigid)  # summary flag: its mean is the fraction of floppy structures
    return out


# [analysis.elastic] runs before [analysis.rigidity] (stages run in name order, on the same
# pack object): it keeps its network and tensor here, with floppy-space samples drawn from its
# own factorization (a few solves), so the rigidity stage adds only its bookkeeping.
_RIGIDITY_SAMPLES = 8
_LAST = {}


def _tensor_key(opts):
    kn, ks = _stiffnesses(opts)
    return (opts.get("bonds", "auto"), float(opts.get("epsilon", 0.01)), kn, ks, opts.get("stiffness", "contact"),
            bool(opts.get("rotations", True)),
            float(opts.get("radius", 0.25e-6)), opts.get("solver", "auto"))


def _remember(packing, key, net, rule, et):
    _LAST.clear()
    _LAST.update(packing=packing, key=key, net=net, rule=rule, et=et)


def _recall(packing, key):
    """The network and tensor [analysis.elastic] made for this very pack and these options, or None."""
    if _LAST.get("packing") is packing and _LAST.get("key") == key:
        return _LAST["net"], _LAST["rule"], _LAST["et"]
    return None


def run_rigidity(packing, opts, seed):
    """``[analysis.rigidity]``: :func:`polypack.mechanics.rigidity` of the realized pack's bonded network.

    Floppy modes, rigid clusters and their percolation, the load-bearing backbone under
    the six unit strains, the non-affinity and the fabric (docs/rigidity.md; the
    intermediate step §4 of 003_873b69fc71c74cf6.txt asks for). The network is that of
    :func:`network_of`; when ``[analysis.elastic]`` ran on the same pack with the same
    bond, rotation, radius and solver options, its tensor (and the floppy-space samples
    drawn from its factorization) is reused, otherwise the tensor is computed here.
    Returns :meth:`Rigidity.to_dict` plus the bond rule; ``percolating`` is 0/1 so that its
    ensemble mean is the fraction of percolating structures. ``seed`` is unused (the
    samples have a fixed seed: the result is deterministic).
    """
    from .elastic import elastic_tensor
    from .rigidity_analysis import rigidity

    path = "analysis.rigidity"
    samples = int(opts.get("samples", _RIGIDITY_SAMPLES))
    key = _tensor_key(opts)
    hit = _recall(packing, key)
    if hit is not None and (hit[2].floppy_samples is None or hit[2].floppy_samples.shape[0] == samples):
        net, rule, et = hit
        reused = True
        _LAST.clear()  # used once: do not keep the pack and its tensor alive
    else:
        try:
            net, rule = _prefixed(path, network_of, packing, opts, path)
        except InfeasibleError as exc:  # not a single bond: floppy, nothing rigid, no backbone
            if "has no bonds" not in str(exc):
                raise
            n = int(np.asarray(packing.radii).shape[0])
            return {"estimator": "Rigidity", "status": "floppy", "floppy_reason": str(exc).split(": ", 1)[-1],
                    "n_particles": n, "n_bonds": 0, "coordination": 0.0, "n_rattlers": n, "percolating": 0,
                    "largest_cluster_fraction": 0.0, "rigid_fraction": 0.0, "backbone_fraction": 0.0,
                    "backbone_bond_fraction": 0.0}
        radius = opts.get("radius", 0.25e-6)
        et = _prefixed(path, elastic_tensor, net, rotations=opts.get("rotations", True),
                       radius=radius if radius > 0 else None, solver=opts.get("solver", "auto"),
                       floppy_samples=samples)
        reused = False
    res = _prefixed(path, rigidity, net, et, rotations=opts.get("rotations", True),
                    force_fraction=opts.get("force_fraction", 0.01), samples=samples)
    out = {"estimator": "Rigidity", "bonds": rule, "elastic_reused": reused}
    out.update(res.to_dict())
    out["percolating"] = int(res.percolating)
    return out


def _scaled(packing, radius):
    """The pack with lengths rescaled so that its mean radius is ``radius`` (None: unchanged); ``(pack, s)``."""
    if not radius:
        return packing, 1.0
    from ..packing import Packing

    s = float(radius) / float(np.mean(packing.radii))
    return Packing(np.asarray(packing.positions) * s, np.asarray(packing.radii) * s, np.asarray(packing.box) * s,
                   species=packing.species, meta=dict(packing.meta), periodic=packing.periodic), s


#: ``[analysis.shear]`` keys passed to :func:`polypack.mechanics.oscillatory_shear`.
SHEAR_KEYS = ("frequency", "amplitude", "cycles", "boundary", "ramp_cycles", "discard_cycles", "steps_per_cycle",
              "samples_per_cycle", "safety", "mass_scale", "damping", "friction", "density", "relax_first", "layers",
              "measurement_layers")


def run_shear(packing, opts, seed):
    """``[analysis.shear]``: the seed's oscillatory shear test (DEM) of the realized pack's bonded network.

    :func:`polypack.mechanics.oscillatory_shear` (§2.4 of 003_873b69fc71c74cf6.txt: G′ and
    G″ from a least-squares fit over whole cycles, per direction and their mean) on the
    network of :func:`network_of`, with lengths rescaled so that the mean radius is
    ``radius`` (default 0.25 µm, seed 003 Table 1: stresses in Pa).  Returns the
    result's ``to_dict()`` (no time series) plus ``direction`` (a table ``"g-a" ->
    {storage_modulus, loss_modulus, phase_angle, breakages}`` for the summary), the bond
    rule and the network's coordination.  ``seed`` is unused (the protocol is
    deterministic).
    """
    from .dem import oscillatory_shear

    path = "analysis.shear"
    radius = opts.get("radius", 0.25e-6)
    pk, _ = _scaled(packing, radius)
    strengths = {k: opts[k] for k in ("normal_strength", "shear_strength", "reference") if k in opts}
    try:
        net, rule = _prefixed(path, network_of, pk, opts, path, **strengths)
    except InfeasibleError as exc:
        return _bondless("ShearResult", exc)
    kw = {k: opts[k] for k in SHEAR_KEYS if k in opts}
    d = opts.get("directions", 6)
    kw["directions"] = d if d == 6 else [tuple(p) for p in d]
    res = _prefixed(path, oscillatory_shear, net, progress=False, **kw)
    out = {"estimator": "ShearResult", "bonds": rule, "stiffness_semantics": net.stiffness, "n_bonds": net.n_bonds,
           "coordination": net.coordination,
           "radius_m": radius if radius else None}
    out.update(res.to_dict(series=False))
    out["direction"] = {f"{r['normal']}-{r['shear']}": {k: r[k] for k in ("storage_modulus", "loss_modulus",
                                                                          "phase_angle", "breakages")}
                        for r in res.per_direction}
    out["breakages"] = int(sum(r["breakages"] for r in res.per_direction))
    # summary flags (means over realizations: the fraction of floppy / converged structures)
    out["floppy"] = int(res.status == "floppy")
    out["converged"] = int(res.converged)
    if res.status == "not_converged":
        # a response that is not a converged elastic one is no modulus: the numbers stay in
        # the record under "measured_*", the moduli are None (never averaged in)
        for k in ("storage_modulus", "loss_modulus", "storage_modulus_sd", "loss_modulus_sd", "complex_modulus"):
            out[f"measured_{k}"] = out.get(k)
            out[k] = None
        for row in out["direction"].values():
            row["measured_storage_modulus"], row["storage_modulus"] = row["storage_modulus"], None
            row["measured_loss_modulus"], row["loss_modulus"] = row["loss_modulus"], None
    if radius:
        sm, lm = out["storage_modulus"], out["loss_modulus"]
        out["storage_modulus_MPa"] = sm * 1e-6 if sm is not None else None
        out["loss_modulus_MPa"] = lm * 1e-6 if lm is not None else None
    return out


# --------------------------------------------------------------------------- [analysis.homogenize] (issue 34)
def _systems(opts):
    """``[(name, matrix Phase, [inclusion Phase, ...])]`` of a resolved ``[analysis.homogenize]`` table."""
    from ._capabilities import MATERIALS
    from .effective import Phase

    out = []
    names = opts.get("materials") or ([] if opts.get("matrix") is not None else ["glass/epoxy"])
    for name in names:
        m, f = MATERIALS[name]
        out.append((name, Phase.from_young(*m), [Phase.from_young(*f)]))
    if opts.get("matrix") is not None:
        incs = opts["inclusions"]
        incs = [incs] if not isinstance(incs[0], (list, tuple)) else incs
        out.append(("custom", Phase.from_young(*opts["matrix"]), [Phase.from_young(*p) for p in incs]))
    return out


def homogenize_record(packing, matrix, inclusions, opts, name="custom"):
    """One system's ``[analysis.homogenize]`` record: the full-field tensor, its isotropic moduli and ratios.

    A solve that did not converge keeps ``converged = 0`` and leaves the moduli out (no NaN
    and no unconverged number reaches a record).
    """
    from .fullfield import homogenize

    res = opts.get("resolution", 48)
    kw = dict(tolerance=opts.get("tolerance", 1e-6), max_iterations=opts.get("max_iterations", 5000),
              scheme=opts.get("scheme", "willot"), workers=opts.get("workers"),
              precision=opts.get("precision", "double"), composite=opts.get("composite", False))
    incs = inclusions if len(inclusions) > 1 else inclusions[0]
    if isinstance(res, list):
        r = homogenize(packing, matrix, incs, res[-1], resolutions=res, **kw)
    else:
        r = homogenize(packing, matrix, incs, res, **kw)
    d = r.to_dict()
    vf = r.volume_fractions
    out = {"estimator": "FFTHomogenization", "system": name, "matrix": matrix.to_dict(),
           "inclusions": [p.to_dict() for p in inclusions], "resolution": d["resolution"], "scheme": d["scheme"],
           "tolerance": d["tolerance"], "composite": int(r.composite), "converged": int(r.converged),
           "iterations": d["iterations"],
           "iterations_total": d["iterations_total"], "seconds": d["seconds"],
           "volume_fraction": float(1.0 - vf["exact"][0]), "voxel_volume_fraction": float(1.0 - vf["voxel"][0]),
           "convergence": d["convergence"]}
    if not r.converged:
        return out
    out.update(stiffness=d["stiffness"], bulk=r.bulk, shear=r.shear, young=r.young, poisson=r.poisson,
               bulk_ratio=r.bulk / matrix.bulk, shear_ratio=r.shear / matrix.shear, young_ratio=r.young / matrix.young,
               anisotropy=d["anisotropy"], asymmetry=d["asymmetry"])
    if r.extrapolated:
        ext = {}
        for q in ("bulk", "shear"):
            e = r.extrapolated[q]
            ref = getattr(matrix, q)
            ext[q + "_ratio"] = {"value": e["value"] / ref, "error": e["error"] / ref, "order": e["order"]}
        out["extrapolated"] = ext
    return out


def run_homogenize(packing, opts, seed):
    """``[analysis.homogenize]``: the full-field moduli of the pack for every material system.

    One system gives one record (``homogenize.<key>`` in ``summary.csv``), several a list
    (``homogenize0.<key>``, ``homogenize1.<key>``, ...: the ``materials`` in order, then the custom system).
    ``seed`` is unused (the solve is deterministic).
    """
    path = "analysis.homogenize"
    out = [_prefixed(path, homogenize_record, packing, m, incs, opts, name) for name, m, incs in _systems(opts)]
    return out[0] if len(out) == 1 else out
