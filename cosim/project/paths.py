"""Where the project's sources and build outputs live.

The Python package runs the project's RTL (hdl/), firmware build and FMU build (build/). It
finds the project folder, the one holding ``hdl/rtl/bowden_core.v``, in this order:

1. the environment variable BOWDEN_ROOT, when set;
2. the folder above the package, when the package runs from the project itself (the editable
   install `make setup` makes);
3. the current folder or the nearest of its parents that holds the project (a wheel or
   `pip install .` used inside a checkout).

When none holds it, REPO_ROOT is the folder above the package and `require_project()` names what
is missing; commands that need only Python (`bowden workspace`) work anywhere.
"""

from __future__ import annotations

import os
from pathlib import Path

ROOT_ENV = "BOWDEN_ROOT"
# A file only the project folder has.
MARKER = Path("hdl") / "rtl" / "bowden_core.v"
PACKAGE_DIR = Path(__file__).resolve().parents[1]  # cosim/ (this file is cosim/project/paths.py)


def is_project(folder: Path) -> bool:
    """True when `folder` holds the project's sources."""
    return (folder / MARKER).is_file()


def find_root(env: dict[str, str] | None = None, cwd: Path | None = None) -> Path | None:
    """The project folder (see the module docstring), or None when there is none."""
    env = os.environ if env is None else env
    given = env.get(ROOT_ENV)
    if given:
        return Path(given).expanduser().resolve()
    if is_project(PACKAGE_DIR.parent):
        return PACKAGE_DIR.parent
    here = (Path.cwd() if cwd is None else cwd).resolve()
    for folder in (here, *here.parents):
        if is_project(folder):
            return folder
    return None


def require_project() -> Path:
    """The project folder; ValueError (one line, what to do) when it cannot be found."""
    root = find_root()
    if root is None:
        raise ValueError(
            f"cannot find the project folder (the one holding {MARKER}): run bowden inside "
            f"the project checkout or set {ROOT_ENV}"
        )
    if not is_project(root):
        raise ValueError(f"{ROOT_ENV}={root} does not hold the project ({MARKER} is missing)")
    return root


REPO_ROOT = find_root() or PACKAGE_DIR.parent
BUILD_DIR = REPO_ROOT / "build"
HDL_DIR = REPO_ROOT / "hdl"
FIRMWARE_DIR = REPO_ROOT / "firmware"
FMU_DIR = REPO_ROOT / "fmu"
