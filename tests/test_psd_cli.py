"""``polypack psd`` through polypack.cli.main."""

import json

import numpy as np
import pytest

import polypack as pp
from polypack.cli import main


def test_cli_cb_discretize_writes_set_report_and_plots(tmp_path, capsys):
    out = tmp_path / "s.csv"
    main(["psd", "--model", "cb", "--a", "2", "--b", "2", "--span", "0.8", "--n-classes", "6", "--min-total", "500",
          "--seed", "4", "-o", str(out), "--plots", str(tmp_path / "plots")])
    s = pp.psd.SizeSet.load(out)
    ref = pp.psd.discretize(pp.psd.CumulativeBeta(a=2, b=2, span=0.8), n_classes=6, min_total=500, seed=4)
    assert np.array_equal(s.radii, ref.radii) and np.array_equal(s.species, ref.species)
    rep = json.loads((tmp_path / "s.json").read_text())
    assert rep["model"]["a"] == 2.0 and rep["parameters"]["n_classes"] == 6 and rep["seed"]["entropy"] == 4
    assert {p.name for p in (tmp_path / "plots").iterdir()} == {"grading.png", "histogram.png"}
    assert "wrote 500 sizes" in capsys.readouterr().out


def test_cli_bimodal_sample_has_168_large(tmp_path):
    out = tmp_path / "bi.csv"
    main(["psd", "--model", "bimodal", "--size-ratio", "0.313", "--volume-ratio", "0.333", "--n", "2000",
          "--seed", "1", "-o", str(out)])
    s = pp.psd.SizeSet.load(out)
    assert s.n == 2000 and np.sum(s.species == 0) == 168


def test_cli_config_toml_and_override(tmp_path):
    cfg = tmp_path / "study.toml"
    cfg.write_text('[study]\nname = "x"\n\n[psd]\nmodel = "lognormal"\nmedian = 1.0\nsigma = 0.25\n'
                   'n = 300\nmethod = "quantiles"\n')
    out = tmp_path / "ln.csv"
    main(["psd", "--config", str(cfg), "--sigma", "0.1", "-o", str(out)])
    s = pp.psd.SizeSet.load(out)
    ref = pp.psd.LogNormal(1.0, 0.1).sample(300, method="quantiles")
    np.testing.assert_array_equal(np.sort(s.radii), np.sort(ref.radii))


def test_cli_sieve_table(tmp_path):
    sieve = tmp_path / "sieve.csv"
    sieve.write_text("size,passing\n0.1,0\n0.2,30\n0.4,100\n")
    main(["psd", "--model", "sieve", "--sieve", str(sieve), "--spacing", "modes", "--method", "quantiles",
          "-o", str(tmp_path / "sv.csv")])
    s = pp.psd.SizeSet.load(tmp_path / "sv.csv")
    assert s.n >= 2000 and s.diameters.min() >= 0.1 and s.diameters.max() <= 0.4


@pytest.mark.parametrize("argv,needle", [
    (["--model", "gamma"], 'psd.model = "gamma": allowed: bimodal, cumulative_beta'),
    (["--model", "cb", "--a", "1", "--b", "1", "--span", "0.5", "--median", "2"],
     'psd.median: not a parameter of model "cumulative_beta"; allowed: a, b, span'),
    (["--model", "cb", "--a", "-1", "--b", "1", "--span", "0.5"], "psd.a = -1.0: must be > 0"),
    (["--model", "cb", "--a", "1", "--b", "1", "--span", "1.5"], "psd.span = 1.5: must be in (0, 1)"),
    (["--model", "cb", "--a", "1", "--b", "3", "--span", "0.98", "--max-total", "1000"], "more than max_total=1000"),
    (["--model", "mixture", "--sizes", "1,0.5", "--volume-fractions", "0.5,0.4"], "must sum to 1"),
    (["--model", "cb", "--a", "1", "--b", "1", "--span", "0.5", "--n", "10", "--n-classes", "4"],
     'psd.n_classes: only used with psd.sampling = "discretize"'),
])
def test_cli_bad_input_is_one_line_error(tmp_path, capsys, argv, needle):
    with pytest.raises(SystemExit) as e:
        main(["psd", *argv, "-o", str(tmp_path / "x.csv")])
    assert e.value.code == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and needle in err and "\n" not in err
    assert not (tmp_path / "x.csv").exists()


def test_cli_config_unknown_key(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[psd]\nmodel = "cb"\na = 1\nb = 1\nspan = 0.5\nshape = 3\n')
    with pytest.raises(SystemExit):
        main(["psd", "--config", str(cfg), "-o", str(tmp_path / "x.csv")])
    err = capsys.readouterr().err
    assert "psd.shape: unknown key; allowed:" in err


def test_cli_unknown_option_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["psd", "--shape", "3", "-o", str(tmp_path / "x.csv")])
    assert e.value.code == 2
    assert "No such option: --shape" in capsys.readouterr().err
