"""``polypack run --check`` is complete: every rule that made a realization fail after the
protocol ran is evaluated before the first realization (issue 31, items 4 and 10)."""

import copy

import pytest

from polypack.ensemble.stages import check_available, child_seed_records, preflight
from polypack.ensemble.sweep import sweep_studies
from polypack.errors import InvalidInputError
from polypack.study import load_study

BASE = {
    "study": {"name": "c", "seed": 1, "realizations": 1},
    "psd": {"model": "monodisperse", "d": 0.5e-6, "n": 64},
    "protocol": {"kind": "vem", "volume_fraction": 0.4, "void_ratio": 1.0},
    "output": {"plots": False},
}


def _check(data):
    if "sweep" in data:
        sw, studies, _ = sweep_studies(data)
        sts = [st for _, st in studies]
    else:
        sts = [load_study(data)]
    for st in sts:
        check_available(st.data)
        preflight(st.data, child_seed_records(st.seed, 1)[0])


BROWNIAN = {"kind": "brownian", "volume_fraction": 0.3, "surface_potential": 0.015}
CASES = {
    # 2D/3D mix-ups (item 4): these made 3D structures from [psd] dim = 2
    "vem with dim 2": (lambda d: d["psd"].update(dim=2), r'protocol.kind = "vem": makes 3D sphere structures'),
    "brownian with dim 2": (lambda d: (d["psd"].update(dim=2), d.update(protocol=dict(BROWNIAN))),
                            r'protocol.kind = "brownian": makes 3D sphere structures'),
    # item 10: each of these failed only after every protocol had run
    "shear amplitude 0.5": (lambda d: d.update(analysis={"shear": {"amplitude": 0.5}}),
                            r"analysis.shear: amplitude=0.5: .* below 0.1"),
    "shear 10 steps per cycle": (lambda d: d.update(analysis={"shear": {"steps_per_cycle": 10}}),
                                 r"analysis.shear: samples_per_cycle=100: at most steps_per_cycle=10"),
    "protocol bonds with vem": (lambda d: d.update(analysis={"elastic": {"bonds": "protocol"}}),
                                r'analysis.elastic.bonds = "protocol": protocol.kind = "vem" makes no bonds'),
    "shear protocol bonds with vem": (lambda d: d.update(analysis={"shear": {"bonds": "protocol"}}),
                                      r'analysis.shear.bonds = "protocol"'),
    "vem with n = 10": (lambda d: d["psd"].update(n=10), r'protocol.kind = "vem": needs at least 32'),
    "deposit analysis of a vem pack": (lambda d: d.update(analysis={"deposit": {}}),
                                       r'analysis.deposit: measures a deposit .* protocol.kind = "vem"'),
    "deposit width below 4 d_max": (lambda d: (d["psd"].update(dim=2),
                                               d.update(protocol={"kind": "deposit", "width": 1.5e-6})),
                                    r"protocol.width = 1.5e-06: below four times the largest diameter"),
    "sweep modulus shear without shear": (
        lambda d: d.update(analysis={"pores": {"n_points": 1000}},
                           sweep={"parameter": "protocol.void_ratio", "values": [0.5, 1.0],
                                  "report": "heterogeneity", "modulus": "shear"}),
        r'sweep.modulus = "shear": needs \[analysis.shear\]'),
    "heterogeneity report without pores": (
        lambda d: d.update(sweep={"parameter": "protocol.void_ratio", "values": [0.5, 1.0],
                                  "report": "heterogeneity"}),
        r'sweep.report = "heterogeneity": needs \[analysis.pores\]'),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_check_refuses_before_the_first_realization(case):
    edit, msg = CASES[case]
    data = copy.deepcopy(BASE)
    edit(data)
    with pytest.raises(InvalidInputError, match=msg) as exc:
        _check(data)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("edit", [
    lambda d: None,
    lambda d: d.update(analysis={"shear": {"amplitude": 0.05, "steps_per_cycle": 200}, "elastic": {}}),
    lambda d: (d["psd"].update(dim=2), d.update(protocol={"kind": "deposit", "width": 2.0e-6})),
    lambda d: d.update(protocol=dict(BROWNIAN), analysis={"elastic": {"bonds": "protocol"}}),
])
def test_valid_studies_still_pass(edit):
    data = copy.deepcopy(BASE)
    edit(data)
    _check(data)
