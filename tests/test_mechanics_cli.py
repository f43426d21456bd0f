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


def test_elastic_cli_file_units_and_options(fcc_file, tmp_path):
    out = tmp_path / "e.json"
    main(["elastic", str(fcc_file), "--radius", "0", "--ks", "20", "--no-rotations", "--json", str(out)])
    d = json.loads(out.read_text())
    np.testing.assert_allclose(d["elastic"]["stiffness"][0][0], np.sqrt(2) * 120.0, rtol=1e-6)
    assert d["elastic"]["rotations"] is False and "shear_modulus_MPa" not in d["elastic"]


@pytest.mark.parametrize("args,msg", [(["--epsilon", "-0.1"], "epsilon=-0.1"), (["--kn", "0"], "normal_stiffness=0.0")])
def test_elastic_cli_errors(fcc_file, args, msg, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["elastic", str(fcc_file), *args])
    assert exc.value.code == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and msg in err and "\n" not in err
