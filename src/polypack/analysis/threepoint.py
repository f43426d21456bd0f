"""Three-point microstructural parameters ζ2 and η2 of sphere packs.

Torquato's parameters (Random Heterogeneous Materials, 2002, §20-21) enter the
three-point bounds on effective conductivity and elastic moduli. For phase 2 (the
spheres, volume fraction φ2 = 1 − φ1)::

    ζ2 = 9/(2 φ1 φ2) ∫0^∞ dr/r ∫0^∞ ds/s ∫_{-1}^{1} du P2(u) [S3(r, s, t) − S2(r) S2(s)/φ2],
    η2 = 5 ζ2/21 + 150/(7 φ1 φ2) ∫0^∞ dr/r ∫0^∞ ds/s ∫_{-1}^{1} du P4(u) [S3 − S2 S2/φ2],

with S2, S3 the two- and three-point probabilities of phase 2 and u the cosine of the
angle between r and s. The S2 S2 term vanishes after the angular integration of an
isotropic medium, and the estimator evaluates the S3 term of the given pack exactly
for its spheres:

* ``∫∫ d³r d³s P_l(r̂·ŝ)/(r³ s³) m_j(x + r) m_k(x + s)`` factors through the addition
  theorem into "fields" of the balls ``j``, ``k`` at the point ``x``; the exterior
  field of a uniform ball is that of its centre times its volume for l = 2 and times
  ``1 − 7 a²/(5 D²)`` for l = 4, and a ball's field on its own interior vanishes;
* the point ``x`` runs over every sphere ``i`` of the pack: the pair terms ``j = k``
  are integrated over the ball in closed form, the triplet terms ``j ≠ k`` by a Gauss
  rule on the ball;
* neighbours enter within a spherical cutoff (the spherical order of summation of
  the conditionally convergent sums; the field of a uniform ball vanishes inside it,
  so the truncation has no surface term).

These exact reductions reproduce the dilute coefficients ζ2 = 0.21068 φ2 and
η2 = 0.48274 φ2 of hard spheres, and the exact sums ζ1 + ζ2 = 1, η1 + η2 = 1 follow
from the mean-square fields over the whole cell (tests).

References
----------
.. [1] S. Torquato, *Random Heterogeneous Materials*, Springer (2002), ch. 20-23.
.. [2] C. A. Miller, S. Torquato, J. Appl. Phys. 68, 5486 (1990) (ζ2 of hard spheres).
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError
from ._base import Estimator, check_packing, check_positive, to_jsonable

__all__ = ["ThreePointParameters", "ball_quadrature", "harmonic_weights"]


def ball_quadrature(radial_nodes=6, angular_nodes=8):
    """Product Gauss rule on the unit ball: nodes (Q, 3) and weights summing to 4π/3.

    Gauss-Legendre in the radius (weight ρ²) and in cos θ, the trapezoid rule in φ
    (``2 angular_nodes`` points); exact for polynomials of degree ``2 radial_nodes − 3``
    in ρ and ``2 angular_nodes − 1`` on the sphere.
    """
    nr, nu = int(radial_nodes), int(angular_nodes)
    if nr < 1 or nu < 1:
        raise InvalidInputError(f"radial_nodes={radial_nodes}, angular_nodes={angular_nodes} must be >= 1")
    xr, wr = np.polynomial.legendre.leggauss(nr)
    rho = 0.5 * (xr + 1.0)
    wrho = 0.5 * wr * rho**2
    u, wu = np.polynomial.legendre.leggauss(nu)
    nphi = 2 * nu
    phi = 2 * np.pi * (np.arange(nphi) + 0.5) / nphi
    wphi = np.full(nphi, 2 * np.pi / nphi)
    st = np.sqrt(1.0 - u**2)
    dirs = np.stack(
        [np.outer(st, np.cos(phi)).ravel(), np.outer(st, np.sin(phi)).ravel(), np.repeat(u, nphi)], axis=1
    )
    wdir = np.outer(wu, wphi).ravel()
    pts = (rho[:, None, None] * dirs[None, :, :]).reshape(-1, 3)
    w = (wrho[:, None] * wdir[None, :]).ravel()
    return np.ascontiguousarray(pts), np.ascontiguousarray(w)


_HARMONIC_WEIGHTS = None


def _monomials(pts, degree):
    cols = []
    for i in range(degree + 1):
        for j in range(degree + 1 - i):
            for k in range(degree + 1 - i - j):
                cols.append(pts[:, 0] ** i * pts[:, 1] ** j * pts[:, 2] ** k)
    return np.stack(cols, axis=1)


def far_field_interpolation(fine_pts, coarse_pts, degree=3):
    """``(Q, C)`` matrix mapping values at coarse nodes to the fitted degree-``degree``
    polynomial's values at the fine nodes (least squares)."""
    vc = _monomials(coarse_pts, degree)
    vf = _monomials(fine_pts, degree)
    return np.ascontiguousarray(vf @ np.linalg.pinv(vc))


def harmonic_weights():
    """``(inv2, inv4)`` with ``Σ_m inv_m b_m(u) b_m(u') = P_l(u·u')`` for the kernel's basis."""
    global _HARMONIC_WEIGHTS
    if _HARMONIC_WEIGHTS is None:
        from .._kernels.threepoint import _basis

        pts, w = ball_quadrature(1, 12)  # radius 1/2 node: directions only
        dirs = pts / np.linalg.norm(pts, axis=1)[:, None]
        wd = w / w.sum() * 4 * np.pi
        b2, b4 = np.empty(5), np.empty(9)
        c2, c4 = np.zeros(5), np.zeros(9)
        for d, wi in zip(dirs, wd):
            _basis(d[0], d[1], d[2], b2, b4)
            c2 += wi * b2**2
            c4 += wi * b4**2
        _HARMONIC_WEIGHTS = (4 * np.pi / 5) / c2, (4 * np.pi / 9) / c4
    return _HARMONIC_WEIGHTS


class ThreePointParameters(Estimator):
    """Torquato's three-point parameters ζ2 and η2 of the spheres of a periodic pack.

    Parameters
    ----------
    cutoff : float, optional
        Centre distance within which neighbours enter (spherical truncation of the
        conditionally convergent sums), in length units; default
        ``min(L/2, 8 ⟨a⟩)`` with ``⟨a⟩`` the volume-weighted mean radius. The
        truncation error falls as ``(a/cutoff)³`` times the pack's compressibility.
    radial_nodes, angular_nodes : int
        Gauss rule on each ball for the triplet terms (see :func:`ball_quadrature`).
    near_factor : float
        Neighbours closer than ``near_factor`` host radii are evaluated at every node
        (pair terms in closed form); the smooth field of farther ones is sampled on 64
        coarse nodes and interpolated by a cubic polynomial (error ~ ``near_factor⁻⁴``
        of that field's variation on the ball).

    Attributes
    ----------
    zeta2, eta2 : float
        Pooled over the realizations accumulated with ``reset=False`` (mean of the
        per-pack values).
    zeta2_stderr, eta2_stderr : float
        Standard error between realizations (NaN for one).
    zeta1, eta1 : float
        ``1 − zeta2``, ``1 − eta2`` (the matrix's parameters).

    Notes
    -----
    The spheres are phase 2 and may be polydisperse; the matrix is phase 1. The
    estimator reads only centres and radii: ``species`` do not matter. Cost is
    ``O(N n_c Q)`` for ``n_c`` neighbours within the cutoff and ``Q`` quadrature nodes.

    References
    ----------
    .. [1] S. Torquato, *Random Heterogeneous Materials*, Springer (2002), ch. 20-23.
    """

    def __init__(self, cutoff=None, radial_nodes=4, angular_nodes=6, near_factor=5.0):
        super().__init__()
        self.cutoff = None if cutoff is None else check_positive("cutoff", cutoff)
        self.near_factor = check_positive("near_factor", near_factor)
        self._qpts, self._qw = ball_quadrature(radial_nodes, angular_nodes)
        self._cpts, _ = ball_quadrature(2, 4)
        self._interp = far_field_interpolation(self._qpts, self._cpts, 3)
        self.radial_nodes, self.angular_nodes = int(radial_nodes), int(angular_nodes)

    def _cutoff_for(self, packing):
        half = 0.5 * float(np.min(packing.box))
        if self.cutoff is None:
            r = packing.radii
            amean = float(np.sum(r**4) / np.sum(r**3))
            return min(half, 8.0 * amean)
        if self.cutoff > half * (1 + 1e-12):
            raise InvalidInputError(
                f"cutoff={self.cutoff:g} exceeds half the smallest box length {half:g}; "
                "use cutoff <= L/2 or a larger pack"
            )
        return self.cutoff

    def compute(self, packing, reset=True):
        """Add ``packing`` (3D, periodic) as a realization; returns ``self``."""
        check_packing(packing, min_n=2, what="ThreePointParameters")
        if getattr(packing, "dim", 3) != 3:
            raise InvalidInputError(f"ThreePointParameters needs a 3D pack, got dim={packing.dim}")
        periodic = getattr(packing, "periodic", (True, True, True))
        if not all(periodic):
            raise InvalidInputError(f"ThreePointParameters needs a periodic pack, got periodic={periodic}")
        if reset:
            self.reset()
        from .._kernels.threepoint import OUT_J2, OUT_J4, OUT_NEIGHBOURS, three_point_sums
        from ..neighbors import choose_cells

        cutoff = self._cutoff_for(packing)
        pos = np.ascontiguousarray(packing.positions, dtype=np.float64)
        rad = np.ascontiguousarray(packing.radii, dtype=np.float64)
        box = np.ascontiguousarray(packing.box, dtype=np.float64)
        nc = choose_cells(box, packing.n, 0.5 * cutoff)
        inv2, inv4 = harmonic_weights()
        out = three_point_sums(pos, rad, box, float(cutoff), self.near_factor, nc, self._qpts, self._qw,
                               self._cpts, self._interp, inv2, inv4)
        volume = float(np.prod(box))
        phi2 = float(np.sum(4.0 / 3.0 * np.pi * rad**3)) / volume
        phi1 = 1.0 - phi2
        j2 = float(out[:, OUT_J2].sum()) / (8 * np.pi**2 * volume)
        j4 = float(out[:, OUT_J4].sum()) / (8 * np.pi**2 * volume)
        zeta2 = 9.0 * j2 / (2.0 * phi1 * phi2)
        eta2 = 5.0 * zeta2 / 21.0 + 150.0 * j4 / (7.0 * phi1 * phi2)
        self._frames.append(
            {
                "zeta2": np.float64(zeta2),
                "eta2": np.float64(eta2),
                "volume_fraction": np.float64(phi2),
                "cutoff": np.float64(cutoff),
                "mean_neighbours": np.float64(out[:, OUT_NEIGHBOURS].mean()),
            }
        )
        return self

    def _mean(self, name):
        self._require()
        return float(np.mean(self._stack(name)))

    @property
    def zeta2(self) -> float:
        return self._mean("zeta2")

    @property
    def eta2(self) -> float:
        return self._mean("eta2")

    @property
    def zeta1(self) -> float:
        return 1.0 - self.zeta2

    @property
    def eta1(self) -> float:
        return 1.0 - self.eta2

    @property
    def zeta2_stderr(self) -> float:
        self._require()
        return float(self._stderr(self._stack("zeta2")))

    @property
    def eta2_stderr(self) -> float:
        self._require()
        return float(self._stderr(self._stack("eta2")))

    @property
    def volume_fraction(self) -> float:
        """Mean sphere volume fraction φ2 of the accumulated packs."""
        return self._mean("volume_fraction")

    @property
    def per_realization(self):
        """Dict of arrays: ``zeta2``, ``eta2``, ``volume_fraction`` of every realization."""
        self._require()
        return {k: self._stack(k) for k in ("zeta2", "eta2", "volume_fraction")}

    def to_dict(self):
        self._require()
        return to_jsonable(
            {
                "zeta2": self.zeta2,
                "eta2": self.eta2,
                "zeta2_stderr": self.zeta2_stderr,
                "eta2_stderr": self.eta2_stderr,
                "volume_fraction": self.volume_fraction,
                "n_realizations": self.n_realizations,
                "cutoff": self._stack("cutoff"),
                "per_realization": self.per_realization,
            }
        )

    def plot(self, ax=None):
        """ζ2 and η2 of every realization against its volume fraction, with the dilute lines."""
        ax = self._axes(ax)
        d = self.per_realization
        ax.plot(d["volume_fraction"], d["zeta2"], "o", label="ζ2 (pack)")
        ax.plot(d["volume_fraction"], d["eta2"], "s", label="η2 (pack)")
        c = np.linspace(0, max(0.05, float(np.max(d["volume_fraction"]))), 50)
        ax.plot(c, 0.21068 * c - 0.04693 * c**2, "-", label="ζ2, Miller-Torquato quadratic")
        ax.plot(c, 0.48274 * c, "--", label="η2, dilute slope 0.48274 φ2")
        ax.set_xlabel("sphere volume fraction φ2 (–)")
        ax.set_ylabel("three-point parameter (–)")
        ax.legend()
        return ax
