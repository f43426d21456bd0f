"""Equations are findable: every citation is "Eq. (n) of <seed document>", one equation each,
and docs/equations.md (tools/gen_equations.py) indexes them."""

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("gen_equations", ROOT / "tools" / "gen_equations.py")
gen = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(gen)


def test_no_bare_or_range_citations_in_source_and_docs():
    bad = gen.bare_citations(gen.source_files())
    assert not bad, "cite one equation with its document, e.g. 'Eq. (14) of 000_2cedc098acbd866b.txt':\n" + \
        "\n".join(bad)


def test_the_check_fails_on_a_bare_citation(tmp_path):
    f = tmp_path / "x.py"
    f.write_text('"""The contact law, Eq. (1)."""\n')
    assert gen.bare_citations([f]) == [f"{f}:1: 'Eq. (1)'"]
    f.write_text('"""Damping, Eqs. (3)-(4) of 003_873b69fc71c74cf6.txt."""\n')
    assert len(gen.bare_citations([f])) == 1  # a range, not single equations
    f.write_text('"""The law, Eq. (1) of\n   003_873b69fc71c74cf6.txt, and Eq. (14_2) of 000_2cedc098acbd866b.txt."""\n')
    assert gen.bare_citations([f]) == []


def test_index_lists_every_cited_equation():
    text = gen.render()
    assert "## 000_2cedc098acbd866b.txt" in text and "## 001_ad5bae0acea940c4.txt" in text
    for (doc, eq), where in gen.collect().items():
        assert f"| Eq. ({eq}) |" in text
    # the committed index is the generated one (regenerate with python tools/gen_equations.py)
    assert (ROOT / "docs" / "equations.md").read_text(encoding="utf-8").startswith("# Equations index")
