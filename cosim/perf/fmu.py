"""Benchmark of the plant FMU (`make perf-fmu`): wall time per simulated second at a 100 us
communication step, and the factor faster than real time. Prints figures; never fails on a slow
machine (the target, 20x real time through fmpy, is reported, not asserted).

    .venv/bin/python -m cosim.perf.fmu [--seconds 2]
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
import tempfile
import time

from cosim.parts.plant import FMU_PATH, Plant

STEP_S = 1e-4
TARGET_X_REAL_TIME = 20.0


def _line(what: str, wall_s: float, sim_s: float) -> None:
    per_sim_s = wall_s / sim_s
    print(
        f"  {what:<52} {per_sim_s * 1e3:8.1f} ms per simulated s "
        f"{1.0 / per_sim_s:8.1f}x real time {wall_s / (sim_s / STEP_S) * 1e6:7.2f} us/step"
    )


def bench_physics(sim_s: float, drive_mode: int) -> float:
    """One doStep of sim_s: the C physics alone, no per-call overhead."""
    with Plant({"drive_mode": drive_mode}, {"current_cmd": 1.5, "T_in_cmd": 10.0}) as plant:
        t0 = time.perf_counter()
        plant.step(sim_s)
        return time.perf_counter() - t0


def bench_fmpy(sim_s: float, with_io: bool) -> float:
    """fmpy's FMU2Slave: doStep per 100 us (and setReal/getReal through fmpy's wrappers)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    unzip_dir = extract(str(FMU_PATH), tempfile.mkdtemp(prefix="bowden_bench_"))
    md = read_model_description(unzip_dir)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(
        guid=md.guid,
        unzipDirectory=unzip_dir,
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="bench",
    )
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    n = int(round(sim_s / STEP_S))
    in_vr = [vr["current_cmd"], vr["x"], vr["y"], vr["z"]]
    out_vr = [vr[name] for name in ("T_in", "T_out", "T_in_meas", "T_out_meas", "phi")]
    t = 0.0
    t0 = time.perf_counter()
    if with_io:
        for k in range(n):
            fmu.setReal(in_vr, [1.5 + 0.5 * math.sin(k * 1e-3), 0.0, 0.6, -0.2])
            fmu.doStep(t, STEP_S)
            fmu.getReal(out_vr)
            t += STEP_S
    else:
        fmu.setReal([vr["current_cmd"]], [1.5])
        for _ in range(n):
            fmu.doStep(t, STEP_S)
            t += STEP_S
    wall = time.perf_counter() - t0
    fmu.terminate()
    fmu.freeInstance()
    shutil.rmtree(unzip_dir, ignore_errors=True)
    return wall


def bench_plant(sim_s: float, moving: bool) -> float:
    """cosim.parts.plant.Plant: set all inputs, doStep, get all outputs per 100 us sample."""
    with Plant() as plant:
        n = int(round(sim_s / STEP_S))
        u, step = plant.u, plant.step
        t0 = time.perf_counter()
        for k in range(n):
            u[0] = 1.5 + 0.5 * math.sin(k * 1e-3)
            if moving:  # a new position every sample: geometry recomputed each step
                u[3] = 0.5 + 0.15 * math.sin(k * 6.3e-5)
                u[2] = 0.05 * math.sin(k * 4.2e-5)
            step(STEP_S)
        return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated seconds per case")
    args = parser.parse_args(argv)
    if not FMU_PATH.exists():
        print(f"{FMU_PATH} is missing: run `make fmu`", file=sys.stderr)
        return 1
    sim = args.seconds
    print(f"BowdenPlant FMU benchmark: {sim:g} simulated s per case at a {STEP_S * 1e6:g} us step")
    _line("C physics alone, drive mode 0 (one long doStep)", bench_physics(sim, 0), sim)
    _line("C physics alone, drive mode 1 (one long doStep)", bench_physics(sim, 1), sim)
    fmpy_wall = bench_fmpy(sim, with_io=False)
    _line("fmpy FMU2Slave.doStep per step", fmpy_wall, sim)
    _line("fmpy setReal + doStep + getReal per step", bench_fmpy(sim, with_io=True), sim)
    _line("cosim.parts.plant.Plant.step (all inputs and outputs)", bench_plant(sim, False), sim)
    _line("cosim.parts.plant.Plant.step, end-effector moving", bench_plant(sim, True), sim)
    factor = sim / fmpy_wall
    verdict = "meets" if factor >= TARGET_X_REAL_TIME else "MISSES"
    print(
        f"  through fmpy the FMU runs {factor:.1f}x faster than real time: {verdict} the "
        f"target of {TARGET_X_REAL_TIME:g}x"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
