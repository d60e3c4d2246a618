"""Testbench of hdl/rtl/pwm_escon.v: ESCON set value 10 % .. 90 % for -I_max .. +I_max."""

from __future__ import annotations

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge
from hdl_sim import SIMULATOR_PARAMS, rtl, run_cocotb

PERIOD_CLKS = 200
IMAX_Q12 = 16384  # 4 A


def pwm_constants(period: int, imax: int) -> tuple[int, int]:
    """(K, SHIFT) as pwm_escon.v's calc_shift computes them."""
    span = 2 * period // 5
    shift = 0
    while ((span << (shift + 1)) + imax // 2) // imax < 32768 and shift < 24:
        shift += 1
    return ((span << shift) + imax // 2) // imax, shift


def duty_model(u: int, enable: bool) -> int:
    """High clocks per period, bit-exact."""
    k, shift = pwm_constants(PERIOD_CLKS, IMAX_Q12)
    u_c = max(-IMAX_Q12, min(IMAX_Q12, u)) if enable else 0
    return PERIOD_CLKS // 2 + ((u_c * k) >> shift)


async def measure_high(dut) -> int:
    """Clocks the output is high over one whole period, starting at a period boundary."""
    while not (int(dut.cnt_reg.value) == 0):
        await FallingEdge(dut.clk)
    high = 0
    for _ in range(PERIOD_CLKS):
        high += int(dut.pwm.value)
        await FallingEdge(dut.clk)
    return high


@cocotb.test()
async def duty_follows_current(dut):
    """Duty = 50 % + 40 % * u / I_max within one clock of ideal, clamped at 10 % and 90 %."""
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.rst.value = 1
    dut.u.value = 0
    dut.enable.value = 0
    await ClockCycles(dut.clk, 3)
    dut.rst.value = 0
    cases = [
        (0, True),
        (IMAX_Q12, True),
        (-IMAX_Q12, True),
        (32767, True),
        (-32768, True),
        (4096, True),
        (-1234, True),
        (1, True),
        (8000, False),
    ]
    for u, enable in cases:
        dut.u.value = u & 0xFFFF
        dut.enable.value = int(enable)
        await ClockCycles(dut.clk, 2 * PERIOD_CLKS)  # the new duty applies from the next period
        high = await measure_high(dut)
        want = duty_model(u, enable)
        assert high == want == int(dut.duty_clks.value), f"u={u}: high {high}, model {want}"
        u_c = max(-IMAX_Q12, min(IMAX_Q12, u)) if enable else 0
        ideal = PERIOD_CLKS * (0.5 + 0.4 * u_c / IMAX_Q12)
        assert abs(high - ideal) <= 1, f"u={u}: {high} clocks high, ideal {ideal:.2f}"
    assert duty_model(IMAX_Q12, True) == PERIOD_CLKS * 9 // 10
    assert duty_model(-IMAX_Q12, True) == PERIOD_CLKS // 10


@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
def test_pwm_escon(simulator):
    """Build pwm_escon with a short period and run the coroutine above."""
    params = {"PERIOD_CLKS": PERIOD_CLKS, "IMAX_Q12": IMAX_Q12}
    run_cocotb("pwm_escon", "test_pwm_escon", rtl("pwm_escon", "mul_s16"), simulator, params)
