"""``polypack deposit``: 2D deposits of disks by potential minimisation (seed 001 §2.4)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
import typer

from ..errors import InvalidInputError


def register(app: typer.Typer) -> None:
    @app.command("deposit")
    def deposit_command(
        sizes: Optional[Path] = typer.Argument(
            None, help="Size-set CSV (radius[,species] columns, e.g. from `polypack psd`); else use --n or --span."),
        n: Optional[int] = typer.Option(None, "--n", help="Number of equal disks (with --radius)."),
        radius: float = typer.Option(0.5, "--radius", help="Radius of the equal disks."),
        span: Optional[float] = typer.Option(
            None, "--span", help="CB grading curve of size span s in [0, 1) (d_max = 1; with --a, --b, --min-total)."),
        a: float = typer.Option(1.0, "--a", help="CB shape parameter a."),
        b: float = typer.Option(1.0, "--b", help="CB shape parameter b."),
        min_total: int = typer.Option(2000, "--min-total", help="CB size set: minimum number of disks N_p^min."),
        width: Optional[float] = typer.Option(None, "--width", help="Box width (default: a roughly square deposit)."),
        boundary: str = typer.Option("periodic", "--boundary", help="'periodic' or 'walls' along x."),
        order: str = typer.Option("random", "--order", help="'random' or 'given' deposition order."),
        floor_rule: str = typer.Option(
            "centred", "--floor-rule", help="Bare floor: 'centred' (midpoint of the leftmost bare stretch, as "
            "LMGC90) or 'left' (its leftmost point: a touching first row)."),
        seed: Optional[int] = typer.Option(None, "--seed", help="Random seed (recorded in the output)."),
        output: Optional[Path] = typer.Option(None, "--output", "-o", help="Output file (.gsd, .xyz, .csv, .vtp)."),
        progress: Optional[bool] = typer.Option(None, "--progress/--no-progress", help="Progress bar."),
    ):
        """Deposit disks one by one at the lowest pocket of the free surface; print the bulk statistics."""
        import polypack as pp

        if sizes is not None:
            if not sizes.exists():
                raise InvalidInputError(f"size-set file {sizes} does not exist")
            from .pack_commands import _read_radius_csv

            radii, species = _read_radius_csv(sizes)
            src = pp.psd.SizeSet(radii, species, dim=2)
        elif span is not None:
            if not (0.0 <= span < 1.0):
                raise InvalidInputError(f"--span {span}: must be in [0, 1)")
            if span == 0.0:
                src = np.full(max(min_total, 1), 0.5)
            else:
                model = pp.psd.CumulativeBeta(a=a, b=b, span=span, d_max=1.0, dim=2)
                src = pp.psd.discretize(model, n_classes=10, min_per_class=10, min_total=min_total,
                                        max_total=10**6, seed=seed)
        elif n is not None:
            if n < 1:
                raise InvalidInputError(f"--n {n}: need at least 1 disk")
            if not radius > 0:
                raise InvalidInputError(f"--radius {radius}: must be > 0")
            src = np.full(n, float(radius))
        else:
            raise InvalidInputError("give a size-set file, --span (CB model) or --n (equal disks)")
        pk = pp.deposit(src, width=width, boundary=boundary, order=order, seed=seed, progress=progress,
                        floor_rule=floor_rule)
        msg = (f"deposited N={pk.n} box={pk.box[0]:.6g}x{pk.box[1]:.6g} boundary={boundary} floor_rule={floor_rule} "
               f"min_gap={pk.min_gap():.3e}")
        try:
            st = pp.analysis.DepositStatistics().compute(pk)
            sh = st.contact_shares
            msg += (f" packing_fraction={st.packing_fraction:.5f} (window of {st.n_window} disks)"
                    f" coordination={st.coordination:.4f} shares(3,4,5)="
                    f"{sh.get(3, 0.0):.3f},{sh.get(4, 0.0):.3f},{sh.get(5, 0.0):.3f}")
        except InvalidInputError as exc:
            msg += f" (no bulk window: {exc})"
        typer.echo(msg)
        if output is not None:
            pp.io.write(output, pk)
            typer.echo(f"wrote {output}")
