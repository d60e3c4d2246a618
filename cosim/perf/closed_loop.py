"""Closed-loop speed benchmark (`make perf-cosim`, part of `make perf`).

Runs the 30 s fig14 scenario (compensator paper, loop routing) through the RTL on Verilator at
the default 10 kHz loop with the firmware and the FMU, and prints simulated seconds per wall
second and the cost split: RTL (Verilator and cocotb's per-clock scheduling, calibrated on bare
samples), FMU steps, firmware ticks, and the harness (AXI4-Lite driver coroutines and per-sample
glue). Targets: real time or better, and harness <= RTL + FMU + firmware. Then the
same run on the native engine (cosim/engines/native; target 20x real time or better) and its
speed against the cocotb runs of the same invocation. A benchmark prints figures and does not
fail on a slow or busy machine.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

from cosim.config.run import COMPENSATORS


def _spec(duration_s: float, compensator: str, bus: str, plant: dict | None = None) -> dict:
    from cosim.config.run import SimConfig  # noqa: PLC0415
    from cosim.config.scenarios import get_scenario
    from cosim.engines.reference import resolve_phi  # noqa: PLC0415

    cfg = SimConfig.from_dict({"plant": plant or {}})
    return {
        "scenario": "fig14",
        "compensator": compensator,
        "loop_routing": True,
        "duration_s": duration_s,
        "phi_rad": resolve_phi(get_scenario("fig14"), cfg, True),
        "config": cfg.to_dict(),
        "bus": bus,
    }


def bench_native(duration_s: float, compensator: str, cocotb_wall: dict[str, float]) -> None:
    """The same run on the native engine, beside the cocotb figures of this invocation."""
    from cosim.engines.native import engine  # noqa: PLC0415

    engine.load_library()
    spec = _spec(duration_s, compensator, "native")
    cpu0 = time.process_time()
    t0 = time.perf_counter()
    _, cost = engine.run_closed_loop(spec, progress=False)
    wall = time.perf_counter() - t0
    # CPU seconds of this process: on a machine shared with other jobs the wall time also holds
    # the time the run waited for a core.
    cpu = time.process_time() - cpu0
    n = cost["samples"]
    sim_s = n / 10_000.0
    loop = cost["total_s"]
    print(f"closed loop, native engine (cosim/native): fig14 {compensator}, loop routing, ", end="")
    print(f"{sim_s:g} s simulated")
    print(f"  wall time, whole run (FMU and firmware set-up included): {wall:7.2f} s")
    print(f"  wall time, closed loop:                                  {loop:7.2f} s")
    print(f"  simulated seconds per wall second (whole run):           {sim_s / wall:7.2f}")
    print(f"  simulated seconds per wall second (closed loop):         {sim_s / loop:7.2f}")
    print(f"  simulated seconds per CPU second (whole run):            {sim_s / cpu:7.2f}")
    try:
        print(f"  load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    except OSError:
        pass
    for name, label in (
        ("rtl_s", "RTL (Verilator, 1-2 eval per clock, bus)"),
        ("fmu_s", "FMU (fmi2DoStep)"),
        ("firmware_s", "firmware (fw_host_tick)"),
        ("harness_s", "harness (interface stage, glue)"),
    ):
        v = cost[name]
        print(f"    {label:<40}{v:8.3f} s {100 * v / loop:5.1f} %  {1e6 * v / n:7.2f} us/sample")
    for bus, other in cocotb_wall.items():
        print(f"  native vs cocotb ({bus}), whole run:  {other / wall:7.1f} times faster")
    print(
        f"  target 20x real time (wall <= {sim_s / 20:g} s): "
        f"{'met' if sim_s / wall >= 20 else 'NOT met'} (x{sim_s / wall:.1f}); per CPU second "
        f"{'met' if sim_s / cpu >= 20 else 'NOT met'} (x{sim_s / cpu:.1f}; on a shared machine "
        "the wall time also holds the waits for a core)"
    )
    # The FMU at the step it had before its convergence study chose 100 us (fmu/README.md).
    fast = _spec(duration_s, compensator, "native", {"max_step": 5e-5})
    t0 = time.perf_counter()
    _, cost = engine.run_closed_loop(fast, progress=False)
    wall = time.perf_counter() - t0
    print(
        f"  with plant.max_step 50 us (the default before the convergence study): {wall:.2f} s "
        f"wall, x{sim_s / wall:.1f} real time "
        f"(FMU {1e6 * cost['fmu_s'] / n:.2f} us/sample)"
    )


def bench_one(duration_s: float, compensator: str, bus: str) -> float:
    """One closed-loop run and its figures."""
    from cosim.config.run import SimConfig  # noqa: PLC0415
    from cosim.engines.cocotb import runner  # noqa: PLC0415

    cfg = SimConfig()
    runner.build("verilator")
    spec = _spec(duration_s, compensator, bus)
    t0 = time.perf_counter()
    _, cost = runner.run_closed_loop(spec, progress=False)
    wall = time.perf_counter() - t0
    sim_s = cost["samples"] / cfg.sample_rate_hz
    loop = cost["total_s"]
    parts = {k: cost[k] for k in ("rtl_s", "fmu_s", "firmware_s", "harness_s")}
    own = parts["rtl_s"] + parts["fmu_s"] + parts["firmware_s"]
    n = cost["samples"]
    try:
        load = os.getloadavg()[0]
    except OSError:
        load = float("nan")

    print(f"closed loop, bus driver {bus}: fig14 {compensator}, loop routing, ", end="")
    print(f"{sim_s:g} s simulated at {cfg.sample_rate_hz:g} Hz, Verilator,")
    print(f"  {cost['clks_per_sample']} clocks per sample, load average {load:.2f} (2 cores)")
    print(f"  wall time, whole run (simulator start-up included): {wall:7.2f} s")
    print(f"  wall time, closed loop:                             {loop:7.2f} s")
    print(f"  simulated seconds per wall second (whole run):      {sim_s / wall:7.2f}")
    print(f"  simulated seconds per wall second (closed loop):    {sim_s / loop:7.2f}")
    # The simulator's CPU time over the loop: the figure of a quiet machine on a shared one.
    print(f"  simulated seconds per CPU second (closed loop):     {sim_s / cost['cpu_s']:7.2f}")
    print("  cost split of the closed loop:")
    for name, label in (
        ("rtl_s", "RTL (Verilator + cocotb clocks)"),
        ("fmu_s", "FMU (doStep through ctypes)"),
        ("firmware_s", "firmware (fw_tick, ctypes)"),
        ("harness_s", "harness (AXI driver + glue)"),
    ):
        v = parts[name]
        print(f"    {label:<34}{v:8.2f} s {100 * v / loop:5.1f} %  {1e6 * v / n:7.1f} us/sample")
    print(f"      of which AXI4-Lite transactions {cost['bus_s']:8.2f} s")
    print(
        f"  target real time (wall <= {sim_s:g} s):  "
        f"{'met' if wall <= sim_s else 'NOT met'} ({wall:.1f} s)"
    )
    print(
        f"  target harness <= RTL + FMU + firmware ({own:.2f} s): "
        f"{'met' if parts['harness_s'] <= own else 'NOT met'} ({parts['harness_s']:.2f} s)"
    )
    return wall


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m cosim.perf.closed_loop", description=__doc__)
    parser.add_argument("--duration", type=float, default=30.0, help="simulated seconds")
    parser.add_argument("--compensator", default="paper", choices=COMPENSATORS)
    parser.add_argument(
        "--bus",
        choices=("cocotbext-axi", "lean", "both", "none"),
        default="both",
        help="AXI driver of the cocotb runs (none: the native engine only)",
    )
    parser.add_argument("--no-native", action="store_true", help="skip the native engine")
    args = parser.parse_args(argv)
    buses = {"both": ("cocotbext-axi", "lean"), "none": ()}.get(args.bus, (args.bus,))
    walls = {bus: bench_one(args.duration, args.compensator, bus) for bus in buses}
    if not args.no_native:
        bench_native(args.duration, args.compensator, walls)
    return 0


if __name__ == "__main__":
    sys.exit(main())
