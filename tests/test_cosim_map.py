"""cosim/README.md's map stays true: every `bowden` subcommand has its cosim/cli/NAME.py, every
`python -m` program of the package is in the entry-point table, and every file the map names
exists."""

from __future__ import annotations

import re
from pathlib import Path

from cosim.cli import SUBCOMMANDS, build_parser
from cosim.project import cliargs

COSIM_DIR = Path(__file__).resolve().parents[1] / "cosim"
README = (COSIM_DIR / "README.md").read_text()


def _section(title: str) -> str:
    start = README.index(title)
    end = README.index("\n## ", start + 1)
    return README[start:end]


def runnable_modules() -> set[str]:
    """Modules `python -m` can run: packages with a __main__.py, modules with a main guard."""
    found = set()
    for path in COSIM_DIR.rglob("*.py"):
        rel = path.relative_to(COSIM_DIR.parent).with_suffix("")
        if path.name == "__main__.py":
            found.add(".".join(rel.parts[:-1]))
        elif path.name != "__init__.py" and 'if __name__ == "__main__"' in path.read_text():
            found.add(".".join(rel.parts))
    return found


def test_every_subcommand_lives_in_cli():
    commands = set(cliargs.subparsers(build_parser()))
    for name in SUBCOMMANDS:
        assert (COSIM_DIR / "cli" / f"{name}.py").is_file()
    # each `bowden X` comes from cli/X.py (bench also registers `emulate`)
    assert commands - set(SUBCOMMANDS) == {"emulate"}


def test_every_runnable_module_is_in_the_entry_point_table():
    table = _section("## Where things live")
    listed = set(re.findall(r"^\| `(cosim[\w.]*)[^`]*` \|", table, flags=re.M))
    missing = sorted(runnable_modules() - listed - {"cosim.cli"})
    assert missing == []
    assert listed - {"cosim"} <= runnable_modules()


def test_every_file_in_the_map_exists():
    table = _section("## Where things live")
    for row in re.findall(r"^\| `(\w+)/` \| [^|]+ \| ([^\n]+) \|$", table, flags=re.M):
        folder, files = row
        for name in re.findall(r"`([\w./]+\.py|[\w]+/)`", files):
            if name.endswith("/") and "/" in name[:-1]:
                continue
            assert (COSIM_DIR / folder / name).exists(), f"{folder}/{name}"
