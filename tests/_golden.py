"""Golden record of a small SCRM study (and a CRM one), recorded before the registry refactor.

``python tests/_golden.py write`` regenerates ``tests/data/golden_study.json`` (only do that
when a change of results is intended and explained); the test compares a fresh run with it.
Everything that does not depend on wall-clock time is compared: every realization record
(protocol statistics, size report, every analysis and scalar), the ensemble curves, the
summary table and the pack arrays (positions, radii, box, species bytes).
"""

from __future__ import annotations

import csv
import hashlib
import json
import sys
from pathlib import Path

GOLDEN = Path(__file__).parent / "data" / "golden_study.json"

STUDIES = {
    "scrm": {
        "study": {"name": "golden_scrm", "seed": 7, "realizations": 2},
        "psd": {"model": "bimodal", "size_ratio": 0.5, "volume_ratio": 0.5, "n": 150},
        "protocol": {"kind": "scrm", "volume_fraction": 0.5, "growth_steps": 3, "stage_shakes": 1,
                     "global_shakes": 3, "shake_method": "paper"},
        "analysis": {"rdf": {"r_max": 1.2, "dr": 0.05}, "kfunction": {"r_max": 1.2, "dr": 0.05},
                     "windows": {"window_radius": [1.5, 2.0]}, "contacts": {"tolerance": 0.02},
                     "pores": {"n_points": 2000}},
        "output": {"plots": False},
    },
    "crm": {
        "study": {"name": "golden_crm", "seed": 3, "realizations": 1},
        "psd": {"model": "cumulative_beta", "a": 1.0, "b": 3.0, "span": 0.3, "sampling": "discretize",
                "n_classes": 3, "min_per_class": 10, "min_total": 120, "max_total": 700},
        "protocol": {"kind": "crm", "volume_fraction": 0.45, "global_shakes": 2},
        "analysis": {"rdf": {"r_max": 1.0, "dr": 0.05}, "contacts": {}},
        "output": {"plots": False},
    },
}

# keys whose values depend on the machine or the clock
_VOLATILE = {"seconds", "wall_seconds", "elapsed", "time", "cpu_seconds", "compile_seconds", "sha256",
             "kernel_seconds", "python_seconds"}


def _volatile(key: str) -> bool:
    key = key.rsplit(".", 1)[-1] if key.startswith(("protocol.", "shake.", "scrm.")) else key
    return key in _VOLATILE or key.endswith(("seconds", "_time", "per_second"))


def _scrub(obj):
    if isinstance(obj, dict):
        return {k: _scrub(v) for k, v in obj.items() if not _volatile(k)}
    if isinstance(obj, list):
        return [_scrub(v) for v in obj]
    return obj


def _digest(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, allow_nan=True).encode()).hexdigest()


def fingerprint_run(study: dict, out: Path) -> dict:
    """Digests of everything a run writes that must not change with a refactor."""
    import numpy as np

    import polypack as pp
    from polypack.ensemble import run_study

    run_study(study, out, workers=1, progress=False)
    res = {"records": [], "packs": []}
    for rec_path in sorted((out / "realizations").glob("r*.json")):
        rec = json.loads(rec_path.read_text())
        res["records"].append({"analysis": _digest(_scrub(rec.get("analysis"))),
                               "protocol": _digest(_scrub(rec.get("protocol"))),
                               "psd": _digest(_scrub(rec.get("psd"))),
                               "scalars": _digest(_scrub(rec.get("scalars"))),
                               "n": rec["n"], "volume_fraction": float(rec["volume_fraction"]).hex()})
    for gsd_path in sorted((out / "realizations").glob("r*.gsd")):
        pk = pp.io.read(gsd_path)
        h = hashlib.sha256()
        for arr in (pk.positions, pk.radii, pk.box, pk.species):
            h.update(np.ascontiguousarray(arr).tobytes())
        res["packs"].append({"arrays": h.hexdigest(), "meta": _digest(_scrub(pk.meta))})
    curves = json.loads((out / "ensemble" / "curves.json").read_text())
    # the averaged curves and their bands (bookkeeping keys of curves.json may be added)
    res["curves"] = _digest(curves["analyses"])
    res["ci_factor"] = curves["ci_factor"]
    with open(out / "summary.csv", newline="") as fh:
        rows = [{k: v for k, v in r.items() if not _volatile(k)} for r in csv.DictReader(fh)]
    res["summary"] = _digest(rows)
    res["summary_columns"] = list(rows[0]) if rows else []
    return res


# The record is bit for bit, and numpy and OpenBLAS pick their floating-point code by CPU at
# run time: numpy's AVX-512 loops and OpenBLAS's SkylakeX kernels round some results
# differently from their AVX2 versions, by ulps that the packing dynamics amplify into other
# packs (seen 2 Dec 2026: the record of an AVX2 machine failed on an AVX-512 one and matched bit
# for bit with these settings).  The numba kernels are not affected (no fast-math: LLVM keeps
# IEEE order whatever the target).  So the studies run in a child process pinned to the AVX2
# code paths; names this numpy does not know are ignored, and on an AVX2 machine it is a no-op.
PINNED_ENV = {
    "OPENBLAS_CORETYPE": "Haswell",
    "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR AVX512F AVX512CD AVX512_SKX AVX512_CLX AVX512_CNL "
                                "AVX512_KNL AVX512_KNM",
}


def compute_all(tmp: Path) -> dict:
    return {name: fingerprint_run(st, tmp / name) for name, st in STUDIES.items()}


def compute_all_pinned(tmp: Path) -> dict:
    """:func:`compute_all` in a child process with :data:`PINNED_ENV` (set before numpy loads)."""
    import os
    import subprocess

    out = Path(tmp) / "fingerprint.json"
    env = dict(os.environ, **PINNED_ENV)  # PYTHONPATH (the tree under test) is inherited
    subprocess.run([sys.executable, str(Path(__file__).resolve()), "compute", str(tmp), str(out)], env=env,
                   check=True)
    return json.loads(out.read_text())


if __name__ == "__main__" and sys.argv[1:2] == ["compute"]:
    data = compute_all(Path(sys.argv[2]))
    Path(sys.argv[3]).write_text(json.dumps(data))

if __name__ == "__main__" and sys.argv[1:] == ["write"]:
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        data = compute_all_pinned(Path(d))
    GOLDEN.parent.mkdir(exist_ok=True)
    GOLDEN.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
    print(f"wrote {GOLDEN}")
