"""A network file is a network; nothing is lost or overwritten (issue 31, items 5, 6, 9).

``convert`` carries bonds and fields or refuses in one line; ``info`` shows them; no
command writes onto its own input; an existing file of another kind is not replaced
without ``--force``; a ``.vtm`` never replaces unrelated ``_particles.vtp`` files and its
three files are written together or not at all.
"""

import numpy as np
import pytest
from _lattices import simple_cubic

import polypack as pp
from polypack.cli import main
from polypack.errors import InvalidInputError
from polypack.io.bonds import read_network
from polypack.mechanics import BondNetwork, elastic_tensor, write_network


def run(capsys, *args):
    code = 0
    try:
        code = main([str(a) for a in args]) or 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def net():
    """A simple cubic lattice with one sphere removed: 6 x 64 / 2 - 6 = 186 bonds, no rattler."""
    pk = simple_cubic(cells=4)
    keep = np.arange(pk.n) != 5
    pk = pp.Packing(pk.positions[keep], pk.radii[keep], pk.box, meta={"seed": 3})
    return BondNetwork.from_packing(pk, epsilon=0.01)


@pytest.fixture()
def netfile(tmp_path, net):
    path = tmp_path / "net.gsd"
    write_network(path, net, elastic_tensor(net))
    return path


def _same_network(a, b):
    pa, ba = read_network(a)
    pb, bb = read_network(b)
    np.testing.assert_array_equal(pa.positions, pb.positions)
    np.testing.assert_array_equal(ba["i"], bb["i"])
    np.testing.assert_array_equal(ba["j"], bb["j"])
    np.testing.assert_array_equal(ba["shift"], bb["shift"])
    return ba, bb


def test_convert_carries_bonds_and_fields(tmp_path, capsys, netfile, net):
    for ext in (".gsd", ".vtm"):
        target = tmp_path / f"other{ext}"
        code, out, err = run(capsys, "convert", netfile, target)
        assert code == 0 and "186 bonds" in out, err
        ba, bb = _same_network(netfile, target)
        assert len(bb["i"]) == net.n_bonds == 186
        assert set(bb["bond_data"]) == set(ba["bond_data"]) and "normal_force" in bb["bond_data"]
        assert set(bb["particle_data"]) == set(ba["particle_data"]) and "rattler" in bb["particle_data"]
        np.testing.assert_array_equal(bb["bond_data"]["rest_length"], ba["bond_data"]["rest_length"])
    # LAMMPS holds bonds but no fields: refused unless the fields are dropped explicitly
    code, _, err = run(capsys, "convert", netfile, tmp_path / "n.data")
    assert code != 0 and "--drop-fields" in err and err.count("\n") == 1
    code, out, _ = run(capsys, "convert", netfile, tmp_path / "n.data", "--drop-fields")
    assert code == 0 and "186 bonds" in out
    # ... and back: the bonds survive .gsd -> .data -> .gsd
    code, _, _ = run(capsys, "convert", tmp_path / "n.data", tmp_path / "back.gsd")
    assert code == 0 and len(_same_network(netfile, tmp_path / "back.gsd")[1]["i"]) == 186


def test_convert_refuses_formats_without_bonds_and_its_own_input(tmp_path, capsys, netfile):
    size = netfile.stat().st_size
    code, _, err = run(capsys, "convert", netfile, netfile)  # destroyed the network before issue 31
    assert code != 0 and "is the input file" in err and err.count("\n") == 1
    assert netfile.stat().st_size == size and len(read_network(netfile)[1]["i"]) == 186
    code, _, err = run(capsys, "convert", netfile, tmp_path / "x.xyz")
    assert code != 0 and "cannot hold the 186 bonds" in err and "--drop-bonds" in err
    assert not (tmp_path / "x.xyz").exists()
    code, out, _ = run(capsys, "convert", netfile, tmp_path / "x.xyz", "--drop-bonds")
    assert code == 0 and "dropped" in out and pp.io.read(tmp_path / "x.xyz").n == 63


def test_info_shows_bonds_rattlers_and_fields(tmp_path, capsys, netfile):
    code, out, _ = run(capsys, "info", netfile)
    assert code == 0
    assert "bonds            186 (types 1, coordination 5.905, rattlers 0)" in out
    assert "normal_force" in out and "nonaffine_displacement" in out
    import json

    code, out, _ = run(capsys, "info", netfile, "--json")
    d = json.loads(out)
    assert d["bonds"] == 186 and d["rattlers"] == 0 and "rest_length" in d["bond_fields"]
    # a pack file says nothing about bonds
    pp.io.write(tmp_path / "pack.gsd", pp.io.read(netfile))
    code, out, _ = run(capsys, "info", tmp_path / "pack.gsd")
    assert code == 0 and "bonds " not in out
    # a rattler is counted: a sphere with one bond
    pk, b = read_network(netfile)
    one = (b["i"] == 0) | (b["j"] == 0)
    drop = np.flatnonzero(one)[1:]
    keep = np.setdiff1d(np.arange(len(b["i"])), drop)
    pp.io.bonds.write_network(tmp_path / "r.gsd", pk, b["i"][keep], b["j"][keep], b["shift"][keep])
    code, out, _ = run(capsys, "info", tmp_path / "r.gsd")
    assert "rattlers 1)" in out


@pytest.mark.parametrize("cmd", [("report",), ("view", "--no-browser")])
def test_report_and_view_never_replace_a_pack(tmp_path, capsys, netfile, cmd):
    pack = tmp_path / "p.gsd"
    pp.io.write(pack, pp.io.read(netfile))
    before = pack.read_bytes()
    code, _, err = run(capsys, cmd[0], pack, "-o", pack, *cmd[1:])  # replaced the pack with HTML before
    assert code != 0 and "is the input file" in err and pack.read_bytes() == before
    other = tmp_path / "q.gsd"
    other.write_bytes(before)
    code, _, err = run(capsys, cmd[0], pack, "-o", other, *cmd[1:])
    assert code != 0 and "existing GSD file would be replaced by HTML" in err and other.read_bytes() == before
    code, _, err = run(capsys, cmd[0], pack, "-o", other, *cmd[1:], "--force")
    assert code == 0 and other.read_bytes()[:15].lower().startswith(b"<!doctype html")


def test_vtm_never_replaces_unrelated_parts(tmp_path, net):
    mine = tmp_path / "x_particles.vtp"
    mine.write_text("my own file")
    with pytest.raises(InvalidInputError, match="x_particles.vtp: exists and is not part of x.vtm"):
        write_network(tmp_path / "x.vtm", net)
    assert mine.read_text() == "my own file" and not (tmp_path / "x.vtm").exists()
    assert not (tmp_path / "x_bonds.vtp").exists()
    mine.unlink()
    write_network(tmp_path / "x.vtm", net)
    write_network(tmp_path / "x.vtm", net)  # rewriting the same network replaces its own parts
    assert len(read_network(tmp_path / "x.vtm")[1]["i"]) == 186
    (tmp_path / "y_bonds.vtp").write_text("mine")
    pp.io.bonds.write_network(tmp_path / "y.vtm", net.packing, net.i, net.j, net.shift, force=True)
    assert len(read_network(tmp_path / "y.vtm")[1]["i"]) == 186


def test_vtm_parts_are_written_together_or_not_at_all(tmp_path, net, monkeypatch):
    from polypack.io import bonds as iob

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(iob._vtp, "document", boom)  # fails after the particles part is written
    with pytest.raises(OSError, match="disk full"):
        iob.write_network(tmp_path / "z.vtm", net.packing, net.i, net.j, net.shift)
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_export_network_writes_the_epsilon_network(tmp_path, capsys, net):
    """`polypack export-network` writes a pack's epsilon-network to GSD, VTK and LAMMPS BPM: the
    bonds read back are those of BondNetwork.from_packing (186 on the lattice with a vacancy)."""
    pack = tmp_path / "p.gsd"
    pp.io.write(pack, net.packing)
    for ext in (".gsd", ".vtm", ".data"):
        out = tmp_path / f"n{ext}"
        code, text, err = run(capsys, "export-network", pack, out, *(("--response",) if ext != ".data" else ()))
        assert code == 0 and "186 bonds by the epsilon rule" in text, err
        _, b = read_network(out)
        got = {tuple(sorted(p)) for p in zip(b["i"].tolist(), b["j"].tolist())}
        assert got == {tuple(sorted(p)) for p in zip(net.i.tolist(), net.j.tolist())}
        if ext != ".data":
            assert "normal_force" in b["bond_data"] and "nonaffine_displacement" in b["particle_data"]
    code, _, err = run(capsys, "export-network", pack, pack)
    assert code == 1 and "is the input file" in err


@pytest.mark.parametrize("args", [
    ("shake", "{pack}", "{pack}", "--global-shakes", "1"),
    ("analyze", "{pack}", "--json", "{pack}"),
    ("moduli", "{pack}", "--json", "{pack}", "--matrix", "3e9,0.4", "--inclusions", "70e9,0.2"),
    ("pack", "{sizes}", "-o", "{sizes}", "-c", "0.3"),
    ("scrm", "{sizes}", "-o", "{sizes}"),
    ("elastic", "{pack}", "--json", "{pack}"),
    ("convert", "{pack}", "{pack}"),
])
def test_no_command_writes_onto_its_input(tmp_path, capsys, net, args):
    pack, sizes = tmp_path / "p.gsd", tmp_path / "s.csv"
    pp.io.write(pack, net.packing)
    sizes.write_text("radius\n" + "0.5\n" * 20)
    before = {p: p.read_bytes() for p in (pack, sizes)}
    code, _, err = run(capsys, *[a.format(pack=pack, sizes=sizes) for a in args])
    assert code == 1 and "is the input file" in err and err.count("\n") == 1
    assert {p: p.read_bytes() for p in (pack, sizes)} == before
