"""A discrete set of particle sizes, the input of the packers."""

from __future__ import annotations

import csv
import io as _io
import json
from pathlib import Path

import numpy as np

from .._util import atomic_open
from ..errors import FormatError, InvalidInputError
from ..geometry import ball_volume

__all__ = ["SizeSet"]


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating,)):
        return float(obj)
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


class SizeSet:
    """Particle radii with a species label per particle and a report.

    Attributes
    ----------
    radii : numpy.ndarray of float64, shape (N,)
        Particle radii (half the diameters of the size-distribution models).
    species : numpy.ndarray of int64, shape (N,)
        Size-class index (from :func:`~polypack.psd.discretize`, 0 = finest class) or mode
        index (from a :class:`~polypack.psd.Mixture`, in the order of its modes; for
        :class:`~polypack.psd.Bimodal` 0 = large, 1 = small, as seed 000's modes 1, 2).
    report : dict
        Descriptors, generation parameters and the seed record (JSON-able).
    """

    def __init__(self, radii, species=None, report=None, dim=3):
        r = np.array(radii, dtype=np.float64).ravel()
        if r.size == 0:
            raise InvalidInputError("radii: a size set needs at least one particle")
        bad = ~np.isfinite(r) | (r <= 0)
        if np.any(bad):
            i = int(np.argmax(bad))
            raise InvalidInputError(f"radius {float(r[i])!r} (index {i}): radii must be positive and finite")
        if species is None:
            s = np.zeros(r.size, np.int64)
        else:
            s = np.array(species).ravel()
            if s.size != r.size:
                raise InvalidInputError(f"species has {s.size} entries for {r.size} radii")
            if s.size and (not np.all(np.equal(np.mod(s, 1), 0)) or s.min() < 0):
                raise InvalidInputError("species: must be non-negative integers")
            s = s.astype(np.int64)
        self.radii = r
        self.species = s
        self.dim = int(dim)
        self.report = dict(report or {})
        self._model = None

    @classmethod
    def from_diameters(cls, diameters, species=None, report=None, model=None, dim=3):
        """Build from diameters (radii = d / 2), remembering the ``model`` they were drawn from.

        The set is data only: its descriptors (Hazen, moments, ``Cr`` against the model) are
        added to ``report["descriptors"]`` by the generators (``model.sample``,
        :func:`~polypack.psd.discretize`) through
        :func:`polypack.psd.descriptors.with_descriptors`, or computed on demand with
        :func:`polypack.psd.describe`.
        """
        out = cls(0.5 * np.asarray(diameters, float), species, report, dim=dim)
        out._model = model
        return out

    # -- basic properties ------------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of particles."""
        return int(self.radii.size)

    @property
    def diameters(self) -> np.ndarray:
        """Particle diameters ``2 * radii``."""
        return 2.0 * self.radii

    @property
    def model(self):
        """The model the set was generated from (None after :meth:`load`)."""
        return self._model

    @property
    def species_counts(self) -> np.ndarray:
        """Number of particles of each species ``0..max(species)``."""
        return np.bincount(self.species)

    def volumes(self) -> np.ndarray:
        """Particle volumes (``4/3 π r**3`` in 3D, ``π r**2`` in 2D)."""
        return ball_volume(self.radii, self.dim)

    def grading(self, d):
        """Grading curve of the set: volume fraction of particles with diameter ``<= d``.

        The ``y_exp(d)`` of Eq. (21) of 001_ad5bae0acea940c4.txt.
        """
        dd = self.diameters
        order = np.argsort(dd)
        ds = dd[order]
        cum = np.cumsum(ds**self.dim)
        cum /= cum[-1]
        k = np.searchsorted(ds, np.asarray(d, float), side="right")
        return np.where(k > 0, cum[np.maximum(k - 1, 0)], 0.0)

    def number_cdf(self, d):
        """Fraction by number of particles with diameter ``<= d``."""
        ds = np.sort(self.diameters)
        return np.searchsorted(ds, np.asarray(d, float), side="right") / ds.size

    def quantile(self, p):
        """Inverse grading curve of the set: smallest diameter ``d`` with ``grading(d) >= p``."""
        p = np.asarray(p, float)
        if np.any(~np.isfinite(p)) or np.any((p < 0) | (p > 1)):
            raise InvalidInputError(f"p={p!r}: probabilities must lie in [0, 1]")
        ds = np.sort(self.diameters)
        cum = np.cumsum(ds**self.dim)
        cum /= cum[-1]
        k = np.searchsorted(cum, p - 1e-12, side="left")
        return ds[np.clip(k, 0, ds.size - 1)]

    def __len__(self):
        return self.n

    def __repr__(self):
        return (f"SizeSet(n={self.n}, species={int(self.species.max()) + 1}, "
                f"d=[{self.diameters.min():.4g}, {self.diameters.max():.4g}])")

    # -- io --------------------------------------------------------------------------------
    @staticmethod
    def _report_path(path):
        path = Path(path)
        return path.with_suffix(".json") if path.suffix.lower() != ".json" else path.with_suffix(".report.json")

    def save(self, path, report_path=None):
        """Write ``radius,diameter,species`` rows as CSV and the report as JSON, both atomically.

        The report goes to ``report_path`` (default: same name with ``.json``). Returns the
        two paths.
        """
        path = Path(path)
        rpath = Path(report_path) if report_path is not None else self._report_path(path)
        with atomic_open(path, "w", newline="") as fh:
            fh.write("radius,diameter,species\n")
            for r, s in zip(self.radii, self.species):
                fh.write(f"{float(r)!r},{float(2.0 * r)!r},{int(s)}\n")
        with atomic_open(rpath, "w") as fh:
            json.dump(_jsonable({"dim": self.dim, **self.report}), fh, indent=2, sort_keys=False)
            fh.write("\n")
        return path, rpath

    @classmethod
    def load(cls, path, report_path=None):
        """Read a set written by :meth:`save` (the JSON report is optional).

        A CSV with a ``radius`` column (or only ``diameter``) and an optional ``species``
        column is accepted.
        """
        path = Path(path)
        try:
            text = path.read_text()
        except OSError as exc:
            raise FormatError(f"cannot read size set {path}: {exc.strerror}") from None
        except UnicodeDecodeError:
            raise FormatError(f"{path}: not a text size-set file (a CSV with a radius or diameter column)") from None
        reader = csv.reader(_io.StringIO(text))
        rows = [row for row in reader if row and "".join(row).strip()]
        if not rows:
            raise FormatError(f"{path}: empty size-set file")
        header = [h.strip().lower() for h in rows[0]]
        if "radius" not in header and "diameter" not in header:
            raise FormatError(f"{path}: header {rows[0]!r} has neither 'radius' nor 'diameter'")
        try:
            data = np.array([[float(x) for x in row] for row in rows[1:]], float)
        except ValueError as exc:
            raise FormatError(f"{path}: non-numeric entry ({exc})") from None
        if data.size == 0:
            raise FormatError(f"{path}: no particles")
        if data.ndim != 2 or data.shape[1] != len(header):
            raise FormatError(f"{path}: rows do not match header {rows[0]!r}")
        radii = data[:, header.index("radius")] if "radius" in header else 0.5 * data[:, header.index("diameter")]
        species = data[:, header.index("species")].astype(np.int64) if "species" in header else None
        rpath = Path(report_path) if report_path is not None else cls._report_path(path)
        report, dim = {}, 3
        if rpath.exists():
            try:
                report = json.loads(rpath.read_text())
            except json.JSONDecodeError as exc:
                raise FormatError(f"{rpath}: invalid JSON report ({exc.msg})") from None
            dim = int(report.pop("dim", 3))
        return cls(radii, species, report, dim=dim)

    # -- plots ---------------------------------------------------------------------------
    # Thin conveniences: the figures are drawn by polypack.psd.plots (which calls SizeSet, not
    # the reverse); they are found through the package's lazy exports, so this module imports
    # no descriptor or plotting module (tests/test_layers.py::test_no_import_cycles).
    def plot_grading(self, model=None, ax=None, **kw):
        """Grading curve of the set (steps) against ``model`` (line), Figs. 1 and 3 style:
        :func:`polypack.psd.plot_grading` ``(model or self.model, self)``."""
        from .. import psd

        return psd.plot_grading(model if model is not None else self._model, self, ax=ax, **kw)

    def plot_histogram(self, ax=None, **kw):
        """Particle counts and volume fractions per species: :func:`polypack.psd.plot_class_histogram`."""
        from .. import psd

        return psd.plot_class_histogram(self, ax=ax, **kw)
