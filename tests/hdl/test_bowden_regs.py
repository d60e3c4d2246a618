"""Testbench of the generated hdl/rtl/bowden_regs.v on its register bus (no AXI in between).

Built twice: RD_STAGES 3 (the default: the external-MCU boards' three-clock read at 48 MHz) and
RD_STAGES 1 (`rd1`, bowden_soc's one-clock read); the read must answer in exactly that many
clocks, with the same data.
"""

from __future__ import annotations

import os

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge
from hdl_sim import SIMULATOR_PARAMS, rtl, run_cocotb

from cosim.parts import regmap


async def write(dut, addr: int, data: int, strb: int = 0xF) -> bool:
    """One bus write; returns the decode error flag."""
    dut.reg_wr_en.value = 1
    dut.reg_wr_addr.value = addr
    dut.reg_wr_data.value = data
    dut.reg_wr_strb.value = strb
    await FallingEdge(dut.clk)
    err = bool(dut.reg_wr_err.value)  # combinational during the write clock
    dut.reg_wr_en.value = 0
    return err


async def read(dut, addr: int) -> tuple[int, bool, int]:
    """One bus read; returns (data, error, clocks until reg_rd_valid)."""
    dut.reg_rd_en.value = 1
    dut.reg_rd_addr.value = addr
    await FallingEdge(dut.clk)
    dut.reg_rd_en.value = 0
    clocks = 1
    while not dut.reg_rd_valid.value:
        await FallingEdge(dut.clk)
        clocks += 1
        assert clocks < 10, "no reg_rd_valid"
    return int(dut.reg_rd_data.value), bool(dut.reg_rd_err.value), clocks


@cocotb.test()
async def pulses_readback_and_errors(dut):
    """Write pulses last one clock, hw inputs read back live, unmapped addresses flag errors."""
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    for name in ("reg_wr_en", "reg_rd_en", "reg_wr_addr", "reg_rd_addr", "reg_wr_data"):
        getattr(dut, name).value = 0
    dut.reg_wr_strb.value = 0
    for sig in dir(dut):
        if sig.startswith("hw_"):
            getattr(dut, sig).value = 0
    dut.rst.value = 1
    await ClockCycles(dut.clk, 2)
    await FallingEdge(dut.clk)
    dut.rst.value = 0
    # CTRL: FAULT_CLEAR is a one-clock pulse, ENABLE a level.
    assert not await write(dut, regmap.CTRL, regmap.CTRL_ENABLE | regmap.CTRL_FAULT_CLEAR)
    assert dut.ctrl_fault_clear.value == 1 and dut.ctrl_enable.value == 1
    await FallingEdge(dut.clk)
    assert dut.ctrl_fault_clear.value == 0 and dut.ctrl_enable.value == 1
    # A strobe without byte 0 does not fire the pulse.
    await write(dut, regmap.CTRL, regmap.CTRL_INTEG_RESET, strb=0xE)
    assert dut.ctrl_integ_reset.value == 0
    # TC write strobe (watchdog refresh), even when the value does not change.
    for _ in range(2):
        await write(dut, regmap.TC, 0x1234)
        assert dut.tc_wr.value == 1 and int(dut.tc.value) == 0x1234
        await FallingEdge(dut.clk)
        assert dut.tc_wr.value == 0
    # Live read-back of hardware values, sign-extended where signed.
    dut.hw_u.value = 0x8001
    dut.hw_sample_count.value = 0xDEADBEEF
    dut.hw_status_saturated.value = 1
    stages = int(os.environ["BOWDEN_RD_STAGES"])
    data, err, clocks = await read(dut, regmap.U)
    assert (data, err, clocks) == (0xFFFF8001, False, stages)
    # The answer holds until the next read, whatever the registers do meanwhile.
    dut.hw_u.value = 0x0002
    await ClockCycles(dut.clk, 2)
    await FallingEdge(dut.clk)
    assert int(dut.reg_rd_data.value) == 0xFFFF8001 and not dut.reg_rd_valid.value
    # Back-to-back reads, one per clock: each answer in its clock, in order.
    names = ["KFF", "KP", "KI_TS", "I_LIMIT"]
    answers = []
    for i in range(len(names) + stages):
        dut.reg_rd_en.value = int(i < len(names))
        dut.reg_rd_addr.value = regmap.REGISTERS[names[min(i, len(names) - 1)]].addr
        await FallingEdge(dut.clk)
        if dut.reg_rd_valid.value:
            answers.append(int(dut.reg_rd_data.value))
    dut.reg_rd_en.value = 0
    assert answers == [regmap.REGISTERS[n].fields[0].reset for n in names]
    assert (await read(dut, regmap.SAMPLE_COUNT))[0] == 0xDEADBEEF
    assert (await read(dut, regmap.STATUS))[0] == regmap.STATUS_SATURATED
    # Unmapped: error on write and read, data 0; read-only write accepted and ignored.
    assert await write(dut, 0xF0, 1)
    data, err, _ = await read(dut, 0xF0)
    assert data == 0 and err
    assert not await write(dut, regmap.U, 5)
    assert (await read(dut, regmap.ID))[0] == 0x424F0100


@pytest.mark.parametrize("stages", [3, 1], ids=["rd3", "rd1"])
@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
def test_bowden_regs(simulator, stages):
    """Build bowden_regs with RD_STAGES `stages` and run the coroutine above."""
    run_cocotb(
        "bowden_regs",
        "test_bowden_regs",
        rtl("bowden_regs"),
        simulator,
        parameters={"RD_STAGES": stages},
        tag=f"rd{stages}",
        extra_env={"BOWDEN_RD_STAGES": str(stages)},
        optimize=False,
    )
