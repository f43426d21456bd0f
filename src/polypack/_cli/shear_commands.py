"""``polypack shear FILE``: bonded-DEM oscillatory shear of a packing file (§2.4 of 003_873b69fc71c74cf6.txt)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import List, Optional

import typer


def _directions(values):
    if not values:
        return 6
    out = []
    for v in values:
        parts = v.replace(",", " ").split()
        if len(parts) != 2:
            from ..errors import InvalidInputError

            raise InvalidInputError(f"--direction {v!r}: give 'NORMAL,SHEAR' axes, e.g. 2,0")
        out.append((int(parts[0]), int(parts[1])))
    return out


def register(app: typer.Typer) -> None:
    """Add the ``shear`` command to ``app``."""

    @app.command()
    def shear(
        source: Path = typer.Argument(..., metavar="FILE", help="Packing file (gsd, xyz, lammps data, csv)."),
        epsilon: float = typer.Option(0.01, "--epsilon", help="Bond pairs closer than (1+epsilon)(r_i+r_j)."),
        normal_stiffness: float = typer.Option(100.0, "--kn", help="Normal contact stiffness (N/m)."),
        shear_stiffness: float = typer.Option(10.0, "--ks", help="Shear contact stiffness (N/m)."),
        stiffness: str = typer.Option("contact", "--stiffness", help="contact: --kn/--ks per contact; particle: "
                                      "per ball, in series per contact (PFC 4, seed 003 Table 1: kn/2 for equal balls)."),
        normal_strength: float = typer.Option(1e-4, "--normal-strength", help="Bond normal strength (N)."),
        shear_strength: float = typer.Option(1e-6, "--shear-strength", help="Bond shear strength (N)."),
        reference: str = typer.Option("stress-free", "--reference", help="stress-free or zero-gap."),
        boundary: str = typer.Option("lees-edwards", "--boundary", help="lees-edwards or plates."),
        direction: Optional[List[str]] = typer.Option(
            None, "--direction", help="NORMAL,SHEAR axes (repeat); default all six."
        ),
        frequency: float = typer.Option(1.0, "--frequency", help="Drive frequency (Hz)."),
        amplitude: float = typer.Option(1e-3, "--amplitude", help="Peak shear strain."),
        cycles: int = typer.Option(10, "--cycles", help="Oscillation cycles per direction."),
        steps_per_cycle: int = typer.Option(4000, "--steps-per-cycle", help="Time steps per cycle."),
        samples_per_cycle: int = typer.Option(100, "--samples-per-cycle",
                                              help="Stress samples per cycle (8 or more, at most --steps-per-cycle)."),
        damping: float = typer.Option(0.9, "--damping", help="Local damping coefficient alpha."),
        density: float = typer.Option(3690.0, "--density", help="Particle density before mass scaling."),
        json_out: Optional[Path] = typer.Option(None, "--json", help="Write the result (with time series) as JSON."),
        plot: Optional[Path] = typer.Option(None, "--plot", help="Write the stress-strain plot here (.png, .pdf, .svg)."),
        trajectory: Optional[Path] = typer.Option(
            None, "--trajectory", help="Write GSD frames with contact forces (20 per cycle) here."
        ),
        progress: Optional[bool] = typer.Option(None, "--progress/--no-progress", help="Progress bar."),
        radius: float = typer.Option(
            0.25e-6, "--radius", help="Mean particle radius in metres the lengths are rescaled to (seed 003: "
            "0.25 µm; stresses in Pa); 0 keeps the file's length unit."),
        bonds: str = typer.Option("auto", "--bonds", help="auto (bonds stored in the file or made by its protocol, "
                                  "else the epsilon rule), file (stored only) or distance (always epsilon)."),
        force: bool = typer.Option(False, "--force", help="Replace existing output files of another kind."),
    ):
        """Storage and loss moduli G', G'' of the bonded pack by oscillatory shear (DEM)."""
        from .._util import atomic_open, atomic_path, check_new_output, check_plot_path, file_kind
        from ..mechanics import ShearInterrupted, oscillatory_shear
        from ._network import network_from_file

        # every output path is checked before the computation
        if json_out is not None:
            check_new_output(json_out, "JSON", inputs=(source,), force=force, option="--json")
        if plot is not None:
            check_new_output(plot, file_kind(plot), inputs=(source,), force=force, option="--plot")
            check_plot_path(plot)
        if trajectory is not None:
            check_new_output(trajectory, "GSD", inputs=(source,), force=force, option="--trajectory")
        pk, net, bonds_note, units_note = network_from_file(
            source, bonds=bonds, epsilon=epsilon, radius=radius, normal_stiffness=normal_stiffness,
            shear_stiffness=shear_stiffness, normal_strength=normal_strength, shear_strength=shear_strength,
            reference=reference, stiffness=stiffness)
        typer.echo(f"{source}: {units_note}; {bonds_note}")
        interrupted = False
        try:
            res = oscillatory_shear(net, frequency=frequency, amplitude=amplitude, cycles=cycles,
                                    directions=_directions(direction), boundary=boundary,
                                    steps_per_cycle=steps_per_cycle, samples_per_cycle=samples_per_cycle,
                                    damping=damping, density=density,
                                    trajectory=trajectory, progress=progress)
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
