"""Imports in cosim/ flow one way: from the command line down to the project's plumbing.

Every module of the package is read as source (ast, nothing is imported or run) and each import
it makes, at the top or inside a function, is an edge of the module graph. Two rules:

- rank: a module may import only from a role ranked below its own, or from its own role (RANKS,
  longest prefix wins; within engines/ the shared code ranks below the engines built on it),
  but for the imports UPHILL_INSIDE_A_FUNCTION names, which run only when a function is called;
- no circle: the module graph has no cycle, whatever the ranks say.

The bench's link (cosim.bench.link: the protocol, the links, the Python API) is also imported in
a fresh interpreter, which must not load the simulation (SIMULATION): a script that only talks to
a board starts without it.

`__main__` modules are entry points (`python -m cosim.X`), the top of the graph: they may import
anything and nothing imports them. The checks run on a copy with a planted back-import and a
planted circle to show that they fail.
"""

from __future__ import annotations

import ast
import functools
import shutil
import subprocess
import sys
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
    # the bench's link to a board (protocol, links, recording, the Python API): below the
    # engines, which it never needs, and the live view that shows its telemetry beside it
    "cosim.bench.link": 4.5,
    "cosim.bench.live": 4.6,
    "cosim.engines": 5,
    "cosim.engines.harness": 5.0,
    "cosim.engines.fwbridge": 5.1,
    "cosim.engines.reference": 5.2,
    "cosim.engines.cocotb": 5.3,
    "cosim.engines.native": 5.3,
    "cosim.engines.antagonist": 5.35,
    # the pair's cocotb bench: the pair's world (antagonist.PairSim) around the RTL
    "cosim.engines.cocotb.tb_pair": 5.36,
    "cosim.engines.experiment": 5.4,
    # the emulated controller: the loop's model, the plant, the simulated board (built with the
    # native engine's Verilator build)
    "cosim.bench.emulate": 5.5,
    "cosim.audit": 6,
    # the bench package itself: its __init__, and `api`, the documented name of link.api
    "cosim.bench": 6,
    # procedures at the rig: `bench calibrate` runs the bench and judges with the audit
    "cosim.bench.rig": 6.5,
    # the `bench` and `emulate` command lines (parsers, handlers): above the procedures they call,
    # below cosim.cli, which only adds them to `bowden`: `python -m cosim.bench` needs no cosim.cli
    "cosim.bench.command": 6.8,
    "cosim.bench.command_tools": 6.7,
    "cosim.studies": 7,
    "cosim.perf": 8,
    "cosim.cli": 9,
}


# Imports that run uphill, allowed only inside a function (never when the importer is imported):
# `Bench(emulate=True)`, the Python API's emulated bench, starts the emulator; importing the
# link stays light. Importer -> the role it may reach.
UPHILL_INSIDE_A_FUNCTION = {"cosim.bench.link.api": "cosim.bench.emulate"}

# What importing the link must not load.
SIMULATION = ("cosim.audit", "cosim.engines", "numba", "fmpy")


def module_name(root: Path, path: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _outside_functions(tree: ast.AST):
    """The nodes of `tree` that run when the module is imported (not those of a function)."""
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        stack.extend(
            child
            for child in ast.iter_child_nodes(node)
            if not isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
        )


@functools.lru_cache(maxsize=4096)
def _parse(text: str) -> ast.Module:
    """A module's tree, parsed once per text: the planted tests copy the package and change one
    file, so the other files' trees are reused (ast.walk does not change a tree)."""
    return ast.parse(text)


def import_graph(root: Path, *, top_level_only: bool = False) -> dict[str, set[str]]:
    """Module -> the cosim modules (or packages) it imports, from the sources under `root`; with
    `top_level_only`, only the imports that run when the module is imported."""
    files = {module_name(root, p): p for p in root.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in files.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        edges: set[str] = set()
        tree = _parse(path.read_text())
        for node in _outside_functions(tree) if top_level_only else ast.walk(tree):
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


def back_imports(
    graph: dict[str, set[str]], top_level: dict[str, set[str]] | None = None
) -> list[str]:
    """Every import that runs against the ranks, as 'importer -> imported'. `top_level`: the
    imports run at import time (import_graph's top_level_only), which UPHILL_INSIDE_A_FUNCTION
    does not cover; without it every import counts as one."""
    top_level = graph if top_level is None else top_level
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
                reach = UPHILL_INSIDE_A_FUNCTION.get(importer)
                inside_a_function = target not in top_level.get(importer, ())
                if reach and inside_a_function and (target + ".").startswith(reach + "."):
                    continue
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
    # only the package's own __init__, the entry point (__main__), its early Ctrl-C handler
    # (_early) and the one module that installs signal handlers (_signals), both standard library
    # only, sit at the top level
    top = {m for m in graph if rank_of(m)[0] == "cosim"}
    assert top == {"cosim", "cosim.__main__", "cosim._early", "cosim._signals"}
    assert roles >= {"cosim.project", "cosim.parts", "cosim.engines.harness", "cosim.cli"}


def uphill(root: Path) -> list[str]:
    """back_imports of the package under `root`, with its import-time imports known."""
    return back_imports(import_graph(root), import_graph(root, top_level_only=True))


def test_imports_run_one_way():
    graph = import_graph(COSIM_DIR)
    assert uphill(COSIM_DIR) == []
    # the allowance is used (drop it when the API no longer starts the emulator)
    assert any(t.startswith("cosim.bench.emulate.") for t in graph["cosim.bench.link.api"])


def simulation_loaded(root: Path) -> list[str]:
    """The SIMULATION modules in sys.modules of a fresh interpreter that imported every module
    of the link under `root` and `cosim.bench.api`."""
    graph = import_graph(root)
    modules = sorted(m for m in graph if m.startswith("cosim.bench.link")) + ["cosim.bench.api"]
    code = (
        "import importlib, sys\n"
        f"for m in {modules!r}:\n    importlib.import_module(m)\n"
        f"print(' '.join(sorted(m for m in sys.modules if m.startswith({SIMULATION!r}))))"
    )
    # run from the folder that holds `root`, so that its copy of the package is the one imported
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=root.parent, capture_output=True, text=True, check=True
    )
    return out.stdout.split()


def test_the_link_loads_no_simulation():
    assert simulation_loaded(COSIM_DIR) == []


def bench_entry_loads(root: Path) -> list[str]:
    """The cosim.cli modules in sys.modules of a fresh interpreter after `python -m cosim.bench
    --help` (run from the folder that holds `root`), which must also have printed its usage."""
    code = (
        "import runpy, sys\n"
        "sys.argv = ['cosim.bench', '--help']\n"
        "try:\n    runpy.run_module('cosim.bench', run_name='__main__', alter_sys=True)\n"
        "except SystemExit as exc:\n    assert exc.code in (0, None), exc.code\n"
        "print('LOADED', *sorted(m for m in sys.modules\n"
        "                        if m == 'cosim.cli' or m.startswith('cosim.cli.')))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=root.parent, capture_output=True, text=True, check=True
    )
    assert "usage: python -m cosim.bench" in out.stdout
    return out.stdout.split("LOADED", 1)[1].split()


def test_the_bench_entry_does_not_import_the_command_line():
    """`python -m cosim.bench` has its own parsers and handlers (cosim.bench.command): it starts
    without `bowden`'s dispatcher and its other commands."""
    assert bench_entry_loads(COSIM_DIR) == []


def test_a_planted_command_line_import_in_the_bench_entry_fails(copy):
    command = copy / "bench" / "command.py"
    command.write_text(command.read_text() + "\nimport cosim.cli.sim  # noqa: E402,F401\n")
    assert "cosim.cli.sim" in bench_entry_loads(copy)


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
    assert uphill(copy) == ["cosim.parts.geometry -> cosim.cli"]


def test_a_planted_relative_back_import_fails(copy):
    trace = copy / "results" / "trace.py"
    trace.write_text(trace.read_text() + "\nfrom ..engines import experiment\n")
    assert uphill(copy) == ["cosim.results.trace -> cosim.engines.experiment"]


def test_a_planted_simulation_import_in_the_link_fails(copy):
    recorder = copy / "bench" / "link" / "recorder.py"
    recorder.write_text(recorder.read_text() + "\nfrom cosim import audit\n")
    assert "cosim.audit" in simulation_loaded(copy)
    assert uphill(copy) == ["cosim.bench.link.recorder -> cosim.audit"]


def test_the_api_imports_the_emulator_only_inside_a_function(copy):
    api = copy / "bench" / "link" / "api.py"
    api.write_text(api.read_text() + "\nfrom cosim.bench.emulate import emulator\n")
    assert uphill(copy) == ["cosim.bench.link.api -> cosim.bench.emulate.emulator"]


def test_only_the_api_may_import_the_emulator_inside_a_function(copy):
    client = copy / "bench" / "link" / "client.py"
    client.write_text(
        client.read_text() + "\n\ndef _late():\n    from cosim.bench.emulate import emulator\n"
    )
    assert uphill(copy) == ["cosim.bench.link.client -> cosim.bench.emulate.emulator"]


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


def test_one_interrupted_type():
    # SIGINT and SIGTERM raise one exception type wherever a handler raises (the dispatcher, a
    # bench run's Signals): defined once, low, in cosim.project.interrupt
    defined = sorted(
        str(path.relative_to(COSIM_DIR))
        for path in COSIM_DIR.rglob("*.py")
        for node in ast.walk(_parse(path.read_text()))
        if isinstance(node, ast.ClassDef) and node.name == "Interrupted"
    )
    assert defined == ["project/interrupt.py"]


# The one module that installs signal handlers; the others call its policies.
SIGNAL_INSTALLER = "cosim._signals"


def signal_installers(root: Path) -> list[str]:
    """Every `signal.signal(...)` call (under any name the signal module or its `signal` function
    is imported as) outside SIGNAL_INSTALLER, as 'module:line'."""
    found = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root.parent).with_suffix("")
        module = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        if module == SIGNAL_INSTALLER:
            continue
        tree = _parse(path.read_text())
        modules, functions = set(), set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                modules |= {a.asname or a.name for a in node.names if a.name == "signal"}
            elif isinstance(node, ast.ImportFrom) and node.module == "signal":
                functions |= {a.asname or a.name for a in node.names if a.name == "signal"}
        for node in ast.walk(tree):
            if not isinstance(node, ast.Call):
                continue
            f = node.func
            if (
                isinstance(f, ast.Attribute)
                and f.attr == "signal"
                and isinstance(f.value, ast.Name)
                and f.value.id in modules
            ) or (isinstance(f, ast.Name) and f.id in functions):
                found.append(f"{module}:{node.lineno}")
    return found


def test_signal_handlers_are_installed_in_one_module():
    assert signal_installers(COSIM_DIR) == []
    assert (COSIM_DIR / "_signals.py").exists()


def test_a_planted_signal_handler_fails(copy):
    view = copy / "bench" / "live" / "page.py"
    view.write_text(view.read_text() + "\nimport signal as _s\n_s.signal(_s.SIGINT, _s.SIG_IGN)\n")
    paths = copy / "project" / "paths.py"
    lines = len(paths.read_text().splitlines())
    paths.write_text(paths.read_text() + "\nfrom signal import signal as _on\n_on(2, print)\n")
    found = signal_installers(copy)
    assert found == [
        f"cosim.bench.live.page:{len(view.read_text().splitlines())}",
        f"cosim.project.paths:{lines + 3}",
    ]
