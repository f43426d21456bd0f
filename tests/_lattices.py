"""Periodic lattice packings for the mechanics tests (touching spheres of diameter d)."""

import numpy as np

import polypack as pp


def fcc(cells=3, d=1.0, jitter=0.0, seed=0):
    """FCC of touching spheres: cubic lattice constant a = sqrt(2) d, 4 spheres per cell."""
    a = np.sqrt(2.0) * d
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    g = np.stack(np.meshgrid(*[np.arange(cells)] * 3, indexing="ij"), -1).reshape(-1, 3)
    pos = ((g[:, None, :] + basis[None]) * a).reshape(-1, 3)
    if jitter:
        pos = pos + np.random.default_rng(seed).normal(0.0, jitter * d, pos.shape)
    return pp.Packing(pos, np.full(len(pos), 0.5 * d), np.full(3, cells * a))


def simple_cubic(cells=4, d=1.0):
    """Simple cubic lattice of touching spheres, lattice constant d."""
    g = np.stack(np.meshgrid(*[np.arange(cells)] * 3, indexing="ij"), -1).reshape(-1, 3)
    pos = (g + 0.25) * d
    return pp.Packing(pos, np.full(len(pos), 0.5 * d), np.full(3, cells * d))


def bcc(cells=4, d=1.0):
    """BCC of touching spheres along the body diagonals: a = 2 d / sqrt(3)."""
    a = 2.0 * d / np.sqrt(3.0)
    basis = np.array([[0, 0, 0], [0.5, 0.5, 0.5]])
    g = np.stack(np.meshgrid(*[np.arange(cells)] * 3, indexing="ij"), -1).reshape(-1, 3)
    pos = ((g[:, None, :] + basis[None]) * a).reshape(-1, 3) + 0.1 * a
    return pp.Packing(pos, np.full(len(pos), 0.5 * d), np.full(3, cells * a))


def diamond(cells=2, d=1.0):
    """Diamond lattice of touching spheres: FCC plus the basis (1/4, 1/4, 1/4) a, a = 4 d / sqrt(3)."""
    a = 4.0 * d / np.sqrt(3.0)
    fccb = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
    basis = np.concatenate([fccb, fccb + 0.25])
    g = np.stack(np.meshgrid(*[np.arange(cells)] * 3, indexing="ij"), -1).reshape(-1, 3)
    pos = ((g[:, None, :] + basis[None]) * a).reshape(-1, 3) + 0.05 * a
    return pp.Packing(pos, np.full(len(pos), 0.5 * d), np.full(3, cells * a))
