"""``polypack psd``: a representative set of particle sizes from a size-distribution model.

Implements the generation procedure of 001_ad5bae0acea940c4.txt (§1.2) and the bimodal
description of 000_2cedc098acbd866b.txt; writes the sizes (CSV), a JSON report and plots.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import FormatError, InvalidInputError


def _load_config(path: Path) -> dict:
    import tomllib

    try:
        data = tomllib.loads(Path(path).read_text())
    except OSError as exc:
        raise FormatError(f"cannot read config {path}: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise FormatError(f"cannot read config {path}: not a UTF-8 text file") from None
    except tomllib.TOMLDecodeError as exc:
        raise FormatError(f"{path}: invalid TOML ({exc})") from None
    if "psd" not in data or not isinstance(data["psd"], dict):
        raise InvalidInputError(f"{path}: no [psd] section")
    return dict(data["psd"])


def run(params: dict, output: Path, report: Optional[Path] = None, plots: Optional[Path] = None, echo=print):
    """Build the size set described by ``params`` and write it; returns the SizeSet."""
    from ..psd.config import GENERATION_KEYS, MODELS, sizeset_from_dict

    allowed = set(GENERATION_KEYS) | {"model"} | {k for v in MODELS.values() for k in v}
    for k in params:
        if k not in allowed:
            raise InvalidInputError(f"psd.{k}: unknown key; allowed: model, {', '.join(sorted(allowed - {'model'}))}")
    from .._util import check_output_folder, output_path

    output_path(output)  # destinations checked before the sizes are built
    if report is not None:
        output_path(report)
    if plots is not None:
        check_output_folder(plots)
    model, s = sizeset_from_dict(params)
    csv_path, json_path = s.save(output, report)
    desc = s.report["descriptors"]
    echo(f"wrote {s.n} sizes ({len(desc['species_counts'])} species) to {csv_path}; report {json_path}")
    line = f"  d10={desc['d10']:.4g} d50={desc['d50']:.4g} d60={desc['d60']:.4g} Cu={desc['Cu']:.4g} Cc={desc['Cc']:.4g}"
    if "Cr" in desc:
        line += f" Cr={desc['Cr']:.3g}"
    echo(line + f" polydispersity={desc['polydispersity']:.4g}")
    if plots is not None:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        from .._util import atomic_path, make_folder

        plots = make_folder(plots)
        for name, ax in (("grading", s.plot_grading(model)), ("histogram", s.plot_histogram())):
            with atomic_path(plots / f"{name}.png") as tmp:
                ax.figure.savefig(tmp, dpi=120, bbox_inches="tight", format="png")
            plt.close(ax.figure)
        echo(f"  plots in {plots}")
    return s


def register(app: typer.Typer) -> None:
    @app.command("psd")
    def psd_command(
        model: Optional[str] = typer.Option(
            None, "--model", "-m",
            help="cumulative_beta (cb), uniform_volume, uniform_size, lognormal, normal, monodisperse, "
                 "bimodal, mixture, sieve."),
        config: Optional[Path] = typer.Option(None, "--config", help="TOML file with a [psd] section (options override it)."),
        a: Optional[float] = typer.Option(None, "--a", help="CB shape a > 0 (Eq. (12) of seed 001)."),
        b: Optional[float] = typer.Option(None, "--b", help="CB shape b > 0."),
        span: Optional[float] = typer.Option(None, "--span", help="Span s = (dmax-dmin)/(dmax+dmin) in (0, 1)."),
        d_min: Optional[float] = typer.Option(None, "--d-min", help="Smallest diameter."),
        d_max: Optional[float] = typer.Option(None, "--d-max", help="Largest diameter."),
        median: Optional[float] = typer.Option(None, "--median", help="Log-normal median diameter."),
        sigma: Optional[float] = typer.Option(None, "--sigma", help="Log-normal standard deviation of ln d."),
        mean: Optional[float] = typer.Option(None, "--mean", help="Normal mean diameter."),
        std: Optional[float] = typer.Option(None, "--std", help="Normal standard deviation."),
        basis: Optional[str] = typer.Option(None, "--basis", help="Law given by 'number' or 'volume'."),
        d: Optional[float] = typer.Option(None, "--d", help="Monodisperse diameter."),
        size_ratio: Optional[float] = typer.Option(None, "--size-ratio", help="Bimodal λ = a2/a1 <= 1 (seed 000)."),
        volume_ratio: Optional[float] = typer.Option(None, "--volume-ratio", help="Bimodal ξ = c2/c1."),
        d_large: Optional[float] = typer.Option(None, "--d-large", help="Bimodal large diameter."),
        spread: Optional[str] = typer.Option(None, "--spread", help="Log-sd per mode (one value or a list)."),
        sizes: Optional[str] = typer.Option(None, "--sizes", help="Mixture mode diameters, e.g. 1,0.3."),
        volume_fractions: Optional[str] = typer.Option(None, "--volume-fractions", help="Mixture volume fractions (sum 1)."),
        sieve: Optional[Path] = typer.Option(None, "--sieve", help="Sieve-table CSV: size, % passing."),
        dim: Optional[int] = typer.Option(None, "--dim", help="3 (spheres, default) or 2 (disks)."),
        n: Optional[int] = typer.Option(None, "--n", help="Draw n particles from the number law (sampling='sample')."),
        sampling: Optional[str] = typer.Option(None, "--sampling", help="'sample' or 'discretize' (default: sample iff --n)."),
        n_classes: Optional[int] = typer.Option(None, "--n-classes", help="Number of size classes N_c."),
        spacing: Optional[str] = typer.Option(None, "--spacing", help="geometric (Eq. (11)), regular, isochoric, modes."),
        min_per_class: Optional[int] = typer.Option(None, "--min-per-class", help="N_p/c^min (Eq. (8))."),
        min_total: Optional[int] = typer.Option(None, "--min-total", help="N_p^min (Eq. (9))."),
        max_total: Optional[int] = typer.Option(None, "--max-total", help="Accessibility limit N_p^max."),
        count_basis: Optional[str] = typer.Option(None, "--count-basis", help="'median' (Eq. (7)) or 'mean'."),
        method: Optional[str] = typer.Option(None, "--method", help="'random' or 'quantiles' (deterministic)."),
        seed: Optional[int] = typer.Option(None, "--seed", help="Random seed (recorded in the report)."),
        output: Path = typer.Option(Path("sizes.csv"), "--output", "-o", help="Size-set CSV (radius,diameter,species)."),
        report: Optional[Path] = typer.Option(None, "--report", help="JSON report (default: output with .json)."),
        plots: Optional[Path] = typer.Option(None, "--plots", help="Folder for grading and histogram plots."),
    ):
        """Generate a representative size set (seed 001 §1.2) or a bimodal/mixture set (seed 000)."""
        params = _load_config(config) if config is not None else {}
        given = dict(model=model, a=a, b=b, span=span, d_min=d_min, d_max=d_max, median=median, sigma=sigma,
                     mean=mean, std=std, basis=basis, d=d, size_ratio=size_ratio, volume_ratio=volume_ratio,
                     d_large=d_large, spread=spread, sizes=sizes, volume_fractions=volume_fractions,
                     sieve=str(sieve) if sieve is not None else None, dim=dim, n=n, sampling=sampling,
                     n_classes=n_classes, spacing=spacing, min_per_class=min_per_class, min_total=min_total,
                     max_total=max_total, count_basis=count_basis, method=method, seed=seed)
        params.update({k: v for k, v in given.items() if v is not None})
        run(params, output, report, plots, echo=typer.echo)
