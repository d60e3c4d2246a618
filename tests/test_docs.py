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

It also fails on a repository path named in text that does not exist: in a markdown file's text
(fenced blocks included: a command names the script it runs) and in the comments and docstrings
of source files (Python, C and C++, Verilog, linker scripts, make files and the other `#`-comment
files), a path that starts with one of the repository's top-level folders (`cosim/`, `hdl/`,
`firmware/`, ...) and ends in an extension or a slash (`cosim/parts/rtl_model.py`, `hdl/rtl/`),
looked up from the repository root and from each folder above the file that names it
(`tests/test_comp.c` in firmware/ is firmware/tests/test_comp.c). Not checked: `build/`, what git
ignores (build outputs), globs (`hdl/rtl/*.v`), placeholders (`tests/hdl/test_<module>.py`),
module paths (`cosim/parts/rtl_model.adc_code_from_tension`: no extension) and string literals in
code, which name files a run reads or writes.

It also holds the named formal properties to their rule (hdl/README.md, "Named properties"):
every assertion labelled after its tag, and the README's table the one `formal.py
--properties` prints.
"""

from __future__ import annotations

import bisect
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

# Paths named in text and comments (path_refs): source files by how they write comments.
C_COMMENTS = {".c", ".h", ".cpp", ".S", ".ld", ".v", ".vh", ".sv", ".vlt"}
HASH_COMMENTS = {".mk", ".sh", ".yaml", ".yml", ".toml", ".core", ".pcf", ".lpf", ".sby", ".txt"}
HASH_COMMENT_NAMES = {"Makefile"}
# A file name's extension: short and alphanumeric (`rtl_model.adc_code_from_tension` is a
# module's function, not a file).
EXTENSION = re.compile(r"\.[A-Za-z][A-Za-z0-9]{0,5}$")
# What may follow a path that is not a path (a glob or a placeholder continues it).
NOT_A_PATH_AFTER = tuple("*?[{<$")
# Python's comments and the starts of its strings (_python_comments).
PY_TOKEN = re.compile(r"(?P<comment>#[^\n]*)|(?P<quote>[rRbBuUfF]{0,2}(?:\"\"\"|\'\'\'|\"|\'))")
LINK_TARGET = re.compile(r"\]\([^)\s]*\)")


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


def check_file(
    root: Path, rel: str, basenames: set[str], refs: re.Pattern | None = None
) -> list[str]:
    """Every finding in one tracked file, as `path:line: what`; `refs` (path_ref_pattern) finds
    the repository paths it names, which must exist."""
    path = root / rel
    if path.suffix not in TEXT_SUFFIXES or not path.is_file():
        return []
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        return []
    found = []
    if refs is not None:
        for n, ref in named_paths(rel, text, refs):
            if not _exists_above(ref, rel, root):
                found.append(f"{rel}:{n}: names {ref}, which does not exist")
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
                and not (refs is not None and refs.fullmatch(token))  # the path rule has it
                and not PLACEHOLDER.search(token)
                and not _exists(token, path, root)
            ):
                found.append(f"{rel}:{n}: cites {token}, which does not exist")
    return found


def check(root: Path, files: list[str], roots: list[str]) -> list[str]:
    basenames = {Path(f).name for f in files}
    refs = path_ref_pattern(top_folders(files))
    found = []
    for rel in files:
        if in_roots(rel, roots):
            found += check_file(root, rel, basenames, refs)
    return drop_ignored(root, found)


# --- repository paths named in text and comments ---------------------------------------------


def top_folders(files: list[str]) -> set[str]:
    """The repository's top-level folders (those of its tracked files), build/ aside."""
    return {f.split("/", 1)[0] for f in files if "/" in f} - {"build"}


def path_ref_pattern(tops: set[str]) -> re.Pattern | None:
    """A path that starts with a top-level folder: `hdl/rtl/x.v`, `cosim/parts/`. Not the tail of
    a longer path, a URL or a module path (`/work/hdl/x.v`, `../hdl/x.v`, `x.hdl/y`)."""
    if not tops:
        return None
    alt = "|".join(re.escape(t) for t in sorted(tops, key=len, reverse=True))
    return re.compile(rf"(?<![\w./~$@-])(?:{alt})/(?:[\w.+-]+/)*(?:[\w+-][\w.+-]*)?")


def named_paths(rel: str, text: str, refs: re.Pattern):
    """(line number, path) of each repository path a file names in its text (markdown) or its
    comments and docstrings (source files): module docstring's rules."""
    for n, line in commented_lines(rel, text):
        if rel.endswith(".md"):
            line = LINK_TARGET.sub("]()", line)  # a link's target is checked as a link
        for m in refs.finditer(line):
            ref = m.group(0).rstrip(".")
            name = ref.rsplit("/", 1)[-1]
            if not (ref.endswith("/") or EXTENSION.search(name)):
                continue  # a folder or a module named without a slash, or not a path
            if line[m.end() : m.end() + 1] in NOT_A_PATH_AFTER or PLACEHOLDER.search(ref):
                continue
            yield n, ref


def commented_lines(rel: str, text: str) -> list[tuple[int, str]]:
    """(line number, text) of what a file says to a reader: every line of a markdown file, the
    comments (and Python's docstrings) of a source file; nothing of other files."""
    p = Path(rel)
    if p.suffix == ".md":
        return list(enumerate(text.splitlines(), 1))
    if p.suffix == ".py":
        return _python_comments(text)
    if p.suffix in C_COMMENTS:
        return _c_comments(text)
    if p.suffix in HASH_COMMENTS or p.name in HASH_COMMENT_NAMES:
        return _hash_comments(text)
    return []


def _python_comments(text: str) -> list[tuple[int, str]]:
    """Comments and docstrings of Python source: a string that starts its line after a line that
    ends in `:` (a def's or class's) or at the top of the file; other strings are code."""
    starts = [0] + [k + 1 for k, ch in enumerate(text) if ch == "\n"]
    lines = text.split("\n")

    def line_of(i: int) -> int:
        return bisect.bisect_right(starts, i)

    out: list[tuple[int, str]] = []
    pos, last_code = 0, ""
    while m := PY_TOKEN.search(text, pos):
        code = text[pos : m.start()].strip()
        if code:
            last_code = code[-1]
        if m.group("comment"):
            out.append((line_of(m.start()), m.group("comment")))
            pos = m.end()
            continue
        delim = m.group("quote").lstrip("rRbBuUfF")
        i = m.end()
        while True:
            j = text.find(delim, i)
            if len(delim) == 1:
                nl = text.find("\n", i)
                if nl != -1 and (j == -1 or nl < j):
                    j = nl - len(delim)  # an unterminated string ends at its line
                    break
            if j == -1:
                j = len(text) - len(delim)
                break
            k = j
            while k > i and text[k - 1] == "\\":
                k -= 1
            if (j - k) % 2 == 0:
                break
            i = j + 1
        end = j + len(delim)
        first = line_of(m.start())
        at_line_start = not text[starts[first - 1] : m.start()].strip()
        if at_line_start and last_code in ("", ":"):
            last = line_of(end - 1)
            out += [(k, lines[k - 1]) for k in range(first, last + 1)]
        last_code = delim[-1]
        pos = end
    return out


CHAR_LITERAL = re.compile(r"'(\\.|[^'\\\n])'")


def _c_comments(text: str) -> list[tuple[int, str]]:
    """`//` and `/* */` comments of C, C++, Verilog or a linker script, string and character
    literals skipped."""
    out: list[tuple[int, str]] = []
    i, n, end = 0, 1, len(text)
    while i < end:
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = end if j < 0 else j
            out.append((n, text[i:j]))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = end if j < 0 else j + 2
            out += [(n + k, part) for k, part in enumerate(text[i:j].split("\n"))]
            n += text.count("\n", i, j)
            i = j
        elif text[i] == '"':
            j = i + 1
            while j < end and text[j] not in '"\n':
                j += 2 if text[j] == "\\" else 1
            i = j + 1 if j < end and text[j] == '"' else j
        elif text[i] == "'" and (m := CHAR_LITERAL.match(text, i)):
            i = m.end()
        else:
            n += text[i] == "\n"
            i += 1
    return out


def _hash_comments(text: str) -> list[tuple[int, str]]:
    """`#` comments (make, shell, YAML, TOML, ...): from a `#` outside quotes to the line's end."""
    out = []
    for n, line in enumerate(text.splitlines(), 1):
        quote = None
        for k, ch in enumerate(line):
            if quote:
                quote = None if ch == quote else quote
            elif ch in "\"'":
                quote = ch
            elif ch == "#":
                out.append((n, line[k:]))
                break
    return out


def _exists_above(ref: str, rel: str, root: Path) -> bool:
    """`ref` exists from the root or from a folder above `rel` (a part's own `tests/x.c`)."""
    folder = Path(rel).parent
    while True:
        if (root / folder / ref).exists():
            return True
        if folder == Path("."):
            return False
        folder = folder.parent


def drop_ignored(root: Path, found: list[str]) -> list[str]:
    """The findings but those naming a path git ignores (a build output, a generated file)."""
    named = {f.rsplit(": names ", 1)[1].split(",", 1)[0] for f in found if ": names " in f}
    if not named:
        return found
    try:
        out = subprocess.run(
            ["git", "check-ignore", "--no-index", "--stdin"],
            cwd=root,
            input="\n".join(sorted(named)),
            capture_output=True,
            text=True,
        )
    except OSError:
        return found
    ignored = set(out.stdout.splitlines()) if out.returncode in (0, 1) else set()
    return [
        f
        for f in found
        if not (": names " in f and f.rsplit(": names ", 1)[1].split(",", 1)[0] in ignored)
    ]


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


# --- the path checker can fail ---------------------------------------------------------------

# A small repository: one real file in each top-level folder the planted texts name.
REAL = [
    "docs/real.md",
    "hdl/rtl/tension_loop.v",
    "cosim/parts/rtl_model.py",
    "firmware/tests/test_comp.c",
    "tests/test_real.py",
    "mk/real.mk",
]


@pytest.fixture
def repo(tmp_path):
    for rel in REAL:
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text("real\n")
    return tmp_path


@pytest.mark.parametrize(
    "rel, text, line, ref",
    [
        ("docs/bad.md", "The model is cosim/rtl_model.py, in text.\n", 1, "cosim/rtl_model.py"),
        ("docs/bad.md", "See `hdl/rtl/gone.v`.\n", 1, "hdl/rtl/gone.v"),
        ("docs/bad.md", "```sh\npython hdl/formal/formal.py\n```\n", 2, "hdl/formal/formal.py"),
        ("docs/bad.md", "Its tests are in tests/cosim/.\n", 1, "tests/cosim/"),
        (
            "hdl/rtl/bad.v",
            "// The model: cosim/rtl_model.py.\nmodule bad;\n",
            1,
            "cosim/rtl_model.py",
        ),
        ("hdl/rtl/bad.v", "/*\n * Model: cosim/rtl_model.py\n */\n", 2, "cosim/rtl_model.py"),
        (
            "firmware/bad.c",
            "char c = '\"'; /* twin: cosim/geometry.py */\n",
            1,
            "cosim/geometry.py",
        ),
        ("cosim/bad.py", '"""Driven by hdl/rtl/gone.v."""\n', 1, "hdl/rtl/gone.v"),
        ("cosim/bad.py", "x = 1  # as hdl/rtl/gone.v does\n", 1, "hdl/rtl/gone.v"),
        ("cosim/bad.py", 'def f():\n    """Reads\n    cosim/gone/ first."""\n', 3, "cosim/gone/"),
        ("mk/bad.mk", "# built from firmware/src/gone.c\nall:\n", 1, "firmware/src/gone.c"),
    ],
)
def test_path_checker_finds_a_planted_stale_path(repo, rel, text, line, ref):
    (repo / rel).write_text(text)
    found = check(repo, [*REAL, rel], [rel])
    assert found == [f"{rel}:{line}: names {ref}, which does not exist"], found


def test_path_checker_passes_what_exists_and_what_is_not_a_path(repo):
    texts = {
        "docs/good.md": (
            "The model cosim/parts/rtl_model.py and `hdl/rtl/tension_loop.v`, the folder hdl/rtl/,"
            " a glob hdl/rtl/*.v, a placeholder `tests/hdl/test_<module>.py`, the function"
            " cosim/parts/rtl_model.adc_code_from_tension, output in build/demo/x.json and"
            " DIR/cosim/x.json, a URL https://example.org/hdl/rtl/gone.v, a relative"
            " ../cosim/gone.py and a [link](real.md).\n"
        ),
        # the part's own tests/ folder, and a string literal (a file a run writes)
        "firmware/src/good.c": '/* its tests: tests/test_comp.c */\nconst char *p = "hdl/x.v";\n',
        "cosim/good.py": 'PATH = "hdl/rtl/gone.v"\n\n\ndef f():\n    return "cosim/gone.py"\n',
        "mk/good.mk": "OUT := hdl/gone.v  # written by the rule below\n",
    }
    for rel, text in texts.items():
        (repo / rel).parent.mkdir(parents=True, exist_ok=True)
        (repo / rel).write_text(text)
    assert check(repo, [*REAL, *texts], list(texts)) == []


def test_path_checker_skips_what_git_ignores(repo):
    if subprocess.run(["git", "init", "-q"], cwd=repo).returncode:
        pytest.skip("git cannot make a repository here")
    (repo / ".gitignore").write_text("sim_build/\n")
    (repo / "docs" / "waves.md").write_text("The waves are in hdl/sim_build/dump.vcd.\n")
    (repo / "docs" / "bad.md").write_text("The waves are in hdl/waves/dump.vcd.\n")
    found = check(repo, [*REAL, "docs/waves.md", "docs/bad.md"], ["docs/"])
    assert found == ["docs/bad.md:1: names hdl/waves/dump.vcd, which does not exist"], found


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
