"""``polypack moduli``: one pack or a folder of realizations; the estimates match the library."""

import json

import numpy as np
import pytest

import polypack as pp
from _analysis_packs import rsa
from polypack.cli import main
from polypack.mechanics import Phase, mefm, mori_tanaka


@pytest.fixture(scope="module")
def packs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("mod")
    (folder / "realizations").mkdir()
    out = []
    for s in range(2):
        pk = rsa(np.random.default_rng(s), 250, 12.0, radii_choices=(0.9, 0.5), weights=(0.4, 0.6))
        path = folder / "realizations" / f"r{s:04d}.gsd"
        pp.io.write(path, pk)
        out.append((path, pk))
    return folder, out


def test_moduli_one_pack_matches_library(packs, tmp_path, capsys):
    folder, items = packs
    path, pk = items[0]
    res_path = tmp_path / "m.json"
    main(["moduli", str(path), "--matrix", "3.01e9,0.394", "--inclusions", "76e9,0.23", "--json", str(res_path)])
    text = capsys.readouterr().out
    assert "mori_tanaka" in text and "mefm" in text and "zeta2" in text
    res = json.loads(res_path.read_text())
    m, f = Phase.from_young(3.01e9, 0.394), Phase.from_young(76e9, 0.23)
    fr = [np.sum(4 / 3 * np.pi * pk.radii[pk.species == s] ** 3) / np.prod(pk.box) for s in range(2)]
    assert res["mori_tanaka"]["young"]["mean"] == pytest.approx(mori_tanaka(m, [f, f], fr).young, rel=1e-10)
    assert res["mefm"]["shear"]["mean"] == pytest.approx(mefm(m, [f, f], pk).shear, rel=1e-10)
    lo, up = res["three_point_lower"]["bulk"]["mean"], res["three_point_upper"]["bulk"]["mean"]
    assert res["hs_lower"]["bulk"]["mean"] <= lo <= up <= res["hs_upper"]["bulk"]["mean"]
    assert res["mori_tanaka"]["young"]["stderr"] is None


def test_moduli_run_folder_gives_error_bars(packs, tmp_path, capsys):
    folder, items = packs
    res_path = tmp_path / "m.json"
    main(["moduli", str(folder), "--matrix", "3.01e9,0.394", "--inclusions", "76e9,0.23",
          "--inclusions", "76e9,0.23", "--no-three-point", "--json", str(res_path)])
    res = json.loads(res_path.read_text())
    assert res["n_realizations"] == 2 and "three_point_lower" not in res
    m, f = Phase.from_young(3.01e9, 0.394), Phase.from_young(76e9, 0.23)
    vals = [mefm(m, [f, f], pk).young / m.young for _, pk in items]
    assert res["mefm"]["young_ratio"]["mean"] == pytest.approx(np.mean(vals), rel=1e-10)
    assert res["mefm"]["young_ratio"]["stderr"] == pytest.approx(np.std(vals, ddof=1) / np.sqrt(2), rel=1e-8)


@pytest.mark.parametrize(
    "args, msg",
    [
        (["--matrix", "3e9", "--inclusions", "76e9,0.23"], "--matrix 3000000000.0: expected [E, nu]"),
        (["--matrix", "3e9,0.7", "--inclusions", "76e9,0.23"], "(-1, 0.5]"),
        (["--matrix", "3e9,0.3", "--inclusions", "76e9,0.23", "--inclusions", "1,0.2", "--inclusions", "1,0.2"],
         "species"),
    ],
)
def test_moduli_bad_input_one_line(packs, capsys, args, msg):
    folder, items = packs
    with pytest.raises(SystemExit):
        main(["moduli", str(items[0][0]), *args])
    err = capsys.readouterr().err
    assert msg in err and len(err.strip().splitlines()) == 1
