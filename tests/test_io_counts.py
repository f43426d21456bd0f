"""Readers count and cross-check: header counts against the rows read, in both directions,
in every format; multi-frame files say which frame they read and can choose one."""

import numpy as np
import pytest

import polypack as pp
from polypack import FormatError


@pytest.fixture(scope="module")
def pk():
    rng = np.random.default_rng(3)
    return pp.Packing(rng.random((6, 3)) * 10.0, np.full(6, 0.5), np.full(3, 10.0), species=[0, 1, 0, 1, 0, 1])


def _lines(path):
    return path.read_text().split("\n")


def test_lammps_header_declaring_fewer_atoms_than_rows_fails(tmp_path, pk):
    p = tmp_path / "a.data"
    pp.io.write(p, pk)
    text = p.read_text().replace("6 atoms\n", "5 atoms\n")
    p.write_text(text)
    with pytest.raises(FormatError, match="declares 5 atoms but the Atoms section has 6 rows"):
        pp.io.read(p)


def test_lammps_header_declaring_more_atoms_than_rows_fails(tmp_path, pk):
    p = tmp_path / "a.data"
    pp.io.write(p, pk)
    p.write_text(p.read_text().replace("6 atoms\n", "7 atoms\n"))
    with pytest.raises(FormatError, match="declares 7 atoms"):
        pp.io.read(p)


def test_lammps_velocities_and_types_are_cross_checked(tmp_path, pk):
    p = tmp_path / "a.data"
    pp.io.write(p, pk)
    base = p.read_text()
    vel = "".join(f"{i} 0 0 0\n" for i in range(1, 6))  # one row short
    p.write_text(base + "\nVelocities\n\n" + vel)
    with pytest.raises(FormatError, match="Velocities section has 5 rows"):
        pp.io.read(p)
    p.write_text(base + "\nVelocities\n\n" + vel + "6 0 0 0\n")
    assert pp.io.read(p).n == 6  # the complete section reads
    p.write_text(base.replace("2 atom types", "1 atom types"))
    with pytest.raises(FormatError, match="header declares 1 atom types"):
        pp.io.read(p)


def test_xyz_frame_with_more_rows_than_declared_fails(tmp_path, pk):
    p = tmp_path / "a.xyz"
    pp.io.write(p, pk)
    lines = _lines(p)
    lines[0] = "5"
    p.write_text("\n".join(lines))
    with pytest.raises(FormatError, match="declares 5 atoms but has more rows"):
        pp.io.read(p)
    lines[0] = "7"
    p.write_text("\n".join(lines))
    with pytest.raises(FormatError, match="declares 7 atoms"):
        pp.io.read(p)


def test_xyz_multi_frame_says_which_frame_and_can_choose(tmp_path, pk):
    a, b = tmp_path / "a.xyz", tmp_path / "b.xyz"
    pk2 = pk.replace(positions=np.mod(pk.positions + 1.0, 10.0))
    pp.io.write(a, pk)
    pp.io.write(b, pk2)
    both = tmp_path / "ab.xyz"
    both.write_text(a.read_text() + b.read_text())
    last, info = pp.io.read_with_info(both)
    assert info["frames"] == 2 and info["frame"] == 1
    assert np.array_equal(last.positions, pk2.positions)
    first, info = pp.io.read_with_info(both, frame=0)
    assert info["frame"] == 0 and np.array_equal(first.positions, pk.positions)
    with pytest.raises(FormatError, match="frame 2 requested but the file has 2 frame"):
        pp.io.read(both, frame=2)


def test_gsd_multi_frame_says_which_frame_and_can_choose(tmp_path, pk, capsys):
    import gsd.hoomd

    from polypack.cli import main

    p = tmp_path / "a.gsd"
    pp.io.write(p, pk)
    with gsd.hoomd.open(str(p), "r") as t:
        f0 = t[0]
    with gsd.hoomd.open(str(tmp_path / "two.gsd"), "w") as t:
        t.append(f0)
        f1 = f0
        f1.particles.position = (np.asarray(f0.particles.position) * 0.5).astype(np.float64)
        t.append(f1)
    _, info = pp.io.read_with_info(tmp_path / "two.gsd")
    assert (info["frames"], info["frame"]) == (2, 1)
    first, info = pp.io.read_with_info(tmp_path / "two.gsd", frame=0)
    # a foreign single-precision file: frame 0 is the original, frame 1 the halved one
    assert info["frame"] == 0 and np.allclose(first.positions, pk.positions, atol=1e-5)
    main(["info", str(tmp_path / "two.gsd"), "--frame", "0"])
    out = capsys.readouterr().out
    assert "frame            0 of frames 0..1" in out
    main(["convert", str(tmp_path / "two.gsd"), str(tmp_path / "c.csv")])
    assert "from frame 1 of 2" in capsys.readouterr().out


def test_gsd_particle_arrays_must_match_particles_n(tmp_path):
    import gsd.fl

    p = tmp_path / "bad.gsd"
    with gsd.fl.open(name=str(p), mode="w", application="test", schema="hoomd", schema_version=[1, 4]) as f:
        f.write_chunk("configuration/box", np.array([10, 10, 10, 0, 0, 0], dtype=np.float32))
        f.write_chunk("particles/N", np.array([5], dtype=np.uint32))
        f.write_chunk("particles/position", np.zeros((4, 3), dtype=np.float32))
        f.end_frame()
    with pytest.raises(FormatError, match="particles/N is 5 but particles/position has 4 rows"):
        pp.io.read(p)


def test_csv_count_is_cross_checked_both_ways(tmp_path, pk):
    p = tmp_path / "a.csv"
    pp.io.write(p, pk)
    for n in (5, 7):
        p.write_text(p.read_text().replace(f"# n: {6 if n == 5 else 5}\n", f"# n: {n}\n"))
        with pytest.raises(FormatError, match=f"declares {n} rows but the file has 6"):
            pp.io.read(p)


def test_single_frame_formats_refuse_other_frames(tmp_path, pk):
    for ext in (".csv", ".data"):
        p = tmp_path / f"a{ext}"
        pp.io.write(p, pk)
        assert pp.io.read_with_info(p)[1]["frame"] == 0
        with pytest.raises(FormatError, match="has 1 frame"):
            pp.io.read(p, frame=1)
