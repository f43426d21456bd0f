"""``polypack analyze``: statistical descriptors of a packing file (JSON + plots)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import List, Optional

import typer


#: The registered analyses `polypack analyze` runs (all unless some are selected), and their selection flags.
STAGES = {"rdf": "rdf", "kfunc": "kfunction", "windows": "windows", "contacts": "contacts", "pores": "pores"}


def option_fields() -> dict:
    """``{field: (OptionSpec, [analyses])}``: the option flags of ``analyze``, the fields of its analyses."""
    from .. import registry

    out = {}
    for name in STAGES.values():
        for k, spec in registry.get("analysis", name).specs().items():
            if spec.cli:
                out.setdefault(k, (spec, []))[1].append(name)
    return out


def analyze_packing(pk, selected=tuple(STAGES.values()), options=None, seed=1, plots=None, partial=True):
    """Run the selected registered analyses on ``pk``, as ``polypack run`` does; returns plain JSON-able data.

    ``options`` holds ``[analysis.NAME]`` keys (study units and defaults: ``r_max`` and ``dr``
    in the pack's length unit, ...) given on the command line; each analysis takes the keys
    it declares, resolved by the registry (:meth:`polypack.registry.Capability.resolve`) and
    run by its registered run function with a child of ``SeedSequence(seed)``.  ``r_max``
    beyond half the smallest box length is capped there (reported in ``notes``).
    """
    import numpy as np

    from .. import _interrupt, analysis, registry
    from ..analysis._base import to_jsonable
    from ..errors import InvalidInputError
    from ._generated import _table

    options = dict(options or {})
    notes = []
    half = 0.5 * float(np.min(pk.box))
    out = {
        "n": pk.n,
        "box": pk.box.tolist(),
        "volume_fraction": pk.volume_fraction,
        "species_counts": pk.species_counts.tolist(),
        "mean_diameter": float(np.mean(2 * pk.radii)),
        "notes": notes,
    }
    figs = {}
    seeds = dict(zip(selected, np.random.SeedSequence(seed).spawn(len(selected))))
    for name in selected:
        cap = registry.get("analysis", name)
        given = {k: v for k, v in options.items() if k in cap.specs()}
        opts = _table(cap, given, f"analysis.{name}")
        if "r_max" in opts and opts["r_max"] > half:
            notes.append(f"{name}: r_max {opts['r_max']:g} capped at half the box length {half:g}")
            opts["r_max"] = half
        try:
            est = cap.load()(pk, opts, seeds[name])
        except InvalidInputError as exc:
            if name != "windows":
                raise InvalidInputError(f"analysis.{name}: {exc}") from None
            notes.append(f"windows skipped: {exc}")  # a window larger than half the box
            _interrupt.check()
            continue
        ests = est if isinstance(est, list) else [est]
        dicts = [e if isinstance(e, dict) else e.to_dict() for e in ests]
        out[name] = dicts if isinstance(est, list) else dicts[0]
        for j, e in enumerate(ests):
            if hasattr(e, "plot"):
                key = name if j == 0 else f"{name}{j}"
                if name == "rdf":
                    figs[key] = (lambda e: lambda ax: e.plot(ax=ax, partials=partial))(e)
                    if partial and pk.n_species > 1:
                        figs["rdf_partial_R"] = (lambda e: lambda ax: e.plot(ax=ax, coordinate="R"))(e)
                else:
                    figs[key] = (lambda e: lambda ax: e.plot(ax=ax))(e)
        if name == "rdf":
            vals, errs = analysis.contact_value(pk, return_error=True)
            ns = pk.n_species
            out["contact_values"] = to_jsonable(
                {(k, m): {"value": vals[(k, m)], "error": errs[(k, m)]} for k in range(ns) for m in range(k, ns)}
            )
        _interrupt.check()
    if plots is not None:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        from .._util import atomic_path, make_folder

        folder = make_folder(plots)
        written = []
        for name, draw in figs.items():
            fig, ax = plt.subplots(figsize=(6, 4))
            draw(ax)
            fig.tight_layout()
            path = folder / f"{name}.png"
            with atomic_path(path) as tmp:
                fig.savefig(tmp, dpi=120, format="png")
            plt.close(fig)
            written.append(str(path))
        out["plots"] = written
    return out


def _parse_run(spec: str):
    """``"name:key=value,key=value"`` -> ``(name, {key: value})`` (values read as TOML, else text)."""
    import tomllib

    from ..errors import InvalidInputError

    name, _, rest = spec.partition(":")
    table = {}
    for item in filter(None, (x.strip() for x in rest.split(","))):
        key, eq, value = item.partition("=")
        if not eq:
            raise InvalidInputError(f"--run {spec!r}: options are key=value pairs separated by commas")
        try:
            table[key.strip()] = tomllib.loads(f"v = {value.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            table[key.strip()] = value.strip()
    return name.strip(), table


def run_registered(pk, specs, seed=1):
    """Run registered analyses (``[analysis.NAME]`` options of a study) on ``pk``: ``{name: result dict}``."""
    import numpy as np

    from .. import registry

    out = {}
    seeds = np.random.SeedSequence(seed).spawn(len(specs))
    for spec, ss in zip(specs, seeds):
        name, table = _parse_run(spec)
        cap = registry.get("analysis", name, path="--run")
        opts = cap.resolve(table, f"analysis.{name}")
        est = cap.load()(pk, opts, ss)
        conv = (lambda e: e if isinstance(e, dict) else e.to_dict())
        out[name] = [conv(e) for e in est] if isinstance(est, list) else conv(est)
    return out


def register(app: typer.Typer) -> None:
    from .. import registry

    names = ", ".join(registry.stages())  # analyses and mechanics stages

    def analyze(
        file: Path = typer.Argument(..., help="Packing file (gsd, xyz, lammps data, csv)."),
        rdf: bool = typer.Option(False, "--rdf", help="Total RDF g(r) and contact values g(2a+) (\\[analysis.rdf])."),
        partial: bool = typer.Option(False, "--partial", help="Partial RDFs g_km(r) and g_km(R_km) (\\[analysis.rdf])."),
        kfunc: bool = typer.Option(False, "--kfunc", help="K function, total and partial (\\[analysis.kfunction])."),
        windows: bool = typer.Option(False, "--windows", help="Window histogram p(n_h) (\\[analysis.windows])."),
        contacts: bool = typer.Option(False, "--contacts", help="Coordination numbers, rattlers (\\[analysis.contacts])."),
        pores: bool = typer.Option(False, "--pores", help="Pore-size distribution and DOH fit (\\[analysis.pores])."),
        seed: int = typer.Option(1, help="Seed of the analyses' random numbers (pore test points)."),
        json_out: Optional[str] = typer.Option(None, "--json", help="Write all results as JSON here ('-': stdout)."),
        plots: Optional[Path] = typer.Option(None, "--plots", help="Write PNG plots into this folder."),
        fmt: Optional[str] = typer.Option(None, "--format", help="Override the file format."),
        overlaps: str = typer.Option("warn", "--overlaps", help="Overlapping input: warn, error or ignore."),
        run: Optional[List[str]] = typer.Option(
            None, "--run",
            help=f"Run a registered analysis with the options of its \\[analysis.NAME] study table (user length "
                 f"units), e.g. --run rdf:r_max=2.5,dr=0.02; repeatable. Registered: {names}."),
        options: dict = None,
    ):
        """Statistical descriptors of a pack (all of them unless some are selected)."""
        from .. import io
        from .._util import atomic_open, check_new_output, check_output_folder, file_kind, output_path

        to_stdout = json_out == "-"
        if json_out is not None and not to_stdout:
            output_path(json_out)  # checked before computing
            check_new_output(json_out, file_kind(json_out), inputs=(file,), option="--json")
        if plots is not None:
            check_output_folder(plots)
        from ..analysis._base import OVERLAP_TOLERANCE, overlap_policy
        from ..errors import InvalidInputError, OverlapError

        if overlaps not in ("warn", "error", "ignore"):
            raise InvalidInputError(f"--overlaps {overlaps!r}: allowed are warn, error, ignore")
        pk = io.read(file, fmt)
        if overlaps != "ignore" and pk.n >= 2:
            gap, pair = pk.closest_pair()
            if gap < -OVERLAP_TOLERANCE:
                msg = (f"{file} has overlapping spheres ({pk.overlaps(0.0).shape[0]} pair(s); worst: {pair[0]} and "
                       f"{pair[1]}, relative gap {gap:.3g}); its statistics are not those of a hard-sphere pack")
                if overlaps == "error":
                    raise OverlapError(msg)
                typer.echo(f"warning: {msg}", err=True)
        flags = {"rdf": rdf or partial, "kfunc": kfunc, "windows": windows, "contacts": contacts, "pores": pores}
        if not any(flags.values()):
            flags = dict.fromkeys(flags, not run)
        unused = sorted(k for k in options if not any(k in registry.get("analysis", STAGES[f]).specs()
                                                      for f, on in flags.items() if on))
        if unused:
            raise InvalidInputError(f"--{unused[0].replace('_', '-')}: not used by the selected analyses "
                                    f"({', '.join(STAGES[f] for f, on in flags.items() if on) or 'none'})")
        with overlap_policy("ignore"):  # judged above, once
            res = analyze_packing(pk, [STAGES[f] for f, on in flags.items() if on], options, seed=seed, plots=plots,
                                  partial=partial or not rdf)
        res = {"file": str(file), **res}
        if run:
            res["registered"] = run_registered(pk, run, seed)
        if to_stdout:  # machine-readable output only
            typer.echo(json.dumps(res, indent=1))
            return
        if json_out is not None:
            with atomic_open(json_out, "w") as fh:
                json.dump(res, fh, indent=1)
        typer.echo(f"{file}: N={pk.n}, volume fraction {pk.volume_fraction:.4f}, species {pk.species_counts.tolist()}")
        for note in res["notes"]:
            typer.echo(f"  note: {note}")
        for name, d in res.get("registered", {}).items():
            from ..ensemble.stages import scalar_descriptors

            sc = scalar_descriptors({name: d})
            shown = ", ".join(f"{k}={v:.4g}" for k, v in list(sc.items())[:6])
            typer.echo(f"  {name}: {shown or 'done'}")
        if "contact_values" in res:
            cv = ", ".join(f"g_{k}(contact)={v['value']:.3f}" for k, v in res["contact_values"].items())
            typer.echo(f"  {cv}")
        if "contacts" in res:
            typer.echo(
                f"  coordination {res['contacts']['coordination']:.3f} (eps={res['contacts']['tolerance']:g}), "
                f"rattlers {res['contacts']['rattler_fraction']:.3f}"
            )
        if "windows" in res:
            for w in (res["windows"] if isinstance(res["windows"], list) else [res["windows"]]):
                typer.echo(f"  window counts R_h={w['window_radius']:g}: mean {w['mean']:.3f}")
        if "pores" in res:
            f = res["pores"]["fit"]["normalized"]
            if "a" in f:
                typer.echo(f"  pores: void fraction {res['pores']['void_fraction']:.4f}, "
                           f"DOH a={f['a']:.4f}±{f['a_err']:.4f}, b={f['b']:.4f} (normalised form)")
        if json_out is not None:
            typer.echo(f"  wrote {json_out}")
        if plots is not None:
            typer.echo(f"  wrote {len(res.get('plots', []))} plots to {plots}")

    app.command("analyze")(_with_option_fields(analyze))


def _with_option_fields(func):
    """``analyze`` with one flag per field of its analyses (the ``[analysis.NAME]`` keys, study units and
    defaults); the command receives the given ones as ``options``."""
    import inspect
    import typing

    from .._validate import fmt
    from ._generated import _help, cli_type, flag

    hints = typing.get_type_hints(func)
    own = [p.replace(kind=inspect.Parameter.KEYWORD_ONLY, annotation=hints.get(p.name, p.annotation))
           for p in inspect.signature(func).parameters.values() if p.name != "options"]
    names = {p.name for p in own}
    fields = []
    for key, (spec, users) in option_fields().items():
        typ = cli_type(spec)
        decl = f"{flag(key)}/--no-{key.replace('_', '-')}" if typ is bool else flag(key)
        fields.append(inspect.Parameter(key, inspect.Parameter.KEYWORD_ONLY, annotation=Optional[typ],
                                        default=typer.Option(None, decl, help=f"\\[{', '.join(users)}] " + _help(spec),
                                                             show_default=False if spec.default is None
                                                             else fmt(spec.default))))

    def command(**kw):
        mine = {k: kw.pop(k) for k in names}
        return func(**mine, options={k: v for k, v in kw.items() if v is not None})

    command.__signature__ = inspect.Signature(own + fields)
    command.__doc__ = func.__doc__
    command.__name__ = func.__name__
    return command
