"""``polypack export-network PACK OUT``: a pack's bonded network to GSD, VTK (.vtm) or LAMMPS BPM (.data)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer


def register(app: typer.Typer) -> None:
    @app.command("export-network")
    def export_network(
        source: Path = typer.Argument(..., metavar="PACK", help="Pack or network file (gsd, xyz, data, vtp, csv, vtm)."),
        target: Path = typer.Argument(..., metavar="OUT", help="Network file: .gsd (OVITO, HOOMD), .vtm (ParaView: "
                                      "writes OUT_particles.vtp and OUT_bonds.vtp beside it) or .data (LAMMPS BPM)."),
        epsilon: float = typer.Option(0.01, "--epsilon", help="Bond every pair closer than (1 + epsilon)(r_i + r_j)."),
        kn: float = typer.Option(100.0, "--kn", help="Normal stiffness per contact, N/m (seed 003: 100)."),
        ks: float = typer.Option(10.0, "--ks", help="Shear stiffness per contact, N/m (seed 003: kn/10)."),
        stiffness: str = typer.Option("contact", "--stiffness", help="contact: --kn/--ks per contact; particle: "
                                      "per ball, in series per contact (PFC 4, seed 003 Table 1: kn/2 for equal balls)."),
        bonds: str = typer.Option("auto", "--bonds", help="auto (bonds stored in the file or made by its protocol, "
                                  "else the epsilon rule), file (stored only) or distance (always epsilon)."),
        response: bool = typer.Option(False, "--response/--no-response", help="Add the exact elastic response "
                                      "(bond forces, non-affine displacements) to a unit strain of --mode (.gsd, .vtm)."),
        mode: str = typer.Option("13", "--mode", help="Voigt strain mode of --response: 11 22 33 23 13 12."),
        force: bool = typer.Option(False, "--force", help="Replace an existing OUT of another kind."),
    ):
        """Write the bonded network of a pack (the epsilon rule of seed 003, or its stored bonds) for OVITO, ParaView or LAMMPS.

        Lengths stay in the file's unit. Per bond: rest length, length, stiffnesses, strengths; per particle: bond count and rattler flag; with --response the forces and non-affine motion of the exact elastic tensor.
        """  # noqa: E501
        from .._util import check_new_output, file_kind
        from ..mechanics import elastic_tensor, write_network
        from ._network import network_from_file

        check_new_output(target, file_kind(target), inputs=(source,), force=force, option="OUT")
        _, net, bonds_note, _ = network_from_file(source, bonds=bonds, epsilon=epsilon, radius=0.0,
                                                  normal_stiffness=kn, shear_stiffness=ks, stiffness=stiffness)
        et = elastic_tensor(net) if response else None
        files = write_network(target, net, et, mode=mode)
        extra = ""
        if et is not None:
            extra = f", response to a unit strain {mode}" + ("" if et.rigid else f" (FLOPPY: {et.floppy_reason})")
        typer.echo(f"wrote {', '.join(str(f) for f in files)}: {net.n} particles, {bonds_note}, "
                   f"Z = {net.coordination:.3f}, {int(net.rattlers.sum())} rattlers{extra}")
