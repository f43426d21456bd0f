"""CLI: polypack brownian and polypack dlvo."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np


def _cli(*args, cwd=None):
    env = dict(os.environ)
    return subprocess.run([sys.executable, "-m", "polypack.cli", *args], capture_output=True, text=True, env=env,
                          cwd=cwd, timeout=900)


def test_dlvo_command(tmp_path):
    out = _cli("dlvo", "--plot", str(tmp_path / "v.png"))
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    row15 = [ln for ln in lines if ln.strip().startswith("15.0")][0]
    assert "yes" in row15 and "5.650" in row15
    row0 = [ln for ln in lines if ln.strip().startswith("0.0")][0]
    assert " no " in row0
    assert (tmp_path / "v.png").stat().st_size > 1000


def test_brownian_command(tmp_path):
    import polypack as pp

    target = tmp_path / "gel.gsd"
    out = _cli("brownian", str(target), "--n", "150", "--surface-potential", "0", "--max-time", "0.01", "--seed", "3",
               "--no-progress")
    assert out.returncode == 0, out.stderr
    assert "coordination" in out.stdout
    pk = pp.io.read(str(target))
    assert pk.n == 150
    bonds = json.loads((tmp_path / "gel.gsd.bonds.json").read_text())
    i, j = np.array(bonds["i"]), np.array(bonds["j"])
    shift = np.array(bonds["shift"]).reshape(-1, 3)
    h = np.linalg.norm(pk.positions[j] + shift * pk.box - pk.positions[i], axis=1) - 2 * pk.radii[0]
    assert i.size > 0 and h.min() > -1e-12 and h.max() < 5e-9
    bad = _cli("brownian", str(tmp_path / "x.gsd"), "--n", "100", "--model", "gouy")
    assert bad.returncode == 1 and "model" in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
