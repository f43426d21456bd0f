"""Speed of 2D deposition (pp.deposit) for 1e5 disks; target: under one minute.

No PyPI package implements potential-minimisation deposition, so there is no peer to
run back to back; the script prints the wall and CPU time (``time.process_time``, the
figure to compare with the target on a shared machine) per disk, the chain length (the
surface structure whose length sets the cost per disk) and writes JSON.

    python benchmarks/bench_deposit.py [N]
"""

import json
import sys
import time

import numpy as np

import polypack as pp


def main(n=100_000):
    pp.deposit(np.full(50, 0.5), seed=0)  # compile outside the timing
    rows = []
    rng = np.random.default_rng(1)
    for label, radii in [
        ("equal disks", np.full(n, 0.5)),
        ("uniform radii 0.25-0.5", rng.uniform(0.25, 0.5, n)),
        ("CB a=b=1 s=0.5 (2D set)", None),
    ]:
        if radii is None:
            m = pp.psd.CumulativeBeta(a=1, b=1, span=0.5, dim=2)
            radii = pp.psd.discretize(m, n_classes=10, min_per_class=10, min_total=n, max_total=10 * n, seed=1)
        for boundary in ("periodic", "walls"):
            t = time.perf_counter()
            c = time.process_time()
            pk = pp.deposit(radii, boundary=boundary, seed=2)
            dt = time.perf_counter() - t
            cpu = time.process_time() - c
            rows.append({"case": label, "boundary": boundary, "n": pk.n, "seconds": dt, "cpu_seconds": cpu,
                         "us_per_disk": 1e6 * dt / pk.n, "cpu_us_per_disk": 1e6 * cpu / pk.n,
                         "chain_max": pk.meta["chain_max"]})
            print(f"{label:28s} {boundary:9s} N={pk.n:7d} wall {dt:7.2f} s cpu {cpu:7.2f} s "
                  f"({1e6 * cpu / pk.n:7.1f} us/disk) chain<={pk.meta['chain_max']}", flush=True)
    with open("bench_deposit.json", "w") as fh:
        json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100_000)
