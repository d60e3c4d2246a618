#!/usr/bin/env python3
"""The FMU's reference output: a short simulation whose result the tests compare to.

    .venv/bin/python -m fmu.make_reference       # rewrite fmu/reference/*.csv
    fmpy simulate build/fmu/BowdenPlant.fmu --input-file fmu/reference/BowdenPlant_in.csv ...

The run (0.4 s, 100 us step through fmpy.simulate_fmu, outputs every 1 ms): drive mode 0 with a
current ramp, a 10 Hz sine and a drop to slack, the end-effector moving in and out of the
loop's plane, and the stateful effects on (sensor noise, lag and delay), so that a change to any
part of the physics shows up. Rewrite the reference only for an intended change of the model,
and say why in the commit.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from cosim.parts.plant import FMU_PATH, OUTPUT_NAMES

HERE = Path(__file__).resolve().parent

INPUT_CSV = HERE / "reference" / "BowdenPlant_in.csv"
REF_CSV = HERE / "reference" / "BowdenPlant_ref.csv"
START_VALUES = {"noise_std": 0.05, "seed": 42, "sensor_tau": 0.002, "sensor_delay": 0.001}
OUTPUTS = list(OUTPUT_NAMES)  # every output of the FMU, in the order cosim.parts.plant reads them
STOP_TIME_S = 0.4
STEP_S = 1e-4
OUTPUT_INTERVAL_S = 1e-3


def input_signals() -> np.ndarray:
    """Piecewise-linear input table (fmpy interpolates between the rows)."""
    t = np.round(np.arange(0.0, STOP_TIME_S + 1e-9, 5e-3), 6)
    current = np.where(t < 0.1, 20 * t, 2.0) + np.where(
        (t >= 0.1) & (t < 0.3), 0.5 * np.sin(2 * np.pi * 10 * (t - 0.1)), 0.0
    )
    current = np.where(t >= 0.3, -0.3, current)
    rows = np.zeros(
        len(t), dtype=[(n, np.float64) for n in ("time", "current_cmd", "T_in_cmd", "x", "y", "z")]
    )
    rows["time"] = t
    rows["current_cmd"] = current
    rows["x"] = 0.2 * np.sin(2 * np.pi * 2.5 * t)
    rows["y"] = 0.6
    rows["z"] = -0.2 + 0.1 * t
    return rows


def simulate(fmu_path: str | Path) -> np.ndarray:
    """Run the reference simulation on the FMU at fmu_path; returns fmpy's structured array."""
    from fmpy import simulate_fmu

    return simulate_fmu(
        str(fmu_path),
        stop_time=STOP_TIME_S,
        step_size=STEP_S,
        output_interval=OUTPUT_INTERVAL_S,
        start_values=START_VALUES,
        input=input_signals(),
        output=OUTPUTS,
    )


def main(argv: list[str]) -> int:
    from fmpy.util import write_csv

    fmu_path = argv[1] if len(argv) > 1 else FMU_PATH
    INPUT_CSV.parent.mkdir(exist_ok=True)
    write_csv(str(INPUT_CSV), input_signals())
    write_csv(str(REF_CSV), simulate(fmu_path))
    print(f"wrote {INPUT_CSV} and {REF_CSV}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
