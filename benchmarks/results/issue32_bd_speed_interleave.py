"""Old and new BD kernel interleaved in one process, in CPU seconds (issue 32).

    PYTHONPATH=src python benchmarks/results/issue32_bd_speed_interleave.py --old REV [--n 4000] [--steps 1000]

Loads ``src/polypack/_kernels/bd.py`` of git revision REV as a second module and times
``run_tangential`` of both on the same coagulated gel of the seed study's model
(issue32_bd_speed_state.py: tangential bonds, Kramers escape, 4 nm contact, t = 2 a²/D0,
15 mV), and ``run`` on the stable suspension of bench_brownian.py's ``rate`` part,
alternating old/new ``--reps`` times.  Prints ns per particle-step, the load average
and whether both kernels left bit-identical positions (and anchors, orientations).
"""
import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, ".."))


def load_old(rev):
    src = subprocess.run(["git", "show", f"{rev}:src/polypack/_kernels/bd.py"], capture_output=True, text=True,
                         check=True, cwd=os.path.join(HERE, "..", "..")).stdout
    src = src.replace("from .cells import", "from polypack._kernels.cells import")
    d = tempfile.mkdtemp()
    path = os.path.join(d, f"bd_old_{rev}.py")
    with open(path, "w") as fh:
        fh.write(src)
    spec = importlib.util.spec_from_file_location(f"bd_old_{rev}", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _args(sim):
    return (sim._box, sim._params, sim._state, sim._istate, sim._table, sim._bonds, sim._adj, sim._deg, sim._ncell,
            sim._rng)


def gel_runner(mod, sim, steps):
    def go():
        pos = sim._pos.copy()
        a = [x.copy() for x in _args(sim)]
        anch, ori = sim._anchors.copy(), sim._orient.copy()
        t0 = time.process_time()
        mod.run_tangential(pos, *a, steps, anch, ori)
        return time.process_time() - t0, np.concatenate([pos.ravel(), anch.ravel(), ori.ravel()])
    return go


def susp_runner(mod, sim, steps):
    def go():
        pos = sim._pos.copy()
        a = [x.copy() for x in _args(sim)]
        t0 = time.process_time()
        mod.run(pos, *a, steps)
        return time.process_time() - t0, pos
    return go


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--old", required=True)
    ap.add_argument("--n", type=int, default=4000)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--no-suspension", action="store_true")
    args = ap.parse_args()
    from issue32_bd_speed_state import make_sim
    from polypack._kernels import bd as new

    old = load_old(args.old)
    gel, _ = make_sim(args.n, 2.0)
    cases = [("gel (tangential, kramers, 15 mV, t = 2)", gel_runner, gel)]
    if not args.no_suspension:
        from bench_brownian import _repulsive_setup
        from polypack.generate import brownian as B

        p, pos, L = _repulsive_setup(args.n)
        rc = 2.0 + 30 * p.debye_length / p.radius
        susp = B.BrownianSimulation(pos, L, p, bond_width=None, cutoff=rc * p.radius, seed=2)
        susp.run(10)
        cases.append(("stable suspension (bench rate)", susp_runner, susp))
    for name, runner, sim in cases:
        ro, rn = runner(old, sim, 3), runner(new, sim, 3)
        ro(), rn()  # compile / load
        best = {"old": 1e99, "new": 1e99}
        for rep in range(args.reps):
            for tag, r in (("old", runner(old, sim, args.steps)), ("new", runner(new, sim, args.steps))):
                t, p_ = r()
                best[tag] = min(best[tag], t)
                print(f"  {name} {tag}: {t / (sim.n * args.steps) * 1e9:6.1f} ns/particle-step  "
                      f"load {open('/proc/loadavg').read().split()[0]}", flush=True)
                if tag == "old":
                    p_old = p_
                else:
                    same = np.array_equal(p_old, p_)
        print(f"{name}: best old {best['old'] / (sim.n * args.steps) * 1e9:.1f}, new "
              f"{best['new'] / (sim.n * args.steps) * 1e9:.1f} ns/particle-step, ratio {best['old'] / best['new']:.2f}, "
              f"bit-identical positions: {same}", flush=True)


if __name__ == "__main__":
    main()
