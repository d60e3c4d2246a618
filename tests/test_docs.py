"""The documents stand alone: no tracker numbers, no citations of files that do not exist.

A reader of this repository cannot follow "issue 12" (a number only the project's tracker
knows) or a link to a file that is not in the repository; the text has to name the section,
the property or the decision instead. This test reads the files git tracks under
CHECKED_ROOTS and fails on

- a tracker reference: "issue" followed by a number ("issue 7", "issues 11 and 12", "Issue #3");
- a path outside the repository (`/work/...`, `../shared`);
- in a markdown file, a relative link `[text](path)` whose target does not exist, a path in
  backticks (`dir/file.ext`) that exists neither from the repository root nor from the
  document's folder, or a markdown file cited by its bare name (`NOTES.md`) that the
  repository does not hold.

Fenced code blocks are skipped (they show commands and their outputs, whose files a run
writes), and so are paths under `build/` and paths with placeholders (`DIR/audit.json`).

It also holds the named formal properties to their rule (hdl/README.md, "Named properties"):
every assertion labelled after its tag, and the README's table the one `formal.py
--properties` prints.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# The whole repository ("" is every tracked file) except this file, whose planted failures spell
# tracker numbers on purpose.
CHECKED_ROOTS = [""]
SELF = "tests/test_docs.py"

TEXT_SUFFIXES = {
    ".md", ".py", ".v", ".vh", ".sby", ".json", ".c", ".h", ".txt", ".pcf", ".lpf", ".mk",
    ".toml", ".yaml", ".yml", ".core", ".cfg", ".sh", ".csv", "",
}  # fmt: skip

TRACKER = re.compile(r"(?i)\bissues?\s*#?\s*[0-9]")
OUTSIDE = re.compile(r"(?<![\w.])(/work/|\.\./shared\b)")
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
BACKTICK = re.compile(r"`([^`\s]+)`")
PATH_LIKE = re.compile(r"^[\w.-]+(/[\w.-]+)*/[\w.-]+\.[A-Za-z]\w*$")
BARE_MD = re.compile(r"^[\w.-]+\.md$")
# In code, only the repository's own kind of document (README.md, NOTES.md): lower-case names such
# as report.md are files the tools write.
MD_NAME = re.compile(r"(?<![\w/.-])([A-Z][A-Z0-9_-]*\.md)\b")
PLACEHOLDER = re.compile(r"(^|/)([A-Z][A-Z_]+|<[^>]*>|NAME|\*)(/|$|\.)")


def tracked_files(root: Path = ROOT) -> list[str]:
    try:
        out = subprocess.run(
            ["git", "ls-files"], cwd=root, capture_output=True, text=True, check=True
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: the tracked files are unknown")
    return out.splitlines()


def in_roots(path: str, roots: list[str]) -> bool:
    return any(r == "" or path == r or (r.endswith("/") and path.startswith(r)) for r in roots)


def _prose_lines(text: str):
    """(line number, line) of a markdown text outside fenced code blocks."""
    fenced = False
    for n, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        if not fenced:
            yield n, line


def _exists(target: str, doc: Path, root: Path) -> bool:
    return (doc.parent / target).exists() or (root / target).exists()


def check_file(root: Path, rel: str, basenames: set[str]) -> list[str]:
    """Every finding in one tracked file, as `path:line: what`."""
    path = root / rel
    if path.suffix not in TEXT_SUFFIXES or not path.is_file():
        return []
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        return []
    found = []
    for n, line in enumerate(text.splitlines(), 1):
        if m := TRACKER.search(line):
            found.append(f"{rel}:{n}: tracker reference {m.group(0)!r}: name the decision")
        if m := OUTSIDE.search(line):
            found.append(f"{rel}:{n}: path outside the repository {m.group(1)!r}")
        if path.suffix != ".md":  # code and data: a markdown file named that the repository lacks
            for name in MD_NAME.findall(line):
                if name not in basenames:
                    found.append(f"{rel}:{n}: cites {name}, which the repository does not hold")
    if path.suffix != ".md":
        return found
    for n, line in _prose_lines(text):
        for target in LINK.findall(line):
            if re.match(r"^[a-z]+:", target) or target.startswith("#"):
                continue
            target = target.split("#", 1)[0]
            if target and not _exists(target, path, root):
                found.append(f"{rel}:{n}: link to {target}, which does not exist")
        for token in BACKTICK.findall(line):
            token = token.rstrip(".,;:")
            if BARE_MD.match(token) and token not in basenames:
                found.append(f"{rel}:{n}: cites {token}, which the repository does not hold")
            elif (
                PATH_LIKE.match(token)
                and not token.startswith(("build/", ".venv/"))
                and not PLACEHOLDER.search(token)
                and not _exists(token, path, root)
            ):
                found.append(f"{rel}:{n}: cites {token}, which does not exist")
    return found


def check(root: Path, files: list[str], roots: list[str]) -> list[str]:
    basenames = {Path(f).name for f in files}
    found = []
    for rel in files:
        if in_roots(rel, roots):
            found += check_file(root, rel, basenames)
    return found


def test_checked_roots_stand_alone():
    found = check(ROOT, [f for f in tracked_files() if f != SELF], CHECKED_ROOTS)
    assert not found, "\n".join(found)


# --- the checker can fail -------------------------------------------------------------------


@pytest.fixture
def planted(tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "real.md").write_text("A real file.\n")
    return tmp_path


@pytest.mark.parametrize(
    "text, what",
    [
        ("Fixed in issue 7 of the tracker.\n", "tracker reference"),
        ("As issues 11 and 12 said.\n", "tracker reference"),
        ("See Issue #3.\n", "tracker reference"),
        ("The paper's text in /work/shared/paper/.\n", "outside the repository"),
        ("See [the contract](contract.md).\n", "link to contract.md"),
        ("See [the map](../hdl/missing.v#top).\n", "link to ../hdl/missing.v"),
        ("The style is in `NOTES.md`.\n", "cites NOTES.md"),
        ("The module `hdl/rtl/nowhere.v` does it.\n", "cites hdl/rtl/nowhere.v"),
    ],
)
def test_checker_finds_planted_failures(planted, text, what):
    (planted / "docs" / "bad.md").write_text(text)
    files = ["docs/real.md", "docs/bad.md"]
    found = check(planted, files, ["docs/"])
    assert len(found) == 1 and what in found[0], found


def test_checker_passes_what_exists_and_skips_what_is_not_a_citation(planted):
    (planted / "docs" / "good.md").write_text(
        "See [real](real.md), `docs/real.md`, [anchor](#top), [web](https://example.org/x.md)"
        " and `real.md`; a run writes `build/demo/result.json` and `DIR/audit.json`.\n"
        "```sh\nbowden audit rig/trace.csv   # issue 9 in a fenced block is still text\n```\n"
    )
    found = check(planted, ["docs/real.md", "docs/good.md"], ["docs/"])
    # The fenced block's command is skipped for paths, but a tracker number anywhere is found.
    assert found == ["docs/good.md:3: tracker reference 'issue 9': name the decision"], found


def test_checker_reads_only_its_roots(planted):
    (planted / "other.md").write_text("issue 7\n")
    assert check(planted, ["other.md", "docs/real.md"], ["docs/"]) == []
    assert len(check(planted, ["other.md"], ["other.md"])) == 1


# --- the named formal properties --------------------------------------------------------------


def _formal():
    from hdl.formal import formal

    return formal


def test_every_assertion_is_named_after_its_property():
    props, errors = _formal().properties()
    assert not errors, "\n".join(errors)
    assert len(props) >= 30  # every module's properties were read, not an empty folder


def test_property_table_in_hdl_readme_is_the_generated_one():
    formal = _formal()
    props, _ = formal.properties()
    text = (ROOT / "hdl" / "README.md").read_text()
    m = re.search(
        r"<!-- formal.py --properties: begin -->\n(.*?)<!-- formal.py --properties: end -->",
        text,
        re.S,
    )
    assert m, "hdl/README.md lost the markers of the named-property table"
    assert m.group(1) == formal.property_table(props), (
        "hdl/README.md's property table is stale: paste `python -m hdl.formal.formal --properties`"
    )


def test_property_check_fails_on_an_unlabelled_assertion(tmp_path):
    formal = _formal()
    (tmp_path / "m.v").write_text(
        "module m;\n`ifdef FORMAL\n// property m_ok: fine\nalways @* m_ok: assert(1);\n"
        "always @* assert(1);\n// property m_two: wrong label\nalways @* m_ok_2: assert(1);\n"
        "`endif\nendmodule\n"
    )
    props, errors = formal.properties(tmp_path)
    assert [p.name for p in props] == ["m_ok", "m_two"]
    assert any("labelled None, expected m_ok_2" in e for e in errors), errors
    assert any("labelled m_ok_2, expected m_two" in e for e in errors), errors


def test_a_missing_markdown_file_named_in_code_is_caught(planted):
    (planted / "tool.py").write_text('"""Plots are for a person (NOTES.md)."""\n')
    found = check(planted, ["docs/real.md", "tool.py"], [""])
    assert found == ["tool.py:1: cites NOTES.md, which the repository does not hold"], found
