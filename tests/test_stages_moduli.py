"""``[analysis.moduli]`` through the registry and ``polypack moduli RUN_DIR`` on a ``polypack run`` folder.

The stage's numbers are checked against the direct library calls on the same packs read
back from the realization files (an independent path), against the Mori–Tanaka closed
form for voids, and on bad input (one-line errors naming the key).
"""

import csv
import json

import numpy as np
import pytest

import polypack as pp
from polypack.cli import main
from polypack.errors import InvalidInputError
from polypack.mechanics import Phase, hashin_shtrikman, mefm, mori_tanaka
from polypack.study import validate

GLASS_EPOXY = {"matrix": [3.01e9, 0.394], "inclusions": [76e9, 0.23]}


def _study(moduli, **psd):
    return {
        "study": {"name": "moduli", "seed": 2, "realizations": 2},
        "psd": {"model": "bimodal", "size_ratio": 0.5, "volume_ratio": 0.5, "n": 60, **psd},
        "protocol": {"kind": "crm", "volume_fraction": 0.35},
        "analysis": {"moduli": moduli},
        "output": {"plots": False},
    }


@pytest.fixture(scope="module")
def moduli_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("moduli") / "run"
    pp.ensemble.run_study(_study(GLASS_EPOXY), out, progress=False)
    return out


def test_moduli_stage_matches_the_library_on_each_realization(moduli_run):
    with open(moduli_run / "summary.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    m, f = Phase.from_young(3.01e9, 0.394), Phase.from_young(76e9, 0.23)
    ratios = []
    for k, row in enumerate(rows):
        pk = pp.io.read(moduli_run / "realizations" / f"r{k:04d}.gsd")
        fr = [np.sum(4 / 3 * np.pi * pk.radii[pk.species == s] ** 3) / np.prod(pk.box) for s in range(2)]
        # rel 1e-9: the same formulas on the same double-precision pack; a wrong phase, fraction or
        # species mapping changes these by far more
        assert float(row["moduli.volume_fraction"]) == pytest.approx(sum(fr), rel=1e-12)
        mt = mori_tanaka(m, [f, f], fr)
        assert float(row["moduli.mori_tanaka.young_ratio"]) == pytest.approx(mt.young / m.young, rel=1e-9)
        assert float(row["moduli.mori_tanaka.shear"]) == pytest.approx(mt.shear, rel=1e-9)
        lo, up = hashin_shtrikman([m, f, f], [1 - sum(fr), *fr])
        assert float(row["moduli.hs_upper.bulk"]) == pytest.approx(up.bulk, rel=1e-9)
        me = mefm(m, [f, f], pk)
        assert float(row["moduli.mefm.shear_ratio"]) == pytest.approx(me.shear / m.shear, rel=1e-9)
        tp = pp.analysis.ThreePointParameters().compute(pk)
        assert float(row["moduli.zeta2"]) == pytest.approx(tp.zeta2, rel=1e-9)
        # identities: every estimate within the HS bounds, three-point bounds inside HS
        for est in ("mori_tanaka", "self_consistent", "mefm", "three_point_lower", "three_point_upper"):
            assert lo.bulk * (1 - 1e-12) <= float(row[f"moduli.{est}.bulk"]) <= up.bulk * (1 + 1e-12), est
        ratios.append(me.young / m.young)
    ens = json.loads((moduli_run / "ensemble" / "scalars.json").read_text())
    assert ens["moduli.mefm.young_ratio"]["mean"] == pytest.approx(np.mean(ratios), rel=1e-10)


def test_moduli_cli_reads_a_run_folder_with_its_study_phases(moduli_run, tmp_path, capsys):
    out = tmp_path / "m.json"
    main(["moduli", str(moduli_run), "--no-three-point", "--json", str(out)])  # phases from the study
    res = json.loads(out.read_text())
    assert res["n_realizations"] == 2 and res["matrix"]["young"] == pytest.approx(3.01e9)
    ens = json.loads((moduli_run / "ensemble" / "scalars.json").read_text())
    for est in ("mori_tanaka", "mefm", "hs_lower"):
        assert res[est]["young_ratio"]["mean"] == pytest.approx(ens[f"moduli.{est}.young_ratio"]["mean"], rel=1e-10)
    # explicit phases override the study's
    main(["moduli", str(moduli_run), "--matrix", "3.01e9,0.394", "--inclusions", "7.6e9,0.23", "--no-three-point",
          "--json", str(out)])
    assert json.loads(out.read_text())["mori_tanaka"]["young_ratio"]["mean"] < ens["moduli.mori_tanaka.young_ratio"]["mean"]
    capsys.readouterr()
    with pytest.raises(SystemExit):
        main(["moduli", str(moduli_run), "--matrix", "3.01e9,0.394"])
    err = capsys.readouterr().err.strip()
    assert "give both --matrix and --inclusions" in err and "\n" not in err


def test_moduli_stage_mori_tanaka_closed_form_for_voids():
    """Voids (E = 0) at c = 0.3 in a nu0 = 0.3 matrix: K/K0 = 8/17, G/G0 = 0.55 (Mori–Tanaka)."""
    from polypack.ensemble.moduli_stage import run_moduli

    box = 10.0
    r = (0.3 / 8 * 3 / (4 * np.pi)) ** (1 / 3) * box  # 8 spheres on a cubic grid filling 30 % of the cell
    g = np.stack(np.meshgrid(*[np.arange(2)] * 3, indexing="ij"), -1).reshape(-1, 3) * 5.0 + 2.5
    pk = pp.Packing(g.astype(float), [r] * 8, box)
    opts = pp.registry.get("analysis", "moduli").resolve(
        {"matrix": [1.0, 0.3], "inclusions": [0.0, 0.3], "three_point": False, "mefm": False})
    res = run_moduli(pk, opts, None)
    assert res["volume_fraction"] == pytest.approx(0.3, rel=1e-12)
    assert res["mori_tanaka"]["bulk_ratio"] == pytest.approx(8 / 17, rel=1e-10)
    assert res["mori_tanaka"]["shear_ratio"] == pytest.approx(0.55, rel=1e-10)
    assert "mefm" not in res and "zeta2" not in res


@pytest.mark.parametrize("table,msg", [
    ({"matrix": [3e9], "inclusions": [76e9, 0.23]}, r"analysis.moduli.matrix = \[3000000000.0\]: expected \[E, nu\]"),
    ({"matrix": [3e9, 0.7], "inclusions": [76e9, 0.23]}, r"analysis.moduli.matrix = .*Poisson's ratio 0.7 must lie in"),
    ({"matrix": [-3e9, 0.3], "inclusions": [76e9, 0.23]}, r"Young's modulus -3000000000.0 must be >= 0"),
    ({"inclusions": [76e9, 0.23]}, r"analysis.moduli.matrix: required key is missing"),
    ({**GLASS_EPOXY, "mefm": "yes"}, r"analysis.moduli.mefm = \"yes\""),
])
def test_moduli_stage_bad_options(table, msg):
    with pytest.raises(InvalidInputError, match=msg) as exc:
        validate(_study(table))
    assert "\n" not in str(exc.value)


def test_moduli_stage_species_mismatch_names_the_key():
    from polypack.ensemble.moduli_stage import run_moduli

    pk = pp.Packing(np.array([[1.0, 1.0, 1.0], [3.0, 3.0, 3.0]]), [0.5, 0.25], 6.0, species=[0, 1])
    opts = pp.registry.get("analysis", "moduli").resolve(
        {"matrix": [3e9, 0.3], "inclusions": [[1e9, 0.2], [2e9, 0.2], [3e9, 0.2]], "mefm": False})
    with pytest.raises(InvalidInputError, match=r"^analysis.moduli.inclusions: the pack has 2 species but 3"):
        run_moduli(pk, opts, None)
