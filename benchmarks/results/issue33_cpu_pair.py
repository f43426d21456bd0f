"""Issue 33: CPU seconds of pp.pack(N equal spheres) with a digest of positions and radii (compare two trees
by PYTHONPATH, alternating processes): PYTHONPATH=src python benchmarks/results/issue33_cpu_pair.py N seeds [phi]"""
import sys, time, json, hashlib
import numpy as np
import polypack as pp
from polypack._kernels import edmd
edmd.warmup(); pp.pack(np.ones(64), 0.3, seed=0)
N = int(sys.argv[1]); seeds = [int(s) for s in sys.argv[2].split(",")]
phi = float(sys.argv[3]) if len(sys.argv) > 3 else 0.62
for seed in seeds:
    la = open('/proc/loadavg').read().split()[0]
    c0 = time.process_time(); t0 = time.perf_counter()
    pk = pp.pack(np.ones(N), phi, seed=seed, growth_rate=0.02, progress=False)
    cpu = time.process_time() - c0; w = time.perf_counter() - t0
    h = hashlib.sha1(np.ascontiguousarray(pk.positions).tobytes() + np.ascontiguousarray(pk.radii).tobytes()).hexdigest()[:12]
    m = pk.meta
    print(json.dumps({"src": pp.__file__.split('/src/')[0], "N": N, "seed": seed, "cpu": round(cpu, 3), "wall": round(w, 3),
                      "coll": m["collisions"], "events": m.get("events"), "load": la,
                      "load_end": open('/proc/loadavg').read().split()[0], "digest": h}), flush=True)
