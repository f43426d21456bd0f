"""Sweeps of several structure sets in one run (``[[sweep.set]]``, issue 32): VEM and Brownian-dynamics
sets of seed 003 (003_873b69fc71c74cf6.txt) with one report (Table 2, Figs. 2, 5, 6, the joint fit of
Eq. (7) of 003_873b69fc71c74cf6.txt) and the dynamic G'p of chosen values beside the static one."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import polypack as pp

from polypack.ensemble.sweep import run_sweep, sweep_plan, sweep_studies
from polypack.errors import InvalidInputError

ROOT = Path(__file__).resolve().parents[1]

#: A two-set study at tiny N (48 VEM spheres coagulated: rigid; 40 BD spheres): seconds per structure.
TWO_SETS = """
[study]
name = "two"
seed = 3
realizations = 2

[psd]
model = "monodisperse"
d = 0.5e-6
n = 48

[protocol]
kind = "vem"
volume_fraction = 0.4
restructure = "coagulation"

[analysis.pores]
n_points = 2000

[analysis.contacts]
tolerance = 0.01

[analysis.elastic]
bonds = "distance"
epsilon = 0.01
normal_stiffness = 100.0
stiffness = "particle"
radius = 0.25e-6

[output]
plots = false

[sweep]
report = "heterogeneity"
fig5_kn = [50.0, 100.0]

[sweep.shear]
cycles = 3
steps_per_cycle = 1000
samples_per_cycle = 20
directions = [[2, 0]]

[[sweep.set]]
name = "vem"
parameter = "protocol.void_ratio"
values = [0.25, 1.0]
dynamic = [0.25]

[[sweep.set]]
name = "bd"
parameter = "protocol.surface_potential"
values = [0.0, 0.012]
dynamic = 0.0
[sweep.set.psd]
n = 40
[sweep.set.protocol]
kind = "brownian"
volume_fraction = 0.4
"""


def _data():
    import tomllib

    return tomllib.loads(TWO_SETS)


def test_sets_are_ordinary_studies_with_their_own_protocol():
    """Each set's values are studies of that set's protocol: the same kind merges into [protocol] key by
    key, another kind replaces it (a VEM option never reaches the BD study); [sweep.set.psd] overrides;
    the dynamic values (only they) get [analysis.shear] with the bond options of [analysis.elastic]
    and the [sweep.shear] options; the folders are <set>/<key>=<value>."""
    sw, entries, name = sweep_plan(_data())
    assert name == "two" and [s["name"] for s in sw["sets"]] == ["vem", "bd"]
    got = [(e.set, e.value, str(e.rel), e.dynamic) for e in entries]
    assert got == [("vem", 0.25, "vem/void_ratio=0.25", True), ("vem", 1.0, "vem/void_ratio=1", False),
                   ("bd", 0.0, "bd/surface_potential=0", True), ("bd", 0.012, "bd/surface_potential=0.012", False)]
    for e in entries:
        d = e.study.data
        kind = "vem" if e.set == "vem" else "brownian"
        assert d["protocol"]["kind"] == kind
        assert d["protocol"][e.parameter.split(".")[-1]] == e.value
        assert d["psd"]["n"] == (48 if e.set == "vem" else 40)
        assert e.study.seed == 3  # common random numbers across values and sets
        if e.set == "vem":
            assert d["protocol"]["restructure"] == "coagulation"  # merged with the study's [protocol]
        else:
            assert "restructure" not in d["protocol"] and "void_ratio" not in d["protocol"]
        assert ("shear" in d["analysis"]) == e.dynamic
        if e.dynamic:
            sh = d["analysis"]["shear"]
            assert (sh["bonds"], sh["epsilon"], sh["stiffness"], sh["radius"]) == ("distance", 0.01, "particle",
                                                                                  0.25e-6)
            assert (sh["cycles"], sh["steps_per_cycle"], sh["directions"]) == (3, 1000, [[2, 0]])
    assert len({e.study.fingerprint for e in entries}) == 4
    # the same kind in a set's [protocol]: merged key by key (the study's restructure stays)
    d = _data()
    d["sweep"]["set"][0]["protocol"] = {"kind": "vem", "growth_factor": 1.05}
    _, entries, _ = sweep_plan(d)
    assert entries[0].study.data["protocol"]["restructure"] == "coagulation"
    assert entries[0].study.data["protocol"]["growth_factor"] == 1.05
    # a study that has its own [analysis.shear] (every value): kept, [sweep.shear] on top for the dynamic ones
    d = _data()
    d["analysis"]["shear"] = {"amplitude": 5e-4, "cycles": 7}
    _, entries, _ = sweep_plan(d)
    sh = entries[0].study.data["analysis"]["shear"]
    assert (sh["amplitude"], sh["cycles"], sh["bonds"]) == (5e-4, 3, "distance")
    assert entries[1].study.data["analysis"]["shear"]["cycles"] == 7
    # the old form (one parameter, no sets) keeps its folders and its dynamic choice
    d = _data()
    del d["sweep"]["set"]
    d["sweep"].update(parameter="protocol.void_ratio", values=[0.5, 2.0], dynamic=2)
    _, entries, _ = sweep_plan(d)
    assert [(str(e.rel), e.dynamic) for e in entries] == [("void_ratio=0.5", False), ("void_ratio=2", True)]


def _set(**kw):
    d = _data()
    d["sweep"]["set"][1].update(kw)
    return d


@pytest.mark.parametrize("edit, match", [
    (lambda d: d["sweep"]["set"][1].update(bogus=1), r'^sweep.set "bd".bogus: unknown key; allowed in \[\[sweep.set\]\]'),
    (lambda d: d["sweep"]["set"][1].update(name="vem"), r"^sweep.set #2.name = 'vem': another set has this name"),
    (lambda d: d["sweep"]["set"][1].update(name="heterogeneity"), r"^sweep.set #2.name = 'heterogeneity': give a "
                                                                   "folder name"),
    (lambda d: d["sweep"]["set"][1].update(name="a/b"), r"^sweep.set #2.name = 'a/b'"),
    (lambda d: d["sweep"]["set"][1].update(values=[]), r'^sweep.set "bd".values = \[\]: give a non-empty list$'),
    (lambda d: d["sweep"]["set"][1].update(parameter="surface_potential"),
     r'^sweep.set "bd".parameter = \'surface_potential\': give a key path'),
    (lambda d: d["sweep"]["set"][1].update(dynamic=0.013), r'^sweep.set "bd".dynamic = 0.013: 0.013 is not one of '
                                                            r"the values \[0.0, 0.012\]"),
    (lambda d: d["sweep"]["set"][1].update(label=""), r'^sweep.set "bd".label = \'\': give a text'),
    (lambda d: d["sweep"]["set"][1].update(protocol="brownian"), r'^sweep.set "bd".protocol = \'brownian\': '
                                                                  "expected a table"),
    (lambda d: d["sweep"]["set"][1].update(analysis={"elastic": 1}), r'^sweep.set "bd".analysis.elastic = 1: '
                                                                      "expected a table"),
    (lambda d: d["sweep"]["set"][1].update(values=[0.0, "high"]),
     r'^sweep.set "bd" value \'high\': protocol.surface_potential = "high": expected a number'),
    (lambda d: d["sweep"]["set"][1]["protocol"].update(bonds="glue"),
     r'^sweep.set "bd" value 0.0: protocol.bonds = "glue": allowed: "flexible"'),
    (lambda d: d["sweep"]["set"][1]["protocol"].update(void_ratio=1.0),
     r'^sweep.set "bd" value 0.0: protocol.void_ratio: only used with protocol.kind = "vem"'),
    (lambda d: d["sweep"]["set"][0].update(analysis={"elastic": {"epsilon": -1.0}}),
     r'^sweep.set "vem" value 0.25: analysis.elastic.epsilon = -1.0'),
    (lambda d: d["sweep"].update(parameter="protocol.void_ratio"), r"^sweep.parameter: with \[\[sweep.set\]\] tables "
                                                                   "give parameter in each set"),
    (lambda d: d["sweep"].update(set=[]), r"^sweep.set = \[\]: give one or more \[\[sweep.set\]\] tables$"),
    (lambda d: d["sweep"]["shear"].update(cycles=0), r"^sweep.shear.cycles = 0: "),
    (lambda d: d["sweep"]["shear"].update(bogus=1), r"^sweep.shear.bogus: unknown key"),
    (lambda d: d["sweep"]["set"][1].update(analysis={"pores": {"n_points": 5}}),
     r'^sweep.set "bd" value 0.0: analysis.pores.n_points = 5'),
    (lambda d: d["sweep"].update(modulus="shear"), r'^sweep.set "vem": sweep.modulus = "shear": needs '
                                                   r"\[analysis.shear\]"),
])
def test_bad_set_tables_are_one_line_errors(edit, match):
    d = _data()
    edit(d)
    with pytest.raises(InvalidInputError, match=match) as info:
        sweep_studies(d)
    assert "\n" not in str(info.value)


def test_check_validates_every_set_through_the_cli(tmp_path, capsys):
    """``polypack run --check`` names every set with its values and dynamic choice; a bad option of
    the second set is one line naming the set, the value and the key."""
    from polypack.cli import main

    f = tmp_path / "two.toml"
    f.write_text(TWO_SETS)
    main(["run", str(f), "--check"])
    out = capsys.readouterr().out
    assert "valid sweep of 2 sets, 4 values in all" in out
    assert "vem: protocol.void_ratio = 0.25, 1.0; dynamic G'p at 0.25" in out
    assert "bd: protocol.surface_potential = 0.0, 0.012; dynamic G'p at 0.0" in out
    f.write_text(TWO_SETS.replace('kind = "brownian"\n', 'kind = "brownian"\ntime_step = -1.0\n'))
    with pytest.raises(SystemExit) as info:
        main(["run", str(f), "--check"])
    assert info.value.code == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith('error: sweep.set "bd" value 0.0: protocol.time_step = -1.0')
    assert not (tmp_path / "out").exists()


def _records(folder):
    return [json.loads(p.read_text()) for p in sorted((folder / "realizations").glob("r*.json"))]


@pytest.mark.slow
def test_two_sets_run_end_to_end_through_the_cli(tmp_path):
    """One command makes both sets into sub-folders of one output folder and one report: Table 2 holds
    the rows of both sets beside the seed's row of their kind and value, the joint fit of Eq. (7) of
    003_873b69fc71c74cf6.txt takes the rigid structures of both, Fig. 5 comes from the BD set, the
    dynamic G'p of the dynamic values (one per set) stands beside the static one (the mean of their
    records' storage moduli), and report.html shows all of it. Rerunning resumes: nothing is recomputed,
    and a lost realization of one set is recomputed alone."""
    from typer.testing import CliRunner

    from polypack.analysis.powerlaw import power_law_fit
    from polypack.cli import app

    f = tmp_path / "two.toml"
    f.write_text(TWO_SETS)
    out = tmp_path / "o"
    res = CliRunner().invoke(app, ["run", str(f), "--out", str(out), "--no-progress"])
    assert res.exit_code == 0, res.output
    subs = ["vem/void_ratio=0.25", "vem/void_ratio=1", "bd/surface_potential=0", "bd/surface_potential=0.012"]
    for sub in subs:
        assert (out / sub / "summary.csv").exists() and (out / sub / "report.html").exists()
        assert len(_records(out / sub)) == 2
    kinds = {sub: json.loads((out / sub / "study.resolved.json").read_text())["study"]["protocol"]["kind"]
             for sub in subs}
    assert kinds == dict(zip(subs, ["vem", "vem", "brownian", "brownian"]))
    assert json.loads((out / subs[2] / "study.resolved.json").read_text())["study"]["psd"]["n"] == 40
    data = json.loads((out / "heterogeneity" / "fit.json").read_text())
    labels = ["VEM N_V/N = 0.25", "VEM N_V/N = 1", "Brownian Ψ0 = 0 mV", "Brownian Ψ0 = 12 mV"]
    assert [r["set"] for r in data["rows"]] == labels
    assert [r["kind"] for r in data["rows"]] == ["vem", "vem", "brownian", "brownian"]
    # Table 2: each row's a and C are its records' means; the seed's row of its kind and value beside it
    for r, sub in zip(data["rows"], subs):
        recs = _records(out / sub)
        assert r["a"] == pytest.approx(np.mean([q["analysis"]["pores"]["fit"]["seed"]["a"] for q in recs]), rel=1e-12)
        assert r["C"] == pytest.approx(np.mean([q["analysis"]["contacts"]["coordination"] for q in recs]), rel=1e-12)
    md = (out / "heterogeneity" / "table2.md").read_text()
    assert re.search(r"^\| VEM N_V/N = 0.25 \| 0.25 \|.*\| 0.521 \| 4.71 \| 1.83 ± 0.14 \|$", md, re.M)
    assert re.search(r"^\| Brownian Ψ0 = 0 mV \| 0.0 \|.*\| 0.373 \| 4.52 \| 0.48 ± 0.05 \|$", md, re.M)
    assert re.search(r"^\| Brownian Ψ0 = 12 mV \| 0.012 \|.*\| 0.404 \| 4.84 \| 1.19 ± 0.14 \|$", md, re.M)
    # the dynamic G'p: the values that had the shear test, on their first realization only (default
    # dynamic_realizations = 1): that structure's storage moduli, its static G'p beside
    for r, sub in zip(data["rows"], subs):
        recs = _records(out / sub)
        has = ["shear" in q["analysis"] for q in recs]
        assert has == [sub in (subs[0], subs[2]), False]
        if any(has):
            q = recs[0]
            g = np.mean([d["storage_modulus"] for d in q["analysis"]["shear"]["direction"].values()])
            assert r["dynamic"] == 1 and r["G_dyn_MPa"] == pytest.approx(1e-6 * g, rel=1e-12)
            assert r["G_dyn_MPa"] > 0
            p0 = [p for p in data["points"] if p["set"] == r["set"] and p["index"] == 0][0]
            assert r["G_dyn_static_MPa"] == pytest.approx(1e-6 * p0["G_Pa"], rel=1e-12)
            assert f"(1 of 2; static G'p of the same {r['G_dyn_static_MPa']:.3g})" in md
        else:
            assert r["dynamic"] == 0 and r["G_dyn_MPa"] is None
    # the joint fit: every rigid structure of both sets, and only those (an independent refit from the records)
    rigid = [p for p in data["points"] if p["rigid"]]
    assert {p["kind"] for p in rigid} == {"vem", "brownian"}
    assert data["fit"]["n_points"] == len(rigid) >= 6
    a = np.array([p["a"] for p in rigid])
    g = np.array([p["G_Pa"] for p in rigid]) * 1e-6
    sd = np.array([p["G_sd_Pa"] for p in rigid]) * 1e-6
    ref = power_law_fit(a, g, sigma=sd if np.all(sd > 0) else None)
    assert data["fit"]["a0"] == pytest.approx(ref.a0, rel=1e-9, abs=1e-12)
    assert data["fit"]["beta"] == pytest.approx(ref.beta, rel=1e-9, abs=1e-12)
    assert "Brownian" in data["fig5"]["he"]["set"] and "Brownian" in data["fig5"]["ho"]["set"]
    # report.html: the values of both sets linked, Table 2 with both kinds and the dynamic column, figures
    page = (out / "report.html").read_text()
    for sub in subs:
        assert f'href="{sub}/report.html"' in page
    assert "bd: surface_potential=0.012" in page and "vem: void_ratio=0.25" in page
    assert "G′p MPa dynamic (oscillatory shear)" in page
    for lab, seed_a in zip(labels, ("0.521", "0.418", "0.373", "0.404")):
        cells = re.findall(r"<td[^>]*>(.*?)</td>", re.search(rf"<td>{re.escape(lab)}</td>(.*?)</tr>", page, re.S).group(1))
        assert cells[2] == seed_a
        assert (cells[8] == "–") == (lab in (labels[1], labels[3]))
    assert page.count("data:image/png;base64") == 3  # Figs. 2, 5 and 6
    # resume: a second run computes nothing; a lost realization of one set is recomputed alone
    stamps = {p: p.stat().st_mtime_ns for sub in subs for p in (out / sub / "realizations").glob("r*.json")}
    again = run_sweep(f, out, progress=False, echo=lambda s: None)
    assert set(again) == {("vem", 0.25), ("vem", 1.0), ("bd", 0.0), ("bd", 0.012)}
    assert all(not r.computed and len(r.skipped) == 2 for r in again.values())
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps
    lost = out / subs[3] / "realizations" / "r0001.json"
    lost.unlink()
    again = run_sweep(f, out, progress=False, echo=lambda s: None)
    assert {k: r.computed for k, r in again.items()} == {("vem", 0.25): [], ("vem", 1.0): [], ("bd", 0.0): [],
                                                          ("bd", 0.012): [1]}
    assert lost.exists()
    assert all(p.stat().st_mtime_ns == t for p, t in stamps.items() if p != lost)


def test_bundled_seed_study_makes_both_sets():
    """examples/heterogeneity_seed.toml is the whole seed-size study: VEM at the six N_V/N of Table 2 and
    BD at its five Ψ0 (volts), N = 8000, P = 3, one dynamic value per set, the heterogeneity report."""
    from polypack.mechanics.stages import _tensor_key

    sw, entries, name = sweep_plan(ROOT / "examples" / "heterogeneity_seed.toml")
    assert sw["report"] == "heterogeneity" and [s["name"] for s in sw["sets"]] == ["vem", "bd"]
    vem = [e for e in entries if e.set == "vem"]
    bd = [e for e in entries if e.set == "bd"]
    assert [e.value for e in vem] == [0.125, 0.25, 0.5, 1.0, 1.625, 2.0]
    assert [e.value for e in bd] == [0.0, 0.012, 0.013, 0.014, 0.015]
    assert sum(e.dynamic for e in vem) >= 1 and sum(e.dynamic for e in bd) >= 1
    for e in entries:
        d = e.study.data
        assert d["psd"]["n"] == 8000 and d["study"]["realizations"] == 3 and d["psd"]["d"] == 0.5e-6
        assert d["protocol"]["kind"] == ("vem" if e.set == "vem" else "brownian")
        assert d["protocol"]["volume_fraction"] == 0.4
        assert {"pores", "contacts", "elastic"} <= set(d["analysis"])
        assert d["analysis"]["elastic"]["bonds"] == "distance"  # the seed's ε rule for both sets
        assert ("shear" in d["analysis"]) == e.dynamic
        if "rigidity" in d["analysis"]:  # same bond options: the elastic stage's tensor is reused, not recomputed
            assert _tensor_key(d["analysis"]["rigidity"]) == _tensor_key(d["analysis"]["elastic"])
    # the BD set's bond model is the reduced joint study's model A (docs/brownian.md, fifth pass)
    _, reduced, _ = sweep_plan(ROOT / "examples" / "heterogeneity_reduced.toml")
    model_a = next(e for e in reduced if e.set == "bd").study.data["protocol"]
    for e in bd:
        got = dict(e.study.data["protocol"])
        assert got.pop("surface_potential") == e.value
        assert got == {k: v for k, v in model_a.items() if k != "surface_potential"}


def test_bundled_reduced_joint_study_checks(capsys):
    """examples/heterogeneity_reduced.toml (docs/brownian.md, "Joint study, reduced"): ``polypack run --check``
    accepts it; adhesive VEM at four N_V/N and BD model A (tangential bonds, 100 kT rolling moment, 4 nm
    contacts, Kramers escape, 150 a²/D0) at three Ψ0, N = 1000, P = 2, particle stiffnesses, no dynamic test."""
    from polypack.cli import main

    path = ROOT / "examples" / "heterogeneity_reduced.toml"
    main(["run", str(path), "--check"])
    assert "valid sweep of 2 sets, 7 values in all" in capsys.readouterr().out
    sw, entries, _ = sweep_plan(path)
    assert sw["report"] == "heterogeneity"
    assert [e.value for e in entries if e.set == "vem"] == [0.125, 0.5, 1.0, 2.0]
    assert [e.value for e in entries if e.set == "bd"] == [0.0, 0.012, 0.015]
    for e in entries:
        d = e.study.data
        assert d["psd"]["n"] == 1000 and d["study"]["realizations"] == 2 and not e.dynamic
        assert d["analysis"]["elastic"]["stiffness"] == "particle" and d["analysis"]["elastic"]["bonds"] == "distance"
        pr = d["protocol"]
        if e.set == "vem":
            assert pr["restructure"] == "adhesive" and pr["stiffness"] == "particle"
        else:
            assert (pr["bonds"], pr["bond_escape"], pr["minimum_separation"]) == ("tangential", "kramers", 4e-9)
            assert pr["rolling_moment"] / (1.380649e-23 * 293.15) == pytest.approx(100, rel=1e-3)
            assert pr["min_time"] == pr["max_time"] == pytest.approx(150 * 0.0729148, rel=1e-4)


def test_dynamic_gp_beside_the_static_one_from_the_records(tmp_path):
    """The report's dynamic G'p of a value: per structure the mean of its [analysis.shear] storage moduli
    over the directions (spread: their standard deviation); per row the mean over the structures that had
    the test; a floppy network (no DEM run) is 0, a test that did not converge is left out and counted;
    structures without the test have none. The static G'p and the fit do not change."""
    from polypack.studies.seed003_heterogeneity import _dynamic_values, _g_dyn_cell, heterogeneity_report

    def run(name, recs):
        folder = tmp_path / name
        (folder / "realizations").mkdir(parents=True)
        (folder / "study.resolved.json").write_text(json.dumps({"study": {"protocol": {"kind": "vem"}}}))
        for i, (a, g, sh) in enumerate(recs):
            ana = {"pores": {"fit": {"seed": {"a": a, "b": 0.0}}}, "contacts": {"coordination": 4.6},
                   "elastic": {"shear_moduli": [g] * 3, "affine_shear_modulus": 1e8, "rigid": g > 0}}
            if sh is not None:
                ana["shear"] = sh
            rec = {"index": i, "protocol": {"status": "target"}, "analysis": ana}
            (folder / "realizations" / f"r{i:04d}.json").write_text(json.dumps(rec))
        return folder

    def shear(*g, status="ok"):
        return {"status": status, "direction": {f"{k}-0": {"storage_modulus": x} for k, x in enumerate(g)}}

    a = run("a", [(0.45, 2.0e6, shear(1.0e6, 3.0e6)), (0.47, 3.0e6, shear(4.0e6, 6.0e6)),
                  (0.46, 2.5e6, shear(None, status="not_converged"))])
    b = run("b", [(0.40, 1.0e6, None), (0.50, 4.0e6, None)])
    c = run("c", [(0.36, 0.0, {"status": "floppy", "direction": {}})])
    assert _dynamic_values({"analysis": {}}) is None
    assert _dynamic_values({"analysis": {"shear": shear(1.0, 3.0)}}) == (2.0, 1.0, "ok")
    assert _dynamic_values({"analysis": {"shear": {"status": "floppy", "direction": {}}}}) == (0.0, 0.0, "floppy")
    heterogeneity_report(tmp_path / "out", [(0.5, a), (1.0, b), (2.0, c)], parameter="protocol.void_ratio", fig5_kn=[])
    data = json.loads((tmp_path / "out" / "heterogeneity" / "fit.json").read_text())
    ra, rb, rc = data["rows"]
    assert (ra["dynamic"], ra["dynamic_tested"]) == (2, 3)
    assert ra["G_dyn_MPa"] == pytest.approx(3.5)  # structures 2.0 and 5.0 MPa
    # spread: rms of the per-structure spreads (1.0 MPa each) and the variance between structures (4.5 MPa²)
    assert ra["G_dyn_sd_MPa"] == pytest.approx(np.sqrt(1.0 + 4.5))
    assert ra["G_MPa"] == pytest.approx(2.5)  # the static G'p is untouched
    assert _g_dyn_cell(ra) == "3.5 ± 2.3 (2 of 3, 1 not converged)"
    assert (rb["dynamic"], rb["G_dyn_MPa"], _g_dyn_cell(rb)) == (0, None, "–")
    assert (rc["dynamic"], rc["G_dyn_MPa"], _g_dyn_cell(rc)) == (1, 0.0, "0 (floppy, 1 of 1)")
    pts = data["points"]
    assert [p.get("G_dyn_Pa") for p in pts] == [2.0e6, 5.0e6, None, None, None, 0.0]
    assert pts[2]["dynamic_status"] == "not_converged" and "dynamic_status" not in pts[3]
    md = (tmp_path / "out" / "heterogeneity" / "table2.md").read_text()
    assert "| G'p dynamic (MPa) |" in md and "3.5 ± 2.3 (2 of 3, 1 not converged)" in md
    assert data["fit"]["n_points"] == 5  # the static moduli of the rigid structures, as without the test


def test_a_set_label_names_its_rows(tmp_path):
    """``label`` of a [[sweep.set]] replaces the protocol's name in the report's labels (two BD sets with
    different bond models stay apart), the seed's row is still found by kind and value."""
    from polypack.studies.seed003_heterogeneity import _seed_row, set_label

    d = _data()
    d["sweep"]["set"][1]["label"] = "BD creeping"
    _, entries, _ = sweep_plan(d)
    assert [e.title for e in entries] == [None, None, "BD creeping", "BD creeping"]
    folder = tmp_path / "f"
    folder.mkdir()
    (folder / "study.resolved.json").write_text(json.dumps({"study": {"protocol": {"kind": "brownian"}}}))
    lab, kind, key, v = set_label(folder, "protocol.surface_potential", 0.014, "BD creeping")
    assert (lab, kind, key, v) == ("BD creeping Ψ0 = 14 mV", "brownian", "surface_potential", 0.014)
    assert _seed_row(kind, key, v)[1] == 0.472
    assert set_label(folder, "protocol.surface_potential", 0.014)[0] == "Brownian Ψ0 = 14 mV"


def test_dynamic_realizations_chooses_the_structures_that_get_the_shear_test():
    """``dynamic_realizations`` (``[sweep]``, overridden per set): the dynamic values' [analysis.shear]
    runs on realizations 0 .. n-1 only (default 1, issue 32: one structure per value); ``"all"`` on every
    one; a bad value is one line naming the key path and what is allowed."""
    sw, entries, _ = sweep_plan(_data())
    assert [s["dynamic_realizations"] for s in sw["sets"]] == [1, 1]
    dyn = [e for e in entries if e.dynamic]
    assert [e.study.data["analysis"]["shear"]["realizations"] for e in dyn] == [1, 1]
    d = _data()
    d["sweep"]["dynamic_realizations"] = "all"
    d["sweep"]["set"][1]["dynamic_realizations"] = 2
    sw, entries, _ = sweep_plan(d)
    assert [s["dynamic_realizations"] for s in sw["sets"]] == [None, 2]
    sh = [e.study.data["analysis"]["shear"] for e in entries if e.dynamic]
    assert "realizations" not in sh[0] and sh[1]["realizations"] == 2
    # the study's own [analysis.shear] of the values that are not dynamic stays as written
    d = _data()
    d["analysis"]["shear"] = {"cycles": 7, "realizations": 2}
    _, entries, _ = sweep_plan(d)
    assert [e.study.data["analysis"]["shear"]["realizations"] for e in entries] == [1, 2, 1, 2]
    for where, bad in (("sweep", 0), ("sweep", -1), ("sweep", True), ("sweep", "some"), ("sweep", 1.5),
                       ('sweep.set "bd"', 0)):
        d = _data()
        (d["sweep"] if where == "sweep" else d["sweep"]["set"][1])["dynamic_realizations"] = bad
        with pytest.raises(InvalidInputError, match=rf'^{re.escape(where)}.dynamic_realizations = '
                                                    rf'{re.escape(repr(bad))}: give an integer >= 1') as info:
            sweep_plan(d)
        assert "\n" not in str(info.value)
    d = _data()
    d["sweep"]["shear"]["realizations"] = 2
    with pytest.raises(InvalidInputError, match=r"^sweep.shear.realizations = 2: give sweep.dynamic_realizations"):
        sweep_plan(d)


def test_an_analysis_limited_to_the_first_realizations_leaves_the_others_alone():
    """``[analysis.shear] realizations = 1``: realization 0 gets the shear record, realization 1 none, and
    realization 1's other analyses are bit for bit those of the same study without the limit (child seeds
    spawned over every table); the ensemble files average the shear over the realization that has it."""
    from polypack.ensemble.runner import ensemble_curves, ensemble_scalars
    from polypack.ensemble.stages import child_seed_records, realize
    from polypack.study import load_study

    d = _data()
    d.pop("sweep")
    d["protocol"]["void_ratio"] = 0.25
    d["analysis"] = {"contacts": {"tolerance": 0.01},
                     "shear": {"bonds": "distance", "epsilon": 0.01, "stiffness": "particle", "cycles": 2,
                               "steps_per_cycle": 200, "samples_per_cycle": 10, "directions": [[2, 0]],
                               "realizations": 1}}
    limited = load_study(d)
    seeds = child_seed_records(limited.seed, 2)
    _, r0 = realize(limited.data, 0, seeds[0])
    _, r1 = realize(limited.data, 1, seeds[1])
    assert "shear" in r0["analysis"] and "shear" not in r1["analysis"]
    assert not any(k.startswith("shear.") for k in r1["scalars"])
    d["analysis"]["shear"]["realizations"] = 2
    _, full1 = realize(load_study(d).data, 1, seeds[1])
    assert "shear" in full1["analysis"]
    assert full1["analysis"]["contacts"] == r1["analysis"]["contacts"]
    assert full1["n"] == r1["n"] and full1["volume_fraction"] == r1["volume_fraction"]
    files = {"files": {"gsd": {"path": "x.gsd", "sha256": ""}}}
    sc = ensemble_scalars([dict(r0, **files), dict(r1, **files)])
    assert not any(k.startswith("shear.") for k in sc)  # in one record only: not averaged as if in both
    assert sc["volume_fraction"]["n"] == 2
    ensemble_curves([r0, r1])  # a record without the analysis is skipped, not an error


def _plain_sets(realizations=3):
    """TWO_SETS without the report and the shear test: packs, pores, contacts and tensors only (seconds)."""
    d = _data()
    d["study"]["realizations"] = realizations
    for k in ("report", "fig5_kn"):
        d["sweep"].pop(k)
    for s in d["sweep"]["set"]:
        s.pop("dynamic")
    return d


def _timeless(k):
    return k in ("seconds", "files", "sha256") or str(k).endswith("wall_time")


def _strip(rec):
    """A record without what depends on when it ran (timings; the GSD's checksum: the pack's metadata
    holds the wall time, its arrays are compared bitwise)."""
    if isinstance(rec, dict):
        return {k: _strip(v) for k, v in rec.items() if not _timeless(k)}
    return [_strip(v) for v in rec] if isinstance(rec, list) else rec


def test_one_executor_for_all_values_gives_the_value_by_value_records(tmp_path):
    """With ``workers = 2`` every (value, realization) of both sets shares one process pool (issue 32): the
    records are those of each value run alone by run_study in this process, bit for bit but for the
    timing; the summaries and ensemble files match; each value's summary is echoed once; a rerun
    computes nothing and a lost realization of one value is recomputed alone."""
    from polypack.ensemble.runner import run_study

    d = _plain_sets()
    echoed = []
    got = run_sweep(d, tmp_path / "shared", workers=2, progress=False, echo=echoed.append)
    _, entries, _ = sweep_plan(d)
    assert list(got) == [(e.set, e.value) for e in entries]
    assert len(echoed) == 4 and all(s.startswith("study ") for s in echoed)
    for e in entries:
        ref = run_study(e.study, tmp_path / "ref" / e.rel, progress=False)
        res = got[(e.set, e.value)]
        assert res.computed == [0, 1, 2] and res.out == tmp_path / "shared" / e.rel
        assert [_strip(r) for r in res.records] == [_strip(r) for r in ref.records]
        for i in range(3):
            a, b = (pp.io.read(f / "realizations" / f"r{i:04d}.gsd") for f in (res.out, ref.out))
            assert np.array_equal(a.positions, b.positions) and np.array_equal(a.radii, b.radii)  # bitwise
        sc = [_strip(json.loads((f / "ensemble" / "scalars.json").read_text())) for f in (res.out, ref.out)]
        assert sc[0] == sc[1] and sc[0]
        rows, refrows = ([r.split(",") for r in (f / "summary.csv").read_text().splitlines()] for f in (res.out, ref.out))
        keep = [j for j, c in enumerate(rows[0]) if not _timeless(c)]
        assert len(keep) >= 8 and [[r[j] for j in keep] for r in rows] == [[r[j] for j in keep] for r in refrows]
    again = run_sweep(d, tmp_path / "shared", workers=2, progress=False, echo=lambda s: None)
    assert all(not r.computed and r.skipped == [0, 1, 2] for r in again.values())
    lost = tmp_path / "shared" / "bd" / "surface_potential=0" / "realizations" / "r0002.json"
    lost.unlink()
    again = run_sweep(d, tmp_path / "shared", workers=2, progress=False, echo=lambda s: None)
    assert {k: r.computed for k, r in again.items()} == {("vem", 0.25): [], ("vem", 1.0): [], ("bd", 0.0): [2],
                                                          ("bd", 0.012): []}


class _Refusing(__import__("concurrent.futures").futures.Executor):
    """An executor that records what is submitted and fails every task (no computing)."""

    def __init__(self):
        self.calls = []

    def submit(self, fn, *args):
        import concurrent.futures as cf

        from polypack.errors import PolypackError

        self.calls.append((args[0]["study"]["name"], args[1], "shear" in args[0]["analysis"]))
        f = cf.Future()
        f.set_exception(PolypackError("refused"))
        return f


def test_the_shear_tasks_go_first_and_a_failure_is_raised_after_all(tmp_path, monkeypatch):
    """On a shared executor the realizations that run the oscillatory shear test (realization 0 of each
    dynamic value: the longest tasks) are submitted first, the rest in the sweep's order; a failing
    realization does not stop the others, and the first failure is raised once all are done."""
    from polypack.errors import PolypackError

    monkeypatch.setenv("POLYPACK_PRECOMPILE", "0")
    d = _data()
    d["study"]["realizations"] = 3
    ex = _Refusing()
    with pytest.raises(PolypackError, match=r"^3 of 3 realization\(s\) failed \(first: realization 0: refused\)"):
        run_sweep(d, tmp_path / "o", executor=ex, progress=False, echo=lambda s: None)
    sheared = [(n, i) for n, i, sh in ex.calls[:2]]
    assert sheared == [("two-vem-void_ratio=0.25", 0), ("two-bd-surface_potential=0", 0)]
    assert [c[2] for c in ex.calls] == [True] * 2 + [True, True, False, False, False] + [True, True] + [False] * 3
    assert len(ex.calls) == 12 and len(set(ex.calls)) == 12
    assert [c[:2] for c in ex.calls[2:5]] == [("two-vem-void_ratio=0.25", 1), ("two-vem-void_ratio=0.25", 2),
                                               ("two-vem-void_ratio=1", 0)]
    assert not list((tmp_path / "o").glob("*/*/realizations/r*.json"))


def test_figure_colours_tell_every_set_apart():
    """Fig. 2 / Fig. 6 of the seed-size study have eleven sets (six VEM, five BD): one colour cycle of ten
    would give the first VEM value and the last BD value the same colour. Each protocol kind gets one colour
    family (VEM blues, BD oranges), shaded along its values; other kinds (included runs) their own."""
    from matplotlib.colors import rgb_to_hsv

    from polypack.studies.seed003_heterogeneity import _set_colours

    sets = [f"VEM {v}" for v in range(6)] + [f"BD {v}" for v in range(5)] + ["SCRM", "deposit"]
    kinds = {s: ("vem" if s.startswith("VEM") else "brownian" if s.startswith("BD") else s.lower()) for s in sets}
    col = _set_colours(sets, kinds)
    assert set(col) == set(sets)
    rgb = {s: tuple(round(x, 6) for x in col[s][:3]) for s in sets}
    assert len(set(rgb.values())) == len(sets)  # no two sets share a colour
    hue = {s: rgb_to_hsv(rgb[s])[0] for s in sets}
    blue, orange = [hue[s] for s in sets[:6]], [hue[s] for s in sets[6:11]]
    assert all(0.5 < h < 0.7 for h in blue) and all(0.0 < h < 0.12 for h in orange)  # one family per kind
    value = {s: rgb_to_hsv(rgb[s])[2] for s in sets}
    assert all(value[a] >= value[b] for a, b in zip(sets[:5], sets[1:6]))  # light to dark along the values
    assert len({rgb["SCRM"], rgb["deposit"]} | set(rgb[s] for s in sets[:11])) == len(sets)
