"""Imports in cosim/ flow one way: from the command line down to the project's plumbing.

Every module of the package is read as source (ast, nothing is imported or run) and each import
it makes, at the top or inside a function, is an edge of the module graph. Two rules:

- rank: a module may import only from a role ranked below its own, or from its own role (RANKS,
  longest prefix wins; within engines/ the shared code ranks below the engines built on it);
- no circle: the module graph has no cycle, whatever the ranks say.

`__main__` modules are entry points (`python -m cosim.X`), the top of the graph: they may import
anything and nothing imports them. The checks run on a copy with a planted back-import and a
planted circle to show that they fail.
"""

from __future__ import annotations

import ast
import shutil
from pathlib import Path

import pytest

COSIM_DIR = Path(__file__).resolve().parents[1] / "cosim"

# Roles, lowest first. Equal ranks of different roles may not import each other (audit and bench
# are independent); a role imports its own modules freely, subject to the circle check.
RANKS: dict[str, float] = {
    "cosim": 0,  # the package's own __init__ (the version)
    "cosim.project": 1,
    "cosim.parts": 2,
    "cosim.config": 3,
    "cosim.results": 4,
    "cosim.engines": 5,
    "cosim.engines.harness": 5.0,
    "cosim.engines.fwbridge": 5.1,
    "cosim.engines.reference": 5.2,
    "cosim.engines.cocotb": 5.3,
    "cosim.engines.native": 5.3,
    "cosim.engines.experiment": 5.4,
    "cosim.audit": 6,
    "cosim.bench": 6,
    # `bowden bench calibrate` runs the bench and judges with the audit: above both (nothing in
    # cosim.bench imports it)
    "cosim.bench.calibrate": 6.5,
    "cosim.studies": 7,
    "cosim.perf": 8,
    "cosim.cli": 9,
}


def module_name(root: Path, path: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def import_graph(root: Path) -> dict[str, set[str]]:
    """Module -> the cosim modules (or packages) it imports, from the sources under `root`."""
    files = {module_name(root, p): p for p in root.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in files.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        edges: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")[: len(package.split(".")) - node.level + 1]
                    module = ".".join(base + ([node.module] if node.module else []))
                else:
                    module = node.module or ""
                # `from P import m` imports the module P.m when there is one
                targets = [
                    f"{module}.{a.name}" if f"{module}.{a.name}" in files else module
                    for a in node.names
                ]
            else:
                continue
            edges.update(t for t in targets if t == "cosim" or t.startswith("cosim."))
        edges.discard(name)
        graph[name] = edges
    return graph


def rank_of(module: str) -> tuple[str, float]:
    """The role (longest RANKS prefix) of a module and its rank."""
    best = max((r for r in RANKS if module == r or module.startswith(r + ".")), key=len)
    return best, RANKS[best]


def back_imports(graph: dict[str, set[str]]) -> list[str]:
    """Every import that runs against the ranks, as 'importer -> imported'."""
    found = []
    for importer, targets in sorted(graph.items()):
        if importer.endswith("__main__"):
            continue
        role, rank = rank_of(importer)
        for target in sorted(targets):
            if target.endswith("__main__"):
                found.append(f"{importer} -> {target} (an entry point)")
                continue
            target_role, target_rank = rank_of(target)
            same_role = target_role == role or target.startswith(role + ".")
            if target_rank > rank or (target_rank == rank and not same_role):
                found.append(f"{importer} -> {target}")
    return found


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_every_module_has_a_role():
    graph = import_graph(COSIM_DIR)
    assert len(graph) > 50, "the package was not found"
    roles = {rank_of(m)[0] for m in graph}
    # only the package's own __init__, the entry point (__main__) and its early Ctrl-C handler
    # (_early, standard library only) sit at the top level
    top = {m for m in graph if rank_of(m)[0] == "cosim"}
    assert top == {"cosim", "cosim.__main__", "cosim._early"}
    assert roles >= {"cosim.project", "cosim.parts", "cosim.engines.harness", "cosim.cli"}


def test_imports_run_one_way():
    assert back_imports(import_graph(COSIM_DIR)) == []


def test_no_circle_of_imports():
    assert circles(import_graph(COSIM_DIR)) == []


@pytest.fixture
def copy(tmp_path):
    root = tmp_path / "cosim"
    shutil.copytree(COSIM_DIR, root, ignore=shutil.ignore_patterns("__pycache__", "*.so"))
    return root


def test_a_planted_back_import_fails(copy):
    geometry = copy / "parts" / "geometry.py"
    geometry.write_text(geometry.read_text() + "\n\ndef _late():\n    from cosim.cli import main\n")
    assert back_imports(import_graph(copy)) == ["cosim.parts.geometry -> cosim.cli"]


def test_a_planted_relative_back_import_fails(copy):
    trace = copy / "results" / "trace.py"
    trace.write_text(trace.read_text() + "\nfrom ..engines import experiment\n")
    assert back_imports(import_graph(copy)) == ["cosim.results.trace -> cosim.engines.experiment"]


def test_a_planted_circle_fails(copy):
    # reference imports harness; harness importing reference closes a circle (and runs uphill)
    harness = copy / "engines" / "harness.py"
    harness.write_text(harness.read_text() + "\nfrom . import reference\n")
    graph = import_graph(copy)
    assert circles(graph) == [["cosim.engines.harness", "cosim.engines.reference"]]
    assert "cosim.engines.harness -> cosim.engines.reference" in back_imports(graph)


def test_a_circle_within_one_role_fails():
    # ranks allow any import inside one role; the circle check still catches a loop there
    graph = {"cosim.studies.a": {"cosim.studies.b"}, "cosim.studies.b": {"cosim.studies.a"}}
    assert back_imports(graph) == []
    assert circles(graph) == [["cosim.studies.a", "cosim.studies.b"]]
