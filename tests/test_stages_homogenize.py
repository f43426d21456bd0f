"""``[analysis.homogenize]`` through the registry: summary scalars against the library on the saved
packs, the report's moduli figure, and bad options (one-line errors naming the key)."""

import csv

import numpy as np
import pytest

import polypack as pp
from polypack.errors import InvalidInputError
from polypack.mechanics import Phase, homogenize
from polypack.study import validate


def _study(homog, moduli=True, **psd):
    an = {"homogenize": homog}
    if moduli:
        an["moduli"] = {"matrix": [3.01e9, 0.394], "inclusions": [76e9, 0.23], "three_point": False}
    return {
        "study": {"name": "ff", "seed": 3, "realizations": 2},
        "psd": {"model": "bimodal", "size_ratio": 0.5, "volume_ratio": 0.5, "n": 60, **psd},
        "protocol": {"kind": "crm", "volume_fraction": 0.35},
        "analysis": an,
        "output": {"plots": False},
    }


@pytest.fixture(scope="module")
def ff_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("ff") / "run"
    pp.ensemble.run_study(_study({"materials": ["glass/epoxy"], "resolution": [10, 14], "tolerance": 1e-5}), out,
                          progress=False)
    return out


def test_stage_scalars_match_the_library_on_each_pack(ff_run):
    with open(ff_run / "summary.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 2
    m, f = Phase.from_young(3.01e9, 0.394), Phase.from_young(76e9, 0.23)
    for k, row in enumerate(rows):
        pk = pp.io.read(ff_run / "realizations" / f"r{k:04d}.gsd")
        r = homogenize(pk, m, f, resolutions=[10, 14], tolerance=1e-5)
        assert float(row["homogenize.converged"]) == 1
        assert float(row["homogenize.young_ratio"]) == pytest.approx(r.young / m.young, rel=1e-9)
        assert float(row["homogenize.shear"]) == pytest.approx(r.shear, rel=1e-9)
        assert float(row["homogenize.stiffness.3-3"]) == pytest.approx(r.stiffness[3, 3], rel=1e-9)
        assert float(row["homogenize.extrapolated.shear_ratio.value"]) == pytest.approx(
            r.extrapolated["shear"]["value"] / m.shear, rel=1e-9)
        assert float(row["homogenize.volume_fraction"]) == pytest.approx(float(row["moduli.volume_fraction"]), rel=1e-12)
        # above the Mori-Tanaka (= HS lower) estimate of the same pack
        assert float(row["homogenize.young_ratio"]) > float(row["moduli.mori_tanaka.young_ratio"])


def test_report_has_the_fullfield_moduli_figure(ff_run):
    from polypack.report.build import read_run, run_figures

    figs = run_figures(read_run(ff_run), [pp.io.read(ff_run / "realizations" / "r0000.gsd")])
    names = [n for n, _, _ in figs]
    assert "moduli_fullfield" in names
    svg = dict((n, s) for n, s, _ in figs)["moduli_fullfield"]
    assert "full field" in svg and "E*/E0" in svg


def test_default_system_is_glass_epoxy():
    from polypack.mechanics.stages import _systems

    assert [n for n, _, _ in _systems({})] == ["glass/epoxy"]
    assert [n for n, _, _ in _systems({"matrix": [1.0, 0.3], "inclusions": [2.0, 0.3]})] == ["custom"]


def test_two_systems_give_two_records(tmp_path):
    st = _study({"matrix": [1e9, 0.3], "inclusions": [2e9, 0.3], "materials": ["glass/epoxy"], "resolution": 8,
                 "tolerance": 1e-4}, moduli=False)
    st["study"]["realizations"] = 1
    pp.ensemble.run_study(st, tmp_path / "r", progress=False)
    with open(tmp_path / "r" / "summary.csv", newline="") as fh:
        row = next(csv.DictReader(fh))
    assert 1.0 < float(row["homogenize1.young_ratio"]) < 1.5 < float(row["homogenize0.young_ratio"])  # custom, glass/epoxy


def test_an_unconverged_solve_records_no_moduli(tmp_path):
    st = _study({"materials": ["glass/epoxy"], "resolution": 8, "max_iterations": 1}, moduli=False)
    st["study"]["realizations"] = 1
    pp.ensemble.run_study(st, tmp_path / "r", progress=False)
    with open(tmp_path / "r" / "summary.csv", newline="") as fh:
        row = next(csv.DictReader(fh))
    assert float(row["homogenize.converged"]) == 0
    assert not row.get("homogenize.young_ratio") and not row.get("homogenize.stiffness.0-0")


@pytest.mark.parametrize("bad, match", [
    ({"matrix": [1e9, 0.3]}, "both matrix and inclusions"),
    ({"materials": ["steel/air"]}, "unknown material system"),
    ({"matrix": [1e9, 0.5], "inclusions": [2e9, 0.3]}, "finite bulk"),
    ({"materials": ["AP/HTPB"], "resolution": [32, 16]}, "increasing"),
    ({"materials": ["AP/HTPB"], "scheme": "spectral"}, "scheme"),
])
def test_bad_options(bad, match):
    with pytest.raises(InvalidInputError, match=match):
        validate(_study(bad, moduli=False))
