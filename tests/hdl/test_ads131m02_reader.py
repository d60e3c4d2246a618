"""Testbench of hdl/rtl/ads131m02_reader.v against a behavioural ADS131M0x: the ADS131M02 (TI
SBAS853A) and, with the reader's NCH, the 4- and 8-channel parts (one word per channel in the same
frame format)."""

from __future__ import annotations

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, RisingEdge
from hdl_sim import (
    SIMULATORS,
    Ads131m0x,
    crc16_ccitt,
    rtl,
    run_cocotb,
    signed,
    simulator_param,
    word_bits,
)

from cosim.parts.interface import reader_latency_clks

SCLK_HALF_CLKS = 4


def drdy_timeout_clks(nch: int) -> int:
    """Longer than a frame (about 770 clocks for 2 channels at SCLK_HALF_CLKS = 4, 1920 for 8),
    as the default is."""
    return max(1500, 2 * 2 * SCLK_HALF_CLKS * 24 * (nch + 2))


# Full scale both ways, a sign change between the channels, zero.
CODES = [(0x123456, -0x345678), (-1, 1), (-(1 << 23), (1 << 23) - 1), ((1 << 23) - 1, -(1 << 23))]
CODES += [(0, 0)]
# WREG from CLOCK (0x03), two registers; CLOCK = 0x0302 (CH0, CH1, OSR 128, high resolution),
# GAIN1 = 0x0077 (PGA 128 on both channels): SBAS853A 8.5.1.10, 8.6. The 4-channel part: CLOCK's
# CH0_EN..CH3_EN (0x0F02), GAIN1 for CH0..CH3 (0x7777); the 8-channel part: WREG of three
# registers (0x6182), CLOCK 0xFF02, GAIN1 and GAIN2 (CH4..CH7) 0x7777. The frame is NCH + 2 words.
CONFIG_WORDS = {
    2: [0x618100, 0x030200, 0x007700],
    4: [0x618100, 0x0F0200, 0x777700],
    8: [0x618200, 0xFF0200, 0x777700, 0x777700],
}
CHANNELS = tuple(CONFIG_WORDS)


def config_frame(nch: int) -> list[int]:
    words = CONFIG_WORDS[nch]
    return words + [0] * (nch + 2 - len(words))


def codes_for(nch: int, ch0: int, ch1: int) -> tuple[int, ...]:
    """Every channel a different code: CH0 and CH1 as given, the others their mirror images
    and shifts (full scale included when CH0/CH1 are)."""
    more = [(-ch0 - 1) if k % 2 == 0 else (ch1 >> k) for k in range(2, nch)]
    return (ch0, ch1, *more)


def channels(dut) -> int:
    return len(dut.adc_ch_data) // 24


def samples(dut) -> tuple[int, ...]:
    word = int(dut.adc_ch_data.value)
    return tuple(signed((word >> (24 * k)) & 0xFFFFFF, 24) for k in range(channels(dut)))


async def start(dut) -> Ads131m0x:
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    adc = Ads131m0x(dut, channels=channels(dut))
    dut.rst.value = 1
    await ClockCycles(dut.clk, 3)
    dut.rst.value = 0
    cocotb.start_soon(adc.run())
    for _ in range(4000):
        await RisingEdge(dut.clk)
        if adc.frames:
            break
    assert adc.frames == [config_frame(adc.channels)], [[hex(w) for w in f] for f in adc.frames]
    await ClockCycles(dut.clk, 50)
    return adc


async def convert_and_wait(dut, adc: Ads131m0x, ch0: int, ch1: int):
    """DRDY falls between two clock edges (every channel converted: codes_for); over the frame
    and a few clocks more: the clocks to adc_valid (None if none came) and crc_error at the end."""
    await FallingEdge(dut.clk)
    adc.convert(*codes_for(adc.channels, ch0, ch1))
    at = None
    for clks in range(1, reader_latency_clks(adc.frame_len, SCLK_HALF_CLKS) + 10):
        await RisingEdge(dut.clk)
        if int(dut.adc_valid.value):
            assert at is None, "two samples from one frame"
            at = clks
    return at, bool(int(dut.crc_error.value))


@cocotb.test()
async def configures_and_streams(dut):
    """One WREG frame of CLOCK and GAIN1 (and GAIN2 with 8 channels); then every DRDY gives one
    frame: every channel, the STATUS word, at the latency the co-simulation's ADC model assumes."""
    adc = await start(dut)
    for ch0, ch1 in CODES:
        adc.frames.clear()
        clks, crc_err = await convert_and_wait(dut, adc, ch0, ch1)
        assert clks is not None and not crc_err, f"no sample for {ch0}, {ch1}"
        # cosim.parts.interface hands each result to the core this many clocks after DRDY.
        assert clks == reader_latency_clks(adc.frame_len, SCLK_HALF_CLKS), clks
        sent = codes_for(adc.channels, ch0, ch1)
        assert samples(dut) == sent, f"samples {samples(dut)}, ADC sent {sent}"
        assert int(dut.adc_status.value) == adc.status, hex(int(dut.adc_status.value))
        await ClockCycles(dut.clk, 20)
        null = [0] * (adc.channels + 2)
        assert adc.frames == [null], "a read frame must send NULL commands only"


@cocotb.test()
async def drops_a_frame_with_a_bad_crc(dut):
    """A bit flipped on the line (any word, CRC included) gives no sample and raises crc_error;
    the last good sample stays; the next good frame is taken and clears crc_error."""
    adc = await start(dut)
    clks, _ = await convert_and_wait(dut, adc, 1000, -1000)
    assert clks is not None
    last = adc.frame_len - 1  # the CRC word's last bit is padding: the CRC's own last bit
    for bit in (0, 30, 71, 72, last - 32, last - 8):
        adc.corrupt = bit
        clks, crc_err = await convert_and_wait(dut, adc, 5000, -5000)
        assert clks is None and crc_err, f"flipped bit {bit}: sample taken"
        good = codes_for(adc.channels, 1000, -1000)
        assert samples(dut) == good, f"flipped bit {bit}: last good sample replaced"
        await ClockCycles(dut.clk, 200)
    assert int(dut.crc_error.value), "crc_error holds until a good frame"
    clks, crc_err = await convert_and_wait(dut, adc, 7, -7)
    assert clks is not None and not crc_err, "a good frame is taken and clears crc_error"
    assert samples(dut)[0] == 7


@cocotb.test()
async def flags_a_lost_drdy(dut):
    """DRDY absent (stuck high) or stuck low for DRDY_TIMEOUT_CLKS raises drdy_lost with no
    sample; the next DRDY edge clears it."""
    adc = await start(dut)
    timeout_clks = drdy_timeout_clks(adc.channels)
    clks, _ = await convert_and_wait(dut, adc, 1, 2)
    assert clks is not None
    assert not int(dut.drdy_lost.value)
    await ClockCycles(dut.clk, timeout_clks + 10)
    assert int(dut.drdy_lost.value), "no DRDY for the timeout: drdy_lost must be set"
    clks, _ = await convert_and_wait(dut, adc, 3, 4)
    assert clks is not None and not int(dut.drdy_lost.value), "a DRDY edge clears drdy_lost"
    # Stuck low: one falling edge, then DRDY never returns high.
    await FallingEdge(dut.clk)
    adc.drdy_stuck_low = True
    adc.convert(*codes_for(adc.channels, 5, 6))
    valid = 0
    for _ in range(timeout_clks + 10):
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


# The 4-channel part is `make test-matrix`'s: make test reads the 2 (on MAKE_TEST_SIMULATOR)
# and the 8, its two ends.
@pytest.mark.parametrize(
    ("simulator", "nch"),
    [simulator_param(sim, 2) for sim in SIMULATORS]
    + [
        pytest.param(SIMULATORS[0], n, marks=pytest.mark.matrix) if n == 4 else (SIMULATORS[0], n)
        for n in CHANNELS
        if n != 2
    ],
)
def test_ads131m02_reader(simulator, nch):
    """Build ads131m02_reader with short waits (the ADS131M02, and with NCH the 4- and 8-channel
    parts on one simulator) and run the coroutines above."""
    params = {
        "NCH": nch,
        "SCLK_HALF_CLKS": SCLK_HALF_CLKS,
        "WAIT_CLKS": 64,
        "DRDY_TIMEOUT_CLKS": drdy_timeout_clks(nch),
    }
    run_cocotb(
        "ads131m02_reader",
        "test_ads131m02_reader",
        rtl("ads131m02_reader"),
        simulator,
        params,
        tag="" if nch == 2 else f"nch{nch}",
    )
