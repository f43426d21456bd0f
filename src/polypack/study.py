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
Generated from the registry (:mod:`polypack.registry`; ``polypack.study.schema_doc()``
prints it with every type, bound, default and doc). The built-ins:

``[study]``
    ``name`` (str, default: file stem), ``description`` (str), ``seed`` (int >= 0, default 0),
    ``realizations`` (P, int >= 1, default 1).
``[psd]``
    The one ``[psd]`` table shared with ``polypack psd`` (:func:`polypack.psd.config.resolve`):
    ``model`` (default ``"bimodal"``): ``"bimodal"`` (``size_ratio``, ``volume_ratio``,
    ``d_large``, ``spread``), ``"cumulative_beta"``/``"cb"`` (``a``, ``b``, ``span`` or ``d_min``,
    ``d_max``), ``"uniform_volume"`` and ``"uniform_size"`` (``d_min``, ``d_max``, ``span``),
    ``"lognormal"`` (``median``, ``sigma``, ``d_min``, ``d_max``, ``basis``), ``"normal"``
    (``mean``, ``std``, ``d_min``, ``d_max``, ``basis``), ``"monodisperse"`` (``d``),
    ``"mixture"`` (``sizes``, ``volume_fractions``, ``spread``), ``"sieve"`` (``sieve`` CSV path,
    ``percent``); every model takes ``dim`` (3 spheres, 2 disks).  Sizes are **diameters** as in
    seed 001 (radii are half).  ``sampling = "sample"`` draws ``n`` particles
    (``method = "random" | "quantiles"``); ``sampling = "discretize"`` builds size classes
    (``n_classes``, ``spacing``, ``min_per_class``, ``min_total``, ``max_total``,
    ``count_basis``), §1.2 of 001_ad5bae0acea940c4.txt; the default is ``"sample"`` unless
    class keys are given without ``n``.
``[protocol]``
    ``kind`` picks a registered protocol, which accepts only its own options (a key another
    protocol uses is an error naming it).  ``"crm"``: ``volume_fraction`` (in (0, 1) or
    ``"jammed"``), ``growth_rate`` (> 0), ``max_seconds`` (wall-clock budget of the growth,
    > 0), ``global_shakes`` (M >= 0, default 0: a positive M shakes the finished pack),
    ``shake_radius`` (> 0), ``max_trials`` (>= 1), ``shake_method`` (``"paper"``,
    ``"collision"``, ``"metropolis"``), ``adaptive`` (bool).  ``"scrm"`` (default): the same
    without ``max_seconds`` (M default 60), plus ``schedule`` (increasing volume fractions of
    the growth stages; the target is appended), or ``growth_steps`` (>= 1) from
    ``start_fraction``; ``stage_shakes`` (global shakes after each stage).  ``"brownian"``: a
    colloidal gel by Brownian dynamics (``[psd]`` of one size; ``volume_fraction``,
    ``surface_potential`` and the SI options of :func:`polypack.brownian`; ``docs/brownian.md``).
    ``"deposit"``: sequential deposition of disks (``[psd] dim = 2``) or spheres (3D; ``width``,
    ``boundary``, ``order``, ``tolerance``, ``floor_rule`` (2D), ``rule`` (3D: ``"surface"`` or
    ``"roll"``, drop-and-roll); ``docs/deposition.md``).
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
``[analysis.elastic]``
    exact elastic tensor of the bonded network (``docs/mechanics.md``): ``bonds``, ``epsilon``,
    ``normal_stiffness``, ``shear_stiffness``, ``rotations``, ``radius``, ``solver``.
``[analysis.shear]``
    oscillatory shear test by bonded DEM (``docs/dem.md``): the bond options of
    ``[analysis.elastic]`` and those of :func:`polypack.mechanics.oscillatory_shear`.
``[analysis.deposit]``
    window statistics of a 2D or 3D deposit: ``margin``, ``contact_tolerance``, ``n_bins``; 3D:
    ``small_split``, ``small_layers`` (small-volume fraction against height, its slope and error).
``[analysis.moduli]``
    effective moduli of the composite (``docs/moduli.md``): ``matrix`` and ``inclusions``
    (``[E, nu]``, required), ``three_point``, ``mefm``.
``[output]``
    ``formats`` (list from ``"gsd"``, ``"xyz"``, ``"data"``, ``"vtp"``, ``"csv"``; GSD is always
    written), ``plots`` (bool), ``plot_format`` (``"png"`` | ``"pdf"`` | ``"svg"``).

Each ``[analysis.*]`` table that is present (it may be empty) switches that analysis on.
"""

from __future__ import annotations

import copy
import hashlib
import json
import tomllib
from dataclasses import dataclass
from pathlib import Path

from . import registry
from ._util import atomic_open
from ._validate import (  # noqa: F401  (re-exported: the checks used to live here)
    Bad as _Bad,
    boolean,
    choice,
    fmt as _fmt,
    formats,
    fraction_open,
    int_min,
    non_negative,
    positive,
    positive_or_list,
    schedule,
    size_ratio,
    string,
    type_name as _type_name,
    volume_fraction,
)
from .errors import InvalidInputError
from .registry import option

__all__ = ["Study", "load_study", "validate", "versions", "SCHEMA", "PSD_MODELS", "schema", "schema_doc"]


# --------------------------------------------------------------------------- schema
@dataclass(frozen=True)
class StudyOptions:
    """The ``[study]`` table."""

    name: str = option(None, string, "name used in file names and plots (default: the file stem)")
    description: str = option("", string, "free text")
    seed: int = option(0, int_min(0), "root seed; realization i uses SeedSequence(seed).spawn(P)[i]")
    realizations: int = option(1, int_min(1), "number of realizations P")


@dataclass(frozen=True)
class OutputOptions:
    """The ``[output]`` table."""

    formats: list = option(["gsd"], formats, "pack files written per realization (GSD is always written)")
    plots: bool = option(True, boolean, "write ensemble plots")
    plot_format: str = option("png", choice("png", "pdf", "svg"), "plot file format")


def schema() -> dict:
    """``{section: {key: OptionSpec}}`` of every table a study may hold, from the registry.

    ``"protocol"`` holds ``kind`` and the union of every protocol's options (each protocol
    accepts only its own); ``"psd"`` every generation key and model parameter.
    """
    from ._validate import choice as _choice
    from .psd import config as psd_config
    from .psd._capabilities import Generation

    out = {"study": registry.option_specs(StudyOptions)}
    psd = {k: s for k, s in registry.option_specs(Generation).items() if s.study}
    for cap in registry.capabilities("psd").values():
        for k, s in cap.specs().items():
            psd.setdefault(k, s)
    out["psd"] = psd
    protocols = registry.capabilities("protocol")
    proto = {"kind": registry.OptionSpec("kind", "scrm", _choice(*protocols), "packing protocol", "", False,
                                         True, True)}
    for cap in protocols.values():
        for k, s in cap.specs().items():
            proto.setdefault(k, s)
    out["protocol"] = proto
    for name, cap in registry.stages().items():  # analyses and mechanics stages
        out[f"analysis.{name}"] = cap.specs()
    out["output"] = registry.option_specs(OutputOptions)
    del psd_config
    return out


def schema_doc() -> str:
    """The study schema as text (one line per key: type and bounds, default, doc)."""
    lines = []
    for sec, specs in schema().items():
        lines.append(f"[{sec}]")
        for k, s in specs.items():
            default = "required" if s.required else ("unset" if s.default is None else _fmt(s.default))
            lines.append(f"  {k}: {s.describe}; default {default}. {s.doc}".rstrip())
    return "\n".join(lines)


def __getattr__(name):
    if name == "SCHEMA":
        return schema()
    if name == "PSD_MODELS":
        return {n: (c.run, tuple(c.specs())) for n, c in registry.capabilities("psd").items()}
    if name == "ANALYSES":
        return tuple(registry.stages())
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _check_table(path, table, specs):
    return registry.resolve_table(specs, table, path)


def _check_protocol(table, path="protocol"):
    """Resolve ``[protocol]``: ``kind`` picks the registered protocol, which accepts only its own options."""
    if not isinstance(table, dict):
        raise InvalidInputError(f"{path} = {_fmt(table)}: expected a table ([{path}])")
    protocols = registry.capabilities("protocol")
    kind = table.get("kind", "scrm")
    if not isinstance(kind, str) or kind not in protocols:
        raise InvalidInputError(f"{path}.kind = {_fmt(kind)}: allowed: {', '.join(_fmt(a) for a in protocols)}")
    cap = protocols[kind]
    specs = cap.specs()
    known = set().union(*(set(c.specs()) for c in protocols.values()))
    for key in table:
        if key == "kind" or key in specs:
            continue
        if key in known:
            users = [n for n, c in protocols.items() if key in c.specs()]
            only = " or ".join(f'{path}.kind = "{u}"' for u in users)
            raise InvalidInputError(
                f"{path}.{key}: only used with {only}, not with \"{kind}\"; "
                f"allowed: kind, {', '.join(specs)}"
            )
        raise InvalidInputError(f"{path}.{key}: unknown key; allowed in [{path}]: kind, {', '.join(specs)}")
    rest = cap.resolve({k: v for k, v in table.items() if k != "kind"}, path)
    return {"kind": kind, **rest}


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
    from .psd import config as psd_config

    if not isinstance(data, dict):
        raise InvalidInputError(f"study: expected a table, got {_type_name(data)}")
    sections = ("study", "psd", "protocol", "analysis", "output")
    for key in data:
        if key not in sections:
            raise InvalidInputError(f"{key}: unknown section; allowed: {', '.join(sections)}")
    res = {}
    res["study"] = _check_table("study", data.get("study", {}), registry.option_specs(StudyOptions))
    res["psd"] = psd_config.resolve(data.get("psd", {}), "psd", study=True)
    res["protocol"] = _check_protocol(data.get("protocol", {}))
    res["output"] = _check_table("output", data.get("output", {}), registry.option_specs(OutputOptions))
    if res["study"].get("name") is None:
        res["study"]["name"] = name or "study"
    ana = data.get("analysis", {})
    if not isinstance(ana, dict):
        raise InvalidInputError(f"analysis = {_fmt(ana)}: expected tables such as [analysis.rdf]")
    analyses = registry.stages()  # analyses and mechanics stages share [analysis.NAME]
    res["analysis"] = {}
    for key, table in ana.items():
        if key not in analyses:
            raise InvalidInputError(f"analysis.{key}: unknown analysis; allowed: {', '.join(analyses)}")
        res["analysis"][key] = analyses[key].resolve(table, f"analysis.{key}")

    if res["study"]["realizations"] > MAX_REALIZATIONS:
        raise InvalidInputError(
            f"study.realizations = {res['study']['realizations']}: at most {MAX_REALIZATIONS} "
            "(split a larger ensemble into several studies with different seeds)"
        )
    _check_protocol_fractions(res["protocol"])
    return {k: res[k] for k in ("study", "psd", "protocol", "output", "analysis")}


#: Largest ``study.realizations`` accepted (a typo such as 1e11 would hang the seed spawning).
MAX_REALIZATIONS = 1_000_000

#: Sections a study *file* must have (a dict passed to :func:`validate` may rely on defaults).
REQUIRED_SECTIONS = ("psd", "protocol")


def _check_protocol_fractions(pr):
    """Cross-option checks of the resolved ``[protocol]``: the SCRM start and schedule lie below the target."""
    vf = pr.get("volume_fraction")
    if not isinstance(vf, float):
        return
    start = pr.get("start_fraction")
    if start is not None and not (0 < start <= vf):
        raise InvalidInputError(
            f"protocol.start_fraction = {start!r}: must be in (0, protocol.volume_fraction = {vf!r}]"
        )
    schedule = pr.get("schedule")
    if isinstance(schedule, (list, tuple)) and schedule and schedule[-1] > vf:
        raise InvalidInputError(
            f"protocol.schedule = {list(schedule)!r}: must not exceed protocol.volume_fraction = {vf!r}"
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

    The kernels, generators, size distributions, analyses, mechanics, the data model and the
    realization stages: a resume trusts a saved realization only if it was computed by
    exactly this code (and the same polypack version), so a changed generator never
    silently reuses old packs.
    """
    import hashlib
    import os

    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    files = []
    for sub in ("_kernels", "generate", "psd", "analysis", "mechanics"):
        d = root / sub
        if d.is_dir():
            files += sorted(p for p in d.rglob("*.py"))
    files += [root / n for n in ("packing.py", "neighbors.py", "geometry.py", os.path.join("ensemble", "stages.py"),
                               os.path.join("ensemble", "moduli_stage.py"))]
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

    from ._version import __version__

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
