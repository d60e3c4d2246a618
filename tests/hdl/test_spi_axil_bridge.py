"""Testbench of hdl/rtl/spi_axil_bridge.v: SPI mode 0 frames against an AXI4-Lite memory."""

from __future__ import annotations

import random

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge
from cocotbext.axi import AxiLiteBus, AxiLiteRam
from hdl_sim import (
    READ_OKAY,
    RESP_DECERR,
    SIMULATOR_PARAMS,
    STATUS_DONE,
    STATUS_TAG,
    STATUS_WRITE,
    WRITE_OKAY,
    SpiMaster,
    reset_after_sck_falls,
    rtl,
    run_cocotb,
)

HALF_SCK_CLKS = 8  # SCK = clk / 16, inside the bridge's clk / 8 limit
RAM_BYTES = 256  # the bridge's ADDR_W is 8: word addresses 0..63


class BusWatch:
    """Counts the write and read requests the bridge issues on the AXI4-Lite bus."""

    def __init__(self, dut):
        self.dut = dut
        self.writes = 0
        self.reads = 0
        cocotb.start_soon(self._run())

    async def _run(self) -> None:
        d = self.dut
        while True:
            await FallingEdge(d.clk)
            self.writes += int(d.m_axil_awvalid.value and d.m_axil_awready.value)
            self.reads += int(d.m_axil_arvalid.value and d.m_axil_arready.value)


async def _start(dut) -> tuple[SpiMaster, AxiLiteRam]:
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.rst.value = 1
    spi = SpiMaster(dut, "spi", HALF_SCK_CLKS)
    await FallingEdge(dut.clk)
    # Created once reset is driven: the model watches it and must not see X.
    ram = AxiLiteRam(AxiLiteBus.from_prefix(dut, "m_axil"), dut.clk, dut.rst, size=RAM_BYTES)
    await ClockCycles(dut.clk, 4)
    dut.rst.value = 0
    await FallingEdge(dut.clk)
    # Chip select high for a while: the bridge arms after reset.
    await ClockCycles(dut.clk, 4)
    return spi, ram


@cocotb.test()
async def frames_reach_the_bus(dut):
    """Writes land in memory at word address * 4, reads return memory; cut frames are dropped."""
    spi, ram = await _start(dut)
    rng = random.Random(2)
    shadow = {}
    for _ in range(12):
        addr = rng.randrange(RAM_BYTES // 4)
        value = rng.getrandbits(32)
        assert await spi.write_status(addr, value) == WRITE_OKAY
        shadow[addr] = value
        assert int.from_bytes(ram.read(4 * addr, 4), "little") == value
    for addr, value in shadow.items():
        assert await spi.read_status(addr) == (value, READ_OKAY), f"read word {addr}"
    ram.write(4 * 7, (0xDEADBEEF).to_bytes(4, "little"))
    assert await spi.read(7) == 0xDEADBEEF
    # A write frame cut after 20 bits, or after 39, does not reach the bus.
    bus = BusWatch(dut)
    before = ram.read(4 * 9, 4)
    for cut in (20, 39):
        await spi.frame(bytes([0x80 | 9]) + (0x12345678).to_bytes(4, "big"), cut_after_bits=cut)
    assert ram.read(4 * 9, 4) == before and bus.writes == 0
    # Ending a write after its 40th bit (no status byte) is a complete write.
    await spi.frame(bytes([0x80 | 9]) + (0x0BAD_F00D).to_bytes(4, "big"))
    assert await spi.read(9) == 0x0BAD_F00D


@cocotb.test()
async def words_beyond_the_bus_are_refused(dut):
    """Word addresses 64..127 do not fit ADDR_W 8: refused with DECERR, no bus access."""
    spi, ram = await _start(dut)
    bus = BusWatch(dut)
    ram.write(4 * 1, (0x11111111).to_bytes(4, "little"))
    status = await spi.write_status(65, 0x22222222)  # would alias onto word 1
    assert status == STATUS_TAG | STATUS_WRITE | STATUS_DONE | RESP_DECERR == 0xBB
    value, status = await spi.read_status(127)
    assert (value, status) == (0, STATUS_TAG | STATUS_DONE | RESP_DECERR)
    assert bus.writes == 0 and bus.reads == 0
    assert await spi.read(1) == 0x11111111


@cocotb.test()
async def reset_in_mid_frame_drops_the_frame(dut):
    """Reset during a frame: its remaining bits, which read as a write, reach nothing."""
    spi, ram = await _start(dut)
    ram.write(4 * 9, (0x5555AAAA).to_bytes(4, "little"))
    bus = BusWatch(dut)
    # A read of word 0 whose tail, taken as a frame of its own, would write 0xDEADBEEF to word 9.
    tail = bytes([0x80 | 9]) + (0xDEADBEEF).to_bytes(4, "big") + bytes(1)
    cocotb.start_soon(reset_after_sck_falls(dut, dut.spi_sck, 8))
    await spi.frame(bytes([0]) + tail)
    assert bus.writes == 0 and ram.read(4 * 9, 4) == (0x5555AAAA).to_bytes(4, "little")
    # The next frame, begun with chip select high, works.
    assert await spi.write_status(9, 0x600DF00D) == WRITE_OKAY
    assert await spi.read(9) == 0x600DF00D


@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
def test_spi_axil_bridge(simulator):
    """Build spi_axil_bridge and run the coroutines above."""
    run_cocotb("spi_axil_bridge", "test_spi_axil_bridge", rtl("spi_axil_bridge"), simulator)
