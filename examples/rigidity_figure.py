"""Which variable carries the stiffness? G'p against C - 4, the backbone's excess coordination and a.

The figure seed 003 could not draw (§4 of 003_873b69fc71c74cf6.txt asks for "an intermediate
step"): every structure of one or more study folders (each with ``[analysis.pores]``,
``[analysis.contacts]``, ``[analysis.elastic]`` and ``[analysis.rigidity]``), its plateau
modulus ``G'p`` (mean of C44, C55, C66 of the exact static tensor) against

* the coordination ``C - 4`` (``C`` = bonds at eps = 0.01 per sphere, Z_c = 4 for contact bonds),
* the excess coordination of the load-bearing backbone ``Z_b - 4`` (``rigidity.backbone_coordination``),
* the degree of heterogeneity ``a`` (Eq. (6) of 003_873b69fc71c74cf6.txt),

with the power law Eq. (7) of 003_873b69fc71c74cf6.txt, ``G = A max(a - a0, 0)^beta``, and linear
rigidity fits ``G = k max(x - x0, 0)`` side by side (threshold free, and fixed at Z_c = 4), their
residuals, and AIC / BIC (``n ln(RSS/n) + 2p`` / ``+ p ln n``, Gaussian errors). All models are fitted to
every structure, floppy ones (G = 0) included: each model can say zero. A second figure puts the
three per-plane moduli of each structure (relative to their mean) against the fabric of the plane,
``<n_a^2 n_b^2>`` over all bonds and over that shear's backbone (relative to their mean).

    python examples/rigidity_figure.py OUT FOLDER [FOLDER ...] [--recompute]

``--recompute`` (or a record without the stages) rebuilds the tensor and the rigidity from each
realization's saved pack (the seed's bonds: eps = 0.01, kn = 100 N/m, ks = 10 N/m). A FOLDER is a run folder (``realizations/*.json``) or a sweep folder holding run folders. Writes
OUT/rigidity_fig.png, OUT/rigidity_fabric.png, OUT/rigidity_fits.json and OUT/rigidity_fits.md.
"""

from __future__ import annotations

import json
import math
import os
import sys
from pathlib import Path

import numpy as np


def _runs(folder: Path):
    if (folder / "realizations").is_dir():
        yield folder
        return
    for sub in sorted(folder.iterdir()):
        if (sub / "realizations").is_dir():
            yield sub


def load(folders):
    """One dict per structure: set, a, C, G (Pa), per-plane moduli, rigidity numbers."""
    rows = []
    for f in folders:
        for run in _runs(Path(f)):
            try:
                doc = json.loads((run / "study.resolved.json").read_text())
                proto = doc.get("protocol") or doc.get("study", {}).get("protocol", {})
            except (OSError, ValueError):
                proto = {}
            kind = proto.get("kind", "?")
            for rj in sorted((run / "realizations").glob("r*.json")):
                rec = json.loads(rj.read_text())
                ana = rec.get("analysis", {})
                if "pores" not in ana:
                    continue
                if RECOMPUTE or not all(k in ana for k in ("elastic", "rigidity")):
                    ana = dict(ana, **_recompute(rj.with_suffix(".gsd")))
                el, rg = ana["elastic"], ana["rigidity"]
                g3 = np.asarray(el["shear_moduli"], dtype=float)
                c = ana.get("contacts", {}).get("coordination", el.get("coordination"))
                rows.append(dict(
                    set=kind, run=run.name, a=float(ana["pores"]["fit"]["seed"]["a"]), C=float(c),
                    G=float(g3.mean()), g3=g3, Zb=rg.get("backbone_coordination"),
                    excess=rg.get("excess_coordination"), percolating=rg.get("percolating"),
                    largest=rg.get("largest_cluster_fraction"), backbone=rg.get("backbone_fraction"),
                    floppy_pp=rg.get("floppy_per_particle"), gamma=rg.get("nonaffinity"),
                    fab=np.asarray(rg.get("shear_fabric") or [np.nan] * 3, dtype=float),
                    bfab=np.asarray(rg.get("backbone_shear_fabric") or [np.nan] * 3, dtype=float),
                    seconds=rg.get("seconds"), el_seconds=el.get("seconds")))
    return rows


RECOMPUTE = False


def _recompute(gsd):
    """Elastic tensor and rigidity of a saved pack, bonded by the seed's rule (eps = 0.01,
    kn = 100 N/m, ks = 10 N/m, r0 = 0.25 µm): for studies without those stages, or ``--recompute``."""
    import polypack as pp

    pk = pp.io.read(str(gsd))
    net = pp.mechanics.BondNetwork.from_packing(pk, epsilon=0.01, normal_stiffness=100.0, shear_stiffness=10.0)
    et = pp.mechanics.elastic_tensor(net, radius=0.25e-6, floppy_samples=8)
    r = pp.mechanics.rigidity(net, et)
    el = et.to_dict()
    el["coordination"] = net.coordination
    return {"elastic": el, "rigidity": r.to_dict()}


def _ramp(x, x0):
    return np.maximum(x - x0, 0.0)


def fit_models(x_by_name, g):
    """Least-squares fits of G (MPa) on each predictor; returns {model: dict}."""
    from scipy.optimize import curve_fit, minimize_scalar

    n = g.size
    out = {}

    def score(name, pred, p, params, xname):
        rss = float(np.sum((g - pred) ** 2))
        out[name] = dict(predictor=xname, params=params, k=p, rss=rss, rms=math.sqrt(rss / n),
                         aic=n * math.log(max(rss, 1e-300) / n) + 2 * p,
                         bic=n * math.log(max(rss, 1e-300) / n) + p * math.log(n),
                         r2=1.0 - rss / float(np.sum((g - g.mean()) ** 2)), residuals=(g - pred).tolist())

    for xname, x in x_by_name.items():
        ok = np.isfinite(x)
        if not ok.all():
            continue
        # linear rigidity fit with a free threshold: profile over x0, k by linear least squares
        def rss_of(x0):
            r = _ramp(x, x0)
            k = float(r @ g / max(r @ r, 1e-300))
            return float(np.sum((g - k * r) ** 2))

        lo, hi = float(x.min()) - 3.0, float(x.max())
        grid = np.linspace(lo, hi, 400)
        x0 = float(grid[np.argmin([rss_of(v) for v in grid])])
        step = (hi - lo) / 399
        x0 = float(minimize_scalar(rss_of, bounds=(x0 - step, x0 + step), method="bounded").x)
        r = _ramp(x, x0)
        k = float(r @ g / max(r @ r, 1e-300))
        score(f"linear({xname})", k * r, 2, {"k": k, "x0": x0}, xname)
        if xname in ("C - 4", "Z_b - 4"):  # the isostatic threshold fixed: x0 = 0 (Z = 4), one parameter
            r0 = _ramp(x, 0.0)
            k0 = float(r0 @ g / max(r0 @ r0, 1e-300))
            score(f"linear0({xname})", k0 * r0, 1, {"k": k0, "x0": 0.0}, xname)
    a = x_by_name["a"]

    def eq7(a_, amp, a0, beta):
        return amp * np.maximum(a_ - a0, 0.0) ** beta

    best = None
    for a0 in np.linspace(a.min() - 0.1, a.min() + 0.8 * (np.median(a) - a.min()), 12):
        for beta in (0.2, 0.5, 1.0, 1.5, 2.5):
            try:
                p, _ = curve_fit(eq7, a, g, p0=[max(g.max(), 1e-9) / max(a.max() - a0, 1e-3) ** beta, a0, beta],
                                 bounds=([0, 0, 0.01], [np.inf, a.max(), 10]), maxfev=20000)
            except (RuntimeError, ValueError):
                continue
            rss = float(np.sum((g - eq7(a, *p)) ** 2))
            if best is None or rss < best[0]:
                best = (rss, p)
    if best is not None:
        p = best[1]
        score("Eq. (7)(a)", eq7(a, *p), 3, {"A": float(p[0]), "a0": float(p[1]), "beta": float(p[2])}, "a")
    return out


def main(argv):
    global RECOMPUTE
    if "--recompute" in argv:
        RECOMPUTE = True
        argv = [a for a in argv if a != "--recompute"]
    if len(argv) < 3:
        print(__doc__)
        return 2
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(argv[1])
    out.mkdir(parents=True, exist_ok=True)
    rows = load(argv[2:])
    if not rows:
        print("no structure with pores, elastic and rigidity records found")
        return 1
    g = np.array([r["G"] for r in rows]) * 1e-6
    xs = {"C - 4": np.array([r["C"] for r in rows]) - 4.0,
          # no backbone (a floppy structure): Z_b taken as 0, below any threshold (the model says G = 0)
          "Z_b - 4": np.array([0.0 if r["Zb"] is None else r["Zb"] for r in rows], dtype=float) - 4.0,
          "a": np.array([r["a"] for r in rows])}
    fits = fit_models(xs, g)
    per_set = {}
    for s_ in sorted({r["set"] for r in rows}):
        sel = np.array([r["set"] == s_ for r in rows])
        if sel.sum() >= 5:
            per_set[s_] = fit_models({k: v[sel] for k, v in xs.items()}, g[sel])
    marker = {"brownian": ("^", "tab:red", "BD"), "vem": ("o", "tab:blue", "VEM")}
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5), gridspec_kw={"height_ratios": [2.2, 1]})
    for col, (xname, label) in enumerate((("C - 4", "coordination excess C − 4 (bonds per sphere)"),
                                         ("Z_b - 4", "backbone excess coordination Z_b − 4"),
                                         ("a", "degree of heterogeneity a (Eq. 6, dimensionless)"))):
        ax, axr = axes[0, col], axes[1, col]
        x = xs[xname]
        for s in sorted({r["set"] for r in rows}):
            sel = np.array([r["set"] == s for r in rows])
            m, c, lab = marker.get(s, ("s", "k", s))
            ax.scatter(x[sel], g[sel], marker=m, facecolors="none", edgecolors=c, label=lab)
        xx = np.linspace(np.nanmin(x), np.nanmax(x), 300)
        res_x = []
        for name, f in fits.items():
            if f["predictor"] != xname:
                continue
            p = f["params"]
            if name.startswith("Eq. (7)"):
                yy = p["A"] * np.maximum(xx - p["a0"], 0) ** p["beta"]
                lab = f"Eq. (7): a0 = {p['a0']:.3f}, β = {p['beta']:.2f}"
            else:
                yy = p["k"] * _ramp(xx, p["x0"])
                lab = f"{p['k']:.2f} max({xname} − {p['x0']:.2f}, 0)"
            lab += f"  (AIC {f['aic']:.1f}, BIC {f['bic']:.1f})"
            line, = ax.plot(xx, yy, lw=1.2, label=lab)
            axr.plot(x, f["residuals"], ls="none", marker=".", color=line.get_color())
            res_x.append(name)
        axr.axhline(0, color="k", lw=0.6)
        ax.set_xlabel(label)
        ax.set_ylabel("G′p (MPa)")
        ax.legend(fontsize=6.5, loc="upper left")
        axr.set_xlabel(label)
        axr.set_ylabel("residual G′p − fit (MPa)")
    fig.suptitle(f"seed 003, reduced study: G′p of {len(rows)} structures (exact static tensor, "
                 "kn = 100 N/m, ks = 10 N/m, r0 = 0.25 µm, bonds at ε = 0.01)", fontsize=10)
    fig.tight_layout()
    tmp = out / ".rigidity_fig.png.tmp.png"
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, out / "rigidity_fig.png")
    plt.close(fig)

    # anisotropy: per-plane moduli against the fabric of the plane (both relative to the structure's mean)
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    stats = {}
    for ax, key, lab in ((axes[0], "fab", "all bonds"), (axes[1], "bfab", "backbone of that shear")):
        xr, yr = [], []
        for r in rows:
            if r["G"] <= 0 or not np.all(np.isfinite(r[key])):
                continue
            xr += list(r[key] / r[key].mean() - 1.0)
            yr += list(r["g3"] / r["g3"].mean() - 1.0)
        xr, yr = np.array(xr), np.array(yr)
        rho = float(np.corrcoef(xr, yr)[0, 1]) if xr.size > 2 else float("nan")
        slope = float(np.polyfit(xr, yr, 1)[0]) if xr.size > 2 else float("nan")
        stats[lab] = {"pearson_r": rho, "slope": slope, "n": int(xr.size)}
        ax.scatter(xr, yr, s=12)
        ax.axhline(0, color="k", lw=0.5)
        ax.axvline(0, color="k", lw=0.5)
        ax.set_xlabel(f"⟨n_a² n_b²⟩ of the plane, {lab}: relative deviation from the structure mean")
        ax.set_ylabel("C44, C55, C66: relative deviation from their mean")
        ax.set_title(f"r = {rho:.2f}, slope {slope:.2f} ({xr.size} planes)", fontsize=9)
    fig.tight_layout()
    tmp = out / ".rigidity_fabric.png.tmp.png"
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, out / "rigidity_fabric.png")
    plt.close(fig)

    table = [{k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in r.items()} for r in rows]
    doc = {"n_structures": len(rows), "fits": fits, "fits_per_set": per_set, "fabric": stats, "structures": table}
    tmp = out / ".rigidity_fits.json.tmp"
    tmp.write_text(json.dumps(doc, indent=1))
    os.replace(tmp, out / "rigidity_fits.json")
    lines = ["| model | predictor | parameters | RMS (MPa) | R² | AIC | BIC |", "|---|---|---|---|---|---|---|"]
    for name, f in sorted(fits.items(), key=lambda kv: kv[1]["aic"]):
        par = ", ".join(f"{k} = {v:.4g}" for k, v in f["params"].items())
        lines.append(f"| {name} | {f['predictor']} | {par} | {f['rms']:.4g} | {f['r2']:.3f} | {f['aic']:.1f} | {f['bic']:.1f} |")
    for s_, fs in per_set.items():
        lines += ["", f"{s_} alone:", "", "| model | parameters | RMS (MPa) | R² | AIC | BIC |", "|---|---|---|---|---|---|"]
        for name, f in sorted(fs.items(), key=lambda kv: kv[1]["aic"]):
            par = ", ".join(f"{k} = {v:.4g}" for k, v in f["params"].items())
            lines.append(f"| {name} | {par} | {f['rms']:.4g} | {f['r2']:.3f} | {f['aic']:.1f} | {f['bic']:.1f} |")
    lines += ["", "| set | run | a | C | Z_b | percolating | largest rigid cluster | backbone | Γ | G′p (MPa) |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        zb = "–" if r["Zb"] is None else f"{r['Zb']:.3f}"
        gam = "–" if r["gamma"] is None else f"{r['gamma']:.3g}"
        lines.append(f"| {r['set']} | {r['run']} | {r['a']:.3f} | {r['C']:.3f} | {zb} | {r['percolating']} | "
                     f"{r['largest']:.3f} | {r['backbone']:.3f} | {gam} | {r['G'] * 1e-6:.4g} |")
    tmp = out / ".rigidity_fits.md.tmp"
    tmp.write_text("\n".join(lines) + "\n")
    os.replace(tmp, out / "rigidity_fits.md")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
