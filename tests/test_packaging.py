"""Packaging: the wheel carries every file of the package and its `bowden sim` runs
from a scratch venv; the declared dependencies cover what the package imports; the FuseSoC
core lists the files the Makefile builds; the GitHub Actions workflow runs what .ci/run runs.
"""

from __future__ import annotations

import ast
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from importlib import metadata
from pathlib import Path

import pytest
import yaml

from cosim.project.paths import BUILD_DIR, REPO_ROOT


def _git_files(*paths: str) -> list[str]:
    """Files git tracks, or would track (new and not ignored), under `paths`."""
    out = subprocess.run(
        ["git", "ls-files", "-co", "--exclude-standard", "--", *paths],
        cwd=REPO_ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    return sorted(f for f in out if (REPO_ROOT / f).is_file())


def _make_var(name: str) -> list[str]:
    """The value of a make variable of the top-level Makefile, as words."""
    out = subprocess.run(
        ["make", "-s", "--no-print-directory", "--eval", "print-%: ; @echo $($*)", f"print-{name}"],
        cwd=REPO_ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    return out.split()


# --- the wheel --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel built by the package's build backend (setuptools, as pip and `build` call it)
    from a copy of the package's files, so that nothing is written into the checkout."""
    src = tmp_path_factory.mktemp("src")
    for name in _git_files("pyproject.toml", "README.md", "cosim"):
        (src / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(REPO_ROOT / name, src / name)
    dist = tmp_path_factory.mktemp("dist")
    code = "import sys; from setuptools import build_meta as b; print(b.build_wheel(sys.argv[1]))"
    res = subprocess.run(
        [sys.executable, "-c", code, str(dist)], cwd=src, capture_output=True, text=True
    )
    assert res.returncode == 0, res.stdout + res.stderr
    return dist / res.stdout.split()[-1]


def test_wheel_holds_every_file_of_the_package(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    missing = [f for f in _git_files("cosim") if f not in names]
    assert not missing, f"the wheel leaves out {missing}"
    assert {"cosim/engines/cosim_top.v", "cosim/engines/cosim_top.vlt"} <= names
    assert not [n for n in names if n.endswith((".pyc", ".pyo")) or "__pycache__" in n]
    entry = next(n for n in names if n.endswith(".dist-info/entry_points.txt"))
    assert "bowden = cosim.__main__:run" in zipfile.ZipFile(wheel).read(entry).decode()


def test_wheel_installed_in_a_scratch_venv_runs_a_1s_sim(wheel, tmp_path):
    """`bowden` from the wheel, in a venv of its own, run from a folder outside the checkout
    with BOWDEN_ROOT naming it: a 1 s fig14 run through the RTL, firmware and FMU. The scratch
    venv takes the dependencies from the project's venv (a .pth line) instead of installing them
    again; the package itself comes only from the wheel."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    py = venv / "bin" / "python"
    purelib = Path(
        subprocess.run(
            [str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    )
    deps = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
    (purelib / "_project_venv.pth").write_text("\n".join(sorted(deps)) + "\n")
    install = subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(py), "install", "--quiet", "--no-deps"]
        + ["--no-index", str(wheel)],
        capture_output=True,
        text=True,
    )
    assert install.returncode == 0, install.stdout + install.stderr
    where = subprocess.run(
        [str(py), "-c", "import cosim; print(cosim.__file__)"],
        capture_output=True,
        text=True,
        check=True,
        cwd=tmp_path,
    ).stdout.strip()
    assert where.startswith(str(purelib)), where  # the wheel's copy, not the checkout

    build_log = BUILD_DIR / "cosim" / "verilator" / "build.log"
    built_at = build_log.stat().st_mtime_ns if build_log.exists() else None
    env = dict(os.environ, BOWDEN_ROOT=str(REPO_ROOT))
    env.pop("VIRTUAL_ENV", None)
    run = subprocess.run(
        [str(venv / "bin" / "bowden"), "sim", "fig14", "--duration", "1", "--out", "out"]
        + ["--quiet"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=env,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    result = json.loads((tmp_path / "out" / "result.json").read_text())
    # The run is whole (the closed-loop suite holds its figures to their budgets).
    assert result["samples"] == 10_000 and result["checks"]["tc_eff_mismatches"] == 0
    assert (tmp_path / "out" / "trace.csv").is_file()
    # The Verilator build of the same sources was reused, not redone from the wheel's copy.
    assert (build_log.stat().st_mtime_ns if build_log.exists() else None) == built_at


def test_bowden_finds_the_project_from_a_checkout_folder_or_bowden_root(tmp_path):
    from cosim.project.paths import find_root

    sub = REPO_ROOT / "hdl" / "rtl"
    assert find_root(env={}, cwd=sub) == REPO_ROOT
    assert find_root(env={"BOWDEN_ROOT": str(REPO_ROOT)}, cwd=tmp_path) == REPO_ROOT


def test_declared_dependencies_cover_what_the_package_imports(wheel):
    """Every distribution that provides a module imported anywhere in cosim/ is a dependency of
    the wheel (pyproject.toml); installed with its dependencies, it would otherwise not import."""
    zf = zipfile.ZipFile(wheel)
    meta = zf.read(next(n for n in zf.namelist() if n.endswith(".dist-info/METADATA"))).decode()
    declared = {
        re.split(r"[<>=!~ \[;(]", line.split(":", 1)[1].strip(), maxsplit=1)[0]
        .lower()
        .replace("_", "-")
        for line in meta.splitlines()
        if line.startswith("Requires-Dist:")
    }
    assert declared
    providers = metadata.packages_distributions()
    needed: dict[str, set[str]] = {}
    for path in sorted((REPO_ROOT / "cosim").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                if top in sys.stdlib_module_names or top == "cosim":
                    continue
                for dist in providers.get(top, [top]):
                    needed.setdefault(dist.lower().replace("_", "-"), set()).add(
                        str(path.relative_to(REPO_ROOT))
                    )
    missing = {d: sorted(files) for d, files in needed.items() if d not in declared}
    assert not missing, f"add to [project] dependencies in pyproject.toml: {missing}"


# --- the FuseSoC core -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def core():
    from fusesoc.capi2.coreparser import Core2Parser
    from fusesoc.core import Core

    return Core(Core2Parser(), REPO_ROOT / "bowden.core")  # validated against the CAPI2 schema


@pytest.fixture(scope="module")
def boards():
    """The board table that make synth and make bitstream read (hdl/boards/table.py)."""
    from hdl.boards import table

    return table.BOARDS


def _files(core, target: str) -> dict[str, str]:
    flags = {"is_toplevel": True, "target": target}
    return {f["name"]: f["file_type"] for f in core.get_files(flags)}


def test_fusesoc_core_lists_the_makefiles_rtl(core):
    rtl = _make_var("HDL_RTL")
    assert rtl, "make printed no HDL_RTL"
    assert sorted(_files(core, "lint")) == rtl
    assert core.get_toplevel({"is_toplevel": True, "target": "lint"}) == "bowden_system"


def test_fusesoc_core_has_lint_sim_and_synth_of_each_board(core, boards):
    """bowden.core is written by hand (a user's file, with its comments, read by fusesoc); each
    board's facts in it are the board table's, field for field: top, pin file, device, package,
    speed grade, nextpnr's options and the target clock."""
    rtl = _make_var("HDL_RTL")
    stubs = _make_var("HDL_BOARD_STUBS")
    tops = _make_var("HDL_BOARD_TOPS")
    assert sorted(f"hdl/boards/{b.rtl.top}.v" for b in boards.values()) == tops
    raw = yaml.safe_load((REPO_ROOT / "bowden.core").read_text())["targets"]
    for board in boards.values():
        name = board.name.replace("-", "_")
        design = board.rtl
        top = f"hdl/boards/{design.top}.v"
        constraints = str(design.constraints.relative_to(REPO_ROOT))
        kind = "PCF" if board.fpga.family == "ice40" else "LPF"
        for target in (f"lint_{name}", f"sim_{name}"):
            files = _files(core, target)
            assert sorted(f for f, t in files.items() if t == "verilogSource") == sorted(
                rtl + stubs + [top]
            ), target
            assert core.get_toplevel({"is_toplevel": True, "target": target}) == design.top
        synth = f"synth_{name}"
        files = _files(core, synth)
        assert files == {**dict.fromkeys(rtl, "verilogSource"), top: "verilogSource"} | {
            constraints: kind
        }, synth
        flags = {"is_toplevel": True, "target": synth}
        assert core.get_toplevel(flags) == design.top
        tool = "icestorm" if board.fpga.family == "ice40" else "trellis"
        assert raw[synth]["default_tool"] == tool, synth
        opts = core.get_tool_options({**flags, "tool": tool})["nextpnr_options"]
        # one seed of make synth's order: fusesoc places once
        assert opts[-2] == "--seed" and int(opts[-1]) >= 1, synth
        assert opts[:-2] == [
            *board.fpga.nextpnr_args,
            *design.nextpnr_options,
            "--freq",
            f"{design.target_mhz:g}",
        ], synth
        description = raw[synth]["description"]
        assert f"{design.target_mhz:g} MHz target" in description, synth
        assert board.fpga.package.upper() in description.upper(), synth


def test_fusesoc_core_check_fails_on_a_board_fact_changed(core, boards):
    """The check above fails when the table and bowden.core disagree on one fact."""
    import dataclasses

    from hdl.boards import table

    b = boards["ecp5-25f"]
    changed = dataclasses.replace(b, fpga=dataclasses.replace(b.fpga, speed="8"))
    with pytest.raises(AssertionError, match="synth_ecp5_25f"):
        test_fusesoc_core_has_lint_sim_and_synth_of_each_board(
            core, {**table.BOARDS, "ecp5-25f": changed}
        )


# --- the hosted CI workflow -------------------------------------------------------------------


def test_github_workflow_runs_ci_run_with_the_venv_cached_on_its_inputs():
    flow = yaml.safe_load((REPO_ROOT / ".github" / "workflows" / "ci.yml").read_text())
    steps = flow["jobs"]["test"]["steps"]
    assert any(s.get("run", "").strip() == "bash .ci/run" for s in steps)
    cache = next(s for s in steps if str(s.get("uses", "")).startswith("actions/cache@"))
    assert ".venv" in cache["with"]["path"].split()
    # The key changes whenever the Makefile would rebuild the venv (its stamp's prerequisites).
    database = subprocess.run(
        ["make", "-p", "-n", "-q", "setup"], cwd=REPO_ROOT, capture_output=True, text=True
    ).stdout
    line = next(x for x in database.splitlines() if x.startswith(".venv/.installed:"))
    inputs = line.split(":", 1)[1].split()
    assert inputs
    for name in inputs:
        assert f"'{name}'" in cache["with"]["key"], name
