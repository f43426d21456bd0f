"""Benchmark polypack.analysis against freud-analysis on the same input.

1. Total and all partial RDFs of a bimodal pack (size ratio 0.313, volume ratio
   0.333 as in seed 000, volume fraction 0.6) with N = 10^5, r_max = 3 mean
   diameters: polypack computes everything in one pass, freud needs one call per
   species pair plus one for the total.
2. Pore sizes from 10^6 test points in a pack of 10^5 spheres with diameter ratio 10
   (no peer: target < 5 s).

The inputs are random centres with the pack's radii and number density (the cost of
a pair histogram or a nearest-surface search depends on the density, not on
overlaps), so the benchmark does not depend on the packer.
Numbers measured while other jobs load the machine are noisy.

Usage: ``python benchmarks/bench_analysis.py [--n 100000] [--repeat 2]``
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

import numpy as np

import polypack as pp


def bimodal_pack(n, seed=1, phi=0.6, size_ratio=0.313, volume_ratio=0.333):
    rng = np.random.default_rng(seed)
    frac_small = 1.0 / (1.0 + size_ratio**3 / volume_ratio)  # number fraction of small spheres
    small = rng.random(n) < frac_small
    rad = np.where(small, 0.5 * size_ratio, 0.5)
    species = small.astype(int)
    # random centres at the pack's number density: the cost of a pair histogram
    # depends on the number of pairs within r_max, not on the overlaps
    L = (4 / 3 * np.pi * np.sum(rad**3) / phi) ** (1 / 3)
    return pp.Packing(rng.random((n, 3)) * L, rad, L, species=species), "random centres"


def wide_pack(n, seed=2, phi=0.5, ratio=10.0):
    """Radii log-uniform over a diameter ratio of 10, random centres."""
    rng = np.random.default_rng(seed)
    rad = 0.5 * np.exp(rng.uniform(np.log(1 / ratio), 0.0, n))
    L = (4 / 3 * np.pi * np.sum(rad**3) / phi) ** (1 / 3)
    return pp.Packing(rng.random((n, 3)) * L, rad, L)


def best_of(fn, repeat):
    ts = []
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t)
    return min(ts), out


def bench_rdf(n, repeat):
    import freud

    pk, how = bimodal_pack(n)
    d_mean = float(np.mean(2 * pk.radii))
    r_max = 3.0 * d_mean
    dr = 0.01 * d_mean
    bins = int(round(r_max / dr))
    r_max = bins * dr
    # warm-up (numba compile or cache load) outside the timing
    pp.analysis.RDF(r_max=r_max, bins=bins).compute(pk.replace(positions=pk.positions[:2000] * 1.0,
                                                                radii=pk.radii[:2000],
                                                                species=pk.species[:2000]))

    def ours():
        return pp.analysis.RDF(r_max=r_max, bins=bins, normalization="seed").compute(pk)

    L = float(pk.box[0])
    fbox = freud.box.Box.cube(L)
    P = (pk.positions - L / 2).astype(np.float32)
    groups = [P[pk.species == k] for k in range(2)]

    def theirs():
        out = {"total": freud.density.RDF(bins, r_max).compute((fbox, P)).rdf.copy()}
        for k in range(2):
            for m in range(k, 2):
                f = freud.density.RDF(bins, r_max)
                if k == m:
                    f.compute((fbox, groups[k]))
                else:
                    f.compute((fbox, groups[m]), query_points=groups[k])
                out[(k, m)] = f.rdf.copy()
        return out

    t_ours, g = best_of(ours, repeat)
    t_freud, f = best_of(theirs, repeat)
    diff = max(float(np.max(np.abs(g.g - f["total"]))),
               *(float(np.max(np.abs(g.partial[key] - f[key]))) for key in [(0, 0), (0, 1), (1, 1)]))
    return {
        "case": "RDF total + 3 partials, bimodal",
        "input": how,
        "n": n,
        "n_large": int(np.sum(pk.species == 0)),
        "r_max": r_max,
        "bins": bins,
        "polypack_s": t_ours,
        "freud_s": t_freud,
        "speedup": t_freud / t_ours,
        "max_abs_diff_g": diff,
    }


def bench_pores(n, n_points, repeat):
    pk = wide_pack(n)
    pp.analysis.PoreSizes(n_points=1000, seed=0).compute(pk)  # compile / cache load

    def ours():
        return pp.analysis.PoreSizes(n_points=n_points, seed=1).compute(pk)

    t, p = best_of(ours, repeat)
    return {
        "case": "pore sizes, diameter ratio 10",
        "n": n,
        "n_points": n_points,
        "polypack_s": t,
        "target_s": 5.0,
        "void_fraction_estimate": float(p.void_fraction),
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--skip-pores", action="store_true")
    args = ap.parse_args()
    rows = [bench_rdf(args.n, args.repeat)]
    if not args.skip_pores:
        rows.append(bench_pores(args.n, args.points, args.repeat))
    print(f"{'case':<36s} {'N':>8s} {'polypack s':>11s} {'peer s':>9s} {'ratio':>7s}")
    for r in rows:
        peer = r.get("freud_s")
        ratio = r.get("speedup")
        print(
            f"{r['case']:<36s} {r['n']:>8d} {r['polypack_s']:>11.3f} "
            f"{(f'{peer:.3f}' if peer else '-'):>9s} {(f'{ratio:.1f}x' if ratio else '-'):>7s}"
        )
    os.makedirs(os.path.join(os.path.dirname(__file__), "results"), exist_ok=True)
    out = os.path.join(os.path.dirname(__file__), "results", "bench_analysis.json")
    meta = {"machine": platform.platform(), "cpus": os.cpu_count(), "note": "noisy if other jobs run"}
    with open(out, "w") as fh:
        json.dump({"meta": meta, "rows": rows}, fh, indent=2)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
