"""``polypack info`` and ``polypack convert``: inspect and convert packing files."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Optional

import typer

MAX_PAIRS = 5  # overlapping pairs named in the text output
_FORMATS_HELP = "gsd, xyz (.xyz/.extxyz), lammps (.data/.lmp), vtp, csv"


def _finite(x):
    """float, or None for inf/nan (JSON has no infinity)."""
    x = float(x)
    return x if math.isfinite(x) else None


def _jsonable(obj):
    """``obj`` with non-finite floats replaced by the strings "inf", "-inf", "nan" (strict JSON)."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return repr(obj)
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if obj is None or isinstance(obj, (bool, int, float, str)):
        return obj
    return repr(obj)


def summarize(path, fmt: Optional[str] = None, max_pairs: int = MAX_PAIRS, frame: Optional[int] = None) -> dict:
    """Everything ``polypack info`` reports, as plain JSON-able data.

    Keys: ``file``, ``format``, ``written_by``, ``n``, ``box``, ``box_volume``,
    ``volume_fraction``, ``species`` (per label: ``count``, ``radius_min``,
    ``radius_max``, ``volume_fraction``), ``min_gap`` and ``closest_pair``
    (relative gap ``d_ij/(r_i+r_j) - 1``, minimum image), ``overlapping_pairs``
    (total count), ``overlaps`` (the worst ``max_pairs`` as ``[i, j, gap]``), ``meta``.
    """
    from ..io.bonds import read_maybe_network

    pk, info, net = read_maybe_network(path, fmt, frame)
    gap, pair = pk.closest_pair()
    ov = pk.overlaps(0.0)
    species = []
    fractions = pk.species_fractions
    for k, count in enumerate(pk.species_counts):
        if count == 0:
            continue
        r = pk.radii[pk.species == k]
        species.append(
            {"species": k, "count": int(count), "radius_min": float(r.min()), "radius_max": float(r.max()),
             "volume_fraction": float(fractions[k])}
        )
    written = f"{info['writer']} {info.get('version', '?')}" if "writer" in info else None
    return {
        "file": str(path),
        "format": info["format"],
        "frame": info.get("frame", 0),
        "frames": info.get("frames", 1),
        "written_by": written,
        "n": pk.n,
        "box": pk.box.tolist(),
        "box_volume": pk.box_volume,
        "volume_fraction": pk.volume_fraction,
        "species": species,
        "min_gap": _finite(gap),
        "closest_pair": [int(pair[0]), int(pair[1])] if pair is not None else None,
        "overlapping_pairs": int(len(ov)),
        "overlaps": [[int(i), int(j), float(g)] for i, j, g in ov[:max_pairs]],
        "meta": _jsonable(pk.meta),
        **_network_summary(pk, net),
    }


def _network_summary(pk, net) -> dict:
    """``bonds`` (count), ``bond_types``, ``coordination``, ``rattlers`` (fewer than two bonds,
    recursively), ``bond_fields``, ``particle_fields`` of a network file; {} for a pack."""
    if net is None:
        return {}
    import numpy as np

    m = int(len(net["i"]))
    out = {"bonds": m, "bond_types": sorted({int(t) for t in np.asarray(net["bond_types"]).tolist()}),
           "coordination": 2.0 * m / pk.n if pk.n else 0.0, "rattlers": None,
           "bond_fields": sorted(net["bond_data"]), "particle_fields": sorted(net["particle_data"])}
    if m:
        try:
            from ..mechanics import BondNetwork

            out["rattlers"] = int(BondNetwork.from_pairs(pk, net["i"], net["j"], net["shift"]).rattlers.sum())
        except Exception:  # noqa: BLE001 - a summary line, not a check: a network it cannot build has no count
            out["rattlers"] = None
    return out


def _short(value, width=60) -> str:
    text = json.dumps(value, default=repr)
    return text if len(text) <= width else text[: width - 3] + "..."


def format_summary(s: dict) -> str:
    """Human-readable text of :func:`summarize` output."""
    box = " x ".join(f"{v:.6g}" for v in s["box"])
    lines = [
        f"file             {s['file']} ({s['format']}" + (f", written by {s['written_by']})" if s["written_by"] else ")"),
        *([f"frame            {s['frame']} of frames 0..{s['frames'] - 1} (choose with --frame)"]
          if s.get("frames", 1) > 1 else []),
        f"spheres          {s['n']}",
        f"box              {box}  (volume {s['box_volume']:.6g}, periodic)",
        f"volume fraction  {s['volume_fraction']:.6f}",
    ]
    if s["species"]:
        lines.append("species          count     radius min     radius max   volume fraction")
        for sp in s["species"]:
            lines.append(
                f"  {sp['species']:>5d}     {sp['count']:>9d}   {sp['radius_min']:>12.6g}   {sp['radius_max']:>12.6g}"
                f"   {sp['volume_fraction']:.6f}"
            )
    if s["closest_pair"] is None:
        lines.append("min gap          - (fewer than two spheres)")
    else:
        i, j = s["closest_pair"]
        lines.append(f"min gap          {s['min_gap']:.6g}  (d/(r_i+r_j) - 1, spheres {i} and {j})")
    if s["overlapping_pairs"] == 0:
        lines.append("overlaps         none")
    else:
        named = ", ".join(f"{i} and {j} (gap {g:.3g})" for i, j, g in s["overlaps"])
        more = s["overlapping_pairs"] - len(s["overlaps"])
        lines.append(
            f"overlaps         {s['overlapping_pairs']} overlapping pair(s): spheres {named}"
            + (f", and {more} more" if more > 0 else "")
        )
    if "bonds" in s:
        lines.append(f"bonds            {s['bonds']} (types {', '.join(map(str, s['bond_types'])) or '-'}, "
                     f"coordination {s['coordination']:.4g}, rattlers "
                     f"{'-' if s['rattlers'] is None else s['rattlers']})")
        lines.append(f"bond fields      {', '.join(s['bond_fields']) or '(none)'}")
        lines.append(f"particle fields  {', '.join(s['particle_fields']) or '(none)'}")
    if s["meta"]:
        lines.append("meta")
        for key, value in s["meta"].items():
            lines.append(f"  {key + ':':<15s} {_short(value)}")
    else:
        lines.append("meta             (none)")
    return "\n".join(lines)


def register(app: typer.Typer) -> None:
    """Add ``info`` and ``convert`` to the polypack CLI."""

    @app.command()
    def info(
        file: str = typer.Argument(..., metavar="FILE", help=f"Packing file ({_FORMATS_HELP})."),
        json_output: bool = typer.Option(False, "--json", help="Print machine-readable JSON instead of text."),
        fmt: Optional[str] = typer.Option(None, "--format", help="Format name when the extension is not standard."),
        pairs: int = typer.Option(MAX_PAIRS, "--pairs", min=0, help="How many overlapping pairs to name."),
        frame: Optional[int] = typer.Option(None, "--frame", help="Frame of a multi-frame GSD/XYZ file (default: last)."),
    ):
        """Summarise a packing: N, box, volume fraction, species, minimum gap, overlaps, provenance.

        The minimum gap is the smallest d_ij/(r_i+r_j) - 1 over all pairs (minimum image in the periodic box); a negative value means overlapping spheres, and the worst overlapping pairs are named by their 0-based index in the file. Exit code 1 with a one-line error for an unreadable file.
        """  # noqa: E501
        s = summarize(file, fmt, max_pairs=pairs, frame=frame)
        if json_output:
            typer.echo(json.dumps(s, indent=2, allow_nan=False, default=repr))
        else:
            typer.echo(format_summary(s))

    @app.command()
    def convert(
        source: str = typer.Argument(..., metavar="SOURCE", help="Input packing file."),
        target: str = typer.Argument(..., metavar="TARGET", help="Output file; the format follows its extension."),
        from_fmt: Optional[str] = typer.Option(None, "--from", help="Input format when the extension is not standard."),
        to_fmt: Optional[str] = typer.Option(None, "--to", help="Output format when the extension is not standard."),
        frame: Optional[int] = typer.Option(None, "--frame", help="Frame of a multi-frame GSD/XYZ file (default: last)."),
        drop_bonds: bool = typer.Option(False, "--drop-bonds", help="Write only the pack of a network file "
                                        "(its bonds and bond/particle fields are left out)."),
        drop_fields: bool = typer.Option(False, "--drop-fields", help="Keep the bonds of a network file but "
                                         "leave out its bond/particle fields (for LAMMPS data, which has none)."),
    ):
        """Convert a packing or a bonded network between formats (gsd, xyz, lammps, vtp, csv; networks: gsd, lammps, vtm).

        Positions, radii, box, species and provenance are carried over exactly, and so are the bonds and the bond and particle fields of a network file (GSD, LAMMPS data, VTK .vtm) to a format that holds them; a target that cannot hold them is refused unless --drop-bonds. The output is written atomically, never onto SOURCE, so an existing TARGET is replaced only on success.
        """  # noqa: E501
        from .. import io
        from .._util import check_new_output, file_kind, output_path
        from ..errors import InvalidInputError
        from ..io import bonds as iob

        t_ext = Path(target).suffix.lower()
        t_fmt = "vtm" if (to_fmt or "").lower().lstrip(".") == "vtm" or (not to_fmt and t_ext == ".vtm") else None
        if t_fmt is None:
            t_fmt = io.format_for(target, to_fmt)
        check_new_output(target, file_kind(target), inputs=(source,), option="TARGET")
        output_path(target)
        pk, info, net = iob.read_maybe_network(source, from_fmt, frame)
        which = f" from frame {info['frame']} of {info['frames']}" if info.get("frames", 1) > 1 else ""
        if net is not None and drop_fields:
            net = dict(net, bond_data={}, particle_data={})
            if len(net["i"]) == 0:
                net = None
        if net is not None and not drop_bonds:
            fields = sorted(net["bond_data"]) + sorted(net["particle_data"])
            if t_fmt not in iob.BOND_FORMATS:
                raise InvalidInputError(
                    f"TARGET {target}: format {t_fmt!r} cannot hold the {len(net['i'])} bonds"
                    + (f" and fields ({', '.join(fields)})" if fields else "")
                    + f" of {source}; use .gsd, .vtm or .data, or pass --drop-bonds")
            if t_fmt == "lammps" and fields:
                raise InvalidInputError(
                    f"TARGET {target}: LAMMPS data holds bonds but not the fields ({', '.join(fields)}) of {source}; "
                    "use .gsd or .vtm, or pass --drop-fields")
            if len(net["i"]) == 0:
                raise InvalidInputError(f"{source}: holds fields ({', '.join(fields)}) but no bonds; the network "
                                        "writers need bonds: pass --drop-bonds to write the pack only")
            files = iob.write_network(target, pk, net["i"], net["j"], net["shift"], bond_types=net["bond_types"],
                                      bond_data=net["bond_data"], particle_data=net["particle_data"],
                                      network_meta=net["network_meta"], format=t_fmt)
            typer.echo(f"wrote {', '.join(str(f) for f in files)} ({t_fmt}, {pk.n} spheres, {len(net['i'])} bonds"
                       + (f", fields {', '.join(fields)}" if fields else "") + f"{which})")
            return
        if t_fmt == "vtm":
            raise InvalidInputError(f"TARGET {target}: .vtm holds bonded networks; {source} has no bonds (use .vtp)")
        io.write(target, pk, to_fmt)
        dropped = f", bonds and fields of {source} dropped (--drop-bonds)" if net is not None else ""
        typer.echo(f"wrote {target} ({io.format_for(target, to_fmt)}, {pk.n} spheres{which}{dropped})")


__all__ = ["register", "summarize", "format_summary"]
