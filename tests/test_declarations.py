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


# --------------------------------------------------------------------------- a toy protocol and mechanics stage
PLUGINS = __import__("pathlib").Path(__file__).parent / "plugins"


def _cli(*args, cwd=None):
    import os
    import subprocess
    import sys

    env = {**os.environ, "COLUMNS": "250", "PYTHONPATH": os.pathsep.join([str(PLUGINS), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-m", "polypack.cli", *args], capture_output=True, text=True, env=env,
                          cwd=cwd)


TOY_STUDY = """[study]
name = "toy"
seed = 5
realizations = 2
[psd]
model = "monodisperse"
d = 1.0
n = 27
[protocol]
kind = "toy_lattice"
volume_fraction = 0.5235987755982988
[analysis.toy_spring]
stiffness = 3.0
[output]
plots = false
"""


def test_a_toy_protocol_and_mechanics_stage_are_one_dataclass_one_function_one_register(tmp_path):
    """tests/plugins/polypack_toy_plugin.py declares `toy_lattice` and `toy_spring` (nothing else touched):
    they are commands with every field as a flag, study tables checked by --check, and their declared
    statistics reach the records, summary.csv and labelled report rows.  Oracle: N = 27 equal spheres on
    a 3 x 3 x 3 simple cubic lattice at c = pi/6 touch their 6 neighbours, so 3N = 81 springs."""
    res = _cli("--help")
    assert res.returncode == 0, res.stderr
    assert "toy-lattice" in res.stdout and "toy-spring" in res.stdout
    res = _cli("toy-lattice", "--help")
    assert "--volume-fraction" in res.stdout and "--jitter" in res.stdout and "[clearance]" in res.stdout
    res = _cli("toy-spring", "--help")
    assert "--stiffness" in res.stdout and "--epsilon" in res.stdout and "[N/m]" in res.stdout
    study = tmp_path / "toy.toml"
    study.write_text(TOY_STUDY)
    res = _cli("run", str(study), "--check")
    assert res.returncode == 0, res.stderr
    assert "toy_spring" in res.stdout and "toy_lattice" in res.stdout
    bad = tmp_path / "bad.toml"
    bad.write_text(TOY_STUDY.replace("stiffness = 3.0", "stiffness = -1.0"))
    res = _cli("run", str(bad), "--check")
    assert res.returncode == 1 and "analysis.toy_spring.stiffness = -1.0: must be > 0" in res.stderr
    out = tmp_path / "run"
    res = _cli("run", str(study), "--out", str(out), "--no-progress")
    assert res.returncode == 0, res.stderr
    rows = _rows(out)
    assert [int(r["toy_spring.n_springs"]) for r in rows] == [81, 81]
    assert float(rows[0]["toy_spring.stiffness_density"]) == pytest.approx(3.0 * 81 / 27.0, rel=1e-9)  # box 3^3
    assert int(rows[0]["protocol.toy_lattice.cells"]) == 3
    rec = json.loads((out / "realizations" / "r0000.json").read_text())
    assert rec["protocol"]["toy_lattice.spacing"] == pytest.approx(1.0, rel=1e-12)
    html = (out / "report.html").read_text()
    assert "lattice cells per side" in html and "springs (near-contact pairs)" in html and "Toy lattice" in html
    # the generated commands run the same declarations
    res = _cli("toy-lattice", str(tmp_path / "p.gsd"), "--n", "27", "--volume-fraction", "0.5235987755982988",
               "--seed", "1")
    assert res.returncode == 0, res.stderr
    assert "toy_lattice.cells = 3  (lattice cells per side)" in res.stdout
    res = _cli("toy-spring", str(tmp_path / "p.gsd"), "--stiffness", "3", "--json", str(tmp_path / "s.json"))
    assert res.returncode == 0, res.stderr
    assert "toy_spring.n_springs = 81  (springs (near-contact pairs))" in res.stdout
    assert json.loads((tmp_path / "s.json").read_text())["toy_spring"]["n_springs"] == 81
    res = _cli("toy-spring", str(tmp_path / "p.gsd"), "--stiffness", "0")
    assert res.returncode == 1 and "--stiffness 0.0: must be > 0 (analysis.toy_spring.stiffness in a study file)" \
        in res.stderr
    res = _cli("toy-lattice", str(tmp_path / "q.gsd"), "--sizes", str(tmp_path / "none.csv"), "--n", "8")
    assert res.returncode == 1 and "--n: not used with --sizes" in res.stderr


# --------------------------------------------------------------------------- every capability, one declaration
#: Capabilities whose command is still hand-written with its own flags (issue 30, not yet converted to
#: registry._cli._generated.options_from).  Converting one removes it here; a new capability cannot join.
NOT_YET_GENERATED: dict = {}


def _click_commands():
    import typer

    from polypack.cli import app

    return typer.main.get_command(app).commands


def _flags(cmd) -> dict:
    out = {}
    for p in cmd.params:
        for o in list(p.opts) + list(getattr(p, "secondary_opts", [])):
            if o.startswith("--"):
                out[o] = p
    return out


def _reference_sections():
    """``{(kind, name): {option: (default text, unit)}}`` parsed from docs/reference.md."""
    from pathlib import Path

    text = (Path(__file__).resolve().parent.parent / "docs" / "reference.md").read_text()
    out, kind, name = {}, None, None
    for line in text.splitlines():
        if line.startswith("## "):
            kind = line[3:].strip()
        elif line.startswith("### "):
            name = line[4:].strip()
            out[(kind, name)] = {}
        elif line.startswith("| `") and name is not None:
            cells = [c.strip() for c in line.strip("|").split(" | ")]
            out[(kind, name)][cells[0].strip("`")] = (cells[3].strip("`"), "" if cells[4] == "–" else cells[4])
    return out


def test_every_capability_is_one_declaration_cli_study_docs():
    """Walk every registered capability: its study table, its docs/reference.md section and (protocols and
    mechanics stages) its command's flags list exactly its dataclass fields, with the same defaults and units."""
    from polypack._cli._generated import command_name, flag
    from polypack._reference import default_text
    from polypack.study import _check_protocol

    cmds = _click_commands()
    ref = _reference_sections()
    sch = pp.study.schema()
    hand = set()
    for kind in registry.KINDS:
        for name, cap in registry.capabilities(kind).items():
            specs = cap.specs()
            # docs/reference.md: exactly the fields, same defaults and units
            assert set(ref[(kind, name)]) == set(specs), (kind, name)
            for k, s in specs.items():
                assert ref[(kind, name)][k] == (default_text(s), s.unit), (kind, name, k)
            # the study: exactly the fields (with study=True), defaults filled as declared
            study_keys = {k for k, s in specs.items() if s.study}
            if kind == "psd":
                assert study_keys <= set(sch["psd"]), name
                continue
            if kind == "protocol":
                resolved = _check_protocol({"kind": name, **{k: s.default for k, s in specs.items() if s.required}})
                resolved.pop("kind")
                for k in study_keys:  # every field is accepted; an unknown key is not
                    assert k in sch["protocol"], (name, k)
                with pytest.raises(InvalidInputError, match="unknown key"):
                    _check_protocol({"kind": name, "no_such_option": 1})
            else:
                assert set(sch[f"analysis.{name}"]) == study_keys, name
                if any(s.required for s in specs.values()):
                    resolved = None
                else:
                    resolved = cap.resolve({})
            if resolved is not None:
                want = {k: s.default for k, s in specs.items()
                        if s.study and s.default is not None and s.fill and not s.required}
                assert resolved == want, (kind, name)
            # the CLI: the command's flags are the fields (kebab case), help with unit and default
            if kind == "analysis":  # `polypack analyze --run NAME:key=value` resolves the same table
                continue
            if (kind, name) in NOT_YET_GENERATED:
                hand.add((kind, name))
                assert NOT_YET_GENERATED[(kind, name)] in cmds
                continue
            cmd = cmds[command_name(cap)]
            flags = _flags(cmd)
            for k, s in specs.items():
                if not s.cli:
                    continue
                assert flag(k) in flags, (kind, name, k)
                p = flags[flag(k)]
                if s.default is None or s.required:
                    assert p.default is None and ("unset" in p.help or "required" in p.help), (name, k)
                else:  # the flag's default (typer shows it) is the declared one
                    shown = p.default if isinstance(s.default, str) or not isinstance(p.default, str) \
                        else __import__("tomllib").loads(f"x = {p.default}")["x"]
                    assert shown == s.default, (name, k, p.default, s.default)
                if s.unit:
                    assert f"[{s.unit}]" in p.help.replace("\\[", "["), (name, k)
            field_flags = {flag(k) for k, s in specs.items() if s.cli}
            own = set(flags) - field_flags
            assert not {f for f in own if f.lstrip("-").replace("-", "_") in specs}, (kind, name)
    assert hand == set(NOT_YET_GENERATED)


def test_reference_page_is_current():
    from pathlib import Path

    from polypack._reference import reference_markdown

    page = (Path(__file__).resolve().parent.parent / "docs" / "reference.md").read_text()
    assert page == reference_markdown(), "docs/reference.md is stale: run `PYTHONPATH=src python tools/gen_reference.py`"


def test_units_are_one_per_quantity():
    """A quantity named alike in two capabilities has the same unit (surface potential in V everywhere)."""
    units = {}
    for kind in registry.KINDS:
        for cap in registry.capabilities(kind).values():
            for k, s in cap.specs().items():
                units.setdefault(k, {}).setdefault(s.unit, []).append(f"{kind}.{cap.name}")
    mixed = {k: u for k, u in units.items() if len(u) > 1}
    assert not mixed, mixed
    assert registry.get("protocol", "brownian").specs()["surface_potential"].unit == "V"


def test_analyze_runs_the_registered_stages_with_the_study_units_and_defaults(tmp_path):
    """`polypack analyze` and `polypack run` share the declarations: same keys, units (r_max, dr in the
    pack's length unit) and defaults, and the same numbers as the registered run function."""
    from polypack.cli import main

    rng = np.random.default_rng(3)
    pts = []
    while len(pts) < 80:  # a dilute random pack of spheres of radius 0.5 in a box of 10
        x = rng.random(3) * 10.0
        if all(np.linalg.norm((x - y + 5.0) % 10.0 - 5.0) > 1.0 for y in pts):
            pts.append(x)
    pk = pp.Packing(np.array(pts), np.full(len(pts), 0.5), 10.0)
    pp.io.write(tmp_path / "p.gsd", pk)
    main(["analyze", str(tmp_path / "p.gsd"), "--rdf", "--contacts", "--json", str(tmp_path / "a.json")])
    d = json.loads((tmp_path / "a.json").read_text())
    rdf = registry.get("analysis", "rdf")
    opts = rdf.resolve({})
    assert d["rdf"]["r_max"] == opts["r_max"] == 3.0 and d["rdf"]["dr"] == opts["dr"] == 0.02
    direct = rdf.load()(pk, opts, None).to_dict()
    assert np.array_equal(np.asarray(d["rdf"]["g"], dtype=float), np.asarray(direct["g"], dtype=float))
    assert d["contacts"]["tolerance"] == registry.get("analysis", "contacts").resolve({})["tolerance"]
    main(["analyze", str(tmp_path / "p.gsd"), "--rdf", "--r-max", "2.5", "--dr", "0.05", "--json",
          str(tmp_path / "b.json")])
    d = json.loads((tmp_path / "b.json").read_text())
    assert d["rdf"]["r_max"] == 2.5 and d["rdf"]["dr"] == 0.05  # length units, as in [analysis.rdf]
    with pytest.raises(SystemExit):  # an option of an analysis that is not selected is an error, not ignored
        main(["analyze", str(tmp_path / "p.gsd"), "--contacts", "--r-max", "2.0"])


def test_api_and_study_share_the_checks_of_the_options_dataclass():
    """pp.brownian and pp.vem check their keywords through the dataclass the study uses: the same values
    are refused (same reason) and the same edge values accepted (hamaker = 0, rolling_moment = inf)."""
    from polypack.study import validate

    base = {"study": {"seed": 1}, "psd": {"model": "monodisperse", "n": 40}, "output": {"plots": False}}
    for kw, reason in (({"hamaker": -1.0}, "must be >= 0"), ({"rolling_moment": float("nan")}, "must be finite"),
                       ({"bond_width": 0.0}, "must be > 0")):
        key, value = next(iter(kw.items()))
        with pytest.raises(InvalidInputError, match=f"^{key}=.*: {reason}"):
            pp.brownian(40, bonds="tangential", **kw)
        with pytest.raises(InvalidInputError, match=f"^protocol.{key} = .*: {reason}"):
            validate({**base, "protocol": {"kind": "brownian", "bonds": "tangential", **kw}})
    ok = validate({**base, "protocol": {"kind": "brownian", "bonds": "tangential", "rolling_moment": float("inf"),
                                        "hamaker": 0.0}})
    assert ok["protocol"]["rolling_moment"] == float("inf") and ok["protocol"]["hamaker"] == 0.0
    with pytest.raises(InvalidInputError, match=r"^growth_factor=1.0: must be in \(1, 1.5\]"):
        pp.vem(64, growth_factor=1.0)
    with pytest.raises(InvalidInputError, match=r"^protocol.growth_factor = 1.0: must be in \(1, 1.5\]"):
        validate({**base, "protocol": {"kind": "vem", "growth_factor": 1.0}})
    # the defaults of the public functions are the declared ones
    import inspect

    for func, cap in ((pp.vem, "vem"), (pp.brownian, "brownian")):
        specs = registry.get("protocol", cap).specs()
        for k, p in inspect.signature(func).parameters.items():
            if k in specs and p.default is not inspect.Parameter.empty:
                assert p.default == specs[k].default, (cap, k)


def test_mechanics_commands_take_the_stage_fields_and_match_the_stage(tmp_path, capsys):
    """`polypack shear` and `polypack moduli` read their flags from [analysis.shear] / [analysis.moduli]
    (issue 30): the command gives the registered stage's numbers for the same table, the old spellings
    (--direction N,S, --kn) still work hidden, and two spellings at once are refused."""
    from polypack.cli import main

    pk = pp.pack(np.full(40, 0.25e-6), volume_fraction=0.62, seed=3)
    src = tmp_path / "p.gsd"
    pp.io.write(src, pk)
    proto = ["--epsilon", "0.02", "--cycles", "2", "--steps-per-cycle", "100", "--samples-per-cycle", "10",
             "--no-progress"]
    main(["shear", str(src), *proto, "--directions", "[[2, 0]]", "--normal-stiffness", "50",
          "--json", str(tmp_path / "a.json")])
    main(["shear", str(src), *proto, "--direction", "2,0", "--kn", "50", "--bonds", "distance",
          "--json", str(tmp_path / "b.json")])
    a, b = (json.loads((tmp_path / f"{x}.json").read_text()) for x in "ab")
    cap = registry.get("mechanics", "shear")
    table = {"epsilon": 0.02, "cycles": 2, "steps_per_cycle": 100, "samples_per_cycle": 10, "directions": [[2, 0]],
             "normal_stiffness": 50.0}
    stage = cap.load()(pk, cap.resolve(table), np.random.SeedSequence(0))
    assert a["storage_modulus"] == stage["storage_modulus"] == b["storage_modulus"]
    assert [r["voigt"] for r in a["per_direction"]] == ["C55"]
    for args, msg in ((["--direction", "2,0", "--directions", "[[1, 0]]"], "--direction: give --directions only"),
                      (["--directions", "[[2, 2]]"], "--directions [[2, 2]]: pair [2, 2]: give [plate-normal axis"),
                      (["--direction", "2,x"], "--direction '2,x': give 'NORMAL,SHEAR' axes")):
        with pytest.raises(SystemExit):
            main(["shear", str(src), *args])
        err = capsys.readouterr().err.strip()
        assert msg in err and "\n" not in err, err
    # moduli: --mefm is a flag like the study key; the inclusions flag repeats once per species
    main(["moduli", str(src), "--matrix", "3e9,0.4", "--inclusions", "70e9,0.2", "--no-mefm", "--no-three-point",
          "--json", str(tmp_path / "m.json")])
    m = json.loads((tmp_path / "m.json").read_text())
    assert "mefm" not in m and "mori_tanaka" in m
    want = registry.get("mechanics", "moduli").load()(
        pk, registry.get("mechanics", "moduli").resolve({"matrix": [3e9, 0.4], "inclusions": [70e9, 0.2],
                                                         "mefm": False, "three_point": False}), None)
    assert m["mori_tanaka"]["young"]["mean"] == pytest.approx(want["mori_tanaka"]["young"], rel=1e-12)


def test_declared_shear_defaults_are_the_functions_defaults():
    """[analysis.shear] declares the defaults of oscillatory_shear and BondNetwork (fill=False: not written
    into a resolved study); they are the functions' own, so the CLI, the docs and the API agree."""
    import inspect

    from polypack.mechanics import BondNetwork, oscillatory_shear

    specs = registry.get("mechanics", "shear").specs()
    checked = 0
    for func in (oscillatory_shear, BondNetwork.from_packing):
        for k, p in inspect.signature(func).parameters.items():
            if k in specs and k != "shear_stiffness":  # unset: k_n / 10 (the stage's rule; the function's 10.0)
                assert p.default == specs[k].default, (func.__name__, k, p.default, specs[k].default)
                checked += 1
    assert checked >= 20
    assert not specs["frequency"].fill and "frequency" not in registry.get("mechanics", "shear").resolve({})


def test_every_optional_field_declares_its_unset_rule():
    """An option whose default is None says what the run does without it (``option(..., unset=...)``): the
    reference page shows `unset: RULE` as its default and the CLI help `unset: RULE`, so no runtime default
    lives only in the code or in free text."""
    from polypack._cli._generated import _help
    from polypack._reference import default_text
    from polypack.psd._capabilities import Generation

    groups = [("psd", "[psd]", registry.option_specs(Generation))]
    groups += [(kind, name, cap.specs()) for kind in registry.KINDS for name, cap in registry.capabilities(kind).items()]
    missing, n = [], 0
    for kind, name, specs in groups:
        for k, s in specs.items():
            if s.default is None and not s.required:
                n += 1
                if not s.unset.strip():
                    missing.append(f"{kind}.{name}.{k}")
                else:
                    assert default_text(s) == f"unset: {s.unset}" and f"unset: {s.unset}" in _help(s).replace("\\[", "[")
    assert not missing, f"optional fields without an unset rule: {missing}"
    assert n >= 80
    page = (__import__("pathlib").Path(__file__).resolve().parent.parent / "docs" / "reference.md").read_text()
    assert "| `unset: k_n / 10 (seed 003 Table 1)` | N/m |" in page
    assert "the run's own default" not in page


# --------------------------------------------------------------------------- docs/registry.md tells the truth
REGISTRY_DOC = __import__("pathlib").Path(__file__).resolve().parent.parent / "docs" / "registry.md"


def _doc_table(text, header):
    """Rows (lists of cells) of the markdown table that starts with ``header``."""
    lines = text[text.index(header):].splitlines()[2:]
    rows = []
    for line in lines:
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in line.strip().strip("|").split("|")])
    return rows


def test_registry_doc_tells_the_truth():
    """The kinds table and the 'where declarations live' table of docs/registry.md list exactly the
    built-in capabilities and the modules that declare them."""
    import re

    text = REGISTRY_DOC.read_text()
    builtin = {(kind, name): cap.origin for kind in registry.KINDS
               for name, cap in registry.capabilities(kind).items() if cap.origin.startswith("polypack.")}
    listed = {}
    for kind, names, where in _doc_table(text, "| kind | names | declared in |"):
        for name in re.findall(r"`(\w+)`", names.split(" (")[0] if "(" in names else names):
            listed[(kind.strip("`"), name)] = "polypack." + where.strip("`").replace("/", ".").removesuffix(".py")
    assert listed == builtin
    declared = {}
    for sub, path, what in _doc_table(text, "| subpackage | file | declares |"):
        mod = "polypack." + path.strip("`").removeprefix("src/polypack/").replace("/", ".").removesuffix(".py")
        declared[mod] = set(re.findall(r"`(\w+)`", what)) - {"mechanics", "analysis", "psd"}
    for (kind, name), origin in builtin.items():
        if kind != "psd":
            assert name in declared[origin], (kind, name, origin)
    assert declared.keys() == set(builtin.values())


def test_registry_doc_worked_example(tmp_path):
    """The worked example of docs/registry.md runs as it stands (its asserts are the checks), and the
    command its text promises exists and prints the declared words."""
    import typer
    from typer.testing import CliRunner

    from polypack._cli._generated import register_generated

    text = REGISTRY_DOC.read_text()
    block = text[text.index("<!-- worked example: executed by tests/test_declarations.py -->"):]
    start = block.index("```python\n") + len("```python\n")
    code = block[start:block.index("\n```\n", start)]
    assert "register(" in code and code.count("assert ") >= 5
    ns = {"__name__": "registry_doc_example"}
    try:
        exec(compile(code, str(REGISTRY_DOC), "exec"), ns)
        assert registry.get("mechanics", "near_pairs").kind == "mechanics"
        app = typer.Typer()

        @app.callback()
        def _root():
            """polypack (test app)."""

        register_generated(app)
        site = np.stack(np.meshgrid(*[np.arange(3.0)] * 3, indexing="ij"), -1).reshape(-1, 3) + 0.5
        pp.io.write(tmp_path / "p.gsd", pp.Packing(site, np.full(27, 0.5), 3.0))
        res = CliRunner().invoke(app, ["near-pairs", str(tmp_path / "p.gsd"), "--epsilon", "0.05"])
        assert res.exit_code == 0, res.output
        assert "near_pairs.pairs = 81  (near-contact pairs)" in res.output
        assert "near_pairs.springs_per_particle = 330" in res.output
    finally:
        registry.unregister("mechanics", "near_pairs")


def test_dlvo_takes_the_dlvo_keys_of_brownian(capsys):
    """`polypack dlvo` reads --hamaker, --debye-length, ... from BrownianOptions (issue 30: one unit and one
    declared default per quantity): the flags are those fields, and a value reaches the potential."""
    from polypack._cli.brownian_commands import DLVO_FIELDS
    from polypack.cli import main
    from polypack.generate.dlvo import dlvo_extrema

    flags = _flags(_click_commands()["dlvo"])
    specs = registry.get("protocol", "brownian").specs()
    for k in DLVO_FIELDS:
        p = flags["--" + k.replace("_", "-")]
        assert p.default == specs[k].default and (not specs[k].unit or f"[{specs[k].unit}]" in p.help)
    main(["dlvo", "--surface-potential", "0.015", "--hamaker", "5e-20", "--debye-length", "3e-9"])
    out = capsys.readouterr().out
    e = dlvo_extrema(0.015, hamaker=5e-20, debye_length=3e-9)
    row = [ln for ln in out.splitlines() if ln.strip().startswith("15.0")][0]
    assert f"{e.primary_energy:11.1f}".strip() in row and "A = 5e-20 J" in out and "1/κ = 3.000 nm" in out
    with pytest.raises(SystemExit):
        main(["dlvo", "--hamaker", "-1"])
    assert "--hamaker -1.0: must be >= 0 (protocol.hamaker in a study file)" in capsys.readouterr().err
