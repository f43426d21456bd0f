"""``polypack elastic``: the tensor of a packing file, JSON, SI scaling, one-line errors."""

import json

import numpy as np
import pytest
from _lattices import fcc

import polypack as pp
from polypack.cli import main


@pytest.fixture(scope="module")
def fcc_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("el") / "fcc.gsd"
    pp.io.write(path, fcc(cells=3, d=1.0))
    return path


def test_elastic_cli_fcc_in_mpa(fcc_file, tmp_path, capsys):
    out = tmp_path / "e.json"
    main(["elastic", str(fcc_file), "--kn", "100", "--ks", "10", "--json", str(out)])
    d = json.loads(out.read_text())
    # FCC closed form with d = 2 x 0.25 um (the default rescaling to seed 003's r0)
    dd = 0.5e-6
    c44 = (100 + 10) / (np.sqrt(2) * dd)
    np.testing.assert_allclose(d["elastic"]["shear_moduli"], [c44] * 3, rtol=1e-6)
    np.testing.assert_allclose(d["elastic"]["shear_moduli_MPa"], [c44 * 1e-6] * 3, rtol=1e-6)
    assert d["network"]["coordination"] == 12.0 and d["elastic"]["units"] == "Pa"
    text = capsys.readouterr().out
    assert "MPa" in text and "Z=12.000" in text and "G/G_affine = 1.0000" in text


def test_elastic_flags_are_the_study_keys(fcc_file, tmp_path):
    """The flags are [analysis.elastic]'s fields (issue 30): --normal-stiffness/--shear-stiffness with the
    stage's default k_s = k_n / 10, the same tensor as the old --kn/--ks spellings (kept hidden)."""
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    main(["elastic", str(fcc_file), "--radius", "0", "--normal-stiffness", "200", "--json", str(a)])
    main(["elastic", str(fcc_file), "--radius", "0", "--kn", "200", "--ks", "20", "--json", str(b)])
    da, db = json.loads(a.read_text()), json.loads(b.read_text())
    assert da["shear_stiffness"] == 20.0 and da["elastic"]["stiffness"] == db["elastic"]["stiffness"]
    # C11 of FCC with d = 1 in file units: sqrt(2) (k_n + k_s) = sqrt(2) * 220
    np.testing.assert_allclose(da["elastic"]["stiffness"][0][0], np.sqrt(2) * 220.0, rtol=1e-6)


def test_elastic_cli_file_units_and_options(fcc_file, tmp_path):
    out = tmp_path / "e.json"
    main(["elastic", str(fcc_file), "--radius", "0", "--ks", "20", "--no-rotations", "--json", str(out)])
    d = json.loads(out.read_text())
    np.testing.assert_allclose(d["elastic"]["stiffness"][0][0], np.sqrt(2) * 120.0, rtol=1e-6)
    assert d["elastic"]["rotations"] is False and "shear_modulus_MPa" not in d["elastic"]


@pytest.mark.parametrize("args,msg", [
    (["--epsilon", "-0.1"], "--epsilon -0.1: must be >= 0 (analysis.elastic.epsilon in a study file)"),
    (["--normal-stiffness", "0"], "--normal-stiffness 0.0: must be > 0"),
    (["--kn", "0"], "--normal-stiffness 0.0: must be > 0"),  # the old spelling, hidden
    (["--kn", "50", "--normal-stiffness", "60"], "--kn 50.0: give --normal-stiffness only"),
    (["--bonds", "bonds"], '--bonds "bonds": allowed: "auto", "distance", "protocol"'),
])
def test_elastic_cli_errors(fcc_file, args, msg, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["elastic", str(fcc_file), *args])
    assert exc.value.code == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and msg in err and "\n" not in err
