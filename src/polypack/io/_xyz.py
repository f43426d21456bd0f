"""Extended XYZ, read by OVITO and ASE (``ase.io.read``).

Written as::

    N
    Lattice="Lx 0 0 0 Ly 0 0 0 Lz" Properties=species:S:1:pos:R:3:radius:R:1:species_id:I:1 pbc="T T T" polypack_provenance="{...}"
    X x y z radius species_id
    ...

2D packs (disks) are written with ``z = 0``, a zero third lattice vector
(``Lattice="Lx 0 0 0 Ly 0 0 0 0"``) and a third ``pbc`` flag ``F``; wall axes have
``pbc`` ``F`` too (e.g. ``pbc="T F F"`` for a 2D deposit with a floor).

``X`` is the dummy element ASE and OVITO accept for spheres that are not atoms; the
polypack species label is the integer column ``species_id``. Numbers use ``shortest round-trip decimals (``repr``)``
so the file reads back exactly. The reader accepts any column order in
``Properties`` (a ``radius`` column is required); multi-frame files give the last frame.
"""

from __future__ import annotations

import re

import numpy as np

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
    pbc_text,
    parse_provenance,
    provenance_json,
    read_text,
)


PROPERTIES = "species:S:1:pos:R:3:radius:R:1:species_id:I:1"
_KEY_VALUE = re.compile(r'\s*([^\s="]+)(?:=("(?:[^"\\]|\\.)*"|\S+))?')


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _unquote(text: str) -> str:
    if len(text) >= 2 and text[0] == text[-1] == '"':
        return re.sub(r"\\(.)", r"\1", text[1:-1])
    return text


def parse_comment(line: str) -> dict[str, str]:
    """Key=value pairs of an extended XYZ comment line (quotes and ``\\"`` escapes handled)."""
    out, pos = {}, 0
    line = line.rstrip("\n")
    while pos < len(line):
        m = _KEY_VALUE.match(line, pos)
        if m is None or m.end() == pos:
            break
        out[m.group(1)] = _unquote(m.group(2)) if m.group(2) is not None else "T"
        pos = m.end()
    return out


def write(path, packing: Packing) -> None:
    """Write ``packing`` as extended XYZ (atomically)."""
    lx, ly = (num(v) for v in packing.box[:2])
    lz = num(packing.box[2]) if packing.dim == 3 else "0"
    header = (
        f'{packing.n}\nLattice="{lx} 0 0 0 {ly} 0 0 0 {lz}" Properties={PROPERTIES} pbc="{pbc_text(packing)}" '
        f"polypack_provenance={_quote(provenance_json(packing))}\n"
    )
    p = packing.positions
    pz = p[:, 2] if packing.dim == 3 else np.zeros(packing.n)
    body = format_rows([p[:, 0], p[:, 1], pz, packing.radii, packing.species], ["X " + FLOAT, FLOAT, FLOAT, FLOAT, "%d"])
    with atomic_open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(header)
        fh.write(body)


def _columns(spec: str, path) -> tuple[dict[str, tuple[int, str, int]], int]:
    """``{name: (first column, type letter, width)}`` and the total number of columns."""
    parts = spec.split(":")
    if len(parts) % 3:
        raise fail(path, f"Properties={spec!r} is not a list of name:type:count triplets")
    cols, at = {}, 0
    for name, kind, count in zip(parts[0::3], parts[1::3], parts[2::3]):
        width = parse_int(count, f"column count of property {name!r}", path)
        cols[name] = (at, kind.upper(), width)
        at += width
    return cols, at


def read_with_info(path, frame: int = -1) -> tuple[Packing, dict]:
    """Read one frame (default: the last) of an extended XYZ file; ``(packing, info)``.

    Every frame is checked to be complete and to hold exactly the declared number of
    rows; ``info`` gives ``frames`` and ``frame`` (the index read, counted from 0).
    """
    lines = read_text(path).split("\n")[:-1]
    start, starts = 0, []
    while True:  # find every frame, checking every frame is complete
        head = lines[start].split()
        if starts and len(head) != 1:
            prev, pn = starts[-1]
            raise fail(path, f"frame at line {prev + 1} declares {pn} atoms but has more rows (line {start + 1})")
        n = parse_int(lines[start].strip(), f"atom count on line {start + 1}", path)
        if n < 0:
            raise fail(path, f"atom count on line {start + 1} is {n}; must be >= 0")
        if len(lines) < start + 2 + n:
            raise fail(path, f"truncated: frame at line {start + 1} declares {n} atoms but the file ends after "
                             f"{max(len(lines) - start - 2, 0)}")
        starts.append((start, n))
        nxt = start + 2 + n
        while nxt < len(lines) and not lines[nxt].strip():
            nxt += 1
        if nxt >= len(lines):
            break
        start = nxt
    frames = len(starts)
    if isinstance(frame, bool) or not isinstance(frame, (int, np.integer)) or not -frames <= frame < frames:
        raise fail(path, f"frame {frame!r} requested but the file has {frames} frame(s)")
    start, n = starts[frame]
    frame = int(frame) % frames
    kv = parse_comment(lines[start + 1])
    if "Lattice" not in kv:
        raise fail(path, "no Lattice=\"...\" on the comment line; polypack needs a periodic box")
    try:
        lattice = np.array([float(t) for t in kv["Lattice"].split()])
    except ValueError:
        raise fail(path, f"Lattice={kv['Lattice']!r} is not 9 numbers") from None
    if lattice.shape != (9,):
        raise fail(path, f"Lattice={kv['Lattice']!r} is not 9 numbers")
    lattice = lattice.reshape(3, 3)
    if np.any(lattice[~np.eye(3, dtype=bool)] != 0):
        raise fail(path, f"Lattice={kv['Lattice']!r} is not orthorhombic; only diagonal boxes are allowed")
    pbc = parse_pbc(kv.get("pbc", "T T T"), path)
    if len(pbc) != 3:
        raise fail(path, f'pbc="{kv.get("pbc")}" must have 3 flags (T or F)')
    dim = 2 if lattice[2, 2] == 0 else 3
    if dim == 2 and pbc[2]:
        raise fail(path, f'zero third lattice vector (a 2-D box) but pbc="{kv.get("pbc")}" says z is periodic')
    cols, ncol = _columns(kv.get("Properties", "species:S:1:pos:R:3"), path)
    for need, width in (("pos", 3), ("radius", 1)):
        if need not in cols or cols[need][2] != width:
            raise fail(path, f"no '{need}' column of width {width} in Properties={kv.get('Properties')!r}")
    rows = [line.split() for line in lines[start + 2 : start + 2 + n]]
    for k, tok in enumerate(rows):
        if len(tok) != ncol:
            raise fail(path, f"line {start + 3 + k} has {len(tok)} fields, expected {ncol}")
    table = np.array(rows, dtype=str).reshape(n, ncol)

    def numeric(name):
        at, _, width = cols[name]
        try:
            return table[:, at : at + width].astype(np.float64)
        except ValueError:
            raise fail(path, f"column {name!r} holds a non-numeric value") from None

    positions, radii = numeric("pos"), numeric("radius")[:, 0]
    if dim == 2:
        if np.any(positions[:, 2] != 0):
            raise fail(path, "a 2-D box (zero third lattice vector) holds particles with z != 0")
        positions = positions[:, :2]
    if "species_id" in cols:
        species = as_int_column(numeric("species_id")[:, 0], "species_id", path)
    elif "species" in cols:  # foreign file: number element symbols by first appearance
        symbols = table[:, cols["species"][0]]
        _, first, inverse = np.unique(symbols, return_index=True, return_inverse=True)
        species = np.argsort(np.argsort(first))[inverse]
    else:
        species = None
    meta, info = {}, {}
    if "polypack_provenance" in kv:
        meta, info = parse_provenance(kv["polypack_provenance"], path)
    info.update(format="xyz", frames=frames, frame=frame)
    periodic = tuple(pbc[:dim])
    return build_packing(path, positions, radii, np.diag(lattice)[:dim], species=species, meta=meta,
                         periodic=periodic), info
