"""Linearised stiffness of a bonded sphere network with rotations (the DEM's own static reference).

Per bond the relative displacement of the contact point is ``Δ = B q`` with
``q = (u_i, θ_i, u_j, θ_j)`` and ``B = [-I, l_i [n]×, I, l_j [n]×]``, the lever arms being the
DEM's ``l_i = (d + r_i - r_j) / 2`` and ``l_j = d - l_i``; the bond energy is
``Δᵀ K_c Δ / 2`` with ``K_c = kn n nᵀ + ks (I - n nᵀ)`` (Eq. (1) of 003_873b69fc71c74cf6.txt and Eq. (2) of
003_873b69fc71c74cf6.txt linearised).  The global matrix ``K = Σ Bᵀ K_c B`` gives

* the highest angular frequency ``ω_max`` of ``M⁻¹ K`` and thus the critical time step
  ``2 / ω_max`` of the central-difference scheme;
* the exact static response to a homogeneous strain: with the affine part ``E b`` of
  every bond's relative displacement, the fluctuations solve ``K q = -f`` and
  ``C = (A - fᵀ K⁺ f) / V``.

This module is the DEM's independent check (a direct sparse solve, no dynamics); it
neglects the geometric stiffness of pre-stressed bonds, so it is exact for
stress-free networks.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


def _skew(n):
    """(M, 3, 3) cross-product matrices ``[n]×`` with ``[n]× x = n × x``."""
    m = n.shape[0]
    s = np.zeros((m, 3, 3))
    s[:, 0, 1] = -n[:, 2]
    s[:, 0, 2] = n[:, 1]
    s[:, 1, 0] = n[:, 2]
    s[:, 1, 2] = -n[:, 0]
    s[:, 2, 0] = -n[:, 1]
    s[:, 2, 1] = n[:, 0]
    return s


def bond_geometry(pos, radii, cell, i, j, shift):
    """Branch vectors, lengths, normals and lever arms of bonds in a cell ``cell`` (3, 3)."""
    b = pos[j] + shift @ cell.T - pos[i]
    d = np.linalg.norm(b, axis=1)
    n = b / d[:, None]
    li = 0.5 * (d + radii[i] - radii[j])
    lj = d - li
    return b, d, n, li, lj


def b_matrices(n, li, lj):
    """(M, 3, 12) matrices ``B`` of the bonds."""
    m = n.shape[0]
    skew = _skew(n)
    B = np.zeros((m, 3, 12))
    eye = np.eye(3)
    B[:, :, 0:3] = -eye
    B[:, :, 3:6] = li[:, None, None] * skew
    B[:, :, 6:9] = eye
    B[:, :, 9:12] = lj[:, None, None] * skew
    return B


def contact_matrices(n, kn, ks):
    """(M, 3, 3) ``K_c = kn n nᵀ + ks (I - n nᵀ)``."""
    nn = n[:, :, None] * n[:, None, :]
    return kn[:, None, None] * nn + ks[:, None, None] * (np.eye(3) - nn)


def stiffness_matrix(n_particles, i, j, n, li, lj, kn, ks):
    """Sparse (6N, 6N) stiffness matrix ``Σ Bᵀ K_c B`` (dofs ``u_x u_y u_z θ_x θ_y θ_z`` per sphere)."""
    B = b_matrices(n, li, lj)
    Kc = contact_matrices(n, kn, ks)
    blocks = np.einsum("mai,mab,mbj->mij", B, Kc, B)  # (M, 12, 12)
    dof = np.concatenate([6 * i[:, None] + np.arange(6), 6 * j[:, None] + np.arange(6)], axis=1)  # (M, 12)
    rows = np.repeat(dof, 12, axis=1).ravel()
    cols = np.tile(dof, (1, 12)).ravel()
    K = sp.coo_matrix((blocks.ravel(), (rows, cols)), shape=(6 * n_particles, 6 * n_particles)).tocsr()
    return K


def highest_frequency(K, mass, inertia):
    """Largest angular frequency ``sqrt(λ_max(M⁻¹ K))`` (Lanczos; Gershgorin bound as fallback)."""
    minv = np.empty(K.shape[0])
    minv.reshape(-1, 6)[:, :3] = 1.0 / np.sqrt(mass)[:, None]
    minv.reshape(-1, 6)[:, 3:] = 1.0 / np.sqrt(inertia)[:, None]
    D = sp.diags(minv)
    A = (D @ K @ D).tocsr()
    try:
        # fixed start vector: ARPACK's default is random, and the time step must be reproducible
        v0 = np.cos(np.arange(A.shape[0]) * 0.7) + 1.5
        lam = float(spla.eigsh(A, k=1, which="LA", tol=1e-6, return_eigenvectors=False, v0=v0,
                               maxiter=max(1000, 20 * A.shape[0]))[0])
    except (spla.ArpackNoConvergence, ValueError):
        lam = float(np.max(np.asarray(abs(A).sum(axis=1)).ravel()))
    return float(np.sqrt(max(lam, 0.0)))


def static_shear_modulus(pos, radii, cell, i, j, shift, kn, ks, axis_a, axis_g):
    """Exact static modulus for the simple shear ``E = e_a e_gᵀ`` of a stress-free bonded network.

    Returns ``(C, info)`` where ``C`` is the Voigt constant ``C_agag`` (``C44`` for
    ``{a, g} = {1, 2}``, ``C55`` for ``{0, 2}``, ``C66`` for ``{0, 1}``) and ``info``
    holds the affine value and the residual of the sparse solve.
    """
    n_p = pos.shape[0]
    b, d, n, li, lj = bond_geometry(pos, radii, cell, i, j, shift)
    E = np.zeros((3, 3))
    E[axis_a, axis_g] = 1.0
    delta = b @ E.T  # affine relative displacement per unit strain
    B = b_matrices(n, li, lj)
    Kc = contact_matrices(n, kn, ks)
    kd = np.einsum("mab,mb->ma", Kc, delta)
    A = float(np.einsum("ma,ma->", delta, kd))
    fb = np.einsum("mai,ma->mi", B, kd)  # (M, 12)
    dof = np.concatenate([6 * i[:, None] + np.arange(6), 6 * j[:, None] + np.arange(6)], axis=1)
    f = np.bincount(dof.ravel(), weights=fb.ravel(), minlength=6 * n_p)
    K = stiffness_matrix(n_p, i, j, n, li, lj, kn, ks)
    diag = K.diagonal()
    scale = float(np.max(diag)) if diag.size else 1.0
    # rattlers and floppy modes: f is orthogonal to the null space of K, so a tiny shift
    # selects the minimum-norm solution without changing the energy
    Kr = (K + sp.identity(K.shape[0]) * (1e-10 * scale)).tocsc()
    q = spla.splu(Kr).solve(-f)
    resid = float(np.linalg.norm(K @ q + f) / max(np.linalg.norm(f), 1e-300))
    volume = float(abs(np.linalg.det(cell)))
    C = (A + float(f @ q)) / volume
    return C, {"affine": A / volume, "residual": resid}
