"""``polypack voxelize``: a pack's periodic phase-label image (.npy, .tif stack, .vti)."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command()
    def voxelize(
        pack: Path = typer.Argument(..., help="Packing file (.gsd, .xyz, .data, .vtp, .csv)."),
        out: Path = typer.Argument(..., help="Image file: .npy, .tif/.tiff (stack) or .vti (ParaView)."),
        resolution: int = typer.Option(64, "--resolution", "-n", help="Voxels along the longest box axis."),
        subsamples: int = typer.Option(0, "--subsamples", help="Sub-voxel samples per axis in boundary voxels "
                                                                "(0: none; .vti gains an inclusion_fraction field)."),
    ):
        """Voxelize a pack: label 0 matrix, 1 + species for spheres; prints exact and voxel phase fractions."""
        from .. import io

        pk = io.read(pack)
        im = io.voxelize(pk, resolution, subsamples=subsamples)
        io.write_image(out, im)
        shape = "x".join(str(s) for s in im.shape)
        typer.echo(f"{out}: {shape} voxels of {', '.join(f'{h:.4g}' for h in im.spacing)}")
        typer.echo(f"  {'phase':>8s} {'exact':>10s} {'voxel':>10s}")
        for k, (e, v) in enumerate(zip(im.exact_fractions, im.voxel_fractions)):
            typer.echo(f"  {'matrix' if k == 0 else f'S{k - 1}':>8s} {e:10.5f} {v:10.5f}")
        if im.fraction is not None:
            typer.echo(f"  inclusions, sub-voxel sampled: {im.subvoxel_inclusion_fraction:.5f}")
