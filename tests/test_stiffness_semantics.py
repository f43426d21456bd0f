"""Stiffness semantics (issue 32): ``stiffness = "contact"`` (per contact, the default) or
``"particle"`` (per-ball values combined in series per contact, k = k_a k_b / (k_a + k_b):
the PFC 4 linear model and Table 1 of 003_873b69fc71c74cf6.txt), in BondNetwork, the
DEM's static reference, the study stages, the CLI, VEM and the LAMMPS export."""

import numpy as np
import pytest
from _lattices import fcc, simple_cubic

import polypack as pp
from polypack.errors import InvalidInputError
from polypack.mechanics import BondNetwork, elastic_tensor, read_network, static_shear_modulus, write_network
from polypack.mechanics.export import lammps_bond_coeffs
from polypack.study import validate

S2 = np.sqrt(2.0)


def _checkerboard_sc(cells=4):
    """Simple cubic lattice (d = 1) whose neighbours always differ in species: every bond joins 0 and 1."""
    pk = simple_cubic(cells=cells)
    g = np.rint(np.asarray(pk.positions) - 0.25).astype(int)
    return pp.Packing(pk.positions, pk.radii, pk.box, species=g.sum(axis=1) % 2)


def test_equal_balls_halve_every_modulus_exactly():
    """FCC (closed form C44 = (kn + ks)/(sqrt2 d)): per-particle 100/10 N/m = contacts of 50/5 N/m,
    so every modulus is exactly 1/2 of the per-contact network's (tensor and the DEM's static reference)."""
    pk = fcc(cells=3, d=1.0)
    con = BondNetwork.from_packing(pk, normal_stiffness=100.0, shear_stiffness=10.0)
    par = BondNetwork.from_packing(pk, normal_stiffness=100.0, shear_stiffness=10.0, stiffness="particle")
    assert con.stiffness == "contact" and par.stiffness == "particle"
    assert np.all(par.normal_stiffness == 50.0) and np.all(par.shear_stiffness == 5.0)
    assert np.all(con.normal_stiffness == 100.0)  # the default is unchanged
    c = elastic_tensor(par, solver="direct").stiffness
    assert c[3, 3] == pytest.approx(55.0 / S2, rel=1e-9)
    assert c[0, 0] == pytest.approx(S2 * 55.0, rel=1e-9)
    assert c[0, 1] == pytest.approx(45.0 / S2, rel=1e-9)
    np.testing.assert_allclose(c, 0.5 * elastic_tensor(con, solver="direct").stiffness, rtol=1e-9, atol=1e-9)
    assert static_shear_modulus(par, 2, 0) == pytest.approx(0.5 * static_shear_modulus(con, 2, 0), rel=1e-6)
    # from_pairs reads the option the same way
    pairs = BondNetwork.from_pairs(pk, con.i, con.j, con.shift, stiffness="particle")
    np.testing.assert_array_equal(pairs.normal_stiffness, par.normal_stiffness)
    # select keeps the per-contact values and the record of the semantics
    sub = par.select(np.arange(10))
    assert sub.stiffness == "particle" and np.all(sub.normal_stiffness == 50.0)


@pytest.mark.parametrize("form", ["list", "mapping"])
def test_unequal_species_give_the_series_value(form):
    """Checkerboard simple cubic (C11 = kn/d, C44 = ks/(2d), d = 1): balls of 100 and 300 N/m
    (shear 10 and 30) make contacts of 100*300/400 = 75 N/m (7.5), not the mean 200."""
    pk = _checkerboard_sc()
    kn = [100.0, 300.0] if form == "list" else {0: 100.0, 1: 300.0}
    ks = [10.0, 30.0] if form == "list" else {0: 10.0, 1: 30.0}
    net = BondNetwork.from_packing(pk, normal_stiffness=kn, shear_stiffness=ks, stiffness="particle")
    assert np.all(net.normal_stiffness == 75.0) and np.all(net.shear_stiffness == 7.5)
    c = elastic_tensor(net, solver="direct").stiffness
    assert c[0, 0] == pytest.approx(75.0, rel=1e-9) and c[3, 3] == pytest.approx(3.75, rel=1e-9)
    assert abs(c[0, 1]) < 1e-9


def test_bad_semantics_and_shapes_are_refused_in_one_line():
    pk = fcc(cells=3, d=1.0)
    cases = [
        (dict(stiffness="ball"), r"^stiffness='ball': allowed are \['contact', 'particle'\]"),
        (dict(stiffness="particle", normal_stiffness=np.full((2, 2), 100.0)), r"normal_stiffness of shape \(2, 2\)"),
        (dict(stiffness="particle", normal_stiffness=-1.0), r"normal_stiffness=-1.0 .*must be finite and > 0"),
        (dict(stiffness="particle", shear_stiffness=[10.0, 0.0]), r"shear_stiffness: per-particle stiffnesses"),
    ]
    for kw, msg in cases:
        with pytest.raises(InvalidInputError, match=msg) as exc:
            BondNetwork.from_packing(pk, **kw)
        assert "\n" not in str(exc.value)


def test_the_option_reaches_the_network_from_every_stage():
    from polypack.mechanics.stages import network_of, run_elastic

    pk = fcc(cells=3, d=1.0)
    for stage in ("elastic", "shear", "rigidity"):
        cap = pp.registry.get("analysis", stage)
        net, _ = network_of(pk, cap.resolve({"stiffness": "particle"}), f"analysis.{stage}")
        assert net.stiffness == "particle" and np.all(net.normal_stiffness == 50.0)
        assert np.all(net.shear_stiffness == 5.0)  # ks defaults to kn / 10, then in series
        net, _ = network_of(pk, cap.resolve({}), f"analysis.{stage}")
        assert net.stiffness == "contact" and np.all(net.normal_stiffness == 100.0)
    cap = pp.registry.get("analysis", "elastic")
    res = run_elastic(pk, cap.resolve({"stiffness": "particle", "radius": 0.0}), None)
    assert res["stiffness_semantics"] == "particle" and res["contact_normal_stiffness"] == 50.0
    assert res["plate_shear_modulus"] == pytest.approx(55.0 / S2, rel=1e-9)


@pytest.mark.parametrize("stage", ["elastic", "shear", "rigidity"])
def test_a_bad_value_in_a_study_is_refused_in_one_line(stage):
    study = {
        "study": {"name": "s", "seed": 1, "realizations": 1},
        "psd": {"model": "monodisperse", "d": 1.0, "n": 60},
        "protocol": {"kind": "crm", "volume_fraction": 0.6},
        "analysis": {stage: {"stiffness": "ball"}},
        "output": {"plots": False},
    }
    with pytest.raises(InvalidInputError, match=rf'analysis.{stage}.stiffness = "ball": allowed') as exc:
        validate(study)
    assert "\n" not in str(exc.value)
    study["protocol"] = {"kind": "vem", "volume_fraction": 0.4, "stiffness": "ball"}
    study["analysis"] = {}
    with pytest.raises(InvalidInputError, match=r'protocol.stiffness = "ball": allowed') as exc:
        validate(study)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("stiffness", ["contact", "particle"])
def test_lammps_export_writes_the_per_contact_value_used(tmp_path, stiffness):
    """bond_coeff Kr, Ks = the network's per-contact stiffness (50/5 N/m for 100/10 N/m balls)."""
    pk = _checkerboard_sc(cells=4)
    net = BondNetwork.from_packing(pk, normal_stiffness=[100.0, 300.0], shear_stiffness=[10.0, 30.0],
                                   stiffness=stiffness) if stiffness == "particle" else \
        BondNetwork.from_packing(pk, normal_stiffness=75.0, shear_stiffness=7.5)
    types, coeffs, _ = lammps_bond_coeffs(net)
    np.testing.assert_array_equal(coeffs[types - 1, 0], net.normal_stiffness)
    np.testing.assert_array_equal(coeffs[types - 1, 1], net.shear_stiffness)
    assert np.all(coeffs[:, 0] == 75.0) and np.all(coeffs[:, 1] == 7.5)  # never the per-ball 100/300
    eq = BondNetwork.from_packing(fcc(cells=3), stiffness=stiffness)
    path = tmp_path / "net.data"
    write_network(path, eq)
    back = read_network(path)
    np.testing.assert_array_equal(back.normal_stiffness, eq.normal_stiffness)
    assert np.all(back.normal_stiffness == (50.0 if stiffness == "particle" else 100.0))


def test_cli_elastic_stiffness_flag(tmp_path, capsys):
    import json

    from polypack.cli import main

    src = tmp_path / "fcc.gsd"
    pp.io.write(src, fcc(cells=3, d=1.0))
    out = {}
    for st in ("contact", "particle"):
        js = tmp_path / f"{st}.json"
        main(["elastic", str(src), "--radius", "0", "--stiffness", st, "--json", str(js)])
        out[st] = json.loads(js.read_text())
    assert out["particle"]["stiffness_semantics"] == "particle"
    np.testing.assert_allclose(np.asarray(out["particle"]["elastic"]["stiffness"]),
                               0.5 * np.asarray(out["contact"]["elastic"]["stiffness"]), rtol=1e-9, atol=1e-9)
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        main(["elastic", str(src), "--stiffness", "ball"])
    err = capsys.readouterr().err.strip()
    assert exc.value.code == 1 and err.startswith("error:") and '--stiffness "ball": allowed: "contact", "particle"' in err and "\n" not in err


def test_vem_contacts_combine_per_ball_values_in_series():
    """Two structure spheres and two voids in a row, all touching: per-contact springs in reduced units."""
    from polypack.generate.vem import _Assembly

    pos = np.array([[5.0, 5, 5], [6.99, 5, 5], [8.49, 5, 5], [9.49, 5, 5]])
    radii = np.array([1.0, 1.0, 0.5, 0.5])
    kn, ks, knv, ksv = 100.0, 10.0, 300.0, 0.01
    ser = lambda a, b: a * b / (a + b)  # noqa: E731
    kss = ser(kn, kn)
    asm = _Assembly(pos, radii, np.full(3, 20.0), 2, 1.0, ser(ks, ks) / kss, ser(kn, knv) / kss,
                    ser(ks, ksv) / kss, 0.0, 0.7, 0.4, void_void=(ser(knv, knv) / kss, ser(ksv, ksv) / kss))
    asm.rebuild()
    got = {(int(a), int(b)): (n, s) for a, b, n, s in zip(asm.ci, asm.cj, asm.ckn, asm.cks)}
    assert got[(0, 1)] == pytest.approx((1.0, 0.1))                       # structure-structure 50 / 5
    assert got[(1, 2)] == pytest.approx((75.0 / 50.0, ser(10, 0.01) / 50))  # structure-void 100*300/400
    assert got[(2, 3)] == pytest.approx((150.0 / 50.0, 0.005 / 50))        # void-void 300/2


def test_vem_passes_the_option_to_its_assembly(monkeypatch):
    import polypack.generate.vem as V

    seen = {}

    class Stop(Exception):
        pass

    class Spy(V._Assembly):
        def __init__(self, *a, **kw):
            seen.update(args=a, kw=kw)
            raise Stop

    monkeypatch.setattr(V, "_Assembly", Spy)
    for st in ("contact", "particle"):
        with pytest.raises(Stop):
            V.vem(64, 0.4, 1.0, seed=1, void_normal_stiffness=300.0, stiffness=st, progress=False)
        kn, ks, knv = seen["args"][4:7]
        if st == "contact":
            assert (kn, ks, knv) == (1.0, 0.1, 3.0) and seen["kw"].get("void_void") is None
        else:
            assert (kn, ks) == (1.0, 0.1) and knv == pytest.approx(75.0 / 50.0)
            assert seen["kw"]["void_void"][0] == pytest.approx(3.0)
    with pytest.raises(InvalidInputError, match=r"stiffness"):
        V.vem(64, 0.4, 1.0, seed=1, stiffness="ball", progress=False)


def test_vem_structure_is_unchanged_by_the_semantics_at_the_seeds_values():
    """kn = kn,V and frictionless contacts (the seed's VEM): every normal contact is kn/2 under
    "particle", the same ratio kn,V/kn = 1 in reduced units, so the structure is bit-identical."""
    from polypack.generate.vem import vem

    a = vem(64, 0.4, 1.0, seed=3, progress=False)
    b = vem(64, 0.4, 1.0, seed=3, progress=False, stiffness="particle")
    assert b.meta["vem"]["stiffness"] == "particle" and a.meta["vem"]["stiffness"] == "contact"
    np.testing.assert_array_equal(a.positions, b.positions)


@pytest.mark.parametrize("name", ["heterogeneity", "heterogeneity_seed", "heterogeneity_bd"])
def test_seed_003_examples_state_the_particle_semantics(name):
    from pathlib import Path

    from polypack.ensemble.sweep import sweep_studies

    _, studies, _ = sweep_studies(Path(__file__).resolve().parents[1] / "examples" / f"{name}.toml")
    for _, st in studies:
        assert st.data["analysis"]["elastic"]["stiffness"] == "particle"
        if st.data["protocol"]["kind"] == "vem":
            assert st.data["protocol"]["stiffness"] == "particle"


def test_sweep_elastic_stiffness_is_checked():
    import tomllib
    from pathlib import Path

    from polypack.ensemble.sweep import sweep_studies

    d = tomllib.loads((Path(__file__).resolve().parents[1] / "examples" / "heterogeneity.toml").read_text())
    d["sweep"]["elastic"] = {"stiffness": "particle"}
    sw, _, _ = sweep_studies(d)
    assert sw["elastic"]["stiffness"] == "particle"
    d["sweep"]["elastic"] = {"stiffness": "ball"}
    with pytest.raises(InvalidInputError, match=r"^sweep.elastic.stiffness = 'ball': allowed: \"contact\", \"particle\"$"):
        sweep_studies(d)


def test_dem_storage_modulus_halves_exactly_for_equal_balls():
    """The DEM scales its masses to the stiffness (critical step), so the whole oscillatory run
    under "particle" is the "contact" run with k/2 and m/2: G' is exactly half (measured 0.5 - 2e-13)."""
    from polypack.mechanics import oscillatory_shear

    pk = fcc(cells=3, d=0.5e-6)
    res = {st: oscillatory_shear(BondNetwork.from_packing(pk, stiffness=st), cycles=3, steps_per_cycle=400,
                                 directions=[(2, 0)], progress=False) for st in ("contact", "particle")}
    assert res["contact"].status == res["particle"].status == "ok"
    assert res["particle"].storage_modulus == pytest.approx(0.5 * res["contact"].storage_modulus, rel=1e-9)
    # and it is the static closed form C55 = (kn + ks)/(sqrt2 d) of 50/5 N/m contacts (d = 0.5 um) within 1 %
    assert res["particle"].storage_modulus == pytest.approx(55.0 / (S2 * 0.5e-6), rel=0.01)


def test_cli_export_network_writes_the_per_contact_lammps_coefficients(tmp_path):
    from polypack.cli import main

    src = tmp_path / "fcc.gsd"
    pp.io.write(src, fcc(cells=3, d=1.0))
    for st, want in (("contact", 100.0), ("particle", 50.0)):
        out = tmp_path / f"{st}.data"
        main(["export-network", str(src), str(out), "--stiffness", st])
        coeffs = [line.split() for line in out.read_text().splitlines() if line.lstrip("# ").startswith("bond_coeff")]
        assert coeffs and all(float(c[-12]) == want and float(c[-11]) == want / 10 for c in coeffs)
        assert np.all(read_network(out).normal_stiffness == want)


def test_heterogeneity_report_names_the_semantics_of_each_source():
    from polypack.studies.seed003_heterogeneity import _semantics

    rec = {"analysis": {"elastic": {"stiffness_semantics": "particle"}, "shear": {"stiffness_semantics": "contact"}}}
    assert _semantics(rec, "[analysis.elastic]", {}) == "particle"
    assert _semantics(rec, "[analysis.shear] (dynamic G')", {}) == "contact"
    assert _semantics({"analysis": {"elastic": {}}}, "[analysis.elastic]", {}) == "contact"  # older records
    assert _semantics(rec, "report (pp.mechanics.elastic_tensor)", {"stiffness": "particle"}) == "particle"
