"""Packing fraction of 2D deposits against size span, §2.4 and Fig. 9 of 001_ad5bae0acea940c4.txt.

For the six CB grading curves (a, b) = (1,1), (1,3), (2,4), (3,1), (4,2), (4,4) and size spans
s from 0.02 to 0.97, draw a representative 2D size set (N_c = 10 geometric classes, at least
10 disks per class, N_p^min disks at least, N_p^max at most: a point needing more is not
"statistically accessible", as in the seed), deposit it twice by potential minimisation
(pp.deposit, periodic in x) and measure the packing fraction in the bulk window
(pp.analysis.DepositStatistics: margin of four largest diameters from the floor and the
free surface).  Writes span_study.csv / .json, the Fig. 9 plot and the snapshots of
Figs. 10-11 (s = 0.02, 0.42, 0.97 for a = b = 1), coloured by diameter.

    python examples/span_study.py --reduced          # a few minutes
    python examples/span_study.py                    # the seed's settings (hours)
    python examples/span_study.py --min-total 10000 --spans 0.02,0.1,0.42,0.97 --workers 2
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

SHAPES = [(1, 1), (1, 3), (2, 4), (3, 1), (4, 2), (4, 4)]
SHAPE_NAMES = {
    (1, 1): "a=1, b=1 (uniform by volume)",
    (1, 3): "a=1, b=3 (rich in small disks)",
    (2, 4): "a=2, b=4 (rich in small disks)",
    (3, 1): "a=3, b=1 (uniform by size, rich in large disks)",
    (4, 2): "a=4, b=2 (rich in large disks)",
    (4, 4): "a=4, b=4 (symmetric, centred)",
}
SNAPSHOT_SPANS = (0.02, 0.42, 0.97)


def one_point(a, b, span, min_total, max_total, seed, n_rep, keep_pack=False, floor_rule="centred"):
    """Size set + ``n_rep`` depositions of one (a, b, s) point; returns a dict of results."""
    import polypack as pp
    from polypack.errors import InfeasibleError, InvalidInputError

    model = pp.psd.CumulativeBeta(a=a, b=b, span=span, d_max=1.0, dim=2)
    row = {"a": a, "b": b, "span": span}
    ss = np.random.SeedSequence([seed, a, b, int(round(span * 1000))])
    try:
        sizes = pp.psd.discretize(model, n_classes=10, spacing="geometric", min_per_class=10,
                                  min_total=min_total, max_total=max_total, seed=ss.spawn(1)[0])
    except InfeasibleError as exc:
        row.update(accessible=False, note=str(exc)[:120])
        return row, None
    rhos, zs, shares, t = [], [], [], time.perf_counter()
    packs = []
    for child in ss.spawn(n_rep):
        pk = pp.deposit(sizes, boundary="periodic", seed=child, progress=False, floor_rule=floor_rule)
        try:
            st = pp.analysis.DepositStatistics().compute(pk)
        except InvalidInputError:
            continue
        rhos.append(st.packing_fraction)
        zs.append(st.coordination)
        shares.append(st.contact_shares)
        if keep_pack and not packs:
            packs.append(pk)
    row.update(accessible=True, n=int(sizes.n), n_measured=len(rhos), seconds=time.perf_counter() - t)
    if rhos:
        row.update(
            rho=float(np.mean(rhos)),
            rho_err=float(np.std(rhos, ddof=1) / np.sqrt(len(rhos))) if len(rhos) > 1 else float("nan"),
            coordination=float(np.mean(zs)),
            share3=float(np.mean([s.get(3, 0.0) for s in shares])),
            share4=float(np.mean([s.get(4, 0.0) for s in shares])),
            share5=float(np.mean([s.get(5, 0.0) for s in shares])),
        )
    return row, (packs[0] if packs else None)


def plot_fig9(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    markers = "osD^v<"
    for (a, b), mk in zip(SHAPES, markers):
        pts = sorted((r["span"], r["rho"], r.get("rho_err", np.nan)) for r in rows
                     if r["a"] == a and r["b"] == b and "rho" in r)
        if not pts:
            continue
        s, rho, err = map(np.array, zip(*pts))
        ax.errorbar(s, rho, yerr=np.nan_to_num(err), marker=mk, ms=4, capsize=2, lw=1, label=SHAPE_NAMES[(a, b)])
    ax.axhline(np.pi / (2 * np.sqrt(3)), color="0.5", ls=":", lw=1, label="triangular crystal π/(2√3) = 0.907")
    ax.axvline(np.sqrt(2) - 1, color="0.7", ls="--", lw=1,
               label="s = √2 − 1 = 0.41: smallest disks fit the square-lattice pore")
    ax.set_xlabel("size span s = (d_max − d_min)/(d_max + d_min)  (–)")
    ax.set_ylabel("packing fraction ρ in the bulk window  (–)")
    ax.set_title("2D deposition by potential minimisation (seed 001, Fig. 9)")
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)


def plot_snapshot(pk, span, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import EllipseCollection

    pos, d = pk.positions, 2 * pk.radii
    fig, ax = plt.subplots(figsize=(6, 6 * min(2.0, pk.box[1] / pk.box[0])))
    coll = EllipseCollection(d, d, np.zeros_like(d), offsets=pos, units="xy", offset_transform=ax.transData,
                             cmap="viridis", edgecolors="k", linewidths=0.1)
    coll.set_array(d)
    ax.add_collection(coll)
    ax.set_xlim(0, pk.box[0])
    ax.set_ylim(0, pk.box[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (units of d_max)")
    ax.set_ylabel("height y (units of d_max)")
    ax.set_title(f"deposit, a = b = 1, s = {span:g}, N = {pk.n}")
    fig.colorbar(coll, ax=ax, label="disk diameter d (units of d_max)", shrink=0.8)
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--reduced", action="store_true", help="few spans, small packs (a few minutes)")
    p.add_argument("--spans", default=None, help="comma-separated spans (default: 0.02..0.97, 20 values)")
    p.add_argument("--min-total", type=int, default=25000, help="N_p^min (seed: 2.5e4)")
    p.add_argument("--max-total", type=int, default=100000, help="N_p^max (seed: 1e5)")
    p.add_argument("--repeats", type=int, default=2, help="depositions per point (seed: 2)")
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--seed", type=int, default=2007)
    p.add_argument("--out", default="span_study_out")
    p.add_argument("--floor-rule", default="centred", choices=("centred", "left"),
                   help="bare-floor rule of pp.deposit (centred: LMGC90's, the default; docs/deposition.md)")
    args = p.parse_args(argv)
    if args.reduced:
        spans = [0.02, 0.2, 0.42, 0.7, 0.97]
        args.min_total, args.max_total = 2000, 20000
    elif args.spans:
        spans = [float(v) for v in args.spans.split(",")]
    else:
        spans = list(np.round(np.linspace(0.02, 0.97, 20), 3))
    os.makedirs(args.out, exist_ok=True)
    jobs = [(a, b, s) for (a, b) in SHAPES for s in spans]
    rows, snaps = [], {}
    t0 = time.perf_counter()
    pool = ProcessPoolExecutor(args.workers) if args.workers > 1 else None
    try:
        futs = []
        for a, b, s in jobs:
            keep = (a, b) == (1, 1) and any(abs(s - v) < 1e-9 for v in SNAPSHOT_SPANS)
            call = (one_point, a, b, s, args.min_total, args.max_total, args.seed, args.repeats, keep, args.floor_rule)
            futs.append(pool.submit(*call) if pool else call)
        for f in futs:
            row, pk = f.result() if pool else f[0](*f[1:])
            rows.append(row)
            if pk is not None:
                snaps[row["span"]] = pk
            print(json.dumps({k: (round(v, 4) if isinstance(v, float) else v) for k, v in row.items() if k != "note"}),
                  flush=True)
    finally:
        if pool:
            pool.shutdown(cancel_futures=True)
    keys = ["a", "b", "span", "accessible", "n", "n_measured", "rho", "rho_err", "coordination",
            "share3", "share4", "share5", "seconds"]
    with open(os.path.join(args.out, "span_study.csv.tmp"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    os.replace(os.path.join(args.out, "span_study.csv.tmp"), os.path.join(args.out, "span_study.csv"))
    with open(os.path.join(args.out, "span_study.json.tmp"), "w") as fh:
        json.dump({"settings": vars(args), "spans": spans, "rows": rows}, fh, indent=1)
    os.replace(os.path.join(args.out, "span_study.json.tmp"), os.path.join(args.out, "span_study.json"))
    plot_fig9(rows, os.path.join(args.out, "fig9_packing_fraction_vs_span.png"))
    for s, pk in snaps.items():
        plot_snapshot(pk, s, os.path.join(args.out, f"snapshot_a1_b1_s{s:g}.png"))
    print(f"done in {time.perf_counter() - t0:.0f} s; outputs in {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
