"""Import-layer contract of ../shared/DESIGN.md, checked on the source (imports point down only).

    cli, _cli, report  >  ensemble  >  study  >  analysis | mechanics  >  generate  >
    psd | io  >  packing, neighbors, geometry  >  registry, _validate, errors, _util  >  _kernels

Every ``import`` and ``from ... import`` in every module (also those inside functions: a lazy
upward import is still an upward dependency) is resolved to its polypack module and must point
to a lower layer or stay inside its own subpackage. Siblings on one layer (analysis and
mechanics; psd and io) must not import each other. The registry finds the ``_capabilities``
modules through ``importlib`` at run time (the plugin mechanism), which is not a static import.

This is a pure-python equivalent of an import-linter "layers" contract; the second test
shows that it fails on a deliberate upward import.
"""

from __future__ import annotations

import ast
import shutil
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "polypack"

LAYERS = [
    ("_kernels",),
    ("errors", "registry", "_validate", "_util", "_interrupt"),
    ("packing", "neighbors", "geometry"),
    ("psd", "io"),
    ("generate",),
    ("analysis", "mechanics"),
    ("study",),
    ("ensemble", "studies"),  # studies: seed-specific drivers of the engine (ensemble.sweep runs them)
    ("cli", "_cli", "report", "__main__", "_entry", "_reference"),  # _reference: the generated docs page reads every declaration
]
RANK = {name: k for k, names in enumerate(LAYERS) for name in names}
# siblings that must stay independent of each other
SIBLINGS = [{"analysis", "mechanics"}, {"psd", "io"}]
# the package root re-exports the public API lazily; it is the entry point, not a layer
EXEMPT = {"__init__", "_version"}


def _component(module: str) -> str | None:
    """Top-level component of ``polypack.x.y`` (``x``), or None outside polypack."""
    parts = module.split(".")
    if parts[0] != "polypack":
        return None
    return parts[1] if len(parts) > 1 else "__init__"


def _module_name(path: Path, root: Path) -> str:
    rel = path.relative_to(root.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path, root: Path):
    """``(lineno, imported polypack module)`` of every import statement in ``path``."""
    mod = _module_name(path, root)
    is_pkg = path.name == "__init__.py"
    package = mod if is_pkg else mod.rsplit(".", 1)[0]
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)] if node.level > 1 else base
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if node.module is None or node.level and not node.module:
                for alias in node.names:  # "from . import x" / "from .. import x": x may be a module
                    yield node.lineno, f"{target}.{alias.name}"
            else:
                yield node.lineno, target


def layer_violations(root: Path = SRC) -> list[str]:
    """Every import that points up the layer order or across siblings, as text lines."""
    bad = []
    for path in sorted(root.rglob("*.py")):
        src_comp = _component(_module_name(path, root))
        if src_comp in EXEMPT or src_comp is None:
            continue
        if src_comp not in RANK:
            bad.append(f"{path.relative_to(root)}: component {src_comp!r} is not in the layer table")
            continue
        for lineno, target in _imports(path, root):
            comp = _component(target)
            if comp is None or comp == src_comp:
                continue
            if comp == "__init__":
                # "import polypack": the package root re-exports every layer (the public API), so
                # only the layers above everything it re-exports may import it
                if RANK[src_comp] < RANK["study"]:
                    bad.append(f"{path.relative_to(root)}:{lineno}: layer {src_comp!r} imports the package "
                               f"root polypack (which re-exports the higher layers)")
                continue
            if comp not in RANK:
                continue  # e.g. a lazily exported name of the package root
            if RANK[comp] > RANK[src_comp]:
                bad.append(f"{path.relative_to(root)}:{lineno}: {src_comp!r} imports {target!r} from the higher "
                           f"layer {comp!r}")
            elif RANK[comp] == RANK[src_comp] and any({comp, src_comp} <= s for s in SIBLINGS):
                bad.append(f"{path.relative_to(root)}:{lineno}: sibling {src_comp!r} imports {target!r}")
    return bad


def test_imports_point_down_only():
    bad = layer_violations()
    assert not bad, "layer violations:\n" + "\n".join(bad)


def test_contract_fails_on_a_deliberate_upward_import(tmp_path):
    copy = tmp_path / "polypack"
    shutil.copytree(SRC, copy, ignore=shutil.ignore_patterns("__pycache__"))
    assert not layer_violations(copy)
    target = copy / "generate" / "lubachevsky.py"
    target.write_text(target.read_text() + "\n\ndef _sneaky():\n    from ..analysis import RDF\n    return RDF\n")
    found = layer_violations(copy)
    assert any("generate/lubachevsky.py" in b and "'analysis'" in b for b in found), found
    kern = copy / "_kernels" / "cells.py"
    kern.write_text(kern.read_text() + "\nfrom ..packing import Packing  # noqa\n")
    assert any("_kernels/cells.py" in b for b in layer_violations(copy))
    sib = copy / "mechanics" / "x_sibling.py"
    sib.write_text("from ..analysis import rdf\n")
    assert any("sibling 'mechanics'" in b for b in layer_violations(copy))


@pytest.mark.parametrize("comp", sorted(RANK))
def test_layer_table_names_real_components(comp):
    assert (SRC / comp).is_dir() or (SRC / f"{comp}.py").is_file() or comp in ("report", "mechanics", "__main__", "_entry")


def _module_graph(root: Path = SRC) -> dict:
    """``{module: {polypack modules it imports}}`` (lazy imports inside functions included)."""
    mods = {_module_name(p, root): p for p in root.rglob("*.py")}
    graph = {}
    for m, p in mods.items():
        deps = set()
        for _, t in _imports(p, root):
            while t and t not in mods:  # "from .x import name": the module, not the name
                t = t.rsplit(".", 1)[0] if "." in t else ""
            if t and t != m:
                deps.add(t)
        graph[m] = deps
    return graph


def import_cycles(root: Path = SRC) -> list:
    """Sorted module lists of every import cycle (strongly connected component of two or more)."""
    graph = _module_graph(root)
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):  # Tarjan
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


#: Import cycles still present (issue 30 item 4 asks to break them); the list can only shrink.
ALLOWED_CYCLES = [
    {"polypack.ensemble._plots", "polypack.ensemble.runner"},
]


def _declaration_cycle(cycle) -> bool:
    """A subpackage's ``_capabilities`` module and its own protocol modules (the run adapter calls the public
    function, which validates its keywords through the declared options dataclass): allowed for now."""
    pkgs = {m.rsplit(".", 1)[0] for m in cycle}
    return len(pkgs) == 1 and any(m.endswith("._capabilities") for m in cycle)


def test_no_import_cycles():
    """No module imports (even lazily) a module that imports it back, apart from ALLOWED_CYCLES. SizeSet is
    data only: polypack.psd.descriptors and .plots call it, it imports neither (issue 30)."""
    bad = [c for c in import_cycles() if not any(set(c) <= a for a in ALLOWED_CYCLES) and not _declaration_cycle(c)]
    assert not bad, f"import cycles: {bad}"
    graph = _module_graph()
    assert not graph["polypack.psd.sizeset"] & {"polypack.psd.descriptors", "polypack.psd.plots",
                                                "polypack.psd.models", "polypack.psd.classes"}


def test_cycle_check_finds_a_cycle(tmp_path):
    copy = tmp_path / "polypack"
    shutil.copytree(SRC, copy, ignore=shutil.ignore_patterns("__pycache__"))
    target = copy / "psd" / "sizeset.py"
    target.write_text(target.read_text() + "\n\ndef _d(s):\n    from .descriptors import describe\n    return describe(s)\n")
    assert ["polypack.psd.descriptors", "polypack.psd.sizeset"] in import_cycles(copy)
