"""``polypack brownian OUT``: a colloidal gel by Brownian dynamics with DLVO forces
(§2.2 of 003_873b69fc71c74cf6.txt), and ``polypack dlvo``: the pair potential."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer


def register(app: typer.Typer) -> None:
    """Add the ``brownian`` and ``dlvo`` commands to ``app``."""

    @app.command("brownian")
    def brownian_command(
        output: Path = typer.Argument(..., metavar="OUT", help="Output file (.gsd, .xyz, .data, .csv, .vtp)."),
        n: int = typer.Option(8000, "--n", help="Number of spheres."),
        volume_fraction: float = typer.Option(0.4, "--volume-fraction", "-c", help="Volume fraction Φ."),
        surface_potential: float = typer.Option(15.0, "--surface-potential", "--psi",
                                                help="Surface potential Ψ0 in mV."),
        radius: Optional[float] = typer.Option(None, "--radius", help="Sphere radius in m (default 0.25e-6)."),
        temperature: Optional[float] = typer.Option(None, "--temperature", help="Temperature in K."),
        viscosity: Optional[float] = typer.Option(None, "--viscosity", help="Solvent viscosity in Pa s."),
        hamaker: Optional[float] = typer.Option(None, "--hamaker", help="Hamaker constant in J."),
        ionic_strength: Optional[float] = typer.Option(None, "--ionic-strength",
                                                       help="1:1 salt in mol/m³ (= mM)."),
        debye_length: Optional[float] = typer.Option(None, "--debye-length", help="Debye length in m."),
        model: str = typer.Option("auto", "--model", help="Double layer: auto, hhf or lsa."),
        bonds: str = typer.Option("flexible", "--bonds",
                                  help="Bond model: rigid (clusters move as rigid bodies), flexible (free rolling) "
                                       "or tangential (elastic-plastic sliding and rolling resistance)."),
        sliding_stiffness: Optional[float] = typer.Option(None, "--sliding-stiffness",
                                                          help="Tangential bonds: sliding stiffness in N/m."),
        rolling_stiffness: Optional[float] = typer.Option(None, "--rolling-stiffness",
                                                          help="Tangential bonds: rolling stiffness in J."),
        rolling_moment: Optional[float] = typer.Option(None, "--rolling-moment",
                                                       help="Tangential bonds: critical rolling moment in N m."),
        hydrodynamics: str = typer.Option("free", "--hydrodynamics",
                                          help="Pair mobility: free (free draining) or lubrication (Honig et al. "
                                               "1971 correction of the relative normal motion of close pairs)."),
        time_step: Optional[float] = typer.Option(None, "--time-step", help="Time step in s."),
        max_time: Optional[float] = typer.Option(None, "--max-time", help="Simulated-time budget in s."),
        max_steps: Optional[int] = typer.Option(None, "--max-steps", help="Step budget."),
        seed: Optional[int] = typer.Option(None, "--seed", help="Random seed (recorded in the output)."),
        progress: Optional[bool] = typer.Option(None, "--progress/--no-progress", help="Progress bar."),
    ):
        """Coagulate a colloidal gel by Brownian dynamics with DLVO forces and write it."""
        import json
        import warnings

        from .. import io
        from .._util import atomic_path, output_path
        from ..generate.brownian import brownian

        io.format_for(str(output))
        output_path(output)  # checked before the run
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # reported in the summary line instead
            pk = brownian(
                n, volume_fraction, surface_potential * 1e-3, seed=seed, radius=radius, temperature=temperature,
                viscosity=viscosity, hamaker=hamaker, ionic_strength=ionic_strength, debye_length=debye_length,
                model=model, time_step=time_step, max_time=max_time, max_steps=max_steps, progress=progress,
                bonds=bonds, sliding_stiffness=sliding_stiffness, rolling_stiffness=rolling_stiffness,
                rolling_moment=rolling_moment, hydrodynamics=hydrodynamics,
            )
        io.write(str(output), pk)
        bonds_path = Path(str(output) + ".bonds.json")
        with atomic_path(bonds_path) as tmp:
            Path(tmp).write_text(json.dumps(pk.meta["bonds"]))
        b = pk.meta["brownian"]
        typer.echo(
            f"wrote {output}: {pk.n} spheres, Ψ0 = {surface_potential:g} mV, {b['bonds']} bonds, "
            f"{b['steps']} steps, "
            f"t = {b['simulated_time'] * 1e3:.3g} ms ({b['simulated_time'] / b['brownian_time']:.3g} a²/D0), "
            f"coordination {b['coordination']:.3f}, {b['clusters']} clusters (largest {b['largest_cluster']}), "
            f"percolating {''.join('xyz'[k] for k in range(3) if b['percolating'][k]) or 'no'}, "
            f"{'stable' if b['converged'] else 'NOT stable (budget used up)'}, {b['wall_time']:.1f} s; "
            f"bonds in {bonds_path}"
        )

    @app.command("dlvo")
    def dlvo_command(
        surface_potential: Optional[List[float]] = typer.Option(
            None, "--surface-potential", "--psi", help="Ψ0 in mV; repeat (default 0 12 13 14 15)."),
        plot: Optional[Path] = typer.Option(None, "--plot", help="Write a plot of V/kBT against h (png, pdf)."),
        hamaker: Optional[float] = typer.Option(None, "--hamaker", help="Hamaker constant in J."),
        ionic_strength: Optional[float] = typer.Option(None, "--ionic-strength", help="1:1 salt in mol/m³."),
        debye_length: Optional[float] = typer.Option(None, "--debye-length", help="Debye length in m."),
        model: str = typer.Option("auto", "--model", help="Double layer: auto, hhf or lsa."),
    ):
        """Barrier and secondary minimum of the DLVO potential (kBT) for each Ψ0."""
        from ..generate.dlvo import dlvo_extrema, dlvo_parameters, plot_dlvo

        psis = [v * 1e-3 for v in (surface_potential or [0.0, 12.0, 13.0, 14.0, 15.0])]
        kw = dict(hamaker=hamaker, ionic_strength=ionic_strength, debye_length=debye_length, model=model)
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
                ax.figure.savefig(tmp, format=plot.suffix.lstrip(".") or "png", dpi=120)
            typer.echo(f"wrote {plot}")
