"""The firmware's units depend on each other one way: no circle among them, and the settings
chain ranks settings < params < flash < dev (a unit uses only those ranked below it).

A unit is a header and its source (`dev.h` + `dev.c` = `dev`); the generated parameter table
`params_table.c` belongs to `params`. Two graphs are checked over the target code
(firmware/include, firmware/src):
- includes: the `#include "..."` lines of every header and source;
- calls (and data references): each source is compiled on its own and `nm` lists what its object
  defines and what it leaves undefined; an undefined symbol that another object defines is an edge
  from the first unit to the second. This catches a call made through a local prototype or a
  `void *` that the include graph cannot see.
Planted back-edges and a planted circle, in a copy of the sources, show that both checks fail.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from graphlib import CycleError, TopologicalSorter
from pathlib import Path

import pytest

FIRMWARE = Path(__file__).resolve().parents[2] / "firmware"
RANK = ("settings", "params", "flash", "dev")
# Files whose unit is not their stem.
UNIT_OF_FILE = {"params_table": "params"}
INCLUDE_RE = re.compile(r'^[ \t]*#[ \t]*include[ \t]+"([^"]+)"', re.MULTILINE)
CC = shutil.which("gcc") or shutil.which("cc")


def unit(path: Path) -> str:
    return UNIT_OF_FILE.get(path.stem, path.stem)


def _files(root: Path) -> list[Path]:
    return sorted((root / "include").glob("*.h")) + sorted((root / "src").glob("*.c"))


def include_graph(root: Path) -> dict[str, set[str]]:
    """unit -> the units it includes (the project's own headers only)."""
    files = _files(root)
    units = {unit(f) for f in files}
    graph: dict[str, set[str]] = {u: set() for u in units}
    for f in files:
        for name in INCLUDE_RE.findall(f.read_text()):
            target = unit(Path(name))
            if target in units and target != unit(f):
                graph[unit(f)].add(target)
    return graph


def call_graph(root: Path, out: Path) -> dict[str, set[str]]:
    """unit -> the units whose functions or data its object code references (from nm)."""
    defined: dict[str, str] = {}
    undefined: dict[str, set[str]] = {}
    for src in sorted((root / "src").glob("*.c")):
        obj = out / f"{src.stem}.o"
        # -O0: every reference written in the source stays in the object.
        subprocess.run(
            [CC, "-std=c11", "-O0", "-c", f"-I{root / 'include'}", str(src), "-o", str(obj)],
            check=True,
            capture_output=True,
        )
        nm = subprocess.run(["nm", "-P", str(obj)], check=True, capture_output=True, text=True)
        undefined.setdefault(unit(src), set())
        for line in nm.stdout.splitlines():
            name, kind = line.split()[:2]
            if kind == "U":
                undefined[unit(src)].add(name)
            elif kind.isupper():  # a global definition (text, data, read-only data, bss)
                defined[name] = unit(src)
    return {
        u: {defined[n] for n in names if n in defined and defined[n] != u}
        for u, names in undefined.items()
    }


def readme_rows(text: str) -> dict[str, int]:
    """unit -> its row in firmware/README.md's Layers table (0 = top)."""
    section = text.split("## Layers", 1)[1]
    block = re.search(r"(?:^    \S.*\n)+", section, re.MULTILINE).group(0)  # the indented table
    rows = {}
    for i, line in enumerate(block.splitlines()):
        units = line.strip().split("  ", 1)[0]
        rows.update({u.strip(): i for u in units.split(",")})
    return rows


def upward(graph: dict[str, set[str]], rows: dict[str, int]) -> list[str]:
    """Edges that do not run down the README's table, and units the table does not list."""
    missing = [f"{u} is not in the Layers table" for u in sorted(graph) if u not in rows]
    return missing + sorted(
        f"{a} -> {b} runs up the Layers table"
        for a, targets in graph.items()
        for b in targets
        if a in rows and b in rows and rows[b] <= rows[a]
    )


def violations(graph: dict[str, set[str]]) -> list[str]:
    """Every back-edge against RANK, and a circle if there is one; empty when the graph is clean."""
    found = [
        f"{a} -> {b} runs against {' < '.join(RANK)}"
        for a, targets in graph.items()
        for b in targets
        if a in RANK and b in RANK and RANK.index(b) > RANK.index(a)
    ]
    try:
        list(TopologicalSorter(graph).static_order())
    except CycleError as exc:
        found.append("circle: " + " -> ".join(exc.args[1]))
    return sorted(found)


@pytest.fixture(scope="module")
def calls(tmp_path_factory) -> dict[str, set[str]]:
    return call_graph(FIRMWARE, tmp_path_factory.mktemp("objs"))


def _copy(tmp_path: Path) -> Path:
    root = tmp_path / "firmware"
    for d in ("include", "src"):
        shutil.copytree(FIRMWARE / d, root / d)
    return root


def test_include_graph_runs_one_way():
    graph = include_graph(FIRMWARE)
    assert set(RANK) <= set(graph), f"missing units: {set(RANK) - set(graph)}"
    assert violations(graph) == []
    # The chain is really there (a check over an empty graph would pass too).
    for a, b in (("params", "settings"), ("flash", "params"), ("flash", "settings"),
                 ("dev", "flash"), ("dev", "params")):  # fmt: skip
        assert b in graph[a], f"{a} no longer includes {b}"


def test_call_graph_runs_one_way(calls):
    assert set(RANK) <= set(calls), f"missing units: {set(RANK) - set(calls)}"
    assert violations(calls) == []
    for a, b in (("params", "settings"), ("flash", "params"), ("flash", "settings"),
                 ("dev", "flash"), ("dev", "params"), ("dev", "settings")):  # fmt: skip
        assert b in calls[a], f"{a} no longer calls {b}"


def test_readme_layers_table_matches_both_graphs(calls):
    rows = readme_rows((FIRMWARE / "README.md").read_text())
    assert [rows[u] for u in RANK] == [3, 2, 1, 0], "the chain's rows in the table"
    assert upward(include_graph(FIRMWARE), rows) == []
    assert upward(calls, rows) == []
    # And the check can fail: a unit moved one row up is caught.
    assert "comp -> fxp runs up the Layers table" in upward(calls, {**rows, "fxp": rows["comp"]})


def test_planted_include_back_edge_and_circle_are_caught(tmp_path):
    root = _copy(tmp_path)
    with (root / "include" / "settings.h").open("a") as f:
        f.write('#include "flash.h"\n')
    found = violations(include_graph(root))
    assert "settings -> flash runs against settings < params < flash < dev" in found
    assert any(v.startswith("circle: ") for v in found), found


def test_planted_circle_outside_the_chain_is_caught(tmp_path):
    root = _copy(tmp_path)
    assert "comp" in include_graph(root)["fw"]
    with (root / "include" / "comp.h").open("a") as f:
        f.write('#include "fw.h"\n')
    found = violations(include_graph(root))
    assert len(found) == 1 and found[0].startswith("circle: "), found
    assert {"comp", "fw"} <= set(found[0].removeprefix("circle: ").split(" -> "))


def test_planted_call_back_edge_is_caught(tmp_path):
    """A call that no include shows (a local prototype) is still an edge of the call graph."""
    root = _copy(tmp_path)
    with (root / "src" / "params.c").open("a") as f:
        f.write(
            "\nstruct dev_planted;\n"
            "void dev_overrun(struct dev_planted *d);\n"
            "void params_planted(struct dev_planted *d);\n"
            "void params_planted(struct dev_planted *d) { dev_overrun(d); }\n"
        )
    assert violations(include_graph(root)) == []
    found = violations(call_graph(root, tmp_path))
    assert "params -> dev runs against settings < params < flash < dev" in found
