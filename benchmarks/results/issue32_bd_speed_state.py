"""Make (or load) a coagulated gel state of the seed study's model for kernel timing (issue 32).

Model A of docs/brownian.md "fifth pass": bonds="tangential", bond_escape="kramers",
minimum_separation = bond_width = 4e-9 m, time_step = 1.37e-5 s, Phi = 0.4, Psi0 = 15 mV.
``make_sim(n, t)`` runs ``pp.brownian``'s set-up and escape loop to ``t`` a^2/D0 and saves
the arrays to ``/tmp/r32_gel_{n}_{t}.npz``; later calls restore them into a fresh
``BrownianSimulation`` (same state, any kernel version).
"""
import math
import os
import sys

import numpy as np

ARRAYS = ("_pos", "_state", "_istate", "_bonds", "_adj", "_deg", "_anchors", "_orient", "_rng")


def _new_sim(n, psi=0.015, seed=1):
    import polypack as pp
    from polypack.generate import brownian as B

    given = dict(B._DEFAULTS)
    given.update(volume_fraction=0.4, surface_potential=psi, minimum_separation=4e-9, time_step=1.37e-5,
                 bond_width=4e-9, bonds="tangential", rolling_moment=100 * 4.047e-21, bond_escape="kramers")
    c = B._check_brownian_args(n, given)
    from polypack._util import as_seed_sequence

    ss = as_seed_sequence(seed)
    s_init, s_noise, s_escape = ss.spawn(3)
    pos0 = B._initial_positions(n, c.a, c.box_len, 2.0 * c.p.debye_length, s_init)
    sim = B.BrownianSimulation(pos0, c.box_len, c.p, time_step=1.37e-5, bond_width=4e-9, seed=s_noise,
                               bonds="tangential", rolling_moment=100 * 4.047e-21)
    esc = B._Escape(sim, c.p, s_escape)
    return sim, esc, c


def make_sim(n=4000, t=2.0, psi=0.015):
    sim, esc, c = _new_sim(n, psi)
    path = f"/tmp/r32_gel_{n}_{t}_{int(round(psi * 1e3))}.npz"
    if os.path.exists(path):
        z = np.load(path)
        for k in ARRAYS:
            getattr(sim, k)[...] = z[k]
        esc.rng = np.random.default_rng(int(z["esc_seed"]))
    else:
        steps = int(round(t * c.tau / sim.time_step))
        esc.run(steps)
        np.savez(path, esc_seed=12345, **{k: getattr(sim, k) for k in ARRAYS})
        esc.rng = np.random.default_rng(12345)
    return sim, esc


if __name__ == "__main__":
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 4000
    t = float(sys.argv[2]) if len(sys.argv) > 2 else 2.0
    import time
    c0 = time.process_time()
    sim, esc = make_sim(n, t)
    print(f"N={n} t={t}: bonds {sim.n_bonds}, C={sim.coordination:.3f}, steps {sim.steps}, "
          f"{time.process_time() - c0:.1f} CPU s, load {open('/proc/loadavg').read().split()[:3]}")
