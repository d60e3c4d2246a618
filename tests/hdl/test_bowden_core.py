"""Testbench of hdl/rtl/bowden_core.v: AXI4-Lite registers (cocotbext-axi) and the loop.

The core runs at its minimum of 15 clocks per sample, as the co-simulation runs it. A monitor
watches the bus and ports every clock and replays into the bit-exact model what the RTL sees at
each clock edge: ADC samples, sample ticks and register writes, in the RTL's order (a write that
completes on a tick edge counts for the next sample). Every cmd_valid is compared to the model.

Built in two configurations: `mcu` (the defaults of the external-MCU boards: three-clock read,
configuration snapshot at the tick) and `soc` (bowden_soc's RD_STAGES 1, SNAPSHOT 0: one-clock
read, the loop reads the live registers and the bus holds a write while a sample is in flight).
At 15 clocks per sample the soc configuration holds writes 14 clocks of every 15, so nearly
every write of the random test is held; the monitor counts them and the longest hold.
"""

from __future__ import annotations

import os
import random
from collections import deque

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, RisingEdge
from cocotbext.axi import AxiLiteBus, AxiLiteMaster
from hdl_sim import (
    ADDR_TO_NAME,
    SIMULATOR_PARAMS,
    replay_write,
    rtl,
    run_cocotb,
    signed,
)

from cosim.parts import regmap
from cosim.parts.regmap import FAULT_WATCHDOG
from cosim.parts.rtl_model import TensionLoopModel, adc_code_from_tension

CLKS_PER_SAMPLE = 15
RESP_OKAY, RESP_SLVERR = 0, 2
CONFIGS = {
    "mcu": {},
    "soc": {"RD_STAGES": 1, "SNAPSHOT": 0},
}
MAX_HOLD_CLKS = 14  # tension_loop's cfg_busy: the tick clock and the 13 after it


class CoreTb:
    """Clock, reset, AXI master, ADC driver and the model-replaying monitor."""

    def __init__(self, dut):
        self.dut = dut
        self.model = TensionLoopModel()
        self.expected: deque = deque()
        self.compared = 0
        self.axi: AxiLiteMaster | None = None
        self.config = os.environ.get("BOWDEN_CORE_CONFIG", "mcu")
        self.held_writes = 0  # writes that waited for the hold
        self.hold_run = 0  # clocks the current write has been held
        self.max_hold = 0

    async def start(self) -> None:
        cocotb.start_soon(Clock(self.dut.clk, 10, unit="ns").start())
        self.dut.adc_valid.value = 0
        self.dut.adc_data.value = 0
        self.dut.rst.value = 1
        await FallingEdge(self.dut.clk)
        # Created once reset is driven: the master watches it and must not see X.
        self.axi = AxiLiteMaster(
            AxiLiteBus.from_prefix(self.dut, "s_axil"), self.dut.clk, self.dut.rst
        )
        await self.reset()
        cocotb.start_soon(self.monitor())

    async def reset(self) -> None:
        self.dut.rst.value = 1
        await ClockCycles(self.dut.clk, 3)
        await FallingEdge(self.dut.clk)
        self.model.reset()
        self.expected.clear()
        self.dut.rst.value = 0

    async def monitor(self) -> None:
        """Mid-cycle, look at what the next rising edge captures and replay it in order."""
        d = self.dut
        while True:
            await FallingEdge(d.clk)
            if d.rst.value:
                continue
            if d.cmd_valid.value:
                assert self.expected, "cmd_valid without a sample tick"
                exp = self.expected.popleft()
                got = (signed(int(d.cmd_current.value), 16), bool(d.cmd_enable.value))
                want = (exp.u, exp.out_en)
                assert got == want, f"sample {exp.sample_count}: RTL {got} != model {want}"
                assert bool(d.fault.value) == (exp.faults != 0)
                self.compared += 1
            if d.adc_valid.value:
                self.model.adc_sample(signed(int(d.adc_data.value), 24))
            if d.sample_tick.value:
                self.expected.append(self.model.tick())
            waiting = d.s_axil_awvalid.value and d.s_axil_wvalid.value
            if waiting and not d.s_axil_awready.value and not d.s_axil_bvalid.value:
                self.hold_run += 1  # a write the bus could take, held
                self.max_hold = max(self.max_hold, self.hold_run)
            elif waiting and d.s_axil_awready.value:
                self.held_writes += self.hold_run > 0
                self.hold_run = 0
            if d.s_axil_awvalid.value and d.s_axil_wvalid.value and d.s_axil_awready.value:
                replay_write(
                    self.model,
                    int(d.s_axil_awaddr.value),
                    int(d.s_axil_wdata.value),
                    int(d.s_axil_wstrb.value),
                )

    async def adc_stream(self, tension_n, rng: random.Random) -> None:
        """ADC samples at random phases, tension from `tension_n(k)`.

        Driven after rising edges, like the AXI master, so that the monitor sees them settled.
        """
        d = self.dut
        k = 0
        while True:
            await ClockCycles(d.clk, rng.randint(1, CLKS_PER_SAMPLE - 1))
            d.adc_valid.value = 1
            d.adc_data.value = adc_code_from_tension(tension_n(k)) & 0xFFFFFF
            await RisingEdge(d.clk)
            d.adc_valid.value = 0
            k += 1

    async def write(self, name: str, value: int) -> None:
        """Register write of a field value (two's complement for signed fields)."""
        resp = await self.axi.write(
            regmap.REGISTERS[name].addr, (value & 0xFFFFFFFF).to_bytes(4, "little")
        )
        assert int(resp.resp) == RESP_OKAY, f"write {name}={value}: response {resp.resp}"

    async def read(self, name: str) -> int:
        """Register read, decoded as the field's value (sign-extended when signed)."""
        return regmap.decode(name, await self.axi.read_dword(regmap.REGISTERS[name].addr))


@cocotb.test()
async def registers_over_axi(dut):
    """Reset values, read-back of every writable register, strobes, read-only and SLVERR."""
    tb = CoreTb(dut)
    await tb.start()
    assert await tb.axi.read_dword(regmap.ID) == 0x424F0100
    for name, reg in regmap.REGISTERS.items():
        f = reg.fields[0]
        if f.access == "rw" and len(reg.fields) == 1:
            got = await tb.read(name)
            assert got == f.reset, f"{name} resets to {got}, expected {f.reset}"
    rng = random.Random(1)
    for name, reg in regmap.REGISTERS.items():
        f = reg.fields[0]
        if f.access != "rw" or len(reg.fields) != 1 or name == "TC":
            continue
        for value in (f.min, f.max, rng.randint(f.min, f.max)):
            await tb.axi.write_dword(reg.addr, value & 0xFFFFFFFF)
            got = await tb.read(name)
            assert got == value, f"{name}: wrote {value}, read {got}"
    # Bits beyond a field read as zero (or as the sign extension).
    await tb.axi.write_dword(regmap.I_LIMIT, 0xFFFFFFFF)
    assert await tb.axi.read_dword(regmap.I_LIMIT) == 0x7FFF
    await tb.axi.write_dword(regmap.TC, 0x0001_8000)
    assert await tb.axi.read_dword(regmap.TC) == 0xFFFF_8000
    # Byte strobes: only byte 1 of KP changes.
    await tb.axi.write_dword(regmap.KP, 0x1234)
    await tb.axi.write(regmap.KP + 1, b"\xab")
    assert await tb.axi.read_dword(regmap.KP) == 0xFFFF_AB34
    # CTRL pulse bits read 0; ENABLE and SLEW_EN read back.
    await tb.axi.write_dword(regmap.CTRL, 0xF)
    assert await tb.axi.read_dword(regmap.CTRL) == regmap.CTRL_ENABLE | regmap.CTRL_SLEW_EN
    await tb.axi.write_dword(regmap.CTRL, 0)
    # Read-only registers ignore writes; unmapped addresses answer SLVERR.
    await tb.axi.write_dword(regmap.ID, 0)
    assert await tb.axi.read_dword(regmap.ID) == 0x424F0100
    bad = 0xFC
    assert bad not in ADDR_TO_NAME
    rresp = await tb.axi.read(bad, 4)
    assert int(rresp.resp) == RESP_SLVERR and rresp.data == bytes(4)
    wresp = await tb.axi.write(bad, bytes(4))
    assert int(wresp.resp) == RESP_SLVERR
    assert int((await tb.axi.read(regmap.ID, 4)).resp) == RESP_OKAY
    # Concurrent reads and writes complete in order and intact.
    values = [rng.randint(-32768, 32767) for _ in range(8)]
    await cocotb.triggers.Combine(
        *[
            cocotb.start_soon(tb.axi.write_dword(regmap.KFF + 4 * (i % 2), v & 0xFFFFFFFF))
            for i, v in enumerate(values)
        ]
    )
    assert {await tb.read("KFF"), await tb.read("KP")} <= set(values)


@cocotb.test()
async def loop_through_axi_against_model(dut):
    """Random AXI writes at random times with an ADC stream: every command equals the model."""
    tb = CoreTb(dut)
    await tb.start()
    rng = random.Random(6)
    await tb.write("WDT_TIMEOUT", 50)
    await tb.write("ADC_STALE", 3)
    await tb.write("TC", 10 * 256)
    cocotb.start_soon(tb.adc_stream(lambda k: 8.0 + 4.0 * ((k // 40) % 2), rng))
    await tb.write("CTRL", regmap.CTRL_ENABLE)
    for _ in range(400):
        what = rng.random()
        if what < 0.5:
            await tb.write("TC", rng.randint(-20 * 256, 40 * 256))
        elif what < 0.6:
            await tb.write(rng.choice(["KFF", "KP"]), rng.randint(-32768, 32767))
        elif what < 0.65:
            await tb.write("KI_TS", rng.randint(-32768, 32767))
        elif what < 0.7:
            await tb.write("I_LIMIT", rng.choice([2048, 8192, 16384, 32767]))
        elif what < 0.75:
            pulse = rng.choice([regmap.CTRL_INTEG_RESET, regmap.CTRL_SLEW_EN, 0])
            await tb.write("CTRL", regmap.CTRL_ENABLE | pulse)
        elif what < 0.8 and tb.model.faults:
            await tb.write("CTRL", regmap.CTRL_ENABLE | regmap.CTRL_FAULT_CLEAR)
        else:
            await tb.read(rng.choice(["U", "T_IN", "INTEG", "SAMPLE_COUNT"]))
        await ClockCycles(dut.clk, rng.randint(0, 12))
    assert tb.compared > 200, f"only {tb.compared} samples compared"
    assert tb.model.sample_count > 200
    # The configuration's hold: none with the snapshot; with SNAPSHOT 0 most writes are held
    # (14 clocks of every 15), never longer than the loop reads its configuration.
    if tb.config == "soc":
        assert tb.held_writes > 100, f"only {tb.held_writes} writes held"
        assert tb.max_hold <= MAX_HOLD_CLKS, f"a write held {tb.max_hold} clocks"
    else:
        assert tb.held_writes == 0 and tb.max_hold == 0


@cocotb.test()
async def readback_and_watchdog_over_axi(dut):
    """Read-back registers equal the model; the watchdog fault shows in FAULT and STATUS."""
    tb = CoreTb(dut)
    await tb.start()
    rng = random.Random(3)
    await tb.write("KI_TS", 0)  # steady state: u and the integrator stay constant
    await tb.write("WDT_TIMEOUT", 100)
    await tb.write("TC", 12 * 256)
    cocotb.start_soon(tb.adc_stream(lambda k: 10.0, rng))
    await tb.write("CTRL", regmap.CTRL_ENABLE)
    enabled_at = tb.model.sample_count
    await ClockCycles(dut.clk, 5 * CLKS_PER_SAMPLE)
    m = tb.model
    assert await tb.read("U") == m.u != 0
    assert await tb.read("T_IN") == m.t_in == 10 * 256
    assert await tb.read("TC_EFF") == m.tc_eff == 12 * 256
    assert await tb.read("INTEG") == m.integ == 0
    assert await tb.axi.read_dword(regmap.STATUS) == regmap.STATUS_OUT_EN
    count = await tb.read("SAMPLE_COUNT")
    assert abs(count - m.sample_count) <= 1
    # No TC write since enabling: the watchdog fires at its 100th sample.
    while not m.faults:
        await ClockCycles(dut.clk, CLKS_PER_SAMPLE)
        assert m.sample_count - enabled_at <= 102, "the watchdog did not fire"
    assert m.sample_count - enabled_at >= 100
    await ClockCycles(dut.clk, CLKS_PER_SAMPLE)
    assert await tb.axi.read_dword(regmap.FAULT) == FAULT_WATCHDOG == m.faults
    status = await tb.axi.read_dword(regmap.STATUS)
    assert status & regmap.STATUS_FAULT_ACTIVE
    await ClockCycles(dut.clk, 200 * CLKS_PER_SAMPLE)  # ramp done: u = 0, enable low
    assert await tb.axi.read_dword(regmap.STATUS) == regmap.STATUS_FAULT_ACTIVE
    assert await tb.read("U") == 0 and not dut.cmd_enable.value
    await tb.write("CTRL", regmap.CTRL_ENABLE | regmap.CTRL_FAULT_CLEAR)
    await tb.write("TC", 12 * 256)
    await ClockCycles(dut.clk, 3 * CLKS_PER_SAMPLE)
    assert await tb.axi.read_dword(regmap.FAULT) == 0
    assert dut.cmd_enable.value
    assert tb.compared > 300


@pytest.mark.parametrize("config", list(CONFIGS))
@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
def test_bowden_core(simulator, config):
    """Build bowden_core at 15 clocks per sample in `config` and run the coroutines above."""
    sources = rtl(
        "bowden_core", "axil_regbus", "bowden_regs", "tension_loop", "tension_loop_dp", "mul_s16"
    )
    sources += rtl("pwm_escon")
    params = {"CLKS_PER_SAMPLE": CLKS_PER_SAMPLE, "CLK_HZ": 1_000_000, "PWM_HZ": 5000}
    run_cocotb(
        "bowden_core",
        "test_bowden_core",
        sources,
        simulator,
        parameters={**params, **CONFIGS[config]},
        tag=config,
        extra_env={"BOWDEN_CORE_CONFIG": config},
        optimize=False,
    )
