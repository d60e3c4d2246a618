"""The firmware's profile on bowden_soc (make soc-profile): the program counter sampled at every
clock of each tick and of each received frame's handling, while a run goes on with requests
arriving, as in tb_soc_tick.py (a sine from the firmware's generator, the paper's compensator,
telemetry every tick, the ADS131M02 at pin level, HELLOs at pseudo-random points of the period).

Writes {"tick": [span, ...], "received bytes": [span, ...]} to $SOC_PROFILE_JSON, a span being
{"0x<pc>": clocks}; firmware/soc/tools/rv32_profile.py names the functions. A clock costs a
Python callback here, so the run is kept short (TICKS).

SOC_CHANNELS (as in tb_soc_tick.py) profiles a SoC of several cables, every cable running;
SOC_PROFILE_STREAM=1 feeds cable 0 with full STREAM frames from the host instead of the HELLOs
(the other cables follow the sine), the run whose period's work is the longest.
"""

from __future__ import annotations

import json
import os
from collections import Counter

import cocotb
from cocotb.triggers import RisingEdge
from soc_sim import MARK_RX, MARK_TICK, mark
from tb_soc_tick import (
    CHANNELS,
    TICK_BUDGET,
    WAVE_RUN,
    booted,
    hello_during_run,
    set_params,
    stream_during_run,
)

TICKS = 24
PHASES = {MARK_TICK: "tick", MARK_RX: "received bytes"}


@cocotb.test()
async def profile_ticks_and_requests(dut):
    bench = await booted(dut)
    answered: list[int] = []
    streamed = os.environ.get("SOC_PROFILE_STREAM") == "1"
    if streamed:
        await set_params(bench, (("source", "host"), ("comp.mode", "paper")), [0])
        await set_params(bench, WAVE_RUN, range(1, CHANNELS))
        await stream_during_run(bench, dut, 2, answered)  # 48 samples before the run
    else:
        await set_params(bench, WAVE_RUN)
    reply = await bench.request("START", duration_ticks=TICKS)
    assert reply is not None and reply.name == "ACK", reply
    if streamed:
        cocotb.start_soon(stream_during_run(bench, dut, TICKS // 3, answered))
    else:
        cocotb.start_soon(hello_during_run(bench, dut, TICKS // 3, answered))
    pc = dut.soc.cpu.reg_pc
    spans: dict[int, list[Counter]] = {m: [] for m in PHASES}
    # A phase already on at the first clock (a tick that outlasts START's reply) opens a span.
    last = None
    for _ in range(TICKS * TICK_BUDGET):
        await RisingEdge(dut.clk)
        m = mark(dut)
        if m in spans:
            if m != last:
                spans[m].append(Counter())
            spans[m][-1][int(pc.value)] += 1
        last = m
    assert not int(dut.cpu_trap.value)
    assert len(spans[MARK_TICK]) >= TICKS - 1, f"{len(spans[MARK_TICK])} ticks seen"
    assert spans[MARK_RX], "no request handled during the run"
    out = {
        PHASES[m]: [{f"0x{a:x}": n for a, n in sorted(s.items())} for s in v]
        for m, v in spans.items()
    }
    with open(os.environ["SOC_PROFILE_JSON"], "w") as fh:
        json.dump(out, fh)
