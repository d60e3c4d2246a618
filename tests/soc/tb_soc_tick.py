"""Cycles of the firmware's tick on bowden_soc, measured in the simulation, against the tick's
budget (SOC clock / tick rate: 24000 clocks at 24 MHz and 1 kHz), with the ADS131M02 at pin level
feeding the loop.

A run is started over the UART (a sine reference from the firmware's generator, the paper's
compensator, telemetry every tick); the firmware writes its phase to SOC_SYS_MARK, so the clocks
of each tick (dev_tick: reference, compensator, T_c write, the telemetry frame) and of each burst
of received bytes (dev_rx_bytes, with the reply's transmission) are read off the bus. The worst
tick must leave 2x margin, the worst tick plus a request's handling must fit one period. Figures
are printed (make bench-soc). Run by test_soc_boot.py in its simulation (one build).
"""

from __future__ import annotations

import statistics

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, Edge
from hdl_sim import Ads131m02
from soc_sim import (
    CLK_HZ,
    MARK_IDLE,
    MARK_RX,
    MARK_TICK,
    Bench,
    mark,
    protocol,
    reset,
    wait_mark,
)

TICK_BUDGET = CLK_HZ // 1000
ADC_PERIOD_CLKS = 750  # 32 kSPS at 24 MHz


async def adc_source(adc: Ads131m02, dut, code: int):
    while True:
        await ClockCycles(dut.clk, ADC_PERIOD_CLKS)
        adc.convert(code, code)


async def phase_spans(dut, spans: dict[int, list[int]], stop):
    """Clocks spent in each phase the firmware writes, span by span: the SoC's clock counter
    (SOC_TIMER_COUNT) read at each change of the phase word."""
    soc = dut.soc
    cur, t0 = mark(dut), int(soc.timer_count_reg.value)
    while not stop():
        await Edge(soc.mark_reg)
        m, t = mark(dut), int(soc.timer_count_reg.value)
        if m != cur:
            spans.setdefault(cur, []).append(t - t0)
            cur, t0 = m, t


async def set_param(bench: Bench, name: str, value):
    p = protocol.param(name)
    word = protocol.word_from_value(p, value)
    reply = await bench.request("PARAM_SET", param=p.id, value=word)
    assert reply is not None and reply.name != "ERROR", (name, reply)


@cocotb.test()
async def tick_cycles_have_margin(dut):
    cocotb.start_soon(Clock(dut.clk, 40, unit="ns").start())
    adc = Ads131m02(dut)
    cocotb.start_soon(adc.run())
    cocotb.start_soon(adc_source(adc, dut, 1 << 18))
    bench = Bench(dut)
    await reset(dut)
    await wait_mark(dut, MARK_IDLE, 3_000_000)
    for name, value in (
        ("source", "wave"),
        ("wave.kind", "sine"),
        ("wave.mean_n", 8.0),
        ("wave.amplitude_n", 6.0),
        ("wave.freq_hz", 5.0),
        ("comp.mode", "paper"),
    ):
        await set_param(bench, name, value)
    spans: dict[int, list[int]] = {}
    done = False
    cocotb.start_soon(phase_spans(dut, spans, lambda: done))
    ticks = 40
    reply = await bench.request("START", duration_ticks=ticks)
    assert reply is not None and reply.name == "ACK", reply
    await ClockCycles(dut.clk, (ticks + 2) * TICK_BUDGET)
    # START's own handling (the configuration written to the loop, fw_start) is a one-off at the
    # run's start, kept apart from the requests handled while a run goes on
    start_rx = list(spans.get(MARK_RX, []))
    spans[MARK_RX] = []
    for _ in range(3):
        assert await bench.request("HELLO") is not None
    done = True
    await ClockCycles(dut.clk, 10)
    tick = spans.get(MARK_TICK, [])
    rx = spans.get(MARK_RX, [])
    assert len(tick) >= ticks, f"{len(tick)} ticks seen"
    tel = [f for f in bench.poll() if f.name == "TELEMETRY"]
    assert len(tel) >= ticks - 2, f"{len(tel)} telemetry frames"
    worst, median = max(tick), statistics.median(tick)
    worst_rx = max(rx) if rx else 0
    dut._log.info(
        "cycles per tick: worst %d, median %d; a request (HELLO) worst %d; START %d; budget %d "
        "(tick margin x%.1f, tick + request x%.2f)",
        worst, median, worst_rx, max(start_rx, default=0), TICK_BUDGET, TICK_BUDGET / worst,
        TICK_BUDGET / (worst + worst_rx),
    )  # fmt: skip
    assert not int(dut.cpu_trap.value)
    # The tick itself with 2x margin; the tick and a request's handling within one period (no
    # overrun). The 2x margin for both together is not met at 24 MHz (hdl/README.md).
    assert worst <= TICK_BUDGET // 2, "the tick has less than 2x margin"
    assert worst + worst_rx <= TICK_BUDGET, "a tick and a request do not fit one period"
