"""File formats: exact round trips, conventions checked with independent readers, rejections."""

import json
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import polypack as pp
from polypack import FormatError, InvalidInputError, Packing

READABLE = {"gsd": ".gsd", "xyz": ".xyz", "lammps": ".data", "csv": ".csv", "vtp": ".vtp"}
ALL_EXT = [".gsd", ".xyz", ".extxyz", ".data", ".lmp", ".vtp", ".csv"]

META = {
    "seed": {"entropy": 123456789012345678901234567890, "spawn_key": [0, 3]},
    "protocol": [{"step": "pack", "volume_fraction": 0.1, "rate": 1e-300}, {"step": "shake", "ok": True}],
    "note": 'quote " backslash \\ newline \n unicode \u00e9 -- dashes',
    "big": float(np.finfo(float).max),
    "inf": float("inf"),
    "none": None,
}


def edge_positions(box):
    """Coordinates that break naive centring: 0, subnormals, just below L, L/2, L/4 +- ulps."""
    vals = []
    for L in box:
        v = [0.0, 5e-324, 1e-300, 1e-17, np.nextafter(L, 0), np.nextafter(np.nextafter(L, 0), 0), L / 2,
             np.nextafter(L / 2, 0), np.nextafter(L / 2, L), L / 4, np.nextafter(L / 4, 0), 0.1 * L, L / 3]
        vals.append(np.array(v))
    m = min(len(v) for v in vals)
    return np.column_stack([v[:m] for v in vals])


def random_pack(rng, n=300, n_species=4, box=(7.3, 8.1, 9.7), meta=META):
    box = np.asarray(box, dtype=np.float64) * rng.uniform(0.9, 1.1, 3)  # box lengths with full mantissas
    pos = rng.random((n, 3)) * box
    edge = edge_positions(box)[:n]
    pos[: len(edge)] = edge
    radii = np.exp(rng.uniform(np.log(0.02), np.log(0.5), n))
    species = rng.integers(0, n_species, n)
    return Packing(pos, radii, box, species=species, meta=meta)


def assert_bitwise_equal(a: Packing, b: Packing):
    for name in ("positions", "radii", "box"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.shape == y.shape and x.dtype == y.dtype == np.float64, name
        assert np.array_equal(x.view(np.int64), y.view(np.int64)), f"{name} differ bitwise"
    assert np.array_equal(a.species, b.species)
    assert a.meta == b.meta
    assert a == b


# ------------------------------------------------------------- round trips
@pytest.mark.parametrize("fmt", sorted(READABLE))
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_round_trip_is_bitwise_exact(tmp_path, fmt, seed):
    pk = random_pack(np.random.default_rng(seed))
    path = tmp_path / f"pack{READABLE[fmt]}"
    pp.io.write(path, pk)
    back, info = pp.io.read_with_info(path)
    assert_bitwise_equal(pk, back)
    assert info["format"] == fmt and info["writer"] == "polypack" and info["version"] == pp.__version__


def test_edge_positions_defeat_naive_centring():
    """The test set above would catch a writer that stores x - L/2 and reads back y + L/2."""
    box = np.array([7.3, 8.1, 9.7]) * 1.0123456789
    x = edge_positions(box)
    naive = (x - box / 2) + box / 2
    assert np.any(naive != x)


@pytest.mark.parametrize("ext", [".gsd", ".extxyz", ".lmp", ".csv", ".vtp"])
def test_round_trip_other_extensions_and_edge_cases(tmp_path, ext):
    rng = np.random.default_rng(7)
    cases = [
        random_pack(rng, n=40, n_species=1, meta=None),  # no meta, one species
        random_pack(rng, n=40, n_species=3).replace(species=np.full(40, 5)),  # unused species labels
        Packing(np.zeros((0, 3)), np.zeros(0), [1.0, 2.0, 3.0], meta={"empty": True}),  # empty pack
        Packing([[0.0, 0.0, 0.0]], [0.25], 1.0),  # one sphere at the origin, diameter 0.5 (gsd default 1.0)
    ]
    for k, pk in enumerate(cases):
        path = tmp_path / f"case{k}{ext}"
        pp.io.write(path, pk)
        assert_bitwise_equal(pk, pp.io.read(path))


def test_format_override_and_overwrite(tmp_path):
    rng = np.random.default_rng(3)
    a, b = random_pack(rng, n=20), random_pack(rng, n=30)
    path = tmp_path / "pack.txt"
    pp.io.write(path, a, format="csv")
    pp.io.write(path, b, format="CSV")
    assert_bitwise_equal(b, pp.io.read(path, format="csv"))


def test_numpy_values_in_meta_are_stored_as_plain_json(tmp_path):
    pk = random_pack(np.random.default_rng(4), n=10, meta={"a": np.float64(0.1), "b": np.arange(3), "c": np.int32(7)})
    pp.io.write(tmp_path / "p.gsd", pk)
    assert pp.io.read(tmp_path / "p.gsd").meta == {"a": 0.1, "b": [0, 1, 2], "c": 7}


# ------------------------------------------------------- format conventions
def test_gsd_conventions_with_gsd_hoomd(tmp_path):
    import gsd.hoomd

    pk = random_pack(np.random.default_rng(11))
    path = tmp_path / "p.gsd"
    pp.io.write(path, pk)
    with gsd.hoomd.open(str(path), "r") as traj:
        assert len(traj) == 1
        f = traj[0]
    L = pk.box
    gbox = np.asarray(f.configuration.box, dtype=np.float64)
    assert np.all(gbox[3:] == 0)
    assert np.all(gbox[:3] >= L) and np.all(gbox[:3] - L <= 1e-7 * L)  # float32 rounded up
    assert int(f.particles.N) == pk.n
    pos = f.particles.position
    assert pos.dtype == np.float64 and f.particles.diameter.dtype == np.float64
    assert np.all(pos >= -L / 2) and np.all(pos < L / 2)  # exact box
    assert np.all(pos >= -gbox[:3] / 2) and np.all(pos < gbox[:3] / 2)  # box HOOMD/OVITO see
    shift = (pk.positions - pos) / L
    assert np.all((shift == 0) | (shift == 1))  # same point, periodic image only
    assert np.array_equal(f.particles.diameter, 2 * pk.radii)
    assert np.array_equal(f.particles.typeid, pk.species)
    assert f.particles.types == [f"S{k}" for k in range(pk.n_species)]
    assert np.array_equal(f.log["polypack/box"], L)
    record = json.loads(str(f.log["polypack/provenance"]))
    assert record["meta"] == pk.meta and record["version"] == pp.__version__
    assert float(np.asarray(f.log["polypack/volume_fraction"]).ravel()[0]) == pytest.approx(pk.volume_fraction)


def test_gsd_reads_foreign_hoomd_file_without_polypack_log(tmp_path):
    import gsd.hoomd

    rng = np.random.default_rng(5)
    f = gsd.hoomd.Frame()
    f.configuration.box = [10.0, 12.0, 14.0, 0, 0, 0]
    f.particles.N = 30
    f.particles.types = ["A", "B"]
    centred = rng.uniform(-0.5, 0.5, (30, 3)) * np.array([10.0, 12.0, 14.0])
    f.particles.position = centred.astype(np.float32)
    f.particles.diameter = rng.uniform(0.5, 1.0, 30).astype(np.float32)
    f.particles.typeid = rng.integers(0, 2, 30).astype(np.uint32)
    path = tmp_path / "hoomd.gsd"
    with gsd.hoomd.open(str(path), "w") as t:
        t.append(f)
        f.particles.position = (centred * 0.5).astype(np.float32)
        t.append(f)  # two frames: read() gives the last
    pk, info = pp.io.read_with_info(path)
    assert info["frames"] == 2 and "writer" not in info and pk.meta == {}
    L = np.array([10.0, 12.0, 14.0])
    last = (centred * 0.5).astype(np.float32).astype(np.float64)
    assert np.array_equal(pk.box, L)
    assert np.allclose(pk.positions, np.mod(last, L), rtol=0, atol=1e-12)
    assert np.array_equal(pk.radii, f.particles.diameter.astype(np.float64) / 2)
    assert np.array_equal(pk.species, f.particles.typeid)
    first = centred.astype(np.float32).astype(np.float64)
    assert np.allclose(pp.io.read(path, frame=0).positions, np.mod(first, L), rtol=0, atol=1e-12)


def test_extxyz_readable_by_ase(tmp_path):
    import ase.io as ase_io  # in the test extra: a missing install fails, never skips
    pk = random_pack(np.random.default_rng(12), n=50)
    path = tmp_path / "p.xyz"
    pp.io.write(path, pk)
    atoms = ase_io.read(str(path))
    assert len(atoms) == pk.n
    assert np.array_equal(atoms.positions, pk.positions)
    assert np.array_equal(atoms.arrays["radius"], pk.radii)
    assert np.array_equal(atoms.arrays["species_id"], pk.species)
    assert np.array_equal(atoms.cell.array, np.diag(pk.box))
    assert atoms.pbc.all()
    assert json.loads(atoms.info["polypack_provenance"])["meta"] == json.loads(json.dumps(pk.meta))


def test_extxyz_foreign_file_uses_symbols_as_species(tmp_path):
    path = tmp_path / "foreign.xyz"
    path.write_text(
        '3\nProperties=species:S:1:pos:R:3:radius:R:1 Lattice="5 0 0 0 5 0 0 0 5" pbc="T T T"\n'
        "Si 1 1 1 0.5\nO 2 2 2 0.25\nSi 3 3 3 0.5\n"
    )
    pk = pp.io.read(path)
    assert pk.species.tolist() == [0, 1, 0] and pk.radii.tolist() == [0.5, 0.25, 0.5]
    assert pk.box.tolist() == [5.0, 5.0, 5.0]


def test_lammps_data_layout(tmp_path):
    pk = random_pack(np.random.default_rng(13), n=25)
    path = tmp_path / "p.data"
    pp.io.write(path, pk)
    lines = path.read_text().splitlines()
    assert f"{pk.n} atoms" in lines and f"{pk.n_species} atom types" in lines
    assert "Atoms # sphere" in lines
    for axis, L in zip("xyz", pk.box):
        bounds = [ln.split() for ln in lines if ln.endswith(f"{axis}lo {axis}hi")]
        assert len(bounds) == 1 and float(bounds[0][0]) == 0 and float(bounds[0][1]) == L
    start = lines.index("Atoms # sphere") + 2
    rows = np.loadtxt(lines[start:])
    assert rows.shape == (pk.n, 7)
    assert np.array_equal(rows[:, 0], np.arange(1, pk.n + 1))
    assert np.array_equal(rows[:, 1], pk.species + 1)  # 1-based types
    assert np.array_equal(rows[:, 2], 2 * pk.radii)
    assert np.array_equal(rows[:, 4:7], pk.positions)


def test_lammps_reader_accepts_image_flags_and_unsorted_ids(tmp_path):
    path = tmp_path / "lmp.data"
    path.write_text(
        "LAMMPS data file via write_data\n\n2 atoms\n2 atom types\n\n-1 3 xlo xhi\n0 4 ylo yhi\n0 4 zlo zhi\n\n"
        "Masses\n\n1 1.0\n2 1.0\n\nAtoms # sphere\n\n2 2 0.5 1 0.5 1 1 0 0 0\n1 1 1.0 1 -0.5 1 1 1 0 0\n\n"
        "Velocities\n\n1 0 0 0 0 0 0\n2 0 0 0 0 0 0\n"
    )
    pk = pp.io.read(path)
    assert pk.radii.tolist() == [0.5, 0.25] and pk.species.tolist() == [0, 1]
    assert pk.box.tolist() == [4.0, 4.0, 4.0]
    assert np.allclose(pk.positions, [[0.5, 1, 1], [1.5, 1, 1]])  # -0.5 - (-1) + 4 image -> 0.5 (mod 4)


def test_csv_layout_readable_by_numpy(tmp_path):
    pk = random_pack(np.random.default_rng(14), n=25)
    path = tmp_path / "p.csv"
    pp.io.write(path, pk)
    rows = np.loadtxt(path, delimiter=",", skiprows=5)
    assert np.array_equal(rows[:, :3], pk.positions) and np.array_equal(rows[:, 3], pk.radii)
    assert np.array_equal(rows[:, 4], pk.species)
    head = path.read_text().splitlines()[:5]
    assert head[2] == "# box: " + ",".join(repr(float(v)) for v in pk.box)
    assert head[4] == "x,y,z,radius,species"


def test_vtp_is_valid_polydata(tmp_path):
    pk = random_pack(np.random.default_rng(15), n=40)
    path = tmp_path / "p.vtp"
    pp.io.write(path, pk)
    root = ET.parse(path).getroot()
    assert root.tag == "VTKFile" and root.get("type") == "PolyData"
    piece = root.find("PolyData/Piece")
    assert int(piece.get("NumberOfPoints")) == pk.n == int(piece.get("NumberOfVerts"))

    def array(xpath, name):
        el = [a for a in root.findall(xpath + "/DataArray") if a.get("Name") == name]
        assert len(el) == 1, name
        return el[0], np.array(el[0].text.split(), dtype=float)

    el, pts = array("PolyData/Piece/Points", "Points")
    assert el.get("NumberOfComponents") == "3"
    assert np.array_equal(pts.reshape(-1, 3), pk.positions)
    assert np.array_equal(array("PolyData/Piece/PointData", "radius")[1], pk.radii)
    assert np.array_equal(array("PolyData/Piece/PointData", "species")[1], pk.species)
    conn = array("PolyData/Piece/Verts", "connectivity")[1]
    offs = array("PolyData/Piece/Verts", "offsets")[1]
    assert np.array_equal(conn, np.arange(pk.n)) and np.array_equal(offs, np.arange(1, pk.n + 1))
    assert np.array_equal(array("PolyData/FieldData", "box")[1], pk.box)


def test_vtp_layout_lets_ovito_detect_the_format(tmp_path):
    """OVITO's VTP particle reader detects a file only if the XML declaration is followed
    directly by <VTKFile type="PolyData"> (no comment, the provenance used to sit there) and
    the first element below <PolyData> is the <Piece> (field data must come after it)."""
    pk = random_pack(np.random.default_rng(17), n=12)
    path = tmp_path / "p.vtp"
    pp.io.write(path, pk)
    events = [(ev, el.tag) for ev, el in ET.iterparse(path, events=("start", "comment"))][:4]
    assert events[:3] == [("start", "VTKFile"), ("start", "PolyData"), ("start", "Piece")]
    head = path.read_text().split("\n", 2)
    assert head[0] == '<?xml version="1.0"?>' and head[1].startswith('<VTKFile type="PolyData"')
    assert "<!--" not in path.read_text()
    piece = ET.parse(path).getroot().find("PolyData/Piece")
    assert piece.get("NumberOfPoints") == piece.get("NumberOfVerts") and piece.get("NumberOfLines") == "0"


# -------------------------------------------------------------- rejections
def test_unknown_extension_lists_allowed(tmp_path):
    pk = random_pack(np.random.default_rng(0), n=5)
    with pytest.raises(InvalidInputError) as exc:
        pp.io.write(tmp_path / "pack.pdb", pk)
    for ext in ALL_EXT:
        assert ext in str(exc.value)
    with pytest.raises(InvalidInputError, match=r"\.gsd"):
        pp.io.read(tmp_path / "pack")
    with pytest.raises(InvalidInputError, match="format='hdf5'"):
        pp.io.write(tmp_path / "pack.gsd", pk, format="hdf5")
    with pytest.raises(InvalidInputError, match="Packing"):
        pp.io.write(tmp_path / "pack.gsd", {"positions": []})
    assert not list(tmp_path.iterdir())


def _damaged_files(tmp_path, fmt):
    """(label, path) pairs: empty, cut in half, last line cut, garbage, other formats."""
    pk = random_pack(np.random.default_rng(21), n=60)
    ext = READABLE[fmt]
    good = tmp_path / f"good{ext}"
    pp.io.write(good, pk)
    raw = good.read_bytes()
    out = {}

    def put(label, data):
        p = tmp_path / f"{label}{ext}"
        p.write_bytes(data)
        out[label] = p

    put("empty", b"")
    put("blank", b"\n\n  \n")
    put("half", raw[: len(raw) // 2])
    put("minus_one_line", raw[: raw.rstrip(b"\n").rfind(b"\n") + 1])
    put("minus_one_byte", raw[:-2] + b"\n" if fmt != "gsd" else raw[:-1])
    put("garbage", bytes(np.random.default_rng(0).integers(0, 256, 4000, dtype=np.uint8)))
    for other, oext in READABLE.items():
        if other != fmt:
            src = tmp_path / f"src_{other}{oext}"
            pp.io.write(src, pk)
            put(f"foreign_{other}", src.read_bytes())
    out["missing"] = tmp_path / f"missing{ext}"
    return out


@pytest.mark.parametrize("fmt", sorted(READABLE))
def test_damaged_or_foreign_files_raise_format_error(tmp_path, fmt):
    for label, path in _damaged_files(tmp_path, fmt).items():
        if label == "minus_one_byte" and fmt != "gsd":
            continue  # cutting the species digit of the last row is still a valid file; see next test
        with pytest.raises(FormatError) as exc:
            pp.io.read(path)
        msg = str(exc.value)
        assert str(path) in msg, (label, msg)
        assert "\n" not in msg, (label, msg)


@pytest.mark.parametrize("fmt", ["xyz", "lammps", "csv"])
def test_text_file_cut_mid_number_is_detected(tmp_path, fmt):
    pk = random_pack(np.random.default_rng(22), n=30)
    path = tmp_path / f"p{READABLE[fmt]}"
    pp.io.write(path, pk)
    raw = path.read_bytes()
    path.write_bytes(raw[:-5])  # last row cut inside a number: no final newline
    with pytest.raises(FormatError, match="truncated"):
        pp.io.read(path)


def test_invalid_contents_raise_format_error(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("# box: 4,4,4\nx,y,z,radius,species\n1,1,1,-0.5,0\n")
    with pytest.raises(FormatError, match="radius"):
        pp.io.read(path)
    path.write_text("# box: 4,4,4\nx,y,z,radius,species\n1,1,1,0.5,1.5\n")
    with pytest.raises(FormatError, match="species"):
        pp.io.read(path)
    path = tmp_path / "tilt.xyz"
    path.write_text('1\nLattice="4 1 0 0 4 0 0 0 4" Properties=species:S:1:pos:R:3:radius:R:1\nX 1 1 1 0.5\n')
    with pytest.raises(FormatError, match="orthorhombic"):
        pp.io.read(path)
    path = tmp_path / "noradius.xyz"
    path.write_text('1\nLattice="4 0 0 0 4 0 0 0 4" Properties=species:S:1:pos:R:3\nX 1 1 1\n')
    with pytest.raises(FormatError, match="radius"):
        pp.io.read(path)
    path = tmp_path / "style.data"
    path.write_text("t\n\n1 atoms\n1 atom types\n0 4 xlo xhi\n0 4 ylo yhi\n0 4 zlo zhi\n\nAtoms # atomic\n\n1 1 1 1 1\n")
    with pytest.raises(FormatError, match="atomic"):
        pp.io.read(path)


# ------------------------------------------------------------ atomic writes
@pytest.mark.parametrize("ext", [".gsd", ".xyz", ".data", ".csv", ".vtp"])
def test_interrupted_write_leaves_old_file_and_no_temp(tmp_path, monkeypatch, ext):
    import gsd.hoomd

    rng = np.random.default_rng(30)
    old, new = random_pack(rng, n=20), random_pack(rng, n=50)
    path = tmp_path / f"p{ext}"
    pp.io.write(path, old)
    before = path.read_bytes()

    class Interrupted(Exception):
        pass

    real_append = gsd.hoomd.HOOMDTrajectory.append

    def append_then_fail(self, frame):  # the data reaches the temporary file, then we die
        real_append(self, frame)
        raise Interrupted

    def fsync_fail(fd):
        raise Interrupted

    monkeypatch.setattr(gsd.hoomd.HOOMDTrajectory, "append", append_then_fail)
    monkeypatch.setattr(os, "fsync", fsync_fail)
    with pytest.raises(Interrupted):
        pp.io.write(path, new)
    with pytest.raises(Interrupted):
        pp.io.write(tmp_path / f"fresh{ext}", new)
    monkeypatch.undo()
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]
    if ext != ".vtp":
        assert_bitwise_equal(old, pp.io.read(path))


def test_written_files_get_normal_permissions(tmp_path):
    from polypack._util import _umask

    pk = random_pack(np.random.default_rng(31), n=10)
    fresh = tmp_path / "fresh.gsd"
    pp.io.write(fresh, pk)
    assert fresh.stat().st_mode & 0o777 == 0o666 & ~_umask()  # not mkstemp's private 0600
    kept = tmp_path / "kept.csv"
    pp.io.write(kept, pk)
    os.chmod(kept, 0o640)
    pp.io.write(kept, pk)
    assert kept.stat().st_mode & 0o777 == 0o640


def test_vtp_reads_in_vtk(tmp_path):
    """ParaView's own reader (vtkXMLPolyDataReader; ``vtk`` is in the test extra, so this runs in CI)."""
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy

    pk = random_pack(np.random.default_rng(16), n=40)
    path = tmp_path / "p.vtp"
    pp.io.write(path, pk)
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    assert reader.GetErrorCode() == 0
    data = reader.GetOutput()
    assert data.GetNumberOfPoints() == pk.n == data.GetNumberOfVerts()
    assert np.array_equal(vtk_to_numpy(data.GetPoints().GetData()), pk.positions)
    assert np.array_equal(vtk_to_numpy(data.GetPointData().GetArray("radius")), pk.radii)
    assert np.array_equal(vtk_to_numpy(data.GetPointData().GetArray("species")), pk.species)
    assert np.array_equal(vtk_to_numpy(data.GetFieldData().GetArray("box")).ravel(), pk.box)
    prov = data.GetFieldData().GetAbstractArray("provenance")
    assert prov.GetNumberOfValues() == 1
    assert json.loads(prov.GetValue(0)) == json.loads(pp.io._common.provenance_json(pk))
    assert list(vtk_to_numpy(data.GetFieldData().GetArray("periodic")).ravel()) == [1, 1, 1]


def test_vtp_2d_and_walls_round_trip(tmp_path):
    rng = np.random.default_rng(18)
    disks = Packing(rng.random((30, 2)) * [6.0, 5.0], rng.uniform(0.05, 0.2, 30), [6.0, 5.0],
                    species=rng.integers(0, 2, 30), meta={"d": 2})
    walls = Packing(rng.uniform(0.5, 4.5, (20, 3)), np.full(20, 0.3), [5.0, 5.0, 5.0], periodic=(True, True, False))
    for k, pk in enumerate((disks, walls)):
        path = tmp_path / f"p{k}.vtp"
        pp.io.write(path, pk)
        back = pp.io.read(path)
        assert_bitwise_equal(pk, back)
        assert back.periodic == pk.periodic and back.dim == pk.dim

