"""Commands generated from the registry: one per protocol and mechanics stage without a hand-written one.

The flags of a generated command are the fields of the capability's options dataclass
(:func:`polypack.registry.option`), in kebab case, with the field's unit and default: the
same names, units and checks as the study file's ``[protocol]`` / ``[analysis.NAME]`` table,
validated by the same :meth:`polypack.registry.Capability.resolve` and run by the same run
function as ``polypack run`` (so the CLI, the study and the API cannot drift apart).

``polypack NAME OUT``  (a protocol) packs ``--n`` equal spheres of diameter ``--d`` (or the
size set ``--sizes`` written by ``polypack psd``) and writes the pack; it prints the
protocol's declared statistics (:attr:`polypack.registry.Outputs.meta`).

``polypack NAME PACK`` (a mechanics stage) runs the stage on a packing file and prints its
declared summary scalars; ``--json`` writes the whole result.

A flag whose value is not a plain number, integer, flag or choice (``--volume-fraction
jammed``, ``--schedule "[0.3, 0.5]"``, ``--directions "[[2, 0]]"``) is read as a TOML value,
as it would be written in a study file.
"""

from __future__ import annotations

import inspect
import json
from pathlib import Path
from typing import List, Optional

import typer

from .. import registry
from .._validate import Bad, fmt
from ..errors import InvalidInputError

__all__ = ["register_generated", "options_from", "flag", "cli_type", "cli_fields", "protocol_extras", "stage_extras",
           "command_name", "generated_names"]

#: Flags every generated protocol command has besides the option fields (name: help).
protocol_extras = {
    "n": "Number of equal spheres (default 1000; or give --sizes).",
    "d": "Diameter of the equal spheres, user length units (default 1.0).",
    "dim": "Dimension of the equal spheres: 3 (default) or 2 (disks).",
    "sizes": "Size set (CSV written by `polypack psd`) instead of --n/--d/--dim.",
    "seed": "Random seed (numpy SeedSequence entropy; default: fresh entropy).",
}
#: Flags every generated mechanics command has besides the option fields.
stage_extras = {
    "seed": "Random seed of the stage (default 0).",
    "json": "Write the whole result as JSON here.",
    "format": "Override the packing file's format.",
}


def flag(name: str) -> str:
    """The CLI flag of an option field: ``void_ratio`` -> ``--void-ratio``."""
    return "--" + name.replace("_", "-")


def command_name(cap) -> str:
    return cap.name.replace("_", "-")


def cli_type(spec):
    """Python type of the flag from the field's check: numbers float, integers int, flags bool, else text."""
    d = spec.describe
    if (d.startswith("integer") and "array" not in d) or d.startswith("2 (disks)"):
        return int
    if d.startswith("number") and "array" not in d and " or " not in d:
        return float
    if d == "boolean":
        return bool
    return str


def cli_fields(cap) -> dict:
    """``{field: OptionSpec}`` of the options offered on the command line (``option(..., cli=True)``)."""
    return {k: s for k, s in cap.specs().items() if s.cli}


def _esc(text: str) -> str:
    """``[`` escaped for rich markup (``[[normal, shear]]`` and ``[N/m]`` are shown, not read as tags)."""
    return str(text).replace("\\[", "[").replace("[", "\\[")


def _help(spec) -> str:
    unit = f" \\[{spec.unit}]" if spec.unit else ""  # escaped for rich markup: shows "[N/m]"
    doc, describe = _esc(spec.doc), _esc(spec.describe)
    if spec.required:
        return f"{doc}{unit} ({describe}; required)."
    if spec.default is None:  # the declared rule of the run's own default (option(..., unset="k_n / 10"))
        return f"{doc}{unit} ({describe}; unset: {_esc(spec.unset or 'the run' + chr(39) + 's own default')})."
    return f"{doc}{unit} ({describe})."  # typer shows [default: ...]


def _parse_text(spec, value):
    """A text flag value: a choice or plain string as given, anything else read as a TOML value."""
    if getattr(spec.check, "choices", None) is not None or not isinstance(value, str):
        return value
    import tomllib

    try:
        return tomllib.loads(f"x = {value}")["x"]
    except tomllib.TOMLDecodeError:
        return value


def _field_params(cap, reserved, short=None, *, repeat=(), notes=None, fields=None) -> list:
    """One typer option per CLI field (``short``: extra short flags, ``{field: "-c"}``; ``repeat``: fields
    whose flag may be given several times, one item each; ``notes``: ``{field: text}`` added to the help)."""
    params = []
    short = short or {}
    notes = notes or {}
    for key, spec in cli_fields(cap).items():
        if fields is not None and key not in fields:
            continue
        if key in reserved:
            raise InvalidInputError(f"{cap.kind} {cap.name!r}: option {key!r} clashes with the command's own "
                                    f"{flag(key)}; rename the field")
        typ = cli_type(spec)
        # the declared default is the flag's default (typer shows it); None: unset, the run's own default
        default = None if spec.required or spec.default is None else spec.default
        if default is not None and typ is str and not isinstance(default, str):
            default = fmt(default)  # shown and parsed back as in a study file (TOML)
        extra = [short[key]] if key in short else []
        text = _help(spec) + (f" {notes[key]}" if key in notes else "")
        if typ is bool:
            opt = typer.Option(default, f"{flag(key)}/--no-{key.replace('_', '-')}", *extra, help=text)
        else:
            opt = typer.Option(default, flag(key), *extra, help=text)
        ann = Optional[List[typ]] if key in repeat else Optional[typ]
        params.append(inspect.Parameter(key, inspect.Parameter.KEYWORD_ONLY, default=opt, annotation=ann))
    return params


def _repeated(spec, values):
    """The value of a repeatable flag: one occurrence as given, several an array of their items
    (``--inclusions 76e9,0.23 --inclusions 70e9,0.2`` -> ``[["76e9", "0.23"], ["70e9", "0.2"]]``)."""
    if not values:
        return None
    if len(values) == 1:
        return values[0]
    from .._validate import _split

    return [_split(_parse_text(spec, x)) for x in values]


def _table(cap, given: dict, path: str) -> dict:
    """Check the given flags (errors name the flag and the study key), then resolve like a study table."""
    specs = cli_fields(cap)
    table = {}
    for key, value in given.items():
        if value is None:
            continue
        spec = specs[key]
        value = _parse_text(spec, value)
        try:
            spec.check(value) if spec.check is not None else value
        except Bad as exc:
            raise InvalidInputError(f"{flag(key)} {fmt(value)}: {exc} ({path}.{key} in a study file)") from None
        table[key] = value
    return cap.resolve(table, path)


def _kw(name, annotation, default, *decls, help=""):
    return inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, annotation=annotation,
                             default=typer.Option(default, *decls, help=help))


def options_from(kind: str, name: str, path: str | None = None, short=None, *, aliases=None, repeat=(), notes=None,
                 prepare=None, fields=None):
    """Decorator of a hand-written command: its option flags are the capability's fields.

    The command declares only its own parameters (output, ``--n``, ``--seed`` ...) plus a
    keyword ``options``; the decorator adds one flag per field of the options dataclass
    (as :func:`register_generated` does) and calls the command with ``options`` = the given
    flags checked and resolved like the study table (defaults filled, cross-key checks run).
    Use it for commands whose output is special (a bonds file, a summary line).

    Parameters
    ----------
    short : dict, optional
        Extra visible flags of some fields (``{"volume_fraction": "-c"}``).
    aliases : dict, optional
        Hidden deprecated spellings of a field's flag (``{"--kn": "normal_stiffness"}``): the
        value goes to the field; giving both spellings (the field's flag at a value other than
        its default) is an error.
    repeat : tuple of str
        Array-valued fields whose flag may be repeated, one item per occurrence
        (``--inclusions E,nu`` once per species).
    notes : dict, optional
        ``{field: text}`` added to the field's help (what the command does when it is unset).
    prepare : callable, optional
        ``prepare(own, flags) -> flags`` with the command's own arguments and the raw field
        values (``None``: not given), before they are checked: fill values from elsewhere (a
        run folder's study), map a deprecated value, refuse a combination.
    fields : tuple of str, optional
        Only these fields become flags (a command that uses part of a capability's options,
        such as ``polypack dlvo`` with the DLVO keys of ``brownian``); ``options`` is still
        the whole resolved table.
    """

    def deco(func):
        cap = registry.get(kind, name)
        where = path or ("protocol" if kind == "protocol" else f"analysis.{cap.name}")
        import typing

        hints = typing.get_type_hints(func)  # the command module may use `from __future__ import annotations`
        own = [p.replace(kind=inspect.Parameter.KEYWORD_ONLY, annotation=hints.get(p.name, p.annotation))
               for p in inspect.signature(func).parameters.values() if p.name != "options"]
        names = {p.name for p in own}
        if fields is not None and not set(fields) <= set(cli_fields(cap)):
            raise InvalidInputError(f"fields {sorted(set(fields) - set(cli_fields(cap)))} are not options of {cap.name!r}")
        params = _field_params(cap, names, short, repeat=repeat, notes=notes, fields=fields)
        specs = {k: s for k, s in cli_fields(cap).items() if fields is None or k in fields}
        alias_params = {}
        for old, key in (aliases or {}).items():
            pname = "alias_" + old.lstrip("-").replace("-", "_")
            if key not in specs or pname in names or old in {flag(k) for k in specs}:
                raise InvalidInputError(f"alias {old} of {cap.name!r}: {key!r} is not a free field of its options")
            alias_params[pname] = (old, key)
            ann = Optional[cli_type(specs[key])]
            params.append(inspect.Parameter(pname, inspect.Parameter.KEYWORD_ONLY, annotation=ann,
                                            default=typer.Option(None, old, hidden=True,
                                                                 help=f"Deprecated spelling of {flag(key)}.")))
        defaults = {p.name: p.default.default for p in params}

        def command(**kw):
            mine = {k: kw.pop(k) for k in names}
            for pname, (old, key) in alias_params.items():
                value = kw.pop(pname)
                if value is None:
                    continue
                if kw[key] is not None and kw[key] != defaults[key]:
                    raise InvalidInputError(f"{old} {fmt(value)}: give {flag(key)} only ({old} is its old spelling)")
                kw[key] = value
            for key in repeat:
                kw[key] = _repeated(specs[key], kw[key])
            if prepare is not None:
                kw = prepare(mine, kw)
            return func(**mine, options=_table(cap, kw, where))

        command.__signature__ = inspect.Signature(own + params)
        command.__doc__ = func.__doc__
        command.__name__ = func.__name__
        command.__wrapped_capability__ = cap
        return command

    return deco


# --------------------------------------------------------------------------- protocols
def _protocol_sizes(n, d, dim, sizes):
    from ..psd.config import make_sizes, resolve

    if sizes is not None:
        given = [f for f, x in (("--n", n), ("--d", d), ("--dim", dim)) if x is not None]
        if given:
            raise InvalidInputError(f"{', '.join(given)}: not used with --sizes (the size set gives the spheres)")
        from ..psd import SizeSet

        return SizeSet.load(sizes)
    table = {"model": "monodisperse", "n": 1000 if n is None else n, "d": 1.0 if d is None else d}
    if dim is not None:
        table["dim"] = dim
    return make_sizes(resolve(table, "--n/--d/--dim"))


def _stat_lines(cap, meta) -> list:
    from ..ensemble.stages import protocol_stats

    stats = protocol_stats(dict(meta), cap)
    lines = []
    for k, v in stats.items():
        if k in ("status", "min_gap") or any(k.startswith(t + ".") for t in cap.meta_tables()):
            words = cap.words(k)
            lines.append(f"  {k} = {fmt(v) if not isinstance(v, float) else f'{v:.6g}'}"
                         + (f"  ({words})" if words else ""))
    return lines


def protocol_command(cap):
    """The typer callback of the generated command of protocol ``cap``."""
    extras = [_kw("n", Optional[int], None, "--n", help=protocol_extras["n"]),
              _kw("d", Optional[float], None, "--d", help=protocol_extras["d"]),
              _kw("dim", Optional[int], None, "--dim", help=protocol_extras["dim"]),
              _kw("sizes", Optional[Path], None, "--sizes", help=protocol_extras["sizes"]),
              _kw("seed", Optional[int], None, "--seed", help=protocol_extras["seed"])]
    out_arg = inspect.Parameter("output", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation=Path,
                                default=typer.Argument(..., metavar="OUT",
                                                       help="Output file (.gsd, .xyz, .data, .csv, .vtp)."))
    fields = _field_params(cap, set(protocol_extras) | {"output"})

    def command(output, **kw):
        import numpy as np

        from .. import io
        from .._util import output_path

        n, d, dim, sizes, seed = (kw.pop(k) for k in ("n", "d", "dim", "sizes", "seed"))
        io.format_for(str(output))
        output_path(output)  # checked before the run
        opts = _table(cap, kw, "protocol")
        s = _protocol_sizes(n, d, dim, sizes)
        if cap.preflight is not None:
            r = np.asarray(s.radii, dtype=np.float64)
            registry._load(cap.preflight)(opts, {"n": int(r.size), "radii": r, "dim": int(getattr(s, "dim", 3)),
                                                 "volume_fraction": opts.get("volume_fraction")}, "protocol")
        pk = cap.load()(s, opts, np.random.SeedSequence(seed))
        io.write(str(output), pk)
        typer.echo(f"wrote {output}: {pk.n} {'disks' if pk.dim == 2 else 'spheres'}, volume fraction "
                   f"{pk.volume_fraction:.6g} ({cap.title})")
        for line in _stat_lines(cap, pk.meta):
            typer.echo(line)

    command.__signature__ = inspect.Signature([out_arg] + extras + fields)
    command.__doc__ = f"{cap.doc or cap.name} (protocol {cap.name!r}; flags = \\[protocol] keys of a study)."
    return command


# --------------------------------------------------------------------------- mechanics stages
def stage_command(cap):
    """The typer callback of the generated command of mechanics stage ``cap``."""
    file_arg = inspect.Parameter("file", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation=Path,
                                 default=typer.Argument(..., help="Packing file (gsd, xyz, lammps data, csv)."))
    extras = [_kw("seed", int, 0, "--seed", help=stage_extras["seed"]),
              _kw("json_out", Optional[Path], None, "--json", help=stage_extras["json"]),
              _kw("fmt", Optional[str], None, "--format", help=stage_extras["format"])]
    fields = _field_params(cap, set(stage_extras) | {"file", "json_out", "fmt"})

    def command(file, **kw):
        import numpy as np

        from .. import io
        from .._util import atomic_open, output_path
        from ..ensemble.stages import _as_dict, scalar_descriptors

        seed, json_out, fmt_ = (kw.pop(k) for k in ("seed", "json_out", "fmt"))
        if json_out is not None:
            output_path(json_out)  # checked before computing
        path = f"analysis.{cap.name}"
        opts = _table(cap, kw, path)
        pk = io.read(file, fmt_)
        if cap.preflight is not None:
            box = np.asarray(pk.box, dtype=np.float64)
            registry._load(cap.preflight)(opts, {"n": int(pk.n), "dim": int(pk.dim),
                                                 "volume_fraction": float(pk.volume_fraction),
                                                 "half_box": 0.5 * float(box.min())}, path)
        res = cap.load()(pk, opts, np.random.SeedSequence(seed))
        res = [_as_dict(e) for e in res] if isinstance(res, list) else _as_dict(res)
        scal = scalar_descriptors({cap.name: res})
        typer.echo(f"{file}: N={pk.n}, volume fraction {pk.volume_fraction:.4f} ({cap.title})")
        for k, v in scal.items():
            words = cap.words(k.split(".", 1)[1])
            typer.echo(f"  {k} = {v:.6g}" + (f"  ({words})" if words else ""))
        if json_out is not None:
            with atomic_open(json_out, "w") as fh:
                json.dump({"file": str(file), "options": opts, cap.name: res}, fh, indent=1, default=float)
            typer.echo(f"  wrote {json_out}")

    command.__signature__ = inspect.Signature([file_arg] + extras + fields)
    command.__doc__ = f"{cap.doc or cap.name} (mechanics stage; flags = \\[analysis.{cap.name}] keys of a study)."
    return command


# --------------------------------------------------------------------------- registration
def _existing(app) -> set:
    out = set()
    for info in app.registered_commands:
        out.add(info.name or info.callback.__name__.replace("_", "-"))
    return out


def generated_names(app) -> dict:
    """``{command: Capability}`` of the commands this module generates for ``app``."""
    return dict(getattr(app, "_polypack_generated", {}))


def register_generated(app: typer.Typer) -> None:
    """Add a command for every protocol and mechanics stage that has no hand-written command."""
    taken = _existing(app)
    made = {}
    for kind, factory in (("protocol", protocol_command), ("mechanics", stage_command)):
        for cap in registry.capabilities(kind).values():
            name = command_name(cap)
            if name in taken:
                continue
            app.command(name)(factory(cap))
            taken.add(name)
            made[name] = cap
    app._polypack_generated = made
