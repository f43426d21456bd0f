"""Size segregation of 3D deposits: small-sphere volume fraction against height (seed 001 §1), issue 35.

001_ad5bae0acea940c4.txt §1: "the application of the potential minimization method or ballistic
deposition to a 3D system leads to the accumulation of small particles at the bottom of the packing
as the small particles can flow in the pore space".  For bidisperse mixes (radii 0.5 and 0.5/ratio,
a fifth of the volume small, ratios 3, 5, 7, 10) and the CB (1, 1) grading at span s = 0.9 (size
ratio 10), deposit at least ``--depth`` large diameters deep on a periodic ``--width`` footprint,
in random order, with the drop-and-roll rule (``rule="roll"``, Visscher & Bolsterli 1972) and the
lowest-surface-pocket rule (``rule="surface"``), and measure the small-volume fraction in layers of
the whole deposit (:func:`polypack.analysis.small_fraction_profile`: standard errors from 3 x 3
footprint columns, slope by least squares).  Writes ``segregation_study.json`` and a figure with
seed 001's Fig. 9 (ρ against s for the six shapes, from the 2D span study's table in
docs/deposition.md, examples/span_study.py) beside the profiles.

    nice python examples/segregation_study.py --out docs/deposition_segregation.png
    nice python examples/segregation_study.py --rules roll --seeds 1,2,3 --depth 8
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

# seed 001 Fig. 9 reproduced by the 2D span study (docs/deposition.md, "The span study", floor_rule="left",
# two periodic deposits per point, 5000-60000 disks): rho against s for the six CB shapes (None: not accessible)
SPANS = [0.02, 0.05, 0.1, 0.2, 0.3, 0.42, 0.55, 0.7, 0.85, 0.97]
FIG9 = {
    (1, 1): [0.816, 0.822, 0.821, 0.823, 0.825, 0.827, 0.833, 0.839, 0.846, 0.864],
    (1, 3): [0.809, 0.820, 0.821, 0.823, 0.824, 0.826, 0.829, 0.834, 0.842, 0.852],
    (2, 4): [0.810, 0.823, 0.823, 0.823, 0.825, 0.826, 0.829, 0.835, 0.843, 0.852],
    (3, 1): [0.813, 0.820, 0.823, 0.823, 0.823, 0.826, 0.829, 0.834, 0.841, 0.848],
    (4, 2): [0.811, 0.827, 0.826, 0.824, 0.825, 0.826, 0.830, None, None, None],
    (4, 4): [0.811, 0.817, 0.821, 0.822, 0.823, 0.824, 0.827, 0.833, 0.843, None],
}


def sizes_for(case, width, depth, phi=0.6):
    """Radii (large radius 0.5) for ``case`` ("3", "5", "7", "10" bidisperse, "cb0.9"), ``depth`` d_max deep."""
    import polypack as pp

    vol = width * width * depth * phi  # solid volume needed
    if case.startswith("cb"):
        span = float(case[2:])
        m = pp.psd.CumulativeBeta(a=1, b=1, span=span, d_max=1.0, dim=3)
        base = np.asarray(pp.psd.discretize(m, n_classes=10, min_per_class=10, min_total=2000, max_total=10**6,
                                            seed=1).radii)
        k = int(np.ceil(vol / (4.0 / 3.0 * np.pi * np.sum(base**3))))
        return np.tile(base, k)
    ratio = float(case)
    v_large = 4.0 / 3.0 * np.pi * 0.125
    n_large = int(np.ceil(0.8 * vol / v_large))
    n_small = int(round(0.25 * n_large * ratio**3))
    return np.r_[np.full(n_large, 0.5), np.full(n_small, 0.5 / ratio)]


def run(cases, rules, seeds, width, depth, n_layers, time_limit):
    import polypack as pp
    from polypack.analysis import free_surface_height, small_fraction_profile

    rows = []
    for case in cases:
        radii = sizes_for(case, width, depth)
        for rule in rules:
            for seed in seeds:
                load = open("/proc/loadavg").read().split()[:3]
                t, c = time.perf_counter(), time.process_time()
                pk = pp.deposit(radii, width=width, seed=seed, dim=3, rule=rule, progress=False)
                wall, cpu = time.perf_counter() - t, time.process_time() - c
                top = free_surface_height(pk)
                pr = small_fraction_profile(pk, window=(0.0, top - 1.0), n_layers=n_layers, blocks=3)
                row = {"case": case, "rule": rule, "seed": seed, "n": pk.n, "width": width,
                       "cpu_seconds": cpu, "wall_seconds": wall, "loadavg": load, "min_gap": float(pk.min_gap()),
                       "overhang_placements": int(pk.meta.get("overhang_placements", 0)),
                       **{k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in pr.items()},
                       "surface_height": float(top)}
                rows.append(row)
                print(f"{case:6s} {rule:8s} seed {seed} N={pk.n:6d} H={top:6.2f} cpu {cpu:7.1f} s "
                      f"small fraction {np.round(pr['fraction'], 3)} slope {pr['slope']:+.4f} "
                      f"± {pr['slope_err']:.4f} ({pr['slope'] / pr['slope_err']:+.1f} se) load {' '.join(load)}",
                      flush=True)
                if cpu > time_limit:
                    print(f"  ({rule} at {case}: {cpu:.0f} CPU s, over the limit: no further seeds)")
                    break
    return rows


def plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rules = [r for r in ("roll", "surface") if any(x["rule"] == r for x in rows)]
    fig, axes = plt.subplots(1, 1 + len(rules), figsize=(4.6 * (1 + len(rules)), 4.8))
    ax = axes[0]
    for (a, b), rho in FIG9.items():
        s = [x for x, y in zip(SPANS, rho) if y is not None]
        ax.plot(s, [y for y in rho if y is not None], "-o", ms=3, label=f"a={a}, b={b}")
    ax.set_xlabel("size span s = (d_max - d_min)/(d_max + d_min) (–)")
    ax.set_ylabel("packing fraction ρ of the 2D deposit (–)")
    ax.set_title("seed 001 Fig. 9, 2D span study")
    ax.legend(fontsize=7, loc="upper left")
    cases = list(dict.fromkeys(x["case"] for x in rows))
    for k, rule in enumerate(rules):
        ax = axes[1 + k]
        for j, case in enumerate(cases):
            sel = [x for x in rows if x["case"] == case and x["rule"] == rule]
            if not sel:
                continue
            f = np.mean([x["fraction"] for x in sel], axis=0) / np.mean([x["mean"] for x in sel])
            e = np.sqrt(np.sum(np.square([x["fraction_err"] for x in sel]), axis=0)) / len(sel) / np.mean(
                [x["mean"] for x in sel])
            slope = np.mean([x["slope"] for x in sel])
            se = np.sqrt(np.sum(np.square([x["slope_err"] for x in sel]))) / len(sel)
            label = ("CB (1,1) s=" + case[2:]) if case.startswith("cb") else f"ratio {case}"
            ax.errorbar(f, np.asarray(sel[0]["height"]), xerr=e, fmt="-o", ms=3, capsize=2, color=f"C{j}",
                        label=f"{label}: slope {slope:+.3f}±{se:.3f}/d (n={len(sel)})")
        ax.axvline(1.0, color="0.6", ls="--")
        ax.set_xlim(0.0, 2.4)
        ax.set_xlabel("small-sphere volume fraction / its deposit mean (–)")
        ax.set_ylabel("height above the floor (large diameters)")
        ax.set_title(f"3D deposits, rule = {rule}")
        ax.legend(fontsize=6.5, loc="center right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", default="3,5,7,10,cb0.9")
    p.add_argument("--rules", default="roll,surface")
    p.add_argument("--seeds", default="1,2,3")
    p.add_argument("--width", type=float, default=4.5, help="footprint side in large diameters (>= 4)")
    p.add_argument("--depth", type=float, default=8.0, help="deposit depth in large diameters")
    p.add_argument("--layers", type=int, default=8)
    p.add_argument("--time-limit", type=float, default=600.0, help="CPU s per deposit beyond which seeds stop")
    p.add_argument("--json", default="segregation_study.json")
    p.add_argument("--out", default="segregation_study.png")
    p.add_argument("--plot-only", action="store_true", help="redraw the figure from --json")
    a = p.parse_args(argv)
    if a.plot_only:
        rows = json.load(open(a.json))
    else:
        rows = run(a.cases.split(","), a.rules.split(","), [int(s) for s in a.seeds.split(",")], a.width, a.depth,
                   a.layers, a.time_limit)
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    plot(rows, a.out)
    print(f"wrote {a.json}, {a.out}")


if __name__ == "__main__":
    main()
