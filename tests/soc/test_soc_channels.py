"""bowden_soc with two cables (CHANNELS 2: bowden_core_mc, an ADS131M04), in Verilator.

The one-cable SoC is what the other tests here run; this one runs the configuration of the
UP5K's top and pins with two cables (the ECP5's four differ only in N and the ADS131M08): the
image boots and answers HELLO through bank 0 of the two-bank core; the reader configures the
ADS131M04 at OSR 256 (the four-channel frame does not fit the 31.25 us of 32 kSPS at SCLK
clk / 6) and hands each cable its own T_in and T_out of one conversion; each cable has its own
PWM at the ESCON's period, 50 % while disabled. A build of its own (some minutes), so `long`.
"""

from __future__ import annotations

import cocotb
import pytest
from cocotb.triggers import RisingEdge
from hdl_sim import Ads131m0x, run_cocotb
from soc_sim import (
    CLK_HZ,
    FW_HEX,
    MARK_IDLE,
    VERILATOR_ARGS,
    Bench,
    clocks,
    protocol,
    reset,
    soc_sources,
    start_clock,
    wait_mark,
)

BOOT_MAX_CLKS = 3_000_000  # as test_soc_boot: a boot that takes longer is a defect
ADC_PERIOD_CLKS = CLK_HZ // 16_000  # OSR 256: 16 kSPS
# WREG of CLOCK and GAIN1 (0x6181: two registers from 0x03): CLOCK = 0x0F06 (CH0..CH3 on, OSR
# 256, high resolution), GAIN1 = 0x7777 (PGA 128 on CH0..CH3); ADS131M04 "Register Map".
CONFIG_WORDS = [0x618100, 0x0F0600, 0x777700]
# T_in and T_out of cable 0, then of cable 1: all different, of both signs.
CODES = (0x012345, -0x023456, 0x034567, -0x045678)


async def adc_source(adc: Ads131m0x, dut):
    while True:
        await clocks(dut, ADC_PERIOD_CLKS)
        adc.convert(*CODES)


def signed24(v: int) -> int:
    return v - (1 << 24) if v & (1 << 23) else v


@cocotb.test()
async def two_cables_boot_sample_and_drive(dut):
    start_clock(dut)
    adc = Ads131m0x(dut, channels=4)
    cocotb.start_soon(adc.run())
    bench = Bench(dut)
    await reset(dut)
    await wait_mark(dut, MARK_IDLE, BOOT_MAX_CLKS)
    assert adc.frames, "the reader never configured the ADC"
    assert adc.frames[0][:3] == CONFIG_WORDS, [hex(w) for w in adc.frames[0]]
    cocotb.start_soon(adc_source(adc, dut))
    reply = await bench.request("HELLO")
    assert reply is not None and reply.name == "HELLO_ACK", reply
    fields = protocol.unpack("HELLO_ACK", reply.payload)
    assert fields["proto_version"] == protocol.msgs.PROTOCOL_VERSION
    assert not int(dut.cpu_trap.value)

    # Every conversion read, each cable's T_in (ADC channel 2k) in its own slot of the loop.
    await clocks(dut, 4 * ADC_PERIOD_CLKS)
    assert int(dut.soc.adc_drdy_lost.value) == 0 and int(dut.soc.adc_crc_err.value) == 0
    raw = int(dut.soc.g_core_mc.core.loop.raw_reg.value)
    t_in = [signed24((raw >> (24 * k)) & 0xFFFFFF) for k in range(2)]
    assert t_in == [CODES[0], CODES[2]], t_in

    # Each cable's PWM: the ESCON's period, 50 % with the drive disabled.
    rises = {0: [], 1: []}
    highs = {0: 0, 1: 0}
    last = int(dut.soc.drive_pwm.value)
    n = 0
    while min(len(r) for r in rises.values()) < 3:
        await RisingEdge(dut.clk)
        n += 1
        v = int(dut.soc.drive_pwm.value)
        for k in (0, 1):
            bit = (v >> k) & 1
            if bit and not (last >> k) & 1:
                rises[k].append(n)
            if len(rises[k]) == 1 and bit:
                highs[k] += 1
        last = v
    for k in (0, 1):
        periods = {b - a for a, b in zip(rises[k], rises[k][1:], strict=False)}
        assert periods == {CLK_HZ // 5_000}, (k, periods)
        assert highs[k] == CLK_HZ // 5_000 // 2, (k, highs[k])
    assert int(dut.soc.drive_enable.value) == 0, "a drive is enabled without a run"


@pytest.mark.slow
@pytest.mark.long
def test_soc_two_cables():
    assert FW_HEX.exists(), "make firmware-soc first (make test builds it)"
    params = {"CHANNELS": 2, "ROM_INIT": f'"{FW_HEX}"', "ADC_WAIT_CLKS": 256}
    run_cocotb(
        "soc_tb", "test_soc_channels", soc_sources(), "verilator", params, tag="channels2",
        build_args=VERILATOR_ARGS,
    )  # fmt: skip
