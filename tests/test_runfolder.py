"""Run folder ownership and what a resume trusts: one run per folder (advisory lock with
stale-lock detection), realizations keyed by study fingerprint and polypack code, and
realizations stopped by a budget reported, never averaged in."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import polypack as pp
from polypack.ensemble import runner
from polypack.ensemble._lock import LOCK_NAME, FolderBusyError, RunFolderLock


def tiny(seed=11, realizations=3, **protocol):
    pr = {"kind": "crm", "volume_fraction": 0.45}
    pr.update(protocol)
    return {
        "study": {"name": "tiny", "seed": seed, "realizations": realizations},
        "psd": {"model": "bimodal", "size_ratio": 0.5, "volume_ratio": 0.5, "n": 120},
        "protocol": pr,
        "analysis": {"contacts": {"tolerance": 0.02}},
        "output": {"plots": False},
    }


def _holder(folder, seconds=60):
    """A separate process that owns ``folder`` until killed."""
    code = (
        "import sys, time; from polypack.ensemble._lock import RunFolderLock; "
        f"l = RunFolderLock({str(folder)!r}, 'x').acquire(); print('held', flush=True); time.sleep({seconds})"
    )
    env = dict(os.environ)
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True, env=env)
    assert proc.stdout.readline().strip() == "held"
    return proc


def test_second_run_on_a_folder_in_use_refuses_with_the_owner(tmp_path):
    proc = _holder(tmp_path / "o")
    try:
        with pytest.raises(FolderBusyError, match=f"pid {proc.pid} on "):
            pp.ensemble.run_study(tiny(), tmp_path / "o")
        t0 = time.monotonic()
        with pytest.raises(FolderBusyError, match="one run per folder"):
            pp.ensemble.run_study(tiny(), tmp_path / "o", wait=0.6)
        assert time.monotonic() - t0 >= 0.6  # waited before refusing
        assert not (tmp_path / "o" / "realizations").exists()  # nothing computed or written
    finally:
        proc.kill()
        proc.wait()
    # the owner died (SIGKILL): its lock is stale and the next run takes it over
    res = pp.ensemble.run_study(tiny(), tmp_path / "o")
    assert res.computed == [0, 1, 2]
    lock = (tmp_path / "o" / LOCK_NAME).read_text()
    assert lock == ""  # released at the end of the run


def test_stale_lock_file_of_a_dead_process_is_taken_over(tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    pid = int(dead.stdout)
    (tmp_path / "o").mkdir()
    (tmp_path / "o" / LOCK_NAME).write_text(json.dumps({"pid": pid, "host": "somewhere", "started": 0}))
    with RunFolderLock(tmp_path / "o", "fp") as lock:
        assert lock.previous["pid"] == pid
        rec = json.loads((tmp_path / "o" / LOCK_NAME).read_text())
        assert rec["pid"] == os.getpid() and rec["previous"]["pid"] == pid
        with pytest.raises(FolderBusyError):  # a second owner in this process is refused too
            RunFolderLock(tmp_path / "o", "fp").acquire()


def test_two_different_studies_on_one_folder_never_mix(tmp_path):
    from polypack.study import Study

    files = []
    for k, vf in enumerate((0.40, 0.45)):
        f = tmp_path / f"s{k}.toml"
        f.write_text(Study.from_dict(tiny(volume_fraction=vf, realizations=4)).to_toml())
        files.append(f)
    out = tmp_path / "o"
    procs = [subprocess.Popen([sys.executable, "-m", "polypack", "run", str(f), "--out", str(out), "--no-progress"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for f in files]
    results = [p.communicate(timeout=600) + (p.returncode,) for p in procs]
    codes = sorted(r[2] for r in results)
    assert codes[0] == 0 and codes[1] == 1, results  # one ran, the other refused with one line
    err = next(r[1] for r in results if r[2] == 1)
    assert len(err.strip().splitlines()) == 1 and ("in use by" in err or "different study" in err), err
    fp = json.loads((out / "study.resolved.json").read_text())["fingerprint"]
    vf = json.loads((out / "study.resolved.json").read_text())["study"]["protocol"]["volume_fraction"]
    for rec in (out / "realizations").glob("r*.json"):
        r = json.loads(rec.read_text())
        assert r["fingerprint"] == fp
        assert abs(r["volume_fraction"] - vf) < 1e-9


def test_realizations_of_other_polypack_code_are_recomputed(tmp_path, monkeypatch):
    res = pp.ensemble.run_study(tiny(), tmp_path)
    before = [pp.io.read(tmp_path / "realizations" / f"r{i:04d}.gsd").positions for i in range(3)]
    rec = json.loads((tmp_path / "realizations" / "r0000.json").read_text())
    assert rec["code"] == runner.code_record() and rec["code"]["digest"]
    monkeypatch.setattr(runner, "code_record", lambda: {"polypack": "9.9", "digest": "changed"})
    res = pp.ensemble.run_study(tiny(), tmp_path)
    assert res.computed == [0, 1, 2] and res.stale == [0, 1, 2] and res.skipped == []
    assert "other polypack code" in res.summary()
    for i in range(3):  # same code path, so the same packs
        assert np.array_equal(pp.io.read(tmp_path / "realizations" / f"r{i:04d}.gsd").positions, before[i])


def test_budget_stopped_realizations_are_reported_not_averaged(tmp_path, monkeypatch):
    from polypack.ensemble import stages

    real = stages.make_packing

    def budget_on_1(sizes, protocol, seed):
        pk = real(sizes, protocol, seed)
        if seed.spawn_key[:1] == (1,):  # realization 1 ran out of time
            pk.meta = dict(pk.meta, status="time_budget")
        return pk

    monkeypatch.setattr(stages, "make_packing", budget_on_1)
    res = pp.ensemble.run_study(tiny(), tmp_path)
    assert res.incomplete == [(1, "time_budget")]
    assert "left out of the ensemble averages: 1 (time_budget)" in res.summary()
    sc = json.loads((tmp_path / "ensemble" / "scalars.json").read_text())
    assert sc["excluded"] == [{"index": 1, "status": "time_budget"}]
    assert sc["volume_fraction"]["n"] == 2
    recs = [json.loads((tmp_path / "realizations" / f"r{i:04d}.json").read_text()) for i in (0, 2)]
    cn = [r["scalars"]["contacts.coordination"] for r in recs]
    assert sc["contacts.coordination"]["mean"] == pytest.approx(np.mean(cn), rel=1e-12)
    curves = json.loads((tmp_path / "ensemble" / "curves.json").read_text())
    assert curves["n_realizations"] == 2 and curves["excluded"][0]["index"] == 1
    summary = (tmp_path / "summary.csv").read_text()
    assert "time_budget" in summary  # still listed, with its status


# ----------------------------------------------------------------------------- up-front validation
def _write(tmp_path, text, name="s.toml"):
    f = tmp_path / name
    f.write_text(text)
    return f


BASE = '[study]\nname = "v"\n[psd]\nmodel = "bimodal"\nsize_ratio = 0.5\nvolume_ratio = 0.333\nn = 2000\n' \
       '[protocol]\nkind = "crm"\nvolume_fraction = 0.6\n'


@pytest.mark.parametrize("extra,match", [
    ('[analysis.rdf]\nr_max = 3.0\nmethod = "bogus"\n', "analysis.rdf: method='bogus'"),
    ('[analysis.rdf]\nr_max = 3.0\nscale = "bogus"\n', "analysis.rdf: scale='bogus'"),
    ("[analysis.windows]\nwindow_radius = 50\n", "analysis.windows.window_radius = 50"),
])
def test_check_rejects_bad_analysis_options_with_key_path(tmp_path, extra, match, capsys, monkeypatch):
    from polypack.cli import main
    from polypack.ensemble import stages

    monkeypatch.setattr(stages, "make_packing", lambda *a: pytest.fail("packed before validating"))
    f = _write(tmp_path, BASE + extra)
    for args in (["run", str(f), "--check"], ["run", str(f), "--out", str(tmp_path / "o")]):
        with pytest.raises(SystemExit) as info:
            main(args)
        err = capsys.readouterr().err
        assert info.value.code == 1 and match in err and len(err.strip().splitlines()) == 1, err


def test_study_file_sections_realizations_and_fractions_checked_up_front(tmp_path):
    from polypack.study import load_study

    with pytest.raises(pp.InvalidInputError, match="is empty"):
        load_study(_write(tmp_path, ""))
    with pytest.raises(pp.InvalidInputError, match=r"no \[psd\] or \[protocol\] section"):
        load_study(_write(tmp_path, '[study]\nname = "x"\n'))
    with pytest.raises(pp.InvalidInputError, match=r"no \[protocol\] section"):
        load_study(_write(tmp_path, '[psd]\nmodel = "bimodal"\n'))
    t0 = time.monotonic()
    with pytest.raises(pp.InvalidInputError, match="study.realizations = 100000000000: at most"):
        load_study(_write(tmp_path, BASE.replace('name = "v"', "realizations = 100000000000")))
    assert time.monotonic() - t0 < 5
    scrm = BASE.replace('kind = "crm"', 'kind = "scrm"') + "start_fraction = 0.9\n"
    with pytest.raises(pp.InvalidInputError, match=r"protocol.start_fraction = 0.9: must be in \(0, "):
        load_study(_write(tmp_path, scrm))


def test_preflight_refuses_unreachable_fractions_and_oversized_spheres():
    from polypack.ensemble.stages import child_seed_records, preflight
    from polypack.study import validate

    mono = validate({"psd": {"model": "monodisperse", "n": 500}, "protocol": {"kind": "crm", "volume_fraction": 0.9}})
    with pytest.raises(pp.InvalidInputError, match="equal spheres cannot exceed 0.7405"):
        preflight(mono, child_seed_records(1, 1)[0])
    few = validate({"psd": {"model": "bimodal", "size_ratio": 0.2, "volume_ratio": 1.0, "n": 300},
                    "protocol": {"kind": "crm", "volume_fraction": 0.6}})
    with pytest.raises(pp.InvalidInputError, match="half the periodic box"):
        preflight(few, child_seed_records(1, 1)[0])


def test_analyses_warn_or_refuse_on_overlapping_input(tmp_path, capsys):
    from polypack.cli import main
    from polypack.errors import OverlapError, OverlapWarning

    pk = pp.Packing([[1.0, 1.0, 1.0], [1.5, 1.0, 1.0], [4.0, 4.0, 4.0]], [0.5, 0.5, 0.5], [8.0, 8.0, 8.0])
    with pytest.warns(OverlapWarning, match="spheres 0 and 1"):
        pp.analysis.Contacts().compute(pk)
    with pp.analysis.overlap_policy("error"):
        with pytest.raises(OverlapError, match="overlapping spheres"):
            pp.analysis.RDF(r_max=3.0, dr=0.1).compute(pk)
    with pp.analysis.overlap_policy("ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("error")
            pp.analysis.Contacts().compute(pk)
    f = tmp_path / "ov.gsd"
    pp.io.write(f, pk)
    main(["analyze", str(f), "--contacts"])
    assert "warning: " in capsys.readouterr().err
    with pytest.raises(SystemExit) as info:
        main(["analyze", str(f), "--contacts", "--overlaps", "error"])
    assert info.value.code == 1


def test_python_api_errors_are_polypack_errors():
    for args in [([[0.0, 0, 0]], "ab", [1, 1, 1]), ([[0.0, 0, 0]], [1.0], "abc"), ("xx", [1.0], [1, 1, 1])]:
        with pytest.raises(pp.PolypackError, match="must be numbers"):
            pp.Packing(*args)


def test_lock_held_only_by_orphans_of_a_dead_owner_is_stale(tmp_path):
    """A killed run whose forked workers still hold the lock file: the next run takes over."""
    code = (
        "import os, sys, time; from polypack.ensemble._lock import RunFolderLock; "
        f"l = RunFolderLock({str(tmp_path / 'o')!r}, 'x').acquire(); "
        "pid = os.fork()\n"
        "if pid == 0:\n    time.sleep(60)\n"  # the child keeps the flocked file open
        "else:\n    print(pid, flush=True); os._exit(0)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    orphan = int(proc.stdout.readline())
    proc.wait()
    try:
        with RunFolderLock(tmp_path / "o", "fp") as lock:
            assert lock.previous["pid"] == proc.pid
    finally:
        os.kill(orphan, signal.SIGKILL)
