"""LAMMPS data file, ``atom_style sphere`` or ``bpm/sphere`` (``read_data`` in LAMMPS).

Written as::

    polypack 0.1.0 LAMMPS data file (atom_style sphere)

    N atoms
    K atom types

    # polypack provenance={...}

    0 Lx xlo xhi
    0 Ly ylo yhi
    0 Lz zlo zhi

    Atoms # sphere

    id type diameter density x y z

Atom types are 1-based (``type = species + 1``), ids follow the packing order, the
density column is 1 (LAMMPS then sets each mass to the sphere volume). The first line
is a free title for LAMMPS, kept short: OVITO reads only its first 1024 characters and
expects the ``atoms`` line within the next 20 lines, so the provenance JSON is a header
comment after the counts (files whose title holds ``provenance=`` are read too). The reader
accepts ``Atoms`` rows with or without the three image flags, sorts atoms by id,
ignores other sections (Masses, Velocities) and rejects tilted boxes.

Bonded networks (:mod:`polypack.io.bonds`) use :func:`write_data` with
``atom_style bpm/sphere`` (rows ``id molecule type diameter density x y z``), ``M bonds``
and ``T bond types`` header lines and a ``Bonds`` section (``id type atom1 atom2``);
comment lines (``#``) in the header carry notes such as an input-script snippet.
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
_TITLE_TAG = "provenance="  # files before 0.1.0 kept the provenance in the title
_COMMENT_TAG = "# polypack provenance="


#: Atoms-section columns before ``x y z`` per atom style.
ATOM_STYLES = {"sphere": ("id", "type", "diameter", "density"), "bpm/sphere": ("id", "molecule", "type", "diameter", "density")}


def write(path, packing: Packing) -> None:
    """Write ``packing`` as a LAMMPS ``atom_style sphere`` data file (atomically).

    3D packs only. A data file has no boundary flags: wall axes of ``packing.periodic``
    are not stored (set ``boundary`` in the LAMMPS input script).
    """
    write_data(path, packing)


def write_data(path, packing: Packing, *, atom_style: str = "sphere", density=1.0, comments=(),
               bonds=None, bond_types: int | None = None) -> None:
    """LAMMPS data file with an optional ``Bonds`` section (atomically); 3D packs only.

    Parameters
    ----------
    atom_style : {"sphere", "bpm/sphere"}
        Column layout of the Atoms section (``bpm/sphere``: ``id molecule type diameter
        density x y z``, molecule 0).
    density : float or (N,) array
        The density column (LAMMPS sets each mass to density times the sphere volume).
    comments : sequence of str
        Lines written as ``# ...`` comments in the header (LAMMPS skips them).
    bonds : (types, i, j), optional
        1-based bond types and 0-based particle indices of the ``Bonds`` section.
    bond_types : int, optional
        Number of bond types declared (default: the largest type used). No ``Bond
        Coeffs`` section: BPM bond styles can only be defined after ``read_data`` has
        made the box, so their coefficients belong in the input script.
    """
    from .._version import __version__
    from ..errors import InvalidInputError

    if packing.dim != 3:
        raise InvalidInputError(
            f"the LAMMPS writer supports 3D packings only; got a {packing.dim}D packing (use .gsd, .xyz, .vtp or .csv)"
        )
    if atom_style not in ATOM_STYLES:
        raise InvalidInputError(f"atom_style={atom_style!r}: allowed are {sorted(ATOM_STYLES)}")
    n = packing.n
    rho = np.broadcast_to(np.asarray(density, dtype=np.float64), (n,))
    lx, ly, lz = (num(v) for v in packing.box)
    notes = "".join(f"# {line}\n".replace("# \n", "#\n") for line in comments)
    counts = f"{n} atoms\n{max(packing.n_species, 1)} atom types\n"
    if bonds is not None:
        btype, bi, bj = (np.asarray(a, dtype=np.int64) for a in bonds)
        n_types = int(bond_types) if bond_types is not None else int(btype.max(initial=0))
        counts += f"{btype.size} bonds\n{max(n_types, 1)} bond types\n"
    # OVITO reads at most 1024 characters of the title and looks for the "atoms" line within
    # the next 20 lines: the title stays short, the counts come first, the long provenance
    # line and the notes follow them as header comments (LAMMPS and ASE skip those).
    header = (
        f"polypack {__version__} LAMMPS data file (atom_style {atom_style})\n\n{counts}\n"
        f"{_COMMENT_TAG}{provenance_json(packing)}\n{notes}\n"
        f"0 {lx} xlo xhi\n0 {ly} ylo yhi\n0 {lz} zlo zhi\n\n"
    )
    header += f"Atoms # {atom_style}\n\n"
    p = packing.positions
    lead = [np.arange(1, n + 1)] + ([np.zeros(n, np.int64)] if atom_style == "bpm/sphere" else [])
    body = format_rows(
        lead + [packing.species + 1, 2.0 * packing.radii, rho, p[:, 0], p[:, 1], p[:, 2]],
        ["%d"] * len(lead) + ["%d", FLOAT, FLOAT, FLOAT, FLOAT, FLOAT],
    )
    if bonds is not None:
        m = btype.size
        body += "\nBonds\n\n" + format_rows([np.arange(1, m + 1), btype, bi + 1, bj + 1], ["%d"] * 4)
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
    if style not in ATOM_STYLES:
        raise fail(path, f"Atoms section has atom style {style!r}; supported are {', '.join(sorted(ATOM_STYLES))}")
    lead = len(ATOM_STYLES[style])
    first = atoms_at + 2
    rows = lines[first : first + n_atoms]
    if len(rows) < n_atoms or (n_atoms and not rows[-1].strip()):
        got = sum(1 for r in rows if r.strip())
        raise fail(path, f"truncated: header declares {n_atoms} atoms but the Atoms section has {got} rows")
    _check_after_atoms(lines, first + n_atoms, n_atoms, path)
    ncol = len(rows[0].split()) if rows else lead + 3
    if ncol not in (lead + 3, lead + 6):
        raise fail(path, f"line {first + 1}: {ncol} columns; atom_style {style} rows have {lead + 3} "
                         f"(or {lead + 6} with image flags)")
    table = parse_table(rows, ncol, path, first + 1)
    order = np.argsort(table[:, 0], kind="stable")
    table = table[order]
    ids = as_int_column(table[:, 0], "atom id", path)
    if len(np.unique(ids)) != n_atoms:
        raise fail(path, "atom ids are not unique")
    cols = ATOM_STYLES[style]
    species = as_int_column(table[:, cols.index("type")], "atom type", path) - 1
    if species.size and species.min() < 0:
        raise fail(path, f"atom type {int(species.min()) + 1} is < 1; LAMMPS types start at 1")
    if n_types is not None and species.size and species.max() + 1 > n_types:
        raise fail(path, f"atom type {int(species.max()) + 1} found but the header declares {n_types} atom types")
    lo = np.array([bounds[a][0] for a in "xyz"])
    hi = np.array([bounds[a][1] for a in "xyz"])
    box = hi - lo
    positions = table[:, lead : lead + 3] - lo  # exact when lo == 0 (files written by polypack)
    if ncol == lead + 6:
        positions = positions + table[:, lead + 3 : lead + 6] * box
    meta, info = {}, {}
    record = next((line[len(_COMMENT_TAG):] for line in lines[1:atoms_at] if line.startswith(_COMMENT_TAG)), None)
    if record is None and _TITLE_TAG in title:
        record = title.split(_TITLE_TAG, 1)[1]
    if record is not None:
        meta, info = parse_provenance(record, path)
    info.update(format="lammps", atom_style=style, frames=1, frame=0)
    radii = 0.5 * table[:, cols.index("diameter")]
    return build_packing(path, positions, radii, box, species=species, meta=meta), info

