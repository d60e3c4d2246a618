"""Testbench of hdl/rtl/mul_s16.v: exact signed products, two clocks after the operands.

Also here, on this smallest testbench's build: a run's pass kept and reused by input hash
(sim_cache.py; its key's parts in test_sim_cache.py).
"""

from __future__ import annotations

import json
import random

import cocotb
import pytest
import sim_cache
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge
from hdl_sim import SIMULATOR_PARAMS, rtl, run_cocotb

CORNERS = [-32768, -32767, -1, 0, 1, 32767]


@cocotb.test()
async def products_are_exact(dut):
    """Corners (including -32768 * -32768 = 2^30) and random operands, one per clock."""
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    rng = random.Random(7)
    pairs = [(a, b) for a in CORNERS for b in CORNERS]
    pairs += [(rng.randint(-32768, 32767), rng.randint(-32768, 32767)) for _ in range(300)]
    sent = []
    for k in range(len(pairs) + 2):
        await FallingEdge(dut.clk)
        if k >= 2:
            a, b = sent[k - 2]
            got = int(dut.p.value)
            got = got - (1 << 32) if got >> 31 else got
            assert got == a * b, f"{a} * {b}: got {got}"
        if k < len(pairs):
            a, b = pairs[k]
            dut.a.value = a & 0xFFFF
            dut.b.value = b & 0xFFFF
            sent.append((a, b))


@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
def test_mul_s16(simulator):
    """Build mul_s16 and run the coroutine above."""
    run_cocotb("mul_s16", "test_mul_s16", rtl("mul_s16"), simulator)


@pytest.mark.slow
def test_a_run_lists_what_its_simulator_imported_and_is_reused(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(sim_cache, "cache_dir", lambda: tmp_path)
    assert run_cocotb("mul_s16", "test_mul_s16", rtl("mul_s16"), "verilator") == 1
    (kept,) = (tmp_path / "sim").glob("mul_s16-*.json")
    deps = set(json.loads(kept.read_text())["deps"])
    assert {"tests/hdl/test_mul_s16.py", "tests/hdl/hdl_sim.py", "cosim/parts/regmap.py"} <= deps
    capsys.readouterr()
    assert run_cocotb("mul_s16", "test_mul_s16", rtl("mul_s16"), "verilator") == 1
    assert "reused" in capsys.readouterr().out
