"""Numerically accessible shape parameters of the CB model, §2.3 and Fig. 8 of 001_ad5bae0acea940c4.txt."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InfeasibleError, InvalidInputError
from .classes import class_counts
from .descriptors import hazen
from .models import CumulativeBeta

__all__ = ["AccessibleDomain", "accessible_domain"]


@dataclass
class AccessibleDomain:
    """Particle numbers ``N_p`` needed by the representativity criteria over a grid of (a, b).

    ``n_total[j, i]`` (float; ``inf`` beyond 1e18) is ``N_p`` for ``a = a_values[i]``,
    ``b = b_values[j]``; a shape is accessible when ``N_p <= max_total`` (``mask``).
    ``cu`` and ``cc`` hold the Hazen coefficients of each shape (Eq. (19) of 001_ad5bae0acea940c4.txt to Eq. (20) of 001_ad5bae0acea940c4.txt), so the
    accessible values of ``Cu`` (Fig. 8c) are ``cu[mask]``.
    """

    span: float
    a_values: np.ndarray
    b_values: np.ndarray
    n_total: np.ndarray
    max_total: object
    parameters: dict
    cu: np.ndarray = None
    cc: np.ndarray = None

    @property
    def mask(self) -> np.ndarray:
        """Boolean grid, True where ``N_p <= max_total`` (the first limit if several)."""
        return self.accessible(np.atleast_1d(self.max_total)[0])

    def accessible(self, max_total) -> np.ndarray:
        """Boolean grid of accessible shapes for the limit ``max_total``."""
        return self.n_total <= max_total

    def to_dict(self) -> dict:
        return {"span": self.span, "a_values": self.a_values.tolist(), "b_values": self.b_values.tolist(),
                "n_total": [[None if not np.isfinite(v) else int(v) for v in row] for row in self.n_total],
                "Cu": None if self.cu is None else self.cu.tolist(), "Cc": None if self.cc is None else self.cc.tolist(), "max_total": np.atleast_1d(self.max_total).tolist(),
                "parameters": self.parameters}

    def plot(self, ax=None, **kw):
        """Accessible domains in the (a, b) plane, one boundary per ``max_total`` (Fig. 8 style)."""
        from .plots import plot_accessible_domain

        return plot_accessible_domain(self, ax=ax, **kw)


def accessible_domain(span, a_values=None, b_values=None, n_classes=10, spacing="geometric", min_per_class=10,
                      min_total=2000, max_total=10**5, dim=3, count_basis="median") -> AccessibleDomain:
    """Map ``N_p`` over the CB shape parameters (a, b) for a fixed span, Fig. 8 of 001_ad5bae0acea940c4.txt.

    For every (a, b) the class counts of Eq. (6) of 001_ad5bae0acea940c4.txt to Eq. (9) of 001_ad5bae0acea940c4.txt are computed (no sampling), giving the
    total ``N_p`` the criteria need; the accessible domain is ``N_p <= N_p^max``.

    Parameters
    ----------
    span : float
        CB span ``s`` in (0, 1), Eq. (17) of 001_ad5bae0acea940c4.txt.
    a_values, b_values : array, optional
        Shape parameters to scan (default ``linspace(0.25, 10, 40)`` each).
    max_total : int or sequence of int
        Accessibility limit(s) ``N_p^max``; several give several boundaries in the plot.
    """
    a_values = np.linspace(0.25, 10.0, 40) if a_values is None else np.asarray(a_values, float).ravel()
    b_values = np.linspace(0.25, 10.0, 40) if b_values is None else np.asarray(b_values, float).ravel()
    if a_values.size == 0 or b_values.size == 0:
        raise InvalidInputError("a_values and b_values must not be empty")
    limits = np.atleast_1d(np.asarray(max_total, dtype=np.int64))
    if np.any(limits < 1):
        raise InvalidInputError(f"max_total={max_total!r}: must be positive")
    n = np.empty((b_values.size, a_values.size), float)
    cu = np.empty_like(n)
    cc = np.empty_like(n)
    for j, b in enumerate(b_values):
        for i, a in enumerate(a_values):
            m = CumulativeBeta(a=a, b=b, span=span, d_max=1.0, dim=dim)
            try:
                n[j, i] = class_counts(m, n_classes, spacing, min_per_class, min_total, dim, count_basis).total
            except InfeasibleError:  # more than 1e18 particles
                n[j, i] = np.inf
            hz = hazen(m)
            cu[j, i], cc[j, i] = hz["Cu"], hz["Cc"]
    params = {"n_classes": n_classes, "spacing": spacing, "min_per_class": min_per_class, "min_total": min_total,
              "dim": dim, "count_basis": count_basis}
    mt = int(limits[0]) if limits.size == 1 else limits.tolist()
    return AccessibleDomain(float(span), a_values, b_values, n, mt, params, cu, cc)
