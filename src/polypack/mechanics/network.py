"""Bonded contact networks (PFC contact bonds) built from a :class:`~polypack.Packing`.

Seed 003 (§2.1 of 003_873b69fc71c74cf6.txt) bonds every two spheres whose centres are
closer than ``d_eps = (1 + eps) 2 r0`` with linear springs: the normal force of
Eq. (1) of 003_873b69fc71c74cf6.txt and the incremental shear force of Eq. (2) of
003_873b69fc71c74cf6.txt, extended to separated particles by contact bonds with normal
and shear strengths. :class:`BondNetwork` holds that network; the elastic tensor
(:func:`polypack.mechanics.elastic_tensor`), the dynamic DEM and later tools read it.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..errors import InfeasibleError, InvalidInputError

__all__ = ["BondNetwork", "series_stiffness", "STIFFNESS_SEMANTICS"]

_REFERENCES = ("stress-free", "zero-gap")
#: Meaning of given normal/shear stiffnesses: ``"contact"`` (per contact, PFC 5 and
#: polypack's default) or ``"particle"`` (per ball, combined in series per contact: the
#: PFC 4 linear model and Table 1 of 003_873b69fc71c74cf6.txt).
STIFFNESS_SEMANTICS = ("contact", "particle")


def check_stiffness_semantics(stiffness):
    """Return ``stiffness`` if it is one of :data:`STIFFNESS_SEMANTICS`, else raise (one line)."""
    if not isinstance(stiffness, str) or stiffness not in STIFFNESS_SEMANTICS:
        raise InvalidInputError(f"stiffness={stiffness!r}: allowed are {list(STIFFNESS_SEMANTICS)} "
                                "(per contact, or per particle combined in series)")
    return stiffness


def _particle_to_contact(value, name):
    """Per-contact form of per-particle stiffnesses: a scalar ``k`` -> ``k/2``; a (K,) per-species
    list or a ``{species: k}`` mapping -> the (K, K) series matrix of :func:`series_stiffness`."""
    if isinstance(value, Mapping):
        try:
            keys = sorted(int(key) for key in value)
        except (TypeError, ValueError):
            raise InvalidInputError(f'{name} with stiffness="particle": a mapping must be {{species: k}}, '
                                    f"got keys {list(value)}") from None
        if keys != list(range(len(keys))):
            raise InvalidInputError(f'{name} with stiffness="particle": species {keys} must be 0 ... K-1')
        value = [value[k] if k in value else value[str(k)] for k in keys]
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        k = float(arr)
        if not (np.isfinite(k) and k > 0):
            raise InvalidInputError(f'{name}={k!r} with stiffness="particle": must be finite and > 0')
        return 0.5 * k
    if arr.ndim != 1:
        raise InvalidInputError(f'{name} of shape {arr.shape} with stiffness="particle": allowed are a scalar, '
                                "a per-species list or a {species: k} mapping (per-ball values)")
    try:
        return series_stiffness(arr)
    except InvalidInputError as exc:
        raise InvalidInputError(f"{name}: {exc}") from None


def series_stiffness(per_particle):
    """Per-contact stiffness matrix from per-particle stiffnesses combined in series.

    PFC 4 and earlier give each ball a stiffness and combine the two balls of a
    contact in series, ``k = k_A k_B / (k_A + k_B)`` (``k/2`` for equal balls); PFC 5
    and polypack's default set stiffnesses per contact. ``BondNetwork.from_packing(...,
    stiffness="particle")`` applies this to its per-ball input; the result can also be
    passed as ``normal_stiffness=`` or ``shear_stiffness=`` of a per-contact network.

    Parameters
    ----------
    per_particle : (K,) array_like of float
        Stiffness of the balls of each species, > 0.

    Returns
    -------
    (K, K) numpy.ndarray
        Per-contact stiffness for every species pair.
    """
    k = np.asarray(per_particle, dtype=np.float64)
    if k.ndim != 1 or k.size == 0 or not np.all(np.isfinite(k)) or np.any(k <= 0):
        raise InvalidInputError(
            f"per-particle stiffnesses {np.asarray(per_particle).tolist()!r}: need a 1-D list of finite values > 0"
        )
    return k[:, None] * k[None, :] / (k[:, None] + k[None, :])


def _per_bond(value, name, si, sj, m, *, allow_inf, per_bond_ok):
    """Resolve a scalar, a species mapping, a (K, K) species matrix or an (M,) array."""
    if isinstance(value, Mapping):
        out = np.empty(m, np.float64)
        table = {}
        for key, v in value.items():
            try:
                a, b = (int(x) for x in key)
            except (TypeError, ValueError):
                raise InvalidInputError(
                    f"{name} key {key!r}: keys must be species pairs such as (0, 1)"
                ) from None
            table[(a, b)] = table[(b, a)] = float(v)
        for c in range(m):
            key = (int(si[c]), int(sj[c]))
            if key not in table:
                raise InvalidInputError(
                    f"{name} has no value for species pair {key}; given pairs {sorted(value)}"
                )
            out[c] = table[key]
    else:
        arr = np.asarray(value, dtype=np.float64)
        if arr.ndim == 0:
            out = np.full(m, float(arr))
        elif arr.ndim == 2:
            k = arr.shape[0]
            if arr.shape != (k, k) or not np.allclose(arr, arr.T, rtol=1e-12, atol=0.0):
                raise InvalidInputError(
                    f"{name} matrix of shape {arr.shape} must be square and symmetric (species x species)"
                )
            need = int(max(si.max(), sj.max())) + 1 if m else 0
            if k < need:
                raise InvalidInputError(f"{name} matrix is {k}x{k} but the packing has {need} species")
            out = arr[si, sj].astype(np.float64)
        elif arr.ndim == 1 and per_bond_ok and arr.shape[0] == m:
            out = arr.astype(np.float64).copy()
        else:
            allowed = "a scalar, a {(a, b): value} mapping or a (K, K) species matrix"
            if per_bond_ok:
                allowed += f" or an array with one value per bond ({m})"
            raise InvalidInputError(f"{name} of shape {arr.shape}: allowed are {allowed}")
    bad = ~(out > 0) | (np.isinf(out) & (not allow_inf)) | np.isnan(out)
    if bad.any():
        c = int(np.flatnonzero(bad)[0])
        lim = "> 0 (np.inf = unbreakable)" if allow_inf else "finite and > 0"
        raise InvalidInputError(f"{name}={float(out[c])!r} (bond {c}): must be {lim}")
    out.setflags(write=False)
    return out


def _geometry(packing):
    pos = np.asarray(packing.positions, dtype=np.float64)
    box = np.asarray(packing.box, dtype=np.float64)
    dim = int(getattr(packing, "dim", pos.shape[1]))
    periodic = getattr(packing, "periodic", None)
    if periodic is None:
        periodic = (True,) * dim
    periodic = np.array([bool(p) for p in periodic], dtype=bool)
    if periodic.shape != (dim,):
        periodic = np.full(dim, bool(periodic.all()))
    return pos, box, dim, periodic


def _candidate_pairs(packing, a):
    """Pairs with ``d_ij <= a (r_i + r_j)`` by the shared cell-list search (2D/3D, walls)."""
    from ..neighbors import pairs_within

    pos, box, dim, periodic = _geometry(packing)
    rad = np.asarray(packing.radii, dtype=np.float64)
    return pairs_within(pos, rad, box, a=a, b=0.0, periodic=tuple(bool(p) for p in periodic))


class BondNetwork:
    """A bonded contact network: linear normal and shear springs between particles.

    Build it with :meth:`from_packing` (bond every pair closer than
    ``(1 + epsilon)(r_i + r_j)``, as in seed 003) or :meth:`from_pairs` (bonds made
    elsewhere, e.g. by Brownian dynamics). The packing is never modified; all arrays
    are read-only.

    Attributes
    ----------
    packing : Packing
    i, j : (M,) int64
        Particle indices of the two bond ends.
    shift : (M, dim) int64
        Periodic image of ``j`` seen from ``i``: the branch vector is
        ``b = x[j] + shift * box - x[i]`` (0 on wall axes).
    branch, length, normal : (M, dim), (M,), (M, dim)
        Branch vector, its length and the unit normal from ``i`` to ``j``.
    rest_length : (M,)
        Reference length of each bond: the current length (``reference="stress-free"``)
        or ``r_i + r_j`` (``"zero-gap"``, PFC: a bond made across a gap ``g`` starts
        under tension ``k_n g``).
    normal_stiffness, shear_stiffness : (M,) float64
        Stiffness of each contact in force per length (N/m for SI input), always the
        per-contact value the mechanics use. Given ``stiffness="particle"`` the input
        values are per ball and combined in series here (PFC 4, seed 003 Table 1; a
        factor 1/2 for equal balls, :func:`series_stiffness`).
    stiffness : str
        ``"contact"`` or ``"particle"``: how the input stiffnesses were read.
    normal_strength, shear_strength : (M,) float64
        Bond strengths in force units (N for SI input); ``np.inf`` = unbreakable.
    reference : str
    epsilon : float or None
        Relative bonding distance used by :meth:`from_packing` (``None`` for
        :meth:`from_pairs`).

    Notes
    -----
    Contact geometry follows PFC: with the overlap ``U_n = r_i + r_j - |b|`` (negative
    for a gap), the contact point is ``x_i + (r_i - U_n / 2) n`` and the lever arms
    from the two centres are ``(r_i - U_n/2) n`` and ``-(r_j - U_n/2) n``. The normal
    force is ``k_n (rest_length - length)`` (positive in compression, Eq. (1) of
    003_873b69fc71c74cf6.txt with the overlap measured from the rest length); the
    shear force is incremental, Eq. (2) of 003_873b69fc71c74cf6.txt.

    References
    ----------
    .. [1] D. O. Potyondy and P. A. Cundall, "A bonded-particle model for rock",
       Int. J. Rock Mech. Min. Sci. 41, 1329 (2004).
    """

    __slots__ = (
        "_packing", "_i", "_j", "_shift", "_branch", "_length", "_normal", "_rest",
        "_kn", "_ks", "_fn", "_fs", "_reference", "_epsilon", "_cache", "_semantics",
    )

    def __init__(self, packing, i, j, shift, *, normal_stiffness, shear_stiffness,
                 normal_strength, shear_strength, reference, epsilon=None, per_bond_ok=True,
                 stiffness="contact"):
        check_stiffness_semantics(stiffness)
        if stiffness == "particle":
            normal_stiffness = _particle_to_contact(normal_stiffness, "normal_stiffness")
            shear_stiffness = _particle_to_contact(shear_stiffness, "shear_stiffness")
        if reference not in _REFERENCES:
            raise InvalidInputError(f"reference={reference!r}: allowed are {list(_REFERENCES)}")
        pos, box, dim, periodic = _geometry(packing)
        n = pos.shape[0]
        i = np.ascontiguousarray(i, dtype=np.int64)
        j = np.ascontiguousarray(j, dtype=np.int64)
        m = i.shape[0]
        if m == 0:
            raise InfeasibleError("the network has no bonds; bond more pairs (a larger epsilon) or pass pairs")
        shift = np.ascontiguousarray(shift, dtype=np.int64).reshape(m, dim)
        branch = pos[j] + shift * box - pos[i]
        length = np.sqrt(np.einsum("ij,ij->i", branch, branch))
        if np.any(length <= 0):
            c = int(np.flatnonzero(length <= 0)[0])
            raise InvalidInputError(f"bond {c} ({i[c]}, {j[c]}) has zero length; particles coincide")
        normal = branch / length[:, None]
        rad = np.asarray(packing.radii, dtype=np.float64)
        rest = length.copy() if reference == "stress-free" else rad[i] + rad[j]
        sp = np.asarray(packing.species, dtype=np.int64)
        si, sj = sp[i], sp[j]
        kw = dict(per_bond_ok=per_bond_ok)
        self._kn = _per_bond(normal_stiffness, "normal_stiffness", si, sj, m, allow_inf=False, **kw)
        self._ks = _per_bond(shear_stiffness, "shear_stiffness", si, sj, m, allow_inf=False, **kw)
        self._fn = _per_bond(normal_strength, "normal_strength", si, sj, m, allow_inf=True, **kw)
        self._fs = _per_bond(shear_strength, "shear_strength", si, sj, m, allow_inf=True, **kw)
        for arr in (i, j, shift, branch, length, normal, rest):
            arr.setflags(write=False)
        self._packing = packing
        self._i, self._j, self._shift = i, j, shift
        self._branch, self._length, self._normal, self._rest = branch, length, normal, rest
        self._reference = reference
        self._epsilon = epsilon
        self._semantics = stiffness
        self._cache = {}
        del n

    # ------------------------------------------------------------ constructors
    @classmethod
    def from_packing(cls, packing, epsilon=0.01, normal_stiffness=100.0, shear_stiffness=10.0,
                     normal_strength=1e-4, shear_strength=1e-6, reference="stress-free", stiffness="contact"):
        """Bond every pair whose centres are closer than ``(1 + epsilon)(r_i + r_j)``.

        For equal spheres this is the bonding distance ``d_eps = (1 + eps) 2 r0`` of
        §2.4 of 003_873b69fc71c74cf6.txt (eps = 0.01 there). Pairs are found with the
        shared size-aware cell-list search, minimum image on periodic axes.

        Parameters
        ----------
        packing : Packing
        epsilon : float, default 0.01
            Relative bonding gap, >= 0.
        normal_stiffness, shear_stiffness : float, mapping or array, default 100, 10
            Stiffnesses (N/m for SI input; seed 003 Table 1: kn = 100 N/m, kn/ks = 10),
            read as ``stiffness`` says. Per contact: a scalar, a mapping ``{(a, b): k}``
            or a symmetric (K, K) species matrix. Per particle: a scalar, a (K,)
            per-species list or a mapping ``{a: k}``.
        stiffness : {"contact", "particle"}, default "contact"
            ``"contact"``: the values are the springs of each contact (PFC 5,
            polypack's default). ``"particle"``: they are per-ball stiffnesses combined
            in series per contact, ``k_ab = k_a k_b / (k_a + k_b)`` (``k/2`` for equal
            balls): the PFC 4 linear model, the semantics of Table 1 of
            003_873b69fc71c74cf6.txt ("normal particle stiffness"), so kn = 100 N/m
            there gives 50 N/m contacts. Strengths are always per contact.
        normal_strength, shear_strength : float, mapping or (K, K) array, default 1e-4, 1e-6
            Bond strengths (N; seed 003 Table 1); ``np.inf`` = unbreakable.
        reference : {"stress-free", "zero-gap"}
            Rest length of the bonds: their current length, or ``r_i + r_j`` (PFC
            contact bonds, prestressed across gaps and overlaps).

        Returns
        -------
        BondNetwork
            Bonds sorted by ``(i, j)`` with ``i < j``.

        Raises
        ------
        InvalidInputError
            On ``epsilon < 0``, non-positive stiffness or strength, an unknown reference,
            or a bonding reach beyond half the box.
        InfeasibleError
            When no pair is close enough to bond.
        """
        eps = float(epsilon)
        if not np.isfinite(eps) or eps < 0:
            raise InvalidInputError(f"epsilon={epsilon!r}: must be finite and >= 0")
        if reference not in _REFERENCES:
            raise InvalidInputError(f"reference={reference!r}: allowed are {list(_REFERENCES)}")
        pos, box, dim, periodic = _geometry(packing)
        if pos.shape[0] < 2:
            raise InfeasibleError(f"the packing has {pos.shape[0]} particle(s); a network needs at least 2")
        pi, pj, _ = _candidate_pairs(packing, 1.0 + eps)
        if pi.size == 0:
            raise InfeasibleError(
                f"no pair within (1 + epsilon)(r_i + r_j) for epsilon={eps:g}: the network has no bonds"
            )
        lo, hi = np.minimum(pi, pj), np.maximum(pi, pj)
        order = np.lexsort((hi, lo))
        lo, hi = lo[order], hi[order]
        delta = pos[hi] - pos[lo]
        shift = np.where(periodic, -np.round(delta / box), 0.0).astype(np.int64)
        return cls(packing, lo, hi, shift, normal_stiffness=normal_stiffness,
                   shear_stiffness=shear_stiffness, normal_strength=normal_strength,
                   shear_strength=shear_strength, reference=reference, epsilon=eps,
                   per_bond_ok=False, stiffness=stiffness)

    @classmethod
    def from_pairs(cls, packing, i, j, shift=None, normal_stiffness=100.0, shear_stiffness=10.0,
                   normal_strength=1e-4, shear_strength=1e-6, reference="stress-free", stiffness="contact"):
        """A network with the given bonds (kept in the given order and orientation).

        Parameters
        ----------
        packing : Packing
        i, j : (M,) array_like of int
            Bond ends, ``0 <= i, j < N``, ``i != j``.
        shift : (M, dim) array_like of int, optional
            Periodic image of ``j`` seen from ``i`` (branch ``x[j] + shift * box - x[i]``);
            default the minimum image on periodic axes.
        normal_stiffness, shear_stiffness, normal_strength, shear_strength
            As in :meth:`from_packing`, or (per contact) an (M,) array with one value per bond.
        reference : {"stress-free", "zero-gap"}
        stiffness : {"contact", "particle"}, default "contact"
            As in :meth:`from_packing`.

        Raises
        ------
        InvalidInputError
            On out-of-range or equal ends, a duplicated bond, a shift on a wall axis
            or bad stiffnesses.
        InfeasibleError
            When no bond is given.
        """
        pos, box, dim, periodic = _geometry(packing)
        n = pos.shape[0]
        i = np.asarray(i)
        j = np.asarray(j)
        if i.ndim != 1 or j.shape != i.shape:
            raise InvalidInputError(f"i and j must be 1-D of equal length, got shapes {i.shape}, {j.shape}")
        if i.size and (i.dtype.kind not in "iu" or j.dtype.kind not in "iu"):
            raise InvalidInputError(f"i and j must be integer arrays, got {i.dtype}, {j.dtype}")
        i = i.astype(np.int64)
        j = j.astype(np.int64)
        m = i.size
        if m == 0:
            raise InfeasibleError("from_pairs got no pairs: the network has no bonds")
        bad = (i < 0) | (i >= n) | (j < 0) | (j >= n)
        if bad.any():
            c = int(np.flatnonzero(bad)[0])
            raise InvalidInputError(f"bond {c} = ({i[c]}, {j[c]}): indices must be in [0, {n})")
        if np.any(i == j):
            c = int(np.flatnonzero(i == j)[0])
            raise InvalidInputError(f"bond {c} joins particle {i[c]} to itself")
        if shift is None:
            delta = pos[j] - pos[i]
            sh = np.where(periodic, -np.round(delta / box), 0.0).astype(np.int64)
        else:
            raw = np.asarray(shift)
            if raw.shape != (m, dim):
                raise InvalidInputError(f"shift must have shape ({m}, {dim}), got {raw.shape}")
            if raw.dtype.kind == "f" and np.any(raw != np.round(raw)):
                raise InvalidInputError("shift must hold integer image offsets")
            sh = raw.astype(np.int64)
            wall = np.flatnonzero(~periodic)
            if wall.size and np.any(sh[:, wall] != 0):
                raise InvalidInputError(f"shift is nonzero on wall axis/axes {wall.tolist()}")
        # duplicated bonds (same pair, same image, in either orientation)
        flip = i > j
        key = np.column_stack([np.where(flip, j, i), np.where(flip, i, j), np.where(flip[:, None], -sh, sh)])
        _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
        if np.any(counts > 1):
            c = int(first[np.flatnonzero(counts > 1)[0]])
            raise InvalidInputError(f"bond ({i[c]}, {j[c]}) with shift {sh[c].tolist()} is given more than once")
        return cls(packing, i, j, sh, normal_stiffness=normal_stiffness,
                   shear_stiffness=shear_stiffness, normal_strength=normal_strength,
                   shear_strength=shear_strength, reference=reference, epsilon=None,
                   per_bond_ok=True, stiffness=stiffness)

    def select(self, keep):
        """A new network with only the bonds ``keep`` (bool mask or indices), e.g. after breakage."""
        idx = np.arange(self.n_bonds)[np.asarray(keep)]
        return BondNetwork(self._packing, self._i[idx], self._j[idx], self._shift[idx],
                           normal_stiffness=self._kn[idx], shear_stiffness=self._ks[idx],
                           normal_strength=self._fn[idx], shear_strength=self._fs[idx],
                           reference=self._reference, epsilon=self._epsilon, per_bond_ok=True,
                           stiffness="contact")._with_semantics(self._semantics)

    def _with_semantics(self, stiffness):
        self._semantics = stiffness
        return self

    # -------------------------------------------------------------------- data
    packing = property(lambda self: self._packing, doc="The Packing (never modified).")
    i = property(lambda self: self._i, doc="(M,) int64 first bond ends.")
    j = property(lambda self: self._j, doc="(M,) int64 second bond ends.")
    shift = property(lambda self: self._shift, doc="(M, dim) int64 periodic image of j seen from i.")
    branch = property(lambda self: self._branch, doc="(M, dim) branch vectors x[j] + shift*box - x[i].")
    length = property(lambda self: self._length, doc="(M,) branch lengths.")
    normal = property(lambda self: self._normal, doc="(M, dim) unit normals from i to j.")
    rest_length = property(lambda self: self._rest, doc="(M,) reference (rest) lengths.")
    normal_stiffness = property(lambda self: self._kn, doc="(M,) per-contact normal stiffness.")
    shear_stiffness = property(lambda self: self._ks, doc="(M,) per-contact shear stiffness.")
    normal_strength = property(lambda self: self._fn, doc="(M,) normal bond strength (inf = unbreakable).")
    shear_strength = property(lambda self: self._fs, doc="(M,) shear bond strength (inf = unbreakable).")
    reference = property(lambda self: self._reference, doc='"stress-free" or "zero-gap".')
    epsilon = property(lambda self: self._epsilon, doc="Relative bonding gap (None for from_pairs).")
    stiffness = property(lambda self: self._semantics,
                         doc='How the given stiffnesses were read: "contact" or "particle" (series per contact); '
                             "normal_stiffness / shear_stiffness hold the per-contact values either way.")

    @property
    def dim(self) -> int:
        """Space dimension of the packing."""
        return int(self._shift.shape[1])

    @property
    def n(self) -> int:
        """Number of particles (bonded or not)."""
        return int(np.asarray(self._packing.radii).shape[0])

    @property
    def n_bonds(self) -> int:
        """Number of bonds M."""
        return int(self._i.shape[0])

    def __len__(self) -> int:
        return self.n_bonds

    @property
    def overlap(self) -> np.ndarray:
        """(M,) overlap ``U_n = r_i + r_j - length`` (negative for a gap)."""
        r = np.asarray(self._packing.radii)
        return r[self._i] + r[self._j] - self._length

    @property
    def relative_gap(self) -> np.ndarray:
        """(M,) ``length / (r_i + r_j) - 1``: in ``[.., epsilon]`` for :meth:`from_packing`."""
        r = np.asarray(self._packing.radii)
        return self._length / (r[self._i] + r[self._j]) - 1.0

    @property
    def lever_arm_i(self) -> np.ndarray:
        """(M, dim) vector from centre i to the contact point, ``(r_i - U_n/2) n``."""
        r = np.asarray(self._packing.radii)
        return (r[self._i] - 0.5 * self.overlap)[:, None] * self._normal

    @property
    def lever_arm_j(self) -> np.ndarray:
        """(M, dim) vector from (the image of) centre j to the contact point, ``-(r_j - U_n/2) n``."""
        r = np.asarray(self._packing.radii)
        return -(r[self._j] - 0.5 * self.overlap)[:, None] * self._normal

    @property
    def contact_point(self) -> np.ndarray:
        """(M, dim) PFC contact point ``x_i + (r_i - U_n/2) n`` (may lie up to a radius outside the box)."""
        return np.asarray(self._packing.positions)[self._i] + self.lever_arm_i

    @property
    def normal_force(self) -> np.ndarray:
        """(M,) normal force in the reference state, ``k_n (rest_length - length)``; > 0 compression.

        Zero for ``"stress-free"``; for ``"zero-gap"`` a bond across a gap g carries the
        tension ``k_n g`` (negative value).
        """
        return self._kn * (self._rest - self._length)

    # -------------------------------------------------------------- topology
    @property
    def bonds_per_particle(self) -> np.ndarray:
        """(N,) number of bonds of each particle."""
        n = self.n
        return np.bincount(self._i, minlength=n) + np.bincount(self._j, minlength=n)

    @property
    def coordination(self) -> float:
        """Mean number of bonds per particle, ``2 M / N`` (seed 003 Table 2's C)."""
        return 2.0 * self.n_bonds / self.n

    def _peel(self, min_bonds):
        key = ("peel", min_bonds)
        if key not in self._cache:
            from .._kernels import network as kn

            live = np.ones(self.n_bonds, np.int64)
            out = kn.peel(self.n, self._i, self._j, live, int(min_bonds)).astype(bool)
            out.setflags(write=False)
            self._cache[key] = out
        return self._cache[key]

    @property
    def rattlers(self) -> np.ndarray:
        """(N,) bool: particles left with fewer than two bonds after removing such particles recursively.

        A rattler carries no load in the linear elastic response.
        """
        return self._peel(2)

    def rattlers_with(self, min_bonds) -> np.ndarray:
        """Rattler mask for another threshold (recursive removal of < ``min_bonds`` bonds)."""
        if int(min_bonds) != min_bonds or min_bonds < 0:
            raise InvalidInputError(f"min_bonds={min_bonds!r}: must be an integer >= 0")
        return self._peel(int(min_bonds))

    @property
    def backbone_bonds(self) -> np.ndarray:
        """(M,) bool: bonds between two non-rattlers."""
        r = self.rattlers
        return ~r[self._i] & ~r[self._j]

    @property
    def coordination_without_rattlers(self) -> float:
        """Mean bonds per particle among non-rattlers, counting only their mutual bonds."""
        keep = int((~self.rattlers).sum())
        return 2.0 * int(self.backbone_bonds.sum()) / keep if keep else 0.0

    def components(self, backbone=True):
        """Connected clusters and the box axes each one wraps.

        Parameters
        ----------
        backbone : bool, default True
            Use only bonds between non-rattlers.

        Returns
        -------
        label : (N,) int64
            Cluster of each particle, -1 for particles without (backbone) bonds.
        spans : (K, dim) bool
            ``spans[k, a]`` is True when cluster ``k`` closes a loop through the
            periodic boundary along axis ``a`` (it percolates along that axis).
        """
        from .._kernels import network as kn

        live = (self.backbone_bonds if backbone else np.ones(self.n_bonds, bool)).astype(np.int64)
        label, ncomp, spans = kn.components(self.n, self._i, self._j, self._shift, live)
        return label, spans.astype(bool)

    # ------------------------------------------------------------ statistics
    def bond_angles(self) -> np.ndarray:
        """Angles (radians, in [0, pi]) between every two bonds sharing a particle.

        Each unordered pair of bonds at a particle counts once; the bond direction at a
        particle points to its partner.
        """
        from .._kernels import network as kn

        cos = kn.bond_angle_cosines(self.n, self._i, self._j, np.ascontiguousarray(self._normal))
        return np.arccos(cos)

    @property
    def fabric(self) -> np.ndarray:
        """(dim, dim) fabric tensor ``<n n^T>`` over bonds (``I / dim`` when isotropic)."""
        return self._normal.T @ self._normal / self.n_bonds

    def statistics(self) -> dict:
        """Plain-data summary: counts, coordination, rattlers, bond lengths, gaps and angles.

        Lengths are in the packing's unit; angles in degrees.
        """
        def stats(x):
            x = np.asarray(x, dtype=np.float64)
            if x.size == 0:
                return {"mean": float("nan"), "std": float("nan"), "min": float("nan"), "max": float("nan")}
            return {"mean": float(x.mean()), "std": float(x.std()), "min": float(x.min()), "max": float(x.max())}

        ang = np.degrees(self.bond_angles())
        hist, edges = np.histogram(ang, bins=36, range=(0.0, 180.0))
        fab = self.fabric
        return {
            "n_particles": self.n,
            "n_bonds": self.n_bonds,
            "coordination": self.coordination,
            "coordination_without_rattlers": self.coordination_without_rattlers,
            "n_rattlers": int(self.rattlers.sum()),
            "rattler_fraction": float(self.rattlers.mean()),
            "reference": self._reference,
            "epsilon": self._epsilon,
            "bond_length": stats(self._length),
            "relative_gap": stats(self.relative_gap),
            "bond_angle_deg": stats(ang),
            "bond_angle_histogram": {"edges_deg": edges.tolist(), "counts": hist.tolist()},
            "fabric_anisotropy": float(np.linalg.eigvalsh(fab)[-1] - np.linalg.eigvalsh(fab)[0]),
        }

    def __repr__(self) -> str:
        return (f"BondNetwork(n={self.n}, bonds={self.n_bonds}, Z={self.coordination:.3f}, "
                f"reference={self._reference!r}, stiffness={self._semantics!r})")
