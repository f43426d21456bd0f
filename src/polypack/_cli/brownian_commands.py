"""``polypack brownian OUT``: a colloidal gel by Brownian dynamics with DLVO forces
(§2.2 of 003_873b69fc71c74cf6.txt), and ``polypack dlvo``: the pair potential."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from ._generated import options_from

#: The ``brownian`` options that set the DLVO pair potential (``polypack dlvo`` takes these flags).
DLVO_FIELDS = ("radius", "temperature", "relative_permittivity", "hamaker", "ionic_strength", "debye_length",
               "minimum_separation", "model")


def register(app: typer.Typer) -> None:
    """Add the ``brownian`` and ``dlvo`` commands to ``app``."""

    @app.command("brownian")
    @options_from("protocol", "brownian")
    def brownian_command(
        output: Path = typer.Argument(..., metavar="OUT", help="Output file (.gsd, .xyz, .data, .csv, .vtp)."),
        n: int = typer.Option(8000, "--n", help="Number of spheres."),
        seed: Optional[int] = typer.Option(None, "--seed", help="Random seed (recorded in the output)."),
        progress: Optional[bool] = typer.Option(None, "--progress/--no-progress", help="Progress bar."),
        options: dict = None,
    ):
        """Coagulate a colloidal gel by Brownian dynamics with DLVO forces and write it."""
        import json
        import warnings

        from .. import io
        from .._util import atomic_paths, output_path
        from ..generate.brownian import brownian

        fmt = io.format_for(str(output))
        bonds_path = Path(str(output) + ".bonds.json")
        output_path(output)  # both checked before the run
        output_path(bonds_path)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # reported in the summary line instead
            pk = brownian(n, seed=seed, progress=progress, **options)  # the flags are BrownianOptions' fields
        with atomic_paths(output, bonds_path) as (tmp_pack, tmp_bonds):  # the pair together or not at all
            io.write(tmp_pack, pk, fmt)
            Path(tmp_bonds).write_text(json.dumps(pk.meta["bonds"]))
        b = pk.meta["brownian"]
        typer.echo(
            f"wrote {output}: {pk.n} spheres, Ψ0 = {options['surface_potential']:g} V, {b['bonds']} bonds, "
            f"{b['steps']} steps, "
            f"t = {b['simulated_time'] * 1e3:.3g} ms ({b['simulated_time'] / b['brownian_time']:.3g} a²/D0), "
            f"coordination {b['coordination']:.3f}, {b['clusters']} clusters (largest {b['largest_cluster']}), "
            f"percolating {''.join('xyz'[k] for k in range(3) if b['percolating'][k]) or 'no'}, "
            f"{'stable' if b['converged'] else 'NOT stable (budget used up)'}, {b['wall_time']:.1f} s; "
            f"bonds in {bonds_path}"
        )

    @app.command("dlvo")
    @options_from("protocol", "brownian", fields=DLVO_FIELDS)
    def dlvo_command(
        surface_potential: Optional[List[float]] = typer.Option(
            None, "--surface-potential",
            help="Ψ0 in V (the unit of the API and the study file); repeat (default 0 0.012 0.013 0.014 0.015)."),
        plot: Optional[Path] = typer.Option(None, "--plot", help="Write a plot of V/kBT against h (png, pdf)."),
        options: dict = None,
    ):
        """Barrier and secondary minimum of the DLVO potential (kBT) for each Ψ0.

        The flags are the DLVO keys of \\[protocol] kind = "brownian" (same names, units and defaults).
        """
        from .._util import check_plot_path
        from ..generate.dlvo import dlvo_extrema, dlvo_parameters, plot_dlvo

        plot_fmt = check_plot_path(plot) if plot is not None else None
        psis = list(surface_potential or [0.0, 0.012, 0.013, 0.014, 0.015])
        kw = {k: options[k] for k in DLVO_FIELDS if k in options}  # the [protocol] keys of brownian, same units
        p = dlvo_parameters(psis[0], **kw)
        typer.echo(f"a = {p.radius:g} m, T = {p.temperature:g} K, A = {p.hamaker:g} J, "
                   f"1/κ = {p.debye_length * 1e9:.3f} nm (κa = {p.radius / p.debye_length:.1f}), model {p.model}")
        typer.echo("Ψ0/mV  secondary  h_max/nm  V_max/kBT  h_sec/nm  V_sec/kBT  barrier/kBT  primary/kBT")
        for psi in psis:
            e = dlvo_extrema(psi, **kw)
            if e.has_secondary_minimum:
                typer.echo(f"{psi * 1e3:5.1f}  yes        {e.barrier_separation * 1e9:8.3f}  {e.maximum_energy:9.3f}  "
                           f"{e.secondary_separation * 1e9:8.3f}  {e.secondary_energy:9.3f}  {e.barrier:11.3f}  "
                           f"{e.primary_energy:11.1f}")
            else:
                typer.echo(f"{psi * 1e3:5.1f}  no         {'-':>8}  {'-':>9}  {'-':>8}  {'-':>9}  {'-':>11}  "
                           f"{e.primary_energy:11.1f}")
        if plot is not None:
            import matplotlib

            matplotlib.use("Agg")
            from .._util import atomic_path

            ax = plot_dlvo(psis, **kw)
            with atomic_path(plot) as tmp:
                ax.figure.savefig(tmp, format=plot_fmt, dpi=120)
            typer.echo(f"wrote {plot}")
