"""CPU s of the 10^5 bidisperse size-ratio-10 pack to 0.70 (bench_pack's bidisperse, seed 1)."""
import sys, time, json, hashlib, resource
sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1]))
import numpy as np
import polypack as pp
from polypack._kernels import edmd
from bench_pack import bidisperse
edmd.warmup(); pp.pack(np.ones(64), 0.3, seed=0)
r, _ = bidisperse(10**5, 10.0)
la = open('/proc/loadavg').read().split()[0]
c0 = time.process_time(); t0 = time.perf_counter()
pk = pp.pack(r, 0.70, seed=1, growth_rate=0.02, progress=False)
cpu = time.process_time() - c0; w = time.perf_counter() - t0
h = hashlib.sha1(pk.positions.tobytes() + pk.radii.tobytes()).hexdigest()[:12]
print(json.dumps({"src": pp.__file__.split('/src/')[0], "case": "bi10 1e5 0.70", "cpu": round(cpu, 2), "wall": round(w, 2),
                  "coll": pk.meta["collisions"], "events": pk.meta.get("events"), "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "load": la, "load_end": open('/proc/loadavg').read().split()[0], "digest": h}), flush=True)
