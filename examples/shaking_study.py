"""What shaking does to a CRM pack: a reproducible version of §5.1 and Figs. 1, 2, 4 of
000_2cedc098acbd866b.txt (Buryachenko et al., random bimodal structures, part I).

For c = 0.575, 0.6, 0.63 and P realizations of N = 2000 equal spheres it builds

* CRM: Lubachevsky–Stillinger growth (``polypack.pack``, §3.1);
* CRM + shaking: the CRM pack shaken with the seed's parameters (R_sh = 0.02, N_sh = 150,
  M = 60 global shakes, ``polypack.shake(method="paper")``);
* SCRM: growth interleaved with shaking, then M = 60 global shakes (``polypack.scrm``),

and writes

* ``fig1_rdf_contact.png``: g(r) for 2 < r/a < 2.2 at c = 0.575 (Fig. 1), with the
  Percus–Yevick and Willis (Eqs. (11)–(13)) curves;
* ``fig2_rdf_far.png``: g(r) for 2.5 < r/a < 4.5 at c = 0.575 (Fig. 2);
* ``fig4_window_counts.png``: p(n_h), R_h = 2.5, at c = 0.6 (Fig. 4), including a rapidly
  grown (locked) CRM pack where the narrowing is clearest;
* ``contact_peak_vs_c.png``: the drop of g(2a+) by shaking against c, next to the seed's
  43 %, 21 %, 4 %;
* ``convergence.png``: g(2a+) against the number of global shakes (the seed: 12 % change
  between M = 3 and 60, under 0.2 % between 30 and 60 for its bimodal packs);
* ``summary.json``: every number plotted.

g(2a+) is the seed's estimator: the histogram g in [2a, 2a + Δr) with Δr = 0.01a (§5.1),
i.e. ``polypack.analysis.contact_value(pk, width=0.005, n_bins=1, degree=0)``.

Usage: ``python examples/shaking_study.py [--realizations 3] [--n 2000] [--out shaking_study_output]``
(about 2 minutes with the defaults on one core).
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import polypack as pp  # noqa: E402
from polypack.analysis import RDF, WindowCounts, contact_value  # noqa: E402

FRACTIONS = (0.575, 0.6, 0.63)
SEED_REDUCTION = {0.575: 0.43, 0.6: 0.21, 0.63: 0.04}  # §5.1 of 000_2cedc098acbd866b.txt
SHAKE = dict(global_shakes=60, shake_radius=0.02, max_trials=150, method="paper")


SEED_ESTIMATOR = {"width": 0.005, "n_bins": 1, "degree": 0}


def g_contact(pk):
    """The seed's g(2a+): histogram g in [2a, 2.01a)."""
    return contact_value(pk, **SEED_ESTIMATOR)[(0, 0)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--realizations", type=int, default=3, help="P realizations per fraction")
    ap.add_argument("--n", type=int, default=2000, help="spheres per pack")
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--out", default="shaking_study_output")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    radii = np.ones(args.n)  # a = 1: r/a = r
    root = np.random.SeedSequence(args.seed)
    seeds = {c: s.spawn(args.realizations) for c, s in zip(FRACTIONS, root.spawn(len(FRACTIONS)))}

    protocols = ("CRM", "CRM + shaking", "SCRM")
    rdf = {c: {p: RDF(r_max=4.6, dr=0.01) for p in protocols} for c in FRACTIONS}
    windows = {p: WindowCounts(window_radius=2.5) for p in protocols}
    gc = {c: {p: [] for p in protocols} for c in FRACTIONS}
    conv = []
    t_start = time.perf_counter()
    for c in FRACTIONS:
        for r, ss in enumerate(seeds[c]):
            s_pack, s_shake, s_scrm = ss.spawn(3)
            t0 = time.perf_counter()
            crm = pp.pack(radii, volume_fraction=c, seed=s_pack)
            # convergence monitor with the seed's estimator, every 3 global shakes
            monitor = dict(monitor=pp.analysis.ContactValueMonitor(**SEED_ESTIMATOR), monitor_every=3) \
                if (c == 0.575 and r == 0) else {}
            shaken = pp.shake(crm, seed=s_shake, **monitor, **SHAKE)
            if c == 0.575 and r == 0:
                mon = shaken.meta["shake"]["monitor"]
                conv = list(zip(mon["global_shake"], mon["contact_value"]["0-0"]))
            scrm = pp.scrm(radii, volume_fraction=c, seed=s_scrm, global_shakes=60,
                           shake_radius=0.02, max_trials=150)
            for name, pk in zip(protocols, (crm, shaken, scrm)):
                rdf[c][name].compute(pk, reset=False)
                gc[c][name].append(g_contact(pk))
                if c == 0.6:
                    windows[name].compute(pk, reset=False)
            print(f"c={c} realization {r}: g(2a+) CRM {gc[c]['CRM'][-1]:.2f}, shaken {gc[c]['CRM + shaking'][-1]:.2f}, "
                  f"SCRM {gc[c]['SCRM'][-1]:.2f}  ({time.perf_counter() - t0:.1f} s)", flush=True)

    # a rapidly grown (locked) CRM pack for Fig. 4
    fast = pp.pack(radii, volume_fraction=0.6, seed=root.spawn(1)[0], growth_rate=1.0)
    fast_shaken = pp.shake(fast, seed=3, **SHAKE)
    w_fast = {"CRM (fast growth)": WindowCounts(window_radius=2.5).compute(fast),
              "CRM (fast) + shaking": WindowCounts(window_radius=2.5).compute(fast_shaken)}

    summary = {"n": args.n, "realizations": args.realizations, "seed": args.seed, "shake": SHAKE,
               "contact_peak": {}, "window_variance": {}, "convergence": conv}
    for c in FRACTIONS:
        m = {p: float(np.mean(v)) for p, v in gc[c].items()}
        summary["contact_peak"][str(c)] = {
            **{p: {"mean": m[p], "values": gc[c][p]} for p in protocols},
            "reduction_shaking": 1.0 - m["CRM + shaking"] / m["CRM"],
            "reduction_scrm": 1.0 - m["SCRM"] / m["CRM"],
            "reduction_seed": SEED_REDUCTION[c],
        }
    for name, w in {**windows, **w_fast}.items():
        summary["window_variance"][name] = {"mean": w.mean, "variance": w.variance}

    theory = pp.analysis.theory
    styles = {"CRM": dict(color="C3", lw=1.2), "CRM + shaking": dict(color="C0", lw=1.2),
              "SCRM": dict(color="C2", lw=1.2, ls="--")}
    c = 0.575
    for fname, lo, hi in (("fig1_rdf_contact.png", 2.0, 2.2), ("fig2_rdf_far.png", 2.5, 4.5)):
        fig, ax = plt.subplots(figsize=(5.5, 4))
        for p in protocols:
            sel = (rdf[c][p].r > lo) & (rdf[c][p].r < hi)
            ax.plot(rdf[c][p].r[sel], rdf[c][p].g[sel], label=f"{p} (P={args.realizations})", **styles[p])
        rr = np.linspace(lo + 1e-6, hi, 400)
        ax.plot(rr, theory.willis(rr, 1.0, c), color="0.5", lw=1, label="Willis, Eqs. (11)-(13)")
        ax.plot(rr, theory.percus_yevick_rdf(rr, 1.0, c), color="k", lw=1, ls=":", label="Percus-Yevick")
        ax.set_xlabel("r / a")
        ax.set_ylabel("g(r)")
        ax.set_title(f"c = {c}, N = {args.n}")
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(os.path.join(args.out, fname), dpi=130)
        plt.close(fig)

    fig, ax = plt.subplots(figsize=(5.5, 4))
    for name, w in {**windows, **w_fast}.items():
        ax.plot(w.n_h, w.p, marker="o", ms=3, lw=1, label=f"{name} (var {w.variance:.2f})")
    ax.set_xlabel("$n_h$ (centres within 2.5a)")
    ax.set_ylabel("$p(n_h)$")
    ax.set_title("c = 0.6, Fig. 4 of seed 000")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "fig4_window_counts.png"), dpi=130)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(5.5, 4))
    x = np.arange(len(FRACTIONS))
    ours = [summary["contact_peak"][str(c)]["reduction_shaking"] * 100 for c in FRACTIONS]
    ours_scrm = [summary["contact_peak"][str(c)]["reduction_scrm"] * 100 for c in FRACTIONS]
    seed = [SEED_REDUCTION[c] * 100 for c in FRACTIONS]
    ax.bar(x - 0.27, seed, 0.27, label="seed 000 (SCRM vs CRM)", color="0.6")
    ax.bar(x, ours, 0.27, label="polypack: CRM + 60 shakes", color="C0")
    ax.bar(x + 0.27, ours_scrm, 0.27, label="polypack: SCRM", color="C2")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xticks(x, [str(c) for c in FRACTIONS])
    ax.set_xlabel("volume fraction c")
    ax.set_ylabel("reduction of g(2a+) relative to CRM [%]")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "contact_peak_vs_c.png"), dpi=130)
    plt.close(fig)

    if conv:
        fig, ax = plt.subplots(figsize=(5.5, 4))
        ms, gs = zip(*conv)
        ax.plot(ms, gs, marker="o", ms=3)
        ax.set_xlabel("global shakes M")
        ax.set_ylabel("g(2a+)")
        ax.set_title("c = 0.575, one realization")
        fig.tight_layout()
        fig.savefig(os.path.join(args.out, "convergence.png"), dpi=130)
        plt.close(fig)
        g = dict(conv)
        summary["convergence_change"] = {"M3_to_60": g[60] / g[3] - 1.0, "M30_to_60": g[60] / g[30] - 1.0}

    summary["wall_time"] = time.perf_counter() - t_start
    with open(os.path.join(args.out, "summary.json"), "w") as fh:
        json.dump(summary, fh, indent=2)
    print("\nreduction of g(2a+) relative to CRM (seed 000: 43 %, 21 %, 4 %):")
    for c in FRACTIONS:
        d = summary["contact_peak"][str(c)]
        print(f"  c = {c}: CRM + shaking {100 * d['reduction_shaking']:5.1f} %, SCRM {100 * d['reduction_scrm']:5.1f} %")
    print("window-count variance at c = 0.6: " + ", ".join(
        f"{k} {v['variance']:.3f}" for k, v in summary["window_variance"].items()))
    if "convergence_change" in summary:
        cc = summary["convergence_change"]
        print(f"g(2a+) change M=3->60 {100 * cc['M3_to_60']:+.1f} %, M=30->60 {100 * cc['M30_to_60']:+.1f} %")
    print(f"wrote figures and summary.json to {args.out} ({summary['wall_time']:.0f} s)")


if __name__ == "__main__":
    main()
