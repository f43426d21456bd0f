"""One declaration per capability (issue 30): what a registration declares reaches every output.

* protocol statistics are declared outputs of each protocol's registration (``Outputs.meta``):
  VEM and deposition statistics reach the realization record and ``summary.csv``;
* mechanics is a registry kind that shares the ``[analysis.NAME]`` tables with the analyses;
* the report labels the rows with the declared words and the protocol's declared name.
"""

import csv
import json

import numpy as np
import pytest

import polypack as pp
from polypack import registry
from polypack.ensemble.stages import protocol_stats
from polypack.errors import InvalidInputError


def _rows(out):
    with open(out / "summary.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def _study(protocol, psd, analysis=None, realizations=1):
    return {"study": {"name": "decl", "seed": 3, "realizations": realizations}, "psd": psd,
            "protocol": protocol, "analysis": analysis or {}, "output": {"plots": False}}


def test_vem_statistics_reach_the_record_and_summary(tmp_path):
    """The bug of issue 30: protocol_stats hard-coded shake/scrm/brownian, so meta["vem"] was dropped."""
    out = tmp_path / "vem"
    pp.ensemble.run_study(_study({"kind": "vem", "void_ratio": 0.5},
                                 {"model": "monodisperse", "d": 1.0, "n": 64}), out, progress=False)
    rec = json.loads((out / "realizations" / "r0000.json").read_text())
    pk = pp.io.read(out / "realizations" / "r0000.gsd")
    row = _rows(out)[0]
    for key in ("stages", "n_void", "coordination_at_jamming", "bonds_at_jamming", "stop_reason", "steps"):
        assert f"vem.{key}" in rec["protocol"], key
        assert f"protocol.vem.{key}" in row, key
    # the values are the generator's own (meta["vem"] of the stored pack is what the record flattens)
    assert rec["protocol"]["vem.n_void"] == 32  # N_V / N = 0.5 of N = 64
    assert int(row["protocol.vem.stages"]) == rec["protocol"]["vem.stages"] > 0
    assert float(row["protocol.vem.coordination_at_jamming"]) == pytest.approx(
        rec["protocol"]["vem.coordination_at_jamming"], rel=1e-12)
    assert "vem.series" not in rec["protocol"]  # per-stage series are not scalars
    assert abs(pk.volume_fraction - 0.4) < 1e-9
    scal = json.loads((out / "ensemble" / "scalars.json").read_text())
    assert scal["protocol.vem.n_void"]["mean"] == 32


def test_deposit_statistics_reach_the_record_and_summary(tmp_path):
    out = tmp_path / "dep"
    pp.ensemble.run_study(_study({"kind": "deposit"}, {"model": "uniform_volume", "d_min": 0.5, "d_max": 1.0,
                                                       "n": 120, "dim": 2}), out, progress=False)
    rec = json.loads((out / "realizations" / "r0000.json").read_text())
    pk = pp.io.read(out / "realizations" / "r0000.gsd")
    row = _rows(out)[0]
    for key in ("chain_length", "chain_max", "n_bed", "boundary"):
        assert key in rec["protocol"] and f"protocol.{key}" in row, key
    assert rec["protocol"]["chain_max"] >= rec["protocol"]["chain_length"] >= 1
    assert rec["protocol"]["n_bed"] == 0 and pk.meta["chain_max"] == rec["protocol"]["chain_max"]


def test_protocol_statistics_are_what_the_registration_declares():
    meta = {"status": "target", "min_gap": 1e-9, "vem": {"stages": [{"c": 1}, {"c": 2}, {"c": 3}], "n_void": 5, "series": {"a": [1]}},
            "shake": {"acceptance_rate": [[0.2, 0.3], [0.4, 0.5]]}, "history": [1, 2]}
    vem = protocol_stats(meta, "vem")
    assert vem == {"status": "target", "min_gap": 1e-9, "vem.stages": 3, "vem.n_void": 5}  # meta["shake"] not declared
    crm = protocol_stats(meta, registry.get("protocol", "crm"))
    assert crm["shake.acceptance_rate.0"] == 0.4 and "vem.n_void" not in crm
    assert registry.get("protocol", "scrm").meta_tables() == ("shake", "scrm")


def test_mechanics_is_a_registry_kind_sharing_the_analysis_tables():
    assert "mechanics" in registry.KINDS
    mech = registry.names("mechanics")
    assert {"elastic", "shear", "moduli"} <= set(mech)
    assert not set(mech) & set(registry.names("analysis"))
    assert registry.get("analysis", "elastic").kind == "mechanics"  # [analysis.elastic] finds it
    assert set(registry.stages()) == set(registry.names("analysis")) | set(mech)
    sch = pp.study.schema()
    for name in mech:
        assert set(sch[f"analysis.{name}"]) == set(registry.get("mechanics", name).specs())
    with pytest.raises(InvalidInputError, match="the name is taken by analysis 'rdf'"):
        registry.register("mechanics", "rdf", registry.get("analysis", "rdf").options, lambda p, o, s: {})


def test_report_labels_come_from_the_declarations(tmp_path):
    from polypack.report.build import _declared_words, _protocol_label

    assert _protocol_label({"protocol": {"kind": "vem"}}) == "VEM"
    assert _protocol_label({"protocol": {"kind": "nonesuch"}}) == "nonesuch"
    st = {"protocol": {"kind": "vem"}}
    assert _declared_words("protocol.vem.stages", st) == "void expansion stages"
    assert _declared_words("protocol.chain_max", {"protocol": {"kind": "deposit"}}).startswith("longest")
    assert _declared_words("protocol.vem.nonesuch", st) == ""
    assert np.isfinite(1.0)
