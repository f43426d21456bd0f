"""Run a study's realizations on any :class:`concurrent.futures.Executor`, with resume.

Layout of the output folder::

    DIR/study.resolved.toml      resolved study (all defaults) ...
    DIR/study.resolved.json      ... with fingerprint and versions (polypack, python, numpy, numba)
    DIR/realizations/r0000.gsd   one pack per realization (GSD, double precision)
    DIR/realizations/r0000.json  its record: seed, protocol statistics, descriptors, sha256 of the GSD
    DIR/summary.csv              one row per realization
    DIR/ensemble/curves.json     ensemble-averaged curves, mean ± t(0.975, P-1) standard errors
    DIR/ensemble/<analysis>.csv  the same as tables; DIR/ensemble/<analysis>.png plots
    DIR/ensemble/scalars.json    mean and standard error of every scalar descriptor

A realization is *complete and verified* when its GSD and its record exist and the
record's sha256 matches the GSD; the record is written last, so killing a run loses at
most the realizations in flight, and rerunning the same command computes only the
missing ones.  Every file is written atomically.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import csv
import hashlib
import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import _interrupt
from .._util import atomic_open, check_output_folder, make_folder, progress_bar
from ..errors import InvalidInputError, PolypackError
from ..study import Study, load_study
from ._lock import RunFolderLock
from .stages import check_available, child_seed_records, compile_kernels, compile_module, preflight, realize, study_kernels

__all__ = ["run_study", "run_studies", "EnsembleResult", "run_realization", "verify_realization", "aggregate", "regenerate"]

CI_LEVEL = 0.95


def t_quantile(dof):
    """Two-sided 95 % Student-t factor ``t(0.975, dof)`` (NaN where ``dof < 1``).

    The band ``mean ± t SE`` over ``P`` realizations covers the true mean 95 % of the
    time for Gaussian scatter with ``dof = P - 1``; ``1.96 SE`` would cover only about
    81 % at ``P = 3`` (``t(0.975, 2) = 4.303``).
    """
    from scipy.stats import t as student_t

    d = np.asarray(dof, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        q = student_t.ppf(0.5 + 0.5 * CI_LEVEL, np.where(d >= 1, d, np.nan))
    return q if q.ndim else float(q)


def sha256_file(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def run_realization(study_data: dict, index: int, seed_rec: dict):
    """Worker task: ``(index, packing, record, seconds)``; picklable for process pools and Dask."""
    t0 = time.perf_counter()
    packing, record = realize(study_data, index, seed_rec)
    return index, packing, record, time.perf_counter() - t0


def regenerate(out, index: int):
    """Recompute realization ``index`` of a finished run from its folder: ``(packing, record)``.

    Uses the resolved study in ``out/study.resolved.json`` and the seed in the
    realization's record, so the pack is bitwise the one in ``rNNNN.gsd`` (same platform
    and versions).
    """
    out = Path(out)
    try:
        with open(out / "study.resolved.json", encoding="utf-8") as fh:
            doc = json.load(fh)
    except FileNotFoundError:
        raise InvalidInputError(f"{out} holds no study.resolved.json: not a polypack run folder") from None
    study = Study(doc["study"])
    _, rec = _paths(out, index)
    if rec.is_file():
        with open(rec, encoding="utf-8") as fh:
            seed = json.load(fh)["seed"]
    elif 0 <= index < study.realizations:
        seed = child_seed_records(study.seed, index + 1)[index]
    else:
        raise InvalidInputError(f"index={index}: the study has realizations 0..{study.realizations - 1}")
    return realize(study.data, index, seed)


# the longest compilations first, so they spread evenly over the workers
_COMPILE_ORDER = ("polypack._kernels.edmd", "polypack._kernels.cells", "polypack._kernels.shake")


def _compile_in_pool(pool, study_data, *more):
    """Compile a study's kernel modules (and those of ``more`` studies) in the pool's workers at once
    (cold start)."""
    mods = list(dict.fromkeys(m for d in (study_data, *more) for m in study_kernels(d)))
    mods.sort(key=lambda m: _COMPILE_ORDER.index(m) if m in _COMPILE_ORDER else len(_COMPILE_ORDER))
    futs = [pool.submit(compile_module, m) for m in mods]
    waiting = set(futs)
    while waiting:
        _, waiting = cf.wait(waiting, timeout=0.25)
        _interrupt.check("interrupted while the kernels were compiling")
    for f in futs:
        f.result()


def _worker_init():
    """Pool workers leave Ctrl-C to the main process, which stops them."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _stop_pool(pool):
    """Cancel queued realizations and end the pool's worker processes at once."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    for p in procs:
        if p.is_alive():
            p.terminate()
    pool.shutdown(wait=False)


def _open_pool(executor, workers, n_tasks, datas):
    """``(executor, own)``: the executor to submit realizations to, and the process pool this call
    made and must close (None when the caller gave ``executor``).  The studies' kernels are compiled
    once first, in the new pool's workers side by side (each written to the numba cache once) or here
    for a caller's executor, so that the realizations load them instead of compiling the same kernels
    at the same time (cold start); ``POLYPACK_PRECOMPILE=0`` skips that."""
    precompile = os.environ.get("POLYPACK_PRECOMPILE", "1") != "0"
    if executor is not None:
        if precompile:
            for d in datas:
                compile_kernels(d)
        return executor, None
    own = cf.ProcessPoolExecutor(max_workers=min(workers, n_tasks), initializer=_worker_init)
    if precompile:
        try:
            _compile_in_pool(own, *datas)
        except BaseException:
            _stop_pool(own)
            raise
    return own, own


def _drain(futs, key, collect):
    """Wait for every future of ``futs``, handing each finished one to ``collect`` (in ``key`` order
    among those finished together); short waits, so a deferred Ctrl-C is seen within a quarter
    second.  On any exception the futures not yet started are cancelled before it propagates (the
    pool itself is stopped by :func:`_pool`)."""
    try:
        waiting = set(futs)
        while waiting:
            done, waiting = cf.wait(waiting, timeout=0.25, return_when=cf.FIRST_COMPLETED)
            _interrupt.check("interrupted while realizations were running")
            for fut in sorted(done, key=key):
                collect(fut)
    except BaseException:
        for f in futs:
            f.cancel()
        raise


@contextlib.contextmanager
def _pool(executor, workers, n_tasks, datas):
    """The executor to submit realizations to (:func:`_open_pool`), for a ``with`` block: a pool made
    here is shut down after the block, or stopped at once (workers terminated) when the block raises,
    e.g. on Ctrl-C or a failed collection.  A caller's executor is left open."""
    executor, own = _open_pool(executor, workers, n_tasks, datas)
    try:
        yield executor
    except BaseException:
        if own is not None:
            _stop_pool(own)
        raise
    if own is not None:
        own.shutdown(wait=True, cancel_futures=True)


def _paths(out: Path, index: int):
    base = out / "realizations" / f"r{index:04d}"
    return base.with_suffix(".gsd"), base.with_suffix(".json")


def code_record() -> dict:
    """What a resume trusts besides the study: the polypack version and a digest of the
    code that computes a realization (:func:`polypack.study.code_digest`)."""
    from .._version import __version__
    from ..study import code_digest

    return {"polypack": __version__, "digest": code_digest()}


def verify_realization(out, index: int, fingerprint: str, code: dict | None = None):
    """The record of realization ``index`` if it is complete and verified, else None.

    Verified: its GSD's sha256 matches the record, the record belongs to the study with
    ``fingerprint`` and (when ``code`` is given) was computed by that polypack code.
    """
    gsd, rec = _paths(Path(out), index)
    if not (gsd.is_file() and rec.is_file()):
        return None
    try:
        with open(rec, encoding="utf-8") as fh:
            record = json.load(fh)
        ok = (
            record.get("fingerprint") == fingerprint
            and record.get("index") == index
            and (code is None or record.get("code") == code)
            and record["files"]["gsd"]["sha256"] == sha256_file(gsd)
        )
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return record if ok else None


def realization_status(record) -> str:
    """The packing status of a realization record: "target", "jammed", "time_budget", ...

    A pack asked for a volume fraction that jammed below it is reported as
    ``"jammed_below_target"``.
    """
    proto = record.get("protocol") or {}
    status = str(proto.get("status") or "target")
    if status == "jammed" and proto.get("target", "jammed") != "jammed":
        return "jammed_below_target"
    return status


def is_complete(record) -> bool:
    """True if the realization's protocol reached its target (not stopped by a budget,
    not jammed below a requested volume fraction); others are saved and listed but left
    out of the ensemble averages."""
    return realization_status(record) in ("target", "jammed")


def finite_json(v):
    """``v`` with every non-finite float (NaN, inf) replaced by None, recursively: JSON has
    no NaN, and a record that cannot be written would leave its pack without a record and
    make every rerun fail the same way (issue 31). Stages state *why* a number is missing
    (``status``: ``"floppy"``, ``"not_converged"``)."""
    if isinstance(v, dict):
        return {k: finite_json(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [finite_json(x) for x in v]
    if isinstance(v, (float, np.floating)):
        return float(v) if math.isfinite(v) else None
    return v


def _write_realization(out: Path, study: Study, index, packing, record, seconds):
    import polypack as pp

    gsd, rec = _paths(out, index)
    pp.io.write(gsd, packing)  # atomic
    files = {"gsd": {"path": gsd.name, "sha256": sha256_file(gsd)}}
    for fmt in study.data["output"]["formats"]:
        if fmt == "gsd":
            continue
        p = gsd.with_suffix(f".{fmt}")
        pp.io.write(p, packing)
        files[fmt] = {"path": p.name}
    record = finite_json(dict(record, fingerprint=study.fingerprint, code=code_record(), files=files,
                              seconds=seconds))
    with atomic_open(rec, "w", encoding="utf-8") as fh:  # written last: marks completion
        json.dump(record, fh, allow_nan=False)
    return record


def _extra_formats(out: Path, study: Study, records):
    """Formats asked for after a realization was computed are written from its GSD."""
    import polypack as pp

    for rec in records:
        gsd, _ = _paths(out, rec["index"])
        for fmt in study.data["output"]["formats"]:
            p = gsd.with_suffix(f".{fmt}")
            if fmt != "gsd" and not p.exists():
                pp.io.write(p, pp.io.read(gsd))


@dataclass
class EnsembleResult:
    """What :func:`run_study` did and where the results are."""

    out: Path
    study: Study
    records: list
    computed: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    seconds: float = 0.0
    files: dict = field(default_factory=dict)
    incomplete: list = field(default_factory=list)
    stale: list = field(default_factory=list)

    def summary(self) -> str:
        """A few lines for the terminal: counts, mean volume fraction and file locations."""
        vf = np.array([r["volume_fraction"] for r in self.records if is_complete(r)])
        lines = [
            f"study {self.study.name!r}: {len(self.records)} realization(s) in {self.out} "
            f"({len(self.computed)} computed, {len(self.skipped)} reused) in {self.seconds:.1f} s",
        ]
        if vf.size:
            se = vf.std(ddof=1) / math.sqrt(vf.size) if vf.size > 1 else float("nan")
            lines.append(f"  volume fraction {vf.mean():.5f} ± {t_quantile(vf.size - 1) * se:.2g} (95 % CI)")
        if self.stale:
            lines.append(f"  {len(self.stale)} saved realization(s) were made by other polypack code and were "
                         "recomputed")
        if self.incomplete:
            shown = ", ".join(f"{i} ({st})" for i, st in self.incomplete[:8])
            lines.append(f"  warning: {len(self.incomplete)} realization(s) ended on a budget before the target and "
                         f"are left out of the ensemble averages: {shown}")
        for what, p in self.files.items():
            lines.append(f"  {what:<20s} {p}")
        return "\n".join(lines)


def _check_out(out: Path, study: Study, force: bool):
    prev = out / "study.resolved.json"
    if not prev.is_file():
        return
    try:
        with open(prev, encoding="utf-8") as fh:
            fp = json.load(fh).get("fingerprint")
    except (OSError, ValueError):
        fp = None
    if fp == study.fingerprint:
        return
    if not force:
        raise InvalidInputError(
            f"{out} holds results of a different study (fingerprint {str(fp)[:12]}, this study "
            f"{study.fingerprint[:12]}); use --force (force=True) to recompute there, or another --out"
        )
    # stale realizations are recomputed: their records no longer verify (fingerprint differs)


def run_study(
    study,
    out,
    *,
    executor: cf.Executor | None = None,
    workers: int = 1,
    force: bool = False,
    progress=None,
    aggregate_results: bool = True,
    wait: float = 0.0,
) -> EnsembleResult:
    """Run all realizations of a study and write every result (see the module docstring).

    Parameters
    ----------
    study : Study, dict or path
        A study file (TOML), a parsed dict or a :class:`~polypack.study.Study`.
    out : path
        Output folder (created).  Rerunning into the same folder resumes.
    executor : concurrent.futures.Executor, optional
        Where realizations run: any executor (a process pool, ``dask.distributed``'s
        ``Client.get_executor()``, ``mpi4py.futures.MPIPoolExecutor`` ...).  It is not shut
        down.  Default: in-process when ``workers == 1``, else a
        :class:`~concurrent.futures.ProcessPoolExecutor` with ``workers`` processes.
    workers : int
        Number of worker processes when no executor is given.
    force : bool
        Allow ``out`` to hold results of a different study; they are recomputed.
    progress : bool, optional
        Progress bar across realizations (default: on a terminal only).
    wait : float
        Seconds to wait for another run that owns ``out`` (default 0: refuse at once).

    Returns
    -------
    EnsembleResult

    Notes
    -----
    Realization ``i`` uses child ``i`` of ``numpy.random.SeedSequence(study.seed).spawn(P)``
    and is a pure function of the resolved study and that seed, so serial, process-pool and
    Dask runs give bitwise identical packs.  A run owns its folder (an advisory lock,
    :mod:`polypack.ensemble._lock`): a second run on the same folder waits ``wait``
    seconds, then raises :class:`~polypack.ensemble._lock.FolderBusyError`.  A saved
    realization is reused only if its record matches the study's fingerprint, the GSD's
    checksum and the polypack code that computes realizations.  Realizations stopped by
    a budget (``max_seconds`` ...) are saved with their status and listed in
    ``EnsembleResult.incomplete``, never averaged into the ensemble results.  Workers return the pack to this process, which
    writes the files, so a Dask cluster needs no shared file system.  Children of
    ``spawn`` do not depend on ``P``: raising ``study.realizations`` reuses finished ones.
    """
    t0 = time.perf_counter()
    study = load_study(study)
    check_available(study.data)
    if not (isinstance(workers, int) and workers >= 1):
        raise InvalidInputError(f"workers={workers!r}: must be an integer >= 1")
    check_output_folder(out)
    seeds = child_seed_records(study.seed, study.realizations)
    preflight(study.data, seeds[0])
    out = Path(out)
    make_folder(out)
    lock = RunFolderLock(out, study.fingerprint, wait=wait).acquire()
    try:
        return _run_locked(study, out, seeds, executor, workers, force, progress, aggregate_results, t0)
    finally:
        lock.release()


def _prepare(study, out, force):
    """The saved state of a locked run folder: ``(records, stale, skipped, todo)`` (resume)."""
    _check_out(out, study, force)
    make_folder(out / "realizations")
    for tmp in (out / "realizations").glob(".r[0-9]*.tmp"):  # left by a killed run
        tmp.unlink(missing_ok=True)
    study.write_resolved(out)

    code = code_record()
    records, stale = {}, []
    for i in range(study.realizations):
        rec = verify_realization(out, i, study.fingerprint, code)
        if rec is not None:
            records[i] = rec
        elif verify_realization(out, i, study.fingerprint) is not None:
            stale.append(i)  # same study, other polypack code: recomputed
    skipped = sorted(records)
    todo = [i for i in range(study.realizations) if i not in records]
    return records, stale, skipped, todo


def _finish(study, out, records, computed, skipped, stale, failures, aggregate_results, t0):
    """A run folder's ensemble results once its realizations are done (raises if some failed)."""
    if failures:
        i, exc = sorted(failures.items())[0]
        raise PolypackError(
            f"{len(failures)} of {study.realizations} realization(s) failed (first: realization {i}: {exc}); "
            f"the {len(records)} finished ones are saved in {out}, rerun to retry"
        )

    recs = [records[i] for i in range(study.realizations)]
    _extra_formats(out, study, recs)
    res = EnsembleResult(out=out, study=study, records=recs, computed=sorted(computed), skipped=skipped,
                         stale=stale, incomplete=[(r["index"], realization_status(r)) for r in recs if not is_complete(r)])
    res.files = {
        "resolved study": out / "study.resolved.toml",
        "packs + records": out / "realizations",
    }
    if aggregate_results:
        res.files.update(aggregate(out, study, recs))
    res.seconds = time.perf_counter() - t0
    return res


def _run_locked(study, out, seeds, executor, workers, force, progress, aggregate_results, t0):
    records, stale, skipped, todo = _prepare(study, out, force)
    computed, failures = [], {}

    bar = progress_bar(total=study.realizations, desc=study.name, progress=progress, unit="realization")
    bar.update(len(skipped))

    def collect(i, result):
        # one realization's outcome: written at once (a failure is kept, the others go on)
        try:
            _, pk, rec, sec = result()
        except PolypackError as exc:
            failures[i] = exc
        else:
            records[i] = _write_realization(out, study, i, pk, rec, sec)
            computed.append(i)
        bar.update(1)

    try:
        if todo and executor is None and workers == 1:
            for i in todo:
                _interrupt.check(f"interrupted before realization {i}")
                collect(i, lambda: run_realization(study.data, i, seeds[i]))
        elif todo:
            with _pool(executor, workers, len(todo), [study.data]) as pool:
                futs = {pool.submit(run_realization, study.data, i, seeds[i]): i for i in todo}
                _drain(futs, futs.get, lambda f: collect(futs[f], f.result))
    finally:
        bar.close()
    _interrupt.check("interrupted before the ensemble results were aggregated")
    return _finish(study, out, records, computed, skipped, stale, failures, aggregate_results, t0)


def run_studies(jobs, *, executor: cf.Executor | None = None, workers: int = 1, force: bool = False, progress=None,
                wait: float = 0.0, desc: str = "studies", first=None, on_result=None) -> list:
    """Run the realizations of several studies on one executor: ``[EnsembleResult, ...]`` in ``jobs`` order.

    ``jobs`` is a list of ``(study, out)``; each folder is written exactly as by :func:`run_study`
    (same records, bit for bit: realization ``i`` of a study is a pure function of its resolved
    study and seed; same resume, lock, atomic writes and ensemble files), but every missing
    (study, realization) is submitted to the executor at once, so no worker idles while
    the last realizations of one study run (a sweep's values, issue 32). A study's ensemble
    files are written as soon as its own realizations are done, and ``on_result(k, result)``
    is called then (completion order). ``first(study, index)`` True puts a task ahead of the
    others (the long ones first, so that they do not run alone at the end); otherwise
    the tasks go in ``jobs`` order. A realization that fails is kept and the others go
    on; then the first failure is raised (:class:`~polypack.errors.PolypackError`), after
    every other study's results are written.

    With ``workers == 1`` and no executor the studies run one after another in this
    process (:func:`run_study`). On a shared executor a result's ``seconds`` is the wall time from
    the start of the whole batch to the end of that study's own aggregation.
    """
    if not (isinstance(workers, int) and workers >= 1):
        raise InvalidInputError(f"workers={workers!r}: must be an integer >= 1")
    t0 = time.perf_counter()
    studies, outs = [], []
    for st, out in jobs:
        st = load_study(st)
        check_available(st.data)
        check_output_folder(out)
        preflight(st.data, child_seed_records(st.seed, 1)[0])
        studies.append(st)
        outs.append(Path(out))
    if executor is None and workers == 1:
        results = []
        for k, (st, out) in enumerate(zip(studies, outs)):
            res = run_study(st, out, force=force, progress=progress, wait=wait)
            if on_result is not None:
                on_result(k, res)
            results.append(res)
        return results
    locks = []
    try:
        for st, out in zip(studies, outs):
            make_folder(out)
            locks.append(RunFolderLock(out, st.fingerprint, wait=wait).acquire())
        return _run_many(studies, outs, executor, workers, force, progress, desc, first, on_result, t0)
    finally:
        for lock in locks:
            lock.release()


def _run_many(studies, outs, executor, workers, force, progress, desc, first, on_result, t0):
    seeds = [child_seed_records(st.seed, st.realizations) for st in studies]
    state = []  # per study: records, stale, skipped, todo, computed, failures
    for st, out in zip(studies, outs):
        records, stale, skipped, todo = _prepare(st, out, force)
        state.append({"records": records, "stale": stale, "skipped": skipped, "todo": todo, "computed": [],
                      "failures": {}, "left": len(todo)})
    tasks = [(k, i) for k, s in enumerate(state) for i in s["todo"]]
    if first is not None:  # stable: the long tasks first, each group in jobs order
        tasks.sort(key=lambda t: not first(studies[t[0]], t[1]))
    results = [None] * len(studies)
    bar = progress_bar(total=sum(st.realizations for st in studies), desc=desc, progress=progress,
                       unit="realization")
    bar.update(sum(len(s["skipped"]) for s in state))

    def finish(k):
        s = state[k]
        if s["failures"]:
            return
        results[k] = _finish(studies[k], outs[k], s["records"], s["computed"], s["skipped"], s["stale"], {},
                             True, t0)
        if on_result is not None:
            on_result(k, results[k])

    def collect(k, i, result):
        s = state[k]
        try:
            _, pk, rec, sec = result()
        except PolypackError as exc:
            s["failures"][i] = exc
        else:
            s["records"][i] = _write_realization(outs[k], studies[k], i, pk, rec, sec)
            s["computed"].append(i)
        bar.update(1)
        s["left"] -= 1
        if s["left"] == 0:
            finish(k)

    try:
        for k, s in enumerate(state):  # nothing to compute: read back at once
            if not s["todo"]:
                finish(k)
        if tasks:
            need = list(dict.fromkeys(k for k, _ in tasks))
            with _pool(executor, workers, len(tasks), [studies[k].data for k in need]) as pool:
                futs = {pool.submit(run_realization, studies[k].data, i, seeds[k][i]): (k, i) for k, i in tasks}
                order = {f: n for n, f in enumerate(futs)}
                _drain(futs, order.get, lambda f: collect(*futs[f], f.result))
    finally:
        bar.close()
    _interrupt.check("interrupted before the ensemble results were aggregated")
    for k, s in enumerate(state):
        if s["failures"]:  # the first study with a failure, as run_study names it
            _finish(studies[k], outs[k], s["records"], s["computed"], s["skipped"], s["stale"], s["failures"],
                    True, t0)
    return results


# --------------------------------------------------------------------------- aggregation
def _curves_spec(name):
    """The registered :class:`~polypack.registry.Curves` of analysis ``name`` (None: no curves)."""
    from .. import registry

    try:
        return registry.get("analysis", name).outputs.curves
    except InvalidInputError:
        return None


def _curve_sets(d, spec):
    """``(x_name, x, {curve: y})`` of one analysis dict, or None if it has no curves."""
    if spec is None:
        return None
    xname = spec.x
    if not (xname in d and isinstance(d[xname], list)):
        return None
    x = d[xname]
    curves = {}
    for k, v in d.items():
        if k == xname or k.endswith("_err"):
            continue
        if isinstance(v, list) and v and len(v) == len(x) and all(isinstance(e, (int, float)) or e is None for e in v):
            curves[k] = v
        elif k == "partial" and isinstance(v, dict):
            for pk, pv in v.items():
                if isinstance(pv, list) and len(pv) == len(x):
                    curves[f"partial.{pk}"] = pv
    return xname, x, curves


def _as_float(v):
    return np.array([np.nan if e is None else e for e in v], dtype=np.float64)


def ensemble_curves(records) -> dict:
    """Mean, standard error and 95 % band (mean ± t(0.975, P-1) SE) of every curve across realizations.

    ``P`` is the number of realizations with a finite value at that point (Student t quantile,
    see :func:`t_quantile`).
    """
    out = {}
    names = sorted({k for r in records for k in r.get("analysis", {})})
    for name in names:
        per = []
        for r in records:
            d = r["analysis"].get(name)
            if d is None:  # an analysis run on some realizations only ([analysis.shear] realizations)
                continue
            ds = d if isinstance(d, list) else [d]
            per.append(ds)
        spec = _curves_spec(name)
        for j in range(len(per[0])):
            key = name if len(per[0]) == 1 else f"{name}{j}"
            sets = [_curve_sets(p[j], spec) for p in per if j < len(p)]
            if any(s is None for s in sets):
                continue
            xname = sets[0][0]
            length = max(len(s[1]) for s in sets)
            xs = [_as_float(s[1]) for s in sets]
            regrid = False
            if spec.histogram:  # histograms of different lengths: pad with p = 0
                x = np.arange(length, dtype=np.float64)
            elif all(xi.shape == xs[0].shape and np.array_equal(xi, xs[0]) for xi in xs):
                x = xs[0]
            else:  # grids that follow the data (pore sizes): onto the widest one
                regrid = True
                x = max(xs, key=lambda xi: xi[-1] - xi[0])
                length = x.size
            entry = {"x_name": xname, "x": x.tolist(), "n_realizations": len(sets), "regridded": regrid,
                     "curves": {}}
            cnames = sorted(set().union(*(s[2] for s in sets)))
            for c in cnames:
                y = np.zeros((len(sets), length)) if spec.histogram else np.full((len(sets), length), np.nan)
                for i, s in enumerate(sets):
                    v = s[2].get(c)
                    if v is None:
                        continue
                    if regrid:  # linear interpolation, edge values held beyond a realization's range
                        yi = _as_float(v)
                        ok = np.isfinite(yi)
                        if ok.sum() >= 2:
                            y[i] = np.interp(x, xs[i][ok], yi[ok])
                    else:
                        y[i, : len(v)] = _as_float(v)
                with np.errstate(invalid="ignore", divide="ignore"):
                    cnt = np.sum(np.isfinite(y), axis=0)
                    mean = np.nanmean(np.where(np.isfinite(y), y, np.nan), axis=0) if len(sets) else y[0]
                    sd = np.nanstd(y, axis=0, ddof=1) if len(sets) > 1 else np.full(length, np.nan)
                    se = sd / np.sqrt(np.maximum(cnt, 1))
                    half = t_quantile(cnt - 1) * se
                entry["curves"][c] = {
                    "mean": _nan_none(mean),
                    "se": _nan_none(se),
                    "lo": _nan_none(mean - half),
                    "hi": _nan_none(mean + half),
                }
            out[key] = entry
    return out


def _nan_none(a):
    return [float(v) if math.isfinite(v) else None for v in np.asarray(a, dtype=np.float64)]


def _flat_row(rec) -> dict:
    row = {
        "index": rec["index"],
        "seed_entropy": rec["seed"]["entropy"],
        "seed_spawn_key": " ".join(str(k) for k in rec["seed"].get("spawn_key", [])),
        "n": rec["n"],
        "volume_fraction": rec["volume_fraction"],
    }
    for k, v in rec.get("protocol", {}).items():
        row[f"protocol.{k}"] = v
    for k, v in rec.get("scalars", {}).items():
        row[k] = v
    row["seconds"] = rec.get("seconds")
    row["gsd"] = f"realizations/{rec['files']['gsd']['path']}"
    row["sha256"] = rec["files"]["gsd"]["sha256"]
    return row


def ensemble_scalars(records) -> dict:
    """Mean, standard error and count of every numeric summary column across realizations."""
    rows = [_flat_row(r) for r in records]
    out = {}
    for k in dict.fromkeys(k for r in rows for k in r):
        if k in ("index", "seed_entropy", "seed_spawn_key", "gsd", "sha256", "seconds"):
            continue
        vals = [r.get(k) for r in rows]
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
            continue
        a = np.asarray(vals, dtype=np.float64)
        se = a.std(ddof=1) / math.sqrt(a.size) if a.size > 1 else float("nan")
        out[k] = {"mean": float(a.mean()), "se": se if math.isfinite(se) else None, "n": int(a.size)}
    return out


def aggregate(out, study: Study, records) -> dict:
    """Write summary.csv, ensemble curves (JSON, CSV), scalar means and plots; return their paths."""
    out = Path(out)
    ens = make_folder(out / "ensemble")
    files = {}

    rows = [_flat_row(r) for r in records]
    cols = list(dict.fromkeys(k for r in rows for k in r))
    with atomic_open(out / "summary.csv", "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=cols)
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in cols})
    files["summary table"] = out / "summary.csv"

    # realizations stopped by a budget are in summary.csv (with their status) but never
    # averaged in: the ensemble files name them under "excluded"
    complete = [r for r in records if is_complete(r)]
    excluded = [{"index": r["index"], "status": realization_status(r)} for r in records if not is_complete(r)]
    curves = ensemble_curves(complete) if complete else {}
    with atomic_open(ens / "curves.json", "w", encoding="utf-8") as fh:
        json.dump({"ci_level": CI_LEVEL, "ci_factor": t_quantile(len(complete) - 1) if len(complete) > 1 else None,
                   "n_realizations": len(complete), "excluded": excluded, "analyses": curves}, fh)
    scalars = ensemble_scalars(complete) if complete else {}
    if excluded:
        scalars["excluded"] = excluded
    with atomic_open(ens / "scalars.json", "w", encoding="utf-8") as fh:
        json.dump(scalars, fh, indent=1)
    files["ensemble curves"] = ens / "curves.json"
    files["ensemble scalars"] = ens / "scalars.json"
    for name, entry in curves.items():
        with atomic_open(ens / f"{name}.csv", "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            cn = list(entry["curves"])
            w.writerow([entry["x_name"]] + [f"{c}_{s}" for c in cn for s in ("mean", "lo", "hi")])
            for j, x in enumerate(entry["x"]):
                w.writerow([x] + ["" if entry["curves"][c][s][j] is None else entry["curves"][c][s][j]
                                  for c in cn for s in ("mean", "lo", "hi")])
    if study.data["output"]["plots"]:
        fmt = study.data["output"]["plot_format"]
        files["plots"] = ens / f"*.{fmt}"
        from ._plots import plot_curves, plot_grading

        plot_curves(curves, ens, fmt, title=study.name)
        if complete:
            plot_grading(study, complete, ens / f"grading.{fmt}", fmt)
    return files
