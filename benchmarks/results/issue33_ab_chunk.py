"""Issue 33: CPU seconds of two versions of _kernels/edmd.py on the same chunk, in one process.

    python benchmarks/results/issue33_ab_chunk.py A/src B/src N K REPS [phi]

Tree A's package is copied to a temporary folder with B's edmd.py beside its own (``edmd_b``;
the rest of the package, cells.py included, is A's).  A pack of N equal spheres (seed 2, to phi,
default 0.62) runs with A, the arguments of A's K-th ``run_chunk`` call are kept, and that chunk
(20 N collisions, a global rebuild at its start) is run REPS times by each version, alternately
(A B, B A, ...), each from a fresh copy.  The results of every run must be equal bit for bit.
Both versions see the same machine within seconds, so the per-run ratio B/A is much steadier
than separate processes on a shared machine (their CPU seconds move by 10-20 % with the load).
"""
import hashlib, importlib, os, shutil, sys, tempfile, time
A, B, N, K, R = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
phi = float(sys.argv[6]) if len(sys.argv) > 6 else 0.62
work = tempfile.mkdtemp(prefix="ab")
shutil.copytree(os.path.join(A, "polypack"), os.path.join(work, "polypack"))
shutil.copy(os.path.join(B, "polypack/_kernels/edmd.py"), os.path.join(work, "polypack/_kernels/edmd_b.py"))
os.environ["NUMBA_CACHE_DIR"] = os.path.join(tempfile.gettempdir(), "polypack_ab_cache", 
                                         hashlib.sha1(open(os.path.join(A, "polypack/_kernels/edmd.py"), "rb").read()
                                                      + open(os.path.join(B, "polypack/_kernels/edmd.py"), "rb").read()).hexdigest()[:12])
sys.path.insert(0, work)
import numpy as np
import polypack as pp
from polypack._kernels import edmd as ea
eb = importlib.import_module("polypack._kernels.edmd_b")
ea.warmup(); eb.warmup()
orig = ea.run_chunk
captured = []
calls = [0]
def spy(x, v, g, box, state, params, hist):
    calls[0] += 1
    if calls[0] == K:
        captured.append([a.copy() for a in (x, v, g, box, state, params, hist)])
    return orig(x, v, g, box, state, params, hist)
ea.run_chunk = spy
pk = pp.pack(np.ones(N), phi, seed=2, growth_rate=0.02, progress=False)
ea.run_chunk = orig
print("calls", calls[0], "captured", len(captured), "state", captured[0][4][:3], flush=True)
ta, tb = [], []
ref = None
for r in range(R):
    for name, mod, acc in (("A", ea, ta), ("B", eb, tb)) if r % 2 == 0 else (("B", eb, tb), ("A", ea, ta)):
        args = [a.copy() for a in captured[0]]
        c0 = time.process_time()
        out = mod.run_chunk(*args)
        acc.append(time.process_time() - c0)
        sig = (args[0].tobytes(), args[4].tobytes())
        if ref is None:
            ref = sig
        assert sig == ref, "results differ"
    print(f"rep {r}: A {ta[-1]:.3f} B {tb[-1]:.3f} ratio {tb[-1]/ta[-1]:.3f} load {open('/proc/loadavg').read().split()[0]}", flush=True)
ta, tb = np.array(ta), np.array(tb)
print(f"A median {np.median(ta):.3f} min {ta.min():.3f} | B median {np.median(tb):.3f} min {tb.min():.3f} | median ratio B/A {np.median(tb/ta):.3f} (per-rep ratios {np.round(tb/ta,3).tolist()})")
