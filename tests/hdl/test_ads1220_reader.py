"""Testbench of hdl/rtl/ads1220_reader.v against a behavioural ADS1220 (TI SBAS501, mode 1)."""

from __future__ import annotations

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, RisingEdge
from hdl_sim import SIMULATOR_PARAMS, Ads1220, rtl, run_cocotb

from cosim.parts.interface import reader_latency_clks

CONFIG = bytes([0x0E, 0xD4, 0x40, 0x00])
CODES = [0x123456, -1, -(1 << 23), (1 << 23) - 1, 0]
SCLK_HALF_CLKS = 4


@cocotb.test()
async def configures_and_streams(dut):
    """RESET, WREG of four registers, START; then every DRDY gives one signed sample."""
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    adc = Ads1220(dut)
    dut.rst.value = 1
    await ClockCycles(dut.clk, 3)
    dut.rst.value = 0
    cocotb.start_soon(adc.run())
    for _ in range(4000):
        await RisingEdge(dut.clk)
        if len(adc.received) == 7:
            break
    assert adc.received == [0x06, 0x43, *CONFIG, 0x08], [hex(b) for b in adc.received]
    await ClockCycles(dut.clk, 50)
    for code in CODES:
        adc.received.clear()
        await FallingEdge(dut.clk)
        adc.convert(code)  # DRDY falls between two clock edges
        clks = 0
        while not int(dut.adc_valid.value):
            await RisingEdge(dut.clk)
            clks += 1
            assert clks < 2000, f"no sample for code {code}"
        # The co-simulation's word-level ADC (cosim.parts.interface) hands each result to the core
        # this many clocks after DRDY: the reader takes exactly that long.
        assert clks == reader_latency_clks(24, SCLK_HALF_CLKS), clks
        got = int(dut.adc_data.value)
        got = got - (1 << 24) if got >> 23 else got
        assert got == code, f"sample {got}, ADC sent {code}"
        assert adc.received == [0, 0, 0], "the reader must send nothing while reading"
        await ClockCycles(dut.clk, 20)


@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
def test_ads1220_reader(simulator):
    """Build ads1220_reader with short waits and run the coroutine above."""
    params = {"SCLK_HALF_CLKS": SCLK_HALF_CLKS, "WAIT_CLKS": 64}
    run_cocotb("ads1220_reader", "test_ads1220_reader", rtl("ads1220_reader"), simulator, params)
