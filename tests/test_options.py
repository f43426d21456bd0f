"""Explicit options: pack, shake and scrm take keyword-only arguments (no **options), speed knobs
live in tuning objects, and scrm reaches every growth and shaking option."""

import inspect

import numpy as np
import pytest

import polypack as pp
from polypack.generate import PackTuning, ShakeTuning

# options that scrm does not forward, and why
NOT_IN_SCRM = {
    "pack": {"sizes", "volume_fraction", "seed", "progress", "species",   # scrm's own / from the sizes
             "max_collisions", "max_seconds", "max_events",                # budgets of a single growth
             "jammed_reference_fraction", "tuning",                        # scrm grows to numbers; pack_tuning
             "dim"},                                                       # shaking is 3D only
    "shake": {"packing", "global_shakes", "seed", "progress", "callback", "tuning"},  # scrm's own; shake_tuning
}


@pytest.mark.parametrize("name", ["pack", "shake", "scrm"])
def test_generators_take_explicit_keyword_only_options(name):
    params = inspect.signature(getattr(pp, name)).parameters.values()
    assert not [p for p in params if p.kind is inspect.Parameter.VAR_KEYWORD], f"{name} takes **options"
    positional = [p.name for p in params if p.kind is not inspect.Parameter.KEYWORD_ONLY]
    assert positional == {"pack": ["sizes", "volume_fraction"], "shake": ["packing"],
                          "scrm": ["sizes", "volume_fraction"]}[name]
    with pytest.raises(TypeError):
        getattr(pp, name)(None, no_such_option=1)


def test_scrm_reaches_every_growth_and_shaking_option():
    scrm = set(inspect.signature(pp.scrm).parameters)
    for gen in ("pack", "shake"):
        missing = set(inspect.signature(getattr(pp, gen)).parameters) - NOT_IN_SCRM[gen] - scrm
        assert not missing, f"scrm does not reach {gen} options {sorted(missing)}"
    assert {"pack_tuning", "shake_tuning", "monitor"} <= scrm


def test_tuning_objects_change_speed_not_results():
    pk = pp.pack(np.r_[np.ones(40), np.full(40, 0.6)], 0.45, seed=3, progress=False)
    a = pp.shake(pk, global_shakes=3, seed=1, shake_radius=0.3, tuning=ShakeTuning(neighbours="cells"))
    b = pp.shake(pk, global_shakes=3, seed=1, shake_radius=0.3, tuning=ShakeTuning(neighbours="verlet", skin=0.9))
    np.testing.assert_array_equal(a.positions, b.positions)  # the overlap test is exact either way
    s = pp.scrm(np.ones(60), 0.4, seed=2, growth_steps=2, global_shakes=2, shake_tuning=ShakeTuning(skin=0.8),
                pack_tuning=PackTuning(skin=0.3), max_trials=20, progress=False)
    assert s.min_gap() >= -1e-12 and s.volume_fraction == pytest.approx(0.4, rel=1e-12)
    with pytest.raises(pp.InvalidInputError, match="tuning="):
        pp.pack(np.ones(10), 0.3, tuning={"skin": 0.3})
    with pytest.raises(pp.InvalidInputError, match="tuning="):
        pp.shake(pk, tuning=PackTuning())


def test_cli_defaults_come_from_the_api():
    from polypack._cli._defaults import api_default

    assert api_default(pp.shake, "global_shakes") == 60 and api_default(pp.scrm, "growth_steps") == 10
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-m", "polypack.cli", "scrm", "--help"], capture_output=True, text=True,
                         env={**__import__("os").environ, "COLUMNS": "200"}).stdout
    assert "[default: 60]" in out and "[default: 10]" in out
