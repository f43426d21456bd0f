"""Benchmark of pp.mechanics.homogenize (issue 34): time, iterations, and a plain Moulinec–Suquet loop.

Prints a table and writes JSON (``--json``). Parts (``--parts``):

* ``glass``: 128³ elastic glass/epoxy (contrast E 25), monodisperse pack c = 0.5,
  tolerance 1e-6 and 1e-4: wall time, CG iterations per load case, seconds per iteration.
* ``ms``: the same image with a plain NumPy Moulinec–Suquet fixed-point loop (continuous
  Green operator, reference the arithmetic mean of the extreme Lamé moduli, one load case):
  seconds per iteration and the iterations it needs against CG's (``--ms-resolution``).
* ``ap``: AP/HTPB (contrast E 5.4e4, binder ν = 0.499) at ``--ap-resolution``.
* ``contrast``: CG iterations against the inclusion/matrix contrast (stiff and void) at 32³.
* ``crm``: full-field E*/E0 and μ*/μ0 of CRM and SCRM bimodal packs (seed 000's λ = 0.313,
  ξ = 0.333) at c = 0.6, several realizations, with MEFM beside it.

Always quote the load average printed with the figures: this machine is shared.

    nice python benchmarks/bench_homogenize.py --parts glass ms ap contrast --json bench_homogenize.json
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

import polypack as pp
from polypack.mechanics import Phase, homogenize

EPOXY, GLASS = Phase.from_young(3.01e9, 0.394), Phase.from_young(76e9, 0.23)
HTPB, AP = Phase.from_young(0.6e6, 0.499), Phase.from_young(32.45e9, 0.1433)
PRECISION = "double"
COMPOSITE = False


def load():
    return open("/proc/loadavg").read().split()[:3] if os.path.exists("/proc/loadavg") else None


def mono_pack(n, c, seed=1):
    return pp.pack(np.full(n, 1.0), volume_fraction=c, seed=seed)


def moulinec_suquet(labels, matrix, inclusion, tol=1e-6, maxit=3000, workers=None):
    """Plain basic scheme (Moulinec & Suquet 1998), one macroscopic strain E11 = 1.

    ε^{k+1} = E − Γ0 * [(C − C0) : ε^k] with the continuous Green operator of the reference
    λ0 = (λ_min + λ_max)/2, μ0 = (μ_min + μ_max)/2; stops when the equilibrium error
    ‖ξ·σ̂‖ / ‖σ̂(0)‖ < tol. Returns (C11, iterations, seconds per iteration).
    """
    import scipy.fft as F

    w = workers or os.cpu_count()
    lam_t = np.array([p.bulk - 2 * p.shear / 3 for p in (matrix, inclusion)])
    mu_t = np.array([p.shear for p in (matrix, inclusion)])
    lam, mu = lam_t[labels], mu_t[labels]
    lam0, mu0 = 0.5 * (lam_t.min() + lam_t.max()), 0.5 * (mu_t.min() + mu_t.max())
    n = labels.shape
    k = np.meshgrid(np.fft.fftfreq(n[0]) * n[0], np.fft.fftfreq(n[1]) * n[1], np.fft.rfftfreq(n[2]) * n[2],
                    indexing="ij")
    k2 = k[0] ** 2 + k[1] ** 2 + k[2] ** 2
    k2[0, 0, 0] = 1.0
    xi = [ki / np.sqrt(k2) for ki in k]
    for a in range(3):  # no compatible gradient at the Nyquist frequency of an even axis
        if n[a] % 2 == 0:
            nyq = np.abs(k[a]) == n[a] // 2
            for b in range(3):
                xi[b] = np.where(nyq, 0.0, xi[b])
    idx = ((0, 5, 4), (5, 1, 3), (4, 3, 2))
    vo = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
    c0 = (lam0 + mu0) / (mu0 * (lam0 + 2 * mu0))
    eps = np.zeros((6,) + n)
    eps[0] = 1.0
    t0 = time.perf_counter()
    it = 0
    while it < maxit:
        tr = eps[0] + eps[1] + eps[2]
        sig = 2 * mu * eps
        sig[:3] += lam * tr
        sh = F.rfftn(sig, axes=(1, 2, 3), workers=w)
        # equilibrium error
        div = [sum(sh[idx[i][j]] * xi[j] for j in range(3)) for i in range(3)]
        err = np.sqrt(sum(np.sum(np.abs(d) ** 2) for d in div)) / abs(sh[0, 0, 0, 0])
        if err < tol:
            break
        tau = sig - 2 * mu0 * eps
        tau[:3] -= lam0 * tr
        th = F.rfftn(tau, axes=(1, 2, 3), workers=w)
        tn = [sum(th[idx[i][j]] * xi[j] for j in range(3)) for i in range(3)]
        ntn = xi[0] * tn[0] + xi[1] * tn[1] + xi[2] * tn[2]
        for c, (i, j) in enumerate(vo):
            th[c] = -((xi[j] * tn[i] + xi[i] * tn[j]) / (2 * mu0) - c0 * xi[i] * xi[j] * ntn)
        th[:, 0, 0, 0] = 0.0
        th[0, 0, 0, 0] = eps[0].size  # E11 = 1 mean
        eps = F.irfftn(th, s=n, axes=(1, 2, 3), workers=w)
        it += 1
    dt = (time.perf_counter() - t0) / max(it, 1)
    return float(np.mean(sig[0])), it, dt


def part_glass(res, out):
    pk = mono_pack(out.get("n_spheres", 250), 0.5)
    im = pp.io.voxelize(pk, res)
    for tol in (1e-4, 1e-6):
        t = time.perf_counter()
        r = homogenize(im, EPOXY, GLASS, tolerance=tol, precision=PRECISION)
        dt = time.perf_counter() - t
        row = {"resolution": res, "tolerance": tol, "precision": PRECISION, "seconds": dt, "iterations": r.iterations,
               "seconds_per_iteration": dt / sum(r.iterations), "E_ratio": r.young / EPOXY.young,
               "G_ratio": r.shear / EPOXY.shear, "converged": r.converged, "load": load()}
        print(f"glass/epoxy {res}^3 tol {tol:g}: {dt:.1f} s, iterations {r.iterations}, "
              f"{row['seconds_per_iteration']:.3f} s/it, E*/E0 {row['E_ratio']:.5f}, G*/G0 {row['G_ratio']:.5f}, "
              f"load {row['load']}")
        out.setdefault("glass", []).append(row)
    return im


def part_ms(im, out):
    t = time.perf_counter()
    r = homogenize(im, EPOXY, GLASS, tolerance=1e-6)
    cg_s = time.perf_counter() - t
    c11, it, dt = moulinec_suquet(im.labels.astype(np.intp), EPOXY, GLASS, tol=1e-6)
    row = {"resolution": im.shape[0], "cg_iterations": r.iterations, "cg_seconds_per_iteration": cg_s / sum(r.iterations),
           "cg_C11": float(r.stiffness[0, 0]), "ms_iterations_one_case": it, "ms_seconds_per_iteration": dt,
           "ms_C11_fourier_symbol": c11, "load": load()}
    print(f"{im.shape[0]}^3: CG {np.mean(r.iterations):.0f} it/case, {row['cg_seconds_per_iteration']:.3f} s/it "
          f"(C11 {row['cg_C11']:.4e}); plain Moulinec-Suquet {it} it for E11, {dt:.3f} s/it (C11 {c11:.4e}); "
          f"load {row['load']}")
    out["ms"] = row


def part_ap(res, out):
    pk = mono_pack(out.get("n_spheres", 250), 0.5)
    im = pp.io.voxelize(pk, res)
    t = time.perf_counter()
    r = homogenize(im, HTPB, AP, tolerance=1e-6, precision=PRECISION)
    dt = time.perf_counter() - t
    row = {"resolution": res, "seconds": dt, "iterations": r.iterations, "converged": r.converged,
           "E_ratio": r.young / HTPB.young, "G_ratio": r.shear / HTPB.shear, "load": load()}
    print(f"AP/HTPB {res}^3 (contrast E {AP.young / HTPB.young:.3g}): {dt:.1f} s, iterations {r.iterations}, "
          f"E*/E0 {row['E_ratio']:.4g}, load {row['load']}")
    out["ap"] = row


def part_contrast(out):
    pk = mono_pack(60, 0.5, seed=2)
    im = pp.io.voxelize(pk, 32)
    rows = []
    for ratio in (0.0, 1e-4, 1e-2, 10.0, 1e2, 1e3, 1e4, 1e5, 1e6):
        inc = Phase(EPOXY.bulk * ratio, EPOXY.shear * ratio)
        t = time.perf_counter()
        r = homogenize(im, EPOXY, inc, tolerance=1e-6, precision=PRECISION)
        rows.append({"contrast": ratio, "iterations": max(r.iterations), "converged": r.converged,
                     "seconds": time.perf_counter() - t, "G_ratio": r.shear / EPOXY.shear})
        print(f"  contrast {ratio:8.0e}: {max(r.iterations):4d} iterations, G*/G0 {rows[-1]['G_ratio']:.4f}")
    out["contrast"] = {"resolution": 32, "volume_fraction": 0.5, "rows": rows, "load": load()}


def part_crm(out, n=400, res=64, reals=4):
    from polypack.ensemble.moduli_stage import moduli_of_pack

    sizes = pp.psd.Bimodal(size_ratio=0.313, volume_ratio=0.333, d_large=1.0)
    rows = {"CRM": [], "SCRM": []}
    for r in range(reals):
        s = sizes.sample(n=n, seed=100 + r)
        crm = pp.pack(s, volume_fraction=0.6, seed=100 + r)
        scrm = pp.scrm(s, volume_fraction=0.6, seed=100 + r, global_shakes=60)
        for name, pk in (("CRM", crm), ("SCRM", scrm)):
            h = homogenize(pk, EPOXY, GLASS, res, tolerance=1e-4, composite=COMPOSITE)
            est = moduli_of_pack(pk, EPOXY, [GLASS], three_point=False)
            rows[name].append({"E_ratio": h.young / EPOXY.young, "G_ratio": h.shear / EPOXY.shear,
                               "mefm_E_ratio": est["mefm"].young / EPOXY.young,
                               "voxel_fraction": 1 - h.volume_fractions["voxel"][0], "iterations": max(h.iterations),
                               "min_gap": float(pk.min_gap())})
            print(f"  {name} r{r}: E*/E0 {rows[name][-1]['E_ratio']:.4f} (MEFM {rows[name][-1]['mefm_E_ratio']:.4f}), "
                  f"voxel c {rows[name][-1]['voxel_fraction']:.4f}")
    summ = {}
    for name, rr in rows.items():
        e = np.array([x["E_ratio"] for x in rr])
        summ[name] = {"E_ratio_mean": float(e.mean()), "E_ratio_se": float(e.std(ddof=1) / np.sqrt(len(e)))}
    d = np.array([a["E_ratio"] - b["E_ratio"] for a, b in zip(rows["CRM"], rows["SCRM"])])
    summ["CRM_minus_SCRM"] = {"mean": float(d.mean()), "se": float(d.std(ddof=1) / np.sqrt(len(d)))}
    print(f"  CRM - SCRM in E*/E0 (paired by sizes): {d.mean():+.4f} ± {summ['CRM_minus_SCRM']['se']:.4f} "
          f"(n = {n}, {res}^3, {reals} pairs)")
    out["crm"] = {"n": n, "resolution": res, "composite": COMPOSITE, "rows": rows, "summary": summ, "load": load()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--parts", nargs="+", default=["glass", "ms", "ap", "contrast"],  # crm: minutes more
                    choices=["glass", "ms", "ap", "contrast", "crm"])
    ap.add_argument("--resolution", type=int, default=128)
    ap.add_argument("--ms-resolution", type=int, default=64)
    ap.add_argument("--ap-resolution", type=int, default=64)
    ap.add_argument("--crm-n", type=int, default=400)
    ap.add_argument("--crm-resolution", type=int, default=64)
    ap.add_argument("--crm-realizations", type=int, default=4)
    ap.add_argument("--precision", default="double", choices=["double", "single"])
    ap.add_argument("--composite", action="store_true", help="composite voxels in the crm part")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    global PRECISION, COMPOSITE
    PRECISION = a.precision
    COMPOSITE = a.composite
    out = {"cpu_count": os.cpu_count(), "load_start": load()}
    print(f"load average at start: {out['load_start']}")
    if "glass" in a.parts:
        part_glass(a.resolution, out)
    if "ms" in a.parts:
        part_ms(pp.io.voxelize(mono_pack(250, 0.5), a.ms_resolution), out)
    if "ap" in a.parts:
        part_ap(a.ap_resolution, out)
    if "contrast" in a.parts:
        part_contrast(out)
    if "crm" in a.parts:
        part_crm(out, a.crm_n, a.crm_resolution, a.crm_realizations)
    out["load_end"] = load()
    print(f"load average at end: {out['load_end']}")
    if a.json:
        from polypack._util import atomic_open

        with atomic_open(a.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
