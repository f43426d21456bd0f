"""polypack report / view / pp.view without a browser: the data in the page, the tables, the
figures' data against the seed's formulas, bad input, and that nothing is recomputed."""

from __future__ import annotations

import base64
import io
import json
import math
import re
import shutil

import numpy as np
import pytest

import polypack as pp
from polypack.errors import FormatError, InvalidInputError
from polypack.report import report, view

from test_report_browser import lattice_pack, tiny_study


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("rep") / "tiny"
    pp.ensemble.run_study(tiny_study(), out, progress=False)
    return out


def _payload(html_text):
    m = re.search(r'<script type="application/json" class="pp-data">(.*?)</script>', html_text, re.S)
    assert m, "no viewer data in the page"
    return json.loads(m.group(1).replace("<\\/", "</"))


def _decode(arr):
    dt = {"f32": "<f4", "u8": "u1", "u16": "<u2", "i32": "<i4"}[arr["dtype"]]
    return np.frombuffer(base64.b64decode(arr["data"]), dtype=dt)


def test_viewer_data_are_the_pack(tmp_path):
    pk = lattice_pack(8)
    f = tmp_path / "p.gsd"
    pp.io.write(f, pk)
    text = report(f, tmp_path / "p.html").read_text()
    d = _payload(text)
    (r,) = d["realizations"]
    assert r["n"] == pk.n and r["box"] == list(pk.box)
    pos = _decode(r["positions"]).reshape(-1, 3)
    # float32 in the page: relative error below 2^-23 of the box
    assert np.max(np.abs(pos - pk.positions)) <= 8 * 2.0**-24 * pk.box.max()
    assert np.max(np.abs(_decode(r["radii"]) - pk.radii) / pk.radii) < 1e-7
    assert np.array_equal(_decode(r["fields"]["species"]["values"]), pk.species)
    z = _decode(r["fields"]["coordination"]["values"])
    assert np.array_equal(z, pp.analysis.Contacts(tolerance=0.01).compute(pk).per_sphere)
    # self-contained: no URL to fetch anything, a CSP that forbids it
    assert "default-src 'none'" in text
    assert not re.search(r"""(src|href)\s*=\s*["']https?:""", text)
    assert "<svg" in text  # the grading figure, inline


def test_disks_are_drawn_in_the_plane(tmp_path):
    g = np.stack(np.meshgrid(np.arange(6), np.arange(5), indexing="ij"), -1).reshape(-1, 2) + 0.5
    r = np.linspace(0.2, 0.45, len(g))
    pk = pp.Packing(g, r, [6.0, 5.0], species=(r < 0.3).astype(int), periodic=(True, False))
    d = _payload(view(pk).html)["realizations"][0]
    pos = _decode(d["positions"]).reshape(-1, 3)
    assert d["dim"] == 2 and d["box"] == [6.0, 5.0, 0.0] and np.all(pos[:, 2] == 0)
    assert np.allclose(pos[:, :2], g) and d["periodic"] == [True, False]
    assert {"x", "y"} <= set(d["fields"]) and "z" not in d["fields"]


def test_view_for_jupyter_and_extra_fields(tmp_path):
    pk = lattice_pack(5)
    h = np.arange(pk.n, dtype=float)
    v = pp.report.view(pk, color="height", fields={"height": pk.positions[:, 2], "index": h})
    assert v._repr_html_().startswith("<iframe srcdoc=")
    d = _payload(v.html)
    f = d["realizations"][0]["fields"]
    assert d["initial_field"] == "height" and f["height"]["kind"] == "scale"
    assert np.allclose(_decode(f["height"]["values"]), pk.positions[:, 2], rtol=1e-6)
    assert f["height"]["min"] == pk.positions[:, 2].min()
    out = v.save(tmp_path / "v.html")
    assert out.read_text() == v.html
    assert pp.view is view  # the top-level name
    with pytest.raises(InvalidInputError, match=r"color='nope'.*allowed: species, radius, coordination"):
        view(pk, color="nope")
    with pytest.raises(InvalidInputError, match=r"field 'bad' has shape \(3,\)"):
        view(pk, fields={"bad": [1, 2, 3]})


def test_run_report_tables_come_from_the_run(run_dir, tmp_path):
    text = report(run_dir, tmp_path / "r.html", theory=True, plots_dir=tmp_path / "figs", formats=("png", "svg", "pdf")).read_text()
    sc = json.loads((run_dir / "ensemble" / "scalars.json").read_text())
    assert "complete: 2 of 2 realizations" in text
    # the summary shows the run's means (as written in ensemble/scalars.json)
    from polypack.report.build import _num

    for key in ("volume_fraction", "contacts.coordination", "pores.void_fraction", "protocol.collisions"):
        assert f"<span class='key'>{key}</span>" in text
        assert f'<td class="num">{_num(sc[key]["mean"])}</td>' in text
    doc = json.loads((run_dir / "study.resolved.json").read_text())
    assert doc["fingerprint"] in text and doc["versions"]["numpy"] in text
    d = _payload(text)
    assert [r["label"] for r in d["realizations"]] == ["realization 0", "realization 1"]
    for i, r in enumerate(d["realizations"]):
        pk = pp.io.read(run_dir / "realizations" / f"r{i:04d}.gsd")
        assert np.allclose(_decode(r["positions"]).reshape(-1, 3), pk.positions, atol=1e-5)
    assert text.count("<figure>") == 4
    names = {p.name for p in (tmp_path / "figs").iterdir()}
    assert {f"{n}.{e}" for n in ("rdf_partials_R", "windows", "pores", "grading") for e in ("png", "svg", "pdf")} == names


def test_compare_overlays_another_run(run_dir, tmp_path):
    other = tmp_path / "scrm"
    study = tiny_study()
    study["protocol"] = {"kind": "scrm", "volume_fraction": 0.45, "growth_steps": 2, "global_shakes": 2}
    study["study"]["name"] = "tiny_scrm"
    pp.ensemble.run_study(study, other, progress=False)
    text = report(other, tmp_path / "c.html", compare=[run_dir]).read_text()
    assert "Runs compared: SCRM, CRM." in text
    with pytest.raises(InvalidInputError, match="not a polypack run folder"):
        report(other, tmp_path / "c.html", compare=[tmp_path])


def test_report_never_recomputes_the_analyses(run_dir, tmp_path, monkeypatch):
    def boom(*a, **k):
        raise AssertionError("the report recomputed an analysis the run wrote")

    for cls in (pp.analysis.RDF, pp.analysis.WindowCounts, pp.analysis.PoreSizes, pp.analysis.KFunction):
        monkeypatch.setattr(cls, "compute", boom)
    monkeypatch.setattr(pp.ensemble.runner, "ensemble_curves", boom)
    monkeypatch.setattr(pp.ensemble.runner, "ensemble_scalars", boom)
    assert report(run_dir, tmp_path / "r.html").stat().st_size > 10_000


def test_half_finished_run_is_reported_as_such(run_dir, tmp_path):
    half = tmp_path / "half"
    shutil.copytree(run_dir, half)
    (half / "realizations" / "r0001.json").unlink()
    shutil.rmtree(half / "ensemble")
    text = report(half).read_text()
    assert "incomplete run: 1 of 2 realizations finished" in text
    assert "ensemble curves and means are not written yet" in text
    assert "Not finished: 1" in text
    assert [r["label"] for r in _payload(text)["realizations"]] == ["realization 0"]
    assert "<figure>" not in text  # no curves were written: none are drawn (nothing recomputed)
    # a record whose pack no longer matches its checksum is not shown: nothing left to report
    (half / "realizations" / "r0000.gsd").write_bytes(b"garbage")
    with pytest.raises(InvalidInputError, match=r"no finished realization yet \(0 of 2\)"):
        report(half, tmp_path / "h2.html")


def test_bad_input_one_line_errors(run_dir, tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(InvalidInputError, match="the folder is empty"):
        report(empty)
    other = tmp_path / "other"
    other.mkdir()
    (other / "x.txt").write_text("x\n")
    with pytest.raises(InvalidInputError, match="no study.resolved.json: not a polypack run folder"):
        report(other)
    bad = tmp_path / "bad.gsd"
    bad.write_bytes(b"not a gsd file at all")
    with pytest.raises(FormatError, match=r"bad.gsd: cannot be read as a pack") as e:
        report(bad)
    assert "\n" not in str(e.value)
    with pytest.raises(InvalidInputError, match="no such file or folder"):
        report(tmp_path / "missing.gsd")
    with pytest.raises(InvalidInputError, match=r"color='temperature'.*allowed: species, radius, coordination"):
        report(run_dir, tmp_path / "c.html", color="temperature")
    with pytest.raises(InvalidInputError, match="plot format 'jpg'"):
        report(run_dir, tmp_path / "c.html", plots_dir=tmp_path / "f", formats=("jpg",))
    # a run folder with no finished realization
    fresh = tmp_path / "fresh"
    fresh.mkdir()
    shutil.copy(run_dir / "study.resolved.json", fresh)
    with pytest.raises(InvalidInputError, match=r"no finished realization yet \(0 of 2\)"):
        report(fresh)


def test_cli_report_view_and_run(run_dir, tmp_path, capsys):
    from polypack.cli import main

    pk = lattice_pack(5)
    f = tmp_path / "p.gsd"
    pp.io.write(f, pk)
    np.save(tmp_path / "h.npy", pk.positions[:, 2])
    main(["report", str(f), "-o", str(tmp_path / "p.html"), "--field", f"h={tmp_path / 'h.npy'}", "--color", "h"])
    assert "wrote" in capsys.readouterr().out
    assert _payload((tmp_path / "p.html").read_text())["initial_field"] == "h"
    main(["view", str(f), "--no-browser", "-o", str(tmp_path / "v.html")])
    assert (tmp_path / "v.html").stat().st_size > 10_000
    with pytest.raises(SystemExit) as e:
        main(["report", str(f), "--color", "nope"])
    assert e.value.code == 1
    assert capsys.readouterr().err.count("\n") == 1

    study = tmp_path / "s.toml"
    study.write_text('[study]\nname = "cli_rep"\nseed = 2\nrealizations = 2\n[psd]\nsize_ratio = 0.5\n'
                     'volume_ratio = 0.5\nn = 100\n[protocol]\nkind = "crm"\nvolume_fraction = 0.4\n'
                     '[analysis.rdf]\nr_max = 0.8\ndr = 0.1\n')
    main(["run", str(study), "--out", str(tmp_path / "o")])
    out = capsys.readouterr().out
    assert "report.html" in out
    assert (tmp_path / "o" / "report.html").stat().st_size > 10_000
    assert (tmp_path / "o" / "figures" / "rdf_partials_R.png").is_file()


def test_modulus_against_the_doh(tmp_path):
    """A run with the elastic and pore stages: the shear modulus of each realization against its
    DOH a (seed 003 Fig. 6), the points being the numbers of the records."""
    from polypack.report import figures as P

    st = {"study": {"name": "el", "seed": 3, "realizations": 2},
          "psd": {"model": "bimodal", "size_ratio": 0.5, "volume_ratio": 0.5, "n": 150},
          "protocol": {"kind": "crm", "volume_fraction": "jammed"},
          "analysis": {"elastic": {}, "pores": {"n_points": 2000}}, "output": {"plots": False}}
    out = tmp_path / "el"
    pp.ensemble.run_study(st, out, progress=False)
    text = report(out, tmp_path / "el.html", plots_dir=tmp_path / "f", formats=("svg",)).read_text()
    assert "Static shear modulus G of each realization against its degree of heterogeneity a" in text
    assert (tmp_path / "f" / "modulus_vs_doh_elastic.svg").is_file()
    recs = [json.loads((out / "realizations" / f"r{i:04d}.json").read_text())["scalars"] for i in range(2)]
    a = [r["pores.fit.seed.a"] for r in recs]
    g = [r["elastic.shear_modulus"] for r in recs]
    fig = P.modulus_vs_doh_figure([("CRM", a, g)], y_label="G")
    (ln,) = fig.axes[0].get_lines()
    assert np.allclose(ln.get_xdata(), a) and np.allclose(ln.get_ydata(), g) and min(g) > 0


def test_modulus_against_the_doh_with_floppy_structures():
    """Floppy structures (G = 0) are counted in the legend, not drawn on the log axes; a set with
    no rigid structure at all gives linear axes and a note instead of a crash (log axes need a
    positive point)."""
    from polypack.report import figures as P

    fig = P.modulus_vs_doh_figure([("VEM", [0.4, 0.5, 0.6], [0.0, 2.0e6, 3.0e6])], y_label="G")
    ax = fig.axes[0]
    (ln,) = ax.get_lines()
    assert list(ln.get_xdata()) == [0.5, 0.6] and ax.get_yscale() == "log"
    assert "1 floppy" in ax.get_legend_handles_labels()[1][0]
    fig = P.modulus_vs_doh_figure([("VEM", [0.4, 0.5], [0.0, 0.0])], y_label="G")
    fig.savefig(io.BytesIO(), format="png")
    assert fig.axes[0].get_yscale() == "linear"
    assert any("no rigid structure" in t.get_text() for t in fig.axes[0].texts)
