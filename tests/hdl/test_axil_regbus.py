"""Testbench of hdl/rtl/axil_regbus.v: AXI4-Lite (cocotbext-axi) onto a register-bus model.

The model answers reads after a delay that the test changes (1 clock: bowden_regs' RD_STAGES 1
in bowden_soc; 3: the default; later still: the bus waits for reg_rd_valid however late). The
held write: wr_hold high as bowden_core drives it from the loop's cfg_busy (14 clocks of every
sample period with SNAPSHOT 0), and the write lands only after it falls.
"""

from __future__ import annotations

import random

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, Combine, FallingEdge, RisingEdge
from cocotbext.axi import AxiLiteBus, AxiLiteMaster
from hdl_sim import SIMULATOR_PARAMS, rtl, run_cocotb

BAD_ADDR = 0xF0  # the model answers this address with an error


class RegBusModel:
    """Word-addressed memory on the register bus; reads answer after `delay` clocks."""

    def __init__(self, dut, delay: int):
        self.dut, self.delay = dut, delay
        self.mem: dict[int, int] = {}
        self.writes = 0
        dut.reg_wr_err.value = 0
        dut.reg_rd_err.value = 0
        dut.reg_rd_valid.value = 0
        dut.reg_rd_data.value = 0
        self.write_clocks: list[int] = []  # the clock count of each write
        self.clock = 0

    async def run(self) -> None:
        d = self.dut
        while True:
            await FallingEdge(d.clk)
            d.reg_wr_err.value = int(
                bool(d.reg_wr_en.value) and int(d.reg_wr_addr.value) == BAD_ADDR
            )
            await RisingEdge(d.clk)
            self.clock += 1
            if d.reg_wr_en.value:
                addr = int(d.reg_wr_addr.value) & ~3
                strb = int(d.reg_wr_strb.value)
                old = self.mem.get(addr, 0)
                mask = sum(0xFF << (8 * i) for i in range(4) if strb >> i & 1)
                self.mem[addr] = (int(d.reg_wr_data.value) & mask) | (old & ~mask)
                self.writes += 1
                self.write_clocks.append(self.clock)
            if d.reg_rd_en.value:
                addr = int(d.reg_rd_addr.value) & ~3
                cocotb.start_soon(self.answer(addr))

    async def answer(self, addr: int) -> None:
        d = self.dut
        await ClockCycles(d.clk, self.delay)
        d.reg_rd_data.value = self.mem.get(addr, 0)
        d.reg_rd_err.value = int(addr == BAD_ADDR)
        d.reg_rd_valid.value = 1
        await RisingEdge(d.clk)
        d.reg_rd_valid.value = 0


@cocotb.test()
async def protocol(dut):
    """Writes with strobes, reads after a bus delay, SLVERR, concurrent and back-to-back use."""
    axi, bus = await start(dut, delay=3)
    await axi.write_dword(0x10, 0x11223344)
    assert bus.mem[0x10] == 0x11223344
    assert await axi.read_dword(0x10) == 0x11223344
    await axi.write(0x11, b"\xaa")  # byte strobe 0b0010
    assert await axi.read_dword(0x10) == 0x1122AA44
    wresp = await axi.write(BAD_ADDR, bytes(4))
    assert int(wresp.resp) == 2, "write to an unmapped address must answer SLVERR"
    rresp = await axi.read(BAD_ADDR, 4)
    assert int(rresp.resp) == 2
    assert int((await axi.read(0x10, 4)).resp) == 0
    # Many transactions in flight at once from separate coroutines: all complete, in order.
    rng = random.Random(3)
    values = {4 * a: rng.getrandbits(32) for a in range(16)}
    await Combine(*[cocotb.start_soon(axi.write_dword(a, v)) for a, v in values.items()])
    reads = [cocotb.start_soon(axi.read_dword(a)) for a in values]
    await Combine(*reads)
    assert [r.result() for r in reads] == list(values.values())
    assert bus.writes == 2 + 1 + 16
    # Reads answered one clock after the request (RD_STAGES 1) and much later than three.
    for delay in (1, 7):
        bus.delay = delay
        value = rng.getrandbits(32)
        await axi.write_dword(0x80, value)  # outside the 16 words above
        assert await axi.read_dword(0x80) == value
        reads = [cocotb.start_soon(axi.read_dword(a)) for a in values]
        await Combine(*reads)
        assert [r.result() for r in reads] == list(values.values())


async def start(dut, delay: int) -> tuple[AxiLiteMaster, RegBusModel]:
    """Clock, reset, the AXI master and the register-bus model; wr_hold low."""
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.wr_hold.value = 0
    dut.rst.value = 1
    await FallingEdge(dut.clk)
    axi = AxiLiteMaster(AxiLiteBus.from_prefix(dut, "s_axil"), dut.clk, dut.rst)
    bus = RegBusModel(dut, delay=delay)
    cocotb.start_soon(bus.run())
    await ClockCycles(dut.clk, 3)
    dut.rst.value = 0
    await ClockCycles(dut.clk, 2)
    return axi, bus


SAMPLE_CLKS, HOLD_CLKS = 15, 14  # bowden_core's formal setting: the hold leaves one clock free


@cocotb.test()
async def held_write(dut):
    """A write issued while wr_hold is high waits, and lands on the first clock it is low."""
    axi, bus = await start(dut, delay=1)
    held: list[int] = []  # clocks of the hold's falls

    async def loop_busy() -> None:
        """wr_hold as the loop's cfg_busy: HOLD_CLKS of every SAMPLE_CLKS."""
        while True:
            await FallingEdge(dut.clk)
            dut.wr_hold.value = 1
            for _ in range(HOLD_CLKS):
                await RisingEdge(dut.clk)
                assert not dut.reg_wr_en.value, "a write passed the hold"
            await FallingEdge(dut.clk)
            dut.wr_hold.value = 0
            held.append(bus.clock)
            await RisingEdge(dut.clk)

    cocotb.start_soon(loop_busy())
    await ClockCycles(dut.clk, 3)  # mid-hold
    before = bus.writes
    value = 0xCAFE0001
    await axi.write_dword(0x30, value)
    assert bus.writes == before + 1 and bus.mem[0x30] == value
    assert held and bus.write_clocks[-1] == held[0] + 1, (
        f"write at clock {bus.write_clocks[-1]}, hold released at {held[0]}"
    )
    # Many writes: each lands in a free clock, none lost; reads are not held.
    rng = random.Random(5)
    values = {0x40 + 4 * a: rng.getrandbits(32) for a in range(6)}
    await Combine(*[cocotb.start_soon(axi.write_dword(a, v)) for a, v in values.items()])
    assert all(bus.mem[a] == v for a, v in values.items())
    assert set(bus.write_clocks[-6:]) <= {c + 1 for c in held}
    assert await axi.read_dword(0x40) == values[0x40]


@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
def test_axil_regbus(simulator):
    """Build axil_regbus and run the coroutine above."""
    run_cocotb("axil_regbus", "test_axil_regbus", rtl("axil_regbus"), simulator)
