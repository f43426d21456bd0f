"""Study pipeline options end to end: what the study file asks for is what the run did.

Every option goes in through ``polypack.ensemble.run_study`` (the path ``polypack run``
takes) and is checked in the realization's record, never by calling the stage
functions directly.
"""

import numpy as np
import pytest

import polypack as pp


def _study(protocol, psd=None, **extra):
    d = {
        "study": {"name": "opts", "seed": 5, "realizations": 1},
        "psd": psd or {"model": "bimodal", "size_ratio": 0.5, "volume_ratio": 0.5, "n": 150},
        "protocol": protocol,
        "analysis": {"contacts": {"tolerance": 0.02}},
        "output": {"plots": False},
    }
    d.update(extra)
    return d


def _record(tmp_path, study):
    res = pp.ensemble.run_study(study, tmp_path / "run", progress=False)
    assert len(res.records) == 1
    return res.records[0]


@pytest.mark.parametrize(
    "kind, method, radius, trials, adaptive",
    [("crm", "paper", 0.03, 7, False), ("crm", "collision", 0.04, 3, True), ("crm", "metropolis", 0.05, 1, False),
     ("scrm", "collision", 0.02, 2, False)],
)
def test_protocol_shake_options_reach_the_shaker(tmp_path, kind, method, radius, trials, adaptive):
    pr = {"kind": kind, "volume_fraction": 0.4, "global_shakes": 3, "shake_method": method,
          "shake_radius": radius, "max_trials": trials, "adaptive": adaptive}
    if kind == "scrm":
        pr.update(growth_steps=2, stage_shakes=1)
    rec = _record(tmp_path, _study(pr))
    p = rec["protocol"]
    assert p["shake.method"] == method
    assert p["shake.adaptive"] is adaptive
    assert p["shake.shake_radius.0"] == pytest.approx(radius) and p["shake.shake_radius.1"] == pytest.approx(radius)
    assert p["shake.max_trials.0"] == trials and p["shake.max_trials.1"] == trials
    assert p["shake.global_shakes"] == 3
    if adaptive:
        assert p["shake.final_shake_radius.0"] != pytest.approx(radius)
    else:
        assert p["shake.final_shake_radius.0"] == pytest.approx(radius)
    assert rec["volume_fraction"] == pytest.approx(0.4, rel=1e-9)
    assert p["shake.min_gap"] >= 0.0


def test_psd_discretize_runs_end_to_end(tmp_path):
    """sampling = "discretize" builds size classes (§1.2 of 001_ad5bae0acea940c4.txt):
    n_classes species, each with at least min_per_class particles, N within the bounds,
    the same sizes as polypack.psd.discretize with the same options."""
    psd = {"model": "cumulative_beta", "a": 1.0, "b": 3.0, "span": 0.6, "d_max": 1.0, "sampling": "discretize",
           "n_classes": 3, "spacing": "geometric", "min_per_class": 10, "min_total": 200, "max_total": 5000}
    rec = _record(tmp_path, _study({"kind": "crm", "volume_fraction": 0.3}, psd=psd))
    counts = np.array(rec["species_counts"])
    assert counts.size == 3 and np.all(counts >= 10)
    assert 200 <= rec["n"] <= 5000 and counts.sum() == rec["n"]
    direct = pp.psd.discretize(pp.psd.CumulativeBeta(a=1.0, b=3.0, span=0.6, d_max=1.0), n_classes=3,
                               spacing="geometric", min_per_class=10, min_total=200, max_total=5000, seed=0)
    np.testing.assert_array_equal(np.bincount(direct.species), counts)  # class counts do not depend on the seed
    # the model's sample() would give 2000 particles of one species
    assert rec["n"] != 2000
