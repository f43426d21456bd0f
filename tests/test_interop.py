"""tools/interop.py with the cheap clients (numpy, gsd, vtk, ASE, freud): every writer opens
exactly in every client that reads its format. OVITO and LAMMPS are optional heavy clients:
run ``python tools/interop.py`` where they are installed."""

import importlib.util
import sys
from pathlib import Path

import pytest

CHEAP = ["numpy", "gsd", "vtk", "ase", "freud"]


def _interop():
    path = Path(__file__).resolve().parents[1] / "tools" / "interop.py"
    spec = importlib.util.spec_from_file_location("polypack_interop", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    mod = _interop()
    return mod, mod.run(CHEAP, tmp_path_factory.mktemp("interop"), n=150)


def test_every_applicable_cell_is_exact(results):
    mod, res = results
    assert all(mod.installed(c) for c in CHEAP)  # all in the test extra: nothing may be skipped
    bad = {k: [c for c in v[1] if c[1] is not True] for k, v in res.items() if v[0] not in ("✔", "·")}
    assert not bad, bad
    # each cell that applies checked positions, radii or the box, and bonds for networks
    for (label, client), (status, checks) in res.items():
        if status == "✔":
            items = {c[0] for c in checks if c[1] is True}
            assert "positions" in items and "box" in items, (label, client)
            if label.startswith("network"):
                assert "bonds" in items, (label, client)


def test_every_writer_has_a_cheap_client(results):
    mod, res = results
    for label, _, _ in mod.WRITERS:
        if label.endswith(".data"):
            continue  # only LAMMPS and OVITO read sphere / bpm/sphere data files (heavy clients)
        assert any(res[(label, c)][0] == "✔" for c in CHEAP), label


def test_a_wrong_file_is_caught(results, tmp_path):
    """The checks can fail: a pack whose positions moved by 1 ulp, or another bond list."""
    import numpy as np

    import polypack as pp

    mod, _ = results
    pk, net, _ = mod.make_inputs(60, 3)
    moved = pk.replace(positions=np.nextafter(pk.positions, np.inf))
    pp.io.write(tmp_path / "p.xyz", moved)
    checks = mod.check(mod.client_ase(tmp_path / "p.xyz", "pack"), pk, net, "pack")
    assert dict((c[0], c[1]) for c in checks)["positions"] is not True
    pp.mechanics.write_network(tmp_path / "n.gsd", net.select(np.arange(1, net.n_bonds)))
    checks = mod.check(mod.client_gsd(tmp_path / "n.gsd", "network"), pk, net, "network")
    assert dict((c[0], c[1]) for c in checks)["bonds"] is False
