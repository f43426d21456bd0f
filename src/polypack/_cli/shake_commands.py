"""``polypack shake IN OUT`` (Monte-Carlo shaking of a pack file) and ``polypack scrm``
(growth interleaved with shaking), §3.2 of 000_2cedc098acbd866b.txt."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from ._generated import options_from


def _floats(values):
    if not values:
        return None
    return values[0] if len(values) == 1 else list(values)


def register(app: typer.Typer) -> None:
    """Add the ``shake`` command to ``app``."""
    from ..generate.shake import scrm as _scrm
    from ..generate.shake import shake as _shake
    from ._defaults import api_default

    @app.command()
    def shake(
        source: str = typer.Argument(..., metavar="IN", help="Input packing file (gsd, xyz, lammps data, csv)."),
        target: str = typer.Argument(..., metavar="OUT", help="Output file; the format follows its extension."),
        global_shakes: int = typer.Option(api_default(_shake, "global_shakes"), "--global-shakes", "-M",
                                          help="Passes over all spheres (M)."),
        shake_radius: Optional[List[float]] = typer.Option(
            None, "--shake-radius", help="R_sh in units of the sphere radius; repeat once per species."
        ),
        max_trials: Optional[List[int]] = typer.Option(
            None, "--max-trials", help="N_sh trials per visit; repeat once per species."
        ),
        method: str = typer.Option(api_default(_shake, "method"), "--method", help="paper, collision or metropolis."),
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
        from .._util import check_new_output, file_kind, output_path
        from ..analysis import ContactValueMonitor
        from ..generate.shake import shake as run_shake

        io.format_for(target)
        output_path(target)  # checked before shaking
        check_new_output(target, file_kind(target), inputs=(source,), option="OUT")
        pk = io.read(source)
        out = run_shake(
            pk, global_shakes=global_shakes, shake_radius=_floats(shake_radius), max_trials=_floats(max_trials),
            method=method, seed=seed, progress=progress, order=order, adaptive=adaptive,
            monitor=ContactValueMonitor(), monitor_every=monitor_every,
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

    @app.command("scrm")
    @options_from("protocol", "scrm", short={"volume_fraction": "-c", "global_shakes": "-M"})
    def scrm_command(
        sizes: Optional[Path] = typer.Argument(
            None, help="Size-set CSV (radius[,species]) as written by `polypack psd`; or use --n/--radius."
        ),
        output: Path = typer.Option(..., "--output", "-o", help="Output file (.gsd, .xyz, .data, .csv, .vtp)."),
        n: Optional[int] = typer.Option(None, "--n", help="Number of spheres (without a size-set file)."),
        radius: float = typer.Option(1.0, "--radius", help="Radius (of the large spheres for a bimodal mix)."),
        size_ratio: Optional[float] = typer.Option(None, "--size-ratio", help="Bimodal λ = a2/a1 <= 1."),
        volume_ratio: Optional[float] = typer.Option(None, "--volume-ratio", help="Bimodal ξ = c2/c1."),
        seed: Optional[int] = typer.Option(None, "--seed", help="Random seed (recorded in the output)."),
        progress: Optional[bool] = typer.Option(None, "--progress/--no-progress", help="Progress bar."),
        options: dict = None,
    ):
        """SCRM: Lubachevsky–Stillinger growth interleaved with shaking, then M global shakes.

        The SCRM flags are the \\[protocol] keys of kind = "scrm" (docs/reference.md).
        """
        from types import SimpleNamespace

        import numpy as np

        from .. import io
        from ..analysis import ContactValueMonitor
        from ..errors import InvalidInputError
        from ..generate.shake import scrm
        from .._util import output_path
        from .pack_commands import _read_radius_csv, sizes_from_options

        io.format_for(output)
        output_path(output)  # checked before packing
        from .._util import check_new_output, file_kind

        check_new_output(output, file_kind(output), inputs=(sizes,), option="-o")
        if sizes is not None:
            if not sizes.exists():
                raise InvalidInputError(f"size-set file {sizes} does not exist")
            radii, species = _read_radius_csv(sizes)
        else:
            radii, species = sizes_from_options(n, radius, size_ratio, volume_ratio)
        if species is None:
            species = np.zeros(len(radii), np.int64)
        from ..generate._capabilities import scrm_kwargs

        pk = scrm(SimpleNamespace(radii=radii, species=species), seed=seed, progress=progress,
                  monitor=ContactValueMonitor(), **scrm_kwargs(options))  # the flags are SCRMOptions' fields
        io.write(output, pk)
        sh, rec = pk.meta["shake"], pk.meta["scrm"]
        typer.echo(
            f"wrote {output}: N={pk.n} volume_fraction={pk.volume_fraction:.6f}, {len(rec['schedule'])} growth "
            f"stages x {rec['stage_shakes']} shakes + {sh['global_shakes']} global shakes ({sh['method']}), "
            f"min gap {sh['min_gap']:.3e}, {rec['wall_time']:.2f} s"
        )
