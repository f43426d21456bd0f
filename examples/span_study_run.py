"""The span study of seed 001 §2.4 (Fig. 9) through ``polypack run``: one study per (shape, span) point.

Every point is the study ``examples/deposit_study.toml`` with its CB shape (a, b) and span s
changed: sizes (``[psd]``, 2D) -> ``[protocol] kind = "deposit"`` -> ``[analysis.deposit]``
(packing fraction in the bulk window), two depositions per point as in the seed.  Each
point's run folder (packs, records, summary, ensemble means) is kept under ``--out`` and
reused when rerun; the script then collects ``deposit.packing_fraction`` with its 95 %
interval from each ``ensemble/scalars.json`` and draws Fig. 9 with the plot of
``examples/span_study.py`` (which does the same sweep without run folders).

    python examples/span_study_run.py --out runs/span            # reduced: 4 spans, <= 20000 disks
    python examples/span_study_run.py --spans 0.02,0.1,0.2,0.42,0.7,0.97 --max-total 100000
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import tomllib
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def main(argv=None):
    import polypack as pp
    from polypack.ensemble.runner import t_quantile
    from polypack.errors import PolypackError
    from span_study import SHAPES, plot_fig9

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="runs/span_study", help="folder of the run folders and results")
    ap.add_argument("--spans", default="0.02,0.1,0.42,0.97", help="comma-separated size spans s")
    ap.add_argument("--min-total", type=int, default=2000)
    ap.add_argument("--max-total", type=int, default=20000)
    ap.add_argument("--realizations", type=int, default=2, help="depositions per point (seed: 2)")
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args(argv)

    with open(HERE / "deposit_study.toml", "rb") as fh:
        template = tomllib.load(fh)
    out = Path(args.out)
    rows = []
    for a, b in SHAPES:
        for s in (float(x) for x in args.spans.split(",")):
            st = copy.deepcopy(template)
            name = f"cb{a}{b}_s{s:.3f}"
            st["study"].update(name=name, realizations=args.realizations)
            st["psd"].update(a=float(a), b=float(b), span=s, min_total=args.min_total, max_total=args.max_total)
            row = {"a": a, "b": b, "span": s}
            try:
                pp.ensemble.run_study(st, out / name, workers=args.workers, progress=False)
            except PolypackError as exc:  # e.g. more disks needed than max_total, an empty window
                row.update(accessible=False, note=str(exc)[:160])
                rows.append(row)
                print(f"{name}: not accessible ({str(exc)[:80]})")
                continue
            sc = json.loads((out / name / "ensemble" / "scalars.json").read_text())
            rho = sc["deposit.packing_fraction"]
            half = t_quantile(rho["n"] - 1) * rho["se"] if rho["se"] is not None else float("nan")
            row.update(accessible=True, n=int(sc["n"]["mean"]), rho=rho["mean"], rho_err=half,
                       coordination=sc["deposit.coordination"]["mean"])
            rows.append(row)
            print(f"{name}: N={row['n']}, rho = {row['rho']:.4f} ± {half:.4f} (95 %), Z = {row['coordination']:.3f}")
    (out / "span_study_run.json").write_text(json.dumps(rows, indent=1))
    plot_fig9(rows, out / "fig9_span_study_run.png")
    print(f"wrote {out / 'span_study_run.json'} and {out / 'fig9_span_study_run.png'}")


if __name__ == "__main__":
    main()
