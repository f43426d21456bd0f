"""RDF-dependent effective moduli: effective field with binary interactions (MEFM).

The multiparticle effective field method of Buryachenko reduced to its pair level
(the estimate behind Figs. 8-9 of 000_2cedc098acbd866b.txt, whose §4 is missing). Each
sphere carries a uniform stress polarization ``τ = (L_r − L0) ε`` (Eshelby); the field
that loads it is the effective field ``ε̄`` (the mean matrix strain, as in Mori-Tanaka)
plus the exterior Eshelby field of one neighbour at a time, which is itself loaded by
``ε̄`` and by the first sphere (the two-sphere problem solved to all orders in the
pair; quasi-crystalline closure: the neighbours beyond the pair see only ``ε̄``). The
pair correction of every family's polarization is averaged over the neighbour's
direction and over its distance with the partial RDF ``g_rs``, and closes as in
Mori-Tanaka. With ``g ≡ 0`` it *is* Mori-Tanaka.

The exterior field of a uniformly polarized sphere of radius ``a_s`` at distance ``R``,
averaged over a receiving sphere of radius ``a_r``, is
``−v_s [Γ⁰(R) + (a_r² + a_s²)/10 ∇²Γ⁰(R)] : τ_s`` exactly (``Γ⁰ = ∇∇G`` of the matrix's
Kelvin solution is biharmonic, and the ball averages of a biharmonic function are
``f + ρ²∇²f/10``); the receiving sphere responds to that average (the uniform-field
Eshelby approximation of the pair, good to the order of the field's curvature).

Approximations, stated honestly: uniform strain in each sphere (no higher multipoles
of the pair's mutual field), pairs only (no three-body terms beyond the effective
field), the effective field equal to the mean matrix strain. It reproduces the
Batchelor-Green structure (an ``O(c²)`` stiffening over MT that grows with the
contact value of g) but is an estimate, not a bound.

References
----------
.. [1] V. A. Buryachenko, N. J. Pagano, Math. Mech. Solids 8, 403 (2003).
.. [2] V. A. Buryachenko, *Micromechanics of Heterogeneous Materials*, Springer (2007).
.. [3] T. Mura, *Micromechanics of Defects in Solids*, Nijhoff (1987) (Kelvin tensor).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ..errors import InvalidInputError
from .effective import Phase, _as_phase, _as_phases, _inv, zeta_reference

__all__ = ["mefm", "pair_interaction_coefficients", "partial_rdfs"]

_EYE = np.eye(3)
_MANDEL_IDX = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]
_MANDEL_W = np.array([1, 1, 1, math.sqrt(2), math.sqrt(2), math.sqrt(2)])
_J = np.zeros((6, 6))
_J[:3, :3] = 1.0 / 3.0
_KDEV = np.eye(6) - _J


def _mandel(t4):
    m = np.empty((6, 6))
    for a, (i, j) in enumerate(_MANDEL_IDX):
        for b, (k, l) in enumerate(_MANDEL_IDX):
            m[a, b] = t4[i, j, k, l] * _MANDEL_W[a] * _MANDEL_W[b]
    return m


def _interaction_tensor(rvec, shear0, nu0, size2):
    """Mandel matrix of ``Γ⁰(R) + size2 ∇²Γ⁰(R)`` (strain per unit polarization·volume)."""
    r = float(np.linalg.norm(rvec))
    n = rvec / r
    amp = 1.0 / (16.0 * math.pi * shear0 * (1.0 - nu0))
    d = _EYE
    nn = np.einsum("i,j->ij", n, n)
    # ∂j∂l G_ik = amp [ (3-4ν) δik (3 nj nl - δjl)/r³ + ∂j∂l(x_i x_k / r³) ]
    t = (3.0 - 4.0 * nu0) * np.einsum("ik,jl->ijkl", d, 3 * nn - d)
    t += np.einsum("il,jk->ijkl", d, d) + np.einsum("ij,kl->ijkl", d, d)
    t -= 3.0 * (np.einsum("il,kj->ijkl", d, nn) + np.einsum("kl,ij->ijkl", d, nn))
    t -= 3.0 * (np.einsum("ij,kl->ijkl", d, nn) + np.einsum("jk,il->ijkl", d, nn) + np.einsum("jl,ik->ijkl", d, nn))
    t += 15.0 * np.einsum("i,j,k,l->ijkl", n, n, n, n)
    gdd = amp * t / r**3  # gdd[i, j, k, l] = ∂j ∂l G_ik
    # ∇²(∂j∂l G_ik) = -2 amp ∂i∂j∂k∂l (1/r)
    nnnn = np.einsum("i,j,k,l->ijkl", n, n, n, n)
    six = (
        np.einsum("ij,kl->ijkl", d, nn) + np.einsum("ik,jl->ijkl", d, nn) + np.einsum("il,jk->ijkl", d, nn)
        + np.einsum("jk,il->ijkl", d, nn) + np.einsum("jl,ik->ijkl", d, nn) + np.einsum("kl,ij->ijkl", d, nn)
    )
    three = np.einsum("ij,kl->ijkl", d, d) + np.einsum("ik,jl->ijkl", d, d) + np.einsum("il,jk->ijkl", d, d)
    d4 = (105.0 * nnnn - 15.0 * six + 3.0 * three) / r**5
    gdd = gdd - 2.0 * amp * size2 * d4
    # ε_ij = -1/2 (G_ik,lj + G_jk,li) P_kl  ->  Γ_ijkl symmetrised in (i,j) and (k,l)
    g = 0.5 * (gdd + np.einsum("jikl->ijkl", gdd))
    g = 0.5 * (g + np.einsum("ijlk->ijkl", g))
    return _mandel(g)


def _polarization_factors(matrix, inc):
    """Bulk and shear eigenvalues of ``Q = (L_r − L0) T_r`` (Mandel: 3K-type, 2G-type) and ``T``."""
    b = 4.0 * matrix.shear / 3.0
    z = zeta_reference(matrix.bulk, matrix.shear)
    # (M_r - M0) * (M0 + b)/(M_r + b) as a limit-safe expression
    qk = 3.0 * (matrix.bulk + b) * (1.0 - (matrix.bulk + b) * _inv(inc.bulk + b))
    qg = 2.0 * (matrix.shear + z) * (1.0 - (matrix.shear + z) * _inv(inc.shear + z))
    tk = (matrix.bulk + b) * _inv(inc.bulk + b)
    tg = (matrix.shear + z) * _inv(inc.shear + z)
    return qk, qg, tk, tg


def _sphere_directions(n):
    """Gauss-Legendre in cos θ × trapezoid in φ over the unit sphere (weights sum to 1)."""
    u, wu = np.polynomial.legendre.leggauss(n)
    nphi = 2 * n
    phi = 2 * np.pi * (np.arange(nphi) + 0.5) / nphi
    st = np.sqrt(1 - u**2)
    dirs = np.stack([np.outer(st, np.cos(phi)).ravel(), np.outer(st, np.sin(phi)).ravel(), np.repeat(u, nphi)], 1)
    w = np.outer(wu, np.full(nphi, 1.0 / nphi)).ravel() / 2.0
    return dirs, w


def pair_interaction_coefficients(matrix, inc_r, inc_s, a_r, a_s, distances):
    """Orientation-averaged change of family r's polarization factor by one neighbour s.

    For each distance R, the two-sphere problem in the effective field (uniform
    polarizations, exterior Eshelby fields averaged over the receiving sphere) gives
    ``τ_r = Q_r^pair(R) : ε̄``; the function returns the isotropic parts
    ``(δq_K(R), δq_G(R))`` of ``⟨Q_r^pair⟩ − Q_r`` (Mandel eigenvalues), which fall as R⁻⁶.
    For isotropic phases the pair response for any direction is a rotation of the
    response along z, so the orientation average is the isotropic projection
    ``(tr(J X), tr(K X)/5)`` of the z response (exact; tests check it against an explicit
    average over directions).

    Parameters
    ----------
    matrix, inc_r, inc_s : Phase
        ``matrix`` must have finite moduli.
    a_r, a_s : float
        Radii of the receiving and the neighbouring sphere.
    distances : array_like
        Centre distances ``R >= a_r + a_s``.

    Returns
    -------
    (len(distances), 2) ndarray
    """
    m = _as_phase(matrix, "matrix")
    if math.isinf(m.shear) or m.shear <= 0:
        raise InvalidInputError(f"matrix shear={m.shear!r} must be finite and > 0")
    nu0 = m.poisson
    qk_r, qg_r, _, _ = _polarization_factors(m, inc_r)
    qk_s, qg_s, _, _ = _polarization_factors(m, inc_s)
    q_r = qk_r * _J + qg_r * _KDEV
    q_s = qk_s * _J + qg_s * _KDEV
    v_r, v_s = 4 / 3 * math.pi * a_r**3, 4 / 3 * math.pi * a_s**3
    size2 = (a_r**2 + a_s**2) / 10.0
    z = np.array([0.0, 0.0, 1.0])
    g3 = _interaction_tensor(z, m.shear, nu0, 0.0)  # R^-3 part at R = 1
    g5 = _interaction_tensor(z, m.shear, nu0, 1.0) - g3  # ∇² part at R = 1 (per unit size2)
    rr = np.atleast_1d(np.asarray(distances, dtype=np.float64))
    gam = g3[None] / rr[:, None, None] ** 3 + size2 * g5[None] / rr[:, None, None] ** 5
    eye6 = np.eye(6)[None]
    # τ_r = Q_r (ε̄ − v_s Γ τ_s),  τ_s = Q_s (ε̄ − v_r Γ τ_r)
    lhs = eye6 - v_r * v_s * q_r[None] @ gam @ q_s[None] @ gam
    rhs = q_r[None] @ (eye6 - v_s * gam @ q_s[None])
    d = np.linalg.solve(lhs, rhs) - q_r[None]
    out = np.empty((rr.size, 2))
    out[:, 0] = np.einsum("ij,nji->n", _J, d)
    out[:, 1] = np.einsum("ij,nji->n", _KDEV, d) / 5.0
    return out


def _pair_counts_3d(packing, x_max, nbins, nspecies):
    """Ordered-pair counts ``(K*K, nbins)`` of centre distances in ``[k h, (k+1) h)``, ``h = x_max/nbins``."""
    from .._kernels import analysis as kern
    from ..neighbors import choose_cells

    box = np.ascontiguousarray(packing.box, dtype=np.float64)
    pos = np.ascontiguousarray(packing.positions, dtype=np.float64)
    rad = np.ascontiguousarray(packing.radii, dtype=np.float64)
    sp = np.ascontiguousarray(packing.species, dtype=np.int64)
    nc = choose_cells(box, pos.shape[0], 0.5 * x_max)
    off = kern.half_shell_offsets(nc, box / nc, float(x_max))
    if off.shape[0] > 0:
        counts = kern.pair_histogram_distance(pos, sp, box, nspecies, float(x_max), int(nbins), nc, off)
    else:  # grid too coarse for distinct half-shell offsets: the all-neighbour sweep
        counts = kern.pair_histogram(pos, rad, sp, box, nspecies, float(x_max), int(nbins), False, nc)
    return np.asarray(counts, dtype=np.float64)


def partial_rdfs(packing, r_max, dr):
    """Partial RDFs ``g_km(r)`` of a periodic pack on shells of width ``dr`` (ordered pairs).

    ``g_km(r) = N_km(r) / (N_k ρ_m 4π r² dr)`` with ``N_km`` the ordered pairs of
    species ``k``, ``m`` whose centre distance lies in the shell (ideal-gas shell
    volume, exact for the periodic cell). Returns ``(r, g)`` with ``g`` of shape
    ``(K, K, n_bins)``, ``r`` the shell centres; ``(r, g)`` can be passed back to
    :func:`mefm` as its ``rdf``.

    The pairs are counted by the half-shell cell-sweep pair-histogram kernel
    (:func:`polypack._kernels.analysis.pair_histogram_distance`, the one behind
    :class:`polypack.analysis.RDF`; it never stores the pairs: about 10⁸ pairs for
    N = 2×10⁴ at the default range of :func:`mefm`); bins are ``[k dr, (k + 1) dr)``.
    """
    box = np.asarray(packing.box, dtype=np.float64)
    if r_max > 0.5 * box.min() * (1 + 1e-12):
        raise InvalidInputError(f"r_max={r_max:g} exceeds half the smallest box length {0.5 * box.min():g}")
    if not dr > 0:
        raise InvalidInputError(f"dr={dr!r} must be > 0")
    sp = np.asarray(packing.species, dtype=np.int64)
    k = int(sp.max()) + 1
    nb = int(np.floor(r_max / dr + 1e-9))
    if nb < 1:
        raise InvalidInputError(f"r_max={r_max:g} is shorter than one shell dr={dr:g}")
    edges = np.arange(nb + 1) * dr
    counts = _pair_counts_3d(packing, nb * dr, nb, k).reshape(k, k, nb)
    nk = np.bincount(sp, minlength=k).astype(np.float64)
    vol = float(np.prod(box))
    shell = 4.0 / 3.0 * np.pi * (edges[1:] ** 3 - edges[:-1] ** 3)
    with np.errstate(invalid="ignore", divide="ignore"):
        g = counts / (nk[:, None, None] * (nk[None, :, None] / vol) * shell[None, None, :])
    g[~np.isfinite(g)] = 0.0
    return 0.5 * (edges[1:] + edges[:-1]), g


def _resolve_statistics(inclusions, rdf, fractions, radii, r_max, dr):
    """(r grid or None, g(k, m, r) callable, fractions, radii) from the accepted inputs."""
    n_inc = len(inclusions)
    packing_like = hasattr(rdf, "positions") and hasattr(rdf, "radii") and hasattr(rdf, "box")
    if packing_like:
        if getattr(rdf, "dim", 3) != 3 or not all(getattr(rdf, "periodic", (True,) * 3)):
            raise InvalidInputError(
                f"mefm measures RDFs of 3D periodic packs only; got dim={getattr(rdf, 'dim', 3)}, "
                f"periodic={getattr(rdf, 'periodic', None)}"
            )
        sp = np.asarray(rdf.species, dtype=np.int64)
        k = int(sp.max()) + 1
        if k != n_inc:
            raise InvalidInputError(
                f"the pack has {k} species but {n_inc} inclusion phases were given; give one Phase per species"
            )
        vol = float(np.prod(rdf.box))
        rad = np.asarray(rdf.radii)
        fr = np.array([np.sum(4 / 3 * np.pi * rad[sp == s] ** 3) / vol for s in range(k)])
        rr = np.array([float(np.mean(rad[sp == s])) for s in range(k)])
        if fractions is not None or radii is not None:
            raise InvalidInputError("fractions and radii come from the pack; do not give them with a Packing")
        a_max = float(rr.max())
        r_max = min(0.5 * float(np.min(rdf.box)), 10.0 * a_max) if r_max is None else float(r_max)
        dr = (0.01 * float(rr.min())) if dr is None else float(dr)
        r, g = partial_rdfs(rdf, r_max, dr)
        return r, (lambda a, b, x: np.interp(x, r, g[a, b], right=1.0)), fr, rr
    if fractions is None or radii is None:
        raise InvalidInputError("give fractions= and radii= (one per inclusion family) with an RDF or a model")
    fr = np.atleast_1d(np.asarray(fractions, dtype=np.float64))
    rr = np.atleast_1d(np.asarray(radii, dtype=np.float64))
    if fr.shape != (n_inc,) or rr.shape != (n_inc,):
        raise InvalidInputError(f"fractions {fr.tolist()} and radii {rr.tolist()} need one entry per family ({n_inc})")
    if np.any(rr <= 0) or not np.all(np.isfinite(rr)):
        raise InvalidInputError(f"radii={rr.tolist()} must be finite and > 0")
    if isinstance(rdf, str):
        if rdf == "none":
            return None, (lambda a, b, x: np.zeros_like(x)), fr, rr
        if rdf == "well_stirred":
            return None, (lambda a, b, x: (x >= rr[a] + rr[b]).astype(np.float64)), fr, rr
        raise InvalidInputError(f"rdf={rdf!r}: allowed model names are 'none' and 'well_stirred' (or pass a callable)")
    if callable(rdf):
        return None, (lambda a, b, x: np.asarray(rdf(x, a, b), dtype=np.float64)), fr, rr
    if isinstance(rdf, tuple) and len(rdf) == 2:
        r = np.asarray(rdf[0], dtype=np.float64)
        g = np.asarray(rdf[1], dtype=np.float64)
        if r.ndim != 1 or g.shape != (n_inc, n_inc, r.size):
            raise InvalidInputError(
                f"rdf=(r, g) needs r of shape (n,) and g of shape ({n_inc}, {n_inc}, n) as from partial_rdfs; "
                f"got {r.shape} and {g.shape}"
            )
        return r, (lambda a, b, x: np.interp(x, r, g[a, b], right=1.0)), fr, rr
    if hasattr(rdf, "r") and hasattr(rdf, "partial"):
        r = np.asarray(rdf.r, dtype=np.float64)
        part = rdf.partial
        try:
            tabs = {(a, b): np.asarray(part[(a, b)], dtype=np.float64) for a in range(n_inc) for b in range(n_inc)}
        except Exception as exc:  # unknown species pair
            raise InvalidInputError(f"the RDF lacks partials for {n_inc} species: {exc}") from None
        return r, (lambda a, b, x: np.interp(x, r, tabs[(a, b)], right=1.0)), fr, rr
    raise InvalidInputError(
        f"rdf must be a Packing, a tuple (r, g), an RDF result (.r, .partial), a callable g(r, k, m), 'none' or 'well_stirred'; "
        f"got {type(rdf).__name__}"
    )


def mefm(matrix, inclusions, rdf, fractions=None, radii=None, r_max=None, dr=None, points=24,
         return_details=False):
    """Effective moduli from the partial RDFs by the pair-interaction effective field method.

    For each family ``r`` the polarization factor (Mandel eigenvalues of
    ``Q_r = (L_r − L0) T_r``, bulk and shear) gets the pair correction

    ``q̃_r = q_r + Σ_s n_s ∫_{a_r+a_s}^∞ 4π R² g_rs(R) δq_rs(R) dR``

    (``n_s`` number density of family ``s``, ``δq_rs`` from
    :func:`pair_interaction_coefficients`, tail beyond the RDF's range with
    ``g = 1`` and ``δq ∝ R⁻⁶``), and the Mori-Tanaka closure gives, per mode,
    ``λ* = λ0 + Σ c_r q̃_r / (c0 + Σ c_r t_r q̃_r / q_r)``. With ``g ≡ 0`` this is exactly
    Mori-Tanaka; splitting a family into identical ones changes nothing (the sum over
    neighbours is linear in ``n_s g_rs``).

    Parameters
    ----------
    matrix : Phase
    inclusions : Phase or sequence of Phase
        One per species of the pack (or per family of the RDF).
    rdf : Packing, (r, g), RDF result, callable, "well_stirred" or "none"
        A :class:`~polypack.Packing` (partial RDFs measured here by
        :func:`partial_rdfs`, fractions and mean radii per species from the pack), the
        tuple ``(r, g)`` that :func:`partial_rdfs` returns (a measured ``g_km``, with
        ``fractions`` and ``radii``), an object with ``.r`` and ``.partial[(k, m)]``
        such as :class:`polypack.analysis.RDF` (``scale="distance"``), a callable
        ``g(r, k, m)`` (e.g. Percus-Yevick or the seed's Willis form from
        :mod:`polypack.analysis.theory`, Eq. (20) of 000_2cedc098acbd866b.txt), or a model name
        (``"well_stirred"``: ``g = H(r − a_k − a_m)``, Eq. (19) of 000_2cedc098acbd866b.txt).
    fractions, radii : sequence of float
        Volume fraction and radius of each family (not with a Packing).
    r_max, dr : float, optional
        Range and shell width of the RDF measured from a Packing.
    points : int
        Gauss-Legendre nodes per contact distance of the R-integral (g is sampled there).
    return_details : bool
        Also return a dict with the MT values and the corrected factors.

    Returns
    -------
    Phase (and dict if ``return_details``)

    References
    ----------
    .. [1] V. A. Buryachenko, N. J. Pagano, Math. Mech. Solids 8, 403 (2003).
    .. [2] G. K. Batchelor, J. T. Green, J. Fluid Mech. 56, 401 (1972) (pair structure).
    """
    m = _as_phase(matrix, "matrix")
    inc = _as_phases(inclusions)
    if math.isinf(m.shear) or m.shear <= 0 or math.isinf(m.bulk):
        raise InvalidInputError(
            f"matrix (K={m.bulk:g}, G={m.shear:g}): MEFM needs finite matrix moduli with G > 0 "
            "(use ν slightly below 0.5 for a nearly incompressible binder)"
        )
    r_grid, gfun, fr, rr = _resolve_statistics(inc, rdf, fractions, radii, r_max, dr)
    if np.any(fr < 0) or fr.sum() >= 1:
        raise InvalidInputError(f"inclusion fractions {fr.tolist()} must be >= 0 and sum to < 1")
    c0 = 1.0 - fr.sum()
    n_dens = fr / (4 / 3 * np.pi * rr**3)
    fac = [_polarization_factors(m, p) for p in inc]
    r_end = float(r_grid[-1]) if r_grid is not None else None
    q_corr = np.array([[f[0], f[1]] for f in fac], dtype=np.float64)
    for a in range(len(inc)):
        for b in range(len(inc)):
            if n_dens[b] == 0:
                continue
            contact = rr[a] + rr[b]
            top = r_end if r_end is not None else 12.0 * contact
            if top <= contact:
                continue
            nseg = max(1, int(np.ceil((top - contact) / contact)))
            x, w = np.polynomial.legendre.leggauss(points)
            edges = np.linspace(contact, top, nseg + 1)
            rs = np.concatenate([0.5 * (e1 - e0) * x + 0.5 * (e1 + e0) for e0, e1 in zip(edges[:-1], edges[1:])])
            ws = np.concatenate([0.5 * (e1 - e0) * w for e0, e1 in zip(edges[:-1], edges[1:])])
            gv = gfun(a, b, rs)
            if not np.any(gv):
                continue
            dq = pair_interaction_coefficients(m, inc[a], inc[b], rr[a], rr[b], rs)
            integ = np.sum((ws * 4 * np.pi * rs**2 * gv)[:, None] * dq, axis=0)
            # tail R > top with g = 1 and dq ~ C R^-6
            dq_top = pair_interaction_coefficients(m, inc[a], inc[b], rr[a], rr[b], [top])[0]
            integ += 4 * np.pi * dq_top * top**3 / 3.0 * float(gfun(a, b, np.array([top * 1.0000001]))[0] != 0)
            q_corr[a] += n_dens[b] * integ
    lam0 = np.array([3 * m.bulk, 2 * m.shear])
    out = []
    for mode in (0, 1):
        num, den = 0.0, c0
        for a, f in enumerate(fac):
            q, t = f[mode], f[mode + 2]
            num += fr[a] * q_corr[a, mode]
            den += fr[a] * (t * q_corr[a, mode] / q if q != 0 else t)
        out.append(lam0[mode] + num / den)
    res = Phase(bulk=out[0] / 3.0, shear=out[1] / 2.0)
    if return_details:
        return res, {"q_mt": np.array([[f[0], f[1]] for f in fac]), "q_pair": q_corr, "fractions": fr, "radii": rr}
    return res
