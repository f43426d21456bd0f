"""VTK XML PolyData (``.vtp``) for ParaView and OVITO; read back exactly.

One vertex cell per sphere (so points render without a filter), point arrays
``radius``, ``diameter`` and ``species`` (ParaView: Glyph > Sphere scaled by
``diameter``, or the Point Gaussian representation with ``radius``; OVITO maps
``radius`` onto its Radius property). Field data, after the ``<Piece>``: the box
lengths ``box`` (3 components; ``Lz = 0`` for 2D disks in the ``z = 0`` plane), the
per-axis ``periodic`` flags and the provenance JSON as a one-value string array
``provenance``. Plain ASCII XML with floats written as their shortest exact decimal,
no VTK dependency.

Two details make OVITO detect the format on its own (its VTP particle reader checks
that the XML declaration is followed directly by ``<VTKFile type="PolyData">`` and
that the first element it meets below ``<PolyData>`` is the ``<Piece>``): nothing
(no comment) may sit before the root element, and the field data must follow the
piece. VTK's reader accepts field data in either place.

:func:`write_arrays` is the general writer used for bonded networks (extra per-point
arrays, line cells); see :mod:`polypack.io.bonds`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from .._util import atomic_open
from ..packing import Packing
from ._common import FLOAT, build_packing, fail, format_rows, parse_pbc, parse_provenance, provenance_json

# OVITO parses only Int32, Int64, Float32 and Float64 arrays: booleans go out as Int64
_VTK_TYPES = {"f": "Float64", "i": "Int64", "u": "Int64", "b": "Int64"}


def _array(name, vtk_type, columns, fmt, components=1, indent="        ", extra="") -> str:
    """One ASCII ``<DataArray>`` element; ``columns`` are the components, one row per tuple."""
    rows = format_rows(columns, [fmt] * len(columns))
    return (
        f'{indent}<DataArray type="{vtk_type}" Name="{name}" NumberOfComponents="{components}"{extra} '
        f'format="ascii">\n'
        f"{rows}{indent}</DataArray>\n"
    )


def data_array(name, values, indent="        ") -> str:
    """A ``<DataArray>`` for a (n,) or (n, k) numeric array (float64; integers and booleans as int64)."""
    arr = np.asarray(values)
    kind = arr.dtype.kind
    if kind not in _VTK_TYPES:
        raise TypeError(f"array {name!r} of dtype {arr.dtype} cannot be written to VTK")
    if kind == "f":
        arr, fmt = arr.astype(np.float64), FLOAT
    else:
        arr, fmt = arr.astype(np.int64), "%d"
    cols = [arr] if arr.ndim == 1 else [arr[:, k] for k in range(arr.shape[1])]
    return _array(name, _VTK_TYPES[kind], cols, fmt, len(cols), indent)


def string_array(name, text: str, indent="      ") -> str:
    """A one-value VTK string array (ASCII format: byte codes, NUL-terminated)."""
    codes = " ".join(str(b) for b in text.encode("utf-8")) + " 0"
    return (
        f'{indent}<Array type="String" Name="{name}" NumberOfTuples="1" format="ascii">\n'
        f"{indent}  {codes}\n{indent}</Array>\n"
    )


def points3(packing: Packing) -> np.ndarray:
    """Positions as (n, 3) (2D disks in the ``z = 0`` plane)."""
    p = packing.positions
    if packing.dim == 2:
        p = np.column_stack([p, np.zeros(packing.n)])
    return p


def field_data(packing: Packing, provenance: str) -> str:
    """``<FieldData>`` with box, periodic flags and provenance (placed after the piece)."""
    box = np.append(packing.box, np.zeros(3 - packing.dim))
    flags = np.array(packing.periodic, dtype=np.int64)
    return (
        "    <FieldData>\n"
        + _array("box", "Float64", [box[k : k + 1] for k in range(3)], FLOAT, 3, "      ", ' NumberOfTuples="1"')
        + _array("periodic", "Int64", [flags[k : k + 1] for k in range(flags.size)], "%d", flags.size, "      ",
                 ' NumberOfTuples="1"')
        + string_array("provenance", provenance)
        + "    </FieldData>\n"
    )


def document(piece: str, fields: str) -> str:
    """A PolyData document: XML declaration, then the root element directly (OVITO needs that)."""
    return (
        '<?xml version="1.0"?>\n'
        '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">\n'
        "  <PolyData>\n" + piece + fields + "  </PolyData>\n</VTKFile>\n"
    )


def write_arrays(path, packing: Packing, point_data=None, provenance: str | None = None) -> None:
    """Particles as vertices with point arrays ``radius``, ``diameter``, ``species`` and ``point_data``.

    ``point_data`` maps names to (n,) or (n, k) arrays (NaN allowed), written after the
    standard arrays. Written atomically.
    """
    n = packing.n
    ids = np.arange(n, dtype=np.int64)
    extra = "".join(data_array(name, values) for name, values in (point_data or {}).items())
    p = points3(packing)
    piece = (
        f'    <Piece NumberOfPoints="{n}" NumberOfVerts="{n}" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="0">\n'
        '      <PointData Scalars="radius">\n'
        + _array("radius", "Float64", [packing.radii], FLOAT)
        + _array("diameter", "Float64", [2.0 * packing.radii], FLOAT)
        + _array("species", "Int64", [packing.species], "%d")
        + extra
        + "      </PointData>\n      <Points>\n"
        + _array("Points", "Float64", [p[:, 0], p[:, 1], p[:, 2]], FLOAT, 3)
        + "      </Points>\n      <Verts>\n"
        + _array("connectivity", "Int64", [ids], "%d")
        + _array("offsets", "Int64", [ids + 1], "%d")
        + "      </Verts>\n    </Piece>\n"
    )
    text = document(piece, field_data(packing, provenance or provenance_json(packing)))
    with atomic_open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(text)


def write(path, packing: Packing) -> None:
    """Write ``packing`` as VTK PolyData XML (atomically)."""
    write_arrays(path, packing)


# ------------------------------------------------------------------ reading
def _numbers(el, path, dtype=float) -> np.ndarray:
    try:
        return np.array((el.text or "").split(), dtype=dtype)
    except ValueError:
        raise fail(path, f"array {el.get('Name')!r} holds a non-numeric value") from None


def _find(parent, name, path, tag="DataArray"):
    hits = [a for a in parent.findall(tag) if a.get("Name") == name] if parent is not None else []
    if len(hits) != 1:
        raise fail(path, f"expected one array named {name!r}, found {len(hits)}")
    return hits[0]


def parse(path):
    """Parse a PolyData file: ``(root, piece)``; FormatError on anything else."""
    from ._common import read_text

    text = read_text(path)
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise fail(path, f"not a well-formed XML file ({exc}); truncated or another format?") from None
    if root.tag != "VTKFile" or root.get("type") != "PolyData":
        raise fail(path, f"root element is <{root.tag} type={root.get('type')!r}>, expected a VTK PolyData file")
    pieces = root.findall("PolyData/Piece")
    if len(pieces) != 1:
        raise fail(path, f"{len(pieces)} <Piece> elements; polypack reads single-piece files")
    return root, pieces[0]


def string_value(el, path) -> str:
    """The first value of an ASCII VTK string array."""
    codes = _numbers(el, path, dtype=np.int64)
    end = np.flatnonzero(codes == 0)
    codes = codes[: end[0]] if end.size else codes
    if codes.size and (codes.min() < 0 or codes.max() > 255):
        raise fail(path, f"string array {el.get('Name')!r} holds values outside 0..255")
    return bytes(codes.astype(np.uint8).tolist()).decode("utf-8", "replace")


def read_with_info(path, frame: int = -1) -> tuple[Packing, dict]:
    """Read a ``.vtp`` written by polypack (or points with a ``radius`` array); ``(packing, info)``."""
    if isinstance(frame, bool) or frame not in (0, -1):
        raise fail(path, f"frame {frame!r} requested but the file has 1 frame")
    root, piece = parse(path)
    try:
        n = int(piece.get("NumberOfPoints"))
    except (TypeError, ValueError):
        raise fail(path, f"NumberOfPoints is {piece.get('NumberOfPoints')!r}; expected an integer") from None
    pts = _numbers(_find(piece.find("Points"), "Points", path), path)
    if pts.size != 3 * n:
        raise fail(path, f"NumberOfPoints is {n} but the Points array has {pts.size} values (expected {3 * n})")
    pts = pts.reshape(n, 3)
    pdata = piece.find("PointData")
    radii = _numbers(_find(pdata, "radius", path), path)
    if radii.size != n:
        raise fail(path, f"NumberOfPoints is {n} but the radius array has {radii.size} values")
    species = None
    if pdata is not None and any(a.get("Name") == "species" for a in pdata.findall("DataArray")):
        sp = _numbers(_find(pdata, "species", path), path)
        if sp.size != n:
            raise fail(path, f"NumberOfPoints is {n} but the species array has {sp.size} values")
        from ._common import as_int_column

        species = as_int_column(sp, "species", path)
    fdata = root.find("PolyData/FieldData")
    if fdata is None:
        raise fail(path, "no <FieldData> with the box; not a polypack VTP file")
    box3 = _numbers(_find(fdata, "box", path), path)
    if box3.shape != (3,):
        raise fail(path, f"field 'box' has {box3.size} values, expected 3")
    dim = 2 if box3[2] == 0 else 3
    if dim == 2 and np.any(pts[:, 2] != 0):
        raise fail(path, "box has Lz = 0 (2-D) but some points have z != 0")
    periodic = None
    if any(a.get("Name") == "periodic" for a in fdata.findall("DataArray")):
        flags = " ".join("T" if v else "F" for v in _numbers(_find(fdata, "periodic", path), path))
        periodic = parse_pbc(flags, path)
        if len(periodic) != dim:
            raise fail(path, f"field 'periodic' has {len(periodic)} flags for a {dim}-D box")
    meta, info = {}, {}
    prov = [a for a in fdata.findall("Array") if a.get("Name") == "provenance"]
    if prov:
        meta, info = parse_provenance(string_value(prov[0], path), path)
    info.update(format="vtp", frames=1, frame=0)
    pk = build_packing(path, pts[:, :dim], radii, box3[:dim], species=species, meta=meta, periodic=periodic)
    return pk, info
