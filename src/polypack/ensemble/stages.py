"""The stages of one realization: sizes -> packing protocol -> analyses.

Each stage is a small adapter from the resolved study (:mod:`polypack.study`) to one
public polypack function, so a change of a signature is fixed in one place.
:func:`realize` chains them; it is a pure function of the resolved study and the
realization's seed record, so it gives the same result in-process, in a process pool
or on a Dask worker.
"""

from __future__ import annotations

import inspect
import math

import numpy as np

from .._util import seed_from_record, seed_record
from ..errors import InvalidInputError
from ..geometry import unit_ball_volume

__all__ = ["make_sizes", "make_packing", "run_analyses", "realize", "stage_seeds", "check_available", "preflight"]

def stage_seeds(seed_rec):
    """Independent child seeds of one realization: ``(sizes, protocol, analysis)``."""
    ss = seed_from_record(seed_rec)
    return tuple(ss.spawn(3))


# --------------------------------------------------------------------------- sizes
def make_model(psd: dict):
    """The :mod:`polypack.psd` model of the ``[psd]`` table."""
    from .. import psd as psd_mod
    from ..study import PSD_MODELS

    cls_name, keys = PSD_MODELS[psd["model"]]
    return getattr(psd_mod, cls_name)(**{k: psd[k] for k in keys if k in psd})


def make_sizes(psd: dict, seed):
    """A :class:`polypack.psd.SizeSet` (or a compatible object) from the ``[psd]`` table.

    Uses ``polypack.psd.<Model>(**params).sample(n=, seed=, method=)`` or
    ``polypack.psd.discretize(model, ...)`` (§1.2 of 001_ad5bae0acea940c4.txt).
    """
    from .. import psd as psd_mod

    model = make_model(psd)
    if psd["sampling"] == "discretize":
        kw = {k: psd[k] for k in ("n_classes", "spacing", "min_per_class", "min_total", "max_total") if k in psd}
        return psd_mod.discretize(model, seed=seed, method=psd.get("method", "random"), **kw)
    return model.sample(n=psd["n"], seed=seed, method=psd.get("method", "random"))


# --------------------------------------------------------------------------- packing
def _accepted(func, kwargs):
    """The subset of ``kwargs`` that ``func`` accepts (all of them if it takes ``**kw``)."""
    sig = inspect.signature(func)
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in sig.parameters.values()):
        return dict(kwargs)
    return {k: v for k, v in kwargs.items() if k in sig.parameters}


_SHAKE_KEYS = (("shake_radius", "shake_radius"), ("max_trials", "max_trials"), ("shake_method", "method"),
               ("adaptive", "adaptive"))


def _shake_options(pr):
    opts = {}
    for key, arg in _SHAKE_KEYS:
        if key in pr:
            opts[arg] = pr[key]
    return opts


def check_available(study_data):
    """Raise InvalidInputError (with the key path) if a stage the study needs is missing.

    Run by the runner before any realization starts, so a study asking for SCRM on a
    build without :func:`polypack.scrm` fails at once.
    """
    import polypack as pp

    pr = study_data["protocol"]
    needs = ["pack"]
    if pr["kind"] == "scrm":
        needs.append("scrm")
    if pr.get("global_shakes", 0) > 0:
        needs.append("shake")
    for name in needs:
        try:
            getattr(pp, name)
        except (ImportError, AttributeError):
            raise InvalidInputError(
                f'protocol.kind = "{pr["kind"]}": polypack.{name} is not available in this installation'
            ) from None
    try:
        from .. import psd as psd_mod  # noqa: F401
        from ..study import PSD_MODELS

        getattr(psd_mod, PSD_MODELS[study_data["psd"]["model"]][0])
    except (ImportError, AttributeError):
        raise InvalidInputError(
            f'psd.model = "{study_data["psd"]["model"]}": not available in this installation'
        ) from None
    for name in study_data.get("analysis", {}):
        cls = _ANALYSES[name][0]
        try:
            import polypack.analysis as pa

            getattr(pa, cls)
        except (ImportError, AttributeError):
            raise InvalidInputError(f"analysis.{name}: polypack.analysis.{cls} is not available here") from None


def _check_shake_options(pr):
    """Let :func:`polypack.shake` judge the shake options on a two-sphere pack (no shakes)."""
    opts = _shake_options(pr)
    if not opts or not (pr["kind"] == "scrm" or pr.get("global_shakes", 0) > 0):
        return
    import polypack as pp
    from ..packing import Packing

    tiny = Packing(np.array([[0.0, 0.0, 0.0], [2.5, 2.5, 2.5]]), np.array([0.5, 0.25]), np.full(3, 5.0),
                   species=np.array([0, 1]))
    try:
        pp.shake(tiny, global_shakes=0, seed=0, progress=False, **opts)
    except InvalidInputError as exc:
        msg = str(exc)
        key = next((k for k, a in _SHAKE_KEYS if msg.startswith(f"{a}=")), None)
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
    or jam after every packing) are reported at once with their key paths.
    """
    _check_shake_options(study_data["protocol"])
    _check_analysis_options(study_data.get("analysis", {}))
    s_sizes, _, _ = stage_seeds(seed_rec)
    sizes = make_sizes(study_data["psd"], s_sizes)
    vf = study_data["protocol"]["volume_fraction"]
    if isinstance(vf, str):
        return
    r = np.asarray(sizes.radii, dtype=np.float64)
    if np.ptp(r) == 0 and vf > _KEPLER:
        raise InvalidInputError(
            f"protocol.volume_fraction = {vf!r}: equal spheres cannot exceed {_KEPLER:.4f} (the FCC density); "
            "random packs of equal spheres jam near 0.64"
        )
    half = 0.5 * (unit_ball_volume(3) * float(np.sum(r**3)) / vf) ** (1.0 / 3.0)
    if 2.0 * float(r.max()) > 0.98 * half:
        raise InvalidInputError(
            f"protocol.volume_fraction = {vf!r}: the largest sphere (diameter {2 * float(r.max()):.4g}) would exceed "
            f"half the periodic box ({half:.4g}) of N={r.size}; use more particles (psd.n) or a smaller size ratio"
        )
    for name in ("rdf", "kfunction"):
        opts = study_data.get("analysis", {}).get(name)
        if opts and opts["r_max"] > half:
            raise InvalidInputError(
                f"analysis.{name}.r_max = {opts['r_max']!r}: exceeds half the box length {half:.4g} of this study "
                f"(N={r.size} at volume fraction {vf}); use r_max <= {half:.4g} or more particles"
            )
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
    """Run the packing protocol of the ``[protocol]`` table.

    ``kind = "crm"``: :func:`polypack.pack` (CRM, §3.1 of 000_2cedc098acbd866b.txt), then
    ``global_shakes`` global shakes with :func:`polypack.shake` if M > 0.
    ``kind = "scrm"``: :func:`polypack.scrm` (CRM interleaved with shaking, §3.2, then
    ``global_shakes`` global shakes).
    """
    import polypack as pp

    pr = protocol
    s_pack, s_shake = seed.spawn(2)
    grow = {}
    if "growth_rate" in pr:
        grow["growth_rate"] = pr["growth_rate"]
    if "max_seconds" in pr:
        grow["max_seconds"] = pr["max_seconds"]
    m = int(pr.get("global_shakes", 0))
    if pr["kind"] == "scrm":
        kw = dict(global_shakes=m, **_shake_options(pr))
        if "growth_rate" in pr:
            kw["growth_rate"] = pr["growth_rate"]
        for key in ("growth_steps", "start_fraction", "stage_shakes"):
            if key in pr:
                kw[key] = pr[key]
        if "schedule" in pr:
            sched = list(pr["schedule"])
            if sched[-1] < pr["volume_fraction"]:
                sched.append(pr["volume_fraction"])
            kw["schedule"] = sched
        return pp.scrm(sizes, volume_fraction=pr["volume_fraction"], seed=s_pack, progress=False, **kw)
    pk = pp.pack(sizes, pr["volume_fraction"], seed=s_pack, progress=False, **grow)
    if m > 0:
        pk = pp.shake(pk, global_shakes=m, seed=s_shake, progress=False, **_shake_options(pr))
    return pk


# --------------------------------------------------------------------------- analyses
def _rdf(pa, opts, packing, seed):
    kw = {k: opts[k] for k in ("dr", "method", "scale") if k in opts}
    return pa.RDF(opts["r_max"], **kw).compute(packing)


def _kfunction(pa, opts, packing, seed):
    kw = {k: opts[k] for k in ("dr", "scale") if k in opts}
    return pa.KFunction(opts["r_max"], **kw).compute(packing)


def _windows(pa, opts, packing, seed):
    radii = opts["window_radius"]
    kw = {k: opts[k] for k in ("reference",) if k in opts}
    if isinstance(radii, list):
        return [pa.WindowCounts(window_radius=r, **kw).compute(packing) for r in radii]
    return pa.WindowCounts(window_radius=radii, **kw).compute(packing)


def _contacts(pa, opts, packing, seed):
    kw = {k: opts[k] for k in ("tolerance", "min_contacts") if k in opts}
    return pa.Contacts(**kw).compute(packing)


def _pores(pa, opts, packing, seed):
    kw = {k: opts[k] for k in ("n_grid",) if k in opts}
    return pa.PoreSizes(n_points=opts["n_points"], seed=seed, **kw).compute(packing)


_ANALYSES = {
    "rdf": ("RDF", _rdf),
    "kfunction": ("KFunction", _kfunction),
    "windows": ("WindowCounts", _windows),
    "contacts": ("Contacts", _contacts),
    "pores": ("PoreSizes", _pores),
}


def run_analyses(packing, analyses: dict, seed) -> dict:
    """``{name: estimator.to_dict()}`` for every ``[analysis.*]`` table (§2 of 000_2cedc098acbd866b.txt).

    Window histograms with several radii give a list of dicts.
    """
    import polypack.analysis as pa

    out = {}
    seeds = dict(zip(sorted(analyses), seed.spawn(len(analyses))))
    from .. import _interrupt

    for name in sorted(analyses):
        _interrupt.check(f"interrupted before analysis {name}")
        est = _ANALYSES[name][1](pa, analyses[name], packing, seeds[name])
        out[name] = [e.to_dict() for e in est] if isinstance(est, list) else est.to_dict()
    return out


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


def protocol_stats(meta: dict) -> dict:
    """Scalar run statistics of the protocol for the summary table.

    Top-level ``meta`` scalars (the packer's: status, collisions, reduced pressure ...)
    keep their names; ``meta["shake"]`` and ``meta["scrm"]`` scalars get a ``shake.`` /
    ``scrm.`` prefix; per-shake histories give their last row per species
    (``shake.acceptance_rate.0``), the contact-value monitor its last value per pair.
    """
    out = {}
    for k, v in meta.items():
        if k in ("seed", "history") or isinstance(v, (list, dict, tuple, np.ndarray)):
            continue
        out[k] = _jsonable(v)
    for sub in ("shake", "scrm"):
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


def scalar_descriptors(analyses: dict) -> dict:
    """Scalar descriptors for the summary table (coordination, window moments, pore fit ...)."""
    out = {}
    for name, d in analyses.items():
        items = list(enumerate(d)) if isinstance(d, list) else [(None, d)]
        for idx, dd in items:
            prefix = name if idx is None else f"{name}{idx}"
            for k, v in dd.items():
                if k in ("n_realizations", "estimator", "dr", "r_max", "n_points", "tolerance", "min_contacts"):
                    continue
                if isinstance(v, (int, float)) and not isinstance(v, bool):
                    out[f"{prefix}.{k}"] = v
                elif isinstance(v, list) and name == "contacts" and k == "per_species":
                    for i, x in enumerate(v):
                        if isinstance(x, list):
                            for j, y in enumerate(x):
                                out[f"{prefix}.{k}.{i}-{j}"] = y
                        else:
                            out[f"{prefix}.{k}.{i}"] = x
                elif isinstance(v, dict) and name == "pores" and k == "fit":
                    for fk, fv in v.items():
                        if isinstance(fv, dict):
                            for kk, vv in fv.items():
                                if isinstance(vv, (int, float)) and not isinstance(vv, bool):
                                    out[f"{prefix}.fit.{fk}.{kk}"] = vv
                        elif isinstance(fv, (int, float)) and not isinstance(fv, bool):
                            out[f"{prefix}.fit.{fk}"] = fv
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
        analyses = run_analyses(packing, study_data.get("analysis", {}), s_ana)
    report = getattr(sizes, "report", {}) or {}
    psd_scalars = {k: _jsonable(v) for k, v in report.items() if _jsonable(v) is not None}
    record = {
        "index": int(index),
        "seed": dict(seed_rec),
        "n": int(packing.n),
        "volume_fraction": float(packing.volume_fraction),
        "species_counts": [int(c) for c in np.asarray(packing.species_counts)],
        "box": [float(x) for x in packing.box],
        "protocol": protocol_stats(dict(packing.meta)),
        "psd": psd_scalars,
        "analysis": analyses,
        "scalars": scalar_descriptors(analyses),
    }
    return packing, record


def child_seed_records(seed: int, realizations: int) -> list:
    """Seed records of ``SeedSequence(seed).spawn(realizations)``."""
    root = np.random.SeedSequence(int(seed))
    return [seed_record(c) for c in root.spawn(int(realizations))]
