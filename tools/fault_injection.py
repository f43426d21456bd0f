"""Fault injection: a real SIGINT at every safe point (or at wall-clock times) of a run.

Used by ``tests/test_interrupts.py`` (a sample of the points, a few timings) and as a
standalone reproduction script for the full sweep::

    python tools/fault_injection.py                 # every point of the small studies
    python tools/fault_injection.py --times 40      # + 40 wall-clock SIGINTs to CLI subprocesses

Every interrupted run must either exit with an interrupt (and a resume then gives the
uninterrupted results bit for bit) or finish with exactly those results; a saved
realization is never different from the reference.  Prints one line per study with
the number of timings tried and the number of wrong saved results (must be 0).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def small_study(kind="crm", seed=11, realizations=3, n=120):
    """A study of a few seconds: bimodal sizes, CRM (+ shakes) or SCRM, four analyses."""
    pr = {"kind": kind, "volume_fraction": 0.45, "global_shakes": 3}
    if kind == "scrm":
        pr.update(growth_steps=3, stage_shakes=1)
    return {
        "study": {"name": f"fault-{kind}", "seed": seed, "realizations": realizations},
        "psd": {"model": "bimodal", "size_ratio": 0.5, "volume_ratio": 0.5, "n": n},
        "protocol": pr,
        "analysis": {
            "rdf": {"r_max": 0.9, "dr": 0.05},
            "windows": {"window_radius": 2.0},
            "contacts": {"tolerance": 0.02},
            "pores": {"n_points": 500},
        },
        "output": {"plots": False},
    }


def run_results(out: Path):
    """``{index: (positions, record without timings)}`` of the saved realizations, and the ensemble files."""
    import polypack as pp

    recs = {}
    for rec_path in sorted((out / "realizations").glob("r[0-9]*.json")):
        rec = json.loads(rec_path.read_text())
        pk = pp.io.read(rec_path.with_suffix(".gsd"))
        # timings and the GSD checksum (its provenance holds wall times) differ between runs
        rec = {k: v for k, v in rec.items() if k not in ("seconds", "files")}
        rec["protocol"] = {k: v for k, v in rec["protocol"].items() if "time" not in k and "per_second" not in k}
        recs[rec["index"]] = (pk.positions, json.dumps(rec, sort_keys=True))
    ens = {}
    for name in ("summary.csv", "ensemble/curves.json"):
        p = out / name
        ens[name] = p.read_text() if p.is_file() else None
    return recs, ens


def same_records(a: dict, b: dict, only=None) -> list:
    """Indices where the saved realizations differ (positions bitwise, records exactly)."""
    bad = []
    for i in (only if only is not None else sorted(set(a) | set(b))):
        if i not in a or i not in b:
            bad.append(i)
            continue
        if not np.array_equal(a[i][0], b[i][0]) or a[i][1] != b[i][1]:
            bad.append(i)
    return bad


def _summary_without_timings(text):
    if text is None:
        return None
    import csv
    import io

    rows = list(csv.DictReader(io.StringIO(text)))
    return [{k: v for k, v in r.items() if k not in ("seconds", "sha256") and "time" not in k and "per_second" not in k}
            for r in rows]


class SafePointInjector:
    """Count calls of every numba kernel entry point and of the runner's atomic writes;
    at call number ``k`` deliver a real SIGINT (``signal.raise_signal``) while it runs."""

    def __init__(self):
        self.count = 0
        self.names = []
        self.fire_at = None
        self.fired_in = None
        self._saved = []

    def _hit(self, name):
        self.count += 1
        self.names.append(name)
        if self.fire_at is not None and self.count == self.fire_at:
            self.fired_in = name
            signal.raise_signal(signal.SIGINT)

    def install(self):
        import numba

        import polypack._kernels.analysis as k_an
        import polypack._kernels.cells as k_cells
        import polypack._kernels.edmd as k_edmd
        import polypack._kernels.shake as k_shake
        from polypack.ensemble import runner

        for mod in (k_edmd, k_shake, k_an, k_cells):
            for name in dir(mod):
                fn = getattr(mod, name)
                if isinstance(fn, numba.core.registry.CPUDispatcher):
                    self._wrap(mod, name, fn)
        real_open = runner.atomic_open

        @contextlib.contextmanager
        def atomic_open(path, *a, **kw):
            with real_open(path, *a, **kw) as fh:
                yield fh
                self._hit(f"write {Path(path).name}")

        self._saved.append((runner, "atomic_open", real_open))
        runner.atomic_open = atomic_open
        return self

    def _wrap(self, mod, name, fn):
        def wrapper(*args, **kw):
            out = fn(*args, **kw)
            self._hit(f"{mod.__name__.rsplit('.', 1)[-1]}.{name}")
            return out

        self._saved.append((mod, name, fn))
        setattr(mod, name, wrapper)

    def uninstall(self):
        for mod, name, fn in reversed(self._saved):
            setattr(mod, name, fn)
        self._saved.clear()


def sweep_safe_points(study, points=None, workdir=None, log=print, every=None):
    """SIGINT at call ``k`` for every ``k`` in ``points`` (default: all); returns a dict of counts.

    ``every=K`` instead tries every K-th point plus the first call of every kind (each
    kernel, each file written), so every phase is covered however the counts shift.

    The reference run counts the points.  After each interrupted run the saved
    realizations are compared with the reference, the run is resumed, and the resumed
    results (packs, records, summary, curves) must equal the reference bit for bit.
    """
    import polypack as pp

    work = Path(workdir or tempfile.mkdtemp(prefix="polypack-fault-"))
    inj = SafePointInjector()
    ref_dir = work / "ref"
    pp.ensemble.run_study(study, ref_dir, progress=False)  # compiles everything first
    inj.install()
    try:
        inj.count, inj.names = 0, []
        shutil.rmtree(ref_dir)
        pp.ensemble.run_study(study, ref_dir, progress=False)
        total = inj.count
        if every is not None:
            first = {}
            for k, name in enumerate(inj.names, start=1):
                first.setdefault(name.split(" ")[0] if name.startswith("write") else name, k)
            points = sorted(set(range(1, total + 1, every)) | set(first.values()))
        ref, ref_ens = run_results(ref_dir)
        ks = list(range(1, total + 1)) if points is None else [k for k in points if 1 <= k <= total]
        res = {"points": total, "tried": 0, "interrupted": 0, "finished": 0, "wrong_saved": 0, "wrong_resume": 0,
               "where": {}}
        for k in ks:
            out = work / f"k{k}"
            inj.count, inj.fire_at, inj.fired_in = 0, k, None
            try:
                pp.ensemble.run_study(study, out, progress=False)
                interrupted = False
            except KeyboardInterrupt:
                interrupted = True
            inj.fire_at = None
            res["tried"] += 1
            res["interrupted" if interrupted else "finished"] += 1
            res["where"][inj.fired_in] = res["where"].get(inj.fired_in, 0) + 1
            saved, _ = run_results(out) if (out / "realizations").is_dir() else ({}, {})
            bad = same_records(saved, ref, only=sorted(saved))
            if bad:
                res["wrong_saved"] += 1
                log(f"  k={k} ({inj.fired_in}): saved realization(s) {bad} differ from the reference")
            if interrupted:
                pp.ensemble.run_study(study, out, progress=False)
            got, got_ens = run_results(out)
            bad = same_records(got, ref)
            ens_ok = all(_summary_without_timings(got_ens[n]) == _summary_without_timings(ref_ens[n])
                         if n.endswith(".csv") else got_ens[n] == ref_ens[n] for n in ref_ens)
            if bad or not ens_ok:
                res["wrong_resume"] += 1
                log(f"  k={k} ({inj.fired_in}): after resume realization(s) {bad} / ensemble files differ")
            shutil.rmtree(out, ignore_errors=True)
        return res
    finally:
        inj.uninstall()
        if workdir is None:
            shutil.rmtree(work, ignore_errors=True)


def cli_env():
    env = dict(os.environ)
    src = str(Path(__file__).resolve().parents[1] / "src")
    env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


_STARTUP = {}


def _startup():
    """Wall and CPU time (user + system) of ``import polypack`` in a fresh interpreter, measured once."""
    if not _STARTUP:
        import resource

        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import polypack"], env=cli_env(), check=True)
        _STARTUP["t"] = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        _STARTUP["cpu"] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return _STARTUP


def startup_seconds():
    """Wall time of ``import polypack`` in a fresh interpreter (interpreter + numpy start; before
    it a SIGINT is Python's own KeyboardInterrupt at start-up, not polypack's business)."""
    return _startup()["t"]


def startup_cpu_seconds():
    """CPU time (user + system) of ``import polypack`` in a fresh interpreter."""
    return _startup()["cpu"]


def _cpu_seconds(pid):
    """CPU time used so far by a running child (Linux ``/proc``); None once it has ended."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _sigint_ignored(pid):
    """Whether process ``pid`` ignores SIGINT (Linux ``/proc``); None if unknown or ended."""
    try:
        with open(f"/proc/{pid}/status") as fh:
            for line in fh:
                if line.startswith("SigIgn:"):
                    return bool(int(line.split()[1], 16) >> (signal.SIGINT - 1) & 1)
    except (OSError, ValueError):
        return None
    return None


def run_cli(args, sigint_after=None, cwd=None, timeout=300, clock="wall"):
    """Run ``python -m polypack ARGS``; SIGINT ``sigint_after`` s after the interpreter and
    ``import polypack`` would have started. Returns (rc, stderr).

    On Linux the clock starts when polypack's own SIGINT handler is in place: the child is
    started with SIGINT ignored, which Python keeps through its start-up, and the first
    statement of ``import polypack`` replaces it (``polypack._entry``), which ``/proc`` shows.
    A SIGINT before that moment (interpreter start-up, ``site``) is Python's own business, and
    on a loaded machine a wall-clock SIGINT could land there; so none is ever sent before it.

    ``clock="wall"`` counts wall time after :func:`startup_seconds`; ``clock="cpu"`` counts the
    child's own CPU time after :func:`startup_cpu_seconds`, so the SIGINT lands at the same point
    of the computation however loaded the machine is (Linux only).
    """
    if clock not in ("wall", "cpu"):
        raise ValueError(f"clock={clock!r}: use 'wall' or 'cpu'")
    if sigint_after is not None:
        sigint_after += startup_seconds() if clock == "wall" else startup_cpu_seconds()
    gate = sigint_after is not None and Path("/proc/self/status").exists()
    t0 = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "polypack", *map(str, args)], cwd=cwd, env=cli_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=(lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if gate else None)
    deadline = t0 + timeout
    if gate:  # wait for polypack's handler (the SIGINT-ignored bit clears)
        while proc.poll() is None and _sigint_ignored(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.002)
        t0 = time.monotonic()
    if sigint_after is not None and clock == "wall":
        try:
            proc.wait(timeout=max(0.0, t0 + sigint_after - time.monotonic()))
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGINT)
    elif sigint_after is not None:
        while proc.poll() is None and time.monotonic() < deadline:
            used = _cpu_seconds(proc.pid)
            if used is not None and used >= sigint_after:
                proc.send_signal(signal.SIGINT)
                break
            time.sleep(0.02)
    out, err = proc.communicate(timeout=timeout)
    return proc.returncode, err


# A ``sitecustomize`` (found first on PYTHONPATH) that sends the process a real SIGINT at one
# chosen moment of a ``python -m polypack ...`` run, and notes in a file that it did.
_SIGINT_AT_SITECUSTOMIZE = """
import os, signal, sys

_where = os.environ.get("POLYPACK_SIGINT_AT", "")
_mark = os.environ.get("POLYPACK_SIGINT_MARK", "")
_kind, _, _target = _where.partition(":")


def _fire(kill=os.kill, pid=os.getpid(), mark=_mark, where=_where, open_=open):  # bound: usable at teardown
    if mark:
        with open_(mark, "w") as fh:
            fh.write(where)
    kill(pid, signal.SIGINT)


if _kind == "import":  # while the module _target is being imported (its first import)
    class _Finder:
        def find_spec(self, name, path=None, target=None):
            if name == _target:
                sys.meta_path.remove(self)
                _fire()
            return None

    sys.meta_path.insert(0, _Finder())
elif _kind in ("call", "return"):  # as the function _target (module.function) is entered / returns
    _mod, _, _func = _target.rpartition(".")

    def _profile(frame, event, arg):
        if (event == _kind and frame.f_code.co_name == _func
                and frame.f_globals.get("__name__") == _mod):
            sys.setprofile(None)
            _fire()

    sys.setprofile(_profile)
elif _kind == "atexit":  # registered before polypack is imported: the last atexit callback
    import atexit

    atexit.register(_fire)
elif _kind == "teardown":  # while the modules are torn down, after Python's signal handling ended
    class _OnDelete:
        def __del__(self, fire=_fire):
            fire()

    _on_delete = _OnDelete()
"""

SIGINT_POINTS = ("import:numpy", "import:polypack.__main__", "import:typer", "call:polypack.cli.main",
                 "return:polypack.cli.main", "return:polypack._entry.main", "atexit", "teardown")


def run_cli_sigint_at(args, where, workdir, timeout=300):
    """Run ``python -m polypack ARGS`` with a real SIGINT sent at ``where`` (one of
    :data:`SIGINT_POINTS`, or ``import:<module>`` / ``call:<module.function>`` /
    ``return:<module.function>``). Returns (rc, stderr, fired): ``fired`` says whether the
    SIGINT was sent (a point the run never reached sends nothing)."""
    workdir = Path(workdir)
    site = workdir / "sigint-at-site"
    site.mkdir(parents=True, exist_ok=True)
    (site / "sitecustomize.py").write_text(_SIGINT_AT_SITECUSTOMIZE)
    mark = workdir / "sigint-at-fired"
    mark.unlink(missing_ok=True)
    env = cli_env()
    env["PYTHONPATH"] = str(site) + os.pathsep + env["PYTHONPATH"]
    env.update(POLYPACK_SIGINT_AT=where, POLYPACK_SIGINT_MARK=str(mark))
    proc = subprocess.run([sys.executable, "-m", "polypack", *map(str, args)], env=env, capture_output=True,
                          text=True, timeout=timeout)
    return proc.returncode, proc.stderr, mark.exists()


def during_startup(rc, err) -> bool:
    """A SIGINT that arrived while Python was still starting, before any polypack code ran:
    Python's own outcome, not polypack's (:func:`run_cli` never sends one then on Linux)."""
    return rc != 130 and "KeyboardInterrupt" in err and "polypack/" not in err.replace("\\", "/")


def sweep_cli_times(args_of, reference_check, times, log=print):
    """SIGINT a CLI command at each time; ``reference_check(rc, stderr, tag)`` returns an error text or None.

    SIGINTs that landed in Python's start-up (:func:`during_startup`) are counted apart.
    """
    res = {"tried": 0, "rc": {}, "wrong": 0, "startup": 0}
    for j, t in enumerate(times):
        tag = f"t{j}"
        rc, err = run_cli(args_of(tag), sigint_after=t)
        res["rc"][rc] = res["rc"].get(rc, 0) + 1
        if during_startup(rc, err):
            res["startup"] += 1
            continue
        res["tried"] += 1
        bad = reference_check(rc, err, tag)
        if bad:
            res["wrong"] += 1
            log(f"  SIGINT at {t:.2f} s: {bad}")
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--every", type=int, default=1, help="try every k-th safe point (default 1: all)")
    ap.add_argument("--times", type=int, default=0, help="wall-clock SIGINTs per CLI command (pack, scrm, run)")
    ap.add_argument("--max-time", type=float, default=4.0, help="latest SIGINT time for the CLI sweep (s)")
    args = ap.parse_args(argv)
    total_tried = total_wrong = 0
    for kind in ("crm", "scrm"):
        t0 = time.time()
        study = small_study(kind)
        n_points = None
        res = sweep_safe_points(study, points=None if args.every == 1 else range(1, 10**6, args.every))
        n_points = res["points"]
        print(f"{kind}: {res['tried']} of {n_points} safe points tried, {res['interrupted']} interrupted, "
              f"{res['finished']} finished; wrong saved {res['wrong_saved']}, wrong after resume "
              f"{res['wrong_resume']} ({time.time() - t0:.0f} s)")
        print("   where:", ", ".join(f"{k}: {v}" for k, v in sorted(res["where"].items(), key=str)))
        total_tried += res["tried"]
        total_wrong += res["wrong_saved"] + res["wrong_resume"]
    if args.times:
        tried, wrong = cli_time_sweeps(args.times, args.max_time)
        total_tried += tried
        total_wrong += wrong
    print(f"total: {total_tried} interrupt timings, {total_wrong} wrong outcomes (wrong saved result, wrong exit "
          "code or a resume that differs)")
    return 1 if total_wrong else 0


def cli_time_sweeps(n_times, max_time, log=print):
    """Wall-clock SIGINTs to `polypack pack`, `scrm` and `run` subprocesses; returns (tried, wrong)."""
    import polypack as pp
    from polypack.study import Study

    work = Path(tempfile.mkdtemp(prefix="polypack-fault-cli-"))
    rng = np.random.default_rng(5)
    times = np.sort(rng.uniform(0.3, max_time, n_times))
    tried = wrong = 0
    try:
        jobs = {
            "pack": ["pack", "--n", "3000", "--size-ratio", "0.5", "--volume-ratio", "0.333", "-c", "0.6",
                     "--seed", "3", "--no-progress"],
            "scrm": ["scrm", "--n", "2000", "--size-ratio", "0.5", "--volume-ratio", "0.333", "-c", "0.55",
                     "--growth-steps", "3", "-M", "5", "--seed", "3", "--no-progress"],
        }
        for name, base in jobs.items():
            ref = work / f"{name}-ref.gsd"
            rc, err = run_cli([*base, "-o", ref])
            assert rc == 0, err
            ref_pk = pp.io.read(ref)

            def args_of(tag, base=base, name=name):
                return [*base, "-o", work / f"{name}-{tag}.gsd"]

            def check(rc, err, tag, name=name, ref_pk=ref_pk):
                p = work / f"{name}-{tag}.gsd"
                if rc == 0:
                    got = pp.io.read(p)
                    return None if np.array_equal(got.positions, ref_pk.positions) else "exit 0 with a different pack"
                if rc != 130:
                    return f"exit {rc}: {err.strip()[-300:]}"
                if len(err.strip().splitlines()) != 1 or not err.startswith("interrupted"):
                    return f"not one 'interrupted' line: {err.strip()[-300:]!r}"
                if p.exists():  # the Ctrl-C came after the (atomic) write: named, and whole
                    if f"saved {p}" not in err:
                        return "exit 130 with a pack under the requested name that the line does not name"
                    if not np.array_equal(pp.io.read(p).positions, ref_pk.positions):
                        return "exit 130 with a different pack under the requested name"
                return None

            r = sweep_cli_times(args_of, check, times, log=log)
            print(f"cli {name}: {r['tried']} SIGINT times in [0.3, {max_time}] s (+{r['startup']} during Python's "
                  f"start-up), exit codes {r['rc']}, wrong {r['wrong']}")
            tried += r["tried"]
            wrong += r["wrong"]
        # polypack run: interrupt, then resume, must equal the reference run
        study = small_study("scrm", realizations=3, n=600)
        f = work / "study.toml"
        f.write_text(Study.from_dict(study).to_toml())
        ref_dir = work / "run-ref"
        rc, err = run_cli(["run", f, "--out", ref_dir, "--no-progress"])
        assert rc == 0, err
        ref, _ = run_results(ref_dir)

        def args_of(tag):
            return ["run", f, "--out", work / f"run-{tag}", "--no-progress"]

        def check(rc, err, tag):
            out = work / f"run-{tag}"
            if rc not in (0, 130):
                return f"exit {rc}: {err.strip()[-300:]}"
            saved, _ = run_results(out) if (out / "realizations").is_dir() else ({}, {})
            if same_records(saved, ref, only=sorted(saved)):
                return "a saved realization differs from the reference"
            if rc == 130:
                rc2, err2 = run_cli(["run", f, "--out", out, "--no-progress"])
                if rc2 != 0:
                    return f"resume failed: {err2.strip()[-300:]}"
            got, _ = run_results(out)
            return "resumed results differ" if same_records(got, ref) else None

        r = sweep_cli_times(args_of, check, times, log=log)
        print(f"cli run: {r['tried']} SIGINT times (+{r['startup']} during Python's start-up), exit codes {r['rc']}, "
              f"wrong {r['wrong']}")
        tried += r["tried"]
        wrong += r["wrong"]
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return tried, wrong


if __name__ == "__main__":
    sys.exit(main())
