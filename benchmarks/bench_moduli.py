"""Benchmark of the three-point parameters ζ2, η2 (polypack.analysis.ThreePointParameters).

Targets (issue 18): ζ2/η2 for N = 2000 in < 30 s and N = 2×10^4 in < 5 min on one core
and the MEFM from a measured g_km in < 1 s, for
dense packs (volume fraction 0.6): monodisperse and seed 000's bimodal mix (size ratio
0.313, volume ratio 0.333). No package on PyPI computes ζ2/η2 from a sphere pack, so
there is no peer to run back to back; the script reports wall times against the
targets, the cutoff and neighbours per sphere, and the first (compile) call apart.
Numbers measured while other jobs load the machine are noisy.

Usage: ``python benchmarks/bench_moduli.py [--sizes 2000 20000] [--out bench_moduli.json]``
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

import numpy as np

import polypack as pp

TARGETS = {2000: 30.0, 20000: 300.0}


def packs(n, seed=1):
    mono = pp.pack(np.full(n, 1.0), volume_fraction=0.6, seed=seed)
    sizes = pp.psd.Bimodal(size_ratio=0.313, volume_ratio=0.333, d_large=2.0).sample(n=n, seed=seed)
    bi = pp.pack(sizes, volume_fraction=0.6, seed=seed)
    return {"monodisperse": mono, "bimodal (seed 000)": bi}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[2000, 20000])
    ap.add_argument("--out", default="bench_moduli.json")
    args = ap.parse_args()
    t0 = time.perf_counter()
    small = pp.pack(np.full(50, 1.0), volume_fraction=0.3, seed=0)
    pp.analysis.ThreePointParameters(cutoff=3.0).compute(small)
    compile_s = time.perf_counter() - t0
    rows = []
    for n in args.sizes:
        for name, pk in packs(n).items():
            tp = pp.analysis.ThreePointParameters()
            t = time.perf_counter()
            tp.compute(pk)
            dt = time.perf_counter() - t
            fr = tp._frames[0]
            target = TARGETS.get(n)
            rows.append(
                dict(n=n, pack=name, seconds=dt, target_s=target, zeta2=tp.zeta2, eta2=tp.eta2,
                     cutoff=float(fr["cutoff"]), neighbours=float(fr["mean_neighbours"]),
                     phi=pk.volume_fraction)
            )
            ok = "" if target is None else ("  (target %.0f s: %s)" % (target, "met" if dt < target else "MISSED"))
            print(f"N={n:6d} {name:20s} {dt:7.1f} s  zeta2={tp.zeta2:.4f} eta2={tp.eta2:.4f} "
                  f"cutoff={fr['cutoff']:.2f} neighbours/sphere={fr['mean_neighbours']:.0f}{ok}", flush=True)
            # MEFM from the measured partial RDFs (target < 1 s), glass in epoxy
            m, f = pp.mechanics.Phase.from_young(3.01e9, 0.394), pp.mechanics.Phase.from_young(76e9, 0.23)
            t = time.perf_counter()
            e = pp.mechanics.mefm(m, [f] * pk.n_species, pk)
            dt_m = time.perf_counter() - t
            rows[-1]["mefm_seconds"] = dt_m
            print(f"          MEFM from the pack's partial RDFs: {dt_m:.2f} s (target 1 s), E*/E0 = {e.young / m.young:.4f}",
                  flush=True)
    out = dict(compile_seconds=compile_s, rows=rows, machine=platform.platform(), cpus=os.cpu_count(),
               note="shared machine; no PyPI peer computes zeta2/eta2")
    with open(args.out, "w") as fh:
        json.dump(out, fh, indent=1)
    print(f"compile {compile_s:.1f} s; wrote {args.out}")


if __name__ == "__main__":
    main()
