"""The harness every closed-loop engine runs its loop in (the cocotb co-simulation, the native
loop and the float reference): the RTL top both RTL engines build (cosim_top.v), the sample
timing they keep, T_c as the RTL takes it at each sample (CommandTension), the plant handle set up
for a run, and the pre-allocated record of a run."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cosim.config.run import SimConfig
from cosim.parts import rtl_model
from cosim.parts.firmware import tension_word
from cosim.parts.plant import OUTPUT_NAMES
from cosim.project.paths import HDL_DIR

# The folder of cosim_top.v (the RTL top of both RTL engines) and cosim_top.vlt.
ENGINES_DIR = Path(__file__).resolve().parent

# Clocks per FPGA sample: the RTL's loop needs LATENCY_CLKS from its tick to the command; one
# more lets the command of sample k reach the plant and the ADC sample of t_k+1 reach tick k+1
# with no extra sample of delay (see cocotb/tb_closed_loop.py). cocotb costs about 1 us per
# clock, so this is kept at that minimum.
CLKS_PER_SAMPLE = rtl_model.LATENCY_CLKS + 1
# Clocks per sample of the pair's core (cosim_pair_top.v, bowden_core_mc with N = 2): its loops'
# 1 + 15 N = 31 clocks, then each bank's TC_EFF and FAULT read back (about 5 clocks each) and the
# firmware's words; the start-up's 17 words a cable before the first tick take the most, 68
# clocks with the native engine's bus master and 102 with cocotb's (3 clocks a write), of 128
# (the engines check that every write lands before its tick).
PAIR_CLKS_PER_SAMPLE = 128

# Samples between a firmware tick and the first FPGA sample that uses its T_c: the tick runs
# right after sample k's command is out, half a clock before tick k+1; its AXI write lands a few
# clocks later, so tick k+2 is the first to use it (checked in every co-simulation run through
# the TC_EFF read-back, cosim/engines/cocotb/tb_closed_loop.py).
TC_LATENCY_SAMPLES = 2


@dataclass
class CommandTension:
    """T_c as the RTL's loop takes it at each sample (tension_loop.v; the integer form is
    cosim.parts.rtl_model.TensionLoopModel.tick): the slew limit (CTRL.SLEW_EN) moves it by at
    most SLEW per sample towards the T_c written, then the floor TC_MIN holds it up. In double on
    Q7.8 values, so exact: every Python engine records the same T_c at every sample with it, and
    the native loop (native/closed_loop.cpp) does the same with the same two numbers."""

    slew_n: float  # SLEW, N per sample (Q7.8), as programmed; 0 with CTRL.SLEW_EN off
    floor_n: float  # TC_MIN, N (Q7.8), as fw_start writes it
    tc_n: float = 0.0  # T_c of the last sample (TC_EFF), 0 after reset

    @classmethod
    def programmed(cls, words: dict[str, int], tc_min_n: float) -> CommandTension:
        """The path as the firmware programs it: `words` the loop's register words
        (cosim.engines.fwbridge.loop_words), `tc_min_n` the compensator's floor in N."""
        lsb = 1 << rtl_model.TENSION_FRAC
        slew_n = words["slew"] / lsb if words["slew_en"] else 0.0
        return cls(slew_n=slew_n, floor_n=tension_word(tc_min_n) / lsb)

    def step(self, tc_set_n: float) -> float:
        """T_c of this sample (N) when `tc_set_n` is the T_c written and in force."""
        tc = self.tc_n
        if self.slew_n > 0.0:
            tc = min(max(tc_set_n, tc - self.slew_n), tc + self.slew_n)
        else:
            tc = tc_set_n
        tc = max(tc, self.floor_n)  # the floor after the slew limit
        self.tc_n = tc
        return tc


def rtl_sources() -> list[Path]:
    """The RTL of the core plus the engines' top (cosim_top.v)."""
    return sorted((HDL_DIR / "rtl").glob("*.v")) + [ENGINES_DIR / "cosim_top.v"]


# Recorded per FPGA sample (float64 arrays); cosim.engines.experiment.trace_columns maps them to
# the trace format.
RECORD_FIELDS = (
    "t_s",
    "T_ref_N",
    "T_c_N",
    "T_in_N",
    "T_out_N",
    "T_in_true_N",
    "T_out_true_N",
    "x_m",
    "y_m",
    "z_m",
    "current_A",
    "motor_angle_rad",
    "phi_rad",
)


# Plant outputs recorded at every sample (the sensors as the loop saw them, the true tensions, the
# motor angle and phi): FMU output name -> record field.
PLANT_RECORD = (
    ("T_in_meas", "T_in_N"),
    ("T_out_meas", "T_out_N"),
    ("T_in", "T_in_true_N"),
    ("T_out", "T_out_true_N"),
    ("motor_angle", "motor_angle_rad"),
    ("phi", "phi_rad"),
)


def plant_rows(plant, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A buffer for the plant's whole output array at each of n samples, and a numpy view of the
    plant's output array (cosim.parts.plant.Plant.y, refilled in place by every step): the
    per-sample loop copies a row with one `rows[k] = view`; store_plant_rows files the columns
    afterwards."""
    return np.zeros((n, len(OUTPUT_NAMES))), np.ctypeslib.as_array(plant.y)


def store_plant_rows(rec: dict[str, np.ndarray], rows: np.ndarray) -> None:
    """Copy the recorded plant outputs into the record's fields (PLANT_RECORD)."""
    for name, field in PLANT_RECORD:
        rec[field][:] = rows[:, OUTPUT_NAMES.index(name)]


def store_run(rec: dict[str, np.ndarray], rows: np.ndarray, inp) -> None:
    """The end of every engine's run: the plant's recorded rows (store_plant_rows) and the
    run's inputs (time, T_ref, the end-effector's position) into the record."""
    store_plant_rows(rec, rows)
    rec["t_s"][:] = inp.t_s
    rec["T_ref_N"][:] = inp.t_ref_n
    rec["x_m"][:], rec["y_m"][:], rec["z_m"][:] = inp.x_m, inp.y_m, inp.z_m


class PlantFeed:
    """The plant's side of one sample, as every engine that runs its loop in Python does it
    (`sample`): the plant's outputs recorded (the row in force while the loop computed sample
    k), the end-effector's position of sample k set, and the drive's current segments stepped
    (`drive`: the interface chain's, `(k, command) -> [(dt_s, current_a), ...]`). `rows` holds
    the recorded outputs for `store_run`."""

    def __init__(self, plant, inp, drive, n: int) -> None:
        self.rows, self._y_row = plant_rows(plant, n)
        self._xyz = list(zip(inp.x_m.tolist(), inp.y_m.tolist(), inp.z_m.tolist(), strict=True))
        self._u, self._step, self._drive = plant.u, plant.step, drive
        self.y = plant.y  # refilled in place by every step

    def sample(self, k: int, command):
        """Record sample k's outputs, set its position, drive the plant through the sample
        with `command` (the chain's input: a current word or amperes); the outputs after it."""
        self.rows[k] = self._y_row
        u = self._u
        u[2], u[3], u[4] = self._xyz[k]
        for dt_seg, current_a in self._drive(k, command):
            u[0] = current_a
            self._step(dt_seg)
        return self.y


@dataclass
class Record:
    """Pre-allocated buffers of one run, filled sample by sample."""

    arrays: dict[str, np.ndarray]

    @classmethod
    def allocate(cls, n: int) -> Record:
        return cls({name: np.zeros(n, dtype=np.float64) for name in RECORD_FIELDS})

    def save(self, path) -> None:
        np.savez(path, **self.arrays)

    @classmethod
    def load(cls, path) -> Record:
        with np.load(path) as data:
            return cls({name: data[name].copy() for name in data.files})


def open_plant(
    cfg: SimConfig,
    loop_routing: bool,
    position_m: tuple[float, float, float],
    fmu_path=None,
):
    """The plant FMU (cosim.parts.plant.Plant) instantiated for a closed-loop run: drive mode 0
    (current command), loop routing as asked, the run's parameter overrides, the end-effector at
    its start position, initialised at t = 0. fmu_path: another build of the FMU (the
    convergence study's variants); default build/fmu/BowdenPlant.fmu."""
    from cosim.parts.plant import Plant  # noqa: PLC0415 (the FMU's handle is imported when a run starts)

    params: dict[str, float | int | bool] = {"drive_mode": 0, "loop_routing": bool(loop_routing)}
    params.update(cfg.plant)
    x, y, z = (float(v) for v in position_m)
    return Plant(params=params, inputs={"x": x, "y": y, "z": z}, fmu_path=fmu_path)
