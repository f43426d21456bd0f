"""``polypack pack``: Lubachevsky–Stillinger growth packing from the command line."""

from __future__ import annotations

import csv
import io as _io
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from ..errors import FormatError, InvalidInputError


def _read_radius_csv(path: Path):
    """Radii and species from a CSV with a ``radius`` (or ``diameter``) column and optional ``species``."""
    try:
        from ..psd.sizeset import SizeSet  # written by ``polypack psd``

        s = SizeSet.load(path)
        return np.asarray(s.radii, float), np.asarray(s.species, np.int64)
    except ImportError:
        pass
    try:
        text = path.read_text()
    except OSError as exc:
        raise FormatError(f"cannot read size set {path}: {exc.strerror}") from None
    rows = [r for r in csv.reader(_io.StringIO(text)) if r and not r[0].lstrip().startswith("#")]
    if len(rows) < 2:
        raise FormatError(f"{path}: no size rows")
    header = [h.strip().lower() for h in rows[0]]
    if "radius" not in header and "diameter" not in header:
        raise FormatError(f"{path}: header {rows[0]!r} has neither 'radius' nor 'diameter'")
    try:
        data = np.array([[float(x) for x in r] for r in rows[1:]], float)
    except ValueError as exc:
        raise FormatError(f"{path}: non-numeric entry ({exc})") from None
    radii = data[:, header.index("radius")] if "radius" in header else 0.5 * data[:, header.index("diameter")]
    species = data[:, header.index("species")].astype(np.int64) if "species" in header else None
    return radii, species


def _is_size_csv(path: Path) -> bool:
    if path.suffix.lower() != ".csv":
        return False
    with open(path) as fh:
        for line in fh:
            if line.strip() and not line.startswith("#"):
                cols = [c.strip().lower() for c in line.split(",")]
                return "x" not in cols
    return True


def sizes_from_options(n, radius, size_ratio, volume_ratio):
    """Radii and species for ``--n/--radius`` (monodisperse) or a bimodal mix (seed 000 λ, ξ)."""
    if n is None:
        raise InvalidInputError("give a size-set file or --n (with --radius, optionally --size-ratio/--volume-ratio)")
    if n < 2:
        raise InvalidInputError(f"--n {n}: need at least 2 spheres")
    if not radius > 0:
        raise InvalidInputError(f"--radius {radius}: must be > 0")
    if size_ratio is None and volume_ratio is None:
        return np.full(n, float(radius)), np.zeros(n, np.int64)
    if size_ratio is None or volume_ratio is None:
        raise InvalidInputError("a bimodal mix needs both --size-ratio (λ = a2/a1 <= 1) and --volume-ratio (ξ = c2/c1)")
    if not (0 < size_ratio <= 1):
        raise InvalidInputError(f"--size-ratio {size_ratio}: must be in (0, 1]")
    if not volume_ratio >= 0:
        raise InvalidInputError(f"--volume-ratio {volume_ratio}: must be >= 0")
    # N1 + N2 = N and N2 λ³ / N1 = ξ; the less numerous mode gets the integer part of its
    # share, as polypack.psd does (seed 000: N=2000, λ=0.313, ξ=0.333 -> N1 = 168)
    x1 = 1.0 / (1.0 + volume_ratio / size_ratio**3)
    if x1 <= 0.5:
        n1 = int(np.floor(n * x1 + 1e-9))
    else:
        n1 = n - int(np.floor(n * (1.0 - x1) + 1e-9))
    n1 = min(max(n1, 1), n)
    n2 = n - n1
    radii = np.r_[np.full(n1, float(radius)), np.full(n2, float(radius) * size_ratio)]
    species = np.r_[np.zeros(n1, np.int64), np.ones(n2, np.int64)]
    return radii, species


def register(app: typer.Typer) -> None:
    from ..generate.lubachevsky import pack as _pack
    from ._defaults import api_default

    @app.command("pack")
    def pack_command(
        sizes: Optional[Path] = typer.Argument(
            None,
            help="Size-set CSV (radius[,species] columns, as written by `polypack psd`) or a packing file "
            "(.gsd, .xyz, .data, packing .csv) to continue growing from.",
        ),
        n: Optional[int] = typer.Option(None, "--n", help="Number of spheres (without a size-set file)."),
        radius: float = typer.Option(1.0, "--radius", help="Radius (of the large spheres for a bimodal mix)."),
        size_ratio: Optional[float] = typer.Option(None, "--size-ratio", help="Bimodal λ = a2/a1 <= 1."),
        volume_ratio: Optional[float] = typer.Option(None, "--volume-ratio", help="Bimodal ξ = c2/c1."),
        volume_fraction: str = typer.Option(str(api_default(_pack, "volume_fraction")), "--volume-fraction", "-c",
                                            help="Target fraction or 'jammed'."),
        seed: Optional[int] = typer.Option(None, "--seed", help="Random seed (recorded in the output)."),
        growth_rate: Optional[float] = typer.Option(None, "--growth-rate", help="Dimensionless growth rate Γ."),
        fast_growth: float = typer.Option(
            api_default(_pack, "fast_growth"), "--fast-growth",
            help="Growth this many times faster below volume fraction 0.3 (the dilute start); 1 = one rate throughout.",
        ),
        max_seconds: Optional[float] = typer.Option(None, "--max-seconds", help="Wall-clock budget."),
        max_collisions: Optional[int] = typer.Option(None, "--max-collisions", help="Collision budget."),
        output: Optional[Path] = typer.Option(None, "--output", "-o", help="Output file (.gsd, .xyz, .data, .csv, .vtp)."),
        checkpoint: Optional[Path] = typer.Option(
            None, "--checkpoint",
            help="On Ctrl-C save the partial pack (status 'interrupted') here; never under --output.",
        ),
        progress: Optional[bool] = typer.Option(None, "--progress/--no-progress", help="Progress bar."),
        dim: Optional[int] = typer.Option(
            None, "--dim", help="3 (spheres) or 2 (disks in a periodic square); default: the input's, else 3."),
    ):
        """Pack spheres (or disks, --dim 2) by Lubachevsky–Stillinger growth to a volume fraction or to jamming."""
        from .. import io
        from .._util import output_path
        from ..errors import Interrupted
        from ..generate.lubachevsky import pack

        # every destination is checked before anything is computed
        from .._util import check_new_output, file_kind

        for path in (output, checkpoint):
            if path is not None:
                io.format_for(path)
                output_path(path)
                check_new_output(path, file_kind(path), inputs=(sizes,), option="-o")
        if output is not None and checkpoint is not None and output_path(output) == output_path(checkpoint):
            raise InvalidInputError(f"--checkpoint {checkpoint}: must differ from --output (a partial pack is never "
                                    "saved under the requested name)")
        vf = volume_fraction.strip().lower()
        if vf != "jammed":
            try:
                vf = float(vf)
            except ValueError:
                raise InvalidInputError(
                    f"--volume-fraction {volume_fraction!r}: allowed are a number in (0, 1) or 'jammed'"
                ) from None
        species = None
        if sizes is not None:
            if not sizes.exists():
                raise InvalidInputError(f"size-set file {sizes} does not exist")
            if _is_size_csv(sizes):
                src, species = _read_radius_csv(sizes)
            else:
                from .. import io

                src = io.read(sizes)
        else:
            src, species = sizes_from_options(n, radius, size_ratio, volume_ratio)
        kw = {"fast_growth": fast_growth}
        if species is not None:
            kw["species"] = species
        try:
            pk = pack(src, vf, seed=seed, growth_rate=growth_rate, max_seconds=max_seconds,
                      max_collisions=max_collisions, progress=progress, dim=dim, **kw)
        except Interrupted as exc:
            not_out = f"; nothing written to {output}" if output is not None else ""
            if checkpoint is not None and exc.partial is not None:
                io.write(checkpoint, exc.partial)
                typer.echo(
                    f"interrupted: partial pack (status 'interrupted', volume fraction "
                    f"{exc.partial.volume_fraction:.6f}) saved to {checkpoint}{not_out}",
                    err=True,
                )
            else:
                typer.echo(f"interrupted: nothing was saved{not_out}", err=True)
            raise SystemExit(130) from None
        m = pk.meta
        typer.echo(
            f"{m['status']}: N={pk.n} volume_fraction={pk.volume_fraction:.6f} reduced_pressure="
            f"{m['reduced_pressure']:.4g} jamming_estimate={m['jamming_estimate']:.5f} collisions={m['collisions']} "
            f"({m['collisions_per_second']:.3g}/s) wall_time={m['wall_time']:.2f}s min_gap={m['min_gap']:.3e}"
        )
        if output is not None:
            io.write(output, pk)
            typer.echo(f"wrote {output}")
