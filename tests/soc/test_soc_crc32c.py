"""soc_crc32c, the SoC's CRC-32C unit for the firmware's frames, against the `crc32c` package (an
independent implementation of CRC-32C): the register after loads and bytes driven as the bus
drives them (a one-clock load or push, none while busy), from the reset value and from loaded
ones, over the corner bytes and random messages. Also: busy lasts exactly 8 clocks after a push
and never after a load (the bus waits on it, so it must end), and a push or load while busy is
ignored (the byte being taken is never corrupted)."""

from __future__ import annotations

import random

import cocotb
import crc32c
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge
from hdl_sim import run_cocotb
from soc_sim import HDL_DIR

ONES = 0xFFFF_FFFF


def expected(state: int, data: bytes) -> int:
    """The register (before the final XOR) after `data` from `state`: the package continues a
    finished CRC, which is the register XOR 0xFFFFFFFF."""
    return crc32c.crc32c(data, value=state ^ ONES) ^ ONES


async def idle(dut):
    dut.load.value = 0
    dut.push.value = 0


async def busy_clocks(dut) -> int:
    """Clocks until busy falls (checked at each clock's settled values)."""
    n = 0
    while True:
        await ReadOnly()
        if not int(dut.busy.value):
            return n
        n += 1
        assert n <= 8, "busy for more than a byte"
        await RisingEdge(dut.clk)


async def strobe(dut, name: str, port: str, value: int) -> int:
    """A one-clock strobe `name` with `value` on `port`, as the bus gives it; the clocks busy
    after it."""
    await RisingEdge(dut.clk)
    getattr(dut, port).value = value
    getattr(dut, name).value = 1
    await RisingEdge(dut.clk)
    getattr(dut, name).value = 0
    return await busy_clocks(dut)


async def push(dut, byte: int) -> None:
    assert await strobe(dut, "push", "byte_in", byte) == 8  # a bit a clock after the push's


async def load(dut, value: int) -> None:
    assert await strobe(dut, "load", "load_value", value) == 0


async def state(dut) -> int:
    await RisingEdge(dut.clk)
    await ReadOnly()
    return int(dut.state.value)


@cocotb.test()
async def the_register_follows_crc32c(dut):
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    await idle(dut)
    dut.rst.value = 1
    await ClockCycles(dut.clk, 3)
    dut.rst.value = 0
    assert await state(dut) == ONES, "reset leaves the CRC's initial value"
    # the check value of CRC-32C from reset
    for b in b"123456789":
        await push(dut, b)
    assert await state(dut) ^ ONES == 0xE306_9283
    rng = random.Random(3)
    messages = [bytes([b]) for b in (0x00, 0x01, 0x80, 0xFF)]
    messages += [rng.randbytes(rng.randrange(1, 40)) for _ in range(40)]
    for msg in messages:
        start = rng.choice([ONES, 0, 0x8000_0001, rng.getrandbits(32)])
        await load(dut, start)
        assert await state(dut) == start
        for b in msg:
            await push(dut, b)
        got = await state(dut)
        assert got == expected(start, msg), f"{msg.hex()} from {start:#x}: {got:#x}"
    # a push or a load while a byte is being taken changes nothing of it
    await load(dut, ONES)
    await RisingEdge(dut.clk)
    dut.byte_in.value = 0x5A
    dut.push.value = 1
    await RisingEdge(dut.clk)
    dut.byte_in.value = 0xA5
    dut.load_value.value = 0x1234_5678
    dut.load.value = 1  # push held high and a load, both while busy
    await ClockCycles(dut.clk, 3)
    await idle(dut)
    assert await busy_clocks(dut) == 8 - 3  # three of its clocks gone
    assert int(dut.state.value) == expected(ONES, b"\x5a")


def test_soc_crc32c():
    run_cocotb("soc_crc32c", "test_soc_crc32c", [HDL_DIR / "soc" / "soc_crc32c.v"], "verilator")


pytestmark = [pytest.mark.slow, pytest.mark.filterwarnings("ignore::DeprecationWarning")]
