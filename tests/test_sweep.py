"""Sweeps of a study over one parameter and the heterogeneity report (seed 003 Table 2, Figs. 2, 5, 6)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import polypack as pp
from polypack.ensemble.sweep import has_sweep, run_sweep, sweep_studies
from polypack.errors import InvalidInputError


def _study(n=64, values=(0.5, 2.0), **sweep):
    return {
        "study": {"name": "het", "seed": 5, "realizations": 2},
        "psd": {"model": "monodisperse", "d": 0.5e-6, "n": n},
        "protocol": {"kind": "vem", "volume_fraction": 0.4},
        "analysis": {"pores": {"n_points": 5000}, "contacts": {"tolerance": 0.01}},
        "output": {"plots": False},
        "sweep": {"parameter": "protocol.void_ratio", "values": list(values), "report": "heterogeneity", **sweep},
    }


@pytest.mark.parametrize("sweep, match", [
    ({"parameter": "void_ratio"}, "sweep.parameter"),
    ({"values": []}, "sweep.values"),
    ({"values": [1.0, 1.0]}, "must differ"),
    ({"report": "table"}, "sweep.report"),
    ({"bogus": 1}, "sweep.bogus: unknown key"),
    ({"values": [-1.0]}, "sweep value -1.0: protocol.void_ratio"),
    ({"values": [1, 1.0]}, "1 and 1.0 share the folder name void_ratio=1"),
    ({"fig5_kn": [100.0, 0.0]}, "sweep.fig5_kn"),
    ({"fig5_kn": [100.0]}, "sweep.fig5_kn"),
])
def test_bad_sweeps_are_one_line_errors(sweep, match):
    with pytest.raises(InvalidInputError, match=match) as info:
        sweep_studies(_study(**{k: v for k, v in sweep.items() if k != "values"},
                             **({"values": sweep["values"]} if "values" in sweep else {})))
    assert "\n" not in str(info.value)


def test_folder_names_are_exact():
    """Issue 31: 0.25 and 0.2500000000000001 mapped to one folder (6 significant digits) and
    --force silently replaced the first value's results; now each value has its own folder,
    short where the short form reads back exactly."""
    from polypack.ensemble.sweep import _label

    vals = [0.25, 0.2500000000000001, 1.0, 2, 1e-7, 0.1 + 0.2]
    labels = [_label("protocol.void_ratio", v) for v in vals]
    assert labels == ["void_ratio=0.25", "void_ratio=0.2500000000000001", "void_ratio=1", "void_ratio=2",
                      "void_ratio=1e-07", "void_ratio=0.30000000000000004"]
    for v, lab in zip(vals, labels):
        assert float(lab.split("=")[1]) == v
    sw, studies, _ = sweep_studies(_study(values=(0.25, 0.2500000000000001)))
    assert len(studies) == 2


def test_every_value_is_an_ordinary_study():
    assert has_sweep(_study())
    sw, studies, name = sweep_studies(_study(values=(0.25, 1.0, 2.0)))
    assert name == "het" and [v for v, _ in studies] == [0.25, 1.0, 2.0]
    for v, st in studies:
        assert st.data["protocol"]["void_ratio"] == v
        assert st.seed == 5  # common random numbers across values
    assert len({st.fingerprint for _, st in studies}) == 3


@pytest.mark.slow
def test_sweep_runs_and_reports(tmp_path):
    out = tmp_path / "het"
    res = run_sweep(_study(), out, progress=False, echo=lambda s: None)
    assert set(res) == {0.5, 2.0}
    rep = out / "heterogeneity"
    for f in ("table2.csv", "table2.md", "fit.json", "fig2.png", "fig6.png"):
        assert (rep / f).stat().st_size > 0
    data = json.loads((rep / "fit.json").read_text())
    assert len(data["points"]) == 4 and len(data["rows"]) == 2
    # the table's a and C are the means of the records' own DOH fits and coordinations
    for row in data["rows"]:
        folder = out / f"void_ratio={row['void_ratio']:g}" / "realizations"
        recs = [json.loads(p.read_text()) for p in sorted(folder.glob("r*.json"))]
        a = np.mean([r["analysis"]["pores"]["fit"]["seed"]["a"] for r in recs])
        c = np.mean([r["analysis"]["contacts"]["coordination"] for r in recs])
        assert row["a"] == pytest.approx(a, rel=1e-12) and row["C"] == pytest.approx(c, rel=1e-12)
    # G'p of one structure equals the mean of C44, C55, C66 of its bonded network (Pa -> MPa)
    p0 = data["points"][0]
    pk = pp.io.read(str(out / f"void_ratio={p0['value']:g}" / "realizations" / f"r{p0['index']:04d}.gsd"))
    net = pp.mechanics.BondNetwork.from_packing(pk, epsilon=0.01, normal_stiffness=100.0, shear_stiffness=10.0)
    et = pp.mechanics.elastic_tensor(net)
    assert p0["G_Pa"] == pytest.approx(float(np.mean(et.shear_moduli)), rel=1e-9)
    # rerunning resumes (nothing recomputed)
    again = run_sweep(_study(), out, progress=False, echo=lambda s: None)
    assert all(not r.computed for r in again.values())


@pytest.mark.slow
def test_polypack_run_detects_a_sweep(tmp_path):
    from typer.testing import CliRunner

    from polypack.cli import app

    text = """
[study]
name = "h"
seed = 2
realizations = 1
[psd]
model = "monodisperse"
d = 0.5e-6
n = 48
[protocol]
kind = "vem"
volume_fraction = 0.4
[analysis.pores]
n_points = 2000
[output]
plots = false
[sweep]
parameter = "protocol.void_ratio"
values = [1.0, 2.0]
"""
    f = tmp_path / "h.toml"
    f.write_text(text)
    res = CliRunner().invoke(app, ["run", str(f), "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "o" / "void_ratio=1" / "summary.csv").exists()
    assert (tmp_path / "o" / "void_ratio=2" / "summary.csv").exists()
    # the sweep's report.html links one report per value (each an ordinary run report)
    page = (tmp_path / "o" / "report.html").read_text()
    for sub in ("void_ratio=1", "void_ratio=2"):
        assert (tmp_path / "o" / sub / "report.html").exists()
        assert f'href="{sub}/report.html"' in page
    assert "1 of 1" in page
    res = CliRunner().invoke(app, ["run", str(f), "--check"])
    assert res.exit_code == 0 and "2 values of protocol.void_ratio" in res.output, res.output


def test_bundled_heterogeneity_example_validates():
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "heterogeneity.toml"
    sw, studies, name = sweep_studies(path)
    assert name == "heterogeneity" and sw["report"] == "heterogeneity"
    assert sw["parameter"] == "protocol.void_ratio" and len(studies) >= 3
    for v, st in studies:
        assert st.data["protocol"]["kind"] == "vem" and st.data["protocol"]["volume_fraction"] == 0.4
        assert st.data["psd"]["d"] == 0.5e-6  # r0 = 0.25 µm: moduli in Pa, reported in MPa
        assert {"pores", "contacts", "elastic"} <= set(st.data["analysis"])


@pytest.mark.slow
def test_report_reads_the_elastic_stage(tmp_path):
    """With [analysis.elastic] in the study the report takes G'p from the records; it equals
    the report's own computation through pp.mechanics on the same pack (two code paths)."""
    d = _study(n=64, values=(1.0,))
    d["analysis"]["elastic"] = {"epsilon": 0.01, "normal_stiffness": 100.0, "radius": 0.25e-6}
    out = tmp_path / "h"
    run_sweep(d, out, progress=False, echo=lambda s: None)
    data = json.loads((out / "heterogeneity" / "fit.json").read_text())
    assert data["g_source"] == ["[analysis.elastic]"]
    assert "no fit" in data["note"]  # two structures: too few for three parameters
    p0 = data["points"][0]
    pk = pp.io.read(str(out / "void_ratio=1" / "realizations" / f"r{p0['index']:04d}.gsd"))
    net = pp.mechanics.BondNetwork.from_packing(pk, epsilon=0.01, normal_stiffness=100.0, shear_stiffness=10.0)
    assert p0["G_Pa"] == pytest.approx(float(np.mean(pp.mechanics.elastic_tensor(net).shear_moduli)), rel=1e-6)


def test_dynamic_moduli_from_the_shear_stage():
    """sweep.modulus = "shear": G'p is the mean of the per-direction storage moduli of the
    [analysis.shear] record and its spread their standard deviation (the seed's error bars)."""
    from polypack.studies.seed003_heterogeneity import _structure_values

    rec = {"analysis": {"pores": {"fit": {"seed": {"a": 0.45, "b": 0.01}}}, "contacts": {"coordination": 4.6},
                        "shear": {"coordination": 4.5, "direction": {
                            f"{g}-{a}": {"storage_modulus": v} for (g, a), v in
                            zip([(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)], [1.0, 2.0, 3.0, 4.0, 5.0, 6.0])}}}}
    a, b, c, g, sd, src, g_aff = _structure_values(rec, None, {}, "shear")
    assert (a, b, c) == (0.45, 0.01, 4.6)
    assert g == pytest.approx(3.5) and sd == pytest.approx(np.std([1, 2, 3, 4, 5, 6]))
    assert "shear" in src and np.isnan(g_aff)  # no affine reference without [analysis.elastic]
    del rec["analysis"]["shear"]
    with pytest.raises(InvalidInputError, match="needs \\[analysis.shear\\]"):
        _structure_values(rec, None, {}, "shear")
    with pytest.raises(InvalidInputError, match="sweep.modulus"):
        sweep_studies(_study(modulus="dem"))


def _fake_run(folder, protocol):
    folder.mkdir(parents=True)
    (folder / "study.resolved.json").write_text(json.dumps({"study": {"protocol": protocol}}))
    return folder


def test_sets_are_labelled_by_protocol_kind_and_value(tmp_path):
    """The report names every structure set by its study's protocol kind and the value that
    sets it apart (swept value, else the kind's own option), never a fixed "VEM"."""
    from polypack.studies.seed003_heterogeneity import _seed_row, set_label

    bd = _fake_run(tmp_path / "surface_potential=0.014", {"kind": "brownian", "surface_potential": 0.014})
    vem = _fake_run(tmp_path / "v", {"kind": "vem", "void_ratio": 0.5})
    # a swept BD set: labelled by the swept parameter and value, matched to the seed's BD row
    lab, kind, key, v = set_label(bd, "protocol.surface_potential", 0.014)
    assert (lab, kind, key, v) == ("Brownian Ψ0 = 14 mV", "brownian", "surface_potential", 0.014)
    assert _seed_row(kind, key, v) == (14.0, 0.472, 5.08, 1.46, 0.120)
    # included folders: the kind's own option is read from the folder's resolved study
    assert set_label(bd)[0] == "Brownian Ψ0 = 14 mV"
    lab, kind, key, v = set_label(vem)
    assert (lab, kind) == ("VEM N_V/N = 0.5", "vem") and _seed_row(kind, key, v)[1] == 0.467
    # a swept VEM value with no seed row, another kind, and a folder that is no run folder
    assert _seed_row("vem", "void_ratio", 0.3) is None
    assert set_label(_fake_run(tmp_path / "s", {"kind": "scrm"}))[0] == "SCRM (s)"
    plain = tmp_path / "plain"
    plain.mkdir()
    assert set_label(plain)[0] == "plain"


@pytest.mark.slow
def test_report_fits_a_brownian_set_with_the_vem_set(tmp_path):
    """A swept VEM set and an included Brownian-dynamics run folder enter one report: each
    row and point carries its own label and kind, the BD row is compared with the seed's BD
    row of its Ψ0, and the fit runs over both sets' structures."""
    from polypack.ensemble.runner import run_study
    from polypack.study import load_study

    bd = {"study": {"name": "bd", "seed": 3, "realizations": 1},
          "psd": {"model": "monodisperse", "d": 0.5e-6, "n": 40},
          "protocol": {"kind": "brownian", "volume_fraction": 0.4, "surface_potential": 0.0},
          "analysis": {"pores": {"n_points": 5000}, "contacts": {"tolerance": 0.01}},
          "output": {"plots": False}}
    run_study(load_study(bd), tmp_path / "bd0", progress=False)
    out = tmp_path / "het"
    run_sweep(_study(n=64, values=(0.5, 2.0), include=[str(tmp_path / "bd0")]), out, progress=False,
              echo=lambda s: None)
    data = json.loads((out / "heterogeneity" / "fit.json").read_text())
    labels = [r["set"] for r in data["rows"]]
    assert labels == ["VEM N_V/N = 0.5", "VEM N_V/N = 2", "Brownian Ψ0 = 0 mV"]
    assert [r["kind"] for r in data["rows"]] == ["vem", "vem", "brownian"]
    assert {p["set"] for p in data["points"]} == set(labels) and len(data["points"]) == 5
    md = (out / "heterogeneity" / "table2.md").read_text()
    bd_line = next(line for line in md.splitlines() if line.startswith("| Brownian Ψ0 = 0 mV"))
    assert "| 0.373 | 4.52 |" in bd_line  # the seed's 0 mV BD row beside the measurement
    assert "| VEM N_V/N = 0.5 |" in md and "| 0.467 | 4.69 |" in md


def test_bundled_joint_bd_vem_example_validates():
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "heterogeneity_bd.toml"
    sw, studies, name = sweep_studies(path)
    assert sw["report"] == "heterogeneity" and sw["parameter"] == "protocol.surface_potential"
    assert any("void_ratio" in f for f in sw["include"])
    for v, st in studies:
        assert st.data["protocol"]["kind"] == "brownian" and st.data["protocol"]["surface_potential"] == v
        assert st.data["analysis"]["elastic"]["bonds"] == "distance"  # the seed's rule for both sets


def test_floppy_structures_are_zero_and_left_out_of_the_fit(tmp_path):
    """A structure whose static G'p is round-off of zero (below FLOPPY_FLOOR of its affine
    modulus, as the N_V/N >= 1.6 VEM structures at the seed's size: 1e-11 MPa against an
    affine 22 MPa) counts as G'p = 0: it is reported as floppy and left out of the Eq. (7)
    fit, which then recovers the exact (a0, beta, A) of the rigid structures.  With the old
    rule (every G'p > 0 enters) the floppy point below a0 makes the fit fail."""
    from polypack.analysis.powerlaw import power_law_fit
    from polypack.ensemble.sweep import heterogeneity_report

    a0, beta, amp, g_aff = 0.37, 0.5, 3.0e6, 2.2e7

    def run(name, a_values, g_values):
        folder = _fake_run(tmp_path / name, {"kind": "vem", "void_ratio": 1.0})
        (folder / "realizations").mkdir()
        for i, (a, g) in enumerate(zip(a_values, g_values)):
            rec = {"index": i, "protocol": {"status": "target"},
                   "analysis": {"pores": {"fit": {"seed": {"a": a, "b": 0.0}}}, "contacts": {"coordination": 4.5},
                                "elastic": {"shear_moduli": [g, g, g], "affine_shear_modulus": g_aff}}}
            (folder / "realizations" / f"r{i:04d}.json").write_text(json.dumps(rec))
        return folder

    rigid_a = [0.40, 0.45, 0.50, 0.55]
    sets = [(0.5, run("rigid", rigid_a, [amp * (x - a0) ** beta for x in rigid_a])),
            (2.0, run("floppy", [0.36, 0.361], [1e-5, -7e-4]))]  # round-off of G'p = 0, both signs
    heterogeneity_report(tmp_path / "out", sets, parameter="protocol.void_ratio")
    data = json.loads((tmp_path / "out" / "heterogeneity" / "fit.json").read_text())
    assert [p["rigid"] for p in data["points"]] == [True] * 4 + [False] * 2
    assert [p["G_Pa"] for p in data["points"][4:]] == [0.0, 0.0]
    fit = data["fit"]
    assert fit["a0"] == pytest.approx(a0, rel=1e-6) and fit["beta"] == pytest.approx(beta, rel=1e-5)
    assert "2 floppy structure(s)" in data["note"]
    assert [r["floppy"] for r in data["rows"]] == [0, 2]
    md = (tmp_path / "out" / "heterogeneity" / "table2.md").read_text()
    assert "| 0 (floppy) |" in md
    assert data["fig5"]["ratio"] is None and "Fig. 5: no pack file" in data["fig5"]["note"]  # records only
    with pytest.raises(Exception):  # what the old rule fed to the fit: the floppy point breaks it
        bad = power_law_fit(rigid_a + [0.36], [amp * (x - a0) ** beta for x in rigid_a] + [1e-5])
        assert bad.a0 == pytest.approx(a0, rel=1e-3)


def test_report_marks_floppy_unconverged_and_nan_structures(tmp_path):
    """Issue 31: records holding NaN moduli (old runs) or a not-converged / floppy shear test
    give a report, never a traceback: floppy is G'p = 0, the others are left out and named."""
    from polypack.ensemble.sweep import heterogeneity_report

    folder = _fake_run(tmp_path / "v", {"kind": "vem", "void_ratio": 1.0})
    (folder / "realizations").mkdir()
    a0, beta, amp = 0.37, 0.5, 3.0e6
    shear = [{"status": "ok", "direction": {"2-0": {"storage_modulus": amp * (a - a0) ** beta}}}
             for a in (0.40, 0.45, 0.50, 0.55)]
    shear += [{"status": "floppy", "direction": {}},
              {"status": "not_converged", "direction": {"2-0": {"storage_modulus": None}}},
              {"status": "ok", "direction": {"2-0": {"storage_modulus": float("nan")}}}]
    for i, (a, sh) in enumerate(zip([0.40, 0.45, 0.50, 0.55, 0.36, 0.47, 0.48], shear)):
        rec = {"index": i, "protocol": {"status": "target"},
               "analysis": {"pores": {"fit": {"seed": {"a": a, "b": 0.0}}}, "contacts": {"coordination": 4.5},
                            "shear": sh}}
        (folder / "realizations" / f"r{i:04d}.json").write_text(json.dumps(rec))  # NaN as JSON NaN, as old runs
    heterogeneity_report(tmp_path / "out", [(1.0, folder)], parameter="protocol.void_ratio", modulus="shear")
    data = json.loads((tmp_path / "out" / "heterogeneity" / "fit.json").read_text())
    assert [p["rigid"] for p in data["points"]] == [True] * 4 + [False]
    assert data["points"][4]["G_Pa"] == 0.0 and data["rows"][0]["floppy"] == 1
    assert "2 structure(s) without a modulus" in data["note"] and "r0005" in data["note"] and "r0006" in data["note"]
    assert data["fit"]["a0"] == pytest.approx(a0, rel=1e-6)


def test_report_uses_the_records_rigidity(tmp_path):
    """Issue 31: a record states rigid / floppy; the report follows it (a rigid near-floppy
    structure with G'p = 1e-7 of its affine modulus, below the old FLOPPY_FLOOR, stays rigid;
    a record saying floppy is G'p = 0 whatever its numbers)."""
    from polypack.ensemble.sweep import heterogeneity_report

    folder = _fake_run(tmp_path / "v", {"kind": "vem", "void_ratio": 1.0})
    (folder / "realizations").mkdir()
    g_aff = 2.2e7
    rows = [(0.40, 2.2, True), (0.45, 3e5, True), (0.50, 4e5, True), (0.55, 5e5, True), (0.60, 6e5, False)]
    for i, (a, g, rigid) in enumerate(rows):
        rec = {"index": i, "protocol": {"status": "target"},
               "analysis": {"pores": {"fit": {"seed": {"a": a, "b": 0.0}}}, "contacts": {"coordination": 4.5},
                            "elastic": {"shear_moduli": [g] * 3, "affine_shear_modulus": g_aff, "rigid": rigid}}}
        (folder / "realizations" / f"r{i:04d}.json").write_text(json.dumps(rec))
    heterogeneity_report(tmp_path / "out", [(1.0, folder)], parameter="protocol.void_ratio")
    data = json.loads((tmp_path / "out" / "heterogeneity" / "fit.json").read_text())
    assert [p["rigid"] for p in data["points"]] == [True, True, True, True, False]
    assert data["points"][0]["G_Pa"] == pytest.approx(2.2) and data["points"][4]["G_Pa"] == 0.0


def test_sweep_writes_report_html_with_table2_beside_the_seed(tmp_path):
    """The sweep's OUT/report.html (written by report.build.sweep_report after run_sweep, as
    ``polypack run`` does): Table 2 of the seed side by side with this run's rows
    (a, C, G'p, a / a_seed computed from the run's own fit.json), Figs. 2 and 6 inline."""
    import re

    study = _study(n=48, values=(0.5, 2.0))
    study["study"]["realizations"] = 1
    study["analysis"]["pores"]["n_points"] = 2000
    out = tmp_path / "h"
    res = run_sweep(study, out, progress=False, echo=lambda s: None)
    from polypack.ensemble.sweep import _label
    from polypack.report.build import sweep_report

    sweep_report(out, [(v, out / _label("protocol.void_ratio", v)) for v in res], title="h")
    page = (out / "report.html").read_text()
    rows = json.loads((out / "heterogeneity" / "fit.json").read_text())["rows"]
    assert "a (seed)" in page and "C (seed)" in page and "G′p MPa (seed)" in page
    for r, (a_seed, c_seed, g_seed) in zip(rows, ((0.467, 4.69, "1.62 ± 0.19"), (0.392, 4.61, "1.17 ± 0.23"))):
        cells = re.search(rf"<td>{re.escape(r['set'])}</td>(.*?)</tr>", page, re.S).group(1)
        cells = re.findall(r"<td[^>]*>(.*?)</td>", cells)
        assert cells[1].startswith(f"{r['a']:.3f}") and cells[2] == f"{a_seed:.3f}"
        assert cells[3] == f"{r['a'] / a_seed:.3f}" and cells[5] == f"{c_seed:.2f}" and cells[7] == g_seed
    assert page.count("data:image/png;base64") == 2  # Fig. 2 and Fig. 6
    assert "seed Fig. 6" in page and "Eq. (7)" in page


def test_fig5_picks_the_brownian_set_when_there_is_one():
    """Fig. 5's structures: the most and least heterogeneous rigid ones (largest and smallest a),
    from the BD set when it holds two rigid structures (as the seed: Ψ0 = 15 and 0 mV), else from all."""
    from polypack.studies.seed003_heterogeneity import _fig5_pick

    pts = [{"a": 0.60, "rigid": True, "kind": "vem"}, {"a": 0.30, "rigid": True, "kind": "vem"},
           {"a": 0.45, "rigid": True, "kind": "brownian"}, {"a": 0.70, "rigid": False, "kind": "brownian"},
           {"a": 0.40, "rigid": True, "kind": "brownian"}, {"a": 0.10, "rigid": False, "kind": "vem"}]
    assert _fig5_pick(pts)[:2] == (2, 4)
    pts[4]["rigid"] = False  # one rigid BD structure: the pick is over every set
    assert _fig5_pick(pts)[:2] == (0, 1)
    assert _fig5_pick(pts[3:]) is None  # a single rigid structure: no Fig. 5


@pytest.mark.slow
def test_fig5_gp_against_kn_of_the_most_and_least_heterogeneous(tmp_path):
    """Fig. 5 of the seed on a tiny sweep: the static tensor is linear in the stiffnesses at fixed
    ks / kn, so G'p(kn) / kn is one constant per structure (to 1e-9); the HE / HO ratio is the one of
    two direct elastic_tensor calls on the two packs; the structures are the largest and smallest a
    among the rigid ones; G'p at kn = 100 N/m is Table 2's; the figure is inline in report.html."""
    from polypack.ensemble.sweep import _label
    from polypack.report.build import sweep_report

    study = _study(n=48, values=(0.25, 0.5), fig5_kn=[25.0, 50.0, 100.0, 400.0])
    study["analysis"]["pores"]["n_points"] = 2000
    out = tmp_path / "h"
    res = run_sweep(study, out, progress=False, echo=lambda s: None)
    data = json.loads((out / "heterogeneity" / "fit.json").read_text())
    f5 = data["fig5"]
    kn = np.array(f5["kn_N_per_m"])
    assert kn.tolist() == [25.0, 50.0, 100.0, 400.0]
    rigid = [p for p in data["points"] if p["rigid"]]
    assert len(rigid) >= 2, "the tiny sweep needs two rigid structures for the oracle"
    he = max(rigid, key=lambda p: p["a"])
    ho = min(rigid, key=lambda p: p["a"])
    assert (f5["he"]["set"], f5["he"]["index"]) == (he["set"], he["index"])
    assert (f5["ho"]["set"], f5["ho"]["index"]) == (ho["set"], ho["index"])
    direct = {}
    for name, p in (("he", he), ("ho", ho)):
        g = np.array(f5[name]["G_Pa"])
        assert np.all(g > 0)
        slope = g / kn
        assert np.ptp(slope) <= 1e-9 * slope.mean()  # linear in kn at ks = kn / 10
        assert g[2] == pytest.approx(p["G_Pa"], rel=1e-9)  # kn = 100 N/m: Table 2's G'p
        pk = pp.io.read(str(out / _label("protocol.void_ratio", p["value"]) / "realizations" / f"r{p['index']:04d}.gsd"))
        net = pp.mechanics.BondNetwork.from_packing(pk, epsilon=0.01, normal_stiffness=50.0, shear_stiffness=5.0)
        direct[name] = float(np.mean(pp.mechanics.elastic_tensor(net).shear_moduli))
        assert g[1] == pytest.approx(direct[name], rel=1e-9)
    ratio = np.array(f5["ratio"])
    assert ratio == pytest.approx(direct["he"] / direct["ho"], rel=1e-9)
    assert ratio[0] > 1.0  # the more heterogeneous structure is the stiffer one here
    assert f"{ratio[0]:.3g}" in (out / "heterogeneity" / "table2.md").read_text()
    assert (out / "heterogeneity" / "fig5.png").stat().st_size > 0
    sweep_report(out, [(v, out / _label("protocol.void_ratio", v)) for v in res], title="h")
    page = (out / "report.html").read_text()
    assert page.count("data:image/png;base64") == 3  # Figs. 2, 5 and 6
    assert "seed Fig. 5" in page and "G′p HE / G′p HO" in page
    assert f"<td>{float(ratio[0]):.5g}</td>" in page


@pytest.mark.slow
def test_fig5_uses_the_studys_elastic_settings(tmp_path):
    """With [analysis.elastic] in the study, Fig. 5 bonds and scales as that stage did (per-particle
    stiffnesses in series, radius 0.25 µm, the study's ks / kn = 0.2, not the default 1/10): G'p at
    kn = 100 N/m is the record's own, and at kn = 300 N/m it is a direct elastic_tensor call."""
    from polypack.ensemble.sweep import _label

    d = _study(n=48, values=(0.25, 0.5), fig5_kn=[50.0, 100.0, 300.0])
    d["analysis"]["pores"]["n_points"] = 2000
    d["analysis"]["elastic"] = {"epsilon": 0.01, "normal_stiffness": 100.0, "shear_stiffness": 20.0,
                                "radius": 0.25e-6, "stiffness": "particle"}
    out = tmp_path / "h"
    run_sweep(d, out, progress=False, echo=lambda s: None)
    data = json.loads((out / "heterogeneity" / "fit.json").read_text())
    f5 = data["fig5"]
    assert data["g_source"] == ["[analysis.elastic]"] and f5["ratio"] is not None
    for name in ("he", "ho"):
        s = f5[name]
        assert s["ks_over_kn"] == pytest.approx(0.2, rel=1e-12) and s["settings"]["stiffness"] == "particle"
        p = next(q for q in data["points"] if (q["set"], q["index"]) == (s["set"], s["index"]))
        assert s["G_Pa"][1] == pytest.approx(p["G_Pa"], rel=1e-9)
        pk = pp.io.read(str(out / _label("protocol.void_ratio", p["value"]) / "realizations" / f"r{p['index']:04d}.gsd"))
        net = pp.mechanics.BondNetwork.from_packing(pk, epsilon=0.01, normal_stiffness=300.0, shear_stiffness=60.0,
                                                    stiffness="particle")
        g = float(np.mean(pp.mechanics.elastic_tensor(net, radius=0.25e-6).shear_moduli))
        assert s["G_Pa"][2] == pytest.approx(g, rel=1e-9)
