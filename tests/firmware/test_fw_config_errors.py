"""Configuration errors of the firmware wrapper (cosim.parts.firmware) name the field and never
escape as a Python error of another kind: huge and non-finite values, whole-number fields given
fractions (nothing is truncated), and the previous configuration stays in force."""

from __future__ import annotations

import math
import pickle

import pytest

from cosim.parts.firmware import (
    Compensator,
    CompensatorF64,
    CompensatorParams,
    Firmware,
    FirmwareConfig,
    FirmwareConfigError,
    WaveParams,
)


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"mu": 1e300}, "comp.mu: outside [0, 1]"),
        ({"mu": -1e300}, "comp.mu: outside [0, 1]"),
        ({"phi_rad": 1e308}, "comp.phi_rad"),
        ({"band_n": math.inf}, "comp.band_n: not a finite number (inf)"),
        ({"mu": math.nan}, "comp.mu: not a finite number (nan)"),
        ({"mu": True}, "comp.mu: expected a number; got True"),
        ({"offset_n": "1"}, "comp.offset_n: expected a number; got '1'"),
        ({"mode": ["paper"]}, "comp.mode: ['paper'] is not one of"),
    ],
)
def test_fw_compensator_config_errors_name_the_field(overrides, message):
    for cls in (Compensator, CompensatorF64):
        with pytest.raises(FirmwareConfigError) as info:
            cls(**overrides)
        assert message in str(info.value)


@pytest.mark.parametrize(
    ("config", "message"),
    [
        (FirmwareConfig(tick_rate_hz=math.nan), "tick_rate_hz: not a finite number (nan)"),
        (FirmwareConfig(tick_rate_hz=1000.7), "tick_rate_hz: 1000.7 is not a whole number"),
        (FirmwareConfig(sample_rate_hz=2**40), "sample_rate_hz: 1099511627776 is outside"),
        (FirmwareConfig(loop={"kff": 1.9}), "loop.kff: 1.9 is not a whole number"),
        (FirmwareConfig(loop={"kff": math.nan}), "loop.kff: not a finite number (nan)"),
        (FirmwareConfig(loop={"kp": 1e12}), "loop.kp: 1000000000000.0 is outside"),
        (FirmwareConfig(loop={"kp": 2**31}), "loop.kp: 2147483648 is outside"),
        (FirmwareConfig(loop={3: 1}), "loop.3: unknown"),
        (FirmwareConfig(wave=WaveParams(phase0_turns=math.inf)), "wave.phase0_turns: not a"),
        (FirmwareConfig(wave=WaveParams(freq_hz=1e300)), "wave.freq_hz"),
        (FirmwareConfig(source=None), "source: None is not one of"),
    ],
)
def test_fw_firmware_config_errors_name_the_field_and_keep_the_previous(config, message):
    fw = Firmware()
    before = fw.config
    with pytest.raises(FirmwareConfigError) as info:
        fw.configure(config)
    assert message in str(info.value)
    assert fw.config is before


def test_fw_whole_numbers_given_as_floats_are_taken_exactly():
    """A rate of 1000.0 Hz is 1000 Hz (SimConfig holds rates as floats), nothing is rounded."""
    fw = Firmware(FirmwareConfig(tick_rate_hz=1000.0, sample_rate_hz=10000.0))
    assert fw.config.tick_rate_hz == 1000.0
    comp = Compensator(CompensatorParams(mode="paper", mu=0.075))
    assert comp.step(10.0) > 10.0


def test_fw_config_error_crosses_a_process_boundary_whole():
    """A study's worker returns it pickled: it arrives as itself, field and code kept (unpickled
    with the formatted text alone it broke the worker pool instead)."""
    with pytest.raises(FirmwareConfigError) as info:
        Compensator(mu=2.0)
    back = pickle.loads(pickle.dumps(info.value))
    assert type(back) is FirmwareConfigError and str(back) == str(info.value)
    assert (back.code, back.field) == (info.value.code, "comp.mu") and back.code != 0
