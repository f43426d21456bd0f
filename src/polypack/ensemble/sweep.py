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

Every value is an ordinary study (same seed: common random numbers across values),
written to ``<out>/<key>=<value>/`` with all the files of ``polypack run``; rerunning
resumes each.

``report = "heterogeneity"`` then writes ``<out>/heterogeneity/``: the seed 003 study of
:mod:`polypack.studies.seed003_heterogeneity` (Table 2, Figs. 2, 5 and 6, the power law Eq. (7) of
003_873b69fc71c74cf6.txt), over every swept value and the ``include``d run folders.
"""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

from ..errors import InvalidInputError

__all__ = ["has_sweep", "run_sweep", "sweep_studies", "heterogeneity_report", "set_label", "SEED_TABLE2"]

# the seed-specific report lives in its study module (re-exported here for existing imports)
from ..studies.seed003_heterogeneity import ELASTIC_DEFAULTS as _ELASTIC_DEFAULTS  # noqa: E402
from ..studies.seed003_heterogeneity import SEED_TABLE2, heterogeneity_report, set_label  # noqa: E402,F401

_SWEEP_KEYS = {"parameter", "values", "report", "include", "elastic", "modulus", "fig5_kn"}


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


def _check_sweep(sw) -> dict:
    if not isinstance(sw, dict):
        raise InvalidInputError(f"sweep = {sw!r}: expected a table")
    unknown = sorted(set(sw) - _SWEEP_KEYS)
    if unknown:
        raise InvalidInputError(f"sweep.{unknown[0]}: unknown key; allowed: {', '.join(sorted(_SWEEP_KEYS))}")
    par = sw.get("parameter")
    if not isinstance(par, str) or par.count(".") < 1 or par.split(".")[0] not in ("protocol", "psd", "analysis"):
        raise InvalidInputError(f"sweep.parameter = {par!r}: give a key path such as \"protocol.void_ratio\"")
    vals = sw.get("values")
    if not isinstance(vals, list) or not vals:
        raise InvalidInputError(f"sweep.values = {vals!r}: give a non-empty list")
    if len(set(map(repr, vals))) != len(vals):
        raise InvalidInputError(f"sweep.values = {vals!r}: values must differ")
    seen = {}
    for v in vals:
        text = _value_text(v)
        if text in seen or "/" in text or text in (".", ".."):
            what = (f"{seen[text]!r} and {v!r} share the folder name {par.split('.')[-1]}={text}" if text in seen
                    else f"{v!r} cannot name a folder")
            raise InvalidInputError(f"sweep.values: {what}; give distinct values")
        seen[text] = v
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
    return {"parameter": par, "values": vals, "report": rep, "include": inc, "elastic": el, "modulus": mod,
            "fig5_kn": None if kn is None else [float(x) for x in kn]}


def _set_path(data, path, value):
    keys = path.split(".")
    d = data
    for k in keys[:-1]:
        d = d.setdefault(k, {})
        if not isinstance(d, dict):
            raise InvalidInputError(f"sweep.parameter = {path!r}: {k} is not a table")
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


def sweep_studies(path_or_data):
    """``(sweep, [(value, Study), ...], name)``: one validated study per value."""
    from ..study import load_study

    data, path = _read(path_or_data)
    if data is None:
        load_study(path)  # raises the study loader's one-line error
    sw = _check_sweep(data.pop("sweep"))
    if sw["report"] == "heterogeneity":  # what the report reads, checked before any value runs
        ana = data.get("analysis", {}) if isinstance(data.get("analysis"), dict) else {}
        if "pores" not in ana:
            raise InvalidInputError('sweep.report = "heterogeneity": needs [analysis.pores] in the study (the DOH a, '
                                    "b of Eq. (6) of 003_873b69fc71c74cf6.txt)")
        if sw["modulus"] == "shear" and "shear" not in ana:
            raise InvalidInputError('sweep.modulus = "shear": needs [analysis.shear] in the study (the dynamic G\'); '
                                    'or use sweep.modulus = "elastic"')
    name = data.get("study", {}).get("name") or (path.stem if path is not None else "sweep")
    studies = []
    for v in sw["values"]:
        d = copy.deepcopy(data)
        _set_path(d, sw["parameter"], v)
        d.setdefault("study", {})["name"] = f"{name}-{_label(sw['parameter'], v)}"
        try:
            st = load_study(d)
        except InvalidInputError as exc:
            raise InvalidInputError(f"sweep value {v!r}: {exc}") from None
        studies.append((v, st))
    return sw, studies, name


def run_sweep(path_or_data, out=None, *, workers=1, executor=None, force=False, progress=None, wait=0.0,
              echo=print):
    """Run every value of a swept study, then its report; returns ``{value: EnsembleResult}``."""
    from .runner import run_study

    from .stages import check_available, child_seed_records, preflight

    sw, studies, name = sweep_studies(path_or_data)
    for v, st in studies:  # every value's rules before the first runs
        try:
            check_available(st.data)
            preflight(st.data, child_seed_records(st.seed, 1)[0])
        except InvalidInputError as exc:
            raise InvalidInputError(f"sweep value {v!r}: {exc}") from None
    out = Path(out) if out is not None else Path("out") / name
    results = {}
    for v, st in studies:
        sub = out / _label(sw["parameter"], v)
        res = run_study(st, sub, executor=executor, workers=workers, force=force, progress=progress, wait=wait)
        echo(res.summary())
        results[v] = res
    if sw["report"] == "heterogeneity":
        files = heterogeneity_report(out, [(v, out / _label(sw["parameter"], v)) for v, _ in studies],
                                     parameter=sw["parameter"], include=sw["include"], elastic=sw["elastic"],
                                     modulus=sw["modulus"], fig5_kn=sw["fig5_kn"])
        echo("heterogeneity report: " + ", ".join(str(p) for p in files.values()))
    # OUT/report.html (the values, Table 2 / Figs. 2, 5 and 6) is written by the report layer above this
    # one: ``polypack run`` does it, or polypack.report.build.sweep_report(out, entries) after this call
    return results
