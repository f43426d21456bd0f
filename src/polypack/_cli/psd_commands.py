"""``polypack psd``: a representative set of particle sizes from a size-distribution model.

Implements the generation procedure of 001_ad5bae0acea940c4.txt (§1.2) and the bimodal
description of 000_2cedc098acbd866b.txt; writes the sizes (CSV), a JSON report and plots.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import FormatError, InvalidInputError


def _load_config(path: Path) -> dict:
    import tomllib

    try:
        data = tomllib.loads(Path(path).read_text())
    except OSError as exc:
        raise FormatError(f"cannot read config {path}: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise FormatError(f"cannot read config {path}: not a UTF-8 text file") from None
    except tomllib.TOMLDecodeError as exc:
        raise FormatError(f"{path}: invalid TOML ({exc})") from None
    if "psd" not in data or not isinstance(data["psd"], dict):
        raise InvalidInputError(f"{path}: no [psd] section")
    return dict(data["psd"])


def run(params: dict, output: Path, report: Optional[Path] = None, plots: Optional[Path] = None, echo=print):
    """Build the size set described by ``params`` (one ``[psd]`` table) and write it; returns the SizeSet.

    The table is resolved by :func:`polypack.psd.config.resolve`, the same code as a
    study's ``[psd]`` table, so both read it the same way.
    """
    from .._util import check_output_folder, output_path
    from ..psd.config import make_model, make_sizes, resolve

    res = resolve(params, "psd")
    output_path(output)  # destinations checked before the sizes are built
    if report is not None:
        output_path(report)
    if plots is not None:
        check_output_folder(plots)
    model, s = make_model(res), make_sizes(res)
    csv_path, json_path = s.save(output, report)
    desc = s.report["descriptors"]
    echo(f"wrote {s.n} sizes ({len(desc['species_counts'])} species) to {csv_path}; report {json_path}")
    line = f"  d10={desc['d10']:.4g} d50={desc['d50']:.4g} d60={desc['d60']:.4g} Cu={desc['Cu']:.4g} Cc={desc['Cc']:.4g}"
    if "Cr" in desc:
        line += f" Cr={desc['Cr']:.3g}"
    echo(line + f" polydispersity={desc['polydispersity']:.4g}")
    if plots is not None:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        from .._util import atomic_path, make_folder

        plots = make_folder(plots)
        for name, ax in (("grading", s.plot_grading(model)), ("histogram", s.plot_histogram())):
            with atomic_path(plots / f"{name}.png") as tmp:
                ax.figure.savefig(tmp, dpi=120, bbox_inches="tight", format="png")
            plt.close(ax.figure)
        echo(f"  plots in {plots}")
    return s


def _cli_type(spec):
    """Python type of a CLI option from its check: numbers float, integers int, the rest text."""
    d = spec.describe
    if d.startswith("integer") or d.startswith("2 (disks)"):
        return int
    if d.startswith("number") and "array" not in d:
        return float
    if d == "boolean":
        return bool
    return str


def psd_options() -> dict:
    """``{key: OptionSpec}`` of every ``[psd]`` key offered on the command line (from the registry)."""
    from .. import registry
    from ..psd._capabilities import Generation

    specs = {k: s for k, s in registry.option_specs(Generation).items() if s.cli}
    models = registry.capabilities("psd")
    owners: dict = {}
    for name, cap in models.items():
        for k, s in cap.specs().items():
            if s.cli:
                specs.setdefault(k, s)
                owners.setdefault(k, []).append(name)
    return specs, owners


def register(app: typer.Typer) -> None:
    import inspect

    from .. import registry
    from .._reference import default_text
    from ._generated import _esc

    specs, owners = psd_options()
    models = registry.capabilities("psd")
    params = []
    for key, spec in specs.items():
        flag = "--" + key.replace("_", "-")
        decls = [flag, "-m"] if key == "model" else [flag]
        typ = _cli_type(spec)
        if key == "model":
            aliases = sorted(a for c in models.values() for a in c.aliases)
            help_ = f"{', '.join(models)} (aliases {', '.join(aliases)}); default {spec.default}."
        else:
            who = f" \\[{', '.join(owners[key])}]" if key in owners else ""
            # the declared default (or unset rule) when every model that has the key agrees on it
            texts = {default_text(models[o].specs()[key]) for o in owners[key]} if key in owners \
                else {default_text(spec)}
            t = texts.pop() if len(texts) == 1 else "required"
            dflt = "" if t == "required" else f"; {t}" if t.startswith("unset") else f"; default {t}"
            help_ = f"{_esc(spec.doc)}{who} ({_esc(spec.describe)}{_esc(dflt)})."
        if typ is bool:
            opt = typer.Option(None, f"{flag}/--no-{key.replace('_', '-')}", help=help_)
        else:
            opt = typer.Option(None, *decls, help=help_)
        params.append(inspect.Parameter(key, inspect.Parameter.KEYWORD_ONLY, default=opt,
                                        annotation=Optional[typ]))
    params += [
        inspect.Parameter("config", inspect.Parameter.KEYWORD_ONLY, annotation=Optional[Path],
                          default=typer.Option(None, "--config",
                                               help="TOML file with a \\[psd] section (options override it).")),
        inspect.Parameter("output", inspect.Parameter.KEYWORD_ONLY, annotation=Path,
                          default=typer.Option(Path("sizes.csv"), "--output", "-o",
                                               help="Size-set CSV (radius,diameter,species).")),
        inspect.Parameter("report", inspect.Parameter.KEYWORD_ONLY, annotation=Optional[Path],
                          default=typer.Option(None, "--report", help="JSON report (default: output with .json).")),
        inspect.Parameter("plots", inspect.Parameter.KEYWORD_ONLY, annotation=Optional[Path],
                          default=typer.Option(None, "--plots", help="Folder for grading and histogram plots.")),
    ]

    def psd_command(**kw):
        """Generate a representative size set (seed 001 §1.2) or a bimodal/mixture set (seed 000).

        Options are the keys of the \\[psd] table (the same as in a study file), generated from
        the registered size-distribution models.
        """
        config, output, report, plots = (kw.pop(k) for k in ("config", "output", "report", "plots"))
        table = _load_config(config) if config is not None else {}
        given = {k: (str(v) if isinstance(v, Path) else v) for k, v in kw.items() if v is not None}
        table.update(given)
        run(table, output, report, plots, echo=typer.echo)

    psd_command.__signature__ = inspect.Signature(params)
    app.command("psd")(psd_command)
