"""The bench protocol's C side: unit tests (one pytest case per C test, plain and under UBSan +
ASan) and the bounded random/mutation fuzzer of the decoder and device (>= 1M frames, ASan +
UBSan). All three programs are built by `make bench-build` (part of `make test`'s build step)."""

import re
import subprocess

import pytest

from cosim.project.paths import BUILD_DIR

HOST = BUILD_DIR / "bench" / "host"
UNIT = HOST / "bench_unit_tests"
UNIT_SAN = HOST / "bench_unit_tests_san"
FUZZ = HOST / "proto_fuzz_san"


def _names() -> list[str]:
    if not UNIT.exists():
        return ["<bench_unit_tests not built>"]
    out = subprocess.run([str(UNIT), "--list"], check=True, capture_output=True, text=True)
    return out.stdout.split()


@pytest.mark.parametrize("name", _names())
def test_bench_c_unit(name):
    assert UNIT.exists(), f"{UNIT} is missing: run `make bench-build`"
    run = subprocess.run([str(UNIT), name], capture_output=True, text=True, timeout=120)
    print(run.stdout)
    assert run.returncode == 0, run.stdout + run.stderr
    assert f"PASS {name} " in run.stdout
    assert run.stdout.rstrip().endswith("0 failed")


def test_bench_c_unit_under_sanitizers():
    """Every C test under UBSan and ASan (no recovery): no overflow, no out-of-bounds access."""
    assert UNIT_SAN.exists(), f"{UNIT_SAN} is missing: run `make bench-build`"
    run = subprocess.run([str(UNIT_SAN)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-4000:]
    assert "runtime error" not in run.stderr and "AddressSanitizer" not in run.stderr
    assert run.stdout.rstrip().endswith("0 failed")
    assert int(run.stdout.rstrip().splitlines()[-1].split()[0]) == len(_names())


def test_bench_fuzz_one_million_frames():
    """1M random and mutated frames through the decoder (and every 8th round the device) under
    ASan + UBSan: no crash, no hang (timeout), every intact frame received after any damage,
    and nothing accepted whose CRC the harness's own CRC-32C refuses."""
    assert FUZZ.exists(), f"{FUZZ} is missing: run `make bench-build`"
    run = subprocess.run(
        [str(FUZZ), "--frames", "1000000", "--seed", "1"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-4000:]
    m = re.search(
        r"(\d+) frames \((\d+) intact, (\d+) mutated\), \d+ bytes, (\d+) accepted "
        r"\((\d+) CRCs rechecked\), (\d+) rejected",
        run.stdout,
    )
    assert m, run.stdout
    frames, intact, mutated, accepted, rechecked, rejected = map(int, m.groups())
    assert frames == 1_000_000 and intact + mutated == frames
    assert rechecked == accepted >= intact  # every accepted frame's CRC was checked again
    assert mutated > 500_000 and rejected > 400_000  # the mutations did reach the checks
