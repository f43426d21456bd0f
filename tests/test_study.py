"""Study files: validation with key paths, defaults, resolved copies, CLI --check."""

import tomllib
from pathlib import Path

import pytest

from polypack.errors import InvalidInputError
from polypack.study import Study, load_study, validate

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _err(data):
    with pytest.raises(InvalidInputError) as ei:
        validate(data)
    return str(ei.value)


@pytest.mark.parametrize(
    "data, start",
    [
        ({"protocol": {"volume_fraction": 1.2}}, "protocol.volume_fraction = 1.2: must be in (0, 1)"),
        ({"protocol": {"volume_fraction": 0.0}}, "protocol.volume_fraction = 0.0: must be in (0, 1)"),
        ({"protocol": {"volume_fraction": "loose"}}, 'protocol.volume_fraction = "loose": allowed: a number'),
        ({"protocol": {"kind": "nope"}}, 'protocol.kind = "nope": allowed: "crm"'),
        ({"protocol": {"global_shakes": -1}}, "protocol.global_shakes = -1: must be an integer >= 0"),
        ({"protocol": {"global_shakes": 2.5}}, "protocol.global_shakes = 2.5: expected an integer"),
        ({"protocol": {"shake_radius": 0}}, "protocol.shake_radius = 0: must be > 0"),
        ({"protocol": {"schedule": [0.5, 0.4]}}, "protocol.schedule = [0.5, 0.4]: volume fractions must increase"),
        ({"protocol": {"speed": 1}}, "protocol.speed: unknown key"),
        ({"protocol": {"shake_method": "wiggle"}}, 'protocol.shake_method = "wiggle": allowed: "paper"'),
        ({"protocol": {"kind": "crm", "stage_shakes": 2}}, 'protocol.stage_shakes: only used with protocol.kind = "scrm"'),
        ({"protocol": {"volume_fraction": "jammed"}}, 'protocol.volume_fraction = "jammed": SCRM needs a number'),
        ({"study": {"realizations": 0}}, "study.realizations = 0: must be an integer >= 1"),
        ({"study": {"seed": -3}}, "study.seed = -3: must be an integer >= 0"),
        ({"study": {"seed": "abc"}}, 'study.seed = "abc": expected an integer'),
        ({"study": {"seed": True}}, "study.seed = True: expected an integer, got boolean"),
        ({"psd": {"size_ratio": 3.0}}, "psd.size_ratio = 3.0: must be in (0, 1]"),
        ({"psd": {"model": "bimodal", "a": 2.0}}, 'psd.a: not a parameter of model "bimodal"'),
        ({"psd": {"model": "gamma"}}, 'psd.model = "gamma": allowed:'),
        ({"psd": {"n": 1}}, "psd.n = 1: must be an integer >= 2"),
        ({"psd": {"n": 100, "n_classes": 5}}, 'psd.n_classes: only used with psd.sampling = "discretize"'),
        ({"psd": {"model": "uniform_volume", "d_min": 2.0, "d_max": 1.0}}, "psd.d_min = 2.0: must be < psd.d_max"),
        ({"analysis": {"rdf": {"r_max": -1.0}}}, "analysis.rdf.r_max = -1.0: must be > 0"),
        ({"analysis": {"rdf": {"rmax": 1.0}}}, "analysis.rdf.rmax: unknown key"),
        ({"analysis": {"voronoi": {}}}, "analysis.voronoi: unknown analysis"),
        ({"analysis": {"pores": {"n_points": 10}}}, "analysis.pores.n_points = 10: must be an integer >= 100"),
        ({"analysis": {"windows": {"window_radius": []}}}, "analysis.windows.window_radius = []: must not be empty"),
        ({"output": {"formats": ["gsd", "pdb"]}}, 'output.formats = ["gsd", "pdb"]'.replace('"', "'")),
        ({"output": {"plots": "yes"}}, 'output.plots = "yes": expected true or false'),
        ({"outputs": {}}, "outputs: unknown section"),
        ({"psd": 3}, "psd = 3: expected a table"),
    ],
)
def test_validation_errors_name_the_key_path(data, start):
    msg = _err(data)
    assert msg.startswith(start), msg
    assert "\n" not in msg


def test_defaults_are_filled_and_model_defaults_follow_the_model():
    d = validate({"psd": {"model": "cumulative_beta", "sampling": "discretize", "span": 0.8}})
    assert d["psd"]["a"] == 1.0 and d["psd"]["b"] == 1.0 and d["psd"]["n_classes"] == 10
    assert "n" not in d["psd"] and "size_ratio" not in d["psd"]
    d = validate({})
    assert d["study"] == {"name": "study", "description": "", "seed": 0, "realizations": 1}
    assert d["protocol"]["kind"] == "scrm" and d["protocol"]["global_shakes"] == 60
    assert validate({"protocol": {"kind": "crm"}})["protocol"]["global_shakes"] == 0
    assert d["psd"]["n"] == 2000 and d["psd"]["size_ratio"] == 0.313
    assert d["output"]["formats"] == ["gsd"]
    assert validate({"output": {"formats": ["xyz"]}})["output"]["formats"] == ["gsd", "xyz"]
    assert d["analysis"] == {}
    assert validate({"analysis": {"rdf": {}}})["analysis"]["rdf"] == {"r_max": 3.0, "dr": 0.02}


def test_resolved_toml_round_trips_and_fingerprint_ignores_cosmetics(tmp_path):
    st = Study.from_dict(
        {"study": {"seed": 3, "realizations": 4}, "psd": {"n": 300}, "analysis": {"rdf": {"r_max": 1.0}}}
    )
    again = Study.from_dict(tomllib.loads(st.to_toml()))
    assert again.data == st.data
    assert again.fingerprint == st.fingerprint
    # name, realizations and output do not change what a realization is ...
    assert st.replace(study={"realizations": 9, "name": "x"}, output={"plots": False}).fingerprint == st.fingerprint
    # ... the seed, sizes, protocol and analyses do
    assert st.replace(study={"seed": 4}).fingerprint != st.fingerprint
    assert st.replace(psd={"n": 301}).fingerprint != st.fingerprint
    assert st.replace(protocol={"volume_fraction": 0.55}).fingerprint != st.fingerprint
    st.write_resolved(tmp_path)
    import json

    doc = json.loads((tmp_path / "study.resolved.json").read_text())
    assert doc["fingerprint"] == st.fingerprint
    assert set(doc["versions"]) >= {"polypack", "python", "numpy", "numba"}
    assert Study.from_dict(tomllib.loads((tmp_path / "study.resolved.toml").read_text())).data == st.data


def test_load_study_file_errors(tmp_path):
    with pytest.raises(InvalidInputError, match="does not exist"):
        load_study(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[study\nseed = 1\n")
    with pytest.raises(InvalidInputError, match="not valid TOML"):
        load_study(bad)
    ok = tmp_path / "mystudy.toml"
    ok.write_text("[study]\nseed = 7\n")
    with pytest.raises(InvalidInputError, match="no \\[psd\\] or \\[protocol\\] section"):
        load_study(ok)  # a study file names its size distribution and protocol (no silent default)
    ok.write_text('[study]\nseed = 7\n[psd]\nmodel = "bimodal"\n[protocol]\nkind = "crm"\n')
    assert load_study(ok).name == "mystudy"


@pytest.mark.parametrize("name", ["bimodal_propellant.toml", "cb_grading.toml"])
def test_bundled_examples_validate(name):
    st = load_study(EXAMPLES / name)
    assert st.realizations >= 1


def test_bimodal_example_is_seed_000():
    d = load_study(EXAMPLES / "bimodal_propellant.toml").data
    assert d["psd"]["model"] == "bimodal"
    assert (d["psd"]["size_ratio"], d["psd"]["volume_ratio"]) == (0.313, 0.333)
    assert d["protocol"]["kind"] == "scrm" and d["protocol"]["volume_fraction"] == 0.6
    assert {"rdf", "windows", "pores"} <= set(d["analysis"])


def test_cli_check(tmp_path, capsys):
    from polypack.cli import main

    f = tmp_path / "s.toml"
    f.write_text('[protocol]\nkind = "crm"\nvolume_fraction = 1.2\n')
    with pytest.raises(SystemExit) as ei:
        main(["run", "--check", str(f)])
    assert ei.value.code == 1
    err = capsys.readouterr().err
    assert "error: protocol.volume_fraction = 1.2: must be in (0, 1)" in err
    nopsd = tmp_path / "nopsd.toml"
    nopsd.write_text('[protocol]\nkind = "crm"\nvolume_fraction = 0.5\n')
    with pytest.raises(SystemExit):  # a study file must name its size distribution
        main(["run", "--check", str(nopsd)])
    assert "no [psd] section" in capsys.readouterr().err
    f.write_text('[psd]\nmodel = "bimodal"\n[protocol]\nkind = "crm"\nvolume_fraction = 0.5\n'
                 '[analysis.rdf]\nr_max = 1.0\n')
    main(["run", "--check", str(f)])
    out = capsys.readouterr().out
    assert "valid" in out and "[analysis.rdf]" in out and "dr = 0.02" in out
    assert not (tmp_path / "out").exists()
