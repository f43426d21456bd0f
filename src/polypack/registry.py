"""One declaration per capability: PSD models, packing protocols, analyses, mechanics stages.

A capability is declared once, with

* its ``kind`` (``"psd"``, ``"protocol"``, ``"analysis"``, ``"mechanics"``) and TOML/CLI ``name``;
* an **options dataclass** whose fields carry their check (type and bounds, from
  :mod:`polypack._validate`), default and doc in the field metadata (use :func:`option`);
* the function that runs it, as ``"module:function"`` (imported only when it runs, so
  declarations stay light) or a callable;
* what it outputs (:class:`Outputs`: the scalars for ``summary.csv``, the curves with
  their x and labels for the ensemble curves and plots, files).

The study schema (:mod:`polypack.study`), the stage runner and the aggregation of
``polypack run`` (:mod:`polypack.ensemble`), and the ``polypack psd`` table are generated
from these declarations. See ``docs/registry.md`` ("How to add a capability").

Discovery. The built-in declarations live in a ``_capabilities`` module of each
subpackage (``polypack/analysis/_capabilities.py``, ``polypack/generate/_capabilities.py``
...); every such module is imported on first use. Third-party packages add capabilities
through the entry-point group ``polypack.capabilities``: each entry point names a module
(imported) or a callable (called with this module) that calls :func:`register`.

Run signatures (what the ``run`` target receives):

``analysis``  ``run(packing, options: dict, seed: numpy.random.SeedSequence)`` returning an
              object with ``to_dict()`` (or a list of them), or a plain dict.
``mechanics`` the same as ``analysis`` (a mechanics stage reads the pack and returns its
              results); analyses and mechanics stages share the study's ``[analysis.NAME]``
              tables (:func:`stages`), so their names are unique across both kinds.
``protocol``  ``run(sizes, options: dict, seed: numpy.random.SeedSequence, monitor=None) -> Packing``;
              ``monitor`` is the convergence monitor the runner passes (see :func:`polypack.shake`).
``psd``       ``run(**parameters)`` returning a size-distribution model (``.sample``,
              ``.grading`` ...).

``options`` is the validated table with defaults filled; optional options that are unset
are absent, so the called function applies its own default.

This module imports nothing heavy (no numpy).
"""

from __future__ import annotations

import copy
import dataclasses
import importlib
import pkgutil
from dataclasses import MISSING, dataclass, field
from typing import Any, Callable

from ._validate import Bad, fmt
from .errors import InvalidInputError

__all__ = [
    "KINDS",
    "REQUIRED",
    "option",
    "Curves",
    "Outputs",
    "Capability",
    "register",
    "unregister",
    "get",
    "names",
    "capabilities",
    "discover",
    "stages",
    "STAGE_KINDS",
    "option_specs",
    "resolve_table",
    "defaults",
    "api_kwargs",
    "check_call",
    "ENTRY_POINT_GROUP",
]

KINDS = ("psd", "protocol", "analysis", "mechanics")
#: Kinds whose capabilities run on a finished pack, one ``[analysis.NAME]`` table each.
STAGE_KINDS = ("analysis", "mechanics")
ENTRY_POINT_GROUP = "polypack.capabilities"


class _Required:
    def __repr__(self):
        return "REQUIRED"


#: Default of an option that must be given.
REQUIRED = _Required()


def option(default=None, check=None, doc: str = "", *, unit: str = "", study: bool = True, cli: bool = True,
           api: str = "", fill: bool = True, unset: str = ""):
    """A dataclass field for an options class, with its check and doc in the metadata.

    Parameters
    ----------
    default
        Default value; ``None`` means optional and left out of the resolved table when
        unset (the run function's own default applies); :data:`REQUIRED` means required.
    check : callable
        A check of :mod:`polypack._validate` (returns the normalised value or raises
        :class:`~polypack._validate.Bad`).
    doc : str
        One line for the generated docs and CLI help.
    unit : str
        Unit or reduced coordinate of the value: the one unit of the quantity in the
        Python API, the study file and the command line alike (docs and CLI help show it).
    study, cli : bool
        Whether the option is offered in study files and on the command line.
    api : str
        Keyword of the public function when it differs from the field name
        (``shake_method`` -> ``shake(method=...)``); see :func:`api_kwargs`.
    fill : bool
        Whether :func:`resolve_table` writes the default into a resolved study table.
        ``False`` keeps an unset option absent (the run function applies the same
        declared default), so the fingerprints of studies written before the default was
        declared here stay the same.
    unset : str
        With ``default=None``: what the run does when the option is not given, a value or a
        rule in a few words (``"k_n / 10"``, ``"298.15 K"``, ``"all cycles"``); the reference
        page shows it as the default (``unset: k_n / 10``) and the CLI help as
        ``unset: k_n / 10``. Every optional field declares it (``tests/test_declarations.py``).
    """
    md = {"check": check, "doc": doc, "unit": unit, "study": study, "cli": cli, "required": default is REQUIRED,
          "api": api, "fill": fill, "unset": unset}
    if isinstance(default, (list, dict)):
        return field(default_factory=lambda d=default: copy.deepcopy(d), metadata=md)
    return field(default=None if default is REQUIRED else default, metadata=md)


@dataclass(frozen=True)
class Curves:
    """How an analysis result holds curves, and how to plot their ensemble means.

    Attributes
    ----------
    x : str
        Key of the x array in the result dict (``"r"``, ``"n_h"``).
    x_label, y_label : str
        Axis labels with units or reduced coordinates.
    plot : tuple of str or None
        Curves drawn in the ensemble plot (``None``: every curve).
    partials : bool
        Draw the ``partial.*`` curves.
    style : {"line", "points"}
        Lines with a shaded 95 % band, or points with error bars.
    histogram : bool
        Curves of different lengths are padded with zeros (counts histograms) instead of
        being interpolated onto one grid.
    """

    x: str = "r"
    x_label: str = ""
    y_label: str = ""
    plot: tuple | None = None
    partials: bool = True
    style: str = "line"
    histogram: bool = False


#: Result keys that are never summary scalars (bookkeeping and echoed options).
BASE_SCALAR_SKIP = ("n_realizations", "estimator", "dr", "r_max", "n_points", "tolerance", "min_contacts")


@dataclass(frozen=True)
class Outputs:
    """What a capability outputs.

    Attributes
    ----------
    scalars : tuple of str or None
        Result keys that are summary scalars (``None``: every numeric top-level key except
        :data:`BASE_SCALAR_SKIP` and ``scalar_skip``).
    scalar_skip : tuple of str
        Extra keys that are not scalars.
    flatten : tuple of str
        Nested keys (per-species matrices, fit tables) flattened into scalars
        ``name.key.i-j`` / ``name.key.sub.item``.
    curves : Curves or None
        The curves of the result, if any.
    files : tuple of str
        Names of extra files the run writes (documentation).
    meta : tuple of str or None
        Protocols only: the sub-tables of ``packing.meta`` that hold the protocol's run
        statistics (``meta["vem"]``); their numbers, strings and the last row of their
        per-species histories reach the realization record and ``summary.csv`` as
        ``protocol.<table>.<key>`` (:func:`polypack.ensemble.stages.protocol_stats`).
        ``None``: the sub-table named like the protocol, if any.  Top-level scalars of
        ``packing.meta`` (``status``, ``min_gap``, ...) are always recorded, or only those in
        ``scalars`` when it is given.
    labels : dict
        Words for the report's rows: ``{column: words}`` where ``column`` is the summary
        column without the stage prefix (``"stages"`` for ``protocol.vem.stages`` or
        ``elastic.stages``; a protocol may also give the full ``"vem.stages"``).
    """

    scalars: tuple | None = None
    scalar_skip: tuple = ()
    flatten: tuple = ()
    curves: Curves | None = None
    files: tuple = ()
    meta: tuple | None = None
    labels: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Capability:
    """One registered capability (see the module docstring)."""

    kind: str
    name: str
    options: type
    run: Any
    outputs: Outputs = Outputs()
    doc: str = ""
    aliases: tuple = ()
    requires: tuple = ()  # "module:attribute" that must import for the capability to be available
    check: Any = None  # check(resolved_options, path): cross-key validation after the table checks
    preflight: Any = None  # preflight(resolved_options, info, path): before a study runs (info: box estimate)
    kernels: tuple = ()  # numba kernel modules it runs ("polypack._kernels.edmd"): compiled once before a pool
    origin: str = ""
    label: str = ""  # display name in reports and figure legends ("VEM"); default: the name

    @property
    def title(self) -> str:
        """The display name (``label`` or ``name``)."""
        return self.label or self.name

    def meta_tables(self) -> tuple:
        """Protocols: the ``packing.meta`` sub-tables of its declared run statistics."""
        m = self.outputs.meta
        return (self.name,) if m is None else tuple(m)

    def words(self, column: str) -> str:
        """The declared words of a summary column (without the stage prefix), or ``""``."""
        return str(self.outputs.labels.get(column, ""))

    def load(self) -> Callable:
        """The run function (imported on first use)."""
        return _load(self.run)

    def specs(self) -> dict:
        """``{option: OptionSpec}`` in declaration order."""
        return option_specs(self.options)

    def resolve(self, table: dict, path: str | None = None) -> dict:
        """Validate ``table`` against the options, fill defaults (see :func:`resolve_table`), run ``check``.

        ``path`` names the table in messages; default: the study's, ``analysis.NAME`` for the analyses
        and mechanics stages (they share ``[analysis.NAME]``), else ``KIND.NAME``."""
        path = path or (f"analysis.{self.name}" if self.kind in STAGE_KINDS else f"{self.kind}.{self.name}")
        out = resolve_table(self.specs(), table, path)
        if self.check is not None:
            _load(self.check)(out, path)
        return out

    def available(self) -> bool:
        for target in self.requires:
            try:
                _load(target)
            except (ImportError, AttributeError):
                return False
        return True


@dataclass(frozen=True)
class OptionSpec:
    name: str
    default: Any
    check: Callable | None
    doc: str
    unit: str
    required: bool
    study: bool
    cli: bool
    api: str = ""
    fill: bool = True
    unset: str = ""  # default None: what the run does when the option is not given

    @property
    def describe(self) -> str:
        return getattr(self.check, "describe", "value")


def option_specs(options_cls) -> dict:
    """``{name: OptionSpec}`` of an options dataclass (fields made with :func:`option`)."""
    if not dataclasses.is_dataclass(options_cls):
        raise TypeError(f"options must be a dataclass, got {options_cls!r}")
    out = {}
    for f in dataclasses.fields(options_cls):
        md = f.metadata
        if f.default is not MISSING:
            default = f.default
        elif f.default_factory is not MISSING:
            default = f.default_factory()
        else:
            default = REQUIRED
        required = md.get("required", default is REQUIRED)
        out[f.name] = OptionSpec(f.name, REQUIRED if required else default, md.get("check"), md.get("doc", ""),
                                 md.get("unit", ""), required, md.get("study", True), md.get("cli", True),
                                 md.get("api", ""), md.get("fill", True), md.get("unset", ""))
    return out


def defaults(options_cls) -> dict:
    """``{field: default}`` of an options dataclass (the public functions take their defaults from here)."""
    return {k: s.default for k, s in option_specs(options_cls).items() if not s.required}


def api_kwargs(options_cls, table: dict) -> dict:
    """Keyword arguments of the public function from a resolved table (field names -> ``api`` names)."""
    specs = option_specs(options_cls)
    return {(specs[k].api or k) if k in specs else k: v for k, v in table.items()}


def check_call(options_cls, kwargs: dict) -> dict:
    """Check the keyword arguments of a public function against its options dataclass.

    Every value goes through its field's check (the same check as the study file and the
    CLI); returns the normalised values.

    Raises
    ------
    InvalidInputError
        ``"{key}={value!r}: {reason}"`` (the Python API's form), or an unknown keyword.
    """
    specs = option_specs(options_cls)
    out = {}
    for key, value in kwargs.items():
        spec = specs.get(key)
        if spec is None:
            raise InvalidInputError(f"{key}: unknown option; allowed: {', '.join(specs)}")
        try:
            out[key] = spec.check(value) if spec.check is not None else value
        except Bad as exc:
            raise InvalidInputError(f"{key}={value!r}: {exc}") from None
    return out


def resolve_table(specs: dict, table, path: str, *, fill_defaults: bool = True) -> dict:
    """Check every key of ``table`` and fill the defaults that are not ``None``.

    Raises
    ------
    InvalidInputError
        ``{path}.{key}: unknown key; allowed in [{path}]: ...``, ``{path}.{key} = value:
        reason`` or ``{path}.{key}: required key is missing``.
    """
    if not isinstance(table, dict):
        raise InvalidInputError(f"{path} = {fmt(table)}: expected a table ([{path}])")
    out = {}
    for key, value in table.items():
        spec = specs.get(key)
        if spec is None:
            raise InvalidInputError(f"{path}.{key}: unknown key; allowed in [{path}]: {', '.join(specs)}")
        try:
            out[key] = spec.check(value) if spec.check is not None else value
        except Bad as exc:
            raise InvalidInputError(f"{path}.{key} = {fmt(value)}: {exc}") from None
    if fill_defaults:
        for key, spec in specs.items():
            if key in out:
                continue
            if spec.required:
                raise InvalidInputError(f"{path}.{key}: required key is missing")
            if spec.default is not None and spec.fill:
                out[key] = copy.deepcopy(spec.default)
    return out


# --------------------------------------------------------------------------- the registry
_REGISTRY: dict[str, dict[str, Capability]] = {k: {} for k in KINDS}
_ALIASES: dict[str, dict[str, str]] = {k: {} for k in KINDS}
_DISCOVERED = False
_DISCOVERING = False


def register(kind: str, name: str, options, run, outputs: Outputs | None = None, *, doc: str = "",
             aliases=(), requires=(), check=None, preflight=None, kernels=(), replace: bool = False,
             label: str = "") -> Capability:
    """Declare a capability (see the module docstring); returns it.

    ``label`` is its display name in reports (default: ``name``).

    Raises
    ------
    InvalidInputError
        Unknown ``kind``, a name already registered (unless ``replace``; analyses and
        mechanics stages share one namespace), or options that are not a dataclass made
        with :func:`option`.
    """
    if kind not in KINDS:
        raise InvalidInputError(f"kind={kind!r}: allowed are {', '.join(map(repr, KINDS))}")
    if not isinstance(name, str) or not name.isidentifier():
        raise InvalidInputError(f"name={name!r}: must be an identifier (letters, digits, underscores)")
    if not dataclasses.is_dataclass(options):
        raise InvalidInputError(f"options of {kind} {name!r} must be a dataclass (fields made with option())")
    if name in _REGISTRY[kind] and not replace:
        raise InvalidInputError(f"{kind} {name!r} is already registered (by {_REGISTRY[kind][name].origin or '?'})")
    if kind in STAGE_KINDS:
        for other in STAGE_KINDS:
            if other != kind and name in _REGISTRY[other]:
                if not replace:
                    raise InvalidInputError(f"{kind} {name!r}: the name is taken by {other} {name!r} (by "
                                            f"{_REGISTRY[other][name].origin or '?'}); both are [analysis.{name}]")
                unregister(other, name)
    cap = Capability(kind, name, options, run, outputs or Outputs(), doc, tuple(aliases), tuple(requires),
                     check, preflight, tuple(kernels), origin=_caller_module(), label=label)
    _REGISTRY[kind][name] = cap
    for a in cap.aliases:
        _ALIASES[kind][a] = name
    return cap


def unregister(kind: str, name: str) -> None:
    """Remove a capability (tests and plugins that replace a built-in)."""
    cap = _REGISTRY.get(kind, {}).pop(name, None)
    if cap is not None:
        for a in cap.aliases:
            _ALIASES[kind].pop(a, None)


def _caller_module() -> str:
    import sys

    frame = sys._getframe(2)
    return frame.f_globals.get("__name__", "")


def capabilities(kind: str) -> dict[str, Capability]:
    """``{name: Capability}`` of one kind, in registration order (discovers on first use)."""
    discover()
    if kind not in KINDS:
        raise InvalidInputError(f"kind={kind!r}: allowed are {', '.join(map(repr, KINDS))}")
    return dict(_REGISTRY[kind])


def names(kind: str) -> tuple[str, ...]:
    return tuple(capabilities(kind))


def stages() -> dict[str, Capability]:
    """``{name: Capability}`` of every stage a study's ``[analysis.NAME]`` table can name:
    the analyses, then the mechanics stages (:data:`STAGE_KINDS`)."""
    out = {}
    for kind in STAGE_KINDS:
        out.update(capabilities(kind))
    return out


def canonical(kind: str, name: str) -> str:
    """The registered name for ``name`` or one of its aliases (hyphens read as underscores)."""
    discover()
    key = name.strip().lower().replace("-", "_") if isinstance(name, str) else name
    for k in (STAGE_KINDS if kind in STAGE_KINDS else (kind,)):
        if key in _ALIASES[k]:
            return _ALIASES[k][key]
    return key


def get(kind: str, name: str, path: str | None = None) -> Capability:
    """The capability ``name`` of ``kind`` (aliases accepted).

    Raises
    ------
    InvalidInputError
        Unknown name; the message lists the registered ones.
    """
    caps = stages() if kind in STAGE_KINDS else capabilities(kind)  # one namespace: [analysis.NAME]
    key = canonical(kind, name) if isinstance(name, str) else name
    if key not in caps:
        where = path or kind
        raise InvalidInputError(f"{where} = {fmt(name)}: allowed: {', '.join(caps)}")
    return caps[key]


def _load(target):
    if callable(target):
        return target
    mod, _, attr = str(target).partition(":")
    obj = importlib.import_module(mod)
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


def discover(force: bool = False) -> None:
    """Import the built-in ``_capabilities`` modules and the entry-point plugins (once)."""
    global _DISCOVERED, _DISCOVERING
    if (_DISCOVERED and not force) or _DISCOVERING:
        return
    _DISCOVERING = True
    import importlib.util
    try:
        from pathlib import Path

        here = str(Path(__file__).resolve().parent)  # the polypack package folder
        for info in sorted(pkgutil.iter_modules([here]), key=lambda m: _ORDER.get(m.name, 99)):
            if not info.ispkg or info.name.startswith("_"):
                continue
            modname = f"polypack.{info.name}._capabilities"
            try:
                spec = importlib.util.find_spec(modname)
            except (ImportError, ValueError):
                spec = None
            if spec is not None:
                importlib.import_module(modname)
        _load_entry_points()
        _DISCOVERED = True
    finally:
        _DISCOVERING = False


# built-in declaration order: sizes, protocols, descriptors, then the rest alphabetically
_ORDER = {"psd": 0, "generate": 1, "analysis": 2, "mechanics": 3}


def _load_entry_points() -> None:
    from importlib.metadata import entry_points

    for ep in entry_points(group=ENTRY_POINT_GROUP):
        try:
            obj = ep.load()
        except Exception as exc:  # a broken plugin must not break polypack
            import warnings

            warnings.warn(f"polypack plugin {ep.name!r} ({ep.value}) failed to load: {exc}", stacklevel=2)
            continue
        if callable(obj) and not isinstance(obj, type(importlib)):
            obj(importlib.import_module(__name__))

