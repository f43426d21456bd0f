"""The registry: one declaration per capability drives the study schema, the stages, the
summary table, the ensemble curves, ``polypack psd`` and plugins."""

import csv
import json
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import polypack as pp
from polypack import _validate as v
from polypack import registry
from polypack.cli import main
from polypack.errors import InvalidInputError
from polypack.study import load_study, validate

PLUGINS = Path(__file__).parent / "plugins"


# --------------------------------------------------------------------------- a toy analysis
@dataclass(frozen=True)
class ToyOptions:
    bins: int = registry.option(4, v.int_min(1), "number of radius bins")


def run_toy(packing, opts, seed):
    """Histogram of the radii and the largest radius: plain data, checked against the pack below."""
    counts, edges = np.histogram(packing.radii, bins=opts["bins"])
    return {"estimator": "Toy", "r": (0.5 * (edges[1:] + edges[:-1])).tolist(), "count": counts.tolist(),
            "max_radius": float(packing.radii.max()), "n_realizations": 1}


@pytest.fixture
def toy():
    cap = registry.register(
        "analysis", "toy", ToyOptions, run_toy,
        registry.Outputs(curves=registry.Curves("r", "radius r", "number of spheres")),
        doc="radius histogram (test)")
    yield cap
    registry.unregister("analysis", "toy")


def _tiny_study(extra_analysis=None, **protocol):
    st = {
        "study": {"name": "tiny", "seed": 1, "realizations": 2},
        "psd": {"model": "bimodal", "size_ratio": 0.5, "volume_ratio": 0.5, "n": 60},
        "protocol": {"kind": "crm", "volume_fraction": 0.3, **protocol},
        "analysis": {"contacts": {}},
        "output": {"plots": True},
    }
    if extra_analysis:
        st["analysis"].update(extra_analysis)
    return st


def test_a_toy_analysis_is_one_function_plus_one_registration(toy, tmp_path):
    # the schema knows it at once, with its options and their checks
    assert "analysis.toy" in pp.study.schema()
    with pytest.raises(InvalidInputError, match=r"analysis.toy.bins = 0: must be an integer >= 1"):
        validate(_tiny_study({"toy": {"bins": 0}}))
    res = pp.ensemble.run_study(_tiny_study({"toy": {"bins": 3}}), tmp_path / "run", progress=False)
    assert len(res.records) == 2
    with open(tmp_path / "run" / "summary.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for k, row in enumerate(rows):
        pk = pp.io.read(tmp_path / "run" / "realizations" / f"r{k:04d}.gsd")
        assert float(row["toy.max_radius"]) == pk.radii.max()  # the summary column comes from the declaration
        rec = json.loads((tmp_path / "run" / "realizations" / f"r{k:04d}.json").read_text())
        assert sum(rec["analysis"]["toy"]["count"]) == pk.n
    curves = json.loads((tmp_path / "run" / "ensemble" / "curves.json").read_text())["analyses"]
    assert curves["toy"]["x_name"] == "r" and set(curves["toy"]["curves"]) == {"count"}
    assert (tmp_path / "run" / "ensemble" / "toy.png").is_file()
    assert "contacts" in curves or True  # contacts has no curves; it must not break aggregation


def test_unused_protocol_option_is_an_error():
    with pytest.raises(InvalidInputError, match=r'protocol.max_seconds: only used with protocol.kind = "crm"'):
        validate({"protocol": {"kind": "scrm", "volume_fraction": 0.5, "max_seconds": 10.0}})
    with pytest.raises(InvalidInputError, match=r'protocol.growth_steps: only used with protocol.kind = "scrm"'):
        validate({"protocol": {"kind": "crm", "growth_steps": 3}})
    with pytest.raises(InvalidInputError, match=r"protocol.speed: unknown key"):
        validate({"protocol": {"kind": "crm", "speed": 3}})
    assert validate({"protocol": {"kind": "crm", "max_seconds": 10.0}})["protocol"]["max_seconds"] == 10.0


def test_schema_is_generated_from_the_registry():
    sch = pp.study.schema()
    for name in registry.names("analysis"):
        assert set(sch[f"analysis.{name}"]) == set(registry.get("analysis", name).specs())
    for cap in registry.capabilities("protocol").values():
        assert set(cap.specs()) <= set(sch["protocol"])
    for cap in registry.capabilities("psd").values():
        assert set(cap.specs()) <= set(sch["psd"])
    assert "seed" not in sch["psd"]  # a study's sizes take their seed from study.seed
    text = pp.study.schema_doc()
    assert "[analysis.rdf]" in text and "r_max: number > 0; default 3.0" in text


def test_register_rejects_bad_declarations():
    with pytest.raises(InvalidInputError, match="kind='widget'"):
        registry.register("widget", "x", ToyOptions, run_toy)
    with pytest.raises(InvalidInputError, match="already registered"):
        registry.register("analysis", "rdf", ToyOptions, run_toy)
    with pytest.raises(InvalidInputError, match="must be a dataclass"):
        registry.register("analysis", "y", dict, run_toy)
    with pytest.raises(InvalidInputError, match="must be an identifier"):
        registry.register("analysis", "my-analysis", ToyOptions, run_toy)


# --------------------------------------------------------------------------- one [psd] table
SIEVE = "size,passing\n0.1,0\n0.2,30\n0.4,100\n"


def _psd_tables(tmp_path):
    (tmp_path / "sieve.csv").write_text(SIEVE)
    return [
        {"model": "bimodal", "size_ratio": 0.313, "volume_ratio": 0.333, "n": 300},
        {"model": "bimodal", "spread": 0.05, "sampling": "discretize", "spacing": "modes", "min_total": 200},
        {},  # every default (bimodal, n = 2000)
        {"model": "cumulative_beta", "a": 2.0, "b": 3.0, "span": 0.6, "n_classes": 5, "min_total": 300},
        {"model": "cb", "a": 1.0, "b": 1.0, "d_min": 0.5, "d_max": 1.0, "n": 200, "method": "quantiles"},
        {"model": "uniform_volume", "d_min": 0.5, "d_max": 1.0, "n": 200},
        {"model": "uniform_size", "span": 0.4, "sampling": "discretize", "n_classes": 4, "min_total": 100},
        {"model": "lognormal", "median": 1.0, "sigma": 0.25, "n": 300, "method": "quantiles"},
        {"model": "normal", "mean": 1.0, "std": 0.1, "d_min": 0.8, "n": 100},
        {"model": "monodisperse", "d": 2.0, "n": 50},
        {"model": "monodisperse", "sampling": "discretize", "spacing": "modes", "min_total": 40},
        {"model": "mixture", "sizes": [1.0, 0.4], "volume_fractions": [0.7, 0.3], "n": 120},
        {"model": "sieve", "sieve": str(tmp_path / "sieve.csv"), "spacing": "modes", "min_total": 100},
        {"model": "bimodal", "dim": 2, "n": 100},
    ]


BAD_TABLES = [
    {"model": "gamma"},
    {"model": "bimodal", "a": 2.0},
    {"size_ratio": 3.0},
    {"n": 1},
    {"n": 100, "n_classes": 5},
    {"model": "uniform_volume", "d_min": 2.0, "d_max": 1.0},
    {"model": "cumulative_beta", "span": 0.5, "d_min": 0.2, "d_max": 1.0},
    {"model": "mixture", "sizes": [1.0]},
    {"model": "bimodal", "shape": 3},
    {"sampling": "discretize", "n": 10},
]


def _toml_value(x):
    return json.dumps(x) if not isinstance(x, bool) else ("true" if x else "false")


def _cli_sizes(table, tmp_path, seed, tag):
    cfg = tmp_path / f"{tag}.toml"
    cfg.write_text("[psd]\n" + "".join(f"{k} = {_toml_value(x)}\n" for k, x in table.items()))
    out = tmp_path / f"{tag}.csv"
    main(["psd", "--config", str(cfg), "--seed", str(seed), "-o", str(out)])
    return pp.psd.SizeSet.load(out)


def test_psd_and_run_agree_on_every_psd_table(tmp_path):
    from polypack.ensemble.stages import make_sizes

    tables = _psd_tables(tmp_path)
    models = {pp.registry.canonical("psd", t.get("model", "bimodal")) for t in tables}
    assert models == set(registry.names("psd")), "every registered model is covered"
    for k, table in enumerate(tables):
        study = validate({"psd": table})["psd"]
        run_sizes = make_sizes(study, np.random.SeedSequence(11))
        cli_sizes = _cli_sizes(table, tmp_path, 11, f"t{k}")
        assert np.array_equal(cli_sizes.radii, run_sizes.radii), table
        assert np.array_equal(cli_sizes.species, run_sizes.species), table
        assert cli_sizes.dim == run_sizes.dim


@pytest.mark.parametrize("table", BAD_TABLES, ids=[json.dumps(t) for t in BAD_TABLES])
def test_psd_and_run_reject_a_bad_table_with_the_same_message(tmp_path, capsys, table):
    with pytest.raises(InvalidInputError) as ei:
        validate({"psd": table})
    study_msg = str(ei.value)
    with pytest.raises(SystemExit):
        _cli_sizes(table, tmp_path, 1, "bad")
    cli_msg = capsys.readouterr().err.strip()
    if "unknown key" in study_msg:  # the allowed lists differ by `seed` (polypack psd only)
        study_msg, cli_msg = study_msg.split("; allowed")[0], cli_msg.split("; allowed")[0]
    assert cli_msg == f"error: {study_msg}"


def test_psd_cli_options_are_generated_from_the_registry():
    from polypack._cli.psd_commands import psd_options

    specs, _ = psd_options()
    want = {k for cap in registry.capabilities("psd").values() for k in cap.specs()}
    assert want <= set(specs)
    res = subprocess.run([sys.executable, "-m", "polypack.cli", "psd", "--help"], capture_output=True, text=True,
                         env={**os.environ, "COLUMNS": "200"})
    for k in want:
        assert "--" + k.replace("_", "-") in res.stdout, k


# --------------------------------------------------------------------------- entry-point plugins
def test_entry_point_plugin_adds_an_analysis(tmp_path):
    """A third-party package registers through the ``polypack.capabilities`` entry point."""
    study = tmp_path / "s.toml"
    study.write_text(
        '[study]\nname = "plug"\nrealizations = 1\n[psd]\nmodel = "monodisperse"\nn = 30\n'
        '[protocol]\nkind = "crm"\nvolume_fraction = 0.2\n[analysis.largest]\nscale = 2.0\n[output]\nplots = false\n'
    )
    code = (
        "import json, sys; from polypack import registry; from polypack.ensemble import run_study;"
        "assert 'largest' in registry.names('analysis');"
        f"run_study({str(study)!r}, {str(tmp_path / 'out')!r}, progress=False);"
        f"print(json.load(open({str(tmp_path / 'out' / 'realizations' / 'r0000.json')!r}))['scalars'])"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(PLUGINS), os.environ.get("PYTHONPATH", "")])}
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert res.returncode == 0, res.stderr
    scalars = eval(res.stdout.strip())  # noqa: S307 - our own printed dict
    assert scalars["largest.largest"] == pytest.approx(1.0)  # monodisperse d = 1: radius 0.5, scale 2
    assert scalars["largest.mean"] == pytest.approx(1.0)
    # without the plugin on the path the study is rejected with the allowed analyses
    with pytest.raises(InvalidInputError, match="analysis.largest: unknown analysis; allowed: rdf"):
        load_study(study)


def test_analyze_runs_any_registered_analysis(toy, tmp_path, capsys):
    pk = pp.Packing(np.array([[1.0, 1.0, 1.0], [3.0, 3.0, 3.0], [1.0, 3.0, 1.0]]), [0.5, 0.25, 0.25], 6.0)
    pp.io.write(tmp_path / "p.gsd", pk)
    main(["analyze", str(tmp_path / "p.gsd"), "--run", "toy:bins=2", "--run", "contacts:tolerance=0.1",
          "--json", str(tmp_path / "r.json")])
    res = json.loads((tmp_path / "r.json").read_text())["registered"]
    assert res["toy"]["max_radius"] == 0.5 and sum(res["toy"]["count"]) == 3
    assert res["contacts"]["coordination"] == 0.0  # nobody within 10 % of contact
    with pytest.raises(SystemExit):
        main(["analyze", str(tmp_path / "p.gsd"), "--run", "toy:bins=0"])
    assert "analysis.toy.bins = 0: must be an integer >= 1" in capsys.readouterr().err
