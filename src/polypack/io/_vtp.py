"""VTK XML PolyData (``.vtp``) for ParaView; written only.

One vertex cell per sphere (so points render without a filter), point arrays
``radius``, ``diameter`` and ``species`` (use Glyph > Sphere scaled by ``diameter``,
or Point Gaussian with ``radius``), the box lengths as field data ``box`` and the
provenance JSON in an XML comment. Plain ASCII XML, no VTK dependency.
"""

from __future__ import annotations

import numpy as np

from .._util import atomic_open
from ..packing import Packing
from ._common import FLOAT, format_rows, provenance_json



def _array(name, vtk_type, columns, fmt, components=1, indent="        ", extra="") -> str:
    """One ASCII ``<DataArray>`` element; ``columns`` are the components, one row per tuple."""
    rows = format_rows(columns, [fmt] * len(columns))
    return (
        f'{indent}<DataArray type="{vtk_type}" Name="{name}" NumberOfComponents="{components}"{extra} '
        f'format="ascii">\n'
        f"{rows}{indent}</DataArray>\n"
    )


def write(path, packing: Packing) -> None:
    """Write ``packing`` as VTK PolyData XML (atomically)."""
    n = packing.n
    p = packing.positions
    if packing.dim == 2:  # disks in the z = 0 plane; box [Lx, Ly, 0]
        p = np.column_stack([p, np.zeros(n)])
    box = np.append(packing.box, np.zeros(3 - packing.dim))
    # '--' may not appear inside an XML comment
    provenance = provenance_json(packing).replace("--", "-\\u002d")
    ids = np.arange(n, dtype=np.int64)
    text = (
        '<?xml version="1.0"?>\n'
        f"<!-- polypack provenance: {provenance} -->\n"
        '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">\n'
        "  <PolyData>\n"
        "    <FieldData>\n"
        + _array("box", "Float64", [box[k : k + 1] for k in range(3)], FLOAT, 3, "      ", ' NumberOfTuples="1"')
        + "    </FieldData>\n"
        f'    <Piece NumberOfPoints="{n}" NumberOfVerts="{n}" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="0">\n'
        '      <PointData Scalars="radius">\n'
        + _array("radius", "Float64", [packing.radii], FLOAT)
        + _array("diameter", "Float64", [2.0 * packing.radii], FLOAT)
        + _array("species", "Int64", [packing.species], "%d")
        + "      </PointData>\n      <Points>\n"
        + _array("Points", "Float64", [p[:, 0], p[:, 1], p[:, 2]], FLOAT, 3)
        + "      </Points>\n      <Verts>\n"
        + _array("connectivity", "Int64", [ids], "%d")
        + _array("offsets", "Int64", [ids + 1], "%d")
        + "      </Verts>\n    </Piece>\n  </PolyData>\n</VTKFile>\n"
    )
    with atomic_open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(text)
