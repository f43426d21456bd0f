"""The stages of one realization: sizes -> packing protocol -> analyses.

Each stage is a small adapter from the resolved study (:mod:`polypack.study`) to one
public polypack function, so a change of a signature is fixed in one place.
:func:`realize` chains them; it is a pure function of the resolved study and the
realization's seed record, so it gives the same result in-process, in a process pool
or on a Dask worker.
"""

from __future__ import annotations

import math

import numpy as np

from .. import registry
from .._util import seed_from_record, seed_record
from ..errors import InvalidInputError
from ..geometry import unit_ball_volume

__all__ = ["make_sizes", "make_packing", "run_analyses", "realize", "stage_seeds", "check_available", "preflight",
           "study_kernels", "compile_kernels"]

def stage_seeds(seed_rec):
    """Independent child seeds of one realization: ``(sizes, protocol, analysis)``."""
    ss = seed_from_record(seed_rec)
    return tuple(ss.spawn(3))


# --------------------------------------------------------------------------- sizes
def make_model(psd: dict):
    """The :mod:`polypack.psd` model of the resolved ``[psd]`` table (the registered model)."""
    from ..psd.config import make_model as _make_model

    return _make_model(psd)


def make_sizes(psd: dict, seed):
    """A :class:`polypack.psd.SizeSet` from the resolved ``[psd]`` table.

    The same code as ``polypack psd`` (:func:`polypack.psd.config.make_sizes`):
    ``model.sample(n=, seed=, method=)`` or ``polypack.psd.discretize(model, ...)`` (§1.2 of
    001_ad5bae0acea940c4.txt).
    """
    from ..psd.config import make_sizes as _make_sizes

    return _make_sizes(psd, seed)


# --------------------------------------------------------------------------- packing
def _protocol(study_data):
    return registry.get("protocol", study_data["protocol"]["kind"], path="protocol.kind")


def _shake_options(pr):
    from ..generate._capabilities import shake_options

    return shake_options(pr)


def study_kernels(study_data) -> list[str]:
    """The numba kernel modules a study runs (its protocol's and analyses', plus the monitor's)."""
    mods = list(_protocol(study_data).kernels)
    for name in sorted(study_data.get("analysis", {})):
        mods += list(registry.get("analysis", name).kernels)
    mods += ["polypack._kernels.cells", "polypack._kernels.analysis"]  # the contact-value monitor of shaking
    return list(dict.fromkeys(mods))


def compile_kernels(study_data) -> dict:
    """Compile (or load from the numba cache) the kernels a study needs, in this process.

    Run before a process pool starts, so the workers load the cache instead of all
    compiling the same kernels at once. Returns ``{module: seconds}``.
    """
    return {mod: compile_module(mod) for mod in study_kernels(study_data)}


def compile_module(mod: str) -> float:
    """Compile (or load from the numba cache) one kernel module; the seconds it took."""
    import importlib
    import time

    t0 = time.perf_counter()
    fn = getattr(importlib.import_module(mod), "warmup", None)
    if fn is not None:
        fn()
    return time.perf_counter() - t0


def check_available(study_data):
    """Raise InvalidInputError (with the key path) if a stage the study needs is missing.

    Run by the runner before any realization starts, so a study asking for a protocol or
    analysis whose implementation does not import here fails at once.
    """
    pr = study_data["protocol"]
    cap = _protocol(study_data)
    if not cap.available():
        raise InvalidInputError(
            f'protocol.kind = "{pr["kind"]}": {", ".join(cap.requires)} is not available in this installation'
        )
    model = registry.get("psd", study_data["psd"]["model"], path="psd.model")
    if not model.available():
        raise InvalidInputError(f'psd.model = "{study_data["psd"]["model"]}": not available in this installation')
    for name in study_data.get("analysis", {}):
        cap = registry.get("analysis", name, path="analysis")
        if not cap.available():
            raise InvalidInputError(f"analysis.{name}: {', '.join(cap.requires)} is not available here")


def _check_shake_options(pr):
    """Let :func:`polypack.shake` judge the shake options on a two-sphere pack (no shakes)."""
    opts = _shake_options(pr)
    if not opts or not (pr["kind"] == "scrm" or pr.get("global_shakes", 0) > 0):
        return
    import polypack as pp
    from ..generate.shake import options_check
    from ..packing import Packing

    tiny = Packing(np.array([[0.0, 0.0, 0.0], [2.5, 2.5, 2.5]]), np.array([0.5, 0.25]), np.full(3, 5.0),
                   species=np.array([0, 1]))
    try:
        with options_check():  # no kernel compiles in this (the main) process
            pp.shake(tiny, global_shakes=0, seed=0, progress=False, **opts)
    except InvalidInputError as exc:
        msg = str(exc)
        from ..generate._capabilities import SHAKE_KEYWORDS  # protocol key -> shake() argument

        key = next((k for k, a in SHAKE_KEYWORDS.items() if msg.startswith(f"{a}=")), None)
        raise InvalidInputError(f"protocol.{key}: {msg}" if key else f"protocol: {msg}") from None


_KEPLER = math.pi / math.sqrt(18.0)


def _check_analysis_options(analyses):
    """Build every estimator with its options (no computation): bad values fail here, with the key path."""
    import polypack.analysis as pa

    build = {
        "rdf": lambda o: pa.RDF(o["r_max"], **{k: o[k] for k in ("dr", "method", "scale") if k in o}),
        "kfunction": lambda o: pa.KFunction(o["r_max"], **{k: o[k] for k in ("dr", "scale") if k in o}),
        "windows": lambda o: [pa.WindowCounts(window_radius=w, **{k: o[k] for k in ("reference",) if k in o})
                              for w in (o["window_radius"] if isinstance(o["window_radius"], list)
                                        else [o["window_radius"]])],
        "contacts": lambda o: pa.Contacts(**{k: o[k] for k in ("tolerance", "min_contacts") if k in o}),
        "pores": lambda o: pa.PoreSizes(n_points=o["n_points"], seed=0, **{k: o[k] for k in ("n_grid",) if k in o}),
    }
    for name, opts in analyses.items():
        if name not in build:
            continue
        try:
            build[name](opts)
        except InvalidInputError as exc:
            raise InvalidInputError(f"analysis.{name}: {exc}") from None


def preflight(study_data, seed_rec):
    """Cheap checks on realization 0's sizes before anything runs (``run --check`` and run start).

    Every analysis is built with its options; the box follows from the sizes and the
    target volume fraction, so an ``r_max`` or window beyond half the box, a sphere
    larger than half the box, or equal spheres above the FCC density (which would fail
    or jam after every packing) are reported at once with their key paths (each
    capability's ``preflight`` hook, then the window radii).
    """
    _check_shake_options(study_data["protocol"])
    _check_analysis_options(study_data.get("analysis", {}))
    s_sizes, _, _ = stage_seeds(seed_rec)
    sizes = make_sizes(study_data["psd"], s_sizes)
    vf = study_data["protocol"].get("volume_fraction")
    r = np.asarray(sizes.radii, dtype=np.float64)
    pcap = _protocol(study_data)
    if pcap.preflight is not None:  # the protocol's own checks on the sizes (one size, 2D, ...)
        registry._load(pcap.preflight)(
            {k: v for k, v in study_data["protocol"].items() if k != "kind"},
            {"n": int(r.size), "radii": r, "dim": int(getattr(sizes, "dim", 3)), "volume_fraction": vf}, "protocol")
    dim = int(getattr(sizes, "dim", 3))
    half = None
    if vf is not None and not isinstance(vf, str):  # not "jammed", nor a protocol without a fraction (deposit)
        if np.ptp(r) == 0 and vf > _KEPLER:
            raise InvalidInputError(
                f"protocol.volume_fraction = {vf!r}: equal spheres cannot exceed {_KEPLER:.4f} (the FCC density); "
                "random packs of equal spheres jam near 0.64"
            )
        half = 0.5 * (unit_ball_volume(3) * float(np.sum(r**3)) / vf) ** (1.0 / 3.0)
        if 2.0 * float(r.max()) > 0.98 * half:
            raise InvalidInputError(
                f"protocol.volume_fraction = {vf!r}: the largest sphere (diameter {2 * float(r.max()):.4g}) would "
                f"exceed half the periodic box ({half:.4g}) of N={r.size}; use more particles (psd.n) or a smaller "
                "size ratio"
            )
    info = {"n": int(r.size), "volume_fraction": vf, "half_box": half, "dim": dim,
            "protocol": study_data["protocol"].get("kind")}
    for name in sorted(study_data.get("analysis", {})):
        cap = registry.get("analysis", name)
        if cap.preflight is not None:
            registry._load(cap.preflight)(study_data["analysis"][name], info, f"analysis.{name}")
    if half is None:
        return
    win = study_data.get("analysis", {}).get("windows")
    if win:
        species = np.asarray(getattr(sizes, "species", None) if getattr(sizes, "species", None) is not None
                             else np.zeros(r.size, np.int64), dtype=np.int64)
        ref = win.get("reference", "species")
        if ref == "species":
            a = max(float(np.mean(r[species == k])) for k in np.unique(species))
        else:
            a = float(r.max())
        for rh in (win["window_radius"] if isinstance(win["window_radius"], list) else [win["window_radius"]]):
            if rh * a > half:
                raise InvalidInputError(
                    f"analysis.windows.window_radius = {rh!r}: a window of {rh:g} radii ({rh * a:.4g}) exceeds half "
                    f"the box length {half:.4g} of this study (N={r.size} at volume fraction {vf}); use at most "
                    f"{half / a:.4g} or more particles"
                )


def make_packing(sizes, protocol: dict, seed):
    """Run the registered packing protocol of the ``[protocol]`` table (``kind``).

    ``kind = "crm"``: :func:`polypack.pack` (CRM, §3.1 of 000_2cedc098acbd866b.txt), then
    ``global_shakes`` global shakes with :func:`polypack.shake` if M > 0.
    ``kind = "scrm"``: :func:`polypack.scrm` (CRM interleaved with shaking, §3.2, then
    ``global_shakes`` global shakes). Other kinds: see ``polypack.registry.names("protocol")``.
    """
    from ..analysis import ContactValueMonitor

    cap = registry.get("protocol", protocol["kind"], path="protocol.kind")
    opts = {k: v for k, v in protocol.items() if k != "kind"}
    return cap.load()(sizes, opts, seed, monitor=ContactValueMonitor())


# --------------------------------------------------------------------------- analyses
def _as_dict(est):
    return est if isinstance(est, dict) else est.to_dict()


def run_analyses(packing, analyses: dict, seed, index=None) -> dict:
    """``{name: result dict}`` for every ``[analysis.*]`` table (§2 of 000_2cedc098acbd866b.txt).

    Each registered analysis runs with its own child seed; one that returns several
    estimators (window histograms with several radii) gives a list of dicts.  An analysis
    whose table states ``realizations = N`` (``[analysis.shear]``, issue 32) runs only on
    realizations ``index < N``; the others leave it out.  The child seeds are spawned over
    every table either way, so the other analyses' results do not depend on it.
    """
    out = {}
    seeds = dict(zip(sorted(analyses), seed.spawn(len(analyses))))
    from .. import _interrupt

    for name in sorted(analyses):
        if index is not None and _skips(analyses[name], index):
            continue
        _interrupt.check(f"interrupted before analysis {name}")
        est = registry.get("analysis", name, path="analysis").load()(packing, analyses[name], seeds[name])
        out[name] = [_as_dict(e) for e in est] if isinstance(est, list) else _as_dict(est)
    return out


def _skips(table, index) -> bool:
    """True if an analysis table limited to its first ``realizations`` leaves realization ``index`` out."""
    lim = table.get("realizations") if isinstance(table, dict) else None
    return isinstance(lim, int) and not isinstance(lim, bool) and index >= lim


# --------------------------------------------------------------------------- scalars
def _jsonable(v):
    if isinstance(v, (np.floating, float)):
        v = float(v)
        return v if math.isfinite(v) else None
    if isinstance(v, (np.integer, int)) and not isinstance(v, bool):
        return int(v)
    if isinstance(v, (bool, np.bool_, str)) or v is None:
        return v if not isinstance(v, np.bool_) else bool(v)
    return None


def _is_num(v):
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def protocol_stats(meta: dict, protocol=None) -> dict:
    """Scalar run statistics of the protocol for the record and the summary table.

    What is recorded is what the protocol declares (:attr:`polypack.registry.Outputs.meta`
    and ``scalars`` of its registration; ``protocol`` is its name or
    :class:`~polypack.registry.Capability`, default: the generator named in ``meta``):
    top-level ``meta`` scalars (the packer's: status, collisions, reduced pressure ...)
    keep their names; the scalars of each declared sub-table (``meta["shake"]``,
    ``meta["vem"]`` ...) get its name as prefix (``vem.stages``); per-shake histories give
    their last row per species (``shake.acceptance_rate.0``), the contact-value monitor its
    last value per pair, a list of stages its length.
    """
    cap = _protocol_cap(meta, protocol)
    top = cap.outputs.scalars if cap is not None else None
    tables = cap.meta_tables() if cap is not None else ()
    out = {}
    for k, v in meta.items():
        if k in ("seed", "history") or isinstance(v, (list, dict, tuple, np.ndarray)):
            continue
        if top is not None and k not in top:
            continue
        out[k] = _jsonable(v)
    for sub in tables:
        d = meta.get(sub)
        if not isinstance(d, dict):
            continue
        for k, v in d.items():
            if k in ("seed", "generator"):
                continue
            if _is_num(v) or isinstance(v, (str, bool)):
                out[f"{sub}.{k}"] = _jsonable(v)
            elif isinstance(v, list) and v and all(_is_num(e) for e in v) and k != "schedule":
                for i, e in enumerate(v):
                    out[f"{sub}.{k}.{i}"] = _jsonable(e)
            elif isinstance(v, list) and v and isinstance(v[-1], list) and all(_is_num(e) for e in v[-1]):
                for i, e in enumerate(v[-1]):
                    out[f"{sub}.{k}.{i}"] = _jsonable(e)
            elif k == "monitor" and isinstance(v, dict) and isinstance(v.get("contact_value"), dict):
                for pair, vals in v["contact_value"].items():
                    if isinstance(vals, list) and vals and _is_num(vals[-1]):
                        out[f"{sub}.contact_value.{pair}"] = _jsonable(vals[-1])
            elif k == "stages" and isinstance(v, list):
                out[f"{sub}.stages"] = len(v)
    return out


def _protocol_cap(meta, protocol):
    """The registered protocol whose declaration says which statistics to record."""
    if isinstance(protocol, registry.Capability):
        return protocol
    name = protocol
    if name is None:  # a pack made outside a study: the generator that made it
        name = meta.get("generator") or meta.get("protocol")
        if name == "pack" or name == "lubachevsky":
            name = "crm"
    if not isinstance(name, str):
        return None
    try:
        return registry.get("protocol", name)
    except InvalidInputError:
        return None


def _flatten(prefix, v, out):
    """Numbers of a nested per-species matrix (``prefix.i-j``) or table (``prefix.key``) into ``out``."""
    if isinstance(v, list):
        for i, x in enumerate(v):
            if isinstance(x, list):
                for j, y in enumerate(x):
                    out[f"{prefix}.{i}-{j}"] = y
            else:
                out[f"{prefix}.{i}"] = x
    elif isinstance(v, dict):
        for fk, fv in v.items():
            if isinstance(fv, dict):
                for kk, vv in fv.items():
                    if isinstance(vv, (int, float)) and not isinstance(vv, bool):
                        out[f"{prefix}.{fk}.{kk}"] = vv
            elif isinstance(fv, (int, float)) and not isinstance(fv, bool):
                out[f"{prefix}.{fk}"] = fv


def scalar_descriptors(analyses: dict) -> dict:
    """Scalar descriptors for the summary table, as each analysis declares them (:class:`registry.Outputs`)."""
    out = {}
    for name, d in analyses.items():
        try:
            outputs = registry.get("analysis", name).outputs
        except InvalidInputError:
            outputs = registry.Outputs()
        skip = set(registry.BASE_SCALAR_SKIP) | set(outputs.scalar_skip)
        items = list(enumerate(d)) if isinstance(d, list) else [(None, d)]
        for idx, dd in items:
            prefix = name if idx is None else f"{name}{idx}"
            for k, v in dd.items():
                if k in skip or (outputs.scalars is not None and k not in outputs.scalars and k not in outputs.flatten):
                    continue
                if isinstance(v, (int, float)) and not isinstance(v, bool):
                    out[f"{prefix}.{k}"] = v
                elif k in outputs.flatten and isinstance(v, (list, dict)):
                    _flatten(f"{prefix}.{k}", v, out)
    return out


# --------------------------------------------------------------------------- one realization
def realize(study_data: dict, index: int, seed_rec: dict):
    """Realization ``index`` of a resolved study: ``(packing, record)``.

    A pure function of ``(study_data, seed_rec)``: the sizes, protocol and analysis seeds
    are spawned from the realization's seed (:func:`stage_seeds`).  The record holds the
    seed, the protocol statistics, the size-set report and every analysis as plain data;
    the runner adds file names and checksums.
    """
    from .. import _interrupt

    s_sizes, s_proto, s_ana = stage_seeds(seed_rec)
    # Ctrl-C stops at the next safe point of a generator or between analyses, and the
    # realization is then never returned (so never recorded): the interrupt propagates
    with _interrupt.deferred():
        sizes = make_sizes(study_data["psd"], s_sizes)
        packing = make_packing(sizes, study_data["protocol"], s_proto)
        if packing.meta.get("status") == "interrupted" or (packing.meta.get("shake") or {}).get("interrupted"):
            raise KeyboardInterrupt  # never record a partial pack
        _interrupt.check(f"realization {index} interrupted after its packing")
        analyses = run_analyses(packing, study_data.get("analysis", {}), s_ana, index)
    report = getattr(sizes, "report", {}) or {}
    psd_scalars = {k: _jsonable(v) for k, v in report.items() if _jsonable(v) is not None}
    record = {
        "index": int(index),
        "seed": dict(seed_rec),
        "n": int(packing.n),
        "volume_fraction": float(packing.volume_fraction),
        "species_counts": [int(c) for c in np.asarray(packing.species_counts)],
        "box": [float(x) for x in packing.box],
        "protocol": protocol_stats(dict(packing.meta), _protocol(study_data)),
        "psd": psd_scalars,
        "analysis": analyses,
        "scalars": scalar_descriptors(analyses),
    }
    return packing, record


def child_seed_records(seed: int, realizations: int) -> list:
    """Seed records of ``SeedSequence(seed).spawn(realizations)``."""
    root = np.random.SeedSequence(int(seed))
    return [seed_record(c) for c in root.spawn(int(realizations))]
