"""Fresh machine, README test command (issue 31): without Chromium the browser tests skip outside CI
with one visible line saying how to run them, and fail with CI=true."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).parent

PROBE = '''
from _browser import launch, sync_playwright


def test_needs_a_browser():
    with sync_playwright() as p:
        launch(p).close()
'''


def _run(tmp_path, ci):
    (tmp_path / "test_probe.py").write_text(PROBE)
    env = {k: v for k, v in os.environ.items() if k not in ("CI", "POLYPACK_CHROMIUM", "POLYPACK_SKIP_BROWSER_TESTS")}
    env["PATH"] = str(Path(sys.executable).parent)  # no chromium on it
    env["PYTHONPATH"] = os.pathsep.join([str(HERE), env.get("PYTHONPATH", "")])
    if ci is not None:
        env["CI"] = ci
    conftest = (HERE / "conftest.py").read_text()
    (tmp_path / "conftest.py").write_text(conftest)
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tmp_path)],
                          capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120)


@pytest.mark.skipif(sys.platform == "win32", reason="PATH semantics")
def test_outside_ci_skip_with_one_line(tmp_path):
    r = _run(tmp_path, None)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "1 skipped" in r.stdout
    lines = [ln for ln in r.stdout.splitlines() if ln.startswith("browser tests skipped")]
    assert len(lines) == 1 and "apt-get install chromium" in lines[0]


@pytest.mark.skipif(sys.platform == "win32", reason="PATH semantics")
def test_in_ci_a_missing_browser_fails(tmp_path):
    r = _run(tmp_path, "true")
    assert r.returncode == 1 and "1 failed" in r.stdout
    assert "need it in CI" in r.stdout
