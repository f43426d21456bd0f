"""Bonded networks on disk (polypack.io.bonds): exact round trips, layouts the clients rely on, rejections."""

import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import polypack as pp
from polypack import FormatError, InvalidInputError, Packing
from polypack.io import bonds as iob
from polypack.mechanics import BondNetwork

EXTS = [".gsd", ".vtm", ".data"]


@pytest.fixture(scope="module")
def bimodal():
    sizes = pp.psd.Bimodal(size_ratio=0.5, volume_ratio=0.5, d_large=1.0).sample(n=160, seed=3)
    return pp.pack(sizes, volume_fraction=0.6, seed=3)


@pytest.fixture(scope="module")
def net(bimodal):
    return BondNetwork.from_packing(bimodal, epsilon=0.03)


def fields(pk, m, rng):
    bdata = {"force": rng.normal(size=(m, 3)), "state": rng.integers(0, 3, m), "broken": rng.random(m) < 0.5,
             "gap": np.where(rng.random(m) < 0.1, np.nan, rng.random(m))}
    pdata = {"u": np.where(rng.random((pk.n, 3)) < 0.05, np.nan, rng.normal(size=(pk.n, 3))),
             "bonds": rng.integers(0, 9, pk.n)}
    return bdata, pdata


def assert_same_packing(a: Packing, b: Packing):
    for name in ("positions", "radii", "box"):
        assert np.array_equal(getattr(a, name).view(np.int64), getattr(b, name).view(np.int64)), name
    assert np.array_equal(a.species, b.species) and a.meta == b.meta and a.periodic == b.periodic


@pytest.mark.parametrize("ext", EXTS)
def test_round_trip_bonds_and_fields_exactly(tmp_path, bimodal, net, ext):
    rng = np.random.default_rng(0)
    bdata, pdata = fields(bimodal, net.n_bonds, rng)
    types = rng.integers(1, 4, net.n_bonds)
    path = tmp_path / f"net{ext}"
    written = iob.write_network(path, bimodal, net.i, net.j, net.shift, bond_types=types, bond_data=bdata,
                                particle_data=pdata, network_meta={"note": "x", "k": [1, 2]})
    assert all(p.exists() for p in written) and written[0] == path
    pk, b = iob.read_network(path)
    assert_same_packing(bimodal, pk)
    assert np.array_equal(b["i"], net.i) and np.array_equal(b["j"], net.j)
    assert np.array_equal(b["shift"], net.shift)  # LAMMPS: the minimum image, = net.shift here
    assert np.array_equal(b["bond_types"], types)
    assert b["network_meta"] == {"note": "x", "k": [1, 2]}
    if ext == ".data":
        assert b["bond_data"] == {} and b["particle_data"] == {}
        return
    for want, got in ((bdata, b["bond_data"]), (pdata, b["particle_data"])):
        assert set(want) <= set(got)
        for k, v in want.items():
            np.testing.assert_array_equal(np.asarray(got[k]).astype(np.float64), v.astype(np.float64), err_msg=k)


def test_shift_that_is_not_the_minimum_image_survives_gsd_and_vtm(tmp_path):
    """A bond to a farther image (from_pairs allows it): stored exactly, not re-derived."""
    pk = Packing([[0.5, 0.5, 0.5], [2.5, 0.5, 0.5], [3.6, 0.5, 0.5]], [0.4, 0.4, 0.4], [4.0, 4.0, 4.0])
    i, j, shift = np.array([0, 1, 0]), np.array([1, 2, 2]), np.array([[0, 0, 0], [0, 0, 0], [-1, 0, 1]])
    for ext in (".gsd", ".vtm"):
        iob.write_network(tmp_path / f"n{ext}", pk, i, j, shift)
        _, b = iob.read_network(tmp_path / f"n{ext}")
        assert np.array_equal(b["shift"], shift)
    with pytest.raises(InvalidInputError, match="minimum image"):
        iob.write_network(tmp_path / "n.data", pk, i, j, shift)


def test_gsd_periodic_image_is_the_centred_frame_image(tmp_path, bimodal, net):
    """OVITO draws a GSD bond from y_i to y_j + image * L (y the centred positions)."""
    import gsd.hoomd

    path = tmp_path / "n.gsd"
    iob.write_network(path, bimodal, net.i, net.j, net.shift)
    with gsd.hoomd.open(str(path)) as t:
        f = t[0]
    y = np.asarray(f.particles.position)
    img = np.asarray(f.log["bonds/Periodic Image"])
    g = np.asarray(f.bonds.group).astype(np.int64)
    b = y[g[:, 1]] + img * bimodal.box - y[g[:, 0]]
    np.testing.assert_allclose(b, net.branch, atol=1e-12)
    assert np.any(img != net.shift)  # the centring changes some images: the conversion is exercised


def test_vtk_layout_for_paraview_and_ovito(tmp_path, bimodal, net):
    path = tmp_path / "n.vtm"
    files = iob.write_network(path, bimodal, net.i, net.j, net.shift)
    assert [p.name for p in files] == ["n.vtm", "n_particles.vtp", "n_bonds.vtp"]
    root = ET.parse(path).getroot()
    assert root.get("type") == "vtkMultiBlockDataSet"
    assert [d.get("file") for d in root.iter("DataSet")] == ["n_particles.vtp", "n_bonds.vtp"]
    broot = ET.parse(files[2]).getroot()
    piece = broot.find("PolyData/Piece")
    m = net.n_bonds
    # OVITO's contact-network reader: no vertices, two points per line, cell arrays id1 and id2
    assert (piece.get("NumberOfVerts"), piece.get("NumberOfLines"), piece.get("NumberOfPoints")) == \
        ("0", str(m), str(2 * m))
    names = [a.get("Name") for a in piece.findall("CellData/DataArray")]
    assert names[:2] == ["id1", "id2"]
    pts = np.array(piece.find("Points/DataArray").text.split(), float).reshape(-1, 3)
    # each line runs from x_i to the image of x_j: its length is the bond length (periodic bonds drawn whole)
    np.testing.assert_allclose(pts[0::2], bimodal.positions[net.i], rtol=0, atol=0)
    np.testing.assert_allclose(np.linalg.norm(pts[1::2] - pts[0::2], axis=1), net.length, rtol=1e-14)
    assert [el.tag for el in broot.iter()][:3] == ["VTKFile", "PolyData", "Piece"]


def test_vtk_reads_the_multiblock(tmp_path, bimodal, net):
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy

    path = tmp_path / "n.vtm"
    iob.write_network(path, bimodal, net.i, net.j, net.shift, bond_data={"f": np.arange(net.n_bonds, dtype=float)})
    r = vtk.vtkXMLMultiBlockDataReader()
    r.SetFileName(str(path))
    r.Update()
    mb = r.GetOutput()
    assert mb.GetNumberOfBlocks() == 2
    parts, lines = mb.GetBlock(0), mb.GetBlock(1)
    assert np.array_equal(vtk_to_numpy(parts.GetPoints().GetData()), bimodal.positions)
    cd = lines.GetCellData()
    assert lines.GetNumberOfLines() == net.n_bonds
    assert np.array_equal(vtk_to_numpy(cd.GetArray("id1")) - 1, net.i)
    assert np.array_equal(vtk_to_numpy(cd.GetArray("id2")) - 1, net.j)
    assert np.array_equal(vtk_to_numpy(cd.GetArray("f")), np.arange(net.n_bonds))


@pytest.mark.parametrize("what", ["pack", "network"])
def test_lammps_header_fits_ovito_detection(tmp_path, bimodal, net, what):
    """OVITO reads 1024 characters of the title and wants the 'atoms' line within 20 more lines
    (a generated pack's provenance is tens of kB: it must not sit in the title)."""
    path = tmp_path / "p.data"
    pk = bimodal.replace(meta={"long": "x" * 50000})
    if what == "pack":
        pp.io.write(path, pk)
    else:
        iob.write_network(path, pk, net.i, net.j, net.shift, lammps={"comments": ["c"] * 5})
    lines = path.read_text().split("\n")
    assert len(lines[0]) < 1024
    k = next(n for n, line in enumerate(lines[1:], 1) if line.split("#")[0].strip().endswith("atoms"))
    assert k <= 20
    back = pp.io.read(path)
    assert back.meta == pk.meta and back == pk


def test_lammps_bpm_sphere_columns(tmp_path, bimodal, net):
    path = tmp_path / "n.data"
    iob.write_network(path, bimodal, net.i, net.j, lammps={"density": 2.5})
    text = path.read_text().split("\n")
    atoms = text.index("Atoms # bpm/sphere")
    row = text[atoms + 2].split()
    assert len(row) == 8  # id molecule type diameter density x y z (LAMMPS atom_vec_bpm_sphere)
    assert row[:5] == ["1", "0", str(bimodal.species[0] + 1), repr(float(2 * bimodal.radii[0])), "2.5"]
    assert f"{net.n_bonds} bonds" in text
    b = text.index("Bonds")
    first = text[b + 2].split()
    assert first == ["1", "1", str(net.i[0] + 1), str(net.j[0] + 1)]


def test_2d_network_round_trips_in_gsd_and_vtm_and_lammps_refuses(tmp_path):
    rng = np.random.default_rng(4)
    pts = np.array([[x, y] for x in range(6) for y in range(5)], float) + 0.5
    pk = Packing(pts + rng.uniform(-0.01, 0.01, pts.shape), np.full(30, 0.5), [6.0, 5.0])
    net2 = BondNetwork.from_packing(pk, epsilon=0.05)
    for ext in (".gsd", ".vtm"):
        iob.write_network(tmp_path / f"n{ext}", pk, net2.i, net2.j, net2.shift)
        back, b = iob.read_network(tmp_path / f"n{ext}")
        assert_same_packing(pk, back)
        assert np.array_equal(b["shift"], net2.shift) and np.array_equal(b["i"], net2.i)
    with pytest.raises(InvalidInputError, match="3D") as exc:
        iob.write_network(tmp_path / "n.data", pk, net2.i, net2.j, net2.shift)
    assert "\n" not in str(exc.value)
    assert not (tmp_path / "n.data").exists()


def test_bad_input_one_line_errors(tmp_path, bimodal, net):
    cases = [
        (dict(i=[], j=[]), "no bonds"),
        (dict(i=[0], j=[0]), "distinct"),
        (dict(i=[0], j=[bimodal.n]), "distinct"),
        (dict(i=[0.0], j=[1.0]), "integers"),
        (dict(i=[0, 1], j=[1]), "equal length"),
        (dict(i=[0], j=[1], shift=[[0, 0]]), "shape"),
        (dict(i=[0], j=[1], bond_types=[0]), "bond_types"),
        (dict(i=[0], j=[1], bond_data={"a/b": [1.0]}), "name"),
        (dict(i=[0], j=[1], bond_data={"x": [1.0, 2.0]}), "rows"),
        (dict(i=[0], j=[1], particle_data={"radius": np.ones(bimodal.n)}), "reserved"),
    ]
    for kw, match in cases:
        i, j = kw.pop("i"), kw.pop("j")
        with pytest.raises(InvalidInputError, match=match) as exc:
            iob.write_network(tmp_path / "n.gsd", bimodal, np.asarray(i), np.asarray(j), **kw)
        assert "\n" not in str(exc.value)
    for name, match in (("n.xyz", "cannot store bonds"), ("n.csv", "cannot store bonds"), ("n.vtp", r"\.vtm")):
        with pytest.raises(InvalidInputError, match=match):
            iob.write_network(tmp_path / name, bimodal, net.i, net.j)
    with pytest.raises(InvalidInputError, match="Packing"):
        iob.write_network(tmp_path / "n.gsd", {"positions": []}, [0], [1])
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("ext", EXTS)
def test_damaged_files_raise_format_error(tmp_path, bimodal, net, ext):
    path = tmp_path / f"n{ext}"
    written = iob.write_network(path, bimodal, net.i, net.j)
    target = written[-1]  # the bonds part of a multiblock
    raw = target.read_bytes()
    target.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(FormatError) as exc:
        iob.read_network(path)
    assert "\n" not in str(exc.value)
    with pytest.raises(FormatError):
        iob.read_network(tmp_path / f"missing{ext}")


def test_interrupted_multiblock_write_leaves_no_index(tmp_path, bimodal, net, monkeypatch):
    """A failure while writing a part leaves no index pointing at it, and (issue 31: paired outputs
    are written together or not at all) no part either."""
    calls = {"n": 0}
    real = os.fsync

    class Interrupted(Exception):
        pass

    def fsync(fd):
        calls["n"] += 1
        if calls["n"] == 2:  # the bonds part
            raise Interrupted
        real(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    with pytest.raises(Interrupted):
        iob.write_network(tmp_path / "n.vtm", bimodal, net.i, net.j)
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == []
