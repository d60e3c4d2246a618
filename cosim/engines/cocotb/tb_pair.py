"""The antagonistic pair in closed loop on the RTL core for N cables (cocotb 2.x): the pair's
world (cosim.engines.antagonist.PairSim: both cables' firmware, interface stages and plant FMUs,
and the joint) around cosim_pair_top.v, bowden_core_mc with two cables in one safety group, as a
board would run it: each cable's firmware writes its own bank of the register file over the
core's AXI4-Lite bus, and the loops read the banks at the core's own sample tick.

Started inside the simulator by the pytest of tests/cosim/test_antagonist.py, on a build of
cosim_pair_top (its CLKS_PER_SAMPLE, below). The run's specification is the JSON file named by
BOWDEN_PAIR_SPEC: duration_s, compensator, est_enable, fault (null or {"cable", "kind", "t_s"})
and out, the .npz the record is written to (the pytest compares it with the engines' records).

Per sample, in the period before the core's tick k: the words each firmware wrote since the
last tick, to its bank (regmap.bank_addr), then both cables' ADC codes of the step as one
conversion (the ADC strobe of cosim_pair_top); both must be done before the tick (the bench
checks the ticks' spacing), so the loops take them at tick k as the model takes them. At
cmd_valid (LATENCY = 1 + 15 N clocks after the tick) the bench takes the commands and enables
from the ports and reads back each bank's TC_EFF (the T_c the loop used) and FAULT over the
bus; the group stops, which no register shows, come from the top's hierarchical tap.

Clocks per sample: harness.PAIR_CLKS_PER_SAMPLE (128; the pytest builds the top with it). The
period holds the loops' 31 clocks, the four read-backs and the firmware's TC writes (one per
cable every firmware tick); the longest is the start-up's, every register of both banks (17
words each) in the period before the first tick. The bench records the least slack it saw
(clocks left before a tick once its writes and ADC strobe are done) and fails at a late tick.
"""

from __future__ import annotations

import json
import os

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.simtime import get_sim_time
from cocotb.triggers import FallingEdge, RisingEdge

from cosim.config.antagonist import get_antagonist
from cosim.config.run import SimConfig
from cosim.engines.antagonist import PairSim, pair_fault
from cosim.engines.harness import PAIR_CLKS_PER_SAMPLE as CLKS_PER_SAMPLE
from cosim.parts import regmap
from cosim.parts.rtl_model import LoopOutput

from . import fastio
from .axil import LeanAxiLiteMaster

N = 2
CLK_NS = 10
_CODE_MASK = (1 << 24) - 1


def _field(word: int, k: int, bits: int, is_signed: bool = False) -> int:
    v = (word >> (k * bits)) & ((1 << bits) - 1)
    return v - (1 << bits) if is_signed and v >> (bits - 1) else v


class BankChannel:
    """One cable's side of the core as PairSim's channel: the firmware's bus words
    (write_word(addr, word), for this cable's bank) and the step's ADC code (adc_sample), both
    held until the bench's next tick."""

    def __init__(self) -> None:
        self.writes: list[tuple[int, int]] = []
        self.code: int | None = None

    def write_word(self, addr: int, word: int) -> None:
        self.writes.append((addr, word))

    def adc_sample(self, code: int) -> None:
        self.code = code


class CorePair:
    """cosim_pair_top behind its bus: `channels[i]` takes cable i's words and samples, `await
    tick()` lands them before the core's next tick and returns the two LoopOutputs and group
    stops of that tick."""

    def __init__(self, dut) -> None:
        self.dut = dut
        self.channels = [BankChannel() for _ in range(N)]
        self.toggle = self.codes = 0
        self.last_tick_ns: int | None = None
        self.least_slack_clks = CLKS_PER_SAMPLE
        self.cmd_current = fastio.unsigned_reader(dut.cmd_current)
        self.cmd_enable = fastio.unsigned_reader(dut.cmd_enable)
        self.grp_stop = fastio.unsigned_reader(dut.grp_stop)
        self.bus: LeanAxiLiteMaster | None = None

    async def start(self) -> None:
        d = self.dut
        cocotb.start_soon(Clock(d.clk, CLK_NS, unit="ns").start())
        d.adc_word.value = 0
        self.bus = LeanAxiLiteMaster(d, "s_axil", d.clk)
        d.rst.value = 1
        for _ in range(3):
            await FallingEdge(d.clk)
        d.rst.value = 0

    async def tick(self) -> tuple[list[LoopOutput], list[bool]]:
        d, bus = self.dut, self.bus
        for i, c in enumerate(self.channels):
            for addr, word in c.writes:
                await bus.write_dword(regmap.bank_addr(i, addr), word)
            c.writes = []
        if any(c.code is not None for c in self.channels):
            # a cable's toggle flips when its sample is new (both: one conversion)
            for k, c in enumerate(self.channels):
                if c.code is not None:
                    self.toggle ^= 1 << (48 + k)
                    self.codes &= ~(_CODE_MASK << (24 * k))
                    self.codes |= (c.code & _CODE_MASK) << (24 * k)
                    c.code = None
            # 50 bits: past the fast writer's 32, cocotb's `.value` (once a sample)
            d.adc_word.value = self.toggle | self.codes
        done_ns = get_sim_time("ns")
        await RisingEdge(d.sample_tick)
        now_ns = get_sim_time("ns")
        period_ns = CLKS_PER_SAMPLE * CLK_NS
        if self.last_tick_ns is not None and now_ns - self.last_tick_ns != period_ns:
            raise AssertionError(
                f"the writes and the ADC strobe missed a tick ({now_ns - self.last_tick_ns} ns "
                f"after the last, period {period_ns} ns)"
            )
        self.last_tick_ns = now_ns
        self.least_slack_clks = min(self.least_slack_clks, (now_ns - done_ns) // CLK_NS)
        await RisingEdge(d.cmd_valid)
        u, en, stop = self.cmd_current(), self.cmd_enable(), self.grp_stop()
        outs = []
        for k in range(N):
            tc_eff = await bus.read_dword(regmap.bank_addr(k, regmap.TC_EFF))
            faults = await bus.read_dword(regmap.bank_addr(k, regmap.FAULT))
            outs.append(
                LoopOutput(
                    u=_field(u, k, 16, True),
                    out_en=bool(_field(en, k, 1)),
                    saturated=False,  # (not recorded by PairSim)
                    wdt_ramp=False,
                    faults=faults & 0xF,
                    t_in=0,
                    integ=0,
                    tc_eff=_field(tc_eff, 0, 16, True),
                    sample_count=0,
                )
            )
        return outs, [bool(_field(stop, k, 1)) for k in range(N)]


@cocotb.test()
async def pair_closed_loop(dut):
    """The pair's closed loop on bowden_core_mc for the specification's duration (and fault);
    the record goes to the specification's .npz."""
    with open(os.environ["BOWDEN_PAIR_SPEC"]) as f:
        spec = json.load(f)
    cfg = SimConfig.from_dict({"compensator": {"est_enable": spec["est_enable"]}})
    loop = CorePair(dut)
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
        least_slack_clks=loop.least_slack_clks,
        **arrays,
    )
