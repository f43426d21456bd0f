"""``polypack analyze``: statistical descriptors of a packing file (JSON + plots)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import List, Optional

import typer


def analyze_packing(
    pk,
    rdf=True,
    partial=True,
    kfunc=True,
    windows=True,
    contacts=True,
    pores=True,
    r_max=3.0,
    dr=0.01,
    window_radius=2.5,
    tolerance=0.01,
    n_points=200_000,
    seed=1,
    plots=None,
):
    """Run the selected estimators on ``pk``; returns plain JSON-able data.

    ``r_max`` is in diameters of the largest species (so that every partial RDF
    reaches beyond its first shells) and ``dr`` in number-mean diameters; ``r_max``
    is capped at half the smallest box length (the cap is reported).
    """
    import numpy as np

    from .. import _interrupt, analysis
    from ..analysis._base import to_jsonable
    from ..analysis._paircounts import species_radii
    from ..errors import InvalidInputError

    d_mean = float(np.mean(2 * pk.radii))
    d_large = float(2 * np.nanmax(species_radii(pk)))
    r_abs = r_max * d_large
    notes = []
    half = 0.5 * float(np.min(pk.box))
    if r_abs > half:
        notes.append(f"r_max {r_abs:g} capped at half the box length {half:g}")
        r_abs = half
    step = dr * d_mean
    out = {
        "n": pk.n,
        "box": pk.box.tolist(),
        "volume_fraction": pk.volume_fraction,
        "species_counts": pk.species_counts.tolist(),
        "mean_diameter": d_mean,
        "largest_species_diameter": d_large,
        "notes": notes,
    }
    figs = {}
    if rdf or partial:
        g = analysis.RDF(r_max=r_abs, dr=step).compute(pk)
        out["rdf"] = g.to_dict()
        vals, errs = analysis.contact_value(pk, return_error=True)
        ns = pk.n_species
        out["contact_values"] = to_jsonable(
            {(k, m): {"value": vals[(k, m)], "error": errs[(k, m)]} for k in range(ns) for m in range(k, ns)}
        )
        figs["rdf"] = lambda ax: g.plot(ax=ax, partials=partial)
        if partial and ns > 1:
            figs["rdf_partial_R"] = lambda ax: g.plot(ax=ax, coordinate="R")
    _interrupt.check()
    if kfunc:
        k = analysis.KFunction(r_max=r_abs, dr=step).compute(pk)
        out["kfunction"] = k.to_dict()
        figs["kfunction"] = lambda ax: k.plot(ax=ax)
    _interrupt.check()
    if windows:
        w = analysis.WindowCounts(window_radius=window_radius)
        try:
            w.compute(pk)
        except InvalidInputError as exc:  # window larger than half the box
            notes.append(f"windows skipped: {exc}")
        else:
            out["windows"] = w.to_dict()
            figs["windows"] = lambda ax: w.plot(ax=ax)
    _interrupt.check()
    if contacts:
        c = analysis.Contacts(tolerance=tolerance).compute(pk)
        out["contacts"] = c.to_dict()
        figs["contacts"] = lambda ax: c.plot(ax=ax)
    _interrupt.check()
    if pores:
        p = analysis.PoreSizes(n_points=n_points, seed=seed).compute(pk)
        out["pores"] = p.to_dict()
        figs["pores"] = lambda ax: p.plot(ax=ax)
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

    @app.command()
    def analyze(
        file: Path = typer.Argument(..., help="Packing file (gsd, xyz, lammps data, csv)."),
        rdf: bool = typer.Option(False, "--rdf", help="Total RDF g(r) and contact values g(2a+)."),
        partial: bool = typer.Option(False, "--partial", help="Partial RDFs g_km(r) and g_km(R_km)."),
        kfunc: bool = typer.Option(False, "--kfunc", help="K function, total and partial."),
        windows: bool = typer.Option(False, "--windows", help="Window histogram p(n_h)."),
        contacts: bool = typer.Option(False, "--contacts", help="Coordination numbers, rattlers."),
        pores: bool = typer.Option(False, "--pores", help="Pore-size distribution and DOH fit."),
        r_max: float = typer.Option(3.0, help="RDF/K range in diameters of the largest species (capped at half the box)."),
        dr: float = typer.Option(0.01, help="Bin width in mean diameters."),
        window_radius: float = typer.Option(2.5, help="Window radius R_h in sphere radii."),
        tolerance: float = typer.Option(0.01, help="Contact gap tolerance eps."),
        points: int = typer.Option(200_000, help="Test points for the pore sizes."),
        seed: int = typer.Option(1, help="Seed of the pore test points."),
        json_out: Optional[str] = typer.Option(None, "--json", help="Write all results as JSON here ('-': stdout)."),
        plots: Optional[Path] = typer.Option(None, "--plots", help="Write PNG plots into this folder."),
        fmt: Optional[str] = typer.Option(None, "--format", help="Override the file format."),
        overlaps: str = typer.Option("warn", "--overlaps", help="Overlapping input: warn, error or ignore."),
        run: Optional[List[str]] = typer.Option(
            None, "--run",
            help=f"Run a registered analysis with the options of its \\[analysis.NAME] study table (user length "
                 f"units), e.g. --run rdf:r_max=2.5,dr=0.02; repeatable. Registered: {names}."),
    ):
        """Statistical descriptors of a pack (all of them unless some are selected)."""
        from .. import io
        from .._util import atomic_open, check_output_folder, output_path

        to_stdout = json_out == "-"
        if json_out is not None and not to_stdout:
            output_path(json_out)  # checked before computing
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
        chosen = [rdf, partial, kfunc, windows, contacts, pores]
        if not any(chosen):
            chosen = [not run] * 6
        with overlap_policy("ignore"):  # judged above, once
            res = analyze_packing(
                pk, *chosen, r_max=r_max, dr=dr, window_radius=window_radius, tolerance=tolerance,
                n_points=points, seed=seed, plots=plots,
            )
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
                f"  coordination {res['contacts']['coordination']:.3f} (eps={tolerance:g}), "
                f"rattlers {res['contacts']['rattler_fraction']:.3f}"
            )
        if "windows" in res:
            typer.echo(f"  window counts R_h={window_radius:g}: mean {res['windows']['mean']:.3f}")
        if "pores" in res:
            f = res["pores"]["fit"]["normalized"]
            if "a" in f:
                typer.echo(f"  pores: void fraction {res['pores']['void_fraction']:.4f}, "
                           f"DOH a={f['a']:.4f}±{f['a_err']:.4f}, b={f['b']:.4f} (normalised form)")
        if json_out is not None:
            typer.echo(f"  wrote {json_out}")
        if plots is not None:
            typer.echo(f"  wrote {len(res.get('plots', []))} plots to {plots}")
