"""The generated reference page ``docs/reference.md``: every registered capability's options.

Written by ``python tools/gen_reference.py`` from the options dataclasses of
:mod:`polypack.registry` (the same declarations the study schema, ``--check``, the run
adapters and the CLI flags come from); ``tests/test_declarations.py`` fails when the
checked-in page differs from :func:`reference_markdown`.
"""

from __future__ import annotations

from . import registry
from ._validate import fmt

__all__ = ["reference_markdown", "default_text", "TABLE_HEADER"]

TABLE_HEADER = "| option | CLI flag | type and bounds | default | unit | description |"

_WHERE = {
    "psd": '`[psd] model = "{name}"`',
    "protocol": '`[protocol] kind = "{name}"`',
    "analysis": "`[analysis.{name}]`",
    "mechanics": "`[analysis.{name}]`",
}

_KIND_TEXT = {
    "psd": "Size-distribution models (`[psd]`, `polypack psd`).",
    "protocol": "Packing protocols (`[protocol]`; `polypack NAME OUT` with the fields as flags).",
    "analysis": "Analyses of a finished pack (`[analysis.NAME]`; `polypack analyze` with the fields as flags, "
                "or `polypack analyze --run NAME:key=value`).",
    "mechanics": "Mechanics stages of a finished pack (`[analysis.NAME]`; `polypack NAME PACK` with the fields "
                 "as flags).",
}


def default_text(spec) -> str:
    """The default as the page shows it: ``required``, ``unset: RULE`` (the declared rule of the run's own
    default, :func:`polypack.registry.option` ``unset``) or the value."""
    if spec.required:
        return "required"
    if spec.default is None:
        return f"unset: {spec.unset}" if spec.unset else "unset"
    return fmt(spec.default)


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _rows(specs) -> list:
    out = [TABLE_HEADER, "|---|---|---|---|---|---|"]
    for key, s in specs.items():
        flag = "`--" + key.replace("_", "-") + "`" if s.cli else "–"
        out.append(f"| `{key}` | {flag} | {_cell(s.describe)} | `{_cell(default_text(s))}` | {_cell(s.unit) or '–'} "
                   f"| {_cell(s.doc)} |")
    return out


def reference_markdown() -> str:
    """The text of ``docs/reference.md``."""
    from .psd._capabilities import Generation

    lines = ["# Reference: the options of every capability", "",
             "Generated from the options dataclasses of `polypack.registry` by `python tools/gen_reference.py`; "
             "`tests/test_declarations.py` checks that this page is current. Do not edit by hand.", "",
             "Each option is declared once (type and bounds, default, unit, doc) and is the same key in the Python "
             "API, the study file and the command line (flag = the key in kebab case). `unset: RULE`: the option is "
             "left out of a resolved study and the run applies RULE (a value, or how it follows from the other "
             "options).", ""]
    for kind in registry.KINDS:
        caps = registry.capabilities(kind)
        lines += [f"## {kind}", "", _KIND_TEXT[kind], ""]
        if kind == "psd":
            lines += ["### `[psd]` generation keys (every model)", ""]
            lines += _rows(registry.option_specs(Generation)) + [""]
        for name, cap in caps.items():
            lines += [f"### {name}", ""]
            where = _WHERE[kind].format(name=name)
            label = f" Shown as \"{cap.label}\"." if cap.label else ""
            alias = f" Aliases: {', '.join(cap.aliases)}." if cap.aliases else ""
            lines += [f"{cap.doc.rstrip('.')}. Study: {where}.{label}{alias}", ""]
            specs = cap.specs()
            lines += (_rows(specs) if specs else ["No options."]) + [""]
            if kind == "protocol":
                tables = cap.meta_tables()
                stats = ", ".join(f"`protocol.{t}.*`" for t in tables) or "top-level `packing.meta` scalars only"
                lines += [f"Statistics in records and `summary.csv`: `protocol.status`, `protocol.min_gap`, ... and "
                          f"{stats}.", ""]
    return "\n".join(lines).rstrip() + "\n"
