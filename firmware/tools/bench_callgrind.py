"""Instructions per compensator step, counted by valgrind's callgrind on the host.

    python -m firmware.tools.bench_callgrind BENCH_EXE [--steps N] [--json OUT]

Runs BENCH_EXE (firmware/perf/perf_comp.c) under callgrind with collection switched on only
inside comp_step_q7_8, for each scenario, and prints instructions per step (total Ir / steps).
The count is deterministic for a given binary. Target: <= 100 per step (firmware/README.md,
Measured figures). Without valgrind on PATH it says so and exits 0 (a benchmark must not fail on
a machine without it).
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

SCENARIOS = ("paper", "smooth", "smooth-blend")
TARGET_PER_STEP = 100


def count_per_step(exe: Path, scenario: str, steps: int) -> float:
    """Instructions executed inside comp_step_q7_8 per call, for one scenario."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "callgrind.out"
        subprocess.run(
            [
                "valgrind",
                "--tool=callgrind",
                "--toggle-collect=comp_step_q7_8",
                f"--callgrind-out-file={out}",
                str(exe),
                scenario,
                str(steps),
            ],
            check=True,
            capture_output=True,
            text=True,
        )
        text = out.read_text()
    m = re.search(r"^(?:summary|totals):\s+(\d+)", text, re.MULTILINE)
    if m is None:
        raise RuntimeError(f"no instruction total in the callgrind output of {scenario}")
    return int(m.group(1)) / steps


def measure(exe: Path, steps: int = 20000) -> dict[str, float] | None:
    """Instructions per step by scenario, or None when valgrind is not installed."""
    if shutil.which("valgrind") is None:
        return None
    return {s: count_per_step(exe, s, steps) for s in SCENARIOS}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("exe", type=Path)
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    result = measure(args.exe, args.steps)
    if result is None:
        print("perf-firmware: valgrind not found on PATH: instructions per step NOT measured")
        return 0
    print(f"compensator step on the host (callgrind, {args.steps} steps of the Fig. 14 sine):")
    for scenario, per_step in result.items():
        verdict = "meets" if per_step <= TARGET_PER_STEP else "MISSES"
        print(
            f"  {scenario:<13} {per_step:7.2f} instructions per step "
            f"({verdict} the target of {TARGET_PER_STEP})"
        )
    if args.json is not None:
        args.json.write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
