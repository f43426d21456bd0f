"""``polypack vem OUT``: a heterogeneous structure by the void expansion method
(§2.2 of 003_873b69fc71c74cf6.txt)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer


def register(app: typer.Typer) -> None:
    """Add the ``vem`` command to ``app``."""

    @app.command("vem")
    def vem_command(
        output: Path = typer.Argument(..., metavar="OUT", help="Output file (.gsd, .xyz, .data, .csv, .vtp)."),
        n: int = typer.Option(8000, "--n", help="Number of structure spheres N."),
        volume_fraction: float = typer.Option(0.4, "--volume-fraction", "-c", help="Structure volume fraction Φ."),
        void_ratio: float = typer.Option(1.0, "--void-ratio", help="Void to structure number ratio N_V / N."),
        radius: float = typer.Option(1.0, "--radius", help="Structure sphere radius (user units; seed: 0.25e-6 m)."),
        growth_factor: Optional[float] = typer.Option(None, "--growth-factor",
                                                      help="Void radius factor per stage (default 1.02)."),
        void_normal_stiffness: Optional[float] = typer.Option(None, "--void-kn", help="kn,V in N/m (default 1e2)."),
        friction: Optional[float] = typer.Option(None, "--friction", help="Contact friction (default 0)."),
        jam_overlap: Optional[float] = typer.Option(None, "--jam-overlap",
                                                    help="Stop: void overlap per void at jamming (1e-3)."),
        seed: Optional[int] = typer.Option(None, "--seed", help="Random seed (recorded in the output)."),
        progress: Optional[bool] = typer.Option(None, "--progress/--no-progress", help="Progress bar."),
    ):
        """Generate a heterogeneous pack by void expansion and write it (structure spheres only)."""
        from .. import io
        from .._util import output_path
        from ..generate.vem import vem

        io.format_for(str(output))
        output_path(output)  # checked before the run
        kw = {k: v for k, v in (("growth_factor", growth_factor), ("void_normal_stiffness", void_normal_stiffness),
                                ("friction", friction), ("jam_overlap", jam_overlap)) if v is not None}
        pk = vem(n, volume_fraction, void_ratio, seed=seed, radius=radius, progress=progress, **kw)
        io.write(str(output), pk)
        m = pk.meta["vem"]
        typer.echo(
            f"wrote {output}: {pk.n} spheres at Φ = {pk.volume_fraction:.6g}, N_V = {m['n_void']}, "
            f"{m['stages']} stages, final void diameter {m['final_void_diameter']:.4g}, coordination at jamming "
            f"{m['coordination_at_jamming']:.3f}, min gap {pk.meta['min_gap']:.2e}, {m['wall_time']:.1f} s"
        )
