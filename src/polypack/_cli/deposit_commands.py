"""``polypack deposit``: deposits of disks (2D) or spheres (3D) by potential minimisation (seed 001 §2.4)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
import typer

from ..errors import InvalidInputError
from ._generated import options_from


def register(app: typer.Typer) -> None:
    @app.command("deposit")
    @options_from("protocol", "deposit")
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
        seed: Optional[int] = typer.Option(None, "--seed", help="Random seed (recorded in the output)."),
        output: Optional[Path] = typer.Option(None, "--output", "-o", help="Output file (.gsd, .xyz, .csv, .vtp)."),
        progress: Optional[bool] = typer.Option(None, "--progress/--no-progress", help="Progress bar."),
        dim: int = typer.Option(2, "--dim", help="2 (disks) or 3 (spheres; --width is the side of the square footprint)."),
        plot: Optional[Path] = typer.Option(
            None, "--plot", help="Write a figure of the height profiles (packing fraction; 3D: small-sphere volume "
            "fraction with standard errors) to this file (.png, .pdf, .svg)."),
        options: dict = None,
    ):
        """Deposit disks or spheres one by one; print the bulk statistics.

        The deposition flags (--width, --boundary, --order, --tolerance, --floor-rule, --rule) are the
        [protocol] keys of kind = "deposit" (docs/reference.md).
        """
        import polypack as pp

        from .._util import output_path

        if output is not None:  # checked before the deposit is computed
            pp.io.format_for(output)
            output_path(output)
        given = [f for f, x in (("SIZES", sizes), ("--span", span), ("--n", n)) if x is not None]
        if len(given) > 1:
            raise InvalidInputError(f"{' and '.join(given)}: give one source of sizes (a size-set file, --span or --n)")
        if options.get("floor_rule") is not None and dim != 2:
            raise InvalidInputError(f"--floor-rule {options['floor_rule']}: only for 2D deposits (--dim 2)")
        if options.get("rule") is not None and dim != 3:
            raise InvalidInputError(f"--rule {options['rule']}: only for 3D deposits (--dim 3)")
        if sizes is not None:
            if not sizes.exists():
                raise InvalidInputError(f"size-set file {sizes} does not exist")
            if sizes.suffix.lower() in (".gsd", ".xyz", ".extxyz", ".data", ".lmp", ".vtp", ".vtm"):
                raise InvalidInputError(f"{sizes}: a pack file; deposit takes a size-set CSV (radius[,species] "
                                        "columns, e.g. from `polypack psd`), or --n / --span")
            from ..psd.sizeset import SizeSet

            loaded = SizeSet.load(sizes)
            if SizeSet._report_path(sizes).exists() and loaded.dim != dim:
                raise InvalidInputError(
                    f"{sizes}: a size set for dim={loaded.dim} (its report {SizeSet._report_path(sizes).name}: class "
                    f"counts weighted by {'sphere volume' if loaded.dim == 3 else 'disk area'}); this deposit is "
                    f"--dim {dim}: use --dim {loaded.dim}, --span (the CB model), or a set made with "
                    f"`polypack psd --dim {dim}`")
            radii, species = np.asarray(loaded.radii, float), np.asarray(loaded.species, np.int64)
            src = pp.psd.SizeSet(radii, species, dim=dim)
        elif span is not None:
            if not (0.0 <= span < 1.0):
                raise InvalidInputError(f"--span {span}: must be in [0, 1)")
            if span == 0.0:
                src = pp.psd.SizeSet(np.full(max(min_total, 1), 0.5), dim=dim)
            else:
                model = pp.psd.CumulativeBeta(a=a, b=b, span=span, d_max=1.0, dim=dim)
                src = pp.psd.discretize(model, n_classes=10, min_per_class=10, min_total=min_total,
                                        max_total=10**6, seed=seed)
        elif n is not None:
            if n < 1:
                raise InvalidInputError(f"--n {n}: need at least 1 disk")
            if not radius > 0:
                raise InvalidInputError(f"--radius {radius}: must be > 0")
            src = pp.psd.SizeSet(np.full(n, float(radius)), dim=dim)
        else:
            raise InvalidInputError("give a size-set file, --span (CB model) or --n (equal disks)")
        if dim not in (2, 3):
            raise InvalidInputError(f"--dim {dim}: allowed are 2 and 3")
        if plot is not None:
            from .._util import check_plot_path

            check_plot_path(plot)
        pk = pp.deposit(src, seed=seed, progress=progress, **options)  # the flags are DepositOptions' fields
        rule_word = f"floor_rule={pk.meta.get('floor_rule')}" if dim == 2 else f"rule={pk.meta.get('rule')}"
        boundary = options["boundary"]
        box = "x".join(f"{v:.6g}" for v in pk.box)
        msg = f"deposited N={pk.n} box={box} boundary={boundary} {rule_word} min_gap={pk.min_gap():.3e}"
        st = None
        try:
            st = pp.analysis.DepositStatistics().compute(pk)
            sh = st.contact_shares
            msg += (f" packing_fraction={st.packing_fraction:.5f} (window of {st.n_window} {'disks' if dim == 2 else 'spheres'})"
                    f" coordination={st.coordination:.4f} shares(3,4,5)="
                    f"{sh.get(3, 0.0):.3f},{sh.get(4, 0.0):.3f},{sh.get(5, 0.0):.3f}")
            sp = st.small_profile if dim == 3 else None
            if sp is not None:
                msg += (f" small_fraction_slope={sp['slope']:.4g}+-{sp['slope_err']:.2g} per length unit"
                        f" (small: r < {sp['split']:.4g})")
        except InvalidInputError as exc:
            msg += f" (no bulk window: {exc})"
        typer.echo(msg)
        if plot is not None:
            _plot_profiles(pk, st, plot)
            typer.echo(f"wrote {plot}")
        if output is not None:
            pp.io.write(output, pk)
            typer.echo(f"wrote {output}")


def _plot_profiles(pk, st, path):
    """Height profiles of a deposit: strip packing fraction, and in 3D the small-sphere volume fraction."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..analysis.deposits import small_fraction_profile
    from .._util import atomic_path

    three = pk.dim == 3 and float(pk.radii.min()) < float(pk.radii.max())
    fig, axes = plt.subplots(1, 2 if three else 1, figsize=(9 if three else 4.5, 4.5), squeeze=False)
    ax = axes[0, 0]
    if st is None:
        import polypack as pp

        st = pp.analysis.DepositStatistics(margin=0.0).compute(pk)
    ax.plot(st.profile_fraction, st.profile_height, "-o", ms=3)
    ax.set_xlabel("packing fraction of the horizontal strip (–)")
    ax.set_ylabel("height above the floor (length unit of the radii)")
    ax.set_title(f"N = {pk.n}, {pk.meta.get('rule', pk.meta.get('floor_rule', ''))}")
    if three:
        ax = axes[0, 1]
        top = float(np.max(pk.positions[:, -1]))
        pr = small_fraction_profile(pk, window=(0.0, top), n_layers=12)
        ax.errorbar(pr["fraction"], pr["height"], xerr=pr["fraction_err"], fmt="-o", ms=3, capsize=2)
        ax.axvline(pr["mean"], color="0.6", ls="--", label=f"whole deposit {pr['mean']:.3f}")
        ax.set_xlabel(f"small-sphere volume fraction (r < {pr['split']:.3g}) (–)")
        ax.set_ylabel("height above the floor (length unit of the radii)")
        ax.set_title(f"slope {pr['slope']:.3g} ± {pr['slope_err']:.2g} per length unit")
        ax.legend(loc="best")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=path.suffix.lstrip(".").lower())
    plt.close(fig)
