"""The interface stage between plant and core (cosim.parts.interface): the board's ADC at its DRDY
times and the PWM -> ESCON set value, on closed-form inputs; and the float reference with each
stage, which shows where the board's chain costs tracking error."""

from __future__ import annotations

import math
import random

import pytest

from cosim.config.run import SimConfig
from cosim.config.scenarios import get_scenario
from cosim.engines import reference
from cosim.parts import interface, rtl_model
from cosim.results import metrics

FS = 10_000.0
DT = 1.0 / FS


def _adc(name: str) -> interface.AdcModel:
    return interface.AdcModel(interface.ADC_PARTS[name], FS, 48e6, 8)


@pytest.mark.parametrize(("name", "delay_periods"), [("ads1220", 0.5), ("ads131m02", 1.5)])
def test_adc_result_of_a_ramp_is_the_ramp_one_group_delay_before_drdy(name, delay_periods):
    """Single-cycle averaging (ADS1220) delays a ramp by half a conversion period, the sinc3
    (ADS131M02) by 1.5 periods: the filters' group delays."""
    adc = _adc(name)
    slope = 100.0  # N/s
    for j in range(200):
        adc.record(slope * j * DT)
    p = adc.period
    for i in range(3, 30):
        d = (i + 1) * p
        assert adc.conversion(i) == pytest.approx(slope * (d - delay_periods * p), abs=1e-9)


def test_ads1220_delivers_each_conversion_once_at_its_rate_and_age():
    """At 10 kHz the ADS1220 (0.506 ms per conversion) reaches the core every 5th or 6th tick,
    each result clocked out (DRDY + reader latency) before the tick that takes it."""
    adc = _adc("ads1220")
    adc.record(1.0)
    ticks = []
    for k in range(10_000):
        adc.record(1.0)
        v = adc.deliver(k)
        if v is not None:
            assert v == pytest.approx(1.0)
            ticks.append(k)
            d = (adc.last + 1) * adc.period
            age = (k + 1) * DT - d
            assert adc.read_s <= age < adc.read_s + DT
    assert len(ticks) == math.floor((1.0 - adc.read_s) / adc.period)  # 1976 in one second
    assert set(b - a for a, b in zip(ticks, ticks[1:], strict=False)) == {5, 6}
    # 24 bits at a 3 MHz SCLK after a 2-flop synchronizer, and bowden_system's two registers to
    # the core: about 8 us.
    assert adc.read_s == pytest.approx((388 + interface.CORE_PIPE_CLKS) / 48e6)


def test_ads131m02_hands_over_only_the_newest_of_several_conversions():
    adc = _adc("ads131m02")
    adc.record(0.0)
    delivered = []
    for k in range(100):
        adc.record(float(k))
        if adc.deliver(k) is not None:
            delivered.append(adc.last)
    assert len(delivered) == 100  # a fresh sample at every tick (32 kSPS > 10 kHz)
    assert min(b - a for a, b in zip(delivered, delivered[1:], strict=False)) >= 3


@pytest.mark.parametrize("phase_s", [0.0, 13e-6])
@pytest.mark.parametrize("name", ["ads131m02", "ads1220"])
def test_adc_delivers_the_kernel_sum_of_its_definition_to_the_bit(name, phase_s):
    """deliver's planned sums (numpy node positions, one interval's terms taken once) and the
    inlined conversion give the bits of the definition, fsum(w * value(d_i - offset)) that the
    native engine mirrors, on a noisy input and across a plan block; the ADS131M02's
    conversions take the planned path, the ADS1220's (five intervals per window) the loop."""
    adc = interface.AdcModel(interface.ADC_PARTS[name], FS, 48e6, 4, phase_s)
    looped = []
    conversion = adc.conversion
    adc.conversion = lambda i: looped.append(i) or conversion(i)
    rng = random.Random(11)
    adc.record(rng.uniform(-50.0, 50.0))
    n = interface.PLAN_TICKS + 300
    delivered = 0
    for k in range(n):
        adc.record(rng.uniform(-50.0, 50.0))
        v = adc.deliver(k)
        if v is None:
            continue
        delivered += 1
        d = adc.phase + (adc.last + 1) * adc.period
        ref = math.fsum(w * adc.value(d - o) for o, w in zip(adc.offsets, adc.weights, strict=True))
        assert v.hex() == ref.hex(), f"tick {k}: {v!r} != {ref!r}"
    if name == "ads131m02":
        assert delivered == n and len(looped) <= 1  # the first one reaches before t_0
    else:
        assert delivered == len(looped) > n // 6


def _escon(fixed: bool, resolution: float = interface.ESCON_DUTY_RESOLUTION):
    return interface.PwmEscon(FS, 5000.0, 48e6, 16384, 4.0, 0.0, fixed, resolution)


def test_escon_applies_the_command_of_the_tick_before_a_period_one_period_later():
    """u_k rides the PWM period that starts at tick k+1 (only when (k+1) % 2 == 0) and reaches the
    plant one period later plus one current-controller sample (1 / 53.6 kHz)."""
    drive = _escon(fixed=True)
    frac = (1.0 / interface.ESCON_CURRENT_LOOP_HZ) / DT
    seen = [drive.segments(k, 0) for k in range(4)]
    assert all(s == ((DT, 0.0),) for s in seen)
    # u changes at tick 4 (not latched: (4 + 1) % 2 != 0) and at tick 5 (latched).
    assert drive.segments(4, 4096) == ((DT, 0.0),)
    assert drive.segments(5, 8192) == ((DT, 0.0),)
    assert drive.segments(6, 8192) == ((DT, 0.0),)
    (a, i_old), (b, i_new) = drive.segments(7, 8192)  # period [t6, t8) ends at t8 = step 7's end
    assert (a, b) == pytest.approx((frac * DT, (1 - frac) * DT))
    assert i_old == 0.0 and i_new == pytest.approx(2.0, abs=0.005)  # 2 A, to the ESCON's 10 mA
    assert drive.segments(8, 8192) == ((DT, i_new),)


@pytest.mark.parametrize("fixed", [True, False])
def test_escon_set_value_steps_and_saturates_at_full_scale(fixed):
    """Set values are whole steps of the ESCON's 0.1 % duty resolution (10 mA at 4 A full scale);
    a command beyond +-I_max gives exactly +-4 A (duty 90 % / 10 %)."""
    drive = _escon(fixed)
    step_a = interface.ESCON_DUTY_RESOLUTION / 0.4 * 4.0
    for u_a in (-9.0, -4.0, -1.23456, 0.0, 0.001, 2.5, 3.9999, 4.0, 7.99):
        u = max(-32768, min(32767, round(u_a * 4096))) if fixed else u_a
        i_set = drive.set_value(drive.duty(u))
        assert abs(i_set / step_a - round(i_set / step_a)) < 1e-6, (u_a, i_set)
        assert abs(i_set - max(-4.0, min(4.0, u_a))) <= step_a / 2 + 4.0 / 9600 / 0.4 + 1e-9
    assert drive.set_value(drive.duty(32767 if fixed else 8.0)) == pytest.approx(4.0)
    assert drive.set_value(drive.duty(-32768 if fixed else -8.0)) == pytest.approx(-4.0)
    assert _escon(fixed, 0.0).set_value(0.5 + 0.4 * 1.2345 / 4.0) == pytest.approx(1.2345)


def test_pwm_duty_of_fixed_and_float_agree_to_one_clock():
    fixed, flt = _escon(True), _escon(False)
    for word in range(-20000, 20000, 37):
        assert abs(fixed.duty(word) - flt.duty(word / 4096.0)) <= 1.0 / 9600


def test_ideal_chain_is_the_interface_before_issue_11():
    cfg = SimConfig()
    chain = interface.make_chain(cfg, "ideal", fixed=True)
    assert chain.start(3.0) == rtl_model.adc_code_from_tension(3.0)
    assert chain.drive(0, 4096) == ((DT, 1.0),)
    assert chain.sense(0, 5.0) == rtl_model.adc_code_from_tension(5.0)
    flt = interface.make_chain(cfg, "ideal", fixed=False)
    assert flt.drive(0, 1.5) == ((DT, 1.5),) and flt.sense(0, 5.0) == 5.0


def test_interface_bad_input_names_the_input():
    with pytest.raises(ValueError, match="interface must be one of board, adc, ideal"):
        interface.make_chain(SimConfig(), "dac", fixed=True)
    with pytest.raises(ValueError, match="board.adc must be one of ads1220, ads131m02"):
        SimConfig.from_dict({"board": {"adc": "hx711"}})
    with pytest.raises(ValueError, match="board.pwm_hz must divide sample_rate_hz"):
        SimConfig.from_dict({"board": {"pwm_hz": 3000}})
    with pytest.raises(ValueError, match="board.sclk_half_clks must be a whole number"):
        SimConfig.from_dict({"board": {"sclk_half_clks": 2.5}})


# --- the cost of the board's chain, and where it is (float reference, 4 s of fig14) -----------


def _split(compensator: str, iface: str, cfg: SimConfig | None = None) -> dict:
    cfg = cfg or SimConfig()
    scen = get_scenario("fig14")
    phi = reference.resolve_phi(scen, cfg, True)
    rec = reference.run_reference(scen, cfg, compensator, True, phi, 4.0, False, iface)
    return metrics.reversal_split(rec["t_s"], rec["T_ref_N"], rec["T_out_N"], 1.0)


@pytest.mark.parametrize("compensator", ["paper", "smooth"])
def test_board_chain_costs_error_near_reversals(compensator):
    """Each stage of the ADS1220 board's chain adds delay (ADC: 0.25 ms mean age + hold; PWM/ESCON:
    one period + a current-controller sample), and the delay costs where T_c moves fastest: at the
    reversals. The error near reversals grows ideal < ADC < board; away from them it moves by
    far less than near them."""
    # The first boards' ADS1220 (the ADS131M02's smaller cost: tests/sensing).
    cfg = SimConfig.from_dict({"board": {"adc": "ads1220"}})
    ideal, adc, board = (_split(compensator, i, cfg) for i in ("ideal", "adc", "board"))
    near = [s["rms_near_reversal_n"] for s in (ideal, adc, board)]
    assert near[0] < near[1] < near[2], near
    grown_near = board["rms_near_reversal_n"] - ideal["rms_near_reversal_n"]
    grown_away = board["rms_away_n"] - ideal["rms_away_n"]
    assert grown_near > 0.03 and grown_near > 3 * abs(grown_away), (ideal, board)


def test_escon_quantization_is_what_widens_fixed_against_float():
    """Fixed point (model chain) against float with the board's chain: once the ESCON's 0.1 %
    duty step is off, within the PWM's own resolution (one clock of the 9600-clock period at
    48 MHz = 1/9600 / 0.4 * 4 A = 1.04 mA = 4.3 LSB, which only the fixed chain has) plus two
    LSB (rounding, and the loop's answer through Kp to the PWM's difference in T_in); measured
    5.2 LSB with the shipped gains. With the step, several times that (measured 14.6 LSB;
    tests/cosim/test_cosim_closed_loop.py states the board's budget)."""
    scen = get_scenario("fig14")
    figures = {}
    for resolution in (0.0, interface.ESCON_DUTY_RESOLUTION):
        cfg = SimConfig.from_dict({"board": {"escon_duty_resolution": resolution}})
        phi = reference.resolve_phi(scen, cfg, True)
        fixed = reference.run_model_chain(scen, cfg, "paper", True, phi, 2.0, "board")
        flt = reference.run_reference(scen, cfg, "paper", True, phi, 2.0, False, "board")
        fvf = metrics.fixed_vs_float(
            fixed["current_A"], flt["current_A"], fixed["T_out_N"], flt["T_out_N"], 64.0
        )
        figures[resolution] = fvf["current_max_lsb"]
    pwm_step_lsb = 1.0 / 9600 / 0.4 * 4.0 * 4096
    assert figures[0.0] <= pwm_step_lsb + 2.0, figures
    assert figures[interface.ESCON_DUTY_RESOLUTION] > 2.0 * figures[0.0], figures
