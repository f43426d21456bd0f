import os

import numpy as np
import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def random_polydisperse(rng, n, ratio, box, phi_target=0.2):
    """Random (possibly overlapping) polydisperse spheres with size ratio ``ratio``."""
    r = np.exp(rng.uniform(0.0, np.log(ratio), n))
    r = r / r.max()
    vol = 4 / 3 * np.pi * np.sum(r**3)
    scale = (phi_target * box**3 / vol) ** (1 / 3)
    r = r * scale
    r = np.minimum(r, box / 4.0 - 1e-9)
    return rng.random((n, 3)) * box, r
