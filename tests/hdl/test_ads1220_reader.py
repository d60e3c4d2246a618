"""Testbench of hdl/rtl/ads1220_reader.v against a behavioural ADS1220 (TI SBAS501, mode 1)."""

from __future__ import annotations

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, RisingEdge
from hdl_sim import SIMULATORS, Ads1220, rtl, run_cocotb

CONFIG = bytes([0x0E, 0xD4, 0x40, 0x00])
CODES = [0x123456, -1, -(1 << 23), (1 << 23) - 1, 0]


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
        adc.convert(code)
        for _ in range(2000):
            await RisingEdge(dut.clk)
            if int(dut.adc_valid.value):
                break
        else:
            raise AssertionError(f"no sample for code {code}")
        got = int(dut.adc_data.value)
        got = got - (1 << 24) if got >> 23 else got
        assert got == code, f"sample {got}, ADC sent {code}"
        assert adc.received == [0, 0, 0], "the reader must send nothing while reading"
        await ClockCycles(dut.clk, 20)


@pytest.mark.parametrize("simulator", SIMULATORS)
def test_ads1220_reader(simulator):
    """Build ads1220_reader with short waits and run the coroutine above."""
    params = {"SCLK_HALF_CLKS": 4, "WAIT_CLKS": 64}
    run_cocotb("ads1220_reader", "test_ads1220_reader", rtl("ads1220_reader"), simulator, params)
