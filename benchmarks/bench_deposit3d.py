"""Speed of 3D deposition (pp.deposit(..., dim=3)) for 1e5 spheres; target: under ten minutes.

No PyPI package implements potential-minimisation deposition of spheres, so there is no
peer to run back to back; the script prints the wall time per sphere, the number of alive
(searchable) surface spheres that sets the cost per sphere, the bulk packing fraction and
coordination, and writes JSON.  Run it with ``nice`` on a shared machine.

    nice python benchmarks/bench_deposit3d.py [N] [WIDTH] [CASES]

CASES is a comma-separated subset of ``equal,narrow,wide`` (default: all).  Both the wall
time and the CPU time of the process (``time.process_time``) are printed: on a shared
machine the CPU time is the figure to compare with the ten-minute target.

Size-ratio sweep (issue 35: the cost per sphere must not grow with the size ratio)::

    nice python benchmarks/bench_deposit3d.py ratios N WIDTH RULE [RATIOS]

bidisperse radii 0.5 and 0.5/ratio with a fifth of the volume small, random order, for
``RULE`` ``surface`` or ``roll``, against the narrow PSD (uniform 0.45-0.55) with the same
rule; prints CPU ms per sphere and the load average, writes bench_deposit3d_ratios.json.
"""

import json
import sys
import time

import numpy as np

import polypack as pp


def bulk(pk, margin=3.0):
    z = pk.positions[:, 2]
    a, b = margin, z.max() - margin - 1.0
    lo = np.clip(a - z, -pk.radii, pk.radii)
    hi = np.clip(b - z, -pk.radii, pk.radii)
    vol = np.pi * (pk.radii**2 * (hi - lo) - (hi**3 - lo**3) / 3)
    phi = vol.sum() / (pk.box[0] * pk.box[1] * (b - a))
    c = pp.analysis.Contacts(tolerance=1e-7).compute(pk)
    win = (z > a) & (z < b)
    return float(phi), float(np.mean(np.asarray(c.per_sphere)[win]))


def main(n=100_000, width=20.0, cases="equal,narrow,wide"):
    pp.deposit(np.full(50, 0.5), width=5.0, seed=0, dim=3)  # compile outside the timing
    pp.deposit(np.random.default_rng(0).uniform(0.4, 0.5, 50), width=5.0, seed=0, dim=3)
    rng = np.random.default_rng(1)
    rows = []
    table = {"equal": ("equal spheres", np.full(n, 0.5)),
             "narrow": ("uniform radii 0.45-0.55", rng.uniform(0.45, 0.55, n)),
             "wide": ("uniform radii 0.35-0.65", rng.uniform(0.35, 0.65, n))}
    for key in cases.split(","):
        label, radii = table[key]
        t = time.perf_counter()
        c = time.process_time()
        pk = pp.deposit(radii, width=width, seed=2, dim=3)
        dt = time.perf_counter() - t
        cpu = time.process_time() - c
        phi, z = bulk(pk)
        row = {"case": label, "n": pk.n, "width": width, "seconds": dt, "cpu_seconds": cpu,
               "ms_per_sphere": 1e3 * dt / pk.n, "cpu_ms_per_sphere": 1e3 * cpu / pk.n,
               "candidate_searches": pk.meta["candidate_searches"],
               "alive_max": pk.meta["alive_max"], "overhang_placements": pk.meta["overhang_placements"],
               "bulk_fraction": phi, "bulk_coordination": z}
        rows.append(row)
        print(f"{label:26s} N={pk.n:7d} wall {dt:8.1f} s cpu {cpu:8.1f} s ({1e3 * cpu / pk.n:6.2f} ms/sphere) "
              f"alive<={pk.meta['alive_max']} "
              f"phi={phi:.4f} z={z:.3f}", flush=True)
    with open("bench_deposit3d.json", "w") as fh:
        json.dump(rows, fh, indent=1)


def bidisperse(ratio, n, small_volume=0.2):
    """``n`` spheres of radii 0.5 and 0.5 / ratio with the small ones holding ``small_volume`` of the volume."""
    q = small_volume / (1.0 - small_volume) * ratio**3  # small spheres per large one
    n_large = max(1, int(round(n / (1.0 + q))))
    return np.r_[np.full(n_large, 0.5), np.full(n - n_large, 0.5 / ratio)]


def ratios(n=20000, width=8.0, rule="roll", which="3,5,7,10"):
    pp.deposit(np.full(50, 0.5), width=5.0, seed=0, dim=3, rule=rule, progress=False)  # compile
    pp.deposit(bidisperse(3, 300), width=5.0, seed=0, dim=3, rule=rule, progress=False)
    rows = []
    rng = np.random.default_rng(1)
    cases = [("narrow 0.45-0.55", rng.uniform(0.45, 0.55, n))]
    cases += [(f"ratio {r}", bidisperse(float(r), n)) for r in which.split(",")]
    for label, radii in cases:
        load = open("/proc/loadavg").read().split()[:3]
        t = time.perf_counter()
        c = time.process_time()
        pk = pp.deposit(radii, width=width, seed=2, dim=3, rule=rule, progress=False)
        dt = time.perf_counter() - t
        cpu = time.process_time() - c
        row = {"case": label, "rule": rule, "n": pk.n, "width": width, "seconds": dt, "cpu_seconds": cpu,
               "cpu_ms_per_sphere": 1e3 * cpu / pk.n, "height": float(pk.box[2]), "loadavg": load,
               "min_gap": float(pk.min_gap())}
        rows.append(row)
        print(f"{rule:8s} {label:18s} N={pk.n:7d} H={pk.box[2]:7.2f} wall {dt:8.1f} s cpu {cpu:8.1f} s "
              f"({1e3 * cpu / pk.n:7.3f} ms/sphere) load {' '.join(load)}", flush=True)
    with open("bench_deposit3d_ratios.json", "w") as fh:
        json.dump(rows, fh, indent=1)


if __name__ == "__main__" and len(sys.argv) > 1 and sys.argv[1] == "ratios":
    ratios(int(sys.argv[2]) if len(sys.argv) > 2 else 20000, float(sys.argv[3]) if len(sys.argv) > 3 else 8.0,
           sys.argv[4] if len(sys.argv) > 4 else "roll", sys.argv[5] if len(sys.argv) > 5 else "3,5,7,10")
elif __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100_000, float(sys.argv[2]) if len(sys.argv) > 2 else 20.0,
         sys.argv[3] if len(sys.argv) > 3 else "equal,narrow,wide")
