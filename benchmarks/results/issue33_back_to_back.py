"""Issue 33: polypack and spheropack 0.2.0 back to back in one process on N equal spheres to 0.62.

    PYTHONPATH=src python benchmarks/results/issue33_back_to_back.py 10000 2,3,4 [--no-peer]

One JSON line per seed: wall and CPU seconds, collisions, events, shell rebuilds of polypack, the
peer's wall, CPU and collisions, the coll/s and wall ratios, and the load average before and after
(the machine is shared: compare CPU seconds and runs at the same load).
"""
import sys, time, os, json
import numpy as np
import polypack as pp
from polypack._kernels import edmd
import spheropack
edmd.warmup(); pp.pack(np.ones(64), 0.3, seed=0)
N = int(sys.argv[1]) if len(sys.argv) > 1 else 10000
seeds = [int(s) for s in sys.argv[2].split(",")] if len(sys.argv) > 2 else [2]
peer = "--no-peer" not in sys.argv
rows = []
for seed in seeds:
    la0 = open('/proc/loadavg').read().split()[0]
    c0 = time.process_time(); t0 = time.perf_counter(); pk = pp.pack(np.ones(N), 0.62, seed=seed, growth_rate=0.02, progress=False); w = time.perf_counter() - t0
    m = pk.meta
    r = {"seed": seed, "load": la0, "pp_wall": w, "pp_coll": m["collisions"], "pp_cps": m["collisions"] / w, "pp_cpu": time.process_time() - c0,
         "pp_rebuilds": m.get("rebuilds"), "pp_events": m.get("events"), "pp_local": m.get("shell_rebuilds"), "phi": pk.volume_fraction}
    if peer:
        c0 = time.process_time(); t0 = time.perf_counter(); res = spheropack.pack(n=N, radii=np.ones(N), density=0.62, growth_rate=0.02, seed=seed); w2 = time.perf_counter() - t0
        r.update(sp_wall=w2, sp_coll=int(res.n_collisions), sp_cps=int(res.n_collisions) / w2, sp_cpu=time.process_time() - c0,
                 cps_ratio=(m["collisions"] / w) / (int(res.n_collisions) / w2), wall_ratio=w2 / w)
    r["load_end"] = open('/proc/loadavg').read().split()[0]
    print(json.dumps(r)); sys.stdout.flush(); rows.append(r)
