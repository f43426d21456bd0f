"""Contacts, coordination numbers per species pair, rattlers and the contact list.

Two spheres are in contact when ``d_ij <= (1 + tolerance)(r_i + r_j)``: the bond
criterion of seed 003 (§2.2 of 003_873b69fc71c74cf6.txt, ``d_eps = (1 + eps) 2 r0``
with ``eps = 0.01``), generalised to unequal radii.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError
from ..neighbors import minimum_image, pairs_within
from ._base import Estimator, check_packing, to_jsonable

__all__ = ["Contacts"]


def _rattlers(n, i, j, min_contacts):
    """Iteratively remove spheres with fewer than ``min_contacts`` contacts."""
    keep = np.ones(n, bool)
    if min_contacts <= 0:
        return ~keep
    while True:
        live = keep[i] & keep[j]
        z = np.bincount(i[live], minlength=n) + np.bincount(j[live], minlength=n)
        drop = keep & (z < min_contacts)
        if not drop.any():
            return ~keep
        keep &= ~drop


class Contacts(Estimator):
    """Contact network of a pack.

    Parameters
    ----------
    tolerance : float
        Relative gap ``eps >= 0``: pairs with ``d_ij <= (1 + eps)(r_i + r_j)`` touch
        (seed 003 uses 0.01).
    min_contacts : int
        Rattler criterion: spheres with fewer contacts than this (default 4 = d + 1,
        the minimum for a sphere held in place by frictionless contacts) are removed
        repeatedly until every remaining sphere has at least ``min_contacts``
        contacts with remaining spheres.

    Results
    -------
    coordination : mean number of contacts per sphere, ``2 M / N``;
    per_species : ``(K, K)`` array, mean number of m contacts of a k sphere;
    per_sphere : contact number of every sphere (last realization);
    rattlers : boolean mask (last realization); rattler_fraction;
    coordination_without_rattlers : mean contacts among non-rattlers;
    pairs, distances, gaps, branch_vectors : the contact list (last realization).
    With ``reset=False`` the scalars are averaged over realizations (``*_err`` give
    standard errors between realizations).
    """

    def __init__(self, tolerance=0.01, min_contacts=4):
        super().__init__()
        try:
            tol = float(tolerance)
        except (TypeError, ValueError):
            raise InvalidInputError(f"tolerance={tolerance!r} must be a number >= 0") from None
        if not np.isfinite(tol) or tol < 0:
            raise InvalidInputError(f"tolerance={tolerance!r} must be finite and >= 0")
        if int(min_contacts) != min_contacts or min_contacts < 0:
            raise InvalidInputError(f"min_contacts={min_contacts!r} must be an integer >= 0")
        self.tolerance = tol
        self.min_contacts = int(min_contacts)

    def compute(self, packing, reset=True):
        """Find all contacts of ``packing``; returns ``self``."""
        check_packing(packing, min_n=1, what="Contacts", dims=(2, 3), walls=True)
        if reset:
            self.reset()
        i, j, d = pairs_within(
            packing.positions, packing.radii, packing.box, a=1.0 + self.tolerance, b=0.0, periodic=packing.periodic
        )
        s = packing.radii[i] + packing.radii[j]
        keep = d <= (1.0 + self.tolerance) * s
        i, j, d, s = i[keep], j[keep], d[keep], s[keep]
        lo, hi = np.minimum(i, j), np.maximum(i, j)
        o = np.lexsort((hi, lo))
        i, j, d, s = lo[o], hi[o], d[o], s[o]
        n = packing.n
        ns = packing.n_species
        z = np.bincount(i, minlength=n) + np.bincount(j, minlength=n)
        sp = packing.species
        zz = np.zeros((ns, ns))
        np.add.at(zz, (sp[i], sp[j]), 1.0)
        np.add.at(zz, (sp[j], sp[i]), 1.0)
        nk = np.bincount(sp, minlength=ns).astype(np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            per_species = zz / nk[:, None]
        rat = _rattlers(n, i, j, self.min_contacts)
        live = ~rat[i] & ~rat[j]
        n_live = int((~rat).sum())
        self._frames.append(
            {
                "z": 2.0 * i.size / n,
                "per_species": per_species,
                "rattler_fraction": float(rat.mean()),
                "z_live": 2.0 * int(live.sum()) / n_live if n_live else np.nan,
                "per_sphere": z,
                "rattlers": rat,
                "i": i,
                "j": j,
                "d": d,
                "gaps": d / s - 1.0,
                "branch": minimum_image(packing.positions[j] - packing.positions[i], packing.box, packing.periodic),
            }
        )
        return self

    def _mean(self, name):
        self._require()
        st = self._stack(name)
        if np.all(np.isnan(st)):
            return np.full(st.shape[1:], np.nan)
        return np.nanmean(st, axis=0)

    @property
    def coordination(self) -> float:
        """Mean contact number ``2 M / N``."""
        return float(self._mean("z"))

    @property
    def coordination_err(self) -> float:
        return float(self._stderr(self._stack("z")))

    @property
    def per_species(self) -> np.ndarray:
        """``Z[k, m]``: mean number of species-m contacts of a species-k sphere."""
        return self._mean("per_species")

    @property
    def rattler_fraction(self) -> float:
        return float(self._mean("rattler_fraction"))

    @property
    def coordination_without_rattlers(self) -> float:
        return float(self._mean("z_live"))

    def _last(self, name):
        self._require()
        return self._frames[-1][name]

    @property
    def per_sphere(self) -> np.ndarray:
        return self._last("per_sphere")

    @property
    def rattlers(self) -> np.ndarray:
        return self._last("rattlers")

    @property
    def pairs(self) -> np.ndarray:
        """``(M, 2)`` contact pairs ``i < j`` (last realization)."""
        return np.stack([self._last("i"), self._last("j")], axis=1)

    @property
    def distances(self) -> np.ndarray:
        return self._last("d")

    @property
    def gaps(self) -> np.ndarray:
        """Relative gaps ``d_ij / (r_i + r_j) - 1`` of the contacts."""
        return self._last("gaps")

    @property
    def branch_vectors(self) -> np.ndarray:
        """Minimum-image vectors from sphere ``i`` to sphere ``j`` of every contact."""
        return self._last("branch")

    def contact_list(self) -> dict:
        """Arrays ``i, j, distance, gap, branch`` (last realization) for mechanics."""
        return {
            "i": self._last("i"),
            "j": self._last("j"),
            "distance": self._last("d"),
            "gap": self._last("gaps"),
            "branch": self._last("branch"),
        }

    def to_dict(self, include_list=False) -> dict:
        out = {
            "estimator": "Contacts",
            "tolerance": self.tolerance,
            "min_contacts": self.min_contacts,
            "n_realizations": self.n_realizations,
            "coordination": self.coordination,
            "coordination_err": self.coordination_err,
            "per_species": self.per_species,
            "rattler_fraction": self.rattler_fraction,
            "coordination_without_rattlers": self.coordination_without_rattlers,
            "contact_number_histogram": np.bincount(self.per_sphere),
        }
        if include_list:
            out["pairs"] = self.pairs
            out["gaps"] = self.gaps
        return to_jsonable(out)

    def plot(self, ax=None):
        """Histogram of contact numbers (last realization); returns the Axes."""
        ax = self._axes(ax)
        h = np.bincount(self.per_sphere)
        ax.bar(np.arange(h.size), h / h.sum(), color="0.4")
        ax.set_xlabel("contacts per sphere")
        ax.set_ylabel("fraction")
        ax.set_title(f"mean {self.coordination:.3f}, eps = {self.tolerance:g}")
        return ax
