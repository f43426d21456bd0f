"""``polypack analyze``: one call gives JSON and plots; bad input gives one-line errors."""

import json

import numpy as np
import pytest

import polypack as pp
from _analysis_packs import rsa
from polypack import io
from polypack.cli import main


@pytest.fixture(scope="module")
def pack_file(tmp_path_factory):
    pk = rsa(np.random.default_rng(1), 600, 11.0, radii_choices=(0.6, 0.3), weights=(0.3, 0.7))
    path = tmp_path_factory.mktemp("an") / "pack.gsd"
    io.write(path, pk)
    return path, pk


def test_analyze_all_json_and_plots(pack_file, tmp_path, capsys):
    path, pk = pack_file
    out = tmp_path / "res.json"
    plots = tmp_path / "plots"
    main(["analyze", str(path), "--json", str(out), "--plots", str(plots), "--n-points", "20000", "--dr", "0.05"])
    d = json.loads(out.read_text())
    for key in ("rdf", "kfunction", "windows", "contacts", "pores", "contact_values"):
        assert key in d, key
    assert d["n"] == pk.n and set(d["rdf"]["partial"]) == {"0-0", "0-1", "1-1"}
    # the same numbers as the Python API
    g = pp.analysis.RDF(r_max=d["rdf"]["r_max"], dr=d["rdf"]["dr"]).compute(pk)
    assert np.allclose(d["rdf"]["g"], g.g)
    names = {p.name for p in plots.iterdir()}
    assert {"rdf.png", "rdf_partial_R.png", "kfunction.png", "windows.png", "contacts.png", "pores.png"} <= names
    assert "coordination" in capsys.readouterr().out


def test_analyze_selection_and_cap(pack_file, tmp_path, capsys):
    path, _ = pack_file
    out = tmp_path / "r.json"
    main(["analyze", str(path), "--contacts", "--json", str(out)])  # (--r-max would be an error: unused)
    d = json.loads(out.read_text())
    assert "contacts" in d and "rdf" not in d and "pores" not in d
    main(["analyze", str(path), "--rdf", "--r-max", "100", "--json", str(out)])
    d = json.loads(out.read_text())
    assert any("capped" in n for n in d["notes"])
    assert d["rdf"]["r_max"] <= 5.5 + 1e-9


def test_analyze_bad_file(tmp_path, capsys):
    bad = tmp_path / "nothing.gsd"
    with pytest.raises(SystemExit) as e:
        main(["analyze", str(bad)])
    assert e.value.code == 1
    err = capsys.readouterr().err
    assert err.startswith("error:") and len(err.strip().splitlines()) == 1
