"""Testbench of hdl/rtl/bowden_system.v: the board-level wiring, end to end.

An MCU (the shared SpiMaster) writes the loop registers over the SPI bridge and reads them
back; a behavioural ADC streams load-cell codes into the front-end: the ADS131M02 (the shared
Ads131m0x, T_in on CH0 and T_out on CH1, read back in T_OUT) into ads131m02_reader, the board's
default, or, with ADC_ADS131M02 = 0, the ADS1220 (the shared Ads1220) into ads1220_reader;
the drive pins are checked against the bit-exact model (cosim.parts.rtl_model.TensionLoopModel) and
the ESCON PWM formula (hdl/README.md). A monitor replays into the model, every clock, the ADC
samples, sample ticks and register writes the core sees on bowden_system's internal nets
(adc_valid/adc_data, axil_*), and checks that every sample the core receives is the code the
ADC sent, and every command (cmd_current, drive_enable, fault) equals the model.

Parameters are shrunk so that the test runs in seconds: CLK_HZ 1 MHz gives 100 clocks per
sample and a 200-clock PWM period; the ADC's SCLK runs at clk / 6 (ADS131M02) or clk / 8
(ADS1220) after a 64-clock wait. Each front-end is its own build (tests/hdl/hdl_sim's tag);
BOWDEN_TB_ADC names it.
"""

from __future__ import annotations

import os
from collections import deque

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, RisingEdge
from hdl_sim import (
    READ_OKAY,
    RESP_DECERR,
    RESP_SLVERR,
    SIMULATORS,
    STATUS_DONE,
    STATUS_TAG,
    STATUS_WRITE,
    WRITE_OKAY,
    Ads131m0x,
    Ads1220,
    SpiMaster,
    replay_write,
    reset_after_sck_falls,
    rtl,
    run_cocotb,
    signed,
    simulator_param,
)

from cosim.parts import interface, regmap
from cosim.parts.regmap import FAULT_ADC_STALE
from cosim.parts.rtl_model import TensionLoopModel, adc_code_from_tension

CLK_HZ = 1_000_000
CLKS_PER_SAMPLE = CLK_HZ // 10_000  # bowden_core's default SAMPLE_HZ
PWM_PERIOD_CLKS = CLK_HZ // 5000  # bowden_core's default PWM_HZ
PWM_IMAX_Q12 = 16384  # bowden_core's default: 4 A at 90 % duty
CONFIG = [0x06, 0x43, 0x0E, 0xD4, 0x40, 0x00, 0x08]  # ADS1220: RESET, WREG 0..3, START/SYNC
# ADS131M02: WREG CLOCK, GAIN1 (tests/hdl/test_ads131m02_reader.py)
CONFIG_FRAME = [0x618100, 0x030200, 0x007700, 0x000000]
FRONTENDS = {"ads131m02": 1, "ads1220": 0}  # bowden_system's ADC_ADS131M02 per front-end
ADC = os.environ.get("BOWDEN_TB_ADC", "ads131m02")
# SCLK half period per front-end: the ADS131M02's 96-bit frame (576 clocks at 3, the reader's
# least) must fit in a conversion period, the ADS1220's 24 bits at 4 as before.
SCLK_HALF_CLKS = {"ads131m02": 3, "ads1220": 4}
# One conversion every 6 samples (ADS131M02; its 96-bit frame fits) or 2.5 (ADS1220; on the
# board 0.3 and 5 samples): within ADC_STALE (10 samples) either way.
ADC_PERIOD_CLKS = 600 if ADC == "ads131m02" else 250
# bowden_system's DRDY timeout at this clock: four 96-bit frames.
DRDY_TIMEOUT_CLKS = 4 * 2 * 96 * SCLK_HALF_CLKS[ADC]


def pwm_duty_clks(u: int, enable: bool) -> int:
    """High time of one PWM period for command u (Q3.12 A), as hdl/rtl/pwm_escon.v defines it:
    the co-simulation's word-level model (cosim.parts.interface.pwm_duty_clks), at this build's
    clock."""
    return interface.pwm_duty_clks(u, PWM_PERIOD_CLKS, PWM_IMAX_Q12, enable)


class SystemTb:
    """Clock, reset, MCU, the ADC, and the monitor that replays the core's inputs into the model."""

    def __init__(self, dut):
        self.dut = dut
        self.model = TensionLoopModel()
        self.expected: deque = deque()
        self.sent: deque = deque()  # codes the ADC made ready, not yet seen by the core
        self.aux_sent = 0  # the last T_out code the ADS131M02 made ready
        self.compared = 0
        self.samples_seen = 0
        self.mcu = SpiMaster(dut, "mcu", half_sck_clks=8)
        self.adc = Ads131m0x(dut) if ADC == "ads131m02" else Ads1220(dut)
        self.adc_on = False
        self.tension_n = 0.0
        self.pwm_periods = 0

    async def start(self) -> None:
        d = self.dut
        cocotb.start_soon(Clock(d.clk, 10, unit="ns").start())
        d.rst.value = 1
        await ClockCycles(d.clk, 3)
        await FallingEdge(d.clk)
        self.model.reset()
        d.rst.value = 0
        cocotb.start_soon(self.adc.run())
        cocotb.start_soon(self.monitor())
        cocotb.start_soon(self.conversions())
        cocotb.start_soon(self.pwm_monitor())

    async def monitor(self) -> None:
        """Mid-cycle, look at what the next rising edge captures and replay it in order."""
        d = self.dut
        while True:
            await FallingEdge(d.clk)
            if d.rst.value:  # a reset in mid-run: the core starts over, and so does the model
                self.model.reset()
                self.expected.clear()
                continue
            if d.cmd_valid.value:
                assert self.expected, "cmd_valid without a sample tick"
                exp = self.expected.popleft()
                got = (signed(int(d.cmd_current.value), 16), bool(d.drive_enable.value))
                want = (exp.u, exp.out_en)
                assert got == want, f"sample {exp.sample_count}: RTL {got} != model {want}"
                assert bool(d.fault.value) == (exp.faults != 0)
                self.compared += 1
            if d.adc_valid.value:
                code = signed(int(d.adc_data.value), 24)
                assert self.sent, f"the core got ADC code {code} that the ADC did not send"
                assert code == self.sent.popleft(), "ADC code changed on its way to the core"
                self.model.adc_sample(code)
                self.samples_seen += 1
            if d.sample_tick.value:
                self.expected.append(self.model.tick())
            if d.axil_awvalid.value and d.axil_wvalid.value and d.axil_awready.value:
                replay_write(
                    self.model,
                    int(d.axil_awaddr.value),
                    int(d.axil_wdata.value),
                    int(d.axil_wstrb.value),
                )

    async def pwm_monitor(self) -> None:
        """The rule the co-simulation's word-level PWM model uses (cosim.parts.interface.PwmEscon):
        every PWM period starts at a sample tick and carries the command of the tick before
        (the last cmd_current / drive_enable out before the period starts)."""
        d = self.dut
        clk, last_tick, u, en, start, carried = 0, None, 0, False, None, None
        prev = 1  # a period under way when the monitor starts is not checked
        while True:
            await FallingEdge(d.clk)
            clk += 1
            if d.rst.value:  # a reset in mid-run restarts the period: not checked
                start, prev = None, 1
                continue
            pwm = int(d.drive_pwm.value)
            if d.sample_tick.value:
                last_tick = clk
            if pwm and not prev:  # a period starts (duty >= 10 %, so it starts high)
                if start is not None:
                    self.pwm_periods += 1
                assert last_tick == clk, f"PWM period starts at clock {clk}, tick at {last_tick}"
                start, carried = clk, pwm_duty_clks(u, en)
            if not pwm and prev and start is not None:
                assert clk - start == carried, (
                    f"PWM high {clk - start} clocks, the command of the tick before gives {carried}"
                )
            prev = pwm
            if d.cmd_valid.value:
                u, en = signed(int(d.cmd_current.value), 16), bool(d.drive_enable.value)

    async def conversions(self) -> None:
        """While `adc_on`, one conversion of `tension_n` every ADC_PERIOD_CLKS (and, on the
        ADS131M02's CH1, of a T_out 20 % below it)."""
        while True:
            await ClockCycles(self.dut.clk, ADC_PERIOD_CLKS)
            if self.adc_on:
                code = adc_code_from_tension(self.tension_n)
                self.sent.append(code)
                if ADC == "ads131m02":
                    self.aux_sent = adc_code_from_tension(0.8 * self.tension_n)
                    self.adc.convert(code, self.aux_sent)
                else:
                    self.adc.convert(code)

    def configured(self) -> bool:
        """The front-end has sent its configuration (checked by `check_config`)."""
        if ADC == "ads131m02":
            return bool(self.adc.frames)
        return len(self.adc.received) == len(CONFIG)

    def check_config(self) -> None:
        if ADC == "ads131m02":
            assert self.adc.frames == [CONFIG_FRAME], self.adc.frames
        else:
            assert self.adc.received == CONFIG, [hex(b) for b in self.adc.received]

    async def write(self, name: str, value: int) -> None:
        """MCU register write of a field value (two's complement for signed fields)."""
        await self.mcu.write(regmap.REGISTERS[name].addr // 4, value)

    async def read(self, name: str) -> int:
        """MCU register read, decoded as the field's value (sign-extended when signed)."""
        return regmap.decode(name, await self.mcu.read(regmap.REGISTERS[name].addr // 4))

    async def pwm_high_clks(self) -> int:
        """High time in clocks of the next full PWM period on drive_pwm."""
        d = self.dut
        await FallingEdge(d.clk)
        for _ in range(2 * PWM_PERIOD_CLKS):  # a low clock, then the first high one
            was_low = not d.drive_pwm.value
            await FallingEdge(d.clk)
            if was_low and d.drive_pwm.value:
                break
        else:
            raise AssertionError("no PWM period starts on drive_pwm")
        for high in range(1, PWM_PERIOD_CLKS):
            await FallingEdge(d.clk)
            if not d.drive_pwm.value:
                return high
        raise AssertionError("drive_pwm stuck high")


@cocotb.test()
async def mcu_and_adc_drive_the_loop(dut):
    """SPI writes and ADC samples through the board wiring: commands and PWM as the model."""
    tb = await _configured(dut)
    assert await tb.mcu.read(regmap.ID // 4) == 0x424F0100

    # Disabled: 50 % duty (0 A), drive off.
    assert await tb.pwm_high_clks() == PWM_PERIOD_CLKS // 2
    assert not dut.drive_enable.value and not dut.fault.value

    # Configure as firmware would, then enable with tension steps: every command is checked.
    tb.tension_n = 8.0
    tb.adc_on = True
    await tb.write("KP", round(0.2 * 2**13))  # 0.2 A/N, Q2.13
    await tb.write("KI_TS", round(0.01 * 2**20))  # 0.01 A/N per sample
    await tb.write("TC", 12 * 256)  # 12 N, Q7.8
    await tb.write("CTRL", regmap.CTRL_ENABLE)
    for tc_n, t_n in ((12, 14.0), (20, 14.0), (-5, 3.5), (30, 10.0)):
        tb.tension_n = t_n
        await tb.write("TC", tc_n * 256)
        await ClockCycles(dut.clk, 10 * CLKS_PER_SAMPLE)
    assert dut.drive_enable.value, (await tb.mcu.read(regmap.FAULT // 4), tb.samples_seen)
    assert tb.model.u != 0

    # Steady state (no integral action, constant tension): read-backs and the PWM duty.
    await tb.write("KI_TS", 0)
    await tb.write("CTRL", regmap.CTRL_ENABLE | regmap.CTRL_INTEG_RESET)
    tb.tension_n = 10.0
    await tb.write("TC", 15 * 256)
    await ClockCycles(dut.clk, 5 * CLKS_PER_SAMPLE)
    m = tb.model
    # u = Kff*T_c + Kp*e (README "The loop"): 0.088 A/N * 15 N + 0.2 A/N * 5 N = 2.32 A.
    assert abs(m.u / 4096 - 2.32) < 2e-3, m.u
    assert await tb.read("U") == m.u
    assert await tb.read("T_IN") == m.t_in == 10 * 256
    assert await tb.read("KP") == round(0.2 * 2**13)
    assert await tb.mcu.read(regmap.STATUS // 4) == regmap.STATUS_OUT_EN
    # T_out, sampled with T_in on the ADS131M02's CH1, is read back raw (0 with the ADS1220).
    assert await tb.read("T_OUT") == tb.aux_sent
    assert await tb.mcu.read(regmap.ADC_FLAGS // 4) == 0
    high = await tb.pwm_high_clks()
    assert high == pwm_duty_clks(m.u, True), (high, m.u)
    # 50 % + 40 % * u / 4 A (README "Drive and ADC interfaces"), to one clock.
    assert abs(high - PWM_PERIOD_CLKS * (0.5 + 0.4 * m.u / PWM_IMAX_Q12)) <= 1

    # The ADC stops: ADC_STALE (10 samples) latches, the drive drops, the PWM returns to 50 %.
    tb.adc_on = False
    await ClockCycles(dut.clk, 15 * CLKS_PER_SAMPLE)
    assert dut.fault.value and not dut.drive_enable.value
    assert await tb.mcu.read(regmap.FAULT // 4) == FAULT_ADC_STALE == m.faults
    assert await tb.pwm_high_clks() == PWM_PERIOD_CLKS // 2
    # The ADS131M02's reader also flags the lost DRDY, which the MCU can tell from a bad frame.
    await ClockCycles(dut.clk, DRDY_TIMEOUT_CLKS)
    lost = regmap.ADC_FLAGS_DRDY_LOST if ADC == "ads131m02" else 0
    assert await tb.mcu.read(regmap.ADC_FLAGS // 4) == lost
    assert tb.compared > 80, f"only {tb.compared} samples compared"
    assert tb.pwm_periods > 40, f"only {tb.pwm_periods} PWM periods checked"
    assert tb.samples_seen > 20 and not tb.sent


async def _configured(dut) -> SystemTb:
    """The system after reset, with the ADC front-end done configuring the ADC (over adc_din,
    before anything else)."""
    tb = SystemTb(dut)
    await tb.start()
    for _ in range(3000):
        await RisingEdge(dut.clk)
        if tb.configured():
            break
    tb.check_config()
    return tb


@cocotb.test()
async def refused_accesses_are_reported_over_spi(dut):
    """The MCU learns from the status byte that a write or read was refused, and nothing moved.

    Word 65 used to alias onto CTRL (word 1): now DECERR without a bus access. Unmapped words of
    the map answer SLVERR; writes to read-only registers are ignored with OKAY (documented).
    """
    tb = await _configured(dut)
    ctrl_word = regmap.CTRL // 4
    enable = regmap.CTRL_ENABLE
    w_err = STATUS_TAG | STATUS_WRITE | STATUS_DONE
    r_err = STATUS_TAG | STATUS_DONE
    assert await tb.mcu.write_status(64 + ctrl_word, enable) == w_err | RESP_DECERR
    assert await tb.mcu.write_status(40, enable) == w_err | RESP_SLVERR
    assert await tb.mcu.write_status(regmap.STATUS // 4, 0xF) == WRITE_OKAY
    assert await tb.mcu.read_status(64 + ctrl_word) == (0, r_err | RESP_DECERR)
    assert await tb.mcu.read_status(40) == (0, r_err | RESP_SLVERR)
    assert await tb.mcu.read_status(ctrl_word) == (0, READ_OKAY)
    assert await tb.mcu.read(regmap.STATUS // 4) == 0
    await ClockCycles(dut.clk, 3 * CLKS_PER_SAMPLE)
    assert not dut.drive_enable.value and tb.compared > 0
    # And a good write still works after the refusals.
    await tb.write("CTRL", enable)
    assert await tb.read("KP") == regmap.REGISTERS["KP"].fields[0].reset
    assert await tb.mcu.read_status(ctrl_word) == (enable, READ_OKAY)


@cocotb.test()
async def reset_in_mid_frame_enables_nothing(dut):
    """Reset of the whole system during a frame whose tail reads as "write CTRL = ENABLE".

    The bridge drops the rest of the frame: no bus write, CTRL stays 0, the drive stays off.
    """
    tb = await _configured(dut)
    writes = 0

    async def count_writes() -> None:
        nonlocal writes
        while True:
            await FallingEdge(dut.clk)
            writes += int(dut.axil_awvalid.value and dut.axil_awready.value)

    cocotb.start_soon(count_writes())
    tail = bytes([0x80 | regmap.CTRL // 4]) + regmap.CTRL_ENABLE.to_bytes(4, "big") + bytes(1)
    cocotb.start_soon(reset_after_sck_falls(dut, dut.mcu_sck, 8))
    await tb.mcu.frame(bytes([regmap.ID // 4]) + tail)
    assert writes == 0
    await ClockCycles(dut.clk, 5 * CLKS_PER_SAMPLE)
    assert not dut.drive_enable.value and tb.compared > 0
    assert await tb.mcu.read(regmap.CTRL // 4) == 0
    assert await tb.mcu.read(regmap.ID // 4) == 0x424F0100
    assert writes == 0


@pytest.mark.parametrize(
    ("simulator", "adc"), [simulator_param(sim, adc) for adc in FRONTENDS for sim in SIMULATORS]
)
def test_bowden_system(simulator, adc):
    """Build bowden_system with short clocks per sample and ADC waits, with each front-end; run
    the coroutines above."""
    sources = rtl("bowden_system", "spi_axil_bridge", "ads1220_reader", "ads131m02_reader")
    sources += rtl(
        "bowden_core", "axil_regbus", "bowden_regs", "tension_loop", "tension_loop_dp", "mul_s16"
    )
    sources += rtl("pwm_escon")
    params = {
        "CLK_HZ": CLK_HZ,
        "ADC_ADS131M02": FRONTENDS[adc],
        "ADC_SCLK_HALF_CLKS": SCLK_HALF_CLKS[adc],
        "ADC_WAIT_CLKS": 64,
    }
    run_cocotb(
        "bowden_system",
        "test_bowden_system",
        sources,
        simulator,
        parameters=params,
        tag=adc,
        extra_env={"BOWDEN_TB_ADC": adc},
    )
