"""Validation packs for the analysis tests: Poisson points, lattices, RSA hard spheres."""

import numpy as np

import polypack as pp


def poisson(rng, n, box, n_species=1, radius=1e-4):
    sp = rng.integers(0, n_species, n) if n_species > 1 else None
    return pp.Packing(rng.random((n, 3)) * box, np.full(n, radius), box, species=sp)


def lattice(kind, cells, a=1.0, radius=None):
    """SC/BCC/FCC lattice with cubic cell ``a`` and ``cells`` cells per side."""
    basis = {
        "sc": [(0, 0, 0)],
        "bcc": [(0, 0, 0), (0.5, 0.5, 0.5)],
        "fcc": [(0, 0, 0), (0.5, 0.5, 0), (0.5, 0, 0.5), (0, 0.5, 0.5)],
    }[kind]
    g = np.arange(cells)
    cell = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3).astype(float)
    pos = (cell[:, None, :] + np.asarray(basis, float)[None]).reshape(-1, 3) * a
    nn = {"sc": a, "bcc": a * np.sqrt(3) / 2, "fcc": a / np.sqrt(2)}[kind]
    r = 0.5 * nn if radius is None else radius
    return pp.Packing(pos, np.full(len(pos), r), cells * a)


def rsa(rng, n, box, radii_choices=(0.5,), weights=None, max_tries=200000):
    """Random sequential addition of non-overlapping spheres (hard-sphere-like pack)."""
    radii_choices = np.asarray(radii_choices, float)
    pos = np.empty((n, 3))
    rad = np.empty(n)
    sp = np.empty(n, np.int64)
    k = 0
    tries = 0
    while k < n and tries < max_tries:
        tries += 1
        s = rng.choice(len(radii_choices), p=weights)
        r = radii_choices[s]
        x = rng.random(3) * box
        if k:
            d = pos[:k] - x
            d -= box * np.round(d / box)
            if np.any(np.einsum("ij,ij->i", d, d) < (rad[:k] + r) ** 2):
                continue
        pos[k], rad[k], sp[k] = x, r, s
        k += 1
    if k < n:
        raise RuntimeError(f"RSA placed only {k} of {n} spheres")
    return pp.Packing(pos, rad, box, species=sp)
