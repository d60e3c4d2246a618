"""Testbench of hdl/rtl/tension_loop.v: sample by sample against cosim.parts.rtl_model.

The RTL's configuration ports are driven directly with the register-field values, mirrored into
the bit-exact model `TensionLoopModel`; after every tick all outputs must equal the model's.
"""

from __future__ import annotations

import random

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge
from hdl_sim import SIMULATOR_PARAMS, rtl, run_cocotb

from cosim.parts import regmap
from cosim.parts.regmap import FAULT_ADC_RANGE, FAULT_ADC_STALE, FAULT_OVERCURRENT, FAULT_WATCHDOG
from cosim.parts.rtl_model import (
    LATENCY_CLKS,
    WDT_RAMP_STEP,
    TensionLoopModel,
    calibrate,
)

# Register -> port of tension_loop (the core wires them one to one).
PORTS = {
    "TC": "tc",
    "TC_MIN": "tc_min",
    "KFF": "kff",
    "UFF": "uff",
    "KP": "kp",
    "KI_TS": "ki_ts",
    "I_LIMIT": "i_limit",
    "SLEW": "slew",
    "WDT_TIMEOUT": "wdt_timeout",
    "ADC_OFFSET": "adc_offset",
    "ADC_GAIN": "adc_gain",
    "ADC_MIN": "adc_min",
    "ADC_MAX": "adc_max",
    "ADC_STALE": "adc_stale",
    "OC_TIMEOUT": "oc_timeout",
}


def _signed(value: int, bits: int) -> int:
    return value - (1 << bits) if value >> (bits - 1) else value


class LoopTb:
    """Drives tension_loop and the model in step; compares after every sample."""

    def __init__(self, dut):
        self.dut = dut
        self.model = TensionLoopModel()
        self.pending: dict[str, int] = {}
        self.samples = 0

    async def start(self) -> None:
        """Clock, idle inputs at the register reset values, reset."""
        cocotb.start_soon(Clock(self.dut.clk, 10, unit="ns").start())
        d = self.dut
        for sig in (d.tick, d.adc_valid, d.adc_data, d.enable, d.slew_en):
            sig.value = 0
        for sig in (d.integ_reset, d.fault_clear, d.tc_wr):
            sig.value = 0
        await self.reset()

    async def reset(self) -> None:
        """Synchronous reset of the RTL (registers back to reset values) and of the model."""
        self.dut.rst.value = 1
        self.model.reset()
        for name, port in PORTS.items():
            bits = regmap.REGISTERS[name].fields[0].width
            getattr(self.dut, port).value = self.model.regs[name] & ((1 << bits) - 1)
        self.dut.enable.value = 0
        self.dut.slew_en.value = 0
        for _ in range(3):
            await FallingEdge(self.dut.clk)
        self.dut.rst.value = 0
        await FallingEdge(self.dut.clk)

    def write(self, name: str, value: int) -> None:
        """Queue a register write; it lands with the next tick (same clock edge)."""
        self.pending[name] = value

    async def sample(self, code: int | None) -> None:
        """Tick (with the queued writes and an ADC sample unless None) and compare outputs."""
        d, m = self.dut, self.model
        tcw = irst = fclr = 0
        for name, value in self.pending.items():
            m.write(name, value)
            if name == "CTRL":
                d.enable.value = value & 1
                d.slew_en.value = (value >> 3) & 1
                irst = (value >> 1) & 1
                fclr = (value >> 2) & 1
            else:
                bits = regmap.REGISTERS[name].fields[0].width
                getattr(d, PORTS[name]).value = value & ((1 << bits) - 1)
                tcw |= name == "TC"
        self.pending.clear()
        d.tc_wr.value = tcw
        d.integ_reset.value = irst
        d.fault_clear.value = fclr
        if code is not None:
            m.adc_sample(code)
            d.adc_valid.value = 1
            d.adc_data.value = code & 0xFFFFFF
        d.tick.value = 1
        await FallingEdge(d.clk)
        d.tick.value = d.adc_valid.value = d.tc_wr.value = 0
        d.integ_reset.value = d.fault_clear.value = 0
        clocks = 1
        while not d.out_valid.value:
            await FallingEdge(d.clk)
            clocks += 1
            assert clocks <= LATENCY_CLKS, "out_valid did not come"
        assert clocks == LATENCY_CLKS, f"latency {clocks} clocks, expected {LATENCY_CLKS}"
        exp = m.tick()
        self.samples += 1
        got = {
            "u": _signed(int(d.u.value), 16),
            "out_en": bool(d.out_en.value),
            "saturated": bool(d.saturated.value),
            "wdt_ramp": bool(d.wdt_ramp.value),
            "faults": int(d.faults.value),
            "t_in": _signed(int(d.t_in.value), 16),
            "integ": _signed(int(d.integ.value), 32),
            "tc_eff": _signed(int(d.tc_eff.value), 16),
            "sample_count": int(d.sample_count.value),
        }
        want = vars(exp)
        diff = {k: (got[k], want[k]) for k in want if got[k] != want[k]}
        assert not diff, f"sample {self.samples}: RTL != model (rtl, model): {diff}"
        self.last = exp


def _code(tb: LoopTb, tension_q8: int) -> int:
    """An ADC code that calibrates to about `tension_q8` with the model's current calibration."""
    r = tb.model.regs
    code = r["ADC_OFFSET"] + (tension_q8 << 20) // r["ADC_GAIN"]
    return max(-(1 << 23), min((1 << 23) - 1, code))


async def _enable(tb: LoopTb, ctrl_extra: int = 0) -> None:
    tb.write("CTRL", regmap.CTRL_ENABLE | ctrl_extra)


async def _enabled_without_faults(dut) -> LoopTb:
    """The loop started and enabled with its watchdog and over-current timer off and the ADC's
    limits at full scale, so that the extremes a test drives trip no fault; one sample at 0."""
    tb = LoopTb(dut)
    await tb.start()
    tb.write("WDT_TIMEOUT", 0)
    tb.write("OC_TIMEOUT", 0)
    tb.write("ADC_MIN", -(1 << 23))
    tb.write("ADC_MAX", (1 << 23) - 1)
    await _enable(tb)
    await tb.sample(0)
    return tb


@cocotb.test()
async def random_against_model(dut):
    """Random commands, measurements, gains and control events; every sample equals the model."""
    tb = LoopTb(dut)
    await tb.start()
    rng = random.Random(4)
    tb.write("WDT_TIMEOUT", 0)
    tb.write("OC_TIMEOUT", 40)
    await _enable(tb)
    await tb.sample(0)
    corners16 = [-32768, -32767, -1, 0, 1, 32766, 32767]
    for _ in range(1200):
        if rng.random() < 0.05:
            name = rng.choice(["KFF", "KP", "KI_TS"])
            tb.write(name, rng.choice(corners16 + [rng.randint(-32768, 32767)] * 4))
        if rng.random() < 0.03:
            tb.write("I_LIMIT", rng.choice([0, 1, 4096, 16384, 32767, rng.randint(0, 32767)]))
        if rng.random() < 0.03:
            tb.write("ADC_GAIN", rng.choice([-32768, 1, 2048, 32767, rng.randint(-32768, 32767)]))
            tb.write("ADC_OFFSET", rng.choice([0, -(1 << 23), (1 << 23) - 1, rng.randint(-99, 99)]))
        if rng.random() < 0.02:
            tb.write("SLEW", rng.choice([0, 1, 128, 32767]))
        if rng.random() < 0.3:
            tb.write("TC", rng.choice(corners16 + [rng.randint(-32768, 32767)] * 6))
        if rng.random() < 0.1:
            tb.write("UFF", rng.choice(corners16 + [rng.randint(-2048, 2048)] * 4))
        if rng.random() < 0.03:
            tb.write("TC_MIN", rng.choice(corners16 + [rng.randint(-32768, 32767)] * 2))
        if rng.random() < 0.04:
            extra = rng.choice([0, regmap.CTRL_SLEW_EN])
            extra |= rng.choice([0, regmap.CTRL_INTEG_RESET, regmap.CTRL_FAULT_CLEAR])
            enable = regmap.CTRL_ENABLE if rng.random() < 0.9 else 0
            tb.write("CTRL", enable | extra)
        if tb.model.faults and rng.random() < 0.2:
            tb.write("CTRL", regmap.CTRL_ENABLE | regmap.CTRL_FAULT_CLEAR)
        code = rng.choice(
            [-(1 << 23), (1 << 23) - 1, rng.randint(-(1 << 23), (1 << 23) - 1)]
            + [_code(tb, rng.randint(-32768, 32767))] * 8
        )
        await tb.sample(None if rng.random() < 0.02 else code)
    assert tb.samples == 1201


@cocotb.test()
async def full_scale_errors_and_gain_extremes(dut):
    """Full-scale positive and negative errors at extreme gains; saturation both ways."""
    tb = await _enabled_without_faults(dut)
    tb.write("I_LIMIT", 32767)
    saw_hi = saw_lo = False
    for kff in (-32768, 0, 32767):
        for kp in (-32768, 1, 32767):
            for ki in (-32768, 0, 32767):
                tb.write("KFF", kff)
                tb.write("KP", kp)
                tb.write("KI_TS", ki)
                for tc, code in ((32767, -(1 << 23)), (-32768, (1 << 23) - 1)):
                    tb.write("TC", tc)
                    tb.write("CTRL", regmap.CTRL_ENABLE | regmap.CTRL_INTEG_RESET)
                    for _ in range(3):
                        await tb.sample(code)
                        saw_hi |= tb.last.u == 32767
                        saw_lo |= tb.last.u == -32767
    # With T_in at -/+ full scale the calibrated value saturates to the Q7.8 ends.
    assert calibrate(-(1 << 23), 0, 2048) == -16384
    assert saw_hi and saw_lo, "the output never reached both saturation limits"


@cocotb.test()
async def current_feedforward_at_full_scale(dut):
    """UFF (Q3.12 A, outside the PI) at its full scale both ways, with the PI terms at their
    extremes: the sum saturates at +-I_LIMIT (the limit at full scale and at 1 A), the integrator
    never sees UFF, and every sample equals the model."""
    tb = await _enabled_without_faults(dut)
    seen = set()
    for lim in (32767, 4096):
        tb.write("I_LIMIT", lim)
        for kff, kp in ((32767, 32767), (0, 0), (-32768, 32767)):
            tb.write("KFF", kff)
            tb.write("KP", kp)
            tb.write("KI_TS", 0)
            for uff in (-32768, -32767, -1, 0, 1, 32767):
                tb.write("UFF", uff)
                for tc, code in ((32767, -(1 << 23)), (-32768, (1 << 23) - 1), (0, 0)):
                    tb.write("TC", tc)
                    tb.write("CTRL", regmap.CTRL_ENABLE | regmap.CTRL_INTEG_RESET)
                    for _ in range(2):
                        await tb.sample(code)
                        assert tb.last.integ == 0, "the integrator saw UFF (KI_TS is 0)"
                        assert -lim <= tb.last.u <= lim
                        seen.add(tb.last.u)
    # UFF alone (gains 0, T_c 0) reaches both limits, and passes through exactly below them.
    assert {32767, -32767, 4096, -4096, 1, -1} <= seen


@cocotb.test()
async def floor_holds_at_the_limits(dut):
    """TC_MIN (a cable cannot push): full-scale negative and positive T_c against floors of
    -128 N (off), 0 N, 2 N and full scale, with and without the slew limit; T_c' never goes
    below the floor, and every sample equals the model."""
    tb = await _enabled_without_faults(dut)
    floored = 0
    for slew_en, slew in ((0, 0), (regmap.CTRL_SLEW_EN, 128), (regmap.CTRL_SLEW_EN, 32767)):
        tb.write("SLEW", slew)
        tb.write("CTRL", regmap.CTRL_ENABLE | slew_en)
        for floor in (-32768, 0, 512, 32767):
            tb.write("TC_MIN", floor)
            for tc in (-32768, -1, 0, 511, 512, 32767, -32768):
                tb.write("TC", tc)
                for code in (-(1 << 23), (1 << 23) - 1, 0):
                    await tb.sample(code)
                    assert tb.last.tc_eff >= floor, (
                        f"T_c' {tb.last.tc_eff} below the floor {floor} (TC {tc}, slew {slew})"
                    )
                    floored += tb.last.tc_eff == floor and tc < floor
    assert floored > 10, "the floor never acted"


@cocotb.test()
async def windup_and_recovery(dut):
    """A long saturation does not wind the integrator up; the output recovers at once."""
    tb = LoopTb(dut)
    await tb.start()
    tb.write("WDT_TIMEOUT", 0)
    tb.write("OC_TIMEOUT", 0)
    tb.write("I_LIMIT", 8192)  # 2 A
    tb.write("KFF", 0)
    tb.write("KP", 410)  # 0.05 A/N: 1 A at 20 N, the integrator adds the rest
    tb.write("KI_TS", 20971)  # 0.02 A/N per sample
    await _enable(tb)
    tb.write("TC", 20 * 256)  # 20 N asked, measurement stuck at 0 N: saturates high
    for _ in range(300):
        await tb.sample(_code(tb, 0))
    assert tb.last.saturated and tb.last.u == 8192
    lim28 = 8192 << 16
    assert tb.last.integ <= lim28
    # Integrator held where the output first saturated, not at the clamp.
    held = tb.last.integ
    assert held < lim28, "conditional integration should stop the integrator below its clamp"
    # Command drops below the measurement: the output leaves saturation on the next sample.
    tb.write("TC", 5 * 256)
    await tb.sample(_code(tb, 10 * 256))
    assert not tb.last.saturated
    assert tb.last.u < 8192
    # And the integrator walks down from where it was held.
    for _ in range(20):
        await tb.sample(_code(tb, 10 * 256))
    assert tb.last.integ < held


@cocotb.test()
async def held_integrator_follows_a_lowered_limit(dut):
    """I_LIMIT lowered while the output is clipped high: the held integrator is clamped to it.

    Found by the formal proof (hdl/formal/tension_loop.sby): the anti-windup held I unclamped,
    so after I_LIMIT dropped from 4 A to 1 A the integrator stayed near 4 A, outside its clamp.
    """
    tb = LoopTb(dut)
    await tb.start()
    tb.write("WDT_TIMEOUT", 0)
    tb.write("OC_TIMEOUT", 0)
    tb.write("KP", 0)
    tb.write("KI_TS", 32767)  # 1/32 A/N per sample
    await _enable(tb)
    tb.write("TC", 20 * 256)  # 20 N asked (1.76 A feedforward), 0 N measured: clips high
    for _ in range(80):
        await tb.sample(_code(tb, 0))
    assert tb.last.saturated and tb.last.u == 16384
    assert tb.last.integ > 4096 << 16, "the integrator should be above the lower limit"
    tb.write("I_LIMIT", 4096)  # 1 A, still clipped high with e > 0: the integrator holds
    await tb.sample(_code(tb, 0))
    assert tb.last.u == 4096 and tb.last.integ == 4096 << 16, vars(tb.last)
    await tb.sample(_code(tb, 0))
    assert tb.last.u == 4096 and tb.last.integ == 4096 << 16, vars(tb.last)


@cocotb.test()
async def watchdog_with_another_fault_goes_to_zero(dut):
    """Watchdog ramping, then an ADC fault: u is zero and the drive off at once, no ramp.

    And the other order: an ADC fault first, the watchdog after it, keeps u at zero.
    """
    tb = LoopTb(dut)
    await tb.start()
    tb.write("WDT_TIMEOUT", 3)
    tb.write("KP", 8192)  # 1 A/N: a large command to ramp down from
    await _enable(tb)
    for _ in range(3):
        tb.write("TC", 2 * 256)
        await tb.sample(_code(tb, 0))
    assert tb.last.faults == 0 and tb.last.u > 20 * WDT_RAMP_STEP
    while not tb.last.wdt_ramp:
        await tb.sample(_code(tb, 0))
    u_ramp = tb.last.u
    await tb.sample(_code(tb, 0))
    assert tb.last.wdt_ramp and tb.last.u == u_ramp - WDT_RAMP_STEP
    await tb.sample((1 << 23) - 1)  # clipped code, outside ADC_MAX
    assert tb.last.faults == FAULT_WATCHDOG | FAULT_ADC_RANGE
    assert tb.last.u == 0 and not tb.last.out_en and not tb.last.wdt_ramp
    for _ in range(3):
        await tb.sample(_code(tb, 0))
        assert tb.last.u == 0 and not tb.last.out_en
    # Clear, run, then the range fault first and the watchdog on top of it.
    tb.write("CTRL", regmap.CTRL_ENABLE | regmap.CTRL_FAULT_CLEAR)
    tb.write("TC", 2 * 256)
    await tb.sample(_code(tb, 0))
    assert tb.last.faults == 0 and tb.last.out_en and tb.last.u > 0
    await tb.sample(-(1 << 23))
    assert tb.last.faults == FAULT_ADC_RANGE and tb.last.u == 0
    while not tb.last.faults & FAULT_WATCHDOG:
        await tb.sample(_code(tb, 0))
    assert tb.last.faults == FAULT_WATCHDOG | FAULT_ADC_RANGE
    assert tb.last.u == 0 and not tb.last.out_en and not tb.last.wdt_ramp


@cocotb.test()
async def reset_in_mid_run(dut):
    """Reset during operation leaves the output disabled with registers at reset values."""
    tb = LoopTb(dut)
    await tb.start()
    tb.write("WDT_TIMEOUT", 0)
    await _enable(tb)
    tb.write("TC", 10 * 256)
    for _ in range(30):
        await tb.sample(_code(tb, 3 * 256))
    assert tb.last.out_en and tb.last.u != 0
    await tb.reset()
    assert not int(dut.out_en.value) and int(dut.u.value) == 0
    for _ in range(5):
        await tb.sample(_code(tb, 3 * 256))
    assert not tb.last.out_en and tb.last.u == 0 and tb.last.sample_count == 5


@cocotb.test()
async def watchdog_ramps_and_latches(dut):
    """No TC write for WDT_TIMEOUT samples: fault latches, u ramps to zero, enable drops."""
    tb = LoopTb(dut)
    await tb.start()
    tb.write("WDT_TIMEOUT", 20)
    tb.write("KP", 8192)  # 1 A/N: a large command to ramp down from
    await _enable(tb)
    tb.write("TC", 2 * 256)
    await tb.sample(_code(tb, 0))
    for _ in range(18):
        tb.write("TC", 2 * 256)  # refreshed: no fault
        await tb.sample(_code(tb, 0))
    assert tb.last.faults == 0
    n = 0
    while tb.last.faults == 0:
        u0 = tb.last.u
        await tb.sample(_code(tb, 0))
        n += 1
    assert u0 > 10 * WDT_RAMP_STEP
    assert n == 20, f"watchdog fired after {n} samples without TC, expected 20"
    assert tb.last.faults == FAULT_WATCHDOG and tb.last.wdt_ramp and tb.last.out_en
    assert tb.last.u == u0 - WDT_RAMP_STEP
    while tb.last.out_en:
        await tb.sample(_code(tb, 0))
    assert tb.last.u == 0 and tb.last.faults == FAULT_WATCHDOG
    tb.write("TC", 2 * 256)  # a late write does not clear the fault
    await tb.sample(_code(tb, 0))
    assert tb.last.faults == FAULT_WATCHDOG and not tb.last.out_en
    tb.write("CTRL", regmap.CTRL_ENABLE | regmap.CTRL_FAULT_CLEAR)
    tb.write("TC", 2 * 256)
    await tb.sample(_code(tb, 0))
    assert tb.last.faults == 0 and tb.last.out_en and tb.last.u > 0


@cocotb.test()
async def each_fault_forces_zero(dut):
    """ADC stale, ADC out of range and over-current each latch, zero u at once, and clear."""
    tb = LoopTb(dut)
    await tb.start()
    tb.write("WDT_TIMEOUT", 0)
    tb.write("ADC_STALE", 5)
    tb.write("OC_TIMEOUT", 10)
    tb.write("ADC_MIN", -1000)
    tb.write("ADC_MAX", 1 << 22)
    await _enable(tb)
    tb.write("TC", 5 * 256)
    good = _code(tb, 4 * 256)

    async def clear():
        tb.write("CTRL", regmap.CTRL_ENABLE | regmap.CTRL_FAULT_CLEAR)
        await tb.sample(good)
        assert tb.last.faults == 0 and tb.last.out_en

    for _ in range(5):
        await tb.sample(good)
    assert tb.last.out_en and tb.last.u != 0
    # Stale: the fifth sample without ADC data trips.
    for k in range(5):
        await tb.sample(None)
        assert tb.last.faults == (FAULT_ADC_STALE if k == 4 else 0)
    assert not tb.last.out_en and tb.last.u == 0
    await tb.sample(good)  # data back, fault stays latched
    assert tb.last.faults == FAULT_ADC_STALE and tb.last.u == 0
    await clear()
    # Range: one code below ADC_MIN.
    await tb.sample(-1001)
    assert tb.last.faults == FAULT_ADC_RANGE and not tb.last.out_en and tb.last.u == 0
    await clear()
    await tb.sample((1 << 22) + 1)
    assert tb.last.faults == FAULT_ADC_RANGE
    await clear()
    # Over-current: saturated for OC_TIMEOUT samples.
    tb.write("I_LIMIT", 100)
    n = 0
    while tb.last.faults == 0:
        await tb.sample(good)
        n += 1
        assert n < 20
    assert tb.last.faults == FAULT_OVERCURRENT and tb.last.u == 0 and not tb.last.out_en
    assert n == 11, f"over-current after {n} samples, expected the 11th (10 saturated before)"
    # Faults are not detected while disabled, and clearing while disabled keeps u at zero.
    tb.write("CTRL", regmap.CTRL_FAULT_CLEAR)
    for _ in range(8):
        await tb.sample(None)
    assert tb.last.faults == 0 and not tb.last.out_en


@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
def test_tension_loop(simulator):
    """Build tension_loop and run every coroutine above against the model."""
    run_cocotb(
        "tension_loop",
        "test_tension_loop",
        rtl("tension_loop", "tension_loop_dp", "mul_s16"),
        simulator,
        optimize=False,
    )
