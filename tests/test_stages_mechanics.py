"""Study stages of the mechanics through the registry: ``[analysis.elastic]`` (and later ones).

Each stage is checked (1) end to end in a tiny study (``polypack run``: summary column,
ensemble mean, record) against the direct API call on the same pack read back from the
realization's GSD file (an independent path through the public API), (2) on a lattice
against its closed form, and (3) on bad input (one-line errors naming the key).
"""

import csv
import json

import numpy as np
import pytest
from _lattices import fcc

import polypack as pp
from polypack.errors import InfeasibleError, InvalidInputError
from polypack.mechanics import BondNetwork, elastic_tensor
from polypack.study import validate

R0 = 0.25e-6  # seed 003 Table 1 radius: the stage's default length rescaling


def _study(analysis, **protocol):
    return {
        "study": {"name": "mech", "seed": 5, "realizations": 2},
        "psd": {"model": "monodisperse", "d": 1.0, "n": 60},
        "protocol": {"kind": "crm", "volume_fraction": 0.6, **protocol},
        "analysis": analysis,
        "output": {"plots": False},
    }


def _rows(out):
    with open(out / "summary.csv", newline="") as fh:
        return list(csv.DictReader(fh))


# --------------------------------------------------------------------------- elastic
@pytest.fixture(scope="module")
def elastic_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("elastic") / "run"
    pp.ensemble.run_study(_study({"elastic": {"epsilon": 0.05, "normal_stiffness": 50.0}}), out, progress=False)
    return out


def test_elastic_stage_matches_the_direct_api_on_each_realization(elastic_run):
    rows = _rows(elastic_run)
    assert len(rows) == 2
    gs = []
    for k, row in enumerate(rows):
        pk = pp.io.read(elastic_run / "realizations" / f"r{k:04d}.gsd")
        # the direct path: network and tensor from the public API with the same options
        net = BondNetwork.from_packing(pk, epsilon=0.05, normal_stiffness=50.0, shear_stiffness=5.0)
        et = elastic_tensor(net, radius=R0)
        # GSD stores double precision, so the numbers agree to round-off of the solve
        # (1e-8 would catch any option not passed through: ks, rotations, radius, epsilon)
        for col, want in (("shear_modulus", et.shear_modulus), ("bulk_modulus", et.bulk_modulus),
                          ("affine_shear_modulus", et.affine_shear_modulus),
                          ("relaxation_ratio", et.relaxation_ratio), ("coordination", net.coordination),
                          ("shear_modulus_MPa", et.shear_modulus * 1e-6),
                          ("shear_moduli.2", et.shear_moduli[2])):
            assert float(row[f"elastic.{col}"]) == pytest.approx(want, rel=1e-8), col
        assert int(row["elastic.n_rattlers"]) == int(net.rattlers.sum())
        assert int(row["elastic.n_bonds"]) == net.n_bonds
        rec = json.loads((elastic_run / "realizations" / f"r{k:04d}.json").read_text())
        el = rec["analysis"]["elastic"]
        assert el["bonds"] == "distance" and el["units"] == "Pa"
        np.testing.assert_allclose(el["stiffness"], et.stiffness, rtol=1e-8, atol=1e-8 * abs(et.stiffness).max())
        gs.append(et.shear_modulus)
    ens = json.loads((elastic_run / "ensemble" / "scalars.json").read_text())
    g = ens["elastic.shear_modulus"]
    assert g["n"] == 2 and g["mean"] == pytest.approx(np.mean(gs), rel=1e-8)
    assert g["se"] == pytest.approx(np.std(gs, ddof=1) / np.sqrt(2), rel=1e-6)


def test_elastic_stage_on_fcc_gives_the_closed_form():
    """FCC, nearest-neighbour bonds of length d: C44 = (kn + ks)/(sqrt(2) d), C11 = sqrt(2)(kn + ks)/d."""
    from polypack.mechanics.stages import run_elastic

    cap = pp.registry.get("analysis", "elastic")
    opts = cap.resolve({})  # defaults: kn = 100, ks = kn / 10, lengths rescaled to r0 = 0.25 um
    res = run_elastic(fcc(cells=3, d=1.0), opts, np.random.SeedSequence(0))
    d = 2 * R0
    c = np.asarray(res["stiffness"])
    # tolerance 1e-6: the tensor is exact; a wrong ks default (e.g. 10 % off) or radius fails by far
    assert c[3, 3] == pytest.approx(110.0 / (np.sqrt(2) * d), rel=1e-6)
    assert c[0, 0] == pytest.approx(np.sqrt(2) * 110.0 / d, rel=1e-6)
    assert c[0, 1] == pytest.approx(90.0 / (np.sqrt(2) * d), rel=1e-6)
    assert res["coordination"] == 12.0 and res["n_rattlers"] == 0 and res["relaxation_ratio"] == pytest.approx(1.0)
    # pack units: radius = 0 keeps lengths (d = 1), so C44 = 110 / sqrt(2)
    res = run_elastic(fcc(cells=3, d=1.0), cap.resolve({"radius": 0.0, "rotations": False}), None)
    assert np.asarray(res["stiffness"])[3, 3] == pytest.approx(110.0 / np.sqrt(2), rel=1e-6)
    assert "shear_modulus_MPa" not in res and res["rotations"] is False


def test_elastic_stage_uses_the_protocols_bonds_when_the_pack_has_them():
    """A pack carrying ``meta["bonds"]`` (as ``pp.brownian`` writes) is bonded with those bonds."""
    from polypack.mechanics.stages import run_elastic

    base = fcc(cells=3, d=1.0)
    nn = BondNetwork.from_packing(base, epsilon=0.01)  # nearest neighbours only
    meta = {"bonds": {"i": nn.i.tolist(), "j": nn.j.tolist(), "shift": nn.shift.tolist()}}
    pk = pp.Packing(base.positions, base.radii, base.box, meta=meta)
    cap = pp.registry.get("analysis", "elastic")
    # epsilon = 0.5 would also bond second neighbours (at sqrt(2) d): the protocol's bonds win under "auto"
    auto = run_elastic(pk, cap.resolve({"epsilon": 0.5, "radius": 0.0}), None)
    assert auto["bonds"] == "protocol" and auto["n_bonds"] == nn.n_bonds
    assert np.asarray(auto["stiffness"])[3, 3] == pytest.approx(110.0 / np.sqrt(2), rel=1e-6)
    dist = run_elastic(pk, cap.resolve({"epsilon": 0.5, "radius": 0.0, "bonds": "distance"}), None)
    assert dist["bonds"] == "distance" and dist["n_bonds"] == nn.n_bonds * 3 // 2  # + 6 second neighbours each
    assert dist["shear_modulus"] > auto["shear_modulus"] * 1.1
    with pytest.raises(InvalidInputError, match=r'^analysis.elastic.bonds = "protocol": this pack carries no bonds'):
        run_elastic(base, cap.resolve({"bonds": "protocol"}), None)


@pytest.mark.parametrize("table,msg", [
    ({"epsilon": -1}, r"analysis.elastic.epsilon = -1: must be >= 0"),
    ({"normal_stiffness": 0}, r"analysis.elastic.normal_stiffness = 0: must be > 0"),
    ({"bonds": "bd"}, r'analysis.elastic.bonds = "bd": allowed'),
    ({"solver": "lu"}, r'analysis.elastic.solver = "lu": allowed'),
    ({"kn": 100}, r"analysis.elastic.kn: unknown key; allowed in \[analysis.elastic\]: bonds, epsilon"),
])
def test_elastic_stage_bad_options(table, msg):
    with pytest.raises(InvalidInputError, match=msg) as exc:
        validate(_study({"elastic": table}))
    assert "\n" not in str(exc.value)


def test_elastic_stage_errors_name_the_stage():
    from polypack.mechanics.stages import run_elastic

    cap = pp.registry.get("analysis", "elastic")
    dilute = pp.Packing(np.array([[1.0, 1.0, 1.0], [4.0, 4.0, 4.0], [1.0, 4.0, 2.0]]), [0.5, 0.5, 0.5], 8.0)
    # no bond at all (issue 31): floppy, G = 0, the study goes on
    rec = run_elastic(dilute, cap.resolve({}), None)
    assert rec["status"] == "floppy" and rec["shear_modulus"] == 0.0 and rec["floppy_reason"].startswith("no pair within")
    from polypack.mechanics.stages import run_shear

    rec = run_shear(dilute, pp.registry.get("analysis", "shear").resolve({}), None)
    assert rec["status"] == "floppy" and rec["storage_modulus"] == 0.0 and rec["n_bonds"] == 0
    g = np.stack(np.meshgrid(np.arange(4), np.arange(4), indexing="ij"), -1).reshape(-1, 2) + 0.5
    disks = pp.Packing(g.astype(float), [0.5] * 16, [4.0, 4.0])  # square lattice of touching disks
    with pytest.raises(InvalidInputError, match=r"^analysis.elastic: elastic_tensor supports 3D packings only") as exc:
        run_elastic(disks, cap.resolve({}), None)
    assert "\n" not in str(exc.value)


# --------------------------------------------------------------------------- shear
# one direction, three short cycles: the stage runs in about a second once the kernels are compiled
SHEAR = {"epsilon": 0.05, "directions": [[2, 0]], "cycles": 3, "steps_per_cycle": 2000}


@pytest.fixture(scope="module")
def shear_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("shear") / "run"
    pp.ensemble.run_study(_study({"shear": SHEAR, "elastic": {"epsilon": 0.05}}), out, progress=False)
    return out


def test_shear_stage_matches_the_direct_dem_and_the_static_tensor(shear_run):
    from polypack.mechanics import oscillatory_shear

    for k, row in enumerate(_rows(shear_run)):
        pk = pp.io.read(shear_run / "realizations" / f"r{k:04d}.gsd")
        s = R0 / pk.radii.mean()
        si = pp.Packing(pk.positions * s, pk.radii * s, pk.box * s)
        net = BondNetwork.from_packing(si, epsilon=0.05, normal_stiffness=100.0, shear_stiffness=10.0)
        res = oscillatory_shear(net, directions=[(2, 0)], cycles=3, steps_per_cycle=2000, progress=False)
        # the same deterministic DEM on the same network: equal to round-off of the rescaling
        assert float(row["shear.storage_modulus"]) == pytest.approx(res.storage_modulus, rel=1e-9)
        assert float(row["shear.direction.2-0.loss_modulus"]) == pytest.approx(res.loss_modulus, rel=1e-6,
                                                                                abs=1e-9 * res.storage_modulus)
        # physics: at 2000 steps per cycle the slow-shear G' is the static C55 of the exact tensor
        # (an independent solver); 1 % is well above the inertial error reported (~2e-3) and far below the
        # gap to the affine bound (G/G_aff ~ 0.5 here)
        c55 = float(row["elastic.shear_moduli.1"])
        assert float(row["shear.storage_modulus"]) == pytest.approx(c55, rel=0.01)
        assert float(row["shear.inertial_error"]) < 0.01 and int(row["shear.breakages"]) == 0
        assert float(row["shear.storage_modulus_MPa"]) == pytest.approx(res.storage_modulus * 1e-6, rel=1e-9)
    ens = json.loads((shear_run / "ensemble" / "scalars.json").read_text())
    assert ens["shear.storage_modulus"]["n"] == 2


def test_shear_stage_rescales_a_polydisperse_pack_by_its_mean_radius():
    """Lengths are rescaled so that the *number-mean* radius is ``radius`` (seed 003 Table 1).

    With equal spheres mean, max and median radius coincide; here a 50:50 mix of radii 0.5 and 0.7
    (mean 0.6, max 0.7): G' of a bonded network scales as 1 / length, so a rescaling by another
    radius is off by 0.7 / 0.6 = 1.17.  Checked against (1) the same DEM on the pack the test
    rescales itself (round-off, 1e-9) and (2) the static C55 of the exact tensor, whose own
    ``radius=`` rescaling is independent of the stage (1 %: the inertial error of 2000 steps
    per cycle is ~2e-3, far below the 17 % of a wrong reference radius).
    """
    from polypack.mechanics import oscillatory_shear
    from polypack.mechanics.stages import run_shear

    n = 60
    rad = np.where(np.arange(n) < n // 2, 0.5, 0.7)
    pk = pp.pack(rad, 0.6, seed=7)
    out = run_shear(pk, pp.registry.get("analysis", "shear").resolve(SHEAR), None)
    s = R0 / np.mean(rad)
    si = pp.Packing(pk.positions * s, pk.radii * s, pk.box * s)
    net = BondNetwork.from_packing(si, epsilon=0.05, normal_stiffness=100.0, shear_stiffness=10.0)
    res = oscillatory_shear(net, directions=[(2, 0)], cycles=3, steps_per_cycle=2000, progress=False)
    assert out["storage_modulus"] == pytest.approx(res.storage_modulus, rel=1e-9)
    assert out["radius_m"] == R0
    c55 = elastic_tensor(BondNetwork.from_packing(pk, epsilon=0.05, normal_stiffness=100.0, shear_stiffness=10.0),
                         radius=R0).shear_moduli[1]
    assert out["storage_modulus"] == pytest.approx(c55, rel=0.01)
    assert out["breakages"] == 0


@pytest.mark.parametrize("table,msg", [
    ({"directions": [[2, 2]]}, r"analysis.shear.directions = \[\[2, 2\]\]: pair \[2, 2\]: give \[plate-normal axis"),
    ({"directions": 3}, r"analysis.shear.directions = 3: expected 6"),
    ({"boundary": "walls"}, r'analysis.shear.boundary = "walls": allowed'),
    ({"cycles": 0}, r"analysis.shear.cycles = 0: must be an integer >= 1"),
    ({"damping": 1.5}, r"analysis.shear.damping = 1.5: must be in \[0, 1\]"),
])
def test_shear_stage_bad_options(table, msg):
    with pytest.raises(InvalidInputError, match=msg) as exc:
        validate(_study({"shear": table}))
    assert "\n" not in str(exc.value)


def test_shear_stage_dem_errors_name_the_stage():
    from polypack.mechanics.stages import run_shear

    cap = pp.registry.get("analysis", "shear")
    # an amplitude whose affine bond load reaches the bond strengths is refused by the DEM
    opts = cap.resolve({"epsilon": 0.01, "amplitude": 0.5, "directions": [[2, 0]], "cycles": 1})
    with pytest.raises(InvalidInputError, match=r"^analysis.shear: ") as exc:
        run_shear(fcc(cells=2, d=1.0), opts, None)
    assert "\n" not in str(exc.value)


# ------------------------------------------------- floppy structures in a study (issue 31)
def test_study_with_floppy_structures_finishes_with_them_marked(tmp_path):
    """A phi = 0.3 CRM pack bonded at epsilon = 0.01 has no wrapping cluster: before issue 31
    the shear stage reported a DEM number (29 Pa for such a network) and the elastic stage
    refused; now both records say floppy, G = 0, the study finishes and no NaN is written."""
    data = _study({"shear": dict(SHEAR, epsilon=0.01), "elastic": {"epsilon": 0.01}}, volume_fraction=0.3)
    out = tmp_path / "run"
    pp.ensemble.run_study(data, out, progress=False)
    for k, row in enumerate(_rows(out)):
        rec = json.loads((out / "realizations" / f"r{k:04d}.json").read_text())
        sh, el = rec["analysis"]["shear"], rec["analysis"]["elastic"]
        assert sh["status"] == "floppy" and sh["storage_modulus"] == 0.0 and sh["inertial_error"] is None
        assert el["status"] == "floppy" and el["shear_modulus"] == 0.0 and "disconnected" in el["floppy_reason"]
        assert row["shear.floppy"] == "1" and row["shear.converged"] == "0" and row["elastic.floppy"] == "1"
        assert float(row["shear.storage_modulus"]) == 0.0
    ens = json.loads((out / "ensemble" / "scalars.json").read_text())
    assert ens["shear.floppy"]["mean"] == 1.0 and ens["elastic.shear_modulus"]["mean"] == 0.0


def test_not_converged_shear_states_so_and_gives_no_modulus():
    """100 steps per cycle on a rigid pack: G' +47 % over its static limit; the record keeps
    the measured numbers under measured_* and gives no modulus to average."""
    from polypack.mechanics.stages import run_shear

    pk = pp.pack(np.full(60, 0.5), volume_fraction=0.6, seed=5)
    cap = pp.registry.get("analysis", "shear")
    rec = run_shear(pk, cap.resolve(dict(SHEAR, steps_per_cycle=100, cycles=2)), None)
    json.dumps(rec, allow_nan=False)
    assert rec["status"] == "not_converged" and rec["converged"] == 0 and rec["problems"]
    assert rec["storage_modulus"] is None and rec["storage_modulus_MPa"] is None
    assert rec["measured_storage_modulus"] > 0 and rec["direction"]["2-0"]["storage_modulus"] is None


def test_a_nan_never_reaches_a_record(tmp_path, monkeypatch):
    """A stage result holding NaN (a NaN inertial_error crashed json.dumps and left r0000.gsd
    without its record, forever) is written with None instead."""
    from polypack.ensemble import runner
    from polypack.mechanics import stages

    real = stages.run_elastic
    monkeypatch.setattr(stages, "run_elastic", lambda pk, o, s: dict(real(pk, o, s), inertial_error=float("nan"),
                                                                      nested=[1.0, float("inf")]))
    out = tmp_path / "run"
    pp.ensemble.run_study(_study({"elastic": {"epsilon": 0.05}}), out, progress=False)
    rec = json.loads((out / "realizations" / "r0000.json").read_text())
    assert rec["analysis"]["elastic"]["inertial_error"] is None and rec["analysis"]["elastic"]["nested"] == [1.0, None]
    assert runner.finite_json({"a": [float("nan"), np.float64(2.0)]}) == {"a": [None, 2.0]}
