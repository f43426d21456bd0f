"""Benchmark polypack.pack against spheropack 0.2.0 (same radii, targets and growth rate).

Usage::

    python benchmarks/bench_pack.py            # issue #4 cases up to N=3000 / ratio 10
    python benchmarks/bench_pack.py --quick    # smaller cases (a minute or two)
    python benchmarks/bench_pack.py --large    # adds 1e5 (and with --huge 1e6) spheres, ratio 10, to 0.70

Each case runs polypack and then spheropack in a child process with a time limit (a run
that does not finish is reported as such).  The machine may be shared: figures are noisy.
Writes ``benchmarks/results/bench_pack.json``.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def bidisperse(n, diameter_ratio, large_volume_share=0.5):
    """Radii (large = 1) with the given volume share of the large spheres."""
    small = 1.0 / diameter_ratio
    # n_l + n_s = n, n_l * 1 = share/(1-share) * n_s * small^3
    q = large_volume_share / (1.0 - large_volume_share) * small**3
    n_l = max(1, int(round(n * q / (1.0 + q))))
    return np.r_[np.full(n_l, 1.0), np.full(n - n_l, small)], np.r_[np.zeros(n_l, int), np.ones(n - n_l, int)]


def _run_polypack(radii, target, growth_rate, seed, q):
    import polypack as pp

    t0 = time.perf_counter()
    pk = pp.pack(radii, target, seed=seed, growth_rate=growth_rate, progress=False)
    wall = time.perf_counter() - t0
    m = pk.meta
    q.put({
        "wall_time": wall, "collisions": m["collisions"], "run_time": m["run_time"],
        "collisions_per_second": m["collisions_per_second"], "volume_fraction": pk.volume_fraction,
        "status": m["status"], "min_gap": m["min_gap"], "rebuilds": m["rebuilds"],
        "max_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    })


def _run_spheropack(radii, target, growth_rate, seed, q):
    import spheropack

    density = "max" if target == "jammed" else target
    t0 = time.perf_counter()
    res = spheropack.pack(n=len(radii), radii=np.asarray(radii), density=density, growth_rate=growth_rate, seed=seed)
    wall = time.perf_counter() - t0
    pos = np.asarray(res.positions)
    rad = np.asarray(res.radii)
    q.put({
        "wall_time": wall, "collisions": int(res.n_collisions), "run_time": float(res.wall_time),
        "collisions_per_second": int(res.n_collisions) / float(res.wall_time) if res.wall_time else 0.0,
        "volume_fraction": float(res.density), "status": str(getattr(res, "status", "?")),
        "n": int(pos.shape[0]), "radius_ratio": float(rad.max() / rad.min()),
        "max_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    })


def run_limited(fn, args, timeout):
    """Run ``fn(*args, queue)`` in a child process; None result if it exceeds ``timeout`` seconds."""
    ctx = mp.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=fn, args=(*args, q))
    t0 = time.perf_counter()
    p.start()
    try:
        res = q.get(timeout=timeout)
    except Exception:
        res = {"status": f"did not finish in {timeout:.0f} s", "wall_time": time.perf_counter() - t0}
        p.terminate()
    p.join(5)
    return res


def cases(args):
    out = []
    if args.quick:
        out.append(("mono N=2000 to 0.64", np.ones(2000), 0.64))
    else:
        out.append(("mono N=1e4 to 0.64", np.ones(10000), 0.64))
    n1 = 168
    out.append(("seed000 bimodal N=2000 to 0.6", np.r_[np.full(n1, 1.0), np.full(2000 - n1, 0.313)], 0.6))
    r3, _ = bidisperse(3000 if not args.quick else 1500, 3.0)
    out.append((f"ratio 3, half volume, N={r3.size}, jammed", r3, "jammed"))
    # diameter ratio 10 with half the volume in large spheres needs ~1000 small per large: N=3000
    # would leave 3 large spheres larger than half the box, so use N=20000 (20 large)
    r10, _ = bidisperse(20000 if not args.quick else 10000, 10.0)
    out.append((f"ratio 10, half volume, N={r10.size}, jammed", r10, "jammed"))
    out.append((f"mono N={r10.size}, jammed (per-collision reference)", np.ones(r10.size), "jammed"))
    if args.large:
        r, _ = bidisperse(10**5, 10.0)
        out.append(("ratio 10, N=1e5, to 0.70", r, 0.70))
    if args.huge:
        r, _ = bidisperse(10**6, 10.0)
        out.append(("ratio 10, N=1e6, to 0.70", r, 0.70))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--large", action="store_true", help="add N=1e5, ratio 10, to 0.70")
    ap.add_argument("--huge", action="store_true", help="add N=1e6, ratio 10, to 0.70 (long)")
    ap.add_argument("--timeout", type=float, default=300.0, help="per run, seconds")
    ap.add_argument("--no-peer", action="store_true", help="skip spheropack")
    ap.add_argument("--growth-rate", type=float, default=0.02)
    ap.add_argument("--only", default=None, help="run only cases whose name contains this text")
    ap.add_argument("--output", default="bench_pack.json", help="file name in benchmarks/results/")
    args = ap.parse_args()

    import polypack as pp
    from polypack._kernels import edmd

    edmd.warmup()  # compile outside the timings
    pp.pack(np.ones(64), 0.3, seed=0)
    rows = []
    for name, radii, target in cases(args):
        if args.only and args.only not in name:
            continue
        load = os.getloadavg()[0]  # a shared machine: the figures mean little without it
        ours = run_limited(_run_polypack, (radii, target, args.growth_rate, 1), args.timeout * 3)
        peer = None if args.no_peer else run_limited(_run_spheropack, (radii, target, args.growth_rate, 1), args.timeout)
        row = {"case": name, "n": int(radii.size), "target": target, "polypack": ours, "spheropack": peer,
               "load_average": [load, os.getloadavg()[0]]}
        if peer and "collisions" in peer and "collisions" in ours:
            row["rate_ratio"] = ours["collisions_per_second"] / max(peer["collisions_per_second"], 1e-300)
            row["time_ratio"] = ours["wall_time"] / peer["wall_time"]
        rows.append(row)
        _print_row(row)
        sys.stdout.flush()
    res_dir = Path(__file__).resolve().parent / "results"
    res_dir.mkdir(exist_ok=True)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=Path(__file__).resolve().parent).stdout.strip()
    info = {"commit": commit, "machine": platform.platform(), "cpus": os.cpu_count(), "python": sys.version.split()[0],
            "growth_rate": args.growth_rate, "note": "shared 2-core machine, timings are noisy", "rows": rows}
    (res_dir / args.output).write_text(json.dumps(info, indent=2, default=float))
    print(f"wrote {res_dir / args.output}")


def _fmt(r):
    if r is None:
        return "-"
    if "collisions" not in r:
        return r["status"]
    return (f"{r['wall_time']:7.2f}s {r['collisions']:>10d} coll {r['collisions_per_second']:9.3g}/s "
            f"φ={r['volume_fraction']:.4f} {r['status']}")


def _print_row(row):
    la = row.get("load_average")
    print(f"\n== {row['case']}" + (f"   (load average {la[0]:.2f} -> {la[1]:.2f})" if la else ""))
    print(f"  polypack   : {_fmt(row['polypack'])}")
    print(f"  spheropack : {_fmt(row['spheropack'])}")
    if "rate_ratio" in row:
        print(f"  collisions/s ratio (polypack/spheropack) = {row['rate_ratio']:.2f}, "
              f"wall-time speed-up (spheropack/polypack) = {1.0 / row['time_ratio']:.2f}")


if __name__ == "__main__":
    main()
