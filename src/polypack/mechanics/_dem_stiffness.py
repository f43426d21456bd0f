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

from ..errors import InfeasibleError

#: Largest relative residual of the relaxation accepted by :func:`static_shear_modulus`.
_RESIDUAL_LIMIT = 1e-6


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


def compatibility_matrix(n_particles, i, j, n, li, lj, kn, ks, ell, kbar):
    """Sparse (3M, 6N) weighted compatibility matrix ``R`` in reduced units.

    Row block ``c`` is ``K_c^(1/2) B_c / sqrt(kbar)`` acting on the reduced unknowns
    ``(u / ell, theta)`` of the two spheres, so that ``|R q + r|^2 kbar ell^2 / 2`` is the
    bond energy with ``r`` the reduced affine relative displacements.  Translations and
    rotations enter with entries of order one whatever the units (a rotation moves a
    contact point by a lever arm ``~ ell``).
    """
    m = n.shape[0]
    B = b_matrices(n, li, lj)
    B[:, :, 3:6] /= ell
    B[:, :, 9:12] /= ell
    W = contact_matrices(n, np.sqrt(kn / kbar), np.sqrt(ks / kbar))  # K_c^(1/2) / sqrt(kbar)
    blocks = np.einsum("mab,mbj->maj", W, B)  # (M, 3, 12)
    dof = np.concatenate([6 * i[:, None] + np.arange(6), 6 * j[:, None] + np.arange(6)], axis=1)
    rows = np.broadcast_to((3 * np.arange(m)[:, None] + np.arange(3))[:, :, None], (m, 3, 12))
    cols = np.broadcast_to(dof[:, None, :], (m, 3, 12))
    R = sp.coo_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), shape=(3 * m, 6 * n_particles)).tocsr()
    return R, W


def _symmetric_lu(A):
    """Sparse LU of a symmetric matrix with symmetric ordering and no row pivoting (an LDL^T in disguise)."""
    return spla.splu(A.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                     options={"SymmetricMode": True})


def count_zero_modes(K, rel=1e-9):
    """Eigenvalues of ``K`` below ``rel * mean(diag K)``: its zero-energy modes.

    Sylvester's law of inertia: the symmetric factorization ``L D L^T`` of
    ``K - rel mean(diag K) I`` has as many negative pivots as ``K`` has eigenvalues below
    the shift.  ``K`` must be in reduced units (every unknown of the same scale, as from
    :func:`compatibility_matrix`).  Returns None when the factorization had to pivot off
    the diagonal (the count is then not an inertia).
    """
    nu = rel * float(np.mean(K.diagonal()))
    lu = _symmetric_lu(K - sp.identity(K.shape[0]) * nu)
    if not np.array_equal(lu.perm_r, lu.perm_c):
        return None
    return int(np.count_nonzero(lu.U.diagonal() < 0))


def rigid_body_modes(n_particles, i, j, shift):
    """Zero modes that are rigid motions: 3 translations per bonded cluster wrapping the
    periodic box, 6 rigid-body motions per cluster that does not and per unbonded sphere."""
    from .._kernels.network import components

    label, n_comp, spans = components(n_particles, i.astype(np.int64), j.astype(np.int64),
                                      np.ascontiguousarray(shift, dtype=np.int64), np.ones(i.shape[0], np.int64))
    wraps = spans[:n_comp].any(axis=1)
    return int(3 * np.count_nonzero(wraps) + 6 * np.count_nonzero(~wraps) + 6 * np.count_nonzero(label < 0))


def _pcg(K, b, solve, tol, maxiter, ref):
    """Preconditioned conjugate gradients on the consistent PSD system ``K x = b`` from ``x = 0``.

    Returns ``(x, residual, iterations)``, the residual ``|b - K x|`` relative to
    ``max(|b|, ref)`` (``ref``: the load scale below which ``b`` is round-off, e.g. the
    cancelling affine forces of a lattice).  Started from zero, every iterate
    stays in the Krylov space of ``b``: components along exact zero modes of ``K`` are
    never built up beyond round-off, so the iterate tends to the minimum-norm solution's
    relaxation in the range of ``K``.
    """
    x = np.zeros_like(b)
    r = b.copy()
    bn = max(float(np.linalg.norm(b)), ref)
    if float(np.linalg.norm(b)) <= tol * bn:
        return x, float(np.linalg.norm(b)) / bn, 0
    z = solve(r)
    p = z.copy()
    rz = float(r @ z)
    best = (np.inf, x.copy())
    it = 0
    stall = 0
    while it < maxiter:
        q = K @ p
        pq = float(p @ q)
        if not pq > 0.0:
            break
        alpha = rz / pq
        x += alpha * p
        r -= alpha * q
        it += 1
        res = float(np.linalg.norm(r)) / bn
        if res < best[0]:
            best = (res, x.copy())
            stall = 0
        else:
            stall += 1
        if res <= tol or stall >= 20:
            break
        z = solve(r)
        rz_new = float(r @ z)
        if not rz_new > 0.0:
            break
        p = z + (rz_new / rz) * p
        rz = rz_new
    # the reported residual is the true one of the returned iterate
    x = best[1]
    return x, float(np.linalg.norm(b - K @ x)) / bn, it


def static_shear_modulus(pos, radii, cell, i, j, shift, kn, ks, axis_a, axis_g, *, tol=1e-12, maxiter=500,
                         shift_rel=1e-12, floppy_rel=1e-9, count=True):
    """Exact static modulus for the simple shear ``E = e_a e_gᵀ`` of a stress-free bonded network.

    The relaxed energy per unit strain squared is ``min_q |R q + r|^2`` (``R`` the
    weighted compatibility matrix of :func:`compatibility_matrix`, ``r`` the affine
    relative displacements): a linear least-squares problem whose minimum is unique
    even when ``R`` is rank deficient (floppy modes, rattlers).  It is solved through
    the normal equations ``K q = -R^T r`` (``K = R^T R``) by conjugate gradients
    preconditioned with a sparse factorization of ``K + shift_rel * mean(diag K) * I``:
    a Krylov method, so modes far softer than the shift are relaxed too (a plain shifted
    solve leaves every mode softer than its shift unrelaxed).  Zero-energy modes carry
    no load (``R v = 0`` gives ``v . R^T r = 0``) and are never excited.  The modulus is
    the energy of the relaxed state, ``C = kbar ell^2 |R q + r|^2 / V``, evaluated
    directly (no cancellation between the affine and the relaxation terms).

    Returns ``(C, info)`` where ``C`` is the Voigt constant ``C_agag`` (``C44`` for
    ``{a, g} = {1, 2}``, ``C55`` for ``{0, 2}``, ``C66`` for ``{0, 1}``) and ``info``
    holds the affine value, the relative residual of the normal equations, the CG
    iterations and, with ``count=True``, ``zero_modes`` (eigenvalues of the
    diagonally scaled ``K`` below ``floppy_rel``, by inertia), ``rigid_modes`` (rigid
    motions of the bonded clusters, :func:`rigid_body_modes`) and ``floppy_modes``
    (their difference: mechanisms, including those of spheres with fewer than two
    bonds; None when the count is not available).
    """
    n_p = pos.shape[0]
    b, d, n, li, lj = bond_geometry(pos, radii, cell, i, j, shift)
    ell = float(np.mean(radii))
    kbar = float(np.mean(kn))
    E = np.zeros((3, 3))
    E[axis_a, axis_g] = 1.0
    R, W = compatibility_matrix(n_p, i, j, n, li, lj, kn, ks, ell, kbar)
    r = np.einsum("mab,mb->ma", W, b @ E.T).ravel() / ell
    f = R.T @ r
    K = (R.T @ R).tocsr()
    K = 0.5 * (K + K.T)
    mu = shift_rel * float(np.mean(K.diagonal())) if K.shape[0] else 1.0
    lu = _symmetric_lu(K + sp.identity(K.shape[0]) * mu)
    # load scale: the affine displacements times the mean bond stiffness (reduced units);
    # a load far below it (the cancelling affine forces of a lattice) is round-off
    ref = float(np.sqrt(np.mean(K.diagonal())) * np.linalg.norm(r)) if K.shape[0] else 1.0
    q, resid, iters = _pcg(K, -f, lu.solve, tol, maxiter, ref)
    volume = float(abs(np.linalg.det(cell)))
    scale = kbar * ell * ell / volume
    relaxed = R @ q + r
    C = scale * float(relaxed @ relaxed)
    info = {"affine": scale * float(r @ r), "residual": resid, "iterations": iters}
    if count or resid > _RESIDUAL_LIMIT:
        zero = count_zero_modes(K, floppy_rel)
        rigid = rigid_body_modes(n_p, i, j, shift)
        info.update(zero_modes=zero, rigid_modes=rigid, floppy_modes=None if zero is None else zero - rigid)
    if resid > _RESIDUAL_LIMIT:
        raise InfeasibleError(
            f"static_shear_modulus: the relaxation did not converge (relative residual {resid:.2g} after {iters} "
            f"CG iterations, limit {_RESIDUAL_LIMIT:g}) on a network with {info['floppy_modes']} floppy modes"
        )
    return C, info
