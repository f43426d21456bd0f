"""Bonded networks on disk: particles plus a bond list, per-bond and per-particle fields.

The io layer knows nothing about mechanics: callers pass arrays (``i``, ``j``, the
periodic ``shift`` of each bond, named per-bond and per-particle fields). The
:class:`~polypack.mechanics.BondNetwork` writer in :mod:`polypack.mechanics.export`
builds those arrays. Three formats carry bonds:

=============  ==========================================================================
extension      layout
=============  ==========================================================================
``.gsd``       the pack frame of :mod:`polypack.io._gsd` plus ``bonds/N``, ``bonds/types``,
               ``bonds/typeid``, ``bonds/group`` (i, j); ``log/bonds/Periodic Image``
               (image of j seen from i in the centred GSD frame; OVITO uses it to draw
               bonds across the boundary); ``log/bonds/<field>`` and
               ``log/particles/<field>`` (OVITO: bond and particle properties);
               ``log/polypack/network`` (JSON).
``.data``      LAMMPS data file, ``atom_style bpm/sphere`` with a ``Bonds`` section;
``.lmp``       ``# polypack network: {...}`` and the caller's comment lines (e.g. an
               input snippet with the ``bond_coeff`` lines) in the header. Periodic images are LAMMPS's minimum image, so every bond must
               be shorter than half the box along each periodic axis; no fields.
``.vtm``       a VTK multiblock (ParaView, OVITO) of two PolyData files written next to
               it: ``<stem>_particles.vtp`` (the pack as vertices, see
               :mod:`polypack.io._vtp`, with the particle fields as point arrays) and
               ``<stem>_bonds.vtp`` (one line per bond from ``x_i`` to the image
               ``x_i + b`` of ``x_j``, so periodic bonds are drawn whole; cell arrays
               ``id1``, ``id2`` (1-based particle ids, OVITO's contact-network
               convention), ``shift``, ``bond_type`` and the bond fields).
=============  ==========================================================================

Every file is written atomically; the ``.vtm`` index last, so it never points at a
missing or half-written part. :func:`read_network` reads all three back: positions,
radii, box, species and the bond list exactly, the fields as written (LAMMPS: none).
"""

from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..errors import InvalidInputError
from ..packing import Packing
from . import _gsd, _lammps, _vtp
from ._common import fail, provenance_json

__all__ = ["BOND_FORMATS", "write_network", "read_network", "read_maybe_network", "minimum_image_shift"]

#: format name -> extensions
BOND_FORMATS = {"gsd": (".gsd",), "lammps": (".data", ".lmp"), "vtm": (".vtm",)}


def _allowed() -> str:
    return ", ".join(f"{k} ({'/'.join(v)})" for k, v in BOND_FORMATS.items())


def bond_format_for(path, format: str | None = None) -> str:
    """Format name for a bonded-network file, from ``format`` or the extension."""
    if format is not None:
        name = str(format).lower().lstrip(".")
        if name not in BOND_FORMATS:
            raise InvalidInputError(f"format={format!r} cannot store bonds; allowed: {_allowed()}")
        return name
    ext = Path(path).suffix.lower()
    for name, exts in BOND_FORMATS.items():
        if ext in exts:
            return name
    if ext == ".vtp":
        raise InvalidInputError(
            f"{str(path)!r}: a bonded network in VTK form is a multiblock of particles and bond lines; "
            f"write {str(Path(path).with_suffix('.vtm'))!r} (makes *_particles.vtp and *_bonds.vtp next to it)"
        )
    raise InvalidInputError(
        f"{str(path)!r}: extension {ext or '(none)'!r} cannot store bonds; allowed: {_allowed()} (or pass format=...)"
    )


def minimum_image_shift(packing: Packing, i, j) -> np.ndarray:
    """(M, dim) image of ``j`` nearest to ``i`` (0 on wall axes)."""
    pos, box = packing.positions, packing.box
    delta = pos[np.asarray(j)] - pos[np.asarray(i)]
    periodic = np.array(packing.periodic)
    return np.where(periodic, -np.round(delta / box), 0.0).astype(np.int64)


def _check(packing, i, j, shift, bond_types, bond_data, particle_data):
    if not isinstance(packing, Packing):
        raise InvalidInputError(f"packing must be a polypack.Packing, got {type(packing).__name__}")
    i = np.asarray(i)
    j = np.asarray(j)
    if i.ndim != 1 or j.shape != i.shape:
        raise InvalidInputError(f"bond ends i, j must be 1-D of equal length, got shapes {i.shape}, {j.shape}")
    m, n, dim = i.size, packing.n, packing.dim
    if m == 0:
        raise InvalidInputError("the network has no bonds: nothing to write to a bond format (write the pack with "
                                "polypack.io.write instead)")
    if i.dtype.kind not in "iu" or j.dtype.kind not in "iu":
        raise InvalidInputError(f"bond ends must be integers, got {i.dtype}, {j.dtype}")
    i, j = i.astype(np.int64), j.astype(np.int64)
    bad = (i < 0) | (i >= n) | (j < 0) | (j >= n) | (i == j)
    if bad.any():
        c = int(np.flatnonzero(bad)[0])
        raise InvalidInputError(f"bond {c} = ({i[c]}, {j[c]}): ends must be distinct indices in [0, {n})")
    if shift is None:
        shift = minimum_image_shift(packing, i, j)
    shift = np.asarray(shift)
    if shift.shape != (m, dim) or shift.dtype.kind not in "iu":
        raise InvalidInputError(f"shift must be an integer array of shape ({m}, {dim}), got {shift.dtype} {shift.shape}")
    shift = shift.astype(np.int64)
    if bond_types is None:
        bond_types = np.ones(m, np.int64)
    bond_types = np.asarray(bond_types)
    if bond_types.shape != (m,) or bond_types.dtype.kind not in "iu" or bond_types.min() < 1:
        raise InvalidInputError(f"bond_types must be {m} integers >= 1 (1-based, LAMMPS style)")
    fields = []
    for what, data, rows in (("bond", bond_data, m), ("particle", particle_data, n)):
        out = {}
        for name, values in (data or {}).items():
            arr = np.asarray(values)
            if not isinstance(name, str) or not name or "/" in name or name in ("id1", "id2", "shift", "bond_type",
                                                                                 "radius", "diameter", "species"):
                raise InvalidInputError(f"{what} field name {name!r}: need a non-empty name without '/' that is "
                                        "not reserved (id1, id2, shift, bond_type, radius, diameter, species)")
            if arr.ndim not in (1, 2) or arr.shape[0] != rows or arr.dtype.kind not in "fiub":
                raise InvalidInputError(f"{what} field {name!r} of shape {arr.shape} and dtype {arr.dtype}: need "
                                        f"{rows} rows of numbers")
            out[name] = arr
        fields.append(out)
    return i, j, shift, bond_types.astype(np.int64), fields[0], fields[1]


def write_network(path, packing: Packing, i, j, shift=None, *, bond_types=None, bond_data=None, particle_data=None,
                  network_meta=None, lammps=None, format: str | None = None, force: bool = False) -> list[Path]:
    """Write a pack with bonds (``.gsd``, ``.data``/``.lmp`` or ``.vtm``), atomically.

    Parameters
    ----------
    path : str or os.PathLike
    packing : Packing
    i, j : (M,) int
        Bond ends (0-based particle indices), M >= 1.
    shift : (M, dim) int, optional
        Periodic image of ``j`` seen from ``i`` (branch ``x[j] + shift * box - x[i]``);
        default: the minimum image.
    bond_types : (M,) int >= 1, optional
        Bond type of each bond (LAMMPS bond types; GSD ``bonds/typeid + 1``). Default 1.
    bond_data, particle_data : dict of name -> (M, ...) / (N, ...) arrays, optional
        Per-bond and per-particle fields (GSD ``log/bonds``/``log/particles``, VTK cell
        and point arrays; not stored in LAMMPS files).
    network_meta : dict, optional
        JSON-able description stored with the bonds (GSD log, VTK field data, LAMMPS
        comment), returned by :func:`read_network` as ``network_meta``.
    lammps : dict, optional
        LAMMPS only: ``bond_types`` (number declared), ``density`` (float or (N,)),
        ``comments`` (header comment lines).
    format : {"gsd", "lammps", "vtm"}, optional
    force : bool, default False
        ``.vtm``: replace an existing ``<stem>_particles.vtp`` or ``<stem>_bonds.vtp`` that
        the existing index ``path`` does not name (by default such an unrelated file is
        never replaced: InvalidInputError). The index and its parts are renamed into
        place together, once all three are written.

    Returns
    -------
    list of Path
        The files written (the ``.vtm`` index and its two parts for VTK).

    Raises
    ------
    InvalidInputError
        No bonds, bad arrays, a format that cannot store bonds, a 2D pack to LAMMPS, or
        (LAMMPS) a bond longer than half the box along a periodic axis.
    """
    fmt = bond_format_for(path, format)
    i, j, shift, btype, bdata, pdata = _check(packing, i, j, shift, bond_types, bond_data, particle_data)
    meta_json = json.dumps(network_meta or {}, allow_nan=True, default=float)
    path = Path(path)
    if fmt == "gsd":
        _write_gsd(path, packing, i, j, shift, btype, bdata, pdata, meta_json)
        return [path]
    if fmt == "lammps":
        _write_lammps(path, packing, i, j, shift, btype, meta_json, lammps or {})
        return [path]
    _check_parts(path, force)
    return _write_vtm(path, packing, i, j, shift, btype, bdata, pdata, meta_json)


# ------------------------------------------------------------------------ GSD
def _gsd_image(packing, i, j, shift):
    """Image of j from i in the centred GSD frame (positions ``y = x - c L``)."""
    c = (packing.positions >= 0.5 * packing.box).astype(np.int64)
    img = shift + c[j] - c[i]
    if packing.dim == 2:
        img = np.column_stack([img, np.zeros(img.shape[0], np.int64)])
    return img


def _write_gsd(path, packing, i, j, shift, btype, bdata, pdata, meta_json):
    frame = _gsd.make_frame(packing)
    m = i.size
    n_types = int(btype.max())
    frame.bonds.N = m
    frame.bonds.types = [f"B{t}" for t in range(1, n_types + 1)]
    frame.bonds.typeid = (btype - 1).astype(np.uint32)
    frame.bonds.group = np.column_stack([i, j]).astype(np.uint32)
    frame.log["bonds/Periodic Image"] = _gsd_image(packing, i, j, shift).astype(np.int32)
    for key, fields in (("bonds", bdata), ("particles", pdata)):
        for name, arr in fields.items():
            frame.log[f"{key}/{name}"] = np.ascontiguousarray(arr.astype(np.uint8) if arr.dtype.kind == "b" else arr)
    frame.log["polypack/network"] = meta_json
    _gsd.write_frame(path, frame)


def _read_gsd(path, frame=-1):
    import gsd.hoomd

    from . import read_with_info  # the package's reader (one entry point for every pack read)

    pk, info = read_with_info(path, "gsd", frame=frame)
    with gsd.hoomd.open(str(path), "r") as traj:
        snap = traj[info["frame"]]
        m = int(snap.bonds.N)
        group = np.asarray(snap.bonds.group, dtype=np.int64).reshape(m, 2)
        typeid = np.asarray(snap.bonds.typeid, dtype=np.int64).reshape(m)
        log = dict(snap.log)
    if m and (group.min() < 0 or group.max() >= pk.n):
        raise fail(path, f"bonds/group refers to particles outside [0, {pk.n})")
    i, j = group[:, 0], group[:, 1]
    img = log.pop("bonds/Periodic Image", None)
    if img is not None:
        img = np.asarray(img, dtype=np.int64).reshape(m, 3)[:, : pk.dim]
        c = (pk.positions >= 0.5 * pk.box).astype(np.int64)
        shift = img - c[j] + c[i]
    else:
        shift = minimum_image_shift(pk, i, j)
    bdata = {k[6:]: np.asarray(v) for k, v in log.items() if k.startswith("bonds/")}
    pdata = {k[10:]: np.asarray(v) for k, v in log.items() if k.startswith("particles/")}
    meta = _json_log(log.get("polypack/network"), path)
    return pk, dict(i=i, j=j, shift=shift, bond_types=typeid + 1, bond_data=bdata, particle_data=pdata,
                    network_meta=meta, info=info)


def _json_log(text, path):
    if text is None:
        return {}
    if isinstance(text, np.ndarray):
        text = text.reshape(-1)[0] if text.dtype.kind in "UST" else text.tobytes().decode("utf-8", "replace")
    try:
        return json.loads(str(text))
    except json.JSONDecodeError:
        raise fail(path, "network record is not valid JSON") from None


# --------------------------------------------------------------------- LAMMPS
def _write_lammps(path, packing, i, j, shift, btype, meta_json, opts):
    if packing.dim != 3:
        raise InvalidInputError(
            f"LAMMPS data files hold 3D packings only; this network is {packing.dim}D (use .gsd or .vtm)"
        )
    if not np.array_equal(shift, minimum_image_shift(packing, i, j)):
        c = int(np.flatnonzero(np.any(shift != minimum_image_shift(packing, i, j), axis=1))[0])
        raise InvalidInputError(
            f"bond {c} ({i[c]}, {j[c]}) with shift {shift[c].tolist()} is not the minimum image; LAMMPS bonds always "
            "join the nearest images, so every bond must be shorter than half the box along each periodic axis"
        )
    comments = [f"polypack network: {meta_json}"] + list(opts.get("comments", ()))
    _lammps.write_data(path, packing, atom_style="bpm/sphere", density=opts.get("density", 1.0), comments=comments,
                       bonds=(btype, i, j), bond_types=opts.get("bond_types"))


def _read_lammps(path):
    from ._common import as_int_column, parse_table, read_text

    from . import read_with_info

    pk, info = read_with_info(path, "lammps")
    lines = read_text(path).split("\n")[:-1]
    meta = {}
    for line in lines[1:]:
        text = line.strip()
        if text.startswith("# polypack network:"):
            meta = _json_log(text.split(":", 1)[1], path)
            break
        if text == "Atoms" or text.startswith("Atoms "):
            break
    heads = [k for k, line in enumerate(lines) if line.split("#", 1)[0].strip() == "Bonds"]
    declared = None
    for line in lines:
        tok = line.split("#", 1)[0].split()
        if len(tok) == 2 and tok[1] == "bonds":
            declared = int(tok[0])
            break
    if not heads:
        if declared:
            raise fail(path, f"header declares {declared} bonds but there is no Bonds section")
        return pk, dict(i=np.zeros(0, np.int64), j=np.zeros(0, np.int64), shift=np.zeros((0, 3), np.int64),
                        bond_types=np.zeros(0, np.int64), bond_data={}, particle_data={}, network_meta=meta, info=info)
    first = heads[0] + 2
    rows = []
    for line in lines[first:]:
        if not line.split("#", 1)[0].strip():
            break
        rows.append(line.split("#", 1)[0])
    if declared is not None and len(rows) != declared:
        raise fail(path, f"header declares {declared} bonds but the Bonds section has {len(rows)} rows")
    table = parse_table(rows, 4, path, first + 1)
    order = np.argsort(table[:, 0], kind="stable")
    table = table[order]
    btype = as_int_column(table[:, 1], "bond type", path)
    ends = as_int_column(table[:, 2:4].ravel(), "bond atom", path).reshape(-1, 2) - 1
    if ends.size and (ends.min() < 0 or ends.max() >= pk.n):
        raise fail(path, f"a bond refers to an atom id outside 1..{pk.n}")
    i, j = ends[:, 0], ends[:, 1]
    return pk, dict(i=i, j=j, shift=minimum_image_shift(pk, i, j), bond_types=btype, bond_data={}, particle_data={},
                    network_meta=meta, info=info)


# ------------------------------------------------------------------------ VTK
def _parts(path: Path):
    return path.with_name(path.stem + "_particles.vtp"), path.with_name(path.stem + "_bonds.vtp")


def _own_parts(path: Path):
    """Part files the existing index ``path`` names (empty if there is none or it is unreadable)."""
    try:
        root = ET.fromstring(path.read_text(encoding="utf-8"))
    except (OSError, ET.ParseError, UnicodeDecodeError):
        return set()
    return {d.get("file", "") for d in root.iter("DataSet")}


def _check_parts(path: Path, force: bool):
    """An existing ``<stem>_particles.vtp`` / ``<stem>_bonds.vtp`` is replaced only when the
    existing index ``path`` names it (rewriting the same network) or ``force``."""
    if force:
        return
    own = _own_parts(path) if path.is_file() else set()
    for part in _parts(path):
        if part.exists() and part.name not in own:
            raise InvalidInputError(
                f"{part}: exists and is not part of {path.name}; writing {path.name} would replace it "
                "(choose another name, or force=True)")


def _write_vtm(path, packing, i, j, shift, btype, bdata, pdata, meta_json):
    from .._util import atomic_paths

    ppath, bpath = _parts(path)
    with atomic_paths(ppath, bpath, path) as (tp, tb, ti):
        # the index and both parts are renamed into place together, only once all are written
        _write_vtm_parts(packing, i, j, shift, btype, bdata, pdata, meta_json, ppath, bpath, tp, tb, ti)
    return [path, ppath, bpath]


def _write_vtm_parts(packing, i, j, shift, btype, bdata, pdata, meta_json, ppath, bpath, tp, tb, ti):
    prov = provenance_json(packing)
    _vtp.write_arrays(tp, packing, point_data=pdata, provenance=prov)
    m = i.size
    p3 = _vtp.points3(packing)
    box3 = np.append(packing.box, np.zeros(3 - packing.dim))
    shift3 = np.column_stack([shift, np.zeros((m, 3 - packing.dim), np.int64)]) if packing.dim == 2 else shift
    start = p3[i]
    end = p3[j] + shift3 * box3
    pts = np.empty((2 * m, 3))
    pts[0::2], pts[1::2] = start, end
    ids = np.arange(2 * m, dtype=np.int64)
    cells = (
        _vtp.data_array("id1", i + 1)
        + _vtp.data_array("id2", j + 1)
        + _vtp.data_array("shift", shift3)
        + _vtp.data_array("bond_type", btype)
        + "".join(_vtp.data_array(name, arr) for name, arr in bdata.items())
    )
    piece = (
        f'    <Piece NumberOfPoints="{2 * m}" NumberOfVerts="0" NumberOfLines="{m}" NumberOfStrips="0" '
        'NumberOfPolys="0">\n'
        "      <CellData>\n" + cells + "      </CellData>\n"
        "      <Points>\n" + _vtp.data_array("Points", pts) + "      </Points>\n"
        "      <Lines>\n" + _vtp.data_array("connectivity", ids) + _vtp.data_array("offsets", ids[1::2] + 1)
        + "      </Lines>\n    </Piece>\n"
    )
    fields = _vtp.field_data(packing, prov).replace(
        "    </FieldData>\n", _vtp.string_array("network", meta_json) + "    </FieldData>\n")
    with open(tb, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(_vtp.document(piece, fields))
        fh.flush()
        os.fsync(fh.fileno())
    index = (
        '<?xml version="1.0"?>\n'
        '<VTKFile type="vtkMultiBlockDataSet" version="1.0" byte_order="LittleEndian" header_type="UInt64">\n'
        "  <vtkMultiBlockDataSet>\n"
        f'    <DataSet index="0" name="particles" file="{ppath.name}"/>\n'
        f'    <DataSet index="1" name="bonds" file="{bpath.name}"/>\n'
        "  </vtkMultiBlockDataSet>\n</VTKFile>\n"
    )
    with open(ti, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(index)
        fh.flush()
        os.fsync(fh.fileno())


def _read_vtm(path):
    from ._common import as_int_column, read_text

    try:
        root = ET.fromstring(read_text(path))
    except ET.ParseError as exc:
        raise fail(path, f"not a well-formed XML file ({exc})") from None
    if root.tag != "VTKFile" or root.get("type") != "vtkMultiBlockDataSet":
        raise fail(path, "not a VTK multiblock (.vtm) file")
    files = {d.get("name"): path.parent / d.get("file", "") for d in root.iter("DataSet")}
    if set(files) < {"particles", "bonds"}:
        raise fail(path, f"blocks {sorted(files)}; a polypack network has 'particles' and 'bonds'")
    pk, info = _vtp.read_with_info(files["particles"])
    pdata_el = ET.fromstring(read_text(files["particles"])).find("PolyData/Piece/PointData")
    pdata = {}
    for el in pdata_el.findall("DataArray") if pdata_el is not None else []:
        if el.get("Name") not in ("radius", "diameter", "species"):
            pdata[el.get("Name")] = _cell_values(el, pk.n, files["particles"])
    broot, piece = _vtp.parse(files["bonds"])
    m = int(piece.get("NumberOfLines", "0"))
    cells = {el.get("Name"): _cell_values(el, m, files["bonds"]) for el in piece.findall("CellData/DataArray")}
    for need in ("id1", "id2"):
        if need not in cells:
            raise fail(files["bonds"], f"no cell array {need!r}")
    i = as_int_column(cells.pop("id1").astype(np.float64), "id1", files["bonds"]) - 1
    j = as_int_column(cells.pop("id2").astype(np.float64), "id2", files["bonds"]) - 1
    if m and (min(i.min(), j.min()) < 0 or max(i.max(), j.max()) >= pk.n):
        raise fail(files["bonds"], f"a bond refers to a particle id outside 1..{pk.n}")
    shift = cells.pop("shift", None)
    shift = minimum_image_shift(pk, i, j) if shift is None else shift.reshape(m, 3)[:, : pk.dim].astype(np.int64)
    btype = cells.pop("bond_type", np.ones(m)).astype(np.int64)
    meta = {}
    for el in broot.findall("PolyData/FieldData/Array"):
        if el.get("Name") == "network":
            meta = _json_log(_vtp.string_value(el, files["bonds"]), files["bonds"])
    info = dict(info, format="vtm", files=[str(files["particles"]), str(files["bonds"])])
    return pk, dict(i=i, j=j, shift=shift, bond_types=btype, bond_data=cells, particle_data=pdata,
                    network_meta=meta, info=info)


def _cell_values(el, rows, path):
    comps = int(el.get("NumberOfComponents", "1"))
    kind = el.get("type", "Float64")
    try:
        vals = np.array((el.text or "").split(), dtype=np.float64 if kind.startswith("Float") else np.int64)
    except ValueError:
        raise fail(path, f"array {el.get('Name')!r} holds a non-numeric value") from None
    if vals.size != rows * comps:
        raise fail(path, f"array {el.get('Name')!r} has {vals.size} values, expected {rows * comps}")
    return vals.reshape(rows, comps) if comps > 1 else vals


def read_maybe_network(path, format: str | None = None, frame=None):
    """``(packing, info, bonds)`` of any pack file; ``bonds`` as :func:`read_network`, or None
    when the file holds no bonds and no bond or particle fields (or is of a format without
    bonds: ``.xyz``, ``.vtp``, ``.csv``). ``format`` is a pack format name (``gsd``,
    ``lammps``, ...) or ``"vtm"``."""
    from . import read_with_info

    ext = Path(path).suffix.lower()
    name = (format or "").lower().lstrip(".")
    if name == "vtm" or (not name and ext == ".vtm"):
        pk, b = _read_vtm(Path(path))
        return pk, b["info"], b
    if name in ("", "gsd", "lammps") and (name or ext in (".gsd", ".data", ".lmp")):
        kind = name or ("gsd" if ext == ".gsd" else "lammps")
        if kind == "gsd":
            pk, b = _read_gsd(Path(path), -1 if frame is None else frame)
        else:
            pk, b = _read_lammps(Path(path))
        if len(b["i"]) or b["bond_data"] or b["particle_data"]:
            return pk, b["info"], b
        return pk, b["info"], None
    pk, info = read_with_info(path, format, **({} if frame is None else {"frame": frame}))
    return pk, info, None


def read_network(path, format: str | None = None) -> tuple[Packing, dict]:
    """Read a file written by :func:`write_network`: ``(packing, bonds)``.

    ``bonds`` holds ``i``, ``j`` (0-based), ``shift`` (M, dim), ``bond_types`` (1-based),
    ``bond_data`` and ``particle_data`` (dicts of arrays; empty for LAMMPS),
    ``network_meta`` and ``info`` (format, files). Positions, radii, box, species and the
    bond list are exact.

    Raises
    ------
    FormatError
        A missing, damaged or foreign file.
    """
    fmt = bond_format_for(path, format)
    path = Path(path)
    if fmt == "gsd":
        return _read_gsd(path)
    if fmt == "lammps":
        return _read_lammps(path)
    return _read_vtm(path)
