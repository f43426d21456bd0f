"""``polypack shake IN OUT``: Monte-Carlo shaking of a pack file (§3.2 of 000_2cedc098acbd866b.txt)."""

from __future__ import annotations

from typing import List, Optional

import typer


def _floats(values):
    if not values:
        return None
    return values[0] if len(values) == 1 else list(values)


def register(app: typer.Typer) -> None:
    """Add the ``shake`` command to ``app``."""

    @app.command()
    def shake(
        source: str = typer.Argument(..., metavar="IN", help="Input packing file (gsd, xyz, lammps data, csv)."),
        target: str = typer.Argument(..., metavar="OUT", help="Output file; the format follows its extension."),
        global_shakes: int = typer.Option(60, "--global-shakes", "-M", help="Passes over all spheres (M)."),
        shake_radius: Optional[List[float]] = typer.Option(
            None, "--shake-radius", help="R_sh in units of the sphere radius; repeat once per species."
        ),
        max_trials: Optional[List[int]] = typer.Option(
            None, "--max-trials", help="N_sh trials per visit; repeat once per species."
        ),
        method: str = typer.Option("paper", "--method", help="paper, collision or metropolis."),
        order: Optional[str] = typer.Option(None, "--order", help="sequential or random sphere order."),
        adaptive: bool = typer.Option(False, "--adaptive", help="Adapt R_sh (see polypack.shake)."),
        monitor_every: Optional[int] = typer.Option(
            None, "--monitor-every", help="Record the contact values g(2a+) every k global shakes."
        ),
        seed: Optional[int] = typer.Option(None, "--seed", help="Random seed (recorded in the output)."),
        progress: Optional[bool] = typer.Option(None, "--progress/--no-progress", help="Progress bar."),
    ):
        """Shake a pack: the seed's Monte-Carlo shaking (or collision-limited / Metropolis moves)."""
        from .. import io
        from ..generate.shake import shake as run_shake

        pk = io.read(source)
        out = run_shake(
            pk, global_shakes=global_shakes, shake_radius=_floats(shake_radius), max_trials=_floats(max_trials),
            method=method, seed=seed, progress=progress, order=order, adaptive=adaptive,
            monitor_every=monitor_every,
        )
        io.write(target, out)
        sh = out.meta["shake"]
        acc = sh["acceptance_rate"][-1] if sh["acceptance_rate"] else []
        acc_txt = ", ".join("nan" if a is None else f"{a:.3f}" for a in acc)
        typer.echo(
            f"wrote {target}: {out.n} spheres, {sh['global_shakes']} global shakes ({sh['method']}), "
            f"acceptance [{acc_txt}], min gap {sh['min_gap']:.3e}, {sh['wall_time']:.2f} s"
        )
        mon = sh.get("monitor")
        if mon:
            for key, vals in mon["contact_value"].items():
                typer.echo(f"  g_{key}(contact): {vals[0]:.3f} -> {vals[-1]:.3f}")
