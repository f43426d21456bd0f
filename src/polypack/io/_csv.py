"""CSV: ``x,y,z,radius,species`` rows after ``#`` comment lines holding the box.

Written as::

    # polypack 0.1.0 packing
    # n: 2000
    # box: Lx,Ly,Lz
    # provenance: {...}
    x,y,z,radius,species
    ...

2D packs (disks) use the header ``x,y,radius,species`` and a box line with two lengths.
Packs with walls carry one more comment line, ``# periodic: T,F`` (one flag per axis),
before the header.

Readable by ``numpy.loadtxt(path, delimiter=",", skiprows=5)`` or
``pandas.read_csv(path, comment="#")``. Numbers use ``shortest round-trip decimals (``repr``)`` (exact round trip).
The reader requires the ``box`` line; ``n`` (when present) guards against truncation.
"""

from __future__ import annotations

from .._util import atomic_open
from ..packing import Packing
from ._common import (
    FLOAT,
    num,
    as_int_column,
    build_packing,
    fail,
    format_rows,
    parse_int,
    parse_pbc,
    parse_provenance,
    parse_table,
    provenance_json,
    read_text,
)

HEADER = "x,y,z,radius,species"
HEADER_2D = "x,y,radius,species"


def write(path, packing: Packing) -> None:
    """Write ``packing`` as CSV with the box in a header comment (atomically)."""
    from .._version import __version__

    box = ",".join(num(v) for v in packing.box)
    walls = "" if packing.fully_periodic else "# periodic: " + ",".join("T" if f else "F" for f in packing.periodic) + "\n"
    head = (
        f"# polypack {__version__} packing\n# n: {packing.n}\n# box: {box}\n"
        f"# provenance: {provenance_json(packing)}\n{walls}{HEADER if packing.dim == 3 else HEADER_2D}\n"
    )
    p = packing.positions
    cols = [p[:, k] for k in range(packing.dim)] + [packing.radii, packing.species]
    body = format_rows(cols, [FLOAT] * (packing.dim + 1) + ["%d"], sep=",")
    with atomic_open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(head)
        fh.write(body)


def read_with_info(path, frame: int = -1) -> tuple[Packing, dict]:
    """Read a polypack CSV file; ``(packing, info)``."""
    if isinstance(frame, bool) or frame not in (0, -1):
        raise fail(path, f"frame {frame!r} requested but the file has 1 frame")
    lines = read_text(path).split("\n")[:-1]
    fields, k = {}, 0
    while k < len(lines) and lines[k].startswith("#"):
        key, sep, value = lines[k][1:].partition(":")
        if sep:
            fields[key.strip()] = value.strip()
        k += 1
    head = lines[k].replace(" ", "") if k < len(lines) else None
    if head not in (HEADER, HEADER_2D):
        got = lines[k][:60] if k < len(lines) else "end of file"
        raise fail(path, f"expected the column header {HEADER!r} (or {HEADER_2D!r}) after the comments, found {got!r}")
    dim = 3 if head == HEADER else 2
    if "box" not in fields:
        raise fail(path, "no '# box: Lx,Ly,Lz' comment line before the header")
    box = parse_table([fields["box"]], dim, path, 1, sep=",")[0]
    periodic = None
    if "periodic" in fields:
        periodic = tuple(parse_pbc(fields["periodic"].replace(",", " "), path))
        if len(periodic) != dim:
            raise fail(path, f"'# periodic:' has {len(periodic)} flags, expected {dim}")
    rows = [line for line in lines[k + 1 :] if line.strip()]
    if "n" in fields:
        n = parse_int(fields["n"], "'# n:' count", path)
        if len(rows) != n:
            raise fail(path, f"truncated or padded: header declares {n} rows but the file has {len(rows)}")
    table = parse_table(rows, dim + 2, path, k + 2, sep=",").reshape(-1, dim + 2)
    meta, info = {}, {}
    if "provenance" in fields:
        meta, info = parse_provenance(fields["provenance"], path)
    info.update(format="csv", frames=1, frame=0)
    species = as_int_column(table[:, dim + 1], "species", path)
    return build_packing(path, table[:, :dim], table[:, dim], box, species=species, meta=meta, periodic=periodic), info
