"""Wall time of one VEM structure (issue 16 target: N = 8000 in under 5 minutes on one core).

    nice python benchmarks/bench_vem.py --n 8000 --void-ratio 0.125 2 [--json out.json]

There is no free peer for the void expansion method (the seed used the commercial
PFC3D), so the script reports the time per structure, the particle-steps per second
of the damped soft-contact dynamics and the ratio to the 300 s target.  Run it with
``nice`` on a shared machine and say so when quoting the numbers.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=8000)
    ap.add_argument("--void-ratio", type=float, nargs="+", default=[0.125, 2.0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    import polypack as pp
    from polypack._kernels import cells, contacts, dem, edmd, vem

    for k in (cells, contacts, dem, edmd, vem):
        k.warmup()
    rows = []
    for vr in args.void_ratio:
        t0 = time.perf_counter()
        cpu0 = time.process_time()
        pk = pp.vem(args.n, volume_fraction=0.4, void_ratio=vr, seed=args.seed, progress=False)
        wall = time.perf_counter() - t0
        cpu = time.process_time() - cpu0
        m = pk.meta["vem"]
        s = m["series"]
        nv = m["n_void"]
        psteps = float(np.sum(s["steps"])) * (args.n + nv)
        row = {"n": args.n, "void_ratio": vr, "n_void": nv, "wall_s": wall, "cpu_s": cpu, "stages": m["stages"],
               "steps": m["steps"], "particle_steps_per_cpu_s": psteps / cpu, "target_s": 300.0,
               "ratio_to_target": cpu / 300.0, "coordination_at_jamming": m["coordination_at_jamming"],
               "total_fraction_at_stop": s["total_fraction"][-1], "min_gap": pk.meta["min_gap"]}
        rows.append(row)
        print(f"N={args.n} N_V/N={vr:g}: {wall:.1f} s wall, {cpu:.1f} s CPU ({cpu / 300:.2f} of the 300 s target), "
              f"{m['stages']} stages, {m['steps']} steps, {psteps / cpu:.3g} particle-steps/CPU s, "
              f"C at jamming {m['coordination_at_jamming']:.3f}", flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
