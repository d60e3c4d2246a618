"""bowden_soc boots the RV32 firmware and answers the bench protocol over its UART (Verilator).

The firmware image is build/firmware/soc/bowden_fw.hex (make firmware-soc), read by the ROM's
$readmemh; the SPI flash is the simulation model (hdl/soc/sim/spi_flash_model.v), blank at start.
Also here: the loop's sample period and the PWM period are exact at the SoC's clock, the timer's
tick is the firmware's rate, and a request sent while the board boots gets no answer but does
not hang it; and (tb_soc_tick.py, in the same simulation) the tick's cycles against its budget.
"""

from __future__ import annotations

import cocotb
import pytest
from cocotb.triggers import RisingEdge
from hdl_sim import run_cocotb
from soc_sim import (
    BOOT_MAX_CLKS,
    CLK_HZ,
    FW_HEX,
    MARK_BOOT,
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


async def start(dut):
    start_clock(dut)
    dut.adc_dout.value = 0
    dut.adc_drdy_n.value = 1
    bench = Bench(dut)
    await reset(dut)
    return bench


@cocotb.test()
async def boots_and_answers_hello(dut):
    bench = await start(dut)
    boot = await wait_mark(dut, MARK_IDLE, BOOT_MAX_CLKS)
    dut._log.info("boot: %d clocks (%.2f ms at 24 MHz)", boot, boot / CLK_HZ * 1e3)
    reply = await bench.request("HELLO")
    assert reply is not None, "no answer to HELLO"
    assert reply.name == "HELLO_ACK", reply
    fields = protocol.unpack("HELLO_ACK", reply.payload)
    assert fields["proto_version"] == protocol.msgs.PROTOCOL_VERSION
    assert fields["running"] == 0
    assert fields["n_params"] == len(protocol.msgs.PARAMS)
    assert bench.uart.frame_errors == 0
    assert not int(dut.cpu_trap.value)


@cocotb.test()
async def request_during_boot_is_dropped_then_answered(dut):
    """A HELLO sent while the firmware starts up is dropped whole (main.c clears the receive
    FIFO before it serves the port); the board neither hangs nor answers garbage, and the next
    HELLO is answered."""
    bench = await start(dut)
    await wait_mark(dut, MARK_BOOT, 100_000)
    early = await bench.request("HELLO", timeout_clks=20_000)
    assert early is None
    await wait_mark(dut, MARK_IDLE, BOOT_MAX_CLKS)
    await clocks(dut, 50_000)
    assert bench.poll() == [], "an answer to the request sent during boot"
    reply = await bench.request("HELLO")
    assert reply is not None and reply.name == "HELLO_ACK"


@cocotb.test()
async def sample_pwm_and_tick_periods_are_exact(dut):
    """At 24 MHz: a loop sample every 2400 clocks (10 kHz), the PWM period 4800 clocks (5 kHz),
    the firmware's timer every 24000 clocks (1 kHz), measured on the running SoC."""
    await start(dut)
    await wait_mark(dut, MARK_IDLE, BOOT_MAX_CLKS)
    soc = dut.soc
    assert int(soc.timer_period_reg.value) == CLK_HZ // 1000
    ticks = []
    n = 0
    while len(ticks) < 4:
        await RisingEdge(dut.clk)
        n += 1
        if int(dut.sample_tick.value):
            ticks.append(n)
    assert {b - a for a, b in zip(ticks, ticks[1:], strict=False)} == {CLK_HZ // 10_000}
    # PWM: rising edges of the pin (50 % while disabled)
    rises, last, n = [], int(dut.drive_pwm.value), 0
    while len(rises) < 3:
        await RisingEdge(dut.clk)
        n += 1
        v = int(dut.drive_pwm.value)
        if v and not last:
            rises.append(n)
        last = v
    assert {b - a for a, b in zip(rises, rises[1:], strict=False)} == {CLK_HZ // 5_000}
    # the timer's tick count: the clocks between its steps
    pend, last, n = [], int(soc.timer_ticks_reg.value), 0
    while len(pend) < 3:
        await RisingEdge(dut.clk)
        n += 1
        v = int(soc.timer_ticks_reg.value)
        if v != last:
            assert v == (last + 1) & 0xFFFF
            pend.append(n)
        last = v
    assert {b - a for a, b in zip(pend, pend[1:], strict=False)} == {CLK_HZ // 1000}


@pytest.fixture(scope="module")
def fw_image():
    assert FW_HEX.exists(), "make firmware-soc first (make test builds it)"
    return FW_HEX


def test_soc_boot(fw_image):
    params = {"ROM_INIT": f'"{fw_image}"', "ADC_WAIT_CLKS": 256}
    run_cocotb(
        "soc_tb", "test_soc_boot,tb_soc_tick", soc_sources(), "verilator", params, tag="boot",
        build_args=VERILATOR_ARGS,
    )  # fmt: skip
