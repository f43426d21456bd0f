"""Parameter sweeps of a study (the run engine); the seed's heterogeneity report is a study module.

A study file with a ``[sweep]`` table runs once per value of one parameter
(``polypack run study.toml`` detects it)::

    [sweep]
    parameter = "protocol.void_ratio"      # a key path of the study
    values = [0.125, 0.25, 0.5, 1.0, 1.625, 2.0]
    report = "heterogeneity"               # optional post-processing over all values
    include = []                           # run folders of other structure sets for the report
    modulus = "elastic"                    # G'p: static tensor (default) or "shear" (DEM G')
    fig5_kn = [25, 50, 100, 200, 400]      # kn (N/m) of Fig. 5 (G'p of the most/least heterogeneous
                                           # structure against kn); [] for none
    dynamic = [0.5]                        # values that also get the oscillatory shear test ...
    dynamic_realizations = 1               # ... on their first realization only (default; "all": every one)
    [sweep.shear]                          # its options (default: the bond options of [analysis.elastic])

Every value is an ordinary study (same seed: common random numbers across values),
written to ``<out>/<key>=<value>/`` with all the files of ``polypack run``; rerunning
resumes each.

**Sets.** Several structure sets in one run, each with its own protocol and swept parameter
(``[[sweep.set]]`` tables; then ``parameter``, ``values`` and ``dynamic`` go into the sets)::

    [[sweep.set]]
    name = "vem"                           # folder <out>/vem/ (default: the protocol kind)
    label = "VEM"                          # the report's label of its rows (default: the protocol's title)
    parameter = "protocol.void_ratio"
    values = [0.125, 0.25, 0.5, 1.0, 1.625, 2.0]
    dynamic = [0.125]                      # values of this set that also get [analysis.shear]
    dynamic_realizations = 1               # on how many of their realizations (default: [sweep]'s, 1)
    [sweep.set.protocol]                   # merged over [protocol]; another kind replaces it
    kind = "vem"

    [[sweep.set]]
    name = "bd"
    parameter = "protocol.surface_potential"
    values = [0.0, 0.012, 0.013, 0.014, 0.015]
    [sweep.set.protocol]
    kind = "brownian"
    bonds = "tangential"

A set may also override ``[study]``, ``[psd]`` and ``[analysis.*]`` keys (``[sweep.set.analysis.elastic]``
..., merged key by key). Every value of every set is an ordinary study, written to
``<out>/<set>/<key>=<value>/``; every one is validated (``--check``) before the first runs, and
rerunning resumes each (finished realizations are kept, :func:`polypack.ensemble.run_study`).

``report = "heterogeneity"`` then writes ``<out>/heterogeneity/``: the seed 003 study of
:mod:`polypack.studies.seed003_heterogeneity` (Table 2, Figs. 2, 5 and 6, the power law Eq. (7) of
003_873b69fc71c74cf6.txt), over every swept value of every set and the ``include``d run folders, with
the dynamic G'p of the ``dynamic`` values beside their static one.
"""

from __future__ import annotations

import copy
import tomllib
from dataclasses import dataclass
from pathlib import Path

from ..errors import InvalidInputError

__all__ = ["has_sweep", "run_sweep", "sweep_studies", "sweep_plan", "SweepEntry", "heterogeneity_report", "set_label",
           "SEED_TABLE2"]

# the seed-specific report lives in its study module (re-exported here for existing imports)
from ..studies.seed003_heterogeneity import ELASTIC_DEFAULTS as _ELASTIC_DEFAULTS  # noqa: E402
from ..studies.seed003_heterogeneity import SEED_TABLE2, heterogeneity_report, set_label  # noqa: E402,F401

_SWEEP_KEYS = {"parameter", "values", "report", "include", "elastic", "modulus", "fig5_kn", "dynamic", "shear",
               "set", "dynamic_realizations"}
#: keys of one ``[[sweep.set]]`` table; the section keys are merged over the study's sections
_SET_KEYS = ("name", "label", "parameter", "values", "dynamic", "dynamic_realizations")
_SET_SECTIONS = ("study", "psd", "protocol", "analysis")
#: folder names a set may not take (the report's folder and the run folder's own entries)
_RESERVED = ("heterogeneity", "realizations", "ensemble", "figures")


def _read(path_or_data):
    if isinstance(path_or_data, dict):
        return copy.deepcopy(path_or_data), None
    path = Path(path_or_data)
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh), path
    except (OSError, tomllib.TOMLDecodeError):
        return None, path


def has_sweep(path_or_data) -> bool:
    """True if the study file (or dict) has a ``[sweep]`` table."""
    data, _ = _read(path_or_data)
    return isinstance(data, dict) and "sweep" in data


def _check_parameter(par, where="sweep"):
    if not isinstance(par, str) or par.count(".") < 1 or par.split(".")[0] not in ("protocol", "psd", "analysis"):
        raise InvalidInputError(f"{where}.parameter = {par!r}: give a key path such as \"protocol.void_ratio\"")
    return par


def _check_values(vals, par, where="sweep"):
    if not isinstance(vals, list) or not vals:
        raise InvalidInputError(f"{where}.values = {vals!r}: give a non-empty list")
    if len(set(map(repr, vals))) != len(vals):
        raise InvalidInputError(f"{where}.values = {vals!r}: values must differ")
    seen = {}
    for v in vals:
        text = _value_text(v)
        if text in seen or "/" in text or text in (".", ".."):
            what = (f"{seen[text]!r} and {v!r} share the folder name {par.split('.')[-1]}={text}" if text in seen
                    else f"{v!r} cannot name a folder")
            raise InvalidInputError(f"{where}.values: {what}; give distinct values")
        seen[text] = v
    return vals


def _same_value(v, x) -> bool:
    """``x`` names the swept value ``v`` (numbers by value: 1 names 1.0; others by their text)."""
    num = (int, float)
    if isinstance(v, num) and isinstance(x, num) and not isinstance(v, bool) and not isinstance(x, bool):
        return v == x
    return type(v) is type(x) and v == x


def _check_dynamic(dyn, vals, where="sweep"):
    """``dynamic``: one value or a list of values of the sweep (or set) that also get [analysis.shear]."""
    if dyn is None:
        return []
    items = dyn if isinstance(dyn, list) else [dyn]
    out = []
    for x in items:
        match = [v for v in vals if _same_value(v, x)]
        if not match:
            raise InvalidInputError(f"{where}.dynamic = {dyn!r}: {x!r} is not one of the values "
                                    f"{vals!r}; give values that get the oscillatory shear test [analysis.shear]")
        if match[0] not in out:
            out.append(match[0])
    return out


def _check_dynamic_realizations(x, where="sweep", default=1):
    """``dynamic_realizations``: how many realizations of a ``dynamic`` value get the shear test
    (realizations 0 .. n-1; default 1: one structure per value, issue 32); ``"all"``: every one (None)."""
    if x is None:
        return default
    if x == "all":
        return None
    if isinstance(x, bool) or not isinstance(x, int) or x < 1:
        raise InvalidInputError(f"{where}.dynamic_realizations = {x!r}: give an integer >= 1 (the first n "
                                'realizations of each dynamic value get the shear test) or "all"')
    return x


def _check_sweep(sw) -> dict:
    if not isinstance(sw, dict):
        raise InvalidInputError(f"sweep = {sw!r}: expected a table")
    unknown = sorted(set(sw) - _SWEEP_KEYS)
    if unknown:
        raise InvalidInputError(f"sweep.{unknown[0]}: unknown key; allowed: {', '.join(sorted(_SWEEP_KEYS))}")
    sets = sw.get("set")
    if sets is not None:
        if not isinstance(sets, list) or not sets or not all(isinstance(s, dict) for s in sets):
            raise InvalidInputError(f"sweep.set = {sets!r}: give one or more [[sweep.set]] tables")
        both = [k for k in ("parameter", "values", "dynamic") if k in sw]
        if both:
            raise InvalidInputError(f"sweep.{both[0]}: with [[sweep.set]] tables give {both[0]} in each set "
                                    "(sweep.set.parameter, sweep.set.values, sweep.set.dynamic)")
        par = vals = None
        dyn = []
    else:
        par = _check_parameter(sw.get("parameter"))
        vals = _check_values(sw.get("values"), par)
        dyn = _check_dynamic(sw.get("dynamic"), vals)
    rep = sw.get("report")
    if rep not in (None, "heterogeneity"):
        raise InvalidInputError(f"sweep.report = {rep!r}: allowed: \"heterogeneity\"")
    inc = sw.get("include", [])
    if not isinstance(inc, list) or not all(isinstance(x, str) for x in inc):
        raise InvalidInputError(f"sweep.include = {inc!r}: give a list of run folders")
    el = dict(_ELASTIC_DEFAULTS)
    el_in = sw.get("elastic", {})
    if not isinstance(el_in, dict) or set(el_in) - set(_ELASTIC_DEFAULTS):
        raise InvalidInputError(f"sweep.elastic = {el_in!r}: allowed keys {', '.join(_ELASTIC_DEFAULTS)}")
    for k, v in el_in.items():
        if k == "stiffness":
            if v not in ("contact", "particle"):
                raise InvalidInputError(f'sweep.elastic.stiffness = {v!r}: allowed: "contact", "particle"')
            el[k] = v
            continue
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not v >= 0:
            raise InvalidInputError(f"sweep.elastic.{k} = {v!r}: must be a number >= 0")
        el[k] = float(v)
    mod = sw.get("modulus", "elastic")
    if mod not in ("elastic", "shear"):
        raise InvalidInputError(f"sweep.modulus = {mod!r}: allowed: \"elastic\" (static tensor), \"shear\" (DEM)")
    kn = sw.get("fig5_kn")
    if kn is not None and (not isinstance(kn, list) or len(kn) == 1 or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and x > 0 for x in kn)):
        raise InvalidInputError(f"sweep.fig5_kn = {kn!r}: give two or more normal stiffnesses > 0 (N/m), "
                                "or [] for no Fig. 5")
    shear = sw.get("shear", {})
    if not isinstance(shear, dict):
        raise InvalidInputError(f"sweep.shear = {shear!r}: expected a table ([sweep.shear], the options of "
                                "[analysis.shear])")
    from .. import registry

    registry.stages()["shear"].resolve(shear, "sweep.shear")  # every key and value, with its key path
    dyn_real = _check_dynamic_realizations(sw.get("dynamic_realizations"))
    if "realizations" in shear:
        raise InvalidInputError(f"sweep.shear.realizations = {shear['realizations']!r}: give "
                                "sweep.dynamic_realizations (or sweep.set.dynamic_realizations) instead")
    return {"parameter": par, "values": vals, "report": rep, "include": inc, "elastic": el, "modulus": mod,
            "fig5_kn": None if kn is None else [float(x) for x in kn], "dynamic": dyn, "shear": dict(shear),
            "sets": sets, "dynamic_realizations": dyn_real}


def _set_path(data, path, value, where="sweep"):
    keys = path.split(".")
    d = data
    for k in keys[:-1]:
        d = d.setdefault(k, {})
        if not isinstance(d, dict):
            raise InvalidInputError(f"{where}.parameter = {path!r}: {k} is not a table")
    d[keys[-1]] = value


def _value_text(v) -> str:
    """Exact text of a swept value for its folder name: ``:g`` when that reads back as the same
    number (``0.25``, ``1``), else ``repr`` (``0.2500000000000001``: never rounded onto a
    neighbour's folder, issue 31)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return str(v)
    short = f"{v:g}"
    try:
        same = float(short) == v and type(v)(float(short)) == v
    except (OverflowError, ValueError):
        same = False
    return short if same else repr(v)


def _label(par, v):
    return f"{par.split('.')[-1]}={_value_text(v)}"


@dataclass
class SweepEntry:
    """One value of one set of a sweep: its study and where it is written.

    ``set`` is the set's name (its folder under the sweep's output folder; None for a sweep
    without ``[[sweep.set]]`` tables), ``title`` the report's label of its rows (None: the
    protocol's title), ``dynamic`` whether the value got the oscillatory shear test.
    """

    set: str | None
    title: str | None
    parameter: str
    value: object
    study: object
    dynamic: bool = False

    @property
    def rel(self) -> Path:
        """The value's run folder relative to the sweep's output folder."""
        sub = Path(_label(self.parameter, self.value))
        return sub if self.set is None else Path(self.set) / sub

    @property
    def text(self) -> str:
        """The entry as the sweep's report lists it: ``"bd: surface_potential=0.012"``."""
        return _label(self.parameter, self.value) if self.set is None else f"{self.set}: {_label(self.parameter, self.value)}"


def _merge(base: dict, over: dict) -> dict:
    """``base`` with ``over`` merged in, table by table (a value replaces, a table merges)."""
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def _set_name(i, s, kinds):
    """The checked name of set ``i`` (default: its protocol kind)."""
    name = s.get("name", kinds if isinstance(kinds, str) and kinds else f"set{i + 1}")
    if not isinstance(name, str) or not name or "/" in name or "\\" in name or name.startswith(".") \
            or "=" in name or name in _RESERVED:
        raise InvalidInputError(f"sweep.set #{i + 1}.name = {name!r}: give a folder name (letters, digits, _ -; "
                                f"no '/', '=', leading '.', nor {', '.join(_RESERVED)})")
    return name


def _check_set(i, s, data):
    """``(name, label, parameter, values, dynamic, study dict)`` of ``[[sweep.set]]`` number ``i``."""
    base_kind = data.get("protocol", {}).get("kind", "scrm") if isinstance(data.get("protocol"), dict) else "scrm"
    prot = s.get("protocol", {})
    kind = prot.get("kind", base_kind) if isinstance(prot, dict) else base_kind
    name = _set_name(i, s, kind)
    where = f'sweep.set "{name}"'
    unknown = sorted(set(s) - set(_SET_KEYS) - set(_SET_SECTIONS))
    if unknown:
        raise InvalidInputError(f"{where}.{unknown[0]}: unknown key; allowed in [[sweep.set]]: "
                                f"{', '.join(_SET_KEYS + _SET_SECTIONS)}")
    label = s.get("label")
    if label is not None and (not isinstance(label, str) or not label.strip()):
        raise InvalidInputError(f"{where}.label = {label!r}: give a text (the report's name of this set)")
    for sec in _SET_SECTIONS:
        if sec in s and not isinstance(s[sec], dict):
            raise InvalidInputError(f"{where}.{sec} = {s[sec]!r}: expected a table ([sweep.set.{sec}])")
    if isinstance(s.get("analysis"), dict):
        for k, t in s["analysis"].items():
            if not isinstance(t, dict):
                raise InvalidInputError(f"{where}.analysis.{k} = {t!r}: expected a table ([sweep.set.analysis.{k}])")
    par = _check_parameter(s.get("parameter"), where)
    vals = _check_values(s.get("values"), par, where)
    dyn = _check_dynamic(s.get("dynamic"), vals, where)
    d = copy.deepcopy(data)
    for sec in ("study", "psd", "analysis"):
        if sec in s:
            d[sec] = _merge(d.get(sec, {}) if isinstance(d.get(sec), dict) else {}, s[sec])
    if "protocol" in s:
        base = d.get("protocol", {}) if isinstance(d.get("protocol"), dict) else {}
        # the same kind: merged key by key; another kind: replaces [protocol] (its options are another's)
        d["protocol"] = _merge(base, s["protocol"]) if kind == base_kind else copy.deepcopy(s["protocol"])
    return name, label, par, vals, dyn, d


def _shear_table(d, shear, realizations=None):
    """[analysis.shear] of a dynamic value: the bond options the study's [analysis.elastic] states
    (the same network as the static G'p), then the study's own [analysis.shear] if it has one, then
    ``[sweep.shear]``; ``realizations``: the test runs on realizations 0 .. n-1 only (None: all)."""
    from .. import registry

    specs = registry.stages()["shear"].specs()
    ana = d.get("analysis", {}) if isinstance(d.get("analysis"), dict) else {}
    el = ana.get("elastic", {})
    table = {k: copy.deepcopy(v) for k, v in (el.items() if isinstance(el, dict) else ()) if k in specs}
    if isinstance(ana.get("shear"), dict):
        table.update(copy.deepcopy(ana["shear"]))
    table.update(copy.deepcopy(shear))
    table.pop("realizations", None)
    if realizations is not None:
        table["realizations"] = int(realizations)
    return table


def _entry_study(d, parameter, value, name, where, dynamic, shear, dyn_real=1):
    from ..study import load_study

    d = copy.deepcopy(d)
    _set_path(d, parameter, value, where)
    d.setdefault("study", {})["name"] = f"{name}-{_label(parameter, value)}"
    if dynamic:
        d.setdefault("analysis", {})["shear"] = _shear_table(d, shear, dyn_real)
    try:
        return load_study(d)
    except InvalidInputError as exc:
        raise InvalidInputError(f"{where} value {value!r}: {exc}") from None


def _check_report_needs(sw, d, where):
    if sw["report"] != "heterogeneity":  # what the report reads, checked before any value runs
        return
    ana = d.get("analysis", {}) if isinstance(d.get("analysis"), dict) else {}
    pre = "" if where == "sweep" else f"{where}: "
    if "pores" not in ana:
        raise InvalidInputError(f'{pre}sweep.report = "heterogeneity": needs [analysis.pores] in the study (the DOH '
                                "a, b of Eq. (6) of 003_873b69fc71c74cf6.txt)")
    if sw["modulus"] == "shear" and "shear" not in ana:
        raise InvalidInputError(f'{pre}sweep.modulus = "shear": needs [analysis.shear] in the study (the dynamic '
                                'G\'); or use sweep.modulus = "elastic"')


def sweep_plan(path_or_data):
    """``(sweep, [SweepEntry, ...], name)``: one validated study per value of every set.

    Raises
    ------
    InvalidInputError
        One line naming the key path (``sweep.set "bd".values``, ``sweep.set "bd" value
        0.012: protocol.surface_potential = ...``) before anything runs.
    """
    from ..study import load_study

    data, path = _read(path_or_data)
    if data is None:
        load_study(path)  # raises the study loader's one-line error
    sw = _check_sweep(data.pop("sweep"))
    name = data.get("study", {}).get("name") if isinstance(data.get("study"), dict) else None
    name = name or (path.stem if path is not None else "sweep")
    entries = []
    if sw["sets"] is None:
        _check_report_needs(sw, data, "sweep")
        for v in sw["values"]:
            dyn = any(_same_value(v, x) for x in sw["dynamic"])
            st = _entry_study(data, sw["parameter"], v, name, "sweep", dyn, sw["shear"], sw["dynamic_realizations"])
            entries.append(SweepEntry(None, None, sw["parameter"], v, st, dyn))
        return sw, entries, name
    names = set()
    sets = []
    for i, s in enumerate(sw["sets"]):
        sname, label, par, vals, dyn, d = _check_set(i, s, data)
        dreal = _check_dynamic_realizations(s.get("dynamic_realizations"), f'sweep.set "{sname}"',
                                            sw["dynamic_realizations"])
        if sname in names:
            raise InvalidInputError(f'sweep.set #{i + 1}.name = {sname!r}: another set has this name (each set is '
                                    "written to its own folder); give distinct names")
        names.add(sname)
        _check_report_needs(sw, d, f'sweep.set "{sname}"')
        for v in vals:
            dv = any(_same_value(v, x) for x in dyn)
            st = _entry_study(d, par, v, f"{name}-{sname}", f'sweep.set "{sname}"', dv, sw["shear"], dreal)
            entries.append(SweepEntry(sname, label, par, v, st, dv))
        sets.append({"name": sname, "label": label, "parameter": par, "values": vals, "dynamic": dyn,
                     "dynamic_realizations": dreal})
    sw["sets"] = sets
    return sw, entries, name


def sweep_studies(path_or_data):
    """``(sweep, [(value, Study), ...], name)``: one validated study per value (of every set)."""
    sw, entries, name = sweep_plan(path_or_data)
    return sw, [(e.value, e.study) for e in entries], name


def _where(e: SweepEntry) -> str:
    return "sweep" if e.set is None else f'sweep.set "{e.set}"'


def run_sweep(path_or_data, out=None, *, workers=1, executor=None, force=False, progress=None, wait=0.0,
              echo=print):
    """Run every value of every set of a swept study, then its report; returns ``{value: EnsembleResult}``
    (``{(set, value): EnsembleResult}`` with ``[[sweep.set]]`` tables).

    Each value is a study in its own folder (:func:`polypack.ensemble.run_study`'s files, records
    and resume: a value whose realizations are all finished is read back, not recomputed). With
    ``workers > 1`` or an ``executor`` the realizations of all values of all sets share one executor
    (:func:`polypack.ensemble.runner.run_studies`): every missing (value, realization) is submitted at
    once, the realizations with the oscillatory shear test first, so no worker idles while a value's
    last realization runs (issue 32); the records are those of a value-by-value run, bit for bit (same
    seeds). Each value's summary is echoed when its realizations are done.
    """
    from .runner import run_studies
    from .stages import _skips, check_available, child_seed_records, preflight

    sw, entries, name = sweep_plan(path_or_data)
    for e in entries:  # every value's rules before the first runs
        try:
            check_available(e.study.data)
            preflight(e.study.data, child_seed_records(e.study.seed, 1)[0])
        except InvalidInputError as exc:
            raise InvalidInputError(f"{_where(e)} value {e.value!r}: {exc}") from None
    out = Path(out) if out is not None else Path("out") / name
    def sheared(study, index):  # the longest tasks: the oscillatory shear test (minutes per structure)
        sh = study.data.get("analysis", {}).get("shear")
        return isinstance(sh, dict) and not _skips(sh, index)

    done = run_studies([(e.study, out / e.rel) for e in entries], executor=executor, workers=workers, force=force,
                       progress=progress, wait=wait, desc=name, first=sheared,
                       on_result=lambda k, res: echo(res.summary()))
    results = {e.value if e.set is None else (e.set, e.value): res for e, res in zip(entries, done)}
    if sw["report"] == "heterogeneity":
        files = heterogeneity_report(out, [(e.value, out / e.rel, e.parameter, e.title) for e in entries],
                                     parameter=entries[0].parameter, include=sw["include"], elastic=sw["elastic"],
                                     modulus=sw["modulus"], fig5_kn=sw["fig5_kn"])
        echo("heterogeneity report: " + ", ".join(str(p) for p in files.values()))
    # OUT/report.html (the values, Table 2 / Figs. 2, 5 and 6) is written by the report layer above this
    # one: ``polypack run`` does it, or polypack.report.build.sweep_report(out, entries) after this call
    return results
