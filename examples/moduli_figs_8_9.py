"""Effective moduli from CRM and SCRM packs, in the style of Figs. 8-9 of seed 000.

Glass beads in epoxy (E0 = 3.01 GPa, ν0 = 0.394; E1 = 76 GPa, ν1 = 0.23; Smith 1976's
system of Fig. 8) with equal spheres, and AP in HTPB (binder 1.8 MPa, ν = 0.4995;
AP 32.4 GPa, ν = 0.143) with seed 000's bimodal sizes (λ = 0.313, ξ = 0.333). For
each volume fraction, ``--realizations`` CRM packs (``pp.pack``) and the same packs
shaken (SCRM, ``pp.shake``); the MEFM uses each pack's measured partial RDFs, the
three-point bounds each pack's ζ2 and η2. Error bars: standard errors over the
realizations.

Usage: ``python examples/moduli_figs_8_9.py [--n 1000] [--realizations 4] [--shakes 10]
[--system glass-epoxy|ap-htpb] [--out examples/output]``
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import polypack as pp
from polypack._cli.moduli_commands import moduli_of_pack, plot_figs_8_9, summarize
from polypack.mechanics import Phase, mefm

SYSTEMS = {
    "glass-epoxy": (Phase.from_young(3.01e9, 0.394), Phase.from_young(76e9, 0.23), "glass beads in epoxy"),
    "ap-htpb": (Phase.from_young(1.8e6, 0.4995), Phase.from_young(32.4e9, 0.143), "AP in HTPB"),
}


def sizes_for(system, n, seed):
    if system == "glass-epoxy":
        return np.full(n, 1.0)
    return pp.psd.Bimodal(size_ratio=0.313, volume_ratio=0.333, d_large=2.0).sample(n=n, seed=seed)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--system", default="glass-epoxy", choices=sorted(SYSTEMS))
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--realizations", type=int, default=4)
    ap.add_argument("--shakes", type=int, default=10)
    ap.add_argument("--fractions", type=float, nargs="+", default=[0.3, 0.4, 0.5, 0.6])
    ap.add_argument("--out", default="examples/output")
    args = ap.parse_args()
    matrix, inclusion, title = SYSTEMS[args.system]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    curves = {"CRM": [], "SCRM": []}
    diffs = {}
    t0 = time.time()
    for c in args.fractions:
        rows = {"CRM": [], "SCRM": []}
        for p in range(args.realizations):
            seed = 1000 * int(round(100 * c)) + p
            sizes = sizes_for(args.system, args.n, seed)
            crm = pp.pack(sizes, volume_fraction=c, seed=seed)
            scrm = pp.shake(crm, global_shakes=args.shakes, seed=seed + 1)
            for name, pk in (("CRM", crm), ("SCRM", scrm)):
                incs = [inclusion] * pk.n_species
                r = moduli_of_pack(pk, matrix, incs)
                radii = [float(np.mean(pk.radii[pk.species == s])) for s in range(pk.n_species)]
                fr = [float(np.sum(4 / 3 * np.pi * pk.radii[pk.species == s] ** 3) / np.prod(pk.box))
                      for s in range(pk.n_species)]
                r["well_stirred"] = mefm(matrix, incs, "well_stirred", fractions=fr, radii=radii)
                rows[name].append(r)
            print(f"c={c:.2f} realization {p}: E*/E0 MEFM CRM {rows['CRM'][-1]['mefm'].young / matrix.young:.4f}, "
                  f"SCRM {rows['SCRM'][-1]['mefm'].young / matrix.young:.4f}  ({time.time() - t0:.0f} s)", flush=True)
        for name in rows:
            s = summarize(rows[name], matrix)
            s["well_stirred"] = summarize([{"volume_fraction": r["volume_fraction"], "mefm": r["well_stirred"]}
                                           for r in rows[name]], matrix)["mefm"]
            curves[name].append(s)
        d = np.array([a["mefm"].young - b["mefm"].young for a, b in zip(rows["CRM"], rows["SCRM"])]) / matrix.young
        diffs[c] = {"mean": float(d.mean()), "stderr": float(d.std(ddof=1) / np.sqrt(len(d))) if len(d) > 1 else None}
        print(f"c={c:.2f}: E*/E0 (CRM) - E*/E0 (SCRM) = {diffs[c]['mean']:.4f} ± {diffs[c]['stderr']}", flush=True)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    axes = plot_figs_8_9(curves, matrix, inclusion, title=f"{title}: N = {args.n}, {args.realizations} packs per point")
    fig = axes[0].figure
    fig.tight_layout()
    png = out / f"moduli_{args.system}.png"
    fig.savefig(png, dpi=130)
    plt.close(fig)
    with open(out / f"moduli_{args.system}.json", "w") as fh:
        json.dump({"system": args.system, "n": args.n, "realizations": args.realizations, "shakes": args.shakes,
                   "curves": curves, "crm_minus_scrm_young_ratio": {str(k): v for k, v in diffs.items()}}, fh, indent=1)
    print(f"wrote {png} ({time.time() - t0:.0f} s)")


if __name__ == "__main__":
    main()
