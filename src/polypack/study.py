"""Study files: one TOML file describing a whole ensemble of packs and their analyses.

A study takes a size distribution (seed 001_ad5bae0acea940c4.txt models, or the bimodal
λ, ξ description of 000_2cedc098acbd866b.txt) through a packing protocol (CRM §3.1 or
SCRM §3.2 of 000_2cedc098acbd866b.txt) to the descriptors of §2 of the same seed, for
``realizations`` seeded realizations.  It is run with ``polypack run study.toml --out DIR``
(see :mod:`polypack.ensemble`).

Example (``examples/bimodal_propellant.toml``)::

    [study]
    name = "bimodal_propellant"
    seed = 0
    realizations = 4

    [psd]
    model = "bimodal"
    size_ratio = 0.313      # λ = a2/a1
    volume_ratio = 0.333    # ξ = c2/c1
    d_large = 1.0
    n = 2000

    [protocol]
    kind = "scrm"
    volume_fraction = 0.6
    global_shakes = 60

    [analysis.rdf]
    r_max = 3.0
    dr = 0.02

    [output]
    formats = ["gsd"]
    plots = true

The file is validated completely before anything runs (:func:`validate`): an unknown key,
a wrong type or an impossible value raises :class:`~polypack.InvalidInputError` whose
message starts with the key path, e.g. ``protocol.volume_fraction = 1.2: must be in (0, 1)``.
The resolved study (every default filled in) is what the runner uses and what it writes
next to the results (:meth:`Study.write_resolved`).

Schema
------
``[study]``
    ``name`` (str, default: file stem), ``description`` (str), ``seed`` (int >= 0, default 0),
    ``realizations`` (P, int >= 1, default 1).
``[psd]``
    ``model``: ``"bimodal"`` (``size_ratio``, ``volume_ratio``, ``d_large``, ``spread``),
    ``"cumulative_beta"`` (``a``, ``b``, ``span`` or ``d_min``, ``d_max``), ``"uniform_volume"``
    and ``"uniform_size"`` (``d_min``, ``d_max``, ``span``), ``"lognormal"`` (``median``,
    ``sigma``, ``d_min``, ``d_max``, ``basis``), ``"normal"`` (``mean``, ``std``, ``d_min``,
    ``d_max``, ``basis``), ``"monodisperse"`` (``d``).  Sizes are **diameters** as in
    seed 001 (radii are half).  ``sampling = "sample"`` draws ``n`` particles
    (``method = "random" | "quantiles"``); ``sampling = "discretize"`` builds size classes
    (``n_classes``, ``spacing``, ``min_per_class``, ``min_total``, ``max_total``), §1.2 of
    001_ad5bae0acea940c4.txt.
``[protocol]``
    ``kind = "crm" | "scrm"``, ``volume_fraction`` (in (0, 1) or ``"jammed"``),
    ``growth_rate`` (> 0), ``max_seconds`` (wall-clock budget of the growth, > 0),
    ``global_shakes`` (M >= 0; for ``"crm"`` a positive M shakes the finished pack),
    ``shake_radius`` (> 0), ``max_trials`` (>= 1), ``shake_method`` (``"paper"``, ``"collision"``,
    ``"metropolis"``), ``adaptive`` (bool);
    SCRM only: ``schedule`` (increasing volume fractions of the growth stages; the target is
    appended), or ``growth_steps`` (>= 1) from ``start_fraction``; ``stage_shakes`` (global
    shakes after each stage).
``[analysis.rdf]``
    ``r_max`` (> 0, user length units), ``dr`` (> 0), ``method``, ``scale``.
``[analysis.kfunction]``
    ``r_max``, ``dr``, ``scale``.
``[analysis.windows]``
    ``window_radius`` (R_h in units of the reference sphere radius, > 0), ``reference``.
``[analysis.contacts]``
    ``tolerance`` (>= 0), ``min_contacts`` (>= 0).
``[analysis.pores]``
    ``n_points`` (>= 100), ``n_grid`` (>= 10).
``[output]``
    ``formats`` (list from ``"gsd"``, ``"xyz"``, ``"data"``, ``"vtp"``, ``"csv"``; GSD is always
    written), ``plots`` (bool), ``plot_format`` (``"png"`` | ``"pdf"`` | ``"svg"``).

Each ``[analysis.*]`` table that is present (it may be empty) switches that analysis on.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

from ._util import atomic_open
from .errors import InvalidInputError

__all__ = ["Study", "load_study", "validate", "versions", "SCHEMA", "PSD_MODELS"]

_MISSING = object()


# --------------------------------------------------------------------------- checks
def _type_name(value):
    return {bool: "boolean", int: "integer", float: "float", str: "string", list: "array", dict: "table"}.get(
        type(value), type(value).__name__
    )


def _fmt(value):
    if isinstance(value, str):
        return repr(value).replace("'", '"')
    return repr(value)


class _Bad(Exception):
    """Raised by a check with the reason; the caller adds the key path."""


def _number(v):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise _Bad(f"expected a number, got {_type_name(v)}")
    v = float(v)
    if not math.isfinite(v):
        raise _Bad("must be finite")
    return v


def _integer(v):
    if isinstance(v, bool) or not isinstance(v, int):
        if isinstance(v, float) and v.is_integer():
            return int(v)
        raise _Bad(f"expected an integer, got {_type_name(v)}")
    return v


def positive(v):
    v = _number(v)
    if not v > 0:
        raise _Bad("must be > 0")
    return v


def non_negative(v):
    v = _number(v)
    if v < 0:
        raise _Bad("must be >= 0")
    return v


def fraction_open(v):
    v = _number(v)
    if not 0 < v < 1:
        raise _Bad("must be in (0, 1)")
    return v


def size_ratio(v):
    v = _number(v)
    if not 0 < v <= 1:
        raise _Bad("must be in (0, 1] (λ = a2/a1)")
    return v


def int_min(lo):
    def check(v):
        v = _integer(v)
        if v < lo:
            raise _Bad(f"must be an integer >= {lo}")
        return v

    check.__doc__ = f"integer >= {lo}"
    return check


def string(v):
    if not isinstance(v, str):
        raise _Bad(f"expected a string, got {_type_name(v)}")
    return v


def boolean(v):
    if not isinstance(v, bool):
        raise _Bad(f"expected true or false, got {_type_name(v)}")
    return v


def choice(*allowed):
    def check(v):
        if not isinstance(v, str) or v not in allowed:
            raise _Bad(f"allowed: {', '.join(_fmt(a) for a in allowed)}")
        return v

    return check


def volume_fraction(v):
    if isinstance(v, str):
        if v != "jammed":
            raise _Bad('allowed: a number in (0, 1) or "jammed"')
        return v
    return fraction_open(v)


def positive_or_list(v):
    if isinstance(v, list):
        if not v:
            raise _Bad("must not be empty")
        return [positive(x) for x in v]
    return positive(v)


def schedule(v):
    if not isinstance(v, list):
        raise _Bad(f"expected an array of volume fractions, got {_type_name(v)}")
    out = [fraction_open(x) for x in v]
    if any(b <= a for a, b in zip(out, out[1:])):
        raise _Bad("volume fractions must increase")
    return out


_FORMATS = ("gsd", "xyz", "data", "vtp", "csv")


def formats(v):
    if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
        raise _Bad("expected an array of strings")
    bad = [x for x in v if x not in _FORMATS]
    if bad:
        raise _Bad(f"unknown format {_fmt(bad[0])}; allowed: {', '.join(_fmt(a) for a in _FORMATS)}")
    return ["gsd"] + [x for x in dict.fromkeys(v) if x != "gsd"]


# --------------------------------------------------------------------------- schema
@dataclass(frozen=True)
class Field:
    """One key of a study table: its check (returns the normalised value) and default."""

    check: object
    default: object = _MISSING  # _MISSING: required; None: optional, left out when unset
    doc: str = ""


PSD_MODELS = {
    "bimodal": ("Bimodal", ("size_ratio", "volume_ratio", "d_large", "spread")),
    "cumulative_beta": ("CumulativeBeta", ("a", "b", "span", "d_min", "d_max")),
    "uniform_volume": ("UniformVolume", ("d_min", "d_max", "span")),
    "uniform_size": ("UniformSize", ("d_min", "d_max", "span")),
    "lognormal": ("LogNormal", ("median", "sigma", "d_min", "d_max", "basis")),
    "normal": ("Normal", ("mean", "std", "d_min", "d_max", "basis")),
    "monodisperse": ("Monodisperse", ("d",)),
}

_MODEL_DEFAULTS = {
    "bimodal": {"size_ratio": 0.313, "volume_ratio": 0.333, "d_large": 1.0},
    "cumulative_beta": {"a": 1.0, "b": 1.0},
    "lognormal": {"median": 1.0, "sigma": 0.2},
    "normal": {"mean": 1.0, "std": 0.1},
    "monodisperse": {"d": 1.0},
}

_CLASS_KEYS = ("n_classes", "spacing", "min_per_class", "min_total", "max_total")

SCHEMA = {
    "study": {
        "name": Field(string, None, "name used in file names and plots (default: the file stem)"),
        "description": Field(string, ""),
        "seed": Field(int_min(0), 0, "root seed; realization i uses SeedSequence(seed).spawn(P)[i]"),
        "realizations": Field(int_min(1), 1, "number of realizations P"),
    },
    "psd": {
        "model": Field(choice(*PSD_MODELS), "bimodal"),
        "n": Field(int_min(2), None, "number of particles (sampling = 'sample', default 2000)"),
        "sampling": Field(choice("sample", "discretize"), "sample"),
        "method": Field(choice("random", "quantiles"), "random"),
        # model parameters (checked against the model below)
        "size_ratio": Field(size_ratio, None),
        "volume_ratio": Field(positive, None),
        "d_large": Field(positive, None),
        "spread": Field(non_negative, None),
        "a": Field(positive, None),
        "b": Field(positive, None),
        "span": Field(fraction_open, None),
        "d_min": Field(positive, None),
        "d_max": Field(positive, None),
        "median": Field(positive, None),
        "sigma": Field(positive, None),
        "mean": Field(positive, None),
        "std": Field(positive, None),
        "basis": Field(choice("number", "volume"), None),
        "d": Field(positive, None),
        # size classes (sampling = 'discretize')
        "n_classes": Field(int_min(1), None),
        "spacing": Field(choice("geometric", "regular", "isochoric", "modes"), None),
        "min_per_class": Field(int_min(1), None),
        "min_total": Field(int_min(1), None),
        "max_total": Field(int_min(2), None),
    },
    "protocol": {
        "kind": Field(choice("crm", "scrm"), "scrm"),
        "volume_fraction": Field(volume_fraction, 0.6),
        "growth_rate": Field(positive, None),
        "max_seconds": Field(positive, None),
        "global_shakes": Field(int_min(0), None),
        "shake_radius": Field(positive, None),
        "max_trials": Field(int_min(1), None),
        "shake_method": Field(choice("paper", "collision", "metropolis"), None),
        "adaptive": Field(boolean, None),
        "schedule": Field(schedule, None),
        "growth_steps": Field(int_min(1), None),
        "start_fraction": Field(fraction_open, None),
        "stage_shakes": Field(int_min(0), None),
    },
    "analysis.rdf": {
        "r_max": Field(positive, 3.0),
        "dr": Field(positive, 0.02),
        "method": Field(string, None),
        "scale": Field(string, None),
    },
    "analysis.kfunction": {
        "r_max": Field(positive, 3.0),
        "dr": Field(positive, 0.02),
        "scale": Field(string, None),
    },
    "analysis.windows": {
        "window_radius": Field(positive_or_list, 2.5),
        "reference": Field(string, None),
    },
    "analysis.contacts": {
        "tolerance": Field(non_negative, 0.01),
        "min_contacts": Field(int_min(0), None),
    },
    "analysis.pores": {
        "n_points": Field(int_min(100), 100_000),
        "n_grid": Field(int_min(10), None),
    },
    "output": {
        "formats": Field(formats, ["gsd"]),
        "plots": Field(boolean, True),
        "plot_format": Field(choice("png", "pdf", "svg"), "png"),
    },
}

ANALYSES = tuple(k.split(".", 1)[1] for k in SCHEMA if k.startswith("analysis."))
_DEFAULT_SHAKES = {"crm": 0, "scrm": 60}


def _check_table(path, table, spec):
    if not isinstance(table, dict):
        raise InvalidInputError(f"{path} = {_fmt(table)}: expected a table ([{path}])")
    out = {}
    for key, value in table.items():
        if key not in spec:
            allowed = ", ".join(spec)
            raise InvalidInputError(f"{path}.{key}: unknown key; allowed in [{path}]: {allowed}")
        try:
            out[key] = spec[key].check(value)
        except _Bad as exc:
            raise InvalidInputError(f"{path}.{key} = {_fmt(value)}: {exc}") from None
    for key, field in spec.items():
        if key in out:
            continue
        if field.default is _MISSING:
            raise InvalidInputError(f"{path}.{key}: required key is missing")
        if field.default is not None:
            out[key] = copy.deepcopy(field.default)
    return out


def validate(data, name=None) -> dict:
    """Validate a study (the parsed TOML as a dict) and return it resolved (defaults filled).

    Parameters
    ----------
    data : dict
        Parsed study file.
    name : str, optional
        Default for ``study.name`` (the file stem).

    Returns
    -------
    dict
        ``{"study": {...}, "psd": {...}, "protocol": {...}, "analysis": {name: {...}},
        "output": {...}}`` with every default filled in; optional keys that are unset are
        left out (the stage functions use their own defaults).

    Raises
    ------
    InvalidInputError
        With the key path first: ``protocol.volume_fraction = 1.2: must be in (0, 1)``.
    """
    if not isinstance(data, dict):
        raise InvalidInputError(f"study: expected a table, got {_type_name(data)}")
    sections = ("study", "psd", "protocol", "analysis", "output")
    for key in data:
        if key not in sections:
            raise InvalidInputError(f"{key}: unknown section; allowed: {', '.join(sections)}")
    res = {}
    for sec in ("study", "psd", "protocol", "output"):
        res[sec] = _check_table(sec, data.get(sec, {}), SCHEMA[sec])
    if res["study"].get("name") is None:
        res["study"]["name"] = name or "study"
    ana = data.get("analysis", {})
    if not isinstance(ana, dict):
        raise InvalidInputError(f"analysis = {_fmt(ana)}: expected tables such as [analysis.rdf]")
    res["analysis"] = {}
    for key, table in ana.items():
        if key not in ANALYSES:
            raise InvalidInputError(f"analysis.{key}: unknown analysis; allowed: {', '.join(ANALYSES)}")
        res["analysis"][key] = _check_table(f"analysis.{key}", table, SCHEMA[f"analysis.{key}"])

    if res["study"]["realizations"] > MAX_REALIZATIONS:
        raise InvalidInputError(
            f"study.realizations = {res['study']['realizations']}: at most {MAX_REALIZATIONS} "
            "(split a larger ensemble into several studies with different seeds)"
        )
    _check_psd(res["psd"])
    _check_protocol(res["protocol"])
    return res


#: Largest ``study.realizations`` accepted (a typo such as 1e11 would hang the seed spawning).
MAX_REALIZATIONS = 1_000_000

#: Sections a study *file* must have (a dict passed to :func:`validate` may rely on defaults).
REQUIRED_SECTIONS = ("psd", "protocol")


def _check_psd(psd):
    model = psd["model"]
    allowed = set(PSD_MODELS[model][1])
    params = {k for k in psd if k in _all_model_params()}
    for k in sorted(params - allowed):
        raise InvalidInputError(
            f"psd.{k}: not a parameter of model {_fmt(model)}; allowed: {', '.join(PSD_MODELS[model][1])}"
        )
    for k, v in _MODEL_DEFAULTS.get(model, {}).items():
        psd.setdefault(k, v)
    if psd["sampling"] == "sample":
        psd.setdefault("n", 2000)
        for k in _CLASS_KEYS:
            if k in psd:
                raise InvalidInputError(f"psd.{k}: only used with psd.sampling = \"discretize\"")
    else:
        if "n" in psd:
            raise InvalidInputError('psd.n: not used with psd.sampling = "discretize" (the class criteria set N)')
        psd.setdefault("n_classes", 10)
    for lo, hi in (("d_min", "d_max"),):
        if lo in psd and hi in psd and not psd[lo] < psd[hi]:
            raise InvalidInputError(f"psd.{lo} = {psd[lo]!r}: must be < psd.d_max = {psd[hi]!r}")
    if "span" in psd and "d_min" in psd and "d_max" in psd:
        raise InvalidInputError("psd.span: give span or d_min, not both with d_max")


def _all_model_params():
    return {p for _, ps in PSD_MODELS.values() for p in ps}


def _check_protocol(pr):
    kind = pr["kind"]
    pr.setdefault("global_shakes", _DEFAULT_SHAKES[kind])
    if kind == "crm":
        for key in ("schedule", "growth_steps", "start_fraction", "stage_shakes"):
            if key in pr:
                raise InvalidInputError(f'protocol.{key}: only used with protocol.kind = "scrm"')
    elif pr["volume_fraction"] == "jammed":
        raise InvalidInputError('protocol.volume_fraction = "jammed": SCRM needs a number in (0, 1)')
    elif "start_fraction" in pr and not (0 < pr["start_fraction"] <= pr["volume_fraction"]):
        raise InvalidInputError(
            f"protocol.start_fraction = {pr['start_fraction']!r}: must be in (0, protocol.volume_fraction = "
            f"{pr['volume_fraction']!r}]"
        )
    if isinstance(pr["volume_fraction"], float) and "schedule" in pr:
        if pr["schedule"][-1] > pr["volume_fraction"]:
            raise InvalidInputError(
                f"protocol.schedule = {pr['schedule']!r}: must not exceed protocol.volume_fraction = "
                f"{pr['volume_fraction']!r}"
            )


# --------------------------------------------------------------------------- Study
def _canonical(obj) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


class Study:
    """A validated, resolved study.

    Attributes
    ----------
    data : dict
        The resolved study (see :func:`validate`).
    source : str or None
        Path of the file it was read from.
    """

    def __init__(self, data, source=None):
        self.data = data
        self.source = None if source is None else str(source)

    @classmethod
    def from_dict(cls, data, name=None):
        """Validate ``data`` (a parsed TOML dict) into a Study."""
        return cls(validate(copy.deepcopy(data), name=name))

    @property
    def name(self) -> str:
        return self.data["study"]["name"]

    @property
    def seed(self) -> int:
        return self.data["study"]["seed"]

    @property
    def realizations(self) -> int:
        return self.data["study"]["realizations"]

    @property
    def analyses(self) -> dict:
        return self.data["analysis"]

    @property
    def fingerprint(self) -> str:
        """sha256 of everything that determines a realization's results.

        ``study.name``, ``study.description``, ``study.realizations`` and ``[output]`` are
        left out: renaming, adding realizations (children of ``SeedSequence(seed).spawn``
        do not depend on their number) or changing plots reuses finished realizations.
        """
        d = copy.deepcopy(self.data)
        d["study"] = {"seed": d["study"]["seed"]}
        d.pop("output", None)
        return hashlib.sha256(_canonical(d).encode()).hexdigest()

    def replace(self, **sections):
        """A copy with some keys changed: ``study.replace(study={"realizations": 2})``."""
        d = copy.deepcopy(self.data)
        for sec, upd in sections.items():
            d.setdefault(sec, {}).update(upd)
        return Study(validate(d, name=self.name), self.source)

    def to_toml(self) -> str:
        """The resolved study as TOML text."""
        return _dump_toml(self.data)

    def write_resolved(self, folder, extra=None):
        """Write ``study.resolved.toml`` and ``study.resolved.json`` (with versions) atomically."""
        folder = Path(folder)
        with atomic_open(folder / "study.resolved.toml", "w", encoding="utf-8") as fh:
            fh.write(f"# resolved study ({self.name}); fingerprint {self.fingerprint}\n")
            fh.write(self.to_toml())
        doc = {"study": self.data, "fingerprint": self.fingerprint, "source": self.source, "versions": versions()}
        if extra:
            doc.update(extra)
        with atomic_open(folder / "study.resolved.json", "w", encoding="utf-8") as fh:
            json.dump(doc, fh, indent=2, sort_keys=False)
            fh.write("\n")

    def __repr__(self):
        return f"Study(name={self.name!r}, seed={self.seed}, realizations={self.realizations})"


def load_study(path_or_data) -> Study:
    """Read and validate a study file (TOML), or validate a dict.

    Raises
    ------
    InvalidInputError
        The file is missing, is not valid TOML, lacks a ``[psd]`` or ``[protocol]``
        section, or a key is unknown, mistyped or out of range (the message names its
        key path).  A dict may leave sections out (their defaults are used).
    """
    if isinstance(path_or_data, Study):
        return path_or_data
    if isinstance(path_or_data, dict):
        return Study.from_dict(path_or_data)
    path = Path(path_or_data)
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise InvalidInputError(f"study file {str(path)!r} does not exist") from None
    except IsADirectoryError:
        raise InvalidInputError(f"study file {str(path)!r} is a folder; give the study's TOML file") from None
    except OSError as exc:
        raise InvalidInputError(f"study file {str(path)!r} cannot be read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise InvalidInputError(f"study file {str(path)!r} is not a UTF-8 text file") from None
    except tomllib.TOMLDecodeError as exc:
        raise InvalidInputError(f"{path}: not valid TOML ({exc})") from None
    resolved = validate(data, name=path.stem)  # errors of the sections present come first
    missing = [sec for sec in REQUIRED_SECTIONS if sec not in data]
    if missing:
        what = "is empty" if not data else f"has no [{'] or ['.join(missing)}] section"
        raise InvalidInputError(
            f"study file {str(path)!r} {what}: a study names its size distribution ([psd] model = ...) "
            "and its packing protocol ([protocol] kind, volume_fraction); see docs/run.md"
        )
    st = Study(resolved, source=path)
    return st


def code_digest() -> str:
    """sha256 (16 hex digits) of the sources that determine a realization's results.

    The kernels, generators, size distributions, analyses, the data model and the
    realization stages: a resume trusts a saved realization only if it was computed by
    exactly this code (and the same polypack version), so a changed generator never
    silently reuses old packs.
    """
    import hashlib
    import os

    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    files = []
    for sub in ("_kernels", "generate", "psd", "analysis"):
        d = root / sub
        if d.is_dir():
            files += sorted(p for p in d.rglob("*.py"))
    files += [root / n for n in ("packing.py", "neighbors.py", "geometry.py", os.path.join("ensemble", "stages.py"))]
    for p in files:
        try:
            data = p.read_bytes()
        except OSError:
            continue
        h.update(str(p.relative_to(root)).encode() + b"\0" + data)
    return h.hexdigest()[:16]


def versions() -> dict:
    """Versions of polypack, python, numpy, numba (and scipy, gsd) for provenance."""
    import platform

    import numpy

    from . import __version__

    out = {"polypack": __version__, "python": platform.python_version(), "numpy": numpy.__version__}
    for mod in ("numba", "scipy", "gsd"):
        try:
            out[mod] = __import__(mod).__version__
        except Exception:  # pragma: no cover - optional
            out[mod] = None
    out["platform"] = platform.platform()
    out["code"] = code_digest()
    return out


# --------------------------------------------------------------------------- TOML out
def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _dump_toml(data) -> str:
    lines = []

    def table(prefix, tab):
        scalars = {k: v for k, v in tab.items() if not isinstance(v, dict) and v is not None}
        subs = {k: v for k, v in tab.items() if isinstance(v, dict)}
        if scalars or not subs:
            lines.append(f"\n[{prefix}]")
            for k, v in scalars.items():
                lines.append(f"{k} = {_toml_value(v)}")
        for k, v in subs.items():
            table(f"{prefix}.{k}", v)

    for sec, tab in data.items():
        table(sec, tab)
    return "\n".join(lines).lstrip("\n") + "\n"
