"""The firmware's C unit tests (firmware/tests/*.c), one pytest case per C test.

The host unit-test program is built by `make firmware` (part of `make test`'s build step).
Each case runs the program filtered to one test and fails with the program's own messages.
"""

import subprocess

import pytest

from cosim.project.paths import BUILD_DIR

UNIT = BUILD_DIR / "firmware" / "host" / "fw_unit_tests"
UNIT_SAN = BUILD_DIR / "firmware" / "host" / "fw_unit_tests_san"


def _names() -> list[str]:
    if not UNIT.exists():
        return ["<fw_unit_tests not built>"]
    out = subprocess.run([str(UNIT), "--list"], check=True, capture_output=True, text=True)
    return out.stdout.split()


@pytest.mark.parametrize("name", _names())
def test_fw_unit(name):
    assert UNIT.exists(), f"{UNIT} is missing: run `make firmware`"
    run = subprocess.run([str(UNIT), name], capture_output=True, text=True, timeout=120)
    print(run.stdout)
    assert run.returncode == 0, run.stdout + run.stderr
    assert f"PASS {name} " in run.stdout
    assert run.stdout.rstrip().endswith("0 failed")


def test_fw_unit_program_counts_every_test():
    """The whole program: the summary counts every listed test and no failure."""
    run = subprocess.run([str(UNIT)], capture_output=True, text=True, timeout=300)
    names = _names()
    assert run.returncode == 0, run.stdout
    assert run.stdout.rstrip().splitlines()[-1].startswith(f"{len(names)} tests, ")
    assert sum(line.startswith("PASS ") for line in run.stdout.splitlines()) == len(names)


def test_fw_unit_program_under_sanitizers():
    """The whole program built with UBSan and ASan (no recovery): every test passes without a
    signed overflow, an out-of-range shift or an out-of-bounds access anywhere, including the
    full-scale and random-word runs of the compensator."""
    assert UNIT_SAN.exists(), f"{UNIT_SAN} is missing: run `make firmware`"
    run = subprocess.run([str(UNIT_SAN)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-4000:]
    assert "runtime error" not in run.stderr and "AddressSanitizer" not in run.stderr
    assert run.stdout.rstrip().endswith("0 failed")
