"""Cold and warm first run of the README's main job (``polypack run examples/bimodal_propellant.toml
--workers 2``), with and without compiling the study's kernels once before the process pool starts.

Each run prints its wall and CPU seconds (the run and its workers) and the 1-minute load
average before and after it; the JSON records the commit.

Cold: an empty numba cache (``NUMBA_CACHE_DIR`` in a new temporary folder), as on a fresh clone after
``pip install``. Warm: the same cache, already filled by the cold run. Each run writes into a new
output folder, so nothing is reused but the compiled kernels.

    python benchmarks/bench_cold_start.py [--realizations P] [--json benchmarks/cold_start.json]

``POLYPACK_PRECOMPILE=0`` switches the pre-compilation off (the behaviour before it existed), which
is the comparison printed as "no pre-compile".
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "examples" / "bimodal_propellant.toml"


def run(cache, out, precompile=True, realizations=None):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "POLYPACK_PRECOMPILE": "1" if precompile else "0"}
    study = STUDY
    if realizations is not None:
        text = STUDY.read_text().replace("realizations = 16", f"realizations = {realizations}")
        study = Path(out).with_suffix(".toml")
        study.write_text(text)
    load0 = _load()
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run([sys.executable, "-m", "polypack.cli", "run", str(study), "--out", str(out),
                          "--workers", "2"], env=env, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 0:
        raise SystemExit(f"polypack run failed:\n{res.stderr}")
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)  # the run and its workers
    return dt, cpu, f"{load0}-{_load()}"


def _load():
    """The 1-minute load average (the machine may be shared)."""
    with open("/proc/loadavg") as fh:
        return fh.read().split()[0]


def _commit():
    try:
        return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True).stdout.strip() or None
    except OSError:
        return None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--realizations", type=int, default=None, help="override the study's 16 realizations")
    ap.add_argument("--json", type=Path, default=ROOT / "benchmarks" / "cold_start.json")
    ap.add_argument("--skip-baseline", action="store_true", help="only the pre-compiled runs")
    args = ap.parse_args()
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for label, pre in (("pre-compile", True),) + ((() if args.skip_baseline else (("no pre-compile", False),))):
            cache = tmp / f"cache-{pre}"
            cold, cold_cpu, cold_load = run(cache, tmp / f"cold-{pre}", pre, args.realizations)
            warm, warm_cpu, warm_load = run(cache, tmp / f"warm-{pre}", pre, args.realizations)
            rows[label] = {"cold_seconds": cold, "warm_seconds": warm, "cold_cpu_seconds": cold_cpu,
                           "warm_cpu_seconds": warm_cpu, "cold_load": cold_load, "warm_load": warm_load}
            print(f"{label:>15s}: cold {cold:6.1f} s ({cold_cpu:5.1f} CPU s, load {cold_load})   "
                  f"warm {warm:6.1f} s ({warm_cpu:5.1f} CPU s, load {warm_load})", flush=True)
    info = {"job": f"polypack run {STUDY.relative_to(ROOT)} --workers 2", "realizations": args.realizations or 16,
            "commit": _commit(), "cpus": os.cpu_count(), "results": rows,
            "note": "measured on a machine shared with other jobs; compare the rows, not absolute times"}
    args.json.write_text(json.dumps(info, indent=1) + "\n")
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
