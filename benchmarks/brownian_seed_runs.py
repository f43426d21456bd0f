"""Seed runs of the reversible BD gels of docs/brownian.md ("fifth pass", issue 32).

a (DOH, ``PoreSizes(n_points=100000, seed=1).fit["seed"]["a"]``) and C sampled along one run per seed,
with the same kernel calls in the same chunks as ``pp.brownian(..., min_time=max_time=T)`` (the last
sample is that call's gel; earlier samples are the positions at t without the final overlap removal).
Model A by default (tangential bonds, 100 kT rolling moment, 4 nm contacts, ``bond_escape="kramers"``,
largest step); override options with the environment variable KW (JSON, SI units), e.g. variant E at
15 mV: ``KW='{"rolling_moment": 9.79e-20}'``.  One JSON line per sample (CPU s, load average beside).

usage: python benchmarks/brownian_seed_runs.py N T_end t1,t2,... out.jsonl psi_mV:seed ...   (T in a²/D0)
e.g.   nice python benchmarks/brownian_seed_runs.py 300 150 60,90,120,150 runs.jsonl 0:1 15:1
"""

import json
import os
import sys
import time

import numpy as np

import polypack as pp
from polypack._util import as_seed_sequence
from polypack.generate import brownian as B
from polypack.packing import Packing

TAU = 0.0729  # a²/D0 (s) of the default parameters (a = 0.25 µm, water at 20 °C)
KW = dict(bonds="tangential", rolling_moment=100 * 4.047e-21, minimum_separation=4e-9, bond_width=4e-9,
          bond_escape="kramers", time_step=1.37e-5)
KW.update(json.loads(os.environ.get("KW", "{}")))
N = int(sys.argv[1]); T = float(sys.argv[2]); snaps = [float(x) for x in sys.argv[3].split(",")]
out = sys.argv[4]
for job in sys.argv[5:]:
    psi_mV, seed = float(job.split(":")[0]), int(job.split(":")[1])
    c0 = time.process_time(); w0 = time.time()
    given = dict(volume_fraction=0.4, surface_potential=psi_mV * 1e-3, radius=None, temperature=None, viscosity=None,
                 relative_permittivity=None, hamaker=None, ionic_strength=None, debye_length=None,
                 minimum_separation=None, model=B._DEFAULTS["model"], time_step=None, bond_width=None, cutoff=None,
                 record_interval=None, stable_window=B._DEFAULTS.get("stable_window"),
                 coordination_tolerance=B._DEFAULTS["coordination_tolerance"],
                 cluster_tolerance=B._DEFAULTS["cluster_tolerance"], min_time=T * TAU, max_time=T * TAU,
                 max_steps=None, bonds="flexible", sliding_stiffness=None, rolling_stiffness=None,
                 rolling_moment=None, hydrodynamics=B._DEFAULTS["hydrodynamics"], lubrication_range=None, bond_escape="none")
    given.update(KW)
    c = B._check_brownian_args(N, given)
    ss = as_seed_sequence(seed)
    s_init, s_noise, s_escape = ss.spawn(3)
    pos0 = B._initial_positions(N, c.a, c.box_len, 2.0 * c.p.debye_length, s_init)
    sim = B.BrownianSimulation(pos0, c.box_len, c.p, time_step=given["time_step"], bond_width=given["bond_width"],
                               cutoff=None, seed=s_noise, bonds=given["bonds"],
                               sliding_stiffness=given["sliding_stiffness"], rolling_stiffness=given["rolling_stiffness"],
                               rolling_moment=given["rolling_moment"], hydrodynamics=given["hydrodynamics"],
                               lubrication_range=None)
    esc = B._Escape(sim, c.p, s_escape) if given["bond_escape"] == "kramers" else None
    dt = sim.time_step
    k = max(1, int(round(c.record_interval / dt)))
    todo = list(snaps)
    while todo:
        if sim.time >= todo[0] * TAU * (1 - 1e-12):
            t_s = todo.pop(0)
            final = not todo
            if final:
                sim.relax_constraints()
            pos = sim.positions; bx = sim.box
            pk = Packing(np.mod(pos, bx), np.full(N, c.a), bx)
            ps = pp.analysis.PoreSizes(n_points=100000, seed=1); ps.compute(pk)
            ce = pp.analysis.Contacts(tolerance=0.01).compute(pk).coordination
            _, sizes = sim.clusters()
            rec = dict(model=given["bonds"] + "+" + given["bond_escape"], kw={kk: KW[kk] for kk in KW}, N=N, seed=seed,
                       psi_mV=psi_mV, t=t_s, t_end=T, C=round(sim.coordination, 4), C_eps=round(ce, 4),
                       a=round(ps.fit["seed"]["a"], 4), clusters=int(sizes.size),
                       broken=(esc.broken if esc else 0), cpu_s=round(time.process_time() - c0, 1),
                       wall_s=round(time.time() - w0, 1), load=open("/proc/loadavg").read().split()[:3])
            print(json.dumps(rec), flush=True)
            with open(out, "a") as f:
                f.write(json.dumps(rec) + "\n")
            continue
        (esc.run(k) if esc else sim.run(k))
