"""Bit-identical results across refactors: a small SCRM study and a CRM study against their
golden record (tests/data/golden_study.json, recorded on main before the registry refactor).

A failure means the same seeds no longer give the same packs, records or curves. If that
change is intended (a bug fix in a generator or estimator), regenerate the record with
``python tests/_golden.py write`` in the same commit and say why in its message.  The studies
run in a child process on numpy's and OpenBLAS's AVX2 code paths, so that the record holds on
AVX-512 machines too (``_golden.PINNED_ENV``).
"""

import json

import pytest

import _golden


@pytest.fixture(scope="module")
def fresh(tmp_path_factory):
    # a child process on numpy's and OpenBLAS's AVX2 code paths (see _golden.PINNED_ENV)
    return _golden.compute_all_pinned(tmp_path_factory.mktemp("golden"))


@pytest.mark.parametrize("name", sorted(_golden.STUDIES))
def test_study_results_match_the_golden_record(fresh, name):
    gold = json.loads(_golden.GOLDEN.read_text())[name]
    got = fresh[name]
    assert got["packs"] == gold["packs"], "pack arrays or their metadata changed"
    assert got["records"] == gold["records"], "realization records changed"
    assert got["curves"] == gold["curves"], "ensemble curves changed"
    assert got["ci_factor"] == gold["ci_factor"]
    assert got["summary_columns"] == gold["summary_columns"], "summary.csv columns changed"
    assert got["summary"] == gold["summary"], "summary.csv values changed"
