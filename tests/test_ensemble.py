"""Ensemble runner: serial == process pool (== Dask) bitwise, resume, study changes, aggregation."""

import concurrent.futures as cf
import csv
import json

import numpy as np
import pytest

import polypack as pp
from polypack.errors import InvalidInputError, PolypackError


def tiny(seed=11, realizations=3, **protocol):
    pr = {"kind": "crm", "volume_fraction": 0.45}
    pr.update(protocol)
    return {
        "study": {"name": "tiny", "seed": seed, "realizations": realizations},
        "psd": {"model": "bimodal", "size_ratio": 0.5, "volume_ratio": 0.5, "n": 120},
        "protocol": pr,
        "analysis": {
            "rdf": {"r_max": 0.9, "dr": 0.05},
            "windows": {"window_radius": 2.0},
            "contacts": {"tolerance": 0.02},
            "pores": {"n_points": 500},
        },
        "output": {"plots": False},
    }


def positions(out, i):
    return pp.io.read(out / "realizations" / f"r{i:04d}.gsd").positions


def results(out, p):
    """Everything of a run that must not depend on where or when it ran."""
    recs = []
    for i in range(p):
        rec = json.loads((out / "realizations" / f"r{i:04d}.json").read_text())
        recs.append((rec["seed"], rec["volume_fraction"], rec["analysis"], rec["protocol"]["collisions"]))
    return [positions(out, i) for i in range(p)], recs


def assert_same(a, b):
    pa, ra = a
    pb, rb = b
    for x, y in zip(pa, pb):
        assert np.array_equal(x, y)  # bitwise
    assert ra == rb


@pytest.fixture(scope="module")
def serial_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    res = pp.ensemble.run_study(tiny(), out)
    return out, res


def test_serial_run_writes_everything(serial_run):
    out, res = serial_run
    assert res.computed == [0, 1, 2] and res.skipped == []
    for i in range(3):
        assert (out / "realizations" / f"r{i:04d}.gsd").is_file()
    assert (out / "study.resolved.toml").is_file() and (out / "study.resolved.json").is_file()
    # seeds are SeedSequence(seed).spawn(P)
    kids = np.random.SeedSequence(11).spawn(3)
    for rec, kid in zip(res.records, kids):
        assert rec["seed"]["entropy"] == 11 and tuple(rec["seed"]["spawn_key"]) == kid.spawn_key
        assert rec["volume_fraction"] == pytest.approx(0.45, rel=1e-9)
        assert rec["n"] == 120
    # different realizations are different packs
    assert not np.array_equal(positions(out, 0), positions(out, 1))
    rows = list(csv.DictReader(open(out / "summary.csv")))
    assert [int(r["index"]) for r in rows] == [0, 1, 2]
    assert {"volume_fraction", "protocol.collisions", "contacts.coordination", "windows.mean", "sha256"} <= set(rows[0])


def test_ensemble_curves_are_mean_and_95_band(serial_run):
    out, res = serial_run
    doc = json.loads((out / "ensemble" / "curves.json").read_text())
    g = np.array([r["analysis"]["rdf"]["g"] for r in res.records], dtype=float)
    c = doc["analyses"]["rdf"]["curves"]["g"]
    mean = np.array(c["mean"], dtype=float)
    se = g.std(axis=0, ddof=1) / np.sqrt(3)
    np.testing.assert_allclose(mean, g.mean(axis=0), rtol=1e-12, atol=1e-12)
    # 95 % band of a mean of P = 3: Student t with 2 degrees of freedom, t(0.975, 2) = 4.3027
    # (statistical tables); 1.96 would cover only ~81 %
    np.testing.assert_allclose(np.array(c["hi"], dtype=float) - mean, 4.302653 * se, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(mean - np.array(c["lo"], dtype=float), 4.302653 * se, rtol=1e-6, atol=1e-12)
    assert doc["ci_level"] == 0.95 and doc["ci_factor"] == pytest.approx(4.302653, rel=1e-6)
    assert "partial.0-1" in doc["analyses"]["rdf"]["curves"]
    # window histograms: probabilities pooled over realizations still sum to one
    p = np.array(doc["analyses"]["windows"]["curves"]["p"]["mean"], dtype=float)
    assert p.sum() == pytest.approx(1.0, abs=1e-9)
    # pore-size grids follow each pack's largest pore: curves are interpolated onto the widest grid
    pe = doc["analyses"]["pores"]
    xs = [np.array(r["analysis"]["pores"]["r"], dtype=float) for r in res.records]
    assert pe["regridded"] == (not all(np.array_equal(xs[0], x) for x in xs))
    x = np.array(pe["x"], dtype=float)
    assert x[-1] == pytest.approx(max(xi[-1] for xi in xs), rel=1e-12)
    surv = [np.interp(x, xi, np.array(r["analysis"]["pores"]["survival"], dtype=float))
            for xi, r in zip(xs, res.records)]
    np.testing.assert_allclose(np.array(pe["curves"]["survival"]["mean"], dtype=float), np.mean(surv, axis=0),
                               rtol=1e-12, atol=1e-15)
    sc = json.loads((out / "ensemble" / "scalars.json").read_text())
    cn = [r["scalars"]["contacts.coordination"] for r in res.records]
    assert sc["contacts.coordination"]["mean"] == pytest.approx(np.mean(cn), rel=1e-12)


def test_two_processes_give_identical_results(serial_run, tmp_path):
    out, _ = serial_run
    res = pp.ensemble.run_study(tiny(), tmp_path, workers=2)
    assert res.computed == [0, 1, 2]
    assert_same(results(out, 3), results(tmp_path, 3))


def test_any_executor_gives_identical_results(serial_run, tmp_path):
    out, _ = serial_run
    with cf.ThreadPoolExecutor(max_workers=2) as ex:
        pp.ensemble.run_study(tiny(), tmp_path, executor=ex)
    assert_same(results(out, 3), results(tmp_path, 3))


def test_dask_local_gives_identical_results(serial_run, tmp_path):
    import dask.distributed  # noqa: F401  (in the test extra: a missing install fails, never skips)
    out, _ = serial_run
    with pp.ensemble.dask_executor(n_workers=2) as ex:
        pp.ensemble.run_study(tiny(), tmp_path, executor=ex)
    assert_same(results(out, 3), results(tmp_path, 3))


def test_resume_recomputes_only_broken_realizations(serial_run, tmp_path):
    import shutil

    out, _ = serial_run
    shutil.copytree(out, tmp_path / "r", dirs_exist_ok=True)
    r = tmp_path / "r"
    (r / "realizations" / "r0001.gsd").unlink()  # lost
    gsd2 = r / "realizations" / "r0002.gsd"
    data = bytearray(gsd2.read_bytes())
    data[-10] ^= 0xFF  # corrupted: checksum no longer matches
    gsd2.write_bytes(bytes(data))
    res = pp.ensemble.run_study(tiny(), r)
    assert res.computed == [1, 2] and res.skipped == [0]
    assert_same(results(out, 3), results(r, 3))
    res = pp.ensemble.run_study(tiny(), r)
    assert res.computed == [] and res.skipped == [0, 1, 2]


def test_interrupted_run_resumes_to_the_same_results(serial_run, tmp_path, monkeypatch):
    from polypack.ensemble import runner

    out, _ = serial_run
    real = runner.run_realization

    def dies_at_2(data, i, seed):
        if i == 2:
            raise KeyboardInterrupt
        return real(data, i, seed)

    monkeypatch.setattr(runner, "run_realization", dies_at_2)
    with pytest.raises(KeyboardInterrupt):
        pp.ensemble.run_study(tiny(), tmp_path)
    assert (tmp_path / "realizations" / "r0001.json").is_file()
    assert not (tmp_path / "realizations" / "r0002.json").exists()
    monkeypatch.setattr(runner, "run_realization", real)
    res = pp.ensemble.run_study(tiny(), tmp_path)
    assert res.computed == [2] and res.skipped == [0, 1]
    assert_same(results(out, 3), results(tmp_path, 3))


def test_changed_study_needs_force_and_more_realizations_extend(serial_run, tmp_path):
    import shutil

    out, _ = serial_run
    shutil.copytree(out, tmp_path / "r", dirs_exist_ok=True)
    r = tmp_path / "r"
    # more realizations: spawn children do not depend on P, finished ones are reused
    res = pp.ensemble.run_study(tiny(realizations=4), r)
    assert res.computed == [3] and res.skipped == [0, 1, 2]
    with pytest.raises(InvalidInputError, match="different study"):
        pp.ensemble.run_study(tiny(seed=12, realizations=2), r)
    res = pp.ensemble.run_study(tiny(seed=12, realizations=2), r, force=True)
    assert res.computed == [0, 1]
    assert not np.array_equal(positions(r, 0), positions(out, 0))


def test_r_max_beyond_half_the_box_fails_before_anything_runs(tmp_path):
    bad = tiny(realizations=2)
    bad["analysis"]["rdf"]["r_max"] = 50.0
    with pytest.raises(InvalidInputError, match=r"^analysis.rdf.r_max = 50.0: exceeds half the box length"):
        pp.ensemble.run_study(bad, tmp_path / "o")
    assert not (tmp_path / "o").exists()


def test_failing_realizations_are_reported_and_others_kept(tmp_path, monkeypatch):
    from polypack.ensemble import runner

    real = runner.run_realization

    def fails_at_1(data, i, seed):
        if i == 1:
            raise pp.InfeasibleError("boom")
        return real(data, i, seed)

    monkeypatch.setattr(runner, "run_realization", fails_at_1)
    with pytest.raises(PolypackError, match="1 of 3 realization.*realization 1: boom"):
        pp.ensemble.run_study(tiny(), tmp_path)
    assert (tmp_path / "realizations" / "r0002.json").is_file()
    assert not (tmp_path / "realizations" / "r0001.json").exists()


def test_cli_run_and_resume(tmp_path, capsys):
    from polypack.cli import main

    f = tmp_path / "s.toml"
    f.write_text(
        '[study]\nname = "cli"\nseed = 2\nrealizations = 2\n[psd]\nsize_ratio = 0.5\nvolume_ratio = 0.5\nn = 100\n'
        '[protocol]\nkind = "crm"\nvolume_fraction = 0.4\n[analysis.rdf]\nr_max = 0.8\ndr = 0.1\n'
    )
    main(["run", str(f), "--out", str(tmp_path / "o")])
    text = capsys.readouterr().out
    assert "2 computed, 0 reused" in text and str(tmp_path / "o") in text and "summary.csv" in text
    assert (tmp_path / "o" / "ensemble" / "rdf.png").stat().st_size > 1000
    assert (tmp_path / "o" / "ensemble" / "grading.png").stat().st_size > 1000
    main(["run", str(f), "--out", str(tmp_path / "o")])
    assert "0 computed, 2 reused" in capsys.readouterr().out


def test_scrm_study_serial_equals_two_processes(tmp_path):
    study = tiny(realizations=2, kind="scrm", volume_fraction=0.5, global_shakes=3, growth_steps=3)
    a = pp.ensemble.run_study(study, tmp_path / "a")
    pp.ensemble.run_study(study, tmp_path / "b", workers=2)
    assert_same(results(tmp_path / "a", 2), results(tmp_path / "b", 2))
    rec = a.records[0]
    assert rec["protocol"]["scrm.global_shakes"] == 3 and rec["protocol"]["scrm.stages"] == 3
    assert 0 < rec["protocol"]["shake.acceptance_rate.1"] <= 1
    assert rec["volume_fraction"] == pytest.approx(0.5, rel=1e-9)
    pk = pp.io.read(tmp_path / "a" / "realizations" / "r0000.gsd")
    assert pk.min_gap() >= 0


def test_crm_with_global_shakes(tmp_path):
    study = tiny(realizations=1, global_shakes=2)
    res = pp.ensemble.run_study(study, tmp_path)
    assert res.records[0]["protocol"]["shake.global_shakes"] == 2


def test_extra_formats_and_formats_added_on_resume(serial_run, tmp_path):
    import shutil

    out, _ = serial_run
    shutil.copytree(out, tmp_path / "r", dirs_exist_ok=True)
    r = tmp_path / "r"
    study = tiny()
    study["output"]["formats"] = ["xyz"]
    res = pp.ensemble.run_study(study, r)  # output settings do not invalidate realizations
    assert res.computed == []
    for i in range(3):
        pk = pp.io.read(r / "realizations" / f"r{i:04d}.xyz")
        np.testing.assert_allclose(pk.positions, positions(out, i), rtol=0, atol=1e-9)


def test_packs_do_not_depend_on_the_wall_clock(monkeypatch):
    """The packer sizes its chunks from the measured collision rate; a realization must not care."""
    from polypack.ensemble.stages import make_packing, make_sizes
    from polypack.generate import lubachevsky as lub
    from polypack.study import validate


    class FakeClock:
        def __init__(self, step):
            self.t, self.step = 0.0, step

        def perf_counter(self):
            self.t += self.step
            return self.t

    d = validate({"psd": {"n": 300}, "protocol": {"kind": "crm", "volume_fraction": 0.6}})
    sizes = make_sizes(d["psd"], np.random.SeedSequence(1))
    got = []
    for step in (1e-7, 1000.0):  # a fast and a very slow machine: large vs tiny chunks
        monkeypatch.setattr(lub, "time", FakeClock(step))
        got.append(make_packing(sizes, d["protocol"], np.random.SeedSequence(4)).positions)
    monkeypatch.undo()
    assert np.array_equal(got[0], got[1])


def test_killed_process_resumes_to_the_same_results(serial_run, tmp_path):
    """SIGKILL the whole `polypack run` process group mid-run, rerun: same packs as uninterrupted."""
    import os
    import signal
    import subprocess
    import sys
    import time

    from polypack.study import Study

    out, _ = serial_run
    f = tmp_path / "tiny.toml"
    f.write_text(Study.from_dict(tiny()).to_toml())
    o = tmp_path / "o"
    proc = subprocess.Popen(
        [sys.executable, "-m", "polypack.cli", "run", str(f), "--out", str(o), "--workers", "2"],
        start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    try:
        t0 = time.time()
        while not (o / "realizations" / "r0000.json").exists() and not (o / "realizations" / "r0001.json").exists():
            assert proc.poll() is None, "run ended before writing a record"
            assert time.time() - t0 < 120
            time.sleep(0.02)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    done = sorted(int(p.stem[1:]) for p in (o / "realizations").glob("r*.json"))
    res = pp.ensemble.run_study(tiny(), o)
    assert res.skipped == done and sorted(res.computed + done) == [0, 1, 2]
    assert not list((o / "realizations").glob(".*.tmp"))
    assert_same(results(out, 3), results(o, 3))


def test_cli_scheduler_address_gives_identical_results(serial_run, tmp_path):
    import dask.distributed as distributed  # in the test extra: fails, never skips
    from polypack.cli import main
    from polypack.study import Study

    out, _ = serial_run
    f = tmp_path / "tiny.toml"
    f.write_text(Study.from_dict(tiny()).to_toml())
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster:
        main(["run", str(f), "--out", str(tmp_path / "o"), "--scheduler", cluster.scheduler_address])
    assert_same(results(out, 3), results(tmp_path / "o", 3))


def test_regenerate_a_realization_from_its_record(serial_run):
    out, res = serial_run
    pk, rec = pp.ensemble.regenerate(out, 1)
    assert np.array_equal(pk.positions, positions(out, 1))
    assert rec["analysis"] == res.records[1]["analysis"]
    with pytest.raises(InvalidInputError, match="index=7"):
        pp.ensemble.regenerate(out, 7)


def test_kernels_compile_in_the_pool_longest_first():
    """Cold start: every kernel module a study needs is compiled once, spread over the workers."""
    from polypack.ensemble import runner
    from polypack.ensemble.stages import study_kernels

    study = tiny()
    study["protocol"] = {"kind": "scrm", "volume_fraction": 0.45, "growth_steps": 2, "global_shakes": 1}

    class Recorder(cf.ThreadPoolExecutor):
        submitted = []

        def submit(self, fn, *args):
            self.submitted.append((fn.__name__, args))
            return super().submit(fn, *args)

    with Recorder(max_workers=2) as ex:
        runner._compile_in_pool(ex, study)
    mods = [a[0] for name, a in Recorder.submitted]
    assert {name for name, _ in Recorder.submitted} == {"compile_module"}
    assert sorted(mods) == sorted(study_kernels(study)) and len(mods) == len(set(mods))
    assert mods[0] == "polypack._kernels.edmd"  # the longest compilation starts first
