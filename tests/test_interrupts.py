"""One interrupt discipline: a real SIGINT at safe points of every generator, stage and command.

Every interrupted run either stops with an interrupt (and resuming gives the
uninterrupted results bit for bit) or finishes with exactly those results; nothing
interrupted is ever saved as complete.  ``tools/fault_injection.py`` runs the full
sweep (every safe point, plus wall-clock SIGINTs to CLI subprocesses).
"""

import json
import signal
import sys
from pathlib import Path

import numpy as np
import pytest

import polypack as pp
from polypack import _interrupt
from polypack._kernels import edmd
from polypack._kernels import shake as kshake
from polypack.errors import Interrupted

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
import fault_injection as fi  # noqa: E402


def _sigint_on_call(monkeypatch, module, name, k):
    """Deliver a real SIGINT while the k-th call of ``module.name`` runs; returns the call log."""
    real = getattr(module, name)
    calls = []

    def wrapper(*a, **kw):
        calls.append(name)
        out = real(*a, **kw)
        if len(calls) == k:
            signal.raise_signal(signal.SIGINT)
        return out

    monkeypatch.setattr(module, name, wrapper)
    return calls


def test_interrupt_is_a_keyboard_interrupt_not_an_error():
    assert issubclass(Interrupted, KeyboardInterrupt)
    assert not issubclass(Interrupted, Exception)  # ``except Exception`` never swallows it


def test_deferred_section_delays_sigint_to_the_safe_point():
    with pytest.raises(Interrupted, match="at the safe point"):
        with _interrupt.deferred():
            signal.raise_signal(signal.SIGINT)  # only sets the flag
            reached = True
            _interrupt.check("stopped at the safe point")
    assert reached
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    # an unconsumed request is raised as a plain KeyboardInterrupt at the end of the section
    with pytest.raises(KeyboardInterrupt):
        with _interrupt.deferred():
            signal.raise_signal(signal.SIGINT)
    assert not _interrupt.pending()


def test_second_ctrl_c_falls_through():
    with pytest.raises(KeyboardInterrupt):
        with _interrupt.deferred():
            signal.raise_signal(signal.SIGINT)
            signal.raise_signal(signal.SIGINT)  # the previous (default) handler raises at once
            pytest.fail("a second Ctrl-C must not be deferred")


def test_numba_systemerror_during_an_interrupt_is_an_interrupt():
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise SystemError("<numba kernel> returned a result with an exception set")
    except SystemError as exc:
        assert _interrupt.is_interrupt(exc)
    assert not _interrupt.is_interrupt(SystemError("unrelated"))


def test_pack_interrupted_before_growth_has_no_partial_and_no_zero_division(monkeypatch):
    # SIGINT already pending when the first chunk starts: no ZeroDivisionError at the scale
    monkeypatch.setattr(_interrupt, "consume", lambda: True)
    with pytest.raises(Interrupted) as info:
        pp.pack(np.ones(100), 0.5, seed=1)
    assert info.value.partial is None


def test_shake_interrupted_gives_a_valid_partial_pack(monkeypatch):
    pk = pp.pack(np.ones(300), 0.5, seed=2)
    calls = _sigint_on_call(monkeypatch, kshake, "shake_sweeps", 1)
    with pytest.raises(Interrupted) as info:
        pp.shake(pk, global_shakes=100, seed=3)
    assert len(calls) == 1  # stopped right after the kernel call it arrived in
    part = info.value.partial
    assert part.meta["status"] == "interrupted" and part.meta["shake"]["interrupted"]
    assert 0 < part.meta["shake"]["global_shakes_done"] < 100
    assert part.min_gap() >= 0.0
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_scrm_never_carries_on_after_an_interrupted_growth_stage(monkeypatch):
    sizes = np.ones(200)
    ref = pp.scrm(sizes, 0.5, seed=4, growth_steps=3, global_shakes=2)
    calls = _sigint_on_call(monkeypatch, edmd, "run_chunk", 2)
    shakes = _sigint_on_call(monkeypatch, kshake, "shake_sweeps", 10**9)
    with pytest.raises(Interrupted) as info:
        pp.scrm(sizes, 0.5, seed=4, growth_steps=3, global_shakes=2)
    n_chunks, n_shakes = len(calls), len(shakes)
    assert n_chunks == 2  # no growth after the interrupted chunk ...
    assert "scrm interrupted" in str(info.value)
    part = info.value.partial
    assert part is None or part.meta["status"] == "interrupted"
    monkeypatch.undo()
    again = pp.scrm(sizes, 0.5, seed=4, growth_steps=3, global_shakes=2)
    assert np.array_equal(again.positions, ref.positions)  # and a rerun is the reference
    assert n_shakes <= 1  # ... and no shaking after it either (at most the stage's own shake before)


def test_scrm_rejects_unknown_shake_options_before_growing(monkeypatch):
    calls = _sigint_on_call(monkeypatch, edmd, "run_chunk", 10**9)
    with pytest.raises(TypeError, match="bogus"):  # explicit keyword-only options: rejected at the call
        pp.scrm(np.ones(50), 0.5, seed=1, bogus=3)
    with pytest.raises(pp.InvalidInputError, match="method"):
        pp.scrm(np.ones(50), 0.5, seed=1, method="nope")
    assert calls == []


@pytest.mark.parametrize("kind,every", [("crm", 6), ("scrm", 12)])
def test_sigint_at_safe_points_of_a_study_never_saves_a_wrong_result(kind, every, tmp_path):
    """SIGINT while every k-th kernel call or atomic write of a 3-realization study runs
    (growth, shaking, analyses, records, aggregation), then resume: bitwise the reference."""
    res = fi.sweep_safe_points(fi.small_study(kind), every=every, workdir=tmp_path)
    assert res["tried"] >= 8
    assert res["wrong_saved"] == 0 and res["wrong_resume"] == 0, res
    assert res["interrupted"] == res["tried"]  # each point is before the end of the run
    phases = " ".join(res["where"])
    for phase in ("edmd.", "shake.", "analysis.", "write "):
        assert phase in phases, res["where"]


def _one_interrupt_line(err):
    lines = err.strip().splitlines()
    return len(lines) == 1 and lines[0].startswith("interrupted")


def test_cli_pack_interrupted_never_writes_the_requested_name(tmp_path):
    out, ck = tmp_path / "p.gsd", tmp_path / "p.partial.gsd"
    rc, err = fi.run_cli(["pack", "--n", "60000", "-c", "0.62", "--seed", "1", "-o", out, "--checkpoint", ck,
                          "--no-progress"], sigint_after=5.0, clock="cpu")  # well into the packing: warm, N = 20000
    # packed in under 5 CPU s once the packer got faster (issue 33); N = 60000 takes about 3x that
    assert rc == 130, err
    assert not out.exists()
    assert _one_interrupt_line(err) and str(ck) in err
    part = pp.io.read(ck)
    assert part.meta["status"] == "interrupted" and part.volume_fraction < 0.62
    assert part.min_gap() >= 0.0
    rc, err = fi.run_cli(["pack", "--n", "60000", "-c", "0.62", "--seed", "1", "-o", out, "--no-progress"],
                         sigint_after=0.5)
    assert rc == 130 and not out.exists() and _one_interrupt_line(err) and "nothing was saved" in err


def test_cli_sigint_at_several_times_pack_scrm_shake(tmp_path):
    """Wall-clock SIGINTs (growth, shaking, writing): exit 130 with one line and no output,
    or exit 0 with the reference pack."""
    jobs = {
        "pack": ["pack", "--n", "2000", "--size-ratio", "0.5", "--volume-ratio", "0.333", "-c", "0.6", "--seed", "3"],
        "scrm": ["scrm", "--n", "2000", "--size-ratio", "0.5", "--volume-ratio", "0.333", "-c", "0.55",
                 "--growth-steps", "3", "-M", "5", "--seed", "3"],
    }
    tried = 0
    for name, base in jobs.items():
        ref = tmp_path / f"{name}-ref.gsd"
        rc, err = fi.run_cli([*base, "-o", ref, "--no-progress"])
        assert rc == 0, err
        ref_pk = pp.io.read(ref)
        for j, t in enumerate((0.5, 1.0, 1.5)):
            p = tmp_path / f"{name}-{j}.gsd"
            rc, err = fi.run_cli([*base, "-o", p, "--no-progress"], sigint_after=t)
            tried += 1
            if rc == 0:
                assert np.array_equal(pp.io.read(p).positions, ref_pk.positions)
            else:
                assert rc == 130, err
                assert _one_interrupt_line(err), err
                if p.exists():  # the Ctrl-C came after the (atomic) write: the line names it, and it is whole
                    assert f"saved {p}" in err, err
                    assert np.array_equal(pp.io.read(p).positions, ref_pk.positions)
    ref = tmp_path / "pack-ref.gsd"
    rc, err = fi.run_cli(["shake", ref, tmp_path / "sh.gsd", "-M", "100000", "--seed", "1", "--no-progress"],
                         sigint_after=1.0)
    assert rc == 130 and _one_interrupt_line(err), err  # no numba SystemError traceback
    assert not (tmp_path / "sh.gsd").exists()
    assert tried == 6


@pytest.mark.parametrize("where", fi.SIGINT_POINTS)
def test_cli_sigint_at_each_moment_of_the_process_exits_cleanly(where, tmp_path):
    """A real SIGINT sent at a chosen moment (by a ``sitecustomize``): during ``import polypack``
    (numpy) and the CLI's imports, as ``cli.main`` starts, right after the command returned
    (its pack written), in the last atexit callback and while the modules are torn down (after
    Python's own signal handling ended: this was a death by SIGINT, exit status -2, with the
    pack written).  Before the command: 130 and one line, nothing written; after the write:
    130 and one line naming the whole pack; at exit: 0, no traceback, the whole pack."""
    out = tmp_path / "p.gsd"
    rc, err, fired = fi.run_cli_sigint_at(["pack", "--n", "200", "-c", "0.5", "--seed", "1", "-o", out,
                                           "--no-progress"], where, tmp_path)
    assert fired, f"the SIGINT at {where} was never sent"
    if where in ("atexit", "teardown"):
        assert rc == 0 and err.strip() == "", (rc, err)
    else:
        assert rc == 130 and _one_interrupt_line(err), (rc, err)
    if where.startswith(("import:", "call:")):
        assert "nothing was saved" in err and not out.exists()
    else:
        if rc == 130:
            assert f"saved {out} before the interrupt" in err, err
        pk = pp.io.read(out)
        assert pk.n == 200 and pk.min_gap() >= 0.0


def test_cli_sigint_right_after_polypack_took_over_sigint(tmp_path):
    """The earliest SIGINT polypack can answer: the child starts with SIGINT ignored, the first
    statement of ``import polypack`` installs the CLI's handler (visible in /proc), and the
    SIGINT is sent at once, i.e. during the imports of numpy and the CLI."""
    import subprocess
    import time

    if not Path("/proc/self/status").exists():
        pytest.skip("needs Linux /proc")
    out = tmp_path / "p.gsd"
    proc = subprocess.Popen([sys.executable, "-m", "polypack", "pack", "--n", "200", "-c", "0.5", "-o", str(out),
                             "--no-progress"], env=fi.cli_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    deadline = time.monotonic() + 120
    while proc.poll() is None and fi._sigint_ignored(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.001)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 130 and _one_interrupt_line(err) and "nothing was saved" in err, (proc.returncode, err)
    assert not out.exists()


def test_cli_run_interrupted_and_resumed_equals_uninterrupted(tmp_path):
    from polypack.study import Study

    study = fi.small_study("scrm", realizations=3, n=300)
    f = tmp_path / "study.toml"
    f.write_text(Study.from_dict(study).to_toml())
    rc, err = fi.run_cli(["run", f, "--out", tmp_path / "ref", "--no-progress"])
    assert rc == 0, err
    ref, ref_ens = fi.run_results(tmp_path / "ref")
    for j, t in enumerate((1.0, 2.0)):
        out = tmp_path / f"o{j}"
        rc, err = fi.run_cli(["run", f, "--out", out, "--no-progress"], sigint_after=t)
        assert rc in (0, 130), err
        if rc == 130:
            assert _one_interrupt_line(err), err
            saved, _ = fi.run_results(out) if (out / "realizations").is_dir() else ({}, {})
            assert fi.same_records(saved, ref, only=sorted(saved)) == []
            rc, err = fi.run_cli(["run", f, "--out", out, "--no-progress"])
            assert rc == 0, err
        got, _ = fi.run_results(out)
        assert fi.same_records(got, ref) == []


@pytest.mark.parametrize("command", ["info", "convert", "analyze"])
def test_interrupted_commands_exit_130(command, tmp_path, monkeypatch, capsys):
    from polypack.cli import main

    pk = pp.pack(np.ones(60), 0.4, seed=1)
    src = tmp_path / "a.gsd"
    pp.io.write(src, pk)

    def interrupted(*a, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(pp.io, "read_with_info", interrupted)
    # info and convert read through the network-aware reader (a file may hold bonds)
    monkeypatch.setattr("polypack.io.bonds.read_maybe_network", interrupted)
    args = {"info": ["info", src], "convert": ["convert", src, tmp_path / "b.xyz"],
            "analyze": ["analyze", src, "--json", tmp_path / "r.json"]}[command]
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    assert info.value.code == 130
    err = capsys.readouterr().err
    assert _one_interrupt_line(err) and "nothing was saved" in err
    assert not (tmp_path / "b.xyz").exists() and not (tmp_path / "r.json").exists()


def test_cli_sigint_stops_a_command_started_with_sigint_ignored(tmp_path):
    """A shell without job control starts ``cmd &`` with SIGINT ignored (POSIX); the CLI
    restores the default handler, so ``kill -INT`` still stops it at a safe point (exit 130,
    one line).  Without the restoration the pack would run to its end (exit 0)."""
    import subprocess
    import time

    proc = subprocess.Popen([sys.executable, "-m", "polypack", "pack", "--n", "20000", "-c", "0.62", "--seed", "1",
                             "-o", str(tmp_path / "p.gsd"), "--no-progress"], env=fi.cli_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    start = fi.startup_cpu_seconds() + 2.0
    deadline = time.monotonic() + 300
    while proc.poll() is None and time.monotonic() < deadline:
        used = fi._cpu_seconds(proc.pid)
        if used is not None and used >= start:
            proc.send_signal(signal.SIGINT)
            break
        time.sleep(0.02)
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 130, err
    assert _one_interrupt_line(err), err
    assert not (tmp_path / "p.gsd").exists()
