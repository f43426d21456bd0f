"""Cold start (issue 33): what a study's first run compiles, and the kernels' own sort helpers.

``polypack run`` compiles the kernel modules a study declares in its process pool before the
realizations start (``ensemble/runner.py``); a realization that then needs a version of a kernel
the warmups did not compile (numba compiles one per argument type, writability included)
compiles it in every worker at once.  The check runs in a fresh process, where no other test
has compiled anything.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from polypack._kernels import cells, edmd

_PROBE = r"""
import json, sys
import numba.core.dispatcher as D
from polypack.study import load_study
from polypack.ensemble.stages import child_seed_records, compile_kernels, preflight, realize, study_kernels

study = load_study(json.loads(sys.argv[1]))
seed = child_seed_records(study.seed, 1)[0]


def compiled():
    out = {}
    for name, mod in list(sys.modules.items()):
        if name.startswith("polypack._kernels.") and mod is not None:
            for attr, fn in vars(mod).items():
                if isinstance(fn, D.Dispatcher):
                    out[f"{name}.{attr}"] = {str(s) for s in fn.signatures}
    return out


preflight(study.data, seed)
parent = {k: sorted(v) for k, v in compiled().items() if v}  # the main process compiles nothing
compile_kernels(study.data)
before = compiled()
realize(study.data, 0, seed)
after = compiled()
new = {k: sorted(v - before.get(k, set())) for k, v in after.items() if v - before.get(k, set())}
print(json.dumps({"parent": parent, "new": new, "modules": study_kernels(study.data)}))
"""


def _study(protocol):
    return {
        "study": {"name": "cold", "seed": 5, "realizations": 1},
        "psd": {"model": "bimodal", "size_ratio": 0.5, "volume_ratio": 0.5, "n": 120},
        "protocol": protocol,
        # the analyses of the README job (examples/bimodal_propellant.toml)
        "analysis": {"rdf": {"r_max": 0.9, "dr": 0.05}, "windows": {"window_radius": [1.5, 2.0]},
                     "contacts": {"tolerance": 0.02}, "pores": {"n_points": 500}},
        "output": {"plots": False},
    }


@pytest.mark.parametrize("protocol", [
    {"kind": "scrm", "volume_fraction": 0.45, "growth_steps": 2, "global_shakes": 2},  # the README job's protocol
    {"kind": "crm", "volume_fraction": 0.45},
])
def test_a_realization_compiles_nothing_beyond_the_study_kernels(protocol):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).resolve().parents[1] / "src"),
                                                         os.environ.get("PYTHONPATH", "")])}
    res = subprocess.run([sys.executable, "-c", _PROBE, json.dumps(_study(protocol))], capture_output=True,
                         text=True, env=env, timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    got = json.loads(res.stdout.strip().splitlines()[-1])
    # the option checks of the main process (preflight) run no kernel
    assert got["parent"] == {}
    # every kernel version the realization runs was compiled (or loaded) by the warmups
    assert got["new"] == {}, f"compiled during the realization, not by the warmups of {got['modules']}"
    assert "polypack._kernels.edmd" in got["modules"]


def test_stable_argsort_is_numpys_stable_argsort():
    rng = np.random.default_rng(3)
    for n in (0, 1, 2, 3, 7, 64, 1000):
        keys = rng.integers(0, 5, n).astype(np.float64)  # many ties: the order among equal keys counts
        np.testing.assert_array_equal(cells.stable_argsort(keys), np.argsort(keys, kind="stable"))
        keys = rng.random(n)
        np.testing.assert_array_equal(cells.stable_argsort(keys), np.argsort(keys, kind="stable"))


@pytest.mark.parametrize("n", [1, 2, 5, 6, 101, 1000])
def test_median_and_largest_are_numpys(n):
    g = np.random.default_rng(n).random(n)
    g[: n // 3] = g[0]  # ties
    assert edmd._median(g) == np.median(g)
    assert edmd._largest(g) == g.max()


def test_the_option_check_runs_no_kernel_but_judges_every_option():
    """``polypack run``'s preflight judges the shake options on a two-sphere pack without any kernel
    (generate.shake.options_check), with the errors a real shake gives."""
    import polypack as pp
    from polypack.ensemble.stages import child_seed_records, preflight
    from polypack.generate.shake import options_check
    from polypack.study import load_study

    study = _study({"kind": "scrm", "volume_fraction": 0.45, "growth_steps": 2, "global_shakes": 2,
                    "shake_radius": 2.0})
    with pytest.raises(pp.InvalidInputError, match=r"^protocol.shake_radius: shake_radius=2 exceeds the neighbour"):
        preflight(load_study(study).data, child_seed_records(5, 1)[0])
    pk = pp.Packing(np.array([[0.0, 0.0, 0.0], [2.5, 2.5, 2.5]]), np.array([0.5, 0.5]), np.full(3, 5.0))
    with options_check():
        assert pp.shake(pk, global_shakes=3, seed=0, progress=False) is pk  # judged, not shaken
        with pytest.raises(pp.InvalidInputError, match=r"^shake_radius=2 exceeds the neighbour skin 1.5"):
            pp.shake(pk, shake_radius=2.0, progress=False)
    assert pp.shake(pk, global_shakes=1, seed=0, progress=False) is not pk  # outside the block: a real shake
