"""Every option of every study stage reaches the code it configures (issue 37).

The walker takes the registered capabilities from the public registry API
(``polypack.registry.names``/``get``, ``Capability.specs``/``resolve``/``load``) for every
kind but ``psd`` (whose run function *is* the model class, options = its keywords), and for
each option of each stage:

1. resolves a base table and the same table with that option set to another valid value
   (a choice other than the default, a flipped boolean, a scaled number, an explicit value
   for an option that is unset by default);
2. calls the stage's run function on both, with the library entry points it delegates to
   (``pp.vem``, ``BondNetwork.from_packing``, ``oscillatory_shear``, the estimator classes,
   ...) replaced by recorders that return stubs or stop the stage (nothing heavy runs);
3. asserts that the recorded calls differ, and that the option's value arrives under its own
   keyword (or as a positional argument) unless the table ``TRANSFORMED`` says how the stage
   converts it.

An option that is declared, validated and then dropped (an ``[analysis.shear]`` key missing
from the keys passed to the DEM, a protocol key missing from its key tuple, a strength that
never reaches the network builder) fails step 3.  A new stage fails until its entry points
are named in ``SINKS``.
"""

from __future__ import annotations

import importlib
import types

import numpy as np
import pytest

import polypack as pp
from polypack import registry

SKIP_KINDS = ("psd",)


class _Stop(Exception):
    """Raised by a terminal recorder: the stage has handed its options over."""


# capability name -> [(module path, attribute path, terminal)]: the entry points its run function calls
SINKS = {
    "crm": [("polypack.generate.lubachevsky", "pack", False), ("polypack.generate.shake", "shake", True)],
    "scrm": [("polypack.generate.shake", "scrm", True)],
    "vem": [("polypack.generate.vem", "vem", True)],
    "brownian": [("polypack.generate.brownian", "brownian", True)],
    "deposit": [("polypack.generate.deposit", "deposit", True), ("polypack.analysis", "DepositStatistics", True)],
    "rdf": [("polypack.analysis", "RDF", True)],
    "kfunction": [("polypack.analysis", "KFunction", True)],
    "windows": [("polypack.analysis", "WindowCounts", True)],
    "contacts": [("polypack.analysis", "Contacts", True)],
    "pores": [("polypack.analysis", "PoreSizes", True)],
    "elastic": [("polypack.mechanics.network", "BondNetwork.from_packing", False),
                ("polypack.mechanics.network", "BondNetwork.from_pairs", False),
                ("polypack.mechanics.elastic", "elastic_tensor", True)],
    "shear": [("polypack.mechanics.network", "BondNetwork.from_packing", False),
              ("polypack.mechanics.network", "BondNetwork.from_pairs", False),
              ("polypack.mechanics.dem", "oscillatory_shear", True)],
    "moduli": [("polypack.ensemble.moduli_stage", "moduli_of_pack", True)],
    "homogenize": [("polypack.mechanics.fullfield", "homogenize", True)],
    "rigidity": [("polypack.mechanics.network", "BondNetwork.from_packing", False),
                 ("polypack.mechanics.network", "BondNetwork.from_pairs", False),
                 ("polypack.mechanics.elastic", "elastic_tensor", False),
                 ("polypack.mechanics.rigidity_analysis", "rigidity", True)],
}

# tables every run of a stage needs (required options; shaking on, so that its options are used)
BASE = {"moduli": {"matrix": [1.0, 0.3], "inclusions": [[10.0, 0.2]]}, "crm": {"global_shakes": 2},
        "homogenize": {"matrix": [1.0, 0.3], "inclusions": [[10.0, 0.2]]}}

# options that act only in a context: the other keys that make them count
CONTEXT = {
    ("elastic", "epsilon"): {"bonds": "distance"},  # "auto" takes the protocol's bonds of this pack
    ("shear", "epsilon"): {"bonds": "distance"},
    # issue 30: an option the chosen model ignores is an error, so these need their model
    ("brownian", "sliding_stiffness"): {"bonds": "tangential"},
    ("brownian", "rolling_stiffness"): {"bonds": "tangential"},
    ("brownian", "rolling_moment"): {"bonds": "tangential"},
    ("brownian", "lubrication_range"): {"hydrodynamics": "lubrication"},
    ("rigidity", "epsilon"): {"bonds": "distance"},
}

# values for options whose check alone does not say what to try
OVERRIDES = {
    ("rdf", "method"): "direct",
    ("rdf", "scale"): "contact",
    ("kfunction", "scale"): "contact",
    ("windows", "reference"): "species",
    ("scrm", "schedule"): [0.3, 0.45],
    ("shear", "directions"): [[2, 0], [0, 1]],
    ("moduli", "matrix"): [2.0, 0.25],
    ("moduli", "inclusions"): [[20.0, 0.3]],
    ("homogenize", "matrix"): [2.0, 0.25],
    ("homogenize", "inclusions"): [[20.0, 0.3]],
    ("homogenize", "materials"): ["glass/epoxy"],
    ("elastic", "bonds"): "distance",  # the pack carries protocol bonds: "auto" takes them
    ("brownian", "minimum_separation"): 0.3e-9,  # below the radius
    ("shear", "bonds"): "distance",
    ("rigidity", "bonds"): "distance",
}

# options the stage converts before the call (the recorded calls must still differ)
TRANSFORMED = {
    ("crm", "global_shakes"): "0 skips the shaking; > 0 calls shake(global_shakes=...)",
    ("scrm", "schedule"): "the target volume fraction is appended",
    ("elastic", "bonds"): "selects from_packing or from_pairs",
    ("shear", "bonds"): "selects from_packing or from_pairs",
    ("elastic", "radius"): "0 means none",
    ("shear", "radius"): "rescales the pack to this mean radius",
    ("elastic", "shear_stiffness"): "default k_n / 10 made explicit",
    ("shear", "shear_stiffness"): "default k_n / 10 made explicit",
    ("shear", "directions"): "pairs become tuples",
    ("rigidity", "bonds"): "selects from_packing or from_pairs",
    ("rigidity", "radius"): "0 means none",
    ("rigidity", "shear_stiffness"): "default k_n / 10 made explicit",
    ("moduli", "matrix"): "[E, nu] becomes a Phase",
    ("moduli", "inclusions"): "[E, nu] pairs become Phases",
    ("moduli", "three_point"): "passed as three_point",
    ("moduli", "mefm"): "passed as pair_estimate",
    ("homogenize", "matrix"): "[E, nu] becomes a Phase",
    ("homogenize", "inclusions"): "[E, nu] pairs become Phases",
    ("homogenize", "materials"): "a named system becomes its matrix and inclusion Phases",
    ("crm", "shake_method"): "passed to shake as method",
    ("scrm", "shake_method"): "passed to scrm as method",
    ("windows", "window_radius"): "one estimator per radius",
}


# options the ensemble reads, not the stage: which realizations run the stage at all (the walker checks
# that run_analyses skips exactly the realizations the option leaves out)
SCHEDULED = {
    ("shear", "realizations"): "ensemble.stages.run_analyses runs the stage on realizations 0 .. N-1 only",
}


def _canon(x, depth=0):
    """A comparable, address-free summary of a recorded argument."""
    if depth > 6:
        return "..."
    if x is None or isinstance(x, (bool, str)):
        return x
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x)
    if isinstance(x, np.ndarray):
        return ("array", x.shape, tuple(np.round(x.astype(float).ravel(), 12)))
    if isinstance(x, np.random.SeedSequence):
        return ("seed", x.entropy, tuple(x.spawn_key))
    if isinstance(x, pp.Packing):
        return ("Packing", _canon(np.asarray(x.positions)), _canon(np.asarray(x.radii)), _canon(np.asarray(x.box)))
    if isinstance(x, dict):
        return tuple(sorted((str(k), _canon(v, depth + 1)) for k, v in x.items()))
    if isinstance(x, (list, tuple)):
        return tuple(_canon(v, depth + 1) for v in x)
    if hasattr(x, "to_dict"):
        return (type(x).__name__, _canon(x.to_dict(), depth + 1))
    if isinstance(x, types.SimpleNamespace):
        return _canon(vars(x), depth + 1)
    if callable(x):
        return "callable"
    return type(x).__name__


class _StubNetwork:
    n_bonds = 10
    coordination = 4.0


def _inputs(kind):
    rng = np.random.default_rng(0)
    if kind == "protocol":
        return types.SimpleNamespace(radii=np.full(20, 0.5), species=np.zeros(20, np.int64), dim=3)
    pos = rng.uniform(0, 5, (20, 3))
    meta = {"bonds": {"i": [0, 1, 2], "j": [1, 2, 3], "shift": [[0, 0, 0]] * 3}}
    return pp.Packing(pos, np.full(20, 0.4), np.full(3, 5.0), meta=meta)


def _record(monkeypatch, cap):
    calls = []
    for mod, attr, terminal in SINKS[cap.name]:
        obj = importlib.import_module(mod)
        *owner, name = attr.split(".")
        for o in owner:
            obj = getattr(obj, o)

        def rec(*args, _name=attr, _terminal=terminal, **kw):
            calls.append((_name, args, kw))
            if _terminal:
                raise _Stop
            return _StubNetwork() if "BondNetwork" in _name else args[0]

        monkeypatch.setattr(obj, name, rec)
    return calls


def _run(monkeypatch, cap, table):
    opts = cap.resolve(dict(table))
    calls = _record(monkeypatch, cap)
    try:
        cap.load()(_inputs(cap.kind), opts, np.random.SeedSequence(5))
    except _Stop:
        pass
    return calls


def _alternative(cap, name, spec, base):
    """A valid value of option ``name`` other than its default (None when there is none to try)."""
    if (cap.name, name) in OVERRIDES:
        return OVERRIDES[(cap.name, name)]
    d = spec.default
    choices = getattr(spec.check, "choices", None)
    if choices:
        cands = [c for c in reversed(choices) if c != d]
    elif isinstance(d, bool) or spec.describe == "boolean":
        cands = [not d] if isinstance(d, bool) else [True, False]
    elif isinstance(d, int):
        cands = [d + 1, d + 2]
    elif isinstance(d, float):
        cands = [d * 1.37, d * 0.73, d * 0.5]
    else:
        cands = [0.37, 3, 0.037, 37, 0.9]
    for c in cands:
        try:
            cap.resolve(dict(base, **{name: c}))
            return c
        except Exception:  # noqa: BLE001  (the check says this candidate is not valid)
            continue
    return None


def _stage_options():
    out = []
    registry.discover()
    for kind in registry.KINDS:
        if kind in SKIP_KINDS:
            continue
        for name in registry.names(kind):
            cap = registry.get(kind, name)
            for opt in cap.specs():
                out.append(pytest.param(kind, name, opt, id=f"{name}.{opt}"))
    return out


def test_every_stage_has_its_entry_points_named():
    registry.discover()
    missing = [(k, n) for k in registry.KINDS if k not in SKIP_KINDS for n in registry.names(k) if n not in SINKS]
    assert not missing, f"add the library calls of these stages to SINKS: {missing}"
    assert len(_stage_options()) > 100


def _arrived(calls, opt, value):
    """The value, as recorded, in a recorded call: under the option's own keyword, or positional."""
    target = _canon(value)
    return any((opt in kw and _canon(kw[opt]) == target) or any(_canon(a) == target for a in args)
               for _, args, kw in calls)


@pytest.mark.parametrize("kind, name, opt", _stage_options())
def test_option_reaches_the_code_it_configures(monkeypatch, kind, name, opt):
    cap = registry.get(kind, name)
    spec = cap.specs()[opt]
    base = dict(BASE.get(name, {}), **CONTEXT.get((name, opt), {}))
    alt = _alternative(cap, opt, spec, base)
    assert alt is not None, f"{name}.{opt}: no valid alternative value to try; add one to OVERRIDES"
    if (name, opt) in SCHEDULED:
        _check_scheduled(monkeypatch, cap, base, opt, alt)
        return
    with monkeypatch.context() as m:
        before = _run(m, cap, base)
    with monkeypatch.context() as m:
        after = _run(m, cap, dict(base, **{opt: alt}))
    assert before and after, f"{name}: the stage called none of {SINKS[name]}"
    assert _canon(before) != _canon(after), f"{name}.{opt} = {alt!r} changed nothing the stage passes on"
    resolved = cap.resolve(dict(base, **{opt: alt}))[opt]
    for sink, args, kw in after:
        if opt in kw and (name, opt) not in TRANSFORMED:
            assert _canon(kw[opt]) == _canon(resolved), f"{name}.{opt}: {sink} got {kw[opt]!r}, not {resolved!r}"
    if (name, opt) not in TRANSFORMED:
        assert _arrived(after, opt, resolved), (
            f"{name}.{opt} = {resolved!r} does not reach {[c[0] for c in after]} as such; if the stage converts "
            "it, say how in TRANSFORMED")


def _check_scheduled(monkeypatch, cap, base, opt, n):
    """A scheduling option: the ensemble runs the stage on realizations ``0 .. n-1`` and on no other."""
    from polypack.ensemble import stages

    table = cap.resolve(dict(base, **{opt: n}))
    ran = []
    for index in range(n + 2):
        with monkeypatch.context() as m:
            calls = _record(m, cap)
            try:
                stages.run_analyses(_inputs(cap.kind), {cap.name: dict(table)}, np.random.SeedSequence(5), index=index)
            except _Stop:
                pass
        ran.append(bool(calls))
    assert ran == [True] * n + [False, False], f"{cap.name}.{opt} = {n}: the stage ran on realizations {ran}"
