"""Rigidity of a bonded network: floppy modes, rigid clusters, load-bearing backbone, non-affinity, fabric.

Seed 003 ends (§4 of 003_873b69fc71c74cf6.txt) asking for "an intermediate step, such as
an analysis of the distribution of particle contacts using the fabric tensor ... or of
load-bearing substructures" between the degree of heterogeneity and the plateau modulus
``G'_p``. :func:`rigidity` is that step for the bonded network of
:class:`~polypack.mechanics.BondNetwork` (PFC contact bonds: normal and shear springs,
Eq. (1) of 003_873b69fc71c74cf6.txt and Eq. (2) of 003_873b69fc71c74cf6.txt, acting at the
contact point, no moment).

Counting. A particle has ``nd = 6`` degrees of freedom (translation and rotation) and a
contact bond pins the 3 components of the relative displacement of the contact point, so
Maxwell's count makes ``Z_c = 2 nd / 3 = 4 = d + 1`` the isostatic coordination in 3D
(central springs: ``nd = 3``, one constraint per bond, ``Z_c = 6``). The index theorem
(Calladine) reads ``F - S = nd N - c M - pinned`` with ``F`` the floppy modes, ``S`` the
states of self-stress and ``c`` the constraints per bond.

Method. The floppy (zero) modes are the null space of the bond-deformation operator
``delta = B q`` (``H = B^T K B``, the Hessian of :func:`~polypack.mechanics.elastic_tensor`).
Their number is counted exactly by Sylvester's law of inertia on one sparse factorization
of ``H - tau D`` (``tau = 1e-9``, ``D = diag H``: the count of
:func:`~polypack.mechanics.elastic_tensor`), and random vectors of the null space are
drawn by three sweeps of shifted inverse iteration with that factor
(:func:`polypack.mechanics._elastic_solvers._null_samples`). A random combination of zero modes is
non-zero on every degree of freedom any zero mode moves (with probability one), so a
handful of samples decide, bond by bond, whether the two particles move as one rigid body
in *every* zero mode: for a contact bond (its contact point is shared) that is equal
rotations, ``|w_j - w_i| <= tol`` times the sample's RMS amplitude in every sample. The
rigid clusters are the connected components of the rigid bonds; one that closes a loop
through the periodic boundary along every axis (unwrapped images) percolates. The cost is
that one factorization plus ``3 k`` solves (``k`` samples): with
``elastic_tensor(..., floppy_samples=k)`` the factor of the elastic solve is reused.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError

__all__ = ["Rigidity", "rigidity", "fabric_tensor", "deviatoric_norm", "SHEAR_PLANES"]

#: Voigt strain names (engineering shears), the order of the six columns of the tensors.
MODES = ("11", "22", "33", "23", "13", "12")
#: The shear modes (Voigt columns 3, 4, 5) and their planes' axes (yz, xz, xy).
SHEAR_PLANES = ((1, 2), (0, 2), (0, 1))
# Relative defect (per sample RMS amplitude) below which a bond is rigid in a zero mode.
_RIGID_TOL = 1e-6
# Eigenvalue threshold of the count (generalized eigenvalues of H v = mu D v).
_TAU = 1e-9
# A relaxed bond force below this fraction of the mean affine bond force of the same unit
# strain is round-off, not load (elastic_tensor's FLOPPY_TOLERANCE is 1e-8 on moduli, i.e.
# 1e-4 on forces, which scale as the square root of the energy).
_FORCE_FLOOR = 1e-4
_VOIGT_PAIRS = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))


def fabric_tensor(normals, weights=None) -> np.ndarray:
    """Fabric tensor ``<n n^T>`` of unit bond normals (``I / 3`` when isotropic).

    Parameters
    ----------
    normals : (M, 3) array_like
    weights : (M,) array_like, optional
        Non-negative weights (e.g. a bond mask or the bond forces); default equal.
    """
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    w = np.ones(n.shape[0]) if weights is None else np.asarray(weights, dtype=np.float64)
    tot = float(w.sum())
    if n.shape[0] == 0 or tot <= 0:
        return np.full((3, 3), np.nan)
    return (n * w[:, None]).T @ n / tot


def deviatoric_norm(f) -> float:
    """Frobenius norm of the deviator ``F - tr(F) I / 3`` (0 for an isotropic fabric).

    For a fabric with eigenvalues ``1/3 + (2a/3, -a/3, -a/3)`` (axisymmetric) it is
    ``a sqrt(2/3)``.
    """
    f = np.asarray(f, dtype=np.float64)
    dev = f - np.trace(f) / 3.0 * np.eye(3)
    return float(np.sqrt(np.sum(dev * dev)))


def _fourth_shear(normals, weights=None):
    """``<n_a^2 n_b^2>`` for the shear planes yz, xz, xy (the fabric a plate shear sees)."""
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    w = np.ones(n.shape[0]) if weights is None else np.asarray(weights, dtype=np.float64)
    tot = float(w.sum())
    if tot <= 0:
        return np.full(3, np.nan)
    return np.array([float(np.sum(w * n[:, a] ** 2 * n[:, b] ** 2)) / tot for a, b in SHEAR_PLANES])


class Rigidity:
    """Rigidity analysis of a bonded network (see :func:`rigidity`).

    Attributes
    ----------
    floppy_modes : int
        Zero modes of the relaxing part (clusters that wrap the box, rattlers removed,
        one particle's translations pinned per cluster): the count of
        :func:`~polypack.mechanics.elastic_tensor` (generalized eigenvalues below 1e-9).
    floppy_modes_floating : int
        Internal zero modes of the bonded clusters that do not wrap the box (their rigid
        rotations removed).
    states_of_self_stress : int
        ``S = F - (nd N_a - c M_a - 3 K_a)`` on the relaxing part (index theorem; ``N_a``
        particles, ``M_a`` bonds, ``K_a`` clusters, ``c`` = 3 constraints per contact
        bond, 1 per central spring).
    isostatic_coordination : float
        ``2 nd / c``: 4 for contact bonds with rotations, 2 without, 6 for central springs.
    participation : (N,) ndarray
        Share of each particle in the floppy space: ``sum_k |D_p^1/2 v_kp|^2`` over a
        ``D``-orthonormal basis of the zero modes, estimated from the samples (it sums to
        the number of zero modes); NaN for rattlers.
    cluster : (N,) int64
        Rigid-cluster label (0 the largest), -1 for rattlers; a particle in no rigid bond
        is a cluster of its own.
    cluster_sizes : (K,) int64
        Particles per cluster, largest first (``central=True``: per rigid body, hinge
        particles counted in every body they belong to).
    percolating : bool
        A rigid cluster closes a loop through the periodic boundary along every periodic
        axis.
    spans : (dim,) bool
        The axes the largest-spanning rigid cluster wraps.
    rigid_bonds : (M,) bool
        Bonds whose two particles move as one rigid body in every zero mode.
    rattlers : (N,) bool
        Particles left out (contact bonds: fewer than two bonds, recursively; central:
        no bond).
    backbone_bonds : (6, M) bool or None
        Bonds carrying a force above ``force_fraction`` times the mean bond force of the
        relaxing part under each unit strain (Voigt order 11, 22, 33, 23, 13, 12).
    backbone : (N,) bool or None
        Particles joined by a backbone bond of any of the six strains.
    backbone_fraction : float or None
        ``backbone.mean()``.
    backbone_coordination : float or None
        ``2 M_b / N_b`` of the union backbone (bonds in it over the particles they join;
        None without a backbone); ``backbone_coordination_modes`` per strain (NaN where empty).
    nonaffinity : float or None
        ``Gamma = <|u - u_aff|^2> / (gamma^2 d^2)`` averaged over the three unit shears
        (``d`` the mean diameter, the mean over the relaxing particles);
        ``nonaffinity_modes`` per strain.
    fabric, backbone_fabric : (3, 3) ndarray
        ``<n n^T>`` over all bonds and over the union backbone; ``fabric_anisotropy`` and
        ``backbone_fabric_anisotropy`` their :func:`deviatoric_norm`;
        ``shear_fabric`` and ``backbone_shear_fabric`` the fourth-order ``<n_a^2 n_b^2>``
        of the planes yz, xz, xy (backbone: that shear's own backbone).
    """

    def __init__(self, **kw):
        for k, v in kw.items():
            setattr(self, k, v)

    @property
    def largest_cluster_fraction(self) -> float:
        """Fraction of all particles in the largest rigid cluster."""
        return float(self.cluster_sizes[0]) / self.n_particles if len(self.cluster_sizes) else 0.0

    @property
    def n_rattlers(self) -> int:
        return int(np.count_nonzero(self.rattlers))

    @property
    def rigid_fraction(self) -> float:
        """Fraction of particles in rigid clusters of at least two particles."""
        big = np.flatnonzero(np.asarray(self.cluster_sizes) >= 2)
        return float(np.isin(self.cluster, big).mean())

    @property
    def excess_coordination(self):
        """``backbone_coordination - isostatic_coordination`` (None without a backbone)."""
        if self.backbone_coordination is None:
            return None
        return self.backbone_coordination - self.isostatic_coordination

    def viewer_fields(self, mode="13") -> dict:
        """Per-particle colour fields for the report's 3D viewer (``pp.report.report(pack,
        fields=r.viewer_fields())``): ``backbone`` (1 in the load-bearing backbone of any unit
        strain, else 0), ``rigid_cluster`` (the 11 largest rigid clusters 0-10, every other
        sphere and the rattlers 11), ``nonaffine_displacement`` (``|u - u_aff|`` per unit
        strain of ``mode``, in mean diameters; 0 where undetermined) and
        ``floppy_participation`` (0 for rattlers)."""
        if str(mode) not in MODES:
            raise InvalidInputError(f"mode={mode!r}: allowed are {', '.join(MODES)} (Voigt, engineering shear)")
        out = {"rigid_cluster": np.where((self.cluster >= 0) & (self.cluster < 11), self.cluster, 11),
               "floppy_participation": np.nan_to_num(self.participation, nan=0.0)}
        if self.backbone is not None:
            out["backbone"] = self.backbone.astype(np.int64)
        et = self.elastic
        if et is not None:
            u = np.asarray(et.nonaffine_displacements)[MODES.index(str(mode))]
            out["nonaffine_displacement"] = np.nan_to_num(np.linalg.norm(u, axis=1) / float(et.length_scale), nan=0.0)
        return out

    def to_dict(self) -> dict:
        """Plain data for JSON (per-particle and per-bond arrays left out)."""
        def opt(x):
            return None if x is None else (np.asarray(x).tolist() if np.ndim(x) else float(x))

        return {
            "central": self.central,
            "rotations": self.rotations,
            "n_particles": self.n_particles,
            "n_bonds": self.n_bonds,
            "coordination": self.coordination,
            "isostatic_coordination": self.isostatic_coordination,
            "floppy_modes": self.floppy_modes,
            "floppy_modes_floating": self.floppy_modes_floating,
            "states_of_self_stress": self.states_of_self_stress,
            "floppy_per_particle": self.floppy_modes / self.n_particles,
            "n_rattlers": self.n_rattlers,
            "n_clusters": int(len(self.cluster_sizes)),
            "largest_cluster": int(self.cluster_sizes[0]) if len(self.cluster_sizes) else 0,
            "largest_cluster_fraction": self.largest_cluster_fraction,
            "rigid_fraction": self.rigid_fraction,
            "rigid_bond_fraction": float(np.mean(self.rigid_bonds)),
            "percolating": bool(self.percolating),
            "spans": [bool(s) for s in self.spans],
            "force_fraction": self.force_fraction,
            "backbone_fraction": opt(self.backbone_fraction),
            "backbone_bond_fraction": opt(self.backbone_bond_fraction),
            "backbone_coordination": opt(self.backbone_coordination),
            "excess_coordination": opt(self.excess_coordination),
            "backbone_coordination_modes": opt(self.backbone_coordination_modes),
            "nonaffinity": opt(self.nonaffinity),
            "nonaffinity_modes": opt(self.nonaffinity_modes),
            "fabric": opt(self.fabric),
            "fabric_anisotropy": opt(self.fabric_anisotropy),
            "backbone_fabric": opt(self.backbone_fabric),
            "backbone_fabric_anisotropy": opt(self.backbone_fabric_anisotropy),
            "shear_fabric": opt(self.shear_fabric),
            "backbone_shear_fabric": opt(self.backbone_shear_fabric),
            "samples": self.samples,
            "seconds": self.seconds,
        }

    def __repr__(self) -> str:
        return (f"Rigidity(floppy={self.floppy_modes}, clusters={len(self.cluster_sizes)}, "
                f"largest={self.largest_cluster_fraction:.3f}, percolating={self.percolating}, "
                f"backbone={self.backbone_fraction})")


def _backend():
    from ._elastic_solvers import _pardiso_module

    return "pardiso" if _pardiso_module() is not None else "superlu"


def _nullspace(network, mask, *, rotations, central, samples):
    """Count and sample the zero modes of the bonds among the particles ``mask``.

    One particle's translations are pinned per bonded cluster. Returns a dict: ``count``
    (zero modes, inertia of ``H - tau D``), ``z`` ((S, N, nd) samples, NaN outside
    ``mask``), ``d`` ((N, nd) the diagonal of ``H``), ``label``/``spans`` of the clusters
    (over all N) and the reindexed bond arrays.
    """
    import scipy.sparse as sp

    from .._kernels import network as knl
    from ._elastic_solvers import _null_samples, _Pardiso, _positive_factor, _SuperLU
    from .elastic import _hessian

    n_all = network.n
    nd = 3 if (central or not rotations) else 6
    on = mask[network.i] & mask[network.j]
    idx = np.full(n_all, -1, np.int64)
    idx[mask] = np.arange(int(mask.sum()))
    n = int(mask.sum())
    bi, bj = idx[network.i[on]], idx[network.j[on]]
    kn = np.ascontiguousarray(network.normal_stiffness[on])
    ks = np.zeros_like(kn) if central else np.ascontiguousarray(network.shear_stiffness[on])
    rad = np.asarray(network.packing.radii, dtype=np.float64)
    ell = float(rad[mask].mean())
    h, _, _ = _hessian(n, bi, bj, kn, ks, np.ascontiguousarray(network.normal[on]),
                       np.ascontiguousarray(network.branch[on]), np.ascontiguousarray(network.lever_arm_i[on]),
                       np.ascontiguousarray(network.lever_arm_j[on]), ell, nd == 6)
    live = np.ones(bi.size, np.int64)
    lab, _, spans = knl.components(n, bi, bj, np.ascontiguousarray(network.shift[on]), live)
    first = np.unique(lab, return_index=True)[1]
    keep = np.ones(n * nd, bool)
    keep[(first[:, None] * nd + np.arange(3)[None, :]).ravel()] = False
    # an unknown without stiffness (a zero row of the positive semi-definite H, e.g. the
    # sideways motion of a central-force dimer) is a zero mode of its own
    dk = h.diagonal()
    free = keep & (dk <= 1e-14 * max(float(dk.max()), 1e-300))
    keep &= ~free
    hr = h.tocsr()[keep][:, keep]
    d = hr.diagonal()
    backend = _backend()
    cls = _Pardiso if backend == "pardiso" else _SuperLU
    count = int(free.sum())
    z = None
    if d.size:
        shifted = cls(hr - sp.diags(_TAU * d), -2)
        neg = shifted.negative
        if neg is None:  # SuperLU pivoted off the diagonal: count densely (small systems only)
            ev = np.linalg.eigvalsh((hr / np.sqrt(np.outer(d, d))).toarray())
            neg = int(np.count_nonzero(ev < _TAU))
        count += int(neg)
        if samples:
            if backend == "pardiso":
                z = _null_samples(shifted.solve, d, -_TAU, samples)
            else:
                shifted.free()
                shifted = _positive_factor(_SuperLU, hr, d, _TAU)
                z = _null_samples(shifted.solve, d, _TAU, samples)
        shifted.free()
    zf = np.zeros((n * nd, samples))
    dref = float(d.mean()) if d.size else 1.0
    if z is not None:
        zf[keep] = z
    if samples and free.any():
        zf[free] = np.random.default_rng(7).standard_normal((int(free.sum()), samples)) / np.sqrt(dref)
    zs = np.full((samples, n_all, nd), np.nan)
    zs[:, mask] = zf.reshape(n, nd, samples).transpose(2, 0, 1)
    df = np.zeros(n * nd)
    df[keep] = d
    df[free] = dref
    dd = np.zeros((n_all, nd))
    dd[mask] = df.reshape(n, nd)
    label = np.full(n_all, -1, np.int64)
    label[mask] = lab
    return dict(count=int(count), z=zs, d=dd, label=label, spans=spans.astype(bool), nd=nd,
                on=on, pinned=np.flatnonzero(mask)[first], ell=ell)


def _remove_rigid_rotations(network, res, comps, nd, central):
    """Take the rigid rotations of the floating clusters ``comps`` out of the samples.

    After one particle's translations are pinned, a cluster that does not wrap the box
    still turns freely: ``theta`` (3) about the pinned particle, ``u = theta x (x - x_p)``
    on unwrapped positions. Each sample loses its ``D``-orthogonal projection on these
    modes; returns the number of independent rotations removed (2 for a collinear
    cluster, 3 otherwise).
    """
    from .._kernels import rigidity as kr

    on = res["on"]
    pos = np.asarray(network.packing.positions, dtype=np.float64)
    box = np.asarray(network.packing.box, dtype=np.float64)
    img = kr.unwrap_images(network.n, network.i, network.j, network.shift, on.astype(np.int64))
    xu = pos + img * box
    ell = res["ell"]
    removed = 0
    for c in comps:
        members = np.flatnonzero(res["label"] == c)
        p = [q for q in res["pinned"] if res["label"][q] == c][0]
        r = xu[members] - xu[p]
        modes = np.zeros((3, members.size, nd))
        for a in range(3):
            th = np.zeros(3)
            th[a] = 1.0
            modes[a, :, :3] = np.cross(th, r)
            if nd == 6:
                modes[a, :, 3:] = ell * th
        dm = res["d"][members]
        m = modes.reshape(3, -1)
        w = dm.reshape(-1)
        g = (m * w) @ m.T
        ev, vec = np.linalg.eigh(g)
        ok = ev > 1e-10 * max(ev.max(), 1e-300)
        removed += int(ok.sum())
        if res["z"].shape[0] == 0:
            continue
        basis = (vec[:, ok].T @ m) / np.sqrt(ev[ok])[:, None]  # D-orthonormal rows
        zc = res["z"][:, members].reshape(res["z"].shape[0], -1)
        zc = zc - ((zc * w) @ basis.T) @ basis
        res["z"][:, members] = zc.reshape(res["z"].shape[0], members.size, nd)
    return removed


def rigidity(network, elastic=None, *, rotations=True, central=False, force_fraction=0.01, samples=8,
             rigid_tol=_RIGID_TOL):
    """Rigidity analysis of a bonded network: floppy modes, rigid clusters, backbone, non-affinity.

    The intermediate step between structure and stiffness that seed 003 asks for
    (§4 of 003_873b69fc71c74cf6.txt: "load-bearing substructures" and "the fabric
    tensor"), for the contact-bond network of Eq. (1) of 003_873b69fc71c74cf6.txt and
    Eq. (2) of 003_873b69fc71c74cf6.txt.

    Parameters
    ----------
    network : BondNetwork
        A stress-free network in a fully periodic 3D box.
    elastic : ElasticTensor, optional
        ``elastic_tensor(network, rotations=rotations, floppy_samples=k)`` if already
        made (its relaxed fields give the backbone and the non-affinity; its samples and
        count the floppy modes). Default: computed here with ``floppy_samples=samples``.
        Ignored with ``central=True``.
    rotations : bool, default True
        Particles rotate (6 degrees of freedom; isostatic at Z = 4). ``False``:
        translations only (every bond then makes its pair rigid; Z_c = 2).
    central : bool, default False
        Treat every bond as a central spring (``k_s = 0``: one constraint per bond,
        particles as points, Z_c = 6; the bar-joint rigidity of the bond graph). Counts
        and clusters only: no backbone, non-affinity (the elastic tensor needs
        ``k_s > 0``). Rigid clusters are then sets of bonds (two bonds at a particle are
        in one when the triangle they span moves rigidly); a particle shared by several
        (a hinge) is labelled with the largest.
    force_fraction : float, default 0.01
        A bond is in the backbone of a unit strain when its force exceeds this fraction
        of the mean bond force of the relaxing part (floppy dangling parts carry exactly
        none: any small fraction separates them; 1.0 gives the "strong" network), and
        1e-4 of the mean affine bond force of that strain (below it a force is round-off:
        a floppy strain mode has no backbone).
    samples : int, default 8
        Random zero-mode vectors drawn to decide the rigid clusters and participation.
    rigid_tol : float, default 1e-6
        Relative defect below which a bond counts as rigid in a sample.

    Returns
    -------
    Rigidity

    Raises
    ------
    InvalidInputError
        For a 2D packing, walls, or bad options.
    """
    import time

    t0 = time.perf_counter()
    ff, samples = _check_rigidity(network, elastic, rotations, central, force_fraction, samples, rigid_tol)
    n_all, m_all = network.n, network.n_bonds
    nd = 3 if (central or not rotations) else 6
    cons = 1 if central else 3

    # ------------------------------------------------------------- zero modes
    if central:
        et = None
        rattlers, label, z, dmet, active, floppy, floppy_floating = _zero_modes_central(network, samples, nd)
    else:
        rattlers, label, z, dmet, active, floppy, floppy_floating, et = _zero_modes_bonded(
            network, elastic, rotations, samples, nd)

    # --------------------------------------------------------- participation
    zz = np.where(np.isfinite(z), z, 0.0)
    part_all = np.sum(dmet[None] * zz * zz, axis=2).mean(axis=0)
    participation = np.where(rattlers, np.nan, part_all)
    # the scale of a zero mode in a sample: D-normalized modes move an unknown by ~ D^-1/2
    # (the sample's own RMS would blow round-off up to O(1) where there is no zero mode)
    dpos = dmet[~rattlers]
    dpos = dpos[dpos > 0]
    amp = np.full(samples, float(np.sqrt(np.mean(1.0 / dpos))) if dpos.size else 0.0)

    # ---------------------------------------------------------- rigid clusters
    if central:
        raw, rigid_bonds, spans_any, perc, bsize = _rigid_bodies_central(network, rattlers, zz, amp, rigid_tol)
    else:
        raw, rigid_bonds, spans_any, perc = _rigid_clusters(network, rattlers, zz, amp, rigid_tol, nd)
        bsize = None
    cluster, cluster_sizes = _relabel_clusters(raw, rattlers, bsize)

    # ------------------------------------------------------- counting (index theorem)
    bi, bj = network.i, network.j
    n_a = int(active.sum())
    on_a = active[bi] & active[bj]
    k_a = int(np.unique(np.where(active, label, -1)[active]).size)
    maxwell = nd * n_a - cons * int(on_a.sum()) - 3 * k_a
    sss = int(floppy - maxwell)

    # ------------------------------------------------- backbone, non-affinity, fabric
    normals = np.asarray(network.normal)
    bb = _backbone(network, et, active, on_a, ff)
    fab = fabric_tensor(normals)
    return Rigidity(
        central=bool(central), rotations=bool(rotations) and not central, n_particles=n_all, n_bonds=m_all,
        coordination=float(network.coordination), isostatic_coordination=2.0 * nd / cons,
        floppy_modes=int(floppy), floppy_modes_floating=int(floppy_floating), states_of_self_stress=sss,
        participation=participation, cluster=cluster, cluster_sizes=cluster_sizes, percolating=bool(perc),
        spans=np.asarray(spans_any, bool), rigid_bonds=rigid_bonds, rattlers=rattlers, active=active,
        force_fraction=ff, backbone_bonds=bb["bonds"], backbone=bb["part"], backbone_fraction=bb["frac"],
        backbone_bond_fraction=bb["bfrac"], backbone_coordination=bb["z"], backbone_coordination_modes=bb["zm"],
        nonaffinity=bb["gam"], nonaffinity_modes=bb["gam_m"], fabric=fab, fabric_anisotropy=deviatoric_norm(fab),
        backbone_fabric=bb["fab"], backbone_fabric_anisotropy=bb["fab_an"], shear_fabric=_fourth_shear(normals),
        backbone_shear_fabric=bb["shear"], samples=samples, elastic=et, seconds=time.perf_counter() - t0,
    )


# ---------------------------------------------------------------- rigidity: the steps
def _check_rigidity(network, elastic, rotations, central, force_fraction, samples, rigid_tol):
    """Refuse what :func:`rigidity` cannot analyse; ``(force_fraction, samples)`` normalised."""
    from .elastic import ElasticTensor
    from .network import BondNetwork

    if not isinstance(network, BondNetwork):
        raise InvalidInputError(f"network must be a BondNetwork, got {type(network).__name__}")
    if network.dim != 3:
        raise InvalidInputError(f"rigidity supports 3D packings only; this network has dim={network.dim}")
    per = getattr(network.packing, "periodic", None)
    if per is not None and not all(bool(p) for p in np.atleast_1d(per)):
        raise InvalidInputError(f"rigidity needs a fully periodic box; periodic={tuple(per)}")
    ff = float(force_fraction)
    if not (np.isfinite(ff) and ff > 0):
        raise InvalidInputError(f"force_fraction={force_fraction!r}: must be finite and > 0")
    if isinstance(samples, bool) or int(samples) != samples or not 1 <= samples <= 256:
        raise InvalidInputError(f"samples={samples!r}: must be an integer in [1, 256]")
    samples = int(samples)
    if not (np.isfinite(rigid_tol) and 0 < rigid_tol < 1):
        raise InvalidInputError(f"rigid_tol={rigid_tol!r}: must be in (0, 1)")
    if elastic is not None and not isinstance(elastic, ElasticTensor):
        raise InvalidInputError(f"elastic must be an ElasticTensor, got {type(elastic).__name__}")
    if elastic is not None and (elastic.n_particles != network.n or elastic.n_bonds != network.n_bonds):
        raise InvalidInputError("elastic does not belong to this network (particle or bond counts differ)")
    if elastic is not None and not central and bool(elastic.rotations) != bool(rotations):
        raise InvalidInputError(f"elastic was made with rotations={elastic.rotations}, rigidity got {rotations}")
    return ff, samples


def _zero_modes_central(network, samples, nd):
    """Zero modes of the central-force network (translations only, one constraint per bond):
    ``(rattlers, label, samples z, metric, active, floppy, floppy_floating)``."""
    rattlers = network.bonds_per_particle == 0
    res = _nullspace(network, ~rattlers, rotations=False, central=True, samples=samples)
    label, spans = res["label"], res["spans"]
    wrap = spans.any(axis=1)
    floating = np.flatnonzero(~wrap)
    rot = _remove_rigid_rotations(network, res, floating, nd, True) if floating.size else 0
    z, dmet = res["z"], res["d"]
    active = (label >= 0) & (wrap[np.maximum(label, 0)] if wrap.size else False)
    # the count over the wrapping clusters alone (elastic_tensor's definition)
    if floating.size:
        res_a = _nullspace(network, active, rotations=False, central=True, samples=0)
        floppy = res_a["count"]
        floppy_floating = res["count"] - floppy - rot
    else:
        floppy, floppy_floating = res["count"], 0
    return rattlers, label, z, dmet, active, floppy, floppy_floating


def _zero_modes_bonded(network, elastic, rotations, samples, nd):
    """Zero modes of the contact-bond network (from the elastic tensor's factorization when it
    drew them, else factorized here), the floating clusters' apart:
    ``(rattlers, label, samples z, metric, active, floppy, floppy_floating, elastic tensor)``."""
    from .elastic import elastic_tensor

    n_all = network.n
    rattlers = np.asarray(network.rattlers).copy()
    et = elastic
    if et is None or getattr(et, "floppy_samples", None) is None:
        if et is None:
            et = elastic_tensor(network, rotations=rotations, floppy_samples=samples)
    label_b, spans_b = network.components(backbone=True)
    wrap = spans_b.any(axis=1)
    active = (label_b >= 0) & (wrap[np.maximum(label_b, 0)] if wrap.size else False)
    if not active.any():  # no cluster wraps the box: nothing relaxes under strain (floppy)
        z = np.full((samples, n_all, nd), np.nan)
        dmet = np.zeros((n_all, nd))
        floppy = 0
    elif getattr(et, "floppy_samples", None) is not None and et.floppy_modes is not None:
        z = np.array(et.floppy_samples, dtype=np.float64)
        dmet = np.array(et.floppy_metric, dtype=np.float64)
        floppy = int(et.floppy_modes)
    else:  # an iterative solver made the tensor: factorize here
        res_a = _nullspace(network, active, rotations=rotations, central=False, samples=samples)
        z, dmet, floppy = res_a["z"], res_a["d"], res_a["count"]
    floating_mask = ~rattlers & ~active
    floppy_floating = 0
    if floating_mask.any():
        res_f = _nullspace(network, floating_mask, rotations=rotations, central=False, samples=samples)
        comps = np.unique(res_f["label"][floating_mask])
        rot = _remove_rigid_rotations(network, res_f, comps, nd, False)
        floppy_floating = res_f["count"] - rot
        z[:, floating_mask] = res_f["z"][:, floating_mask]
        dmet[floating_mask] = res_f["d"][floating_mask]
    return rattlers, label_b, z, dmet, active, floppy, floppy_floating, et


def _rigid_bodies_central(network, rattlers, zz, amp, rigid_tol):
    """Rigid bodies of a central-force network (clusters of rigid triangles; a bond in none is a
    bar): ``(raw label, rigid bonds, spanned axes, percolating, body sizes)``."""
    from .._kernels import network as knl
    from .._kernels import rigidity as kr

    n_all, m_all = network.n, network.n_bonds
    bi, bj = network.i, network.j
    live = (~rattlers[bi] & ~rattlers[bj])
    tb, tlab, k = kr.central_triangles(n_all, bi, bj, np.ascontiguousarray(network.branch),
                                       live.astype(np.int64), np.ascontiguousarray(zz[:, :, :3]), amp,
                                       float(rigid_tol))
    # rigid bodies: the bonds of each triangle cluster; a bond in no rigid triangle is a bar
    body_bonds = [np.unique(tb[tlab == c].ravel()) for c in range(k)]
    in_tri = np.zeros(m_all, bool)
    in_tri[tb.ravel()] = True
    body_bonds += [np.array([c]) for c in np.flatnonzero(live & ~in_tri)]
    bsize = np.array([np.unique(np.concatenate([bi[b], bj[b]])).size for b in body_bonds], np.int64)
    raw = np.full(n_all, -1, np.int64)
    for c in np.argsort(bsize, kind="stable"):  # a hinge particle keeps its largest body
        b = body_bonds[c]
        raw[np.concatenate([bi[b], bj[b]])] = c
    rigid_bonds = live.copy()  # a bar keeps its own length: each bond is rigid by itself
    spans_any = np.zeros(3, bool)
    perc = False
    for c in np.argsort(-bsize, kind="stable")[:3]:  # the three largest bodies, each on its own bonds
        mask_b = np.zeros(m_all, np.int64)
        mask_b[body_bonds[c]] = 1
        _, _, sp_c = knl.components(n_all, bi, bj, network.shift, mask_b)
        s_ax = sp_c.astype(bool).any(axis=0)
        perc = perc or bool(s_ax.all())
        if s_ax.sum() > spans_any.sum():
            spans_any = s_ax
    return raw, rigid_bonds, spans_any, perc, bsize


def _rigid_clusters(network, rattlers, zz, amp, rigid_tol, nd):
    """Rigid clusters of a contact-bond network (bonds whose ends share the rotation of every
    zero-mode sample): ``(raw label, rigid bonds, spanned axes, percolating)``."""
    from .._kernels import network as knl

    n_all = network.n
    bi, bj = network.i, network.j
    live = (~rattlers[bi] & ~rattlers[bj])
    if nd == 6:
        dw = zz[:, bj, 3:] - zz[:, bi, 3:]
        defect = np.sqrt(np.sum(dw * dw, axis=2)) / np.maximum(amp, 1e-300)[:, None]
        rigid_bonds = live & np.all(defect <= rigid_tol, axis=0)
    else:
        rigid_bonds = live.copy()
    raw, _, sp_c = knl.components(n_all, bi, bj, network.shift, rigid_bonds.astype(np.int64))
    sp_c = sp_c.astype(bool)
    perc = bool(sp_c.all(axis=1).any()) if sp_c.size else False
    spans_any = sp_c[np.argmax(sp_c.sum(axis=1))] if sp_c.shape[0] else np.zeros(3, bool)
    # particles in no rigid bond: clusters of one
    lone = (raw < 0) & ~rattlers
    nxt = int(raw.max()) + 1 if raw.size and raw.max() >= 0 else 0
    raw = raw.copy()
    raw[lone] = nxt + np.arange(int(lone.sum()))
    return raw, rigid_bonds, spans_any, perc


def _relabel_clusters(raw, rattlers, bsize=None):
    """``(cluster, sizes)``: labels by size, largest first, rattlers -1 (``bsize``: the body sizes
    of a central-force network, whose bodies may share hinge particles)."""
    raw = np.where(rattlers, -1, raw)
    valid = raw >= 0
    if bsize is not None:  # bodies may share hinge particles: sizes count all of their particles
        uniq = np.arange(bsize.size)
        counts = bsize
    else:
        uniq, counts = np.unique(raw[valid], return_counts=True)
    order = np.lexsort((uniq, -counts))
    new = np.empty(uniq.size, np.int64)
    new[order] = np.arange(uniq.size)
    cluster = np.full(raw.shape[0], -1, np.int64)
    cluster[valid] = new[np.searchsorted(uniq, raw[valid])]
    return cluster, np.asarray(counts)[order].astype(np.int64)


def _backbone(network, et, active, on_a, ff):
    """The load-bearing backbone per unit strain (bonds whose relaxed force exceeds ``ff`` of the
    mean), its coordination, the non-affinity and the backbone fabric; all None without a tensor."""
    bi, bj = network.i, network.j
    n_all, m_all = network.n, network.n_bonds
    normals = np.asarray(network.normal)
    bb = bb_part = bb_frac = bb_bfrac = bb_z = bb_zm = gam = gam_m = bfab = bfab_an = bshear = None
    if et is not None and not active.any():
        bb = np.zeros((6, m_all), bool)
        bb_part = np.zeros(n_all, bool)
        bb_frac = bb_bfrac = 0.0
    elif et is not None:
        from .export import bond_forces

        bb = np.zeros((6, m_all), bool)
        # the affine bond forces |K eps b| of each unit strain: a relaxed force below
        # _FORCE_FLOOR of their mean is round-off (a floppy strain mode relaxes every force away)
        scale = float(et.length_scale) / (2.0 * float(np.mean(network.packing.radii)))
        b = np.asarray(network.branch) * scale
        kn_b = np.asarray(network.normal_stiffness)[:, None]
        ks_b = np.asarray(network.shear_stiffness)[:, None]
        for k_mode, name in enumerate(MODES):
            f = np.linalg.norm(bond_forces(network, et, name), axis=1)
            p_, q_ = _VOIGT_PAIRS[k_mode]
            eb = np.zeros_like(b)
            if p_ == q_:
                eb[:, p_] = b[:, p_]
            else:
                eb[:, p_] = 0.5 * b[:, q_]
                eb[:, q_] = 0.5 * b[:, p_]
            ebn = np.sum(eb * normals, axis=1)[:, None]
            f_aff = np.linalg.norm(kn_b * ebn * normals + ks_b * (eb - ebn * normals), axis=1)
            mean = float(f[on_a].mean()) if on_a.any() else 0.0
            floor = _FORCE_FLOOR * float(f_aff[on_a].mean()) if on_a.any() else 0.0
            bb[k_mode] = on_a & (f > max(ff * mean, floor)) if mean > 0 else np.zeros(m_all, bool)
        union = bb.any(axis=0)
        bb_part = np.zeros(n_all, bool)
        bb_part[bi[union]] = True
        bb_part[bj[union]] = True
        bb_frac = float(bb_part.mean())
        bb_bfrac = float(union.mean())
        bb_z = 2.0 * float(union.sum()) / max(int(bb_part.sum()), 1) if union.any() else None
        bb_zm = []
        for k_mode in range(6):
            ends = np.unique(np.concatenate([bi[bb[k_mode]], bj[bb[k_mode]]]))
            bb_zm.append(2.0 * float(bb[k_mode].sum()) / ends.size if ends.size else np.nan)
        bb_zm = np.array(bb_zm)
        u = np.asarray(et.nonaffine_displacements)
        d_mean = float(et.length_scale)
        gam_m = np.array([float(np.nanmean(np.sum(u[k_mode] ** 2, axis=1))) / d_mean ** 2 for k_mode in range(6)])
        gam = float(gam_m[3:].mean())
        bfab = fabric_tensor(normals, union)
        bfab_an = deviatoric_norm(bfab) if np.all(np.isfinite(bfab)) else None
        bshear = np.array([_fourth_shear(normals, bb[3 + p])[p] for p in range(3)])
    return dict(bonds=bb, part=bb_part, frac=bb_frac, bfrac=bb_bfrac, z=bb_z, zm=bb_zm, gam=gam, gam_m=gam_m,
                fab=bfab, fab_an=bfab_an, shear=bshear)
