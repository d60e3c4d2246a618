"""The antagonistic pair in closed loop on the RTL tension_loop_mc (cocotb 2.x): the pair's world
(cosim.engines.antagonist.PairSim: both cables' firmware, interface stages and plant FMUs, and
the joint) around the Verilog two-channel loop, both channels in one safety group.

Started inside the simulator by the pytest of tests/cosim/test_antagonist.py, on a build of
tension_loop_mc with N = 2 and GROUP 0 for both channels. The run's specification is the JSON
file named by BOWDEN_PAIR_SPEC: duration_s, compensator, est_enable, fault (null or
{"cable", "kind", "t_s"}) and out, the .npz the record is written to (the pytest compares it
with the engines' records).

Per tick: the writes the firmware made since the last tick, as a register file would hold them,
are on the configuration ports (TC's write, CTRL's INTEG_RESET and FAULT_CLEAR as one-clock
pulses) and each channel's ADC sample on adc_valid / adc_data, all in the tick's clock (what
tension_loop_mc takes at the tick: its header); the outputs are read at out_valid, 1 + 15 N
clocks later, and handed to PairSim. Ticks are 1 + 15 N + 1 clocks apart (the loop's minimum
plus one idle clock); the plant's time does not depend on the clock, as in the other engines.
"""

from __future__ import annotations

import json
import os

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge

from cosim.config.antagonist import get_antagonist
from cosim.config.run import SimConfig
from cosim.engines.antagonist import PairSim, pair_fault
from cosim.parts import regmap
from cosim.parts.rtl_model import LATENCY_CLKS, LoopOutput

# Register -> configuration port of tension_loop_mc (channel k in bits [k*width +: width]).
PORTS = {
    "TC": "tc",
    "TC_MIN": "tc_min",
    "KFF": "kff",
    "UFF": "uff",
    "KP": "kp",
    "KI_TS": "ki_ts",
    "I_LIMIT": "i_limit",
    "SLEW": "slew",
    "WDT_TIMEOUT": "wdt_timeout",
    "ADC_OFFSET": "adc_offset",
    "ADC_GAIN": "adc_gain",
    "ADC_MIN": "adc_min",
    "ADC_MAX": "adc_max",
    "ADC_STALE": "adc_stale",
    "OC_TIMEOUT": "oc_timeout",
}
N = 2


def _pack(values, bits: int) -> int:
    return sum((int(v) & ((1 << bits) - 1)) << (k * bits) for k, v in enumerate(values))


def _field(word: int, k: int, bits: int, is_signed: bool = False) -> int:
    v = (word >> (k * bits)) & ((1 << bits) - 1)
    return v - (1 << bits) if is_signed and v >> (bits - 1) else v


class RegisterBank:
    """One channel's register file as the loop sees it: write(name, value) as
    rtl_model.TensionLoopModel takes it (field values, CTRL's bit mask), adc_sample(code); the
    events (TC written, the CTRL pulses, a new sample) wait for the next tick."""

    def __init__(self) -> None:
        self.regs = {name: regmap.REGISTERS[name].fields[0].reset for name in PORTS}
        self.ctrl = 0
        self.clear_events()

    def clear_events(self) -> None:
        self.tc_wr = self.integ_reset = self.fault_clear = False
        self.code: int | None = None

    def write(self, name: str, value: int) -> None:
        if name == "CTRL":
            self.ctrl = value
            self.integ_reset |= bool(value & regmap.CTRL_INTEG_RESET)
            self.fault_clear |= bool(value & regmap.CTRL_FAULT_CLEAR)
            return
        if name not in self.regs:
            raise ValueError(f"{name} is not a configuration register of tension_loop_mc")
        regmap.encode(name, value)  # range check with a clear message
        self.regs[name] = value
        self.tc_wr |= name == "TC"

    def adc_sample(self, code: int) -> None:
        self.code = code


class McLoop:
    """tension_loop_mc (N = 2) behind two register banks: `channels[i]` takes channel i's writes
    and samples, `await tick()` runs one period and returns the two LoopOutputs and group stops."""

    def __init__(self, dut) -> None:
        self.dut = dut
        self.channels = [RegisterBank() for _ in range(N)]
        self.latency = 1 + LATENCY_CLKS * N

    async def start(self) -> None:
        d = self.dut
        cocotb.start_soon(Clock(d.clk, 10, unit="ns").start())
        for sig in (d.tick, d.adc_valid, d.adc_data, d.enable, d.slew_en):
            sig.value = 0
        for sig in (d.integ_reset, d.fault_clear, d.tc_wr):
            sig.value = 0
        self._drive()
        d.rst.value = 1
        for _ in range(3):
            await FallingEdge(d.clk)
        d.rst.value = 0
        await FallingEdge(d.clk)

    def _drive(self) -> None:
        d, chans = self.dut, self.channels
        for name, port in PORTS.items():
            width = regmap.REGISTERS[name].fields[0].width
            getattr(d, port).value = _pack([c.regs[name] for c in chans], width)
        d.enable.value = _pack([c.ctrl & regmap.CTRL_ENABLE for c in chans], 1)
        d.slew_en.value = _pack([bool(c.ctrl & regmap.CTRL_SLEW_EN) for c in chans], 1)

    async def tick(self) -> tuple[list[LoopOutput], list[bool]]:
        d, chans = self.dut, self.channels
        self._drive()
        d.tc_wr.value = _pack([c.tc_wr for c in chans], 1)
        d.integ_reset.value = _pack([c.integ_reset for c in chans], 1)
        d.fault_clear.value = _pack([c.fault_clear for c in chans], 1)
        d.adc_valid.value = _pack([c.code is not None for c in chans], 1)
        d.adc_data.value = _pack([c.code or 0 for c in chans], 24)
        for c in chans:
            c.clear_events()
        d.tick.value = 1
        await FallingEdge(d.clk)
        d.tick.value = 0
        d.adc_valid.value = d.tc_wr.value = d.integ_reset.value = d.fault_clear.value = 0
        await ClockCycles(d.clk, self.latency - 1, rising=False)
        if not d.out_valid.value:
            raise AssertionError(f"out_valid not {self.latency} clocks after the tick")
        words = {
            p: int(getattr(d, p).value)
            for p in ("u", "out_en", "saturated", "wdt_ramp", "faults", "t_in", "integ")
            + ("tc_eff", "grp_stop")
        }
        count = int(d.sample_count.value)
        outs = [
            LoopOutput(
                u=_field(words["u"], k, 16, True),
                out_en=bool(_field(words["out_en"], k, 1)),
                saturated=bool(_field(words["saturated"], k, 1)),
                wdt_ramp=bool(_field(words["wdt_ramp"], k, 1)),
                faults=_field(words["faults"], k, 4),
                t_in=_field(words["t_in"], k, 16, True),
                integ=_field(words["integ"], k, 32, True),
                tc_eff=_field(words["tc_eff"], k, 16, True),
                sample_count=count,
            )
            for k in range(N)
        ]
        await FallingEdge(d.clk)  # one idle clock before the next tick
        return outs, [bool(_field(words["grp_stop"], k, 1)) for k in range(N)]


@cocotb.test()
async def pair_closed_loop(dut):
    """The pair's closed loop on the RTL for the specification's duration (and fault); the
    record goes to the specification's .npz."""
    with open(os.environ["BOWDEN_PAIR_SPEC"]) as f:
        spec = json.load(f)
    cfg = SimConfig.from_dict({"compensator": {"est_enable": spec["est_enable"]}})
    loop = McLoop(dut)
    await loop.start()
    sim = PairSim(
        get_antagonist(),
        cfg,
        spec["compensator"],
        loop,
        spec["duration_s"],
        fault=pair_fault(spec["fault"]),
    )
    try:
        for k in sim.ticks():
            sim.feed(k)
            outs, stops = await loop.tick()
            sim.step(k, outs, stops)
    finally:
        rec = sim.finish()
    arrays = {f"c{i}_{name}": v for i, c in enumerate(rec.cables) for name, v in c.items()}
    np.savez(
        spec["out"],
        theta_rad=rec.theta_rad,
        omega_rad_s=rec.omega_rad_s,
        faults=rec.faults,
        out_en=rec.out_en,
        grp_stop=rec.grp_stop,
        **arrays,
    )
