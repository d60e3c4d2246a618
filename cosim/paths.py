"""Where the project's sources and build outputs live (the package is installed editable)."""

from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
BUILD_DIR = REPO_ROOT / "build"
HDL_DIR = REPO_ROOT / "hdl"
FIRMWARE_DIR = REPO_ROOT / "firmware"
FMU_DIR = REPO_ROOT / "fmu"
