"""``[protocol] kind = "brownian"`` and ``kind = "deposit"`` through the registry.

Each protocol runs a tiny study end to end; its packs are checked against the generator
called directly with the realization's protocol seed (an independent path: the public
generator and :func:`polypack.ensemble.stages.stage_seeds`), and bad input fails before
anything runs with a one-line error naming the key.
"""

import csv
import json
import warnings

import numpy as np
import pytest

import polypack as pp
from polypack.ensemble.stages import stage_seeds
from polypack.errors import InvalidInputError
from polypack.mechanics import BondNetwork, elastic_tensor
from polypack.study import validate

FAST_BD = {"surface_potential": 0.0, "stable_window": 5e-3, "max_time": 0.05}  # DLCA at 0 mV: a gel in ~0.03 s


def _bd_study(analysis=None, n=40, psd=None, **protocol):
    return {
        "study": {"name": "bd", "seed": 4, "realizations": 2},
        "psd": psd or {"model": "monodisperse", "d": 1.0, "n": n},
        "protocol": {"kind": "brownian", **FAST_BD, **protocol},
        "analysis": analysis if analysis is not None else {"elastic": {}},
        "output": {"plots": False},
    }


def _rows(out):
    with open(out / "summary.csv", newline="") as fh:
        return list(csv.DictReader(fh))


# --------------------------------------------------------------------------- brownian
@pytest.fixture(scope="module")
def bd_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bd") / "run"
    pp.ensemble.run_study(_bd_study(), out, progress=False)
    return out


def test_brownian_protocol_is_pp_brownian_scaled_to_the_psd_radius(bd_run):
    rows = _rows(bd_run)
    for k, row in enumerate(rows):
        rec = json.loads((bd_run / "realizations" / f"r{k:04d}.json").read_text())
        pk = pp.io.read(bd_run / "realizations" / f"r{k:04d}.gsd")
        # the direct path: pp.brownian with the realization's protocol seed, in SI (a = 0.25 um)
        gel = pp.brownian(40, 0.4, seed=stage_seeds(rec["seed"])[1], progress=False, **FAST_BD)
        scale = 0.5 / 0.25e-6  # the [psd] radius over the physical one
        assert pk.meta["length_scale"] == pytest.approx(scale, rel=1e-15)
        np.testing.assert_allclose(pk.positions, gel.positions * scale, rtol=1e-13, atol=1e-12)
        np.testing.assert_allclose(pk.box, gel.box * scale, rtol=1e-14)
        assert np.all(pk.radii == 0.5)
        assert pk.meta["bonds"] == gel.meta["bonds"]  # the BD bonds travel with the pack (GSD meta)
        assert row["protocol.status"] == "target" and row["protocol.brownian.converged"] == "True"
        assert float(row["protocol.brownian.coordination"]) == pytest.approx(gel.meta["brownian"]["coordination"])
        # [analysis.elastic] used the BD bonds: the tensor of from_pairs on the SI gel (lengths rescaled to
        # a = 0.25 um either way, so the moduli agree to the round-off of the solve)
        i, j, shift = pp.generate.brownian_bonds(gel)
        et = elastic_tensor(BondNetwork.from_pairs(gel, i, j, shift, normal_stiffness=100.0, shear_stiffness=10.0),
                            radius=0.25e-6)
        assert rec["analysis"]["elastic"]["bonds"] == "protocol"
        assert float(row["elastic.shear_modulus"]) == pytest.approx(et.shear_modulus, rel=1e-8)
        assert int(row["elastic.n_bonds"]) == i.size


def test_brownian_protocol_budget_stopped_gel_is_left_out(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # "structure not stable within the budget"
        pp.ensemble.run_study(_bd_study(analysis={}, max_steps=20), tmp_path / "r", progress=False)
    rows = _rows(tmp_path / "r")
    assert [r["protocol.status"] for r in rows] == ["time_budget", "time_budget"]
    ens = json.loads((tmp_path / "r" / "ensemble" / "scalars.json").read_text())
    assert [e["status"] for e in ens["excluded"]] == ["time_budget", "time_budget"]


@pytest.mark.parametrize("study,msg", [
    (_bd_study(psd={"model": "bimodal", "size_ratio": 0.5, "volume_ratio": 0.5, "n": 40}),
     r'^protocol.kind = "brownian": makes equal spheres'),
    (_bd_study(n=10), r'^protocol.kind = "brownian": needs at least 16 spheres'),
])
def test_brownian_protocol_sizes_are_checked_before_anything_runs(tmp_path, study, msg):
    with pytest.raises(InvalidInputError, match=msg):
        pp.ensemble.run_study(study, tmp_path / "r", progress=False)
    assert not (tmp_path / "r" / "realizations").exists() or not any((tmp_path / "r" / "realizations").iterdir())


@pytest.mark.parametrize("protocol,msg", [
    ({"volume_fraction": 0.6}, r"protocol.volume_fraction = 0.6: brownian needs \(0, 0.55\]"),
    ({"surface_potential": 2.0}, r"^protocol: surface_potential=2.0"),
    ({"viscosity": -1.0}, r"protocol.viscosity = -1.0: must be > 0"),
    ({"model": "pb"}, r'protocol.model = "pb": allowed'),
    ({"growth_rate": 0.1}, r'protocol.growth_rate: only used with protocol.kind = "crm" or protocol.kind = "scrm"'),
    ({"max_steps": 0}, r"protocol.max_steps = 0: must be an integer >= 1"),
    ({"bonds": "stiff"}, r'protocol.bonds = "stiff": allowed'),
])
def test_brownian_protocol_bad_options(protocol, msg):
    with pytest.raises(InvalidInputError, match=msg) as exc:
        validate(_bd_study(**protocol))
    assert "\n" not in str(exc.value)


def test_brownian_protocol_passes_the_bond_model(monkeypatch):
    """[protocol] bonds reaches pp.brownian (rigid clusters or free rolling, docs/brownian.md)."""
    import polypack.generate.brownian as gb
    from polypack.generate.protocols import run_brownian

    seen = {}

    class Stop(Exception):
        pass

    def fake(n, **kw):
        seen.update(kw)
        raise Stop

    monkeypatch.setattr(gb, "brownian", fake)
    sizes = pp.psd.SizeSet(np.full(50, 0.5))
    with pytest.raises(Stop):
        run_brownian(sizes, {"volume_fraction": 0.4, "surface_potential": 0.0, "bonds": "rigid"}, seed=1)
    assert seen["bonds"] == "rigid"


# --------------------------------------------------------------------------- deposit
def _dep_study(psd=None, analysis=None, **protocol):
    return {
        "study": {"name": "dep", "seed": 9, "realizations": 2},
        "psd": psd or {"model": "uniform_volume", "d_min": 0.5, "d_max": 1.0, "n": 400, "dim": 2},
        "protocol": {"kind": "deposit", **protocol},
        "analysis": analysis or {},
        "output": {"plots": False},
    }


def test_deposit_protocol_matches_pp_deposit(tmp_path):
    out = tmp_path / "r"
    pp.ensemble.run_study(_dep_study(boundary="walls", analysis={"deposit": {"margin": 1.5}}), out, progress=False)
    rows = _rows(out)
    assert len(rows) == 2
    firsts = []
    for k in range(2):
        pk = pp.io.read(out / "realizations" / f"r{k:04d}.gsd")
        # [analysis.deposit] is DepositStatistics on the pack
        st = pp.analysis.DepositStatistics(margin=1.5).compute(pk)
        assert float(rows[k]["deposit.packing_fraction"]) == pytest.approx(st.packing_fraction, rel=1e-12)
        assert float(rows[k]["deposit.coordination"]) == pytest.approx(st.coordination, rel=1e-12)
        assert float(rows[k]["deposit.contact_shares.4"]) == pytest.approx(st.contact_shares.get(4, 0.0), rel=1e-12)
        assert pk.dim == 2 and pk.periodic == (False, False) and pk.meta["boundary"] == "walls"
        # independent path: deposit the same radii in the stored (deposition) order: the deposit is a
        # deterministic function of the order, so every position must come out the same
        again = pp.deposit(np.array(pk.radii), width=float(pk.box[0]), boundary="walls", order="given",
                           progress=False)
        np.testing.assert_allclose(again.positions, pk.positions, rtol=0, atol=1e-12)
        # and the order is the seeded random permutation of the study's sizes
        rec = json.loads((out / "realizations" / f"r{k:04d}.json").read_text())
        direct = pp.deposit(pp.psd.config.make_sizes(validate(_dep_study())["psd"], stage_seeds(rec["seed"])[0]),
                            seed=stage_seeds(rec["seed"])[1], boundary="walls", progress=False)
        np.testing.assert_array_equal(direct.positions, pk.positions)
        assert pk.min_gap() >= -1e-9
        firsts.append(pk.radii[0])
    assert firsts[0] != firsts[1]  # realizations get their own orders
    curves = json.loads((out / "ensemble" / "curves.json").read_text())["analyses"]
    assert curves["deposit"]["x_name"] == "height" and "fraction" in curves["deposit"]["curves"]


def test_deposit_protocol_in_3d_matches_pp_deposit(tmp_path):
    """[psd] dim = 3: the stage deposits spheres (pp.deposit with dim=3) and [analysis.deposit] measures
    the 3D window: the stored pack is re-deposited in its stored order (a deterministic function of the
    order) to the same positions, and the recorded fraction is DepositStatistics on it."""
    out = tmp_path / "r3"
    study = _dep_study(psd={"model": "uniform_volume", "d_min": 0.7, "d_max": 1.0, "n": 260, "dim": 3},
                       analysis={"deposit": {"margin": 0.8}}, width=5.0)
    study["study"]["realizations"] = 1
    pp.ensemble.run_study(study, out, progress=False)
    rows = _rows(out)
    pk = pp.io.read(out / "realizations" / "r0000.gsd")
    assert pk.dim == 3 and pk.periodic == (True, True, False) and pk.meta["dim"] == 3
    again = pp.deposit(np.array(pk.radii), width=5.0, order="given", dim=3, progress=False)
    np.testing.assert_allclose(again.positions, pk.positions, rtol=0, atol=1e-12)
    st = pp.analysis.DepositStatistics(margin=0.8).compute(pk)
    assert float(rows[0]["deposit.packing_fraction"]) == pytest.approx(st.packing_fraction, rel=1e-12)
    assert 0.5 < st.packing_fraction < 0.7  # a random deposit of spheres, not a lattice or a gas
    assert pk.min_gap() >= -1e-9


def test_deposit_protocol_in_3d_with_the_roll_rule_and_the_segregation_profile(tmp_path):
    """[protocol] rule = "roll" in 3D: the stage is pp.deposit(..., rule="roll") with the stage seed (the
    same positions), and [analysis.deposit] records the small-volume fraction slope, its error and mean of
    DepositStatistics (small_fraction_profile over the window, small_layers layers) and the per-strip curve."""
    out = tmp_path / "r3r"
    study = _dep_study(psd={"model": "uniform_volume", "d_min": 0.4, "d_max": 1.0, "n": 400, "dim": 3},
                       analysis={"deposit": {"margin": 0.5, "small_layers": 4}}, width=4.0, rule="roll")
    study["study"]["realizations"] = 1
    pp.ensemble.run_study(study, out, progress=False)
    rows = _rows(out)
    pk = pp.io.read(out / "realizations" / "r0000.gsd")
    assert pk.meta["rule"] == "roll" and pk.meta["method"] == "drop_and_roll"
    rec = json.loads((out / "realizations" / "r0000.json").read_text())
    sd = stage_seeds(rec["seed"])
    direct = pp.deposit(pp.psd.config.make_sizes(validate(study)["psd"], sd[0]), seed=sd[1], width=4.0,
                        rule="roll", progress=False)
    np.testing.assert_array_equal(direct.positions, pk.positions)
    st = pp.analysis.DepositStatistics(margin=0.5, small_layers=4).compute(pk)
    assert len(st.small_profile["fraction"]) == 4
    assert float(rows[0]["deposit.small_fraction_slope"]) == pytest.approx(st.small_profile["slope"], rel=1e-12)
    assert float(rows[0]["deposit.small_fraction_slope_err"]) == pytest.approx(st.small_profile["slope_err"],
                                                                               rel=1e-12)
    curves = json.loads((out / "ensemble" / "curves.json").read_text())["analyses"]
    assert "small_fraction" in curves["deposit"]["curves"]
    with pytest.raises(InvalidInputError, match=r'protocol.rule = "roll": needs boundary = "periodic"'):
        pp.ensemble.run_study(_dep_study(psd={"model": "uniform_volume", "d_min": 0.4, "d_max": 1.0, "n": 50,
                                              "dim": 3}, rule="roll", boundary="walls"), tmp_path / "w",
                              progress=False)


def test_deposit_protocol_centred_floor_needs_2d_sizes(tmp_path):
    study = _dep_study(psd={"model": "uniform_volume", "d_min": 0.5, "d_max": 1.0, "n": 150}, floor_rule="centred")
    with pytest.raises(InvalidInputError, match=r'^protocol.floor_rule = "centred": only for 2D deposits'):
        pp.ensemble.run_study(study, tmp_path / "r", progress=False)


@pytest.mark.parametrize("protocol,msg", [
    ({"boundary": "open"}, r'protocol.boundary = "open": allowed'),
    ({"width": -3.0}, r"protocol.width = -3.0: must be > 0"),
    ({"volume_fraction": 0.5}, r'protocol.volume_fraction: only used with protocol.kind = "crm"'),
])
def test_deposit_protocol_bad_options(protocol, msg):
    with pytest.raises(InvalidInputError, match=msg):
        validate(_dep_study(**protocol))


def test_elastic_stage_on_a_deposit_names_the_stage(tmp_path):
    with pytest.raises(InvalidInputError, match=r"^analysis.elastic: needs 3D spheres in a periodic box; this study's sizes are for dim=2"):
        pp.ensemble.run_study(_dep_study(analysis={"elastic": {}}), tmp_path / "r", progress=False)


@pytest.mark.parametrize("name", ["brownian_gel.toml", "deposit_study.toml"])
def test_bundled_stage_examples_validate_and_pass_preflight(name):
    from pathlib import Path

    from polypack.ensemble.stages import child_seed_records, preflight
    from polypack.study import load_study

    st = load_study(Path(__file__).resolve().parents[1] / "examples" / name)
    preflight(st.data, child_seed_records(st.seed, 1)[0])  # sizes, protocol and analyses agree
