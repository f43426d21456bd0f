"""CLI: ``polypack info``, ``polypack convert``, ``--version``."""

import json

import numpy as np
import pytest

import polypack as pp
from polypack.cli import main

R = 0.3  # radius on a unit simple cubic lattice: lattice gap is 1/(2R) - 1


def lattice_pack(meta=None):
    """4x4x4 simple cubic lattice (spacing 1, box 4), two species by x parity; no overlaps."""
    g = np.arange(4) + 0.5
    pos = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T
    species = (np.floor(pos[:, 0]).astype(int) % 2)
    radii = np.where(species == 0, R, 0.8 * R)
    return pp.Packing(pos, radii, 4.0, species=species, meta=meta or {"seed": 7, "protocol": ["lattice"]})


def two_overlapping(tmp_path):
    """The lattice with spheres 0 and 48 moved to overlap through the periodic boundary x = 0 = L."""
    pk = lattice_pack()
    pos = pk.positions.copy()
    pos[0] = [0.1, 2.0, 2.0]  # sphere 0 (radius R) near x = 0
    pos[48] = [3.8, 2.0, 2.0]  # sphere 48 (x = 3.5 originally, radius 0.8R) 0.3 away through the boundary
    pk = pk.replace(positions=pos)
    path = tmp_path / "overlap.gsd"
    pp.io.write(path, pk)
    return pk, path


def run(capsys, *args):
    """``(exit code, stdout, stderr)`` of ``polypack ARGS``."""
    code = 0
    try:
        ret = main([str(a) for a in args])
        code = ret or 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_version(capsys):
    code, out, _ = run(capsys, "--version")
    assert code == 0 and out.strip() == f"polypack {pp.__version__}"


def test_info_on_clean_lattice(tmp_path, capsys):
    pk = lattice_pack()
    path = tmp_path / "lattice.gsd"
    pp.io.write(path, pk)
    code, out, err = run(capsys, "info", path)
    assert code == 0 and not err
    assert "overlaps         none" in out
    assert "spheres          64" in out
    code, out, _ = run(capsys, "info", path, "--json")
    s = json.loads(out)
    # relative gaps at distance 1: large-large 1/(2R) - 1 (smallest), large-small 1/(1.8R) - 1, small-small
    assert s["min_gap"] == pytest.approx(1 / (2 * R) - 1, rel=1e-12)
    assert s["overlapping_pairs"] == 0 and s["overlaps"] == []
    assert s["n"] == 64 and s["box"] == [4.0, 4.0, 4.0]
    assert s["volume_fraction"] == pytest.approx(32 * 4 / 3 * np.pi * (R**3 + (0.8 * R) ** 3) / 64, rel=1e-12)
    assert [(x["species"], x["count"], x["radius_min"], x["radius_max"]) for x in s["species"]] == [
        (0, 32, R, R), (1, 32, 0.8 * R, 0.8 * R)]
    assert s["meta"] == {"seed": 7, "protocol": ["lattice"]}
    assert s["written_by"] == f"polypack {pp.__version__}" and s["format"] == "gsd"


def test_info_names_the_overlapping_pair_across_the_boundary(tmp_path, capsys):
    pk, path = two_overlapping(tmp_path)
    expected_gap = 0.3 / (R + 0.8 * R) - 1  # |0.1 - 3.8| minimum image = 0.3
    code, out, err = run(capsys, "info", path)
    assert code == 0 and not err
    assert "1 overlapping pair(s): spheres 0 and 48" in out
    code, out, _ = run(capsys, "info", path, "--json")
    s = json.loads(out)
    assert s["overlapping_pairs"] == 1
    i, j, gap = s["overlaps"][0]
    assert (i, j) == (0, 48) and s["closest_pair"] == [0, 48]
    assert gap == pytest.approx(expected_gap, rel=1e-12) and s["min_gap"] == pytest.approx(expected_gap, rel=1e-12)


def test_info_lists_only_first_pairs(tmp_path, capsys):
    pk = lattice_pack().replace(radii=np.full(64, 0.55))  # every lattice neighbour overlaps: 64*3 pairs
    path = tmp_path / "dense.csv"
    pp.io.write(path, pk)
    code, out, _ = run(capsys, "info", path, "--pairs", "2")
    assert code == 0
    assert "192 overlapping pair(s)" in out and "and 190 more" in out


@pytest.mark.parametrize("damage", ["truncated", "empty", "missing"])
def test_info_on_damaged_gsd_is_one_line_error(tmp_path, capsys, damage):
    path = tmp_path / "bad.gsd"
    if damage != "missing":
        good = tmp_path / "good.gsd"
        pp.io.write(good, lattice_pack())
        raw = good.read_bytes()
        path.write_bytes(raw[: len(raw) // 2] if damage == "truncated" else b"")
    code, out, err = run(capsys, "info", path)
    assert code != 0
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and str(path) in lines[0]
    assert "Traceback" not in err


def test_unknown_extension_is_one_line_error(tmp_path, capsys):
    path = tmp_path / "pack.pdb"
    path.write_text("x\n")
    code, _, err = run(capsys, "info", path)
    assert code == 1 and len(err.strip().splitlines()) == 1 and ".gsd" in err


def test_convert_chain_is_exact(tmp_path, capsys):
    pk, src = two_overlapping(tmp_path)
    chain = [src, tmp_path / "a.xyz", tmp_path / "b.csv", tmp_path / "c.data", tmp_path / "d.extxyz", tmp_path / "e.gsd"]
    for a, b in zip(chain, chain[1:]):
        code, out, err = run(capsys, "convert", a, b)
        assert code == 0 and not err and out.startswith(f"wrote {b}")
    back = pp.io.read(chain[-1])
    assert back == pk
    assert np.array_equal(back.positions.view(np.int64), pk.positions.view(np.int64))
    code, _, _ = run(capsys, "convert", src, tmp_path / "f.vtp")
    assert code == 0 and (tmp_path / "f.vtp").stat().st_size > 0
    code, _, _ = run(capsys, "convert", src, tmp_path / "g.txt", "--to", "csv")
    assert code == 0 and pp.io.read(tmp_path / "g.txt", format="csv") == pk


def test_convert_failure_keeps_target(tmp_path, capsys):
    target = tmp_path / "keep.csv"
    target.write_text("old\n")
    bad = tmp_path / "bad.gsd"
    bad.write_bytes(b"not gsd")
    code, _, err = run(capsys, "convert", bad, target)
    assert code == 1 and err.startswith("error: ")
    assert target.read_text() == "old\n"


@pytest.mark.parametrize("cmd", ["info", "convert"])
def test_help(capsys, cmd):
    code, out, _ = run(capsys, cmd, "--help")
    assert code == 0 and "gsd" in out and "Usage" in out


# ------------------------------------------------------------ bundled example
EXAMPLES = __import__("pathlib").Path(__file__).resolve().parent.parent / "examples"


def _example_script():
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_bimodal_example", EXAMPLES / "make_bimodal_example.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_bundled_example_is_seed_000_bimodal_and_regenerates(capsys):
    path = EXAMPLES / "bimodal_example.gsd"
    pk = pp.io.read(path)
    assert pk.n == 2000 and pk.species_counts.tolist() == [168, 1832]  # N(1) = 168 quoted for seed 000
    assert set(pk.radii[pk.species == 0]) == {1.0} and set(pk.radii[pk.species == 1]) == {0.313}
    c1, c2 = pk.species_fractions
    assert c2 / c1 == pytest.approx(0.333, abs=0.002)  # integer counts: 1832*0.313^3/168 = 0.3344
    assert pk.volume_fraction == pytest.approx(0.35, rel=1e-12)
    assert pk.min_gap() > 0 and len(pk.overlaps()) == 0
    regenerated = _example_script().build()
    assert regenerated == pk  # deterministic, bit for bit
    code, out, err = run(capsys, "info", path)  # the README's main-job command
    assert code == 0 and "spheres          2000" in out and "overlaps         none" in out
