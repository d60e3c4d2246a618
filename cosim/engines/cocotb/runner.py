"""Build the RTL once per simulator and run the closed-loop cocotb test in a subprocess.

The run's specification (scenario, compensator, loop routing, configuration) goes to the test as
a JSON file named by the environment variable BOWDEN_COSIM_SPEC; the test writes its record
(.npz) and its cost split (JSON) to the paths given in the same file.

The Verilator build lives in build/cosim/<simulator>/ and is reused while the RTL sources and
the build parameters do not change (cocotb_tools.runner only rebuilds what changed).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import tempfile
import threading
from pathlib import Path

from cosim.engines.harness import CLKS_PER_SAMPLE, ENGINES_DIR, rtl_sources
from cosim.project import procs
from cosim.project.paths import BUILD_DIR, HDL_DIR
from cosim.project.toolchain import setup_env

TOPLEVEL = "cosim_top"
TEST_MODULE = "cosim.engines.cocotb.tb_closed_loop"

# A 100 MHz system clock (hdl default); simulated time is scaled so that CLKS_PER_SAMPLE clocks
# are one sample period of the plant (the RTL only counts clocks).
CLK_PERIOD_NS = 10


def build_dir(simulator: str) -> Path:
    return BUILD_DIR / "cosim" / simulator


def _make_runner(simulator: str, reuse: bool):
    """cocotb's runner for `simulator`, with two changes:

    - Verilator, for speed: cocotb builds with --public-flat-rw, which makes every internal signal
      visible and keeps Verilator from optimising the design; the co-simulation only touches
      cosim_top's ports, so only those are made public (cosim_top.vlt), and the model is compiled
      with -O2 rather than -Os. Measured on this machine: 48 -> 15 us per 10-clock sample.
    - reuse: build() only records its arguments (which test() needs) and runs no command, when the
      build folder holds a build of the same fingerprint;
    - every command (the build's, the simulator) runs in a process group of its own through
      cosim.project.procs, so that an interrupted `bowden` stops the simulator too.

    (Overrides a private method of cocotb_tools 2.1.0, pinned in requirements.txt; the build fails
    loudly if its command changes shape.)"""
    from cocotb_tools.runner import get_runner  # noqa: PLC0415

    base = type(get_runner(simulator))

    class ProjectRunner(base):
        def _build_command(self):
            if reuse:
                return []
            cmds = super()._build_command()
            if simulator == "verilator":
                if "--public-flat-rw" not in cmds[0] or cmds[1][0] != "make":
                    raise RuntimeError("cocotb_tools' Verilator build command changed shape")
                cmds[0].remove("--public-flat-rw")
                cmds[1] += ["OPT_FAST=-O2", "OPT_GLOBAL=-O2"]
            return cmds

        def _execute_cmds(self, cmds, cwd, stdout=None):
            stderr = None if stdout is None else subprocess.STDOUT
            for cmd in cmds:
                status = procs.run(cmd, cwd=cwd, env=self.env, stdout=stdout, stderr=stderr)
                if status != 0:
                    raise RuntimeError(f"Command failed with return code: {status}")

    return ProjectRunner()


def _fingerprint(simulator: str, parameters: dict, args: list[str]) -> str:
    """What the build depends on: sources' names and contents, parameters, arguments (with the
    harness's folder taken out: an installed package reuses the build of the same sources), tool
    versions."""
    import cocotb  # noqa: PLC0415

    h = hashlib.sha256()
    for path in [*rtl_sources(), ENGINES_DIR / "cosim_top.vlt"]:
        h.update(path.name.encode())
        h.update(path.read_bytes())
    args = [a.replace(str(ENGINES_DIR), "<engines>") for a in args]
    h.update(json.dumps([simulator, parameters, args, cocotb.__version__]).encode())
    return h.hexdigest()


def build(simulator: str = "verilator", clks_per_sample: int = CLKS_PER_SAMPLE):
    """Build the simulation of cosim_top, or reuse it when nothing it depends on changed (a
    fingerprint in the build folder); return the cocotb runner."""
    setup_env()
    if simulator not in ("verilator", "icarus"):
        raise ValueError(f"simulator must be verilator or icarus; got {simulator!r}")
    if simulator == "icarus" and shutil.which("iverilog") is None:
        raise RuntimeError("--simulator icarus: iverilog is not installed (apt install iverilog)")
    args: list[str] = []
    if simulator == "verilator":
        # No tracing, X's resolved at compile time: the closed loop is bound by per-clock cost.
        args = [
            str(ENGINES_DIR / "cosim_top.vlt"),
            "-O3",
            "--x-assign",
            "fast",
            "--x-initial",
            "fast",
        ]
    params = {"CLKS_PER_SAMPLE": clks_per_sample}
    out = build_dir(simulator)
    stamp = out / "fingerprint.txt"
    fingerprint = _fingerprint(simulator, params, args)
    built = (out / TOPLEVEL).exists() or (out / "sim.vvp").exists()
    reuse = built and stamp.is_file() and stamp.read_text() == fingerprint
    runner = _make_runner(simulator, reuse)
    out.mkdir(parents=True, exist_ok=True)
    if not reuse:
        stamp.unlink(missing_ok=True)
    runner.build(
        sources=rtl_sources(),
        includes=[HDL_DIR / "rtl"],
        hdl_toplevel=TOPLEVEL,
        build_dir=out,
        parameters=params,
        build_args=args,
        always=True,
        log_file=None if reuse else out / "build.log",
    )
    if not reuse:
        # Written once per build, atomically: parallel runs read it while others reuse the build.
        tmp_stamp = stamp.with_name(f"{stamp.name}.{os.getpid()}")
        tmp_stamp.write_text(fingerprint)
        os.replace(tmp_stamp, stamp)
    return runner


def run_closed_loop(
    run_spec: dict,
    simulator: str = "verilator",
    work_dir: Path | None = None,
    progress: bool = True,
) -> tuple[dict, dict]:
    """Run one closed-loop co-simulation; return (record arrays, cost split in seconds).

    The simulator's own output goes to WORK/sim.log; the progress bar is drawn here from the
    progress file the testbench updates (a few times a second), so it stays one clean line.
    """
    from cosim.engines.harness import Record  # noqa: PLC0415
    from cosim.project.progress import Progress  # noqa: PLC0415

    runner = build(simulator)
    tmp = None
    if work_dir is None:
        tmp = tempfile.TemporaryDirectory(prefix="bowden-cosim-")
        work = Path(tmp.name)
    else:
        # Absolute: the simulator runs in another folder and reads the paths of the spec.
        work = Path(work_dir).absolute()
    work.mkdir(parents=True, exist_ok=True)
    spec = dict(run_spec)
    spec["record_path"] = str(work / "fixed_record.npz")
    spec["cost_path"] = str(work / "fixed_cost.json")
    spec["progress_path"] = str(work / "progress.txt")
    spec["clks_per_sample"] = CLKS_PER_SAMPLE
    spec["clk_period_ns"] = CLK_PERIOD_NS
    spec_path = work / "spec.json"
    spec_path.write_text(json.dumps(spec, indent=2))
    for stale in (spec["record_path"], spec["cost_path"], spec["progress_path"]):
        Path(stale).unlink(missing_ok=True)
    env = {
        "BOWDEN_COSIM_SPEC": str(spec_path),
        "COCOTB_LOG_LEVEL": os.environ.get("COCOTB_LOG_LEVEL", "WARNING"),
        # Writes go straight to the simulator instead of waiting for a ReadWrite phase: one
        # callback less per sample. Safe here: the harness writes only between clock edges.
        "COCOTB_TRUST_INERTIAL_WRITES": "1",
        # cocotbext-axi 0.1.28 uses APIs that cocotb 2.x deprecates; keep the log readable.
        "PYTHONWARNINGS": "ignore::DeprecationWarning",
    }
    cfg = run_spec["config"]
    rate = float(cfg.get("sample_rate_hz", 10_000.0))
    total = max(1, int(round(float(run_spec["duration_s"]) * rate)))
    bar = Progress(total, f"fixed point ({simulator})", rate, enabled=progress)
    outcome: dict = {}

    def target():
        try:
            outcome["xml"] = runner.test(
                test_module=TEST_MODULE,
                hdl_toplevel=TOPLEVEL,
                build_dir=build_dir(simulator),
                test_dir=work,
                extra_env=env,
                results_xml=str(work / "results.xml"),
                log_file=work / "sim.log",
            )
        except BaseException as exc:  # noqa: BLE001 (re-raised in the caller's thread)
            outcome["error"] = exc

    try:
        worker = threading.Thread(target=target, daemon=True)
        worker.start()
        try:
            while worker.is_alive():
                worker.join(0.25)
                bar.update(_read_progress(spec["progress_path"]))
        except BaseException:
            # Interrupted (SIGINT, SIGTERM through cosim.cli): the simulator runs in the worker
            # thread, in a process group of its own; end it before going on.
            procs.stop_all()
            bar.abandon()
            raise
        bar.close(_read_progress(spec["progress_path"]))
        if "error" in outcome:
            raise RuntimeError(
                f"the closed-loop simulation failed ({outcome['error']}); see {work / 'sim.log'}"
            )
        failed = _failures(Path(outcome["xml"]))
        if failed:
            raise RuntimeError(f"closed-loop cocotb test failed: {failed}; see {work / 'sim.log'}")
        if not Path(spec["record_path"]).is_file():
            raise RuntimeError(f"the cocotb test wrote no record ({spec['record_path']})")
        rec = Record.load(spec["record_path"]).arrays
        cost = json.loads(Path(spec["cost_path"]).read_text())
        Path(spec["record_path"]).unlink()  # the caller writes what it keeps (trace.csv)
    finally:
        if tmp is not None:
            tmp.cleanup()
    return rec, cost


def _read_progress(path: str) -> int:
    """Samples done, as the testbench last wrote them (0 before its first report)."""
    try:
        return int(Path(path).read_text().strip() or 0)
    except (OSError, ValueError):
        return 0


def _failures(results_xml: Path) -> str:
    """The failure messages of a cocotb results file ('' when every test passed)."""
    import xml.etree.ElementTree as ET  # noqa: PLC0415

    if not results_xml.is_file():
        return f"no results file {results_xml}"
    root = ET.parse(results_xml).getroot()
    msgs = []
    for case in root.iter("testcase"):
        for tag in ("failure", "error"):
            for node in case.iter(tag):
                msgs.append(f"{case.get('name')}: {node.get('message') or node.text or tag}")
    return "; ".join(msgs)


def main(argv: list[str] | None = None) -> int:
    """`python -m cosim.engines.cocotb.runner build [verilator|icarus]`: build the simulation."""
    import sys  # noqa: PLC0415

    args = sys.argv[1:] if argv is None else argv
    if not args or args[0] != "build" or len(args) > 2:
        print(
            "usage: python -m cosim.engines.cocotb.runner build [verilator|icarus]",
            file=sys.stderr,
        )
        return 2
    simulator = args[1] if len(args) == 2 else "verilator"
    build(simulator)
    print(f"built {build_dir(simulator)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
