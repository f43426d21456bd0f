"""``polypack elastic``: exact elastic tensor of the bonded network of a packing file."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from ._generated import options_from
from ._network import FILE_BONDS, NETWORK_ALIASES, NETWORK_NOTES, cli_bonds


def elastic_report(pk, epsilon=0.01, kn=100.0, ks=10.0, radius=0.25e-6, rotations=True, solver="auto", net=None,
                   stiffness="contact"):
    """Network and tensor of ``pk`` as plain JSON-able data (moduli in Pa and MPa if ``radius``);
    ``net``: the network to use (default: the epsilon rule on ``pk``)."""
    from ..mechanics import BondNetwork, elastic_tensor

    if net is None:
        net = BondNetwork.from_packing(pk, epsilon=epsilon, normal_stiffness=kn, shear_stiffness=ks,
                                       stiffness=stiffness)
    et = elastic_tensor(net, rotations=rotations, radius=radius, solver=solver)
    st = net.statistics()
    st.pop("bond_angle_histogram")
    return {
        "n": pk.n,
        "volume_fraction": pk.volume_fraction,
        "epsilon": epsilon,
        "normal_stiffness": kn,
        "shear_stiffness": ks,
        "stiffness_semantics": net.stiffness,
        "radius_m": radius,
        "network": st,
        "elastic": et.to_dict(),
    }


def register(app: typer.Typer) -> None:
    @app.command()
    @options_from("mechanics", "elastic", aliases=NETWORK_ALIASES, notes=NETWORK_NOTES, prepare=cli_bonds)
    def elastic(
        file: Path = typer.Argument(..., help="Packing file (gsd, xyz, lammps data, csv)."),
        json_out: Optional[Path] = typer.Option(None, "--json", help="Write the results as JSON here."),
        fmt: Optional[str] = typer.Option(None, "--format", help="Override the file format."),
        force: bool = typer.Option(False, "--force", help="Replace an existing --json file of another kind."),
        options: dict = None,
    ):
        """Exact linear elastic tensor of the bonded network (static limit of seed 003's shear test).

        The option flags are the keys of \\[analysis.elastic] in a study (same defaults and units).
        """
        import numpy as np

        from .._util import atomic_open, check_new_output
        from ..mechanics.stages import _stiffnesses
        from ._network import network_from_file

        if json_out is not None:  # checked before the computation
            check_new_output(json_out, "JSON", inputs=(file,), force=force, option="--json")
        o = options
        kn, ks = _stiffnesses(o)  # shear_stiffness unset: normal_stiffness / 10 (seed 003 Table 1)
        epsilon, radius, stiffness = o["epsilon"], o["radius"], o.get("stiffness", "contact")
        pk, net, bonds_note, units_note = network_from_file(file, bonds=FILE_BONDS[o["bonds"]], epsilon=epsilon,
                                                            radius=radius, fmt=fmt, rescale=False,
                                                            normal_stiffness=kn, shear_stiffness=ks,
                                                            stiffness=stiffness)
        typer.echo(f"{file}: {units_note}; {bonds_note}")
        res = elastic_report(pk, epsilon, kn, ks, radius or None, o["rotations"], o["solver"], net=net,
                             stiffness=stiffness)
        res = {"file": str(file), "bonds_source": bonds_note, "length_scale": units_note, **res}
        if json_out is not None:
            with atomic_open(json_out, "w") as fh:
                json.dump(res, fh, indent=1)
        e, nw = res["elastic"], res["network"]
        si = e["units"] == "Pa"
        unit, f = ("MPa", 1e-6) if si else ("(stiffness/length)", 1.0)
        typer.echo(f"  N={pk.n}, volume fraction {pk.volume_fraction:.4f}, bonds {nw['n_bonds']}, "
                   f"Z={nw['coordination']:.3f}, rattlers {nw['n_rattlers']}, floppy modes {e['floppy_modes']}")
        if not e["rigid"]:
            typer.echo(f"  FLOPPY: G = 0 ({e['floppy_reason']})")
        c = np.asarray(e["stiffness"]) * f
        typer.echo(f"  relaxed stiffness C ({unit}, Voigt 11 22 33 23 13 12, engineering shear):")
        for row in c:
            typer.echo("   " + " ".join(f"{v:10.4g}" for v in row))
        typer.echo(f"  G = {e['shear_modulus'] * f:.4g} {unit}, K = {e['bulk_modulus'] * f:.4g} {unit} "
                   f"(Voigt averages); C44 C55 C66 = "
                   + " ".join(f"{v * f:.4g}" for v in e["shear_moduli"]) + f" {unit}")
        typer.echo(f"  affine G = {e['affine_shear_modulus'] * f:.4g} {unit}, G/G_affine = {e['relaxation_ratio']:.4f}")
        if json_out is not None:
            typer.echo(f"  wrote {json_out}")
