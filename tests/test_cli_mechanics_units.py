"""Mechanics commands state their units, use stored bonds, and check outputs first (issue 31, items 2, 3, 9-11)."""

import json

import numpy as np
import pytest

import polypack as pp
from polypack.cli import main
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
def pack_file(tmp_path_factory):
    """60 spheres of radius 0.5 um at phi = 0.6 (twice the seed's radius)."""
    path = tmp_path_factory.mktemp("u") / "r5.gsd"
    pp.io.write(path, pp.pack(np.full(60, 0.5e-6), volume_fraction=0.6, seed=1))
    return path


def test_elastic_and_shear_use_one_length_scale_and_say_so(tmp_path, pack_file, capsys):
    """Item 2: elastic rescaled to 0.25 um silently and shear did not (C55 = 35.77 MPa against
    G' = 17.89 MPa on an r = 0.5 um pack). Both now rescale by --radius, state it, and agree
    (slow drive: 1 % at 2000 steps per cycle; measured 3e-4)."""
    code, out, _ = run(capsys, "elastic", pack_file, "--epsilon", "0.05", "--json", tmp_path / "e.json")
    assert code == 0 and "lengths rescaled x0.5 to a mean radius of 2.5e-07 m" in out
    c55 = json.loads((tmp_path / "e.json").read_text())["elastic"]["shear_moduli"][1]
    code, out, _ = run(capsys, "shear", pack_file, "--epsilon", "0.05", "--cycles", "3", "--steps-per-cycle", "2000",
                       "--direction", "2,0", "--json", tmp_path / "s.json")
    assert code == 0 and "lengths rescaled x0.5 to a mean radius of 2.5e-07 m" in out
    g = json.loads((tmp_path / "s.json").read_text())["storage_modulus"]
    assert g == pytest.approx(c55, rel=0.01)
    # --radius 0: the file's unit for both (moduli double: stiffness per length)
    code, out, _ = run(capsys, "elastic", pack_file, "--epsilon", "0.05", "--radius", "0", "--json", tmp_path / "f.json")
    assert "lengths in the file's unit" in out
    assert json.loads((tmp_path / "f.json").read_text())["elastic"]["shear_moduli"][1] == pytest.approx(c55 / 2,
                                                                                                     rel=1e-9)


@pytest.mark.parametrize("value", ["-1", "nan", "inf"])
@pytest.mark.parametrize("cmd", ["elastic", "shear"])
def test_bad_radius_is_refused(pack_file, capsys, cmd, value):
    code, _, err = run(capsys, cmd, pack_file, "--radius", value)
    assert code == 1 and f"--radius {float(value)!r}" in err and err.count("\n") == 1


def test_stored_bonds_are_used_and_named(tmp_path, pack_file, capsys):
    """Item 3: 532 stored bonds were rebuilt by the epsilon rule into 666. Keep every other
    bond of the epsilon = 0.05 network: elastic and shear use exactly those (and say so)."""
    pk = pp.io.read(pack_file)
    full = BondNetwork.from_packing(pk, epsilon=0.05)
    half = full.select(np.arange(full.n_bonds) % 4 != 0)
    write_network(tmp_path / "net.gsd", half)
    code, out, _ = run(capsys, "elastic", tmp_path / "net.gsd", "--json", tmp_path / "e.json")
    assert code == 0 and f"{half.n_bonds} bonds stored in" in out
    d = json.loads((tmp_path / "e.json").read_text())
    assert d["network"]["n_bonds"] == half.n_bonds < full.n_bonds
    want = elastic_tensor(half, radius=0.25e-6)
    np.testing.assert_allclose(d["elastic"]["shear_moduli"], want.shear_moduli, rtol=1e-8)
    code, out, _ = run(capsys, "elastic", tmp_path / "net.gsd", "--bonds", "distance", "--epsilon", "0.05")
    assert f"{full.n_bonds} bonds by the epsilon rule" in out
    code, _, err = run(capsys, "elastic", pack_file, "--bonds", "file")
    assert code == 1 and "stores no bonds" in err
    code, out, _ = run(capsys, "shear", tmp_path / "net.gsd", "--cycles", "2", "--steps-per-cycle", "200",
                       "--direction", "2,0")
    assert code == 0 and f"{half.n_bonds} bonds stored in" in out


def test_outputs_checked_before_computing(tmp_path, pack_file, capsys, monkeypatch):
    """Item 10: elastic and shear computed before checking --json / --plot; a plot with an
    unknown extension was a traceback (item 11, dlvo --plot x.txt)."""
    import polypack.mechanics as mech

    def never(*a, **k):
        raise AssertionError("computed before the output path was checked")

    monkeypatch.setattr(mech, "elastic_tensor", never)
    monkeypatch.setattr(mech, "oscillatory_shear", never)
    (tmp_path / "folder").mkdir()
    for args, msg in [(("elastic", pack_file, "--json", tmp_path / "folder"), "is a folder"),
                      (("elastic", pack_file, "--json", pack_file), "is the input file"),
                      (("shear", pack_file, "--plot", tmp_path / "x.txt"), "cannot tell a figure format"),
                      (("shear", pack_file, "--json", pack_file), "is the input file"),
                      (("dlvo", "--plot", tmp_path / "x.txt"), "allowed extensions: .png, .pdf, .svg")]:
        code, _, err = run(capsys, *args)
        assert code == 1 and msg in err and err.count("\n") == 1, (args, err)


def test_shear_with_overflowing_stiffness_is_one_line(tmp_path, pack_file, capsys):
    """Item 11: --kn 1e300 raised an ArpackError traceback."""
    code, _, err = run(capsys, "shear", pack_file, "--epsilon", "0.05", "--kn", "1e300", "--normal-strength", "1e305",
                       "--shear-strength", "1e305", "--cycles", "2", "--steps-per-cycle", "200", "--direction", "2,0",
                       "--no-progress")
    assert code == 1
    line = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert len(line) == 1 and "beyond float64 dynamics" in line[0] and "Traceback" not in err


def test_brownian_pair_is_written_together_or_not_at_all(tmp_path, capsys):
    """Item 9: the GSD was written, then its bonds sidecar failed (half a pair)."""
    (tmp_path / "g.gsd.bonds.json").mkdir()  # the sidecar path cannot be written
    code, _, err = run(capsys, "brownian", tmp_path / "g.gsd", "--n", "30", "--max-steps", "5", "--seed", "1",
                       "--no-progress")
    assert code == 1 and "g.gsd.bonds.json: is a folder" in err and not (tmp_path / "g.gsd").exists()
    (tmp_path / "g.gsd.bonds.json").rmdir()
    code, _, _ = run(capsys, "brownian", tmp_path / "g.gsd", "--n", "30", "--max-steps", "5", "--seed", "1",
                     "--no-progress")
    assert code == 0 and (tmp_path / "g.gsd").is_file() and (tmp_path / "g.gsd.bonds.json").is_file()


def test_deposit_refuses_a_pack_and_a_3d_size_set(tmp_path, pack_file, capsys):
    """Items 4 and 11: `deposit pack.gsd` was a UnicodeDecodeError traceback; a 3D size set
    (class counts weighted by sphere volume) was deposited as 2D disks."""
    code, _, err = run(capsys, "deposit", pack_file)
    assert code == 1 and "a pack file; deposit takes a size-set CSV" in err
    code, _, _ = run(capsys, "psd", "-m", "monodisperse", "--n", "20", "-o", tmp_path / "s3.csv")
    assert code == 0
    code, _, err = run(capsys, "deposit", tmp_path / "s3.csv")
    assert code == 1 and "a size set for dim=3" in err and err.count("\n") == 1
    code, _, _ = run(capsys, "psd", "-m", "monodisperse", "--n", "20", "--dim", "2", "-o", tmp_path / "s2.csv")
    code, out, _ = run(capsys, "deposit", tmp_path / "s2.csv", "--seed", "1")
    assert code == 0 and "deposited N=20" in out
    # the output path is checked before depositing
    (tmp_path / "d.gsd").mkdir()
    code, _, err = run(capsys, "deposit", "--n", "20", "-o", tmp_path / "d.gsd")
    assert code == 1 and "is a folder" in err


def test_shear_offers_the_samples_per_cycle_its_errors_name(tmp_path, pack_file, capsys):
    """The shear command's error for too few steps per cycle names samples_per_cycle; the flag
    exists and reaches the test (a run with 10 samples per cycle records 10 per cycle)."""
    code, _, err = run(capsys, "shear", pack_file, "--epsilon", "0.05", "--cycles", "2", "--steps-per-cycle", "50")
    assert code == 1 and "samples_per_cycle=100" in err
    code, out, _ = run(capsys, "shear", pack_file, "--epsilon", "0.05", "--cycles", "2", "--steps-per-cycle", "50",
                       "--samples-per-cycle", "10", "--direction", "2,0", "--json", tmp_path / "s.json")
    assert code == 0, out
    d = json.loads((tmp_path / "s.json").read_text())
    assert _find(d, "samples_per_cycle") == 10
    code, _, err = run(capsys, "shear", pack_file, "--samples-per-cycle", "4")
    assert code == 1 and "samples_per_cycle" in err


def _find(d, key):
    """The first value under ``key`` anywhere in nested dicts/lists (None if absent)."""
    if isinstance(d, dict):
        if key in d:
            return d[key]
        d = list(d.values())
    if isinstance(d, list):
        for v in d:
            r = _find(v, key)
            if r is not None:
                return r
    return None
