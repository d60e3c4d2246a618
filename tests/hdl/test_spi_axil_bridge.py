"""Testbench of hdl/rtl/spi_axil_bridge.v: SPI mode 0 frames against an AXI4-Lite memory."""

from __future__ import annotations

import random

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge
from cocotbext.axi import AxiLiteBus, AxiLiteRam
from hdl_sim import SIMULATORS, SpiMaster, rtl, run_cocotb

HALF_SCK_CLKS = 8  # SCK = clk / 16, inside the bridge's clk / 8 limit


@cocotb.test()
async def frames_reach_the_bus(dut):
    """Writes land in memory at word address * 4, reads return memory; cut frames are dropped."""
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.rst.value = 1
    spi = SpiMaster(dut, "spi", HALF_SCK_CLKS)
    await FallingEdge(dut.clk)
    # Created once reset is driven: the model watches it and must not see X.
    ram = AxiLiteRam(AxiLiteBus.from_prefix(dut, "m_axil"), dut.clk, dut.rst, size=256)
    await ClockCycles(dut.clk, 4)
    dut.rst.value = 0
    await FallingEdge(dut.clk)
    rng = random.Random(2)
    shadow = {}
    for _ in range(12):
        addr = rng.randrange(64)
        value = rng.getrandbits(32)
        await spi.write(addr, value)
        shadow[addr] = value
        assert int.from_bytes(ram.read(4 * addr, 4), "little") == value
    for addr, value in shadow.items():
        assert await spi.read(addr) == value, f"read word {addr}"
    ram.write(4 * 7, (0xDEADBEEF).to_bytes(4, "little"))
    assert await spi.read(7) == 0xDEADBEEF
    # A write frame cut after 20 bits does not reach the bus.
    before = ram.read(4 * 9, 4)
    await spi.frame(bytes([0x80 | 9]) + (0x12345678).to_bytes(4, "big"), cut_after_bits=20)
    assert ram.read(4 * 9, 4) == before
    await spi.write(9, 0x0BAD_F00D)
    assert await spi.read(9) == 0x0BAD_F00D


@pytest.mark.parametrize("simulator", SIMULATORS)
def test_spi_axil_bridge(simulator):
    """Build spi_axil_bridge and run the coroutine above."""
    run_cocotb("spi_axil_bridge", "test_spi_axil_bridge", rtl("spi_axil_bridge"), simulator)
