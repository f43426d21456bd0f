"""Reproduce the size-distribution figures of 001_ad5bae0acea940c4.txt with polypack.psd.

    python examples/psd_seed001.py [OUT_DIR]

Writes PNG figures and ``psd_seed001.json`` to OUT_DIR (default ``psd_seed001_out``):

* Fig. 3: CB grading curves for classical shapes (a, b);
* Fig. 4: Hazen Cu and Cc against the span s;
* Fig. 5: regression coefficient Cr (Eq. 21) and total N_p against the number of classes N_c
  for (a, b) = (1, 3), (3, 3), (3, 1) at s = 0.98 (N_p/c^min = 10, N_p^min = 2000), 2D volumes
  as in the seed, mean of 5 seeds;
* Fig. 8: accessible (a, b) domain for s = 0.1 and 0.97.
"""

import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import polypack as pp  # noqa: E402


def main(out="psd_seed001_out"):
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    result = {}

    fig, ax = plt.subplots()
    for a, b in [(1, 1), (3, 1), (1, 3), (3, 3), (0.3, 0.3), (4, 2)]:
        m = pp.psd.CumulativeBeta(a=a, b=b, span=0.9, dim=2)
        d = np.linspace(m.d_min, m.d_max, 300)
        ax.plot(d, m.grading(d), label=f"a={a:g}, b={b:g}")
    ax.set_xlabel("d")
    ax.set_ylabel("h(d)")
    ax.legend(fontsize="small")
    fig.savefig(out / "fig3_cb_curves.png", dpi=120)

    ax = pp.psd.plot_hazen_vs_span()
    ax.figure.savefig(out / "fig4_hazen_vs_span.png", dpi=120)

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    result["fig5"] = {}
    for a, b in [(1, 3), (3, 3), (3, 1)]:
        m = pp.psd.CumulativeBeta(a=a, b=b, span=0.98, dim=2)
        rows = []
        for nc in (2, 4, 6, 8, 10, 14, 20):
            try:
                crs = [pp.psd.discretize(m, n_classes=nc, max_total=2 * 10**6, seed=s).report["descriptors"]["Cr"]
                       for s in range(5)]
                n_total = pp.psd.class_counts(m, nc, "geometric", 10, 2000, dim=2).total
            except pp.InfeasibleError:
                continue
            rows.append((nc, float(np.mean(crs)), int(n_total)))
        r = np.array(rows)
        ax1.semilogy(r[:, 0], r[:, 1], "o-", label=f"a={a}, b={b}")
        ax2.semilogy(r[:, 0], r[:, 2], "o-", label=f"a={a}, b={b}")
        result["fig5"][f"a={a},b={b}"] = [{"n_classes": int(x), "Cr": y, "N_p": int(z)} for x, y, z in rows]
        print(f"a={a} b={b}: " + ", ".join(f"Nc={int(x)} Cr={y:.3g} Np={int(z)}" for x, y, z in rows))
    ax1.set_xlabel("N_c")
    ax1.set_ylabel("C_r")
    ax2.set_xlabel("N_c")
    ax2.set_ylabel("N_p")
    ax1.legend(fontsize="small")
    fig.savefig(out / "fig5_cr_vs_classes.png", dpi=120)

    result["fig8"] = {}
    for s in (0.1, 0.97):
        dom = pp.psd.accessible_domain(s, max_total=[10**4, 10**5, 10**6], dim=2)
        ax = dom.plot()
        ax.figure.savefig(out / f"fig8_domain_s{s:g}.png", dpi=120)
        result["fig8"][str(s)] = dom.to_dict()
    plt.close("all")
    (out / "psd_seed001.json").write_text(json.dumps(result, indent=1))
    print(f"figures and psd_seed001.json in {out}")


if __name__ == "__main__":
    main(*sys.argv[1:2])
