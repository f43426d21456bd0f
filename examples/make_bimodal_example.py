"""Regenerate ``examples/bimodal_example.gsd`` (deterministic, seeded).

The bimodal pack of seed 000 (000_2cedc098acbd866b.txt): size ratio lambda = a2/a1 = 0.313,
volume ratio xi = c2/c1 = 0.333, N = 2000 spheres of which N1 = 168 are large. Large
radius a1 = 1 (species 0), small radius a2 = 0.313 (species 1). The box is a cube sized
for a volume fraction of 0.35, which random sequential addition (large spheres first,
then small ones, each at a uniformly random non-overlapping position) reaches without
a packer. Usage::

    python examples/make_bimodal_example.py [OUTPUT]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import polypack as pp
from polypack._util import as_seed_sequence, seed_record

SIZE_RATIO = 0.313  # lambda = a2 / a1
VOLUME_RATIO = 0.333  # xi = c2 / c1
N_TOTAL = 2000
VOLUME_FRACTION = 0.35
SEED = 2024
MAX_TRIALS = 100_000  # per sphere


def counts(n_total=N_TOTAL, size_ratio=SIZE_RATIO, volume_ratio=VOLUME_RATIO):
    """(N1, N2): c2/c1 = (N2 a2^3)/(N1 a1^3) = xi gives N1 = N / (1 + xi / lambda^3), rounded down."""
    n_large = int(n_total / (1.0 + volume_ratio / size_ratio**3))
    return n_large, n_total - n_large


def build(seed=SEED) -> pp.Packing:
    """Random sequential addition of the seed-000 bimodal mixture at volume fraction 0.35."""
    ss = as_seed_sequence(seed)
    rng = np.random.default_rng(ss)
    n_large, n_small = counts()
    radii = np.concatenate([np.ones(n_large), np.full(n_small, SIZE_RATIO)])
    species = np.concatenate([np.zeros(n_large, int), np.ones(n_small, int)])
    box = (4.0 / 3.0 * np.pi * np.sum(radii**3) / VOLUME_FRACTION) ** (1.0 / 3.0)
    placed = np.empty((len(radii), 3))
    for k, r in enumerate(radii):
        for _ in range(MAX_TRIALS):
            x = rng.random(3) * box
            d = placed[:k] - x
            d -= box * np.round(d / box)  # minimum image
            if k == 0 or np.all(np.einsum("ij,ij->i", d, d) > (radii[:k] + r) ** 2):
                placed[k] = x
                break
        else:
            raise pp.InfeasibleError(f"sphere {k}: no free position in {MAX_TRIALS} trials")
    meta = {
        "generator": "random sequential addition (examples/make_bimodal_example.py)",
        "source": "seed 000 bimodal: 000_2cedc098acbd866b.txt",
        "seed": seed_record(ss),
        "size_ratio": SIZE_RATIO,
        "volume_ratio": VOLUME_RATIO,
        "volume_fraction": VOLUME_FRACTION,
        "n_large": n_large,
        "n_small": n_small,
        "large_radius": 1.0,
    }
    return pp.Packing(placed, radii, box, species=species, meta=meta)


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0]) if argv else Path(__file__).with_name("bimodal_example.gsd")
    pk = build()
    pk.check_no_overlap()
    pp.io.write(out, pk)
    print(f"wrote {out}: {pk}")


if __name__ == "__main__":
    main()
