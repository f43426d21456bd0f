"""``polypack export-network PACK OUT``: a pack's bonded network to GSD, VTK (.vtm) or LAMMPS BPM (.data)."""

from __future__ import annotations

from pathlib import Path

import typer

from ._generated import options_from
from ._network import FILE_BONDS, NETWORK_ALIASES, NETWORK_NOTES, cli_bonds

#: The bond options of ``[analysis.elastic]`` that ``export-network`` takes as flags.
BOND_FIELDS = ("bonds", "epsilon", "normal_stiffness", "shear_stiffness", "stiffness")


def register(app: typer.Typer) -> None:
    @app.command("export-network")
    @options_from("mechanics", "elastic", fields=BOND_FIELDS, aliases=NETWORK_ALIASES, notes=NETWORK_NOTES,
                  prepare=cli_bonds)
    def export_network(
        source: Path = typer.Argument(..., metavar="PACK", help="Pack or network file (gsd, xyz, data, vtp, csv, vtm)."),
        target: Path = typer.Argument(..., metavar="OUT", help="Network file: .gsd (OVITO, HOOMD), .vtm (ParaView: "
                                      "writes OUT_particles.vtp and OUT_bonds.vtp beside it) or .data (LAMMPS BPM)."),
        response: bool = typer.Option(False, "--response/--no-response", help="Add the exact elastic response "
                                      "(bond forces, non-affine displacements) to a unit strain of --mode (.gsd, .vtm)."),
        mode: str = typer.Option("13", "--mode", help="Voigt strain mode of --response: 11 22 33 23 13 12."),
        force: bool = typer.Option(False, "--force", help="Replace an existing OUT of another kind."),
        options: dict = None,
    ):
        """Write the bonded network of a pack (the epsilon rule of seed 003, or its stored bonds) for OVITO, ParaView or LAMMPS.

        Lengths stay in the file's unit. The bond flags are those of \\[analysis.elastic] (polypack elastic). Per bond: rest length, length, stiffnesses, strengths; per particle: bond count and rattler flag; with --response the forces and non-affine motion of the exact elastic tensor.
        """  # noqa: E501
        from .._util import check_new_output, file_kind
        from ..mechanics import elastic_tensor, write_network
        from ..mechanics.stages import _stiffnesses
        from ._network import network_from_file

        check_new_output(target, file_kind(target), inputs=(source,), force=force, option="OUT")
        kn, ks = _stiffnesses(options)  # shear_stiffness unset: normal_stiffness / 10, as [analysis.elastic]
        _, net, bonds_note, _ = network_from_file(source, bonds=FILE_BONDS[options["bonds"]], epsilon=options["epsilon"],
                                                  radius=0.0, normal_stiffness=kn, shear_stiffness=ks,
                                                  stiffness=options.get("stiffness", "contact"))
        et = elastic_tensor(net) if response else None
        files = write_network(target, net, et, mode=mode)
        extra = ""
        if et is not None:
            extra = f", response to a unit strain {mode}" + ("" if et.rigid else f" (FLOPPY: {et.floppy_reason})")
        typer.echo(f"wrote {', '.join(str(f) for f in files)}: {net.n} particles, {bonds_note}, "
                   f"Z = {net.coordination:.3f}, {int(net.rattlers.sum())} rattlers{extra}")
