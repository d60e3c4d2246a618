"""soc_mul, the SoC's multiplier on picorv32's co-processor port: MUL, MULH, MULHSU and MULHU
against Python's integers (the RISC-V definitions: the low or the high word of the 64-bit product,
the operands signed or unsigned as the instruction says), at the corner operands and random
ones, driven as picorv32 drives the port (the instruction and operands held until pcpi_ready,
pcpi_valid dropped the clock after it). Also: a non-multiply instruction is not answered."""

from __future__ import annotations

import random

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge
from hdl_sim import run_cocotb
from soc_sim import HDL_DIR

OPS = {"mul": 0, "mulh": 1, "mulhsu": 2, "mulhu": 3}
CORNERS = [0, 1, 2, 0x7FFF_FFFF, 0x8000_0000, 0x8000_0001, 0xFFFF_FFFF, 0xFFFF_0000, 0x0000_FFFF,
           0x1234_5678, 0xDEAD_BEEF]  # fmt: skip


def expected(op: str, a: int, b: int) -> int:
    sa = a - (1 << 32) if a >> 31 else a
    sb = b - (1 << 32) if b >> 31 else b
    p = {"mul": a * b, "mulh": sa * sb, "mulhsu": sa * b, "mulhu": a * b}[op]
    p &= (1 << 64) - 1
    return p & 0xFFFF_FFFF if op == "mul" else p >> 32


def insn(op: str) -> int:
    # mul x3, x1, x2 etc.: funct7 0000001, rs2 2, rs1 1, funct3, rd 3, opcode 0110011
    return (1 << 25) | (2 << 20) | (1 << 15) | (OPS[op] << 12) | (3 << 7) | 0b0110011


async def execute(dut, word: int, a: int, b: int, max_clks: int = 20) -> int | None:
    dut.pcpi_insn.value = word
    dut.pcpi_rs1.value = a
    dut.pcpi_rs2.value = b
    dut.pcpi_valid.value = 1
    for _ in range(max_clks):
        await RisingEdge(dut.clk)
        await ReadOnly()
        if int(dut.pcpi_ready.value):
            assert int(dut.pcpi_wr.value)
            rd = int(dut.pcpi_rd.value)
            await RisingEdge(dut.clk)
            dut.pcpi_valid.value = 0
            return rd
        # a multiply holds the CPU with pcpi_wait until it answers; anything else never does
        assert int(dut.pcpi_wait.value) == int(word in [insn(op) for op in OPS])
    await RisingEdge(dut.clk)
    dut.pcpi_valid.value = 0
    return None


@cocotb.test()
async def multiplies_match_the_definitions(dut):
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.pcpi_valid.value = 0
    dut.rst.value = 1
    await ClockCycles(dut.clk, 3)
    dut.rst.value = 0
    rng = random.Random(7)
    cases = [(a, b) for a in CORNERS for b in CORNERS]
    cases += [(rng.getrandbits(32), rng.getrandbits(32)) for _ in range(150)]
    for a, b in cases:
        for op in OPS:
            got = await execute(dut, insn(op), a, b)
            assert got == expected(op, a, b), f"{op} {a:#x} {b:#x}: {got} != {expected(op, a, b)}"
    # a divide (funct3 100) and an ordinary ADD are not answered
    assert await execute(dut, insn("mul") | (4 << 12), 5, 7) is None
    assert await execute(dut, 0b0110011 | (3 << 7), 5, 7) is None


def test_soc_mul():
    run_cocotb("soc_mul", "test_soc_mul", [HDL_DIR / "soc" / "soc_mul.v"], "verilator")


pytestmark = [pytest.mark.slow, pytest.mark.filterwarnings("ignore::DeprecationWarning")]
