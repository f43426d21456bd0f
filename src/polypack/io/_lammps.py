"""LAMMPS data file, ``atom_style sphere`` (``read_data`` in LAMMPS).

Written as::

    polypack 0.1.0 LAMMPS data file (atom_style sphere) provenance={...}

    N atoms
    K atom types

    0 Lx xlo xhi
    0 Ly ylo yhi
    0 Lz zlo zhi

    Atoms # sphere

    id type diameter density x y z

Atom types are 1-based (``type = species + 1``), ids follow the packing order, the
density column is 1 (LAMMPS then sets each mass to the sphere volume). The first line
is a free title for LAMMPS; polypack keeps its provenance JSON there. The reader
accepts ``Atoms`` rows with or without the three image flags, sorts atoms by id,
ignores other sections (Masses, Velocities) and rejects tilted boxes.
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
    parse_provenance,
    parse_table,
    provenance_json,
    read_text,
)


_SECTIONS = {
    "Atoms", "Velocities", "Masses", "Ellipsoids", "Lines", "Triangles", "Bodies", "Bonds", "Angles",
    "Dihedrals", "Impropers", "Pair Coeffs", "PairIJ Coeffs", "Bond Coeffs", "Angle Coeffs",
    "Dihedral Coeffs", "Improper Coeffs",
}
_TITLE_TAG = "provenance="


def write(path, packing: Packing) -> None:
    """Write ``packing`` as a LAMMPS ``atom_style sphere`` data file (atomically).

    3D packs only. A data file has no boundary flags: wall axes of ``packing.periodic``
    are not stored (set ``boundary`` in the LAMMPS input script).
    """
    from .. import __version__
    from ..errors import InvalidInputError

    if packing.dim != 3:
        raise InvalidInputError(
            f"the LAMMPS writer supports 3D packings only; got a {packing.dim}D packing (use .gsd, .xyz or .csv)"
        )

    lx, ly, lz = (num(v) for v in packing.box)
    header = (
        f"polypack {__version__} LAMMPS data file (atom_style sphere) {_TITLE_TAG}{provenance_json(packing)}\n\n"
        f"{packing.n} atoms\n{max(packing.n_species, 1)} atom types\n\n"
        f"0 {lx} xlo xhi\n0 {ly} ylo yhi\n0 {lz} zlo zhi\n\n"
        "Atoms # sphere\n\n"
    )
    p, n = packing.positions, packing.n
    body = format_rows(
        [np.arange(1, n + 1), packing.species + 1, 2.0 * packing.radii, np.ones(n), p[:, 0], p[:, 1], p[:, 2]],
        ["%d", "%d", FLOAT, FLOAT, FLOAT, FLOAT, FLOAT],
    )
    with atomic_open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(header)
        fh.write(body)


def _check_after_atoms(lines, k, n_atoms, path):
    """Cross-check what follows the declared ``n_atoms`` Atoms rows: more rows before the
    next section mean the header count is too small; a Velocities section must have one
    row per atom."""
    def rows_from(j):
        m = 0
        while j < len(lines) and lines[j].split("#", 1)[0].strip() and lines[j].split("#", 1)[0].strip() not in _SECTIONS:
            m += 1
            j += 1
        return m, j

    extra, k = rows_from(k)
    if extra:
        raise fail(path, f"header declares {n_atoms} atoms but the Atoms section has {n_atoms + extra} rows")
    while k < len(lines):
        text = lines[k].split("#", 1)[0].strip()
        if not text:
            k += 1
            continue
        if text not in _SECTIONS:
            raise fail(path, f"line {k + 1}: {text[:60]!r} after the Atoms section is neither a row nor a section name")
        name = text
        k += 1
        while k < len(lines) and not lines[k].strip():
            k += 1
        m, k = rows_from(k)
        if name == "Velocities" and m != n_atoms:
            raise fail(path, f"header declares {n_atoms} atoms but the Velocities section has {m} rows")


def read_with_info(path, frame: int = -1) -> tuple[Packing, dict]:
    """Read a LAMMPS data file with an ``atom_style sphere`` Atoms section; ``(packing, info)``."""
    if isinstance(frame, bool) or frame not in (0, -1):
        raise fail(path, f"frame {frame!r} requested but the file has 1 frame")
    lines = read_text(path).split("\n")[:-1]
    title = lines[0]
    n_atoms, n_types, bounds, atoms_at = None, None, {}, None
    k = 1
    while k < len(lines):
        text = lines[k].split("#", 1)[0].strip()
        if not text:
            k += 1
            continue
        if text in _SECTIONS:
            if text == "Atoms":
                atoms_at = k
                break
            # skip a section we do not use: a blank line, then rows until the next blank line
            k += 2
            while k < len(lines) and lines[k].strip():
                k += 1
            continue
        tok = text.split()
        if tok[-1] == "atoms" and len(tok) == 2:
            n_atoms = parse_int(tok[0], "atom count", path)
            if n_atoms < 0:
                raise fail(path, f"line {k + 1}: atom count {n_atoms} is negative")
        elif tok[-2:] == ["atom", "types"] and len(tok) == 3:
            n_types = parse_int(tok[0], "atom type count", path)
        elif tok[-2:] in (["xlo", "xhi"], ["ylo", "yhi"], ["zlo", "zhi"]) and len(tok) == 4:
            try:
                bounds[tok[-2][0]] = (float(tok[0]), float(tok[1]))
            except ValueError:
                raise fail(path, f"line {k + 1}: box bounds {text!r} are not numbers") from None
        elif tok[-3:] == ["xy", "xz", "yz"]:
            if any(t.strip("+-0.eE") for t in tok[:3]):
                raise fail(path, f"line {k + 1}: tilted box ({text!r}); only orthorhombic boxes are allowed")
        elif not re.fullmatch(r"[-+0-9.eE ]+[a-z ]+", text):
            raise fail(path, f"line {k + 1}: {text[:60]!r} is neither a header keyword nor a section name")
        k += 1
    if n_atoms is None:
        raise fail(path, "no 'N atoms' line in the header; not a LAMMPS data file")
    if set(bounds) != {"x", "y", "z"}:
        raise fail(path, f"box bounds missing for axis {sorted({'x', 'y', 'z'} - set(bounds))}")
    if atoms_at is None:
        raise fail(path, "no 'Atoms' section")
    style = lines[atoms_at].split("#", 1)[1].strip() if "#" in lines[atoms_at] else "sphere"
    if style != "sphere":
        raise fail(path, f"Atoms section has atom style {style!r}; only 'sphere' is supported")
    first = atoms_at + 2
    rows = lines[first : first + n_atoms]
    if len(rows) < n_atoms or (n_atoms and not rows[-1].strip()):
        got = sum(1 for r in rows if r.strip())
        raise fail(path, f"truncated: header declares {n_atoms} atoms but the Atoms section has {got} rows")
    _check_after_atoms(lines, first + n_atoms, n_atoms, path)
    ncol = len(rows[0].split()) if rows else 7
    if ncol not in (7, 10):
        raise fail(path, f"line {first + 1}: {ncol} columns; atom_style sphere rows have 7 (or 10 with image flags)")
    table = parse_table(rows, ncol, path, first + 1)
    order = np.argsort(table[:, 0], kind="stable")
    table = table[order]
    ids = as_int_column(table[:, 0], "atom id", path)
    if len(np.unique(ids)) != n_atoms:
        raise fail(path, "atom ids are not unique")
    species = as_int_column(table[:, 1], "atom type", path) - 1
    if species.size and species.min() < 0:
        raise fail(path, f"atom type {int(species.min()) + 1} is < 1; LAMMPS types start at 1")
    if n_types is not None and species.size and species.max() + 1 > n_types:
        raise fail(path, f"atom type {int(species.max()) + 1} found but the header declares {n_types} atom types")
    lo = np.array([bounds[a][0] for a in "xyz"])
    hi = np.array([bounds[a][1] for a in "xyz"])
    box = hi - lo
    positions = table[:, 4:7] - lo  # exact when lo == 0 (files written by polypack)
    if ncol == 10:
        positions = positions + table[:, 7:10] * box
    meta, info = {}, {}
    if _TITLE_TAG in title:
        meta, info = parse_provenance(title.split(_TITLE_TAG, 1)[1], path)
    info.update(format="lammps", atom_style="sphere", frames=1, frame=0)
    return build_packing(path, positions, 0.5 * table[:, 2], box, species=species, meta=meta), info

