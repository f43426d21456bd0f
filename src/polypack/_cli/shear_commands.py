"""``polypack shear FILE``: bonded-DEM oscillatory shear of a packing file (§2.4 of 003_873b69fc71c74cf6.txt)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import List, Optional

import typer

from ._generated import options_from
from ._network import FILE_BONDS, NETWORK_ALIASES, NETWORK_NOTES, cli_bonds


def _direction_pairs(values):
    """The old repeated ``--direction NORMAL,SHEAR`` as the ``directions`` value ``[[2, 0], ...]``."""
    from ..errors import InvalidInputError

    out = []
    for v in values:
        parts = v.replace(",", " ").split()
        try:
            out.append([int(parts[0]), int(parts[1])])
            if len(parts) != 2:
                raise ValueError
        except (ValueError, IndexError):
            raise InvalidInputError(f"--direction {v!r}: give 'NORMAL,SHEAR' axes, e.g. 2,0 "
                                    "(or --directions \"[[2, 0]]\")") from None
    return out


def _prepare(own, flags):
    """The old ``--bonds file`` and the old repeated ``--direction N,S`` (hidden) reach the fields."""
    flags = cli_bonds(own, flags)
    if own.get("direction"):
        if flags.get("directions") not in (None, "6"):
            from ..errors import InvalidInputError

            raise InvalidInputError("--direction: give --directions only (--direction is its old spelling)")
        flags = {**flags, "directions": _direction_pairs(own["direction"])}
    return flags


def register(app: typer.Typer) -> None:
    """Add the ``shear`` command to ``app``."""

    @app.command()
    @options_from("mechanics", "shear", aliases=NETWORK_ALIASES, notes=NETWORK_NOTES, prepare=_prepare)
    def shear(
        source: Path = typer.Argument(..., metavar="FILE", help="Packing file (gsd, xyz, lammps data, csv)."),
        direction: Optional[List[str]] = typer.Option(None, "--direction", hidden=True,
                                                      help="Old spelling: NORMAL,SHEAR axes (repeat)."),
        json_out: Optional[Path] = typer.Option(None, "--json", help="Write the result (with time series) as JSON."),
        plot: Optional[Path] = typer.Option(None, "--plot", help="Write the stress-strain plot here (.png, .pdf, .svg)."),
        trajectory: Optional[Path] = typer.Option(
            None, "--trajectory", help="Write GSD frames with contact forces (20 per cycle) here."
        ),
        progress: Optional[bool] = typer.Option(None, "--progress/--no-progress", help="Progress bar."),
        force: bool = typer.Option(False, "--force", help="Replace existing output files of another kind."),
        options: dict = None,
    ):
        """Storage and loss moduli G', G'' of the bonded pack by oscillatory shear (DEM).

        The option flags are the keys of \\[analysis.shear] in a study (same defaults and units).
        """
        from .._util import atomic_open, atomic_path, check_new_output, check_plot_path, file_kind
        from ..mechanics import ShearInterrupted, oscillatory_shear
        from ..mechanics.stages import SHEAR_KEYS, _stiffnesses
        from ._network import network_from_file

        # every output path is checked before the computation
        if json_out is not None:
            check_new_output(json_out, "JSON", inputs=(source,), force=force, option="--json")
        if plot is not None:
            check_new_output(plot, file_kind(plot), inputs=(source,), force=force, option="--plot")
            check_plot_path(plot)
        if trajectory is not None:
            check_new_output(trajectory, "GSD", inputs=(source,), force=force, option="--trajectory")
        o = options
        kn, ks = _stiffnesses(o)  # shear_stiffness unset: normal_stiffness / 10 (seed 003 Table 1)
        strengths = {k: o[k] for k in ("normal_strength", "shear_strength", "reference") if k in o}
        pk, net, bonds_note, units_note = network_from_file(
            source, bonds=FILE_BONDS[o["bonds"]], epsilon=o["epsilon"], radius=o["radius"], normal_stiffness=kn,
            shear_stiffness=ks, stiffness=o.get("stiffness", "contact"), **strengths)
        typer.echo(f"{source}: {units_note}; {bonds_note}")
        kw = {k: o[k] for k in SHEAR_KEYS if k in o}
        d = o.get("directions", 6)
        kw["directions"] = d if d == 6 else [tuple(p) for p in d]
        boundary = kw.get("boundary", "lees-edwards")
        interrupted = False
        try:
            res = oscillatory_shear(net, trajectory=trajectory, progress=progress, **kw)
        except ShearInterrupted as exc:
            res = exc.result
            interrupted = True
        typer.echo(f"  {pk.n} spheres, {net.n_bonds} bonds (coordination {net.coordination:.2f}), {boundary}")
        if res.status == "floppy":
            typer.echo(f"  floppy: G' = 0 ({res.floppy_reason}); no DEM run")
        else:
            typer.echo(
                f"  {res.steps_per_cycle} steps/cycle, dt {res.time_step:.3g} (critical {res.critical_time_step:.3g}, "
                f"mass scale {res.mass_scale:.3g}, inertial error ~{res.inertial_error:.1e})"
                + (f", static G' {res.static_storage_modulus:.6g}" if res.static_storage_modulus is not None else "")
            )
        for row in res.per_direction:
            typer.echo(
                f"  normal {row['normal']} shear {row['shear']} ({row['voigt']}): G' = {row['storage_modulus']:.6g}"
                f"  G'' = {row['loss_modulus']:.4g}  phase {row['phase_angle']:.2e} rad  breaks {row['breakages']}"
                + ("" if row["complete"] else "  (interrupted)")
            )
        if res.status != "floppy":
            typer.echo(
                f"  G' = {res.storage_modulus:.6g} +- {res.storage_modulus_sd:.3g}   G'' = {res.loss_modulus:.4g}"
                f"   ({res.wall_time:.1f} s, {res.particle_steps_per_second:.3g} particle-steps/s)"
            )
        if res.status == "not_converged":
            typer.echo("  NOT CONVERGED: " + "; ".join(res.problems))
        if interrupted:  # what was measured is printed above; nothing incomplete is written
            raise typer.Exit(130)
        if json_out is not None and (res.per_direction or res.status == "floppy"):
            from ..ensemble.runner import finite_json

            out = finite_json(res.to_dict(series=True))  # NaN never reaches JSON
            out["source"] = str(source)
            with atomic_open(json_out, "w") as fh:
                json.dump(out, fh, indent=1, allow_nan=False)
            typer.echo(f"  wrote {json_out}")
        if plot is not None and res.per_direction:
            import matplotlib

            matplotlib.use("Agg", force=False)
            import matplotlib.pyplot as plt

            fig, ax = plt.subplots(figsize=(7, 4))
            res.plot(ax=ax)
            fig.tight_layout()
            with atomic_path(plot) as tmp:
                fig.savefig(tmp, format=check_plot_path(plot), dpi=120)
            plt.close(fig)
            typer.echo(f"  wrote {plot}")
