"""The bit-exact loop model (cosim/parts/rtl_model.py) against its double-precision oracle."""

from __future__ import annotations

import random

import pytest

from cosim.parts import regmap
from cosim.parts.rtl_model import (
    DEFAULT_ADC_GAIN,
    DEFAULT_ADC_OFFSET,
    WDT_RAMP_STEP,
    FloatTensionLoop,
    TensionLoopMcModel,
    TensionLoopModel,
    adc_code_from_tension,
    calibrate,
)


def test_ideal_adc_round_trips_within_half_an_lsb():
    """calibrate(adc_code_from_tension(T)) is T to within half an LSB of Q7.8 (and half a code)."""
    for tension_n in [-64.0, -23.456, -0.001, 0.0, 0.00195, 1.0, 24.0, 63.99]:
        code = adc_code_from_tension(tension_n)
        q8 = calibrate(code, DEFAULT_ADC_OFFSET, DEFAULT_ADC_GAIN)
        # Half an LSB of Q7.8 plus half a code (the code itself is rounded first).
        bound_n = (0.5 + 0.5 * DEFAULT_ADC_GAIN / 2**20) / 256
        assert abs(q8 / 256 - tension_n) <= bound_n + 1e-12, (tension_n, q8)
    assert adc_code_from_tension(64.0) == (1 << 23) - 1  # clipped like a real converter
    assert adc_code_from_tension(-1000.0) == -(1 << 23)
    # Offset and gain are honoured: 2x gain halves the code span.
    assert adc_code_from_tension(10.0, 500, 4096) == 500 + 10 * 65536


def test_calibration_saturates_to_q7_8():
    """Codes beyond the Q7.8 range after calibration saturate, never wrap."""
    assert calibrate((1 << 23) - 1, -(1 << 23), 32767) == 32767
    assert calibrate(-(1 << 23), (1 << 23) - 1, 32767) == -32768
    assert calibrate(-(1 << 23), (1 << 23) - 1, -32768) == 32767


def test_bad_arguments_name_the_variable():
    """Errors name the variable and the allowed range."""
    with pytest.raises(ValueError, match="gain=0"):
        adc_code_from_tension(1.0, 0, 0)
    with pytest.raises(ValueError, match="offset=.* outside the allowed range"):
        adc_code_from_tension(1.0, 1 << 23, 2048)
    model = TensionLoopModel()
    with pytest.raises(ValueError, match="code=8388608 outside the allowed range"):
        model.adc_sample(1 << 23)
    with pytest.raises(ValueError, match="KP=40000 outside allowed"):
        model.write("KP", 40000)


def _run(model: TensionLoopModel, ref: FloatTensionLoop, steps: int, rng: random.Random):
    errors = []
    for k in range(steps):
        if k % 50 == 0:
            tc = rng.randint(-30 * 256, 30 * 256)
            model.write("TC", tc)
        t_in_n = 8.0 * ((k // 37) % 3) - 4.0 + rng.uniform(-0.5, 0.5)
        model.adc_sample(adc_code_from_tension(t_in_n))
        out = model.tick()
        # The float loop gets T_c after the floor TC_MIN, as the RTL uses it.
        u_ref = ref.step(max(model.regs["TC"], model.regs["TC_MIN"]) / 256, out.t_in / 256)
        errors.append(out.u / 4096 - u_ref)
    return errors


def test_fixed_point_tracks_float_within_one_lsb():
    """Same inputs, same gains: the command differs from double precision by <= 1 LSB."""
    rng = random.Random(11)
    model = TensionLoopModel()
    for name, value in {"KFF": 721, "KP": 2048, "KI_TS": 4000, "I_LIMIT": 32767}.items():
        model.write(name, value)
    model.write("WDT_TIMEOUT", 0)
    model.write("CTRL", 1)
    ref = FloatTensionLoop.from_registers(model.regs)
    errors = _run(model, ref, 3000, rng)
    worst = max(abs(e) for e in errors)
    assert worst <= 1.0 / 4096, f"worst difference {worst * 4096:.2f} LSB"


def test_saturation_and_recovery_track_float():
    """With the output saturating often, fixed and float agree to a few LSB outside switching."""
    rng = random.Random(5)
    model = TensionLoopModel()
    for name, value in {"KFF": 721, "KP": 4096, "KI_TS": 8000, "I_LIMIT": 4096}.items():
        model.write(name, value)
    model.write("WDT_TIMEOUT", 0)
    model.write("OC_TIMEOUT", 0)
    model.write("CTRL", 1)
    ref = FloatTensionLoop.from_registers(model.regs)
    errors = _run(model, ref, 3000, rng)
    within = sum(abs(e) <= 2.0 / 4096 for e in errors)
    assert within >= 0.99 * len(errors), f"only {within} of {len(errors)} samples within 2 LSB"
    assert max(abs(e) for e in errors) <= 0.05, "a saturation decision diverged for long"


def test_slew_limit_moves_tc_by_at_most_slew_per_sample():
    """With CTRL.SLEW_EN, T_c' steps towards T_c by SLEW per sample and then holds it."""
    model = TensionLoopModel()
    model.write("WDT_TIMEOUT", 0)
    model.write("SLEW", 100)
    model.write("TC", 1000)
    model.write("CTRL", 1 | 8)  # ENABLE | SLEW_EN
    seen = []
    for _ in range(15):
        model.adc_sample(0)
        seen.append(model.tick().tc_eff)
    assert seen[:10] == [100 * (k + 1) for k in range(10)]
    assert seen[10:] == [1000] * 5
    model.write("TC", -32768)  # full-scale step down, still limited
    model.adc_sample(0)
    assert model.tick().tc_eff == 900


def test_mc_model_group_stop_follows_the_faults_at_the_tick():
    """TensionLoopMcModel: a fault latched on channel 0 stops its partner (channel 1) from the
    next tick, one ramp step a sample down to 0, and leaves the other group (channels 2, 3) equal
    to plain single-loop models; clearing the fault restarts the partner a tick later."""
    mc = TensionLoopMcModel([0, 0, 1, 1])
    plain = [TensionLoopModel() for _ in range(4)]
    code = adc_code_from_tension(0.0)
    for m in [*mc.channels, *plain]:
        for name, value in (("WDT_TIMEOUT", 0), ("OC_TIMEOUT", 0), ("TC", 10 * 256)):
            m.write(name, value)
        m.write("CTRL", regmap.CTRL_ENABLE)

    def tick(codes):
        for k, c in enumerate(codes):
            mc.channels[k].adc_sample(c)
            plain[k].adc_sample(c)
        return mc.tick(), [p.tick() for p in plain]

    for _ in range(5):
        out, ref = tick([code] * 4)
    assert out == ref and not any(mc.group_stop)
    out, ref = tick([-(1 << 23)] + [code] * 3)  # below ADC_MIN's reset value: a range fault
    assert out[0].faults == regmap.FAULT_ADC_RANGE and out[0].u == 0
    assert out[1] == ref[1] and not mc.group_stop[1]  # the stop comes with the next tick
    u1 = out[1].u
    out, ref = tick([code] * 4)
    assert mc.group_stop == [False, True, False, False]
    assert out[1].u == u1 - WDT_RAMP_STEP and out[1].wdt_ramp and out[1].integ == 0
    assert out[2:] == ref[2:], "the other group did not run on as single loops"
    mc.channels[0].write("CTRL", regmap.CTRL_ENABLE | regmap.CTRL_FAULT_CLEAR)
    out, _ = tick([code] * 4)
    assert out[0].faults == 0 and mc.group_stop[1]  # cleared in this sample, seen at the next
    out, _ = tick([code] * 4)
    assert not mc.group_stop[1] and out[1].out_en and not out[1].wdt_ramp
    with pytest.raises(ValueError, match="groups"):
        TensionLoopMcModel([])
