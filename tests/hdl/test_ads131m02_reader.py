"""Testbench of hdl/rtl/ads131m02_reader.v against a behavioural ADS131M02 (TI SBAS853A)."""

from __future__ import annotations

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, RisingEdge
from hdl_sim import SIMULATORS, Ads131m02, crc16_ccitt, rtl, run_cocotb, signed, word_bits

from cosim.parts.interface import reader_latency_clks

SCLK_HALF_CLKS = 4
# Longer than a frame (about 770 clocks at SCLK_HALF_CLKS = 4), as the default is.
DRDY_TIMEOUT_CLKS = 1500
# Full scale both ways, a sign change between the channels, zero.
CODES = [(0x123456, -0x345678), (-1, 1), (-(1 << 23), (1 << 23) - 1), ((1 << 23) - 1, -(1 << 23))]
CODES += [(0, 0)]
# WREG from CLOCK (0x03), two registers; CLOCK = 0x0302 (CH0, CH1, OSR 128, high resolution),
# GAIN1 = 0x0077 (PGA 128 on both channels): SBAS853A 8.5.1.10, 8.6.
CONFIG_FRAME = [0x618100, 0x030200, 0x007700, 0x000000]


async def start(dut) -> Ads131m02:
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    adc = Ads131m02(dut)
    dut.rst.value = 1
    await ClockCycles(dut.clk, 3)
    dut.rst.value = 0
    cocotb.start_soon(adc.run())
    for _ in range(4000):
        await RisingEdge(dut.clk)
        if adc.frames:
            break
    assert adc.frames == [CONFIG_FRAME], [[hex(w) for w in f] for f in adc.frames]
    await ClockCycles(dut.clk, 50)
    return adc


async def convert_and_wait(dut, adc: Ads131m02, ch0: int, ch1: int):
    """DRDY falls between two clock edges; over the frame and a few clocks more: the clocks to
    adc_valid (None if none came) and crc_error at the end."""
    await FallingEdge(dut.clk)
    adc.convert(ch0, ch1)
    at = None
    for clks in range(1, reader_latency_clks(96, SCLK_HALF_CLKS) + 10):
        await RisingEdge(dut.clk)
        if int(dut.adc_valid.value):
            assert at is None, "two samples from one frame"
            at = clks
    return at, bool(int(dut.crc_error.value))


@cocotb.test()
async def configures_and_streams(dut):
    """One WREG frame of CLOCK and GAIN1; then every DRDY gives one frame: both channels, the
    STATUS word, at the latency the co-simulation's ADC model assumes."""
    adc = await start(dut)
    for ch0, ch1 in CODES:
        adc.frames.clear()
        clks, crc_err = await convert_and_wait(dut, adc, ch0, ch1)
        assert clks is not None and not crc_err, f"no sample for {ch0}, {ch1}"
        # cosim.parts.interface hands each result to the core this many clocks after DRDY.
        assert clks == reader_latency_clks(96, SCLK_HALF_CLKS), clks
        got = (signed(int(dut.adc_data.value), 24), signed(int(dut.adc_aux_data.value), 24))
        assert got == (ch0, ch1), f"samples {got}, ADC sent {(ch0, ch1)}"
        assert int(dut.adc_status.value) == adc.status, hex(int(dut.adc_status.value))
        await ClockCycles(dut.clk, 20)
        assert adc.frames == [[0, 0, 0, 0]], "a read frame must send NULL commands only"


@cocotb.test()
async def drops_a_frame_with_a_bad_crc(dut):
    """A bit flipped on the line (any word, CRC included) gives no sample and raises crc_error;
    the last good sample stays; the next good frame is taken and clears crc_error."""
    adc = await start(dut)
    clks, _ = await convert_and_wait(dut, adc, 1000, -1000)
    assert clks is not None
    for bit in (0, 30, 71, 72, 87):
        adc.corrupt = bit
        clks, crc_err = await convert_and_wait(dut, adc, 5000, -5000)
        assert clks is None and crc_err, f"flipped bit {bit}: sample taken"
        got = (signed(int(dut.adc_data.value), 24), signed(int(dut.adc_aux_data.value), 24))
        assert got == (1000, -1000), f"flipped bit {bit}: last good sample replaced by {got}"
        await ClockCycles(dut.clk, 200)
    assert int(dut.crc_error.value), "crc_error holds until a good frame"
    clks, crc_err = await convert_and_wait(dut, adc, 7, -7)
    assert clks is not None and not crc_err, "a good frame is taken and clears crc_error"
    assert signed(int(dut.adc_data.value), 24) == 7


@cocotb.test()
async def flags_a_lost_drdy(dut):
    """DRDY absent (stuck high) or stuck low for DRDY_TIMEOUT_CLKS raises drdy_lost with no
    sample; the next DRDY edge clears it."""
    adc = await start(dut)
    clks, _ = await convert_and_wait(dut, adc, 1, 2)
    assert clks is not None
    assert not int(dut.drdy_lost.value)
    await ClockCycles(dut.clk, DRDY_TIMEOUT_CLKS + 10)
    assert int(dut.drdy_lost.value), "no DRDY for the timeout: drdy_lost must be set"
    clks, _ = await convert_and_wait(dut, adc, 3, 4)
    assert clks is not None and not int(dut.drdy_lost.value), "a DRDY edge clears drdy_lost"
    # Stuck low: one falling edge, then DRDY never returns high.
    await FallingEdge(dut.clk)
    adc.drdy_stuck_low = True
    adc.convert(5, 6)
    valid = 0
    for _ in range(DRDY_TIMEOUT_CLKS + 10):
        await RisingEdge(dut.clk)
        valid += int(dut.adc_valid.value)
    assert int(dut.drdy_lost.value), "DRDY stuck low: drdy_lost must be set"
    assert valid <= 1, f"{valid} samples from one DRDY edge"


def test_crc_matches_datasheet_check_value():
    """The CRC of the model (and so of the testbench frames): CRC-16/CCITT-FALSE of "123456789"
    is 0x29B1 (its catalogued check value), and a frame followed by its CRC leaves 0."""
    msg = b"123456789"
    bits = [(byte >> (7 - i)) & 1 for byte in msg for i in range(8)]
    assert crc16_ccitt(bits) == 0x29B1
    frame = word_bits(0x050300) + word_bits(0x123456) + word_bits(-5)
    assert crc16_ccitt(frame + word_bits(crc16_ccitt(frame) << 8)) == 0


@pytest.mark.parametrize("simulator", SIMULATORS)
def test_ads131m02_reader(simulator):
    """Build ads131m02_reader with short waits and run the coroutines above."""
    params = {
        "SCLK_HALF_CLKS": SCLK_HALF_CLKS,
        "WAIT_CLKS": 64,
        "DRDY_TIMEOUT_CLKS": DRDY_TIMEOUT_CLKS,
    }
    run_cocotb(
        "ads131m02_reader", "test_ads131m02_reader", rtl("ads131m02_reader"), simulator, params
    )
