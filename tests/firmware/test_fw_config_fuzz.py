"""Property-based tests of the firmware's configuration through the wrapper (cosim.parts.firmware;
Hypothesis, profiles in tests/conftest.py): every field of the compensator, the reference
generator and the loop registers given numbers in and out of range, NaN, infinities, huge values,
booleans, None and strings. Each configuration is taken (and then the compensator's output stays
a Q7.8 word, its double twin finite) or refused with FirmwareConfigError naming the field; never
another exception."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import event, given
from hypothesis import strategies as st

from cosim.parts.firmware import (
    LOOP_FIELDS,
    MODES,
    Compensator,
    CompensatorF64,
    CompensatorParams,
    Firmware,
    FirmwareConfig,
    FirmwareConfigError,
    WaveParams,
)

ANY = (
    st.floats(allow_nan=True, allow_infinity=True)
    | st.floats(-10.0, 10.0)
    | st.integers(-(2**64), 2**64)
    | st.booleans()
    | st.none()
    | st.text(max_size=4)
)
COMP_FIELDS = ("mu", "phi_rad", "mu_slope_per_n", "offset_n", "hysteresis_n", "band_n")
COMP = st.builds(
    CompensatorParams,
    mode=st.sampled_from(sorted(MODES)) | ANY,
    **{name: st.floats(0.0, 4.0) | ANY for name in COMP_FIELDS},
)
REFS = st.lists(st.floats(-200.0, 200.0), min_size=1, max_size=40)


def _names_field(exc: FirmwareConfigError, prefixes: tuple[str, ...]) -> bool:
    return str(exc).startswith(prefixes)


@given(params=COMP, refs=REFS)
def test_fw_compensator_config_is_taken_or_names_the_field(params, refs):
    try:
        comp = Compensator(params)
    except FirmwareConfigError as exc:
        assert _names_field(exc, tuple(f"comp.{n}" for n in ("mode", *COMP_FIELDS))), exc
        event(f"refused: {exc.field}")
        return
    event("accepted")
    words = [comp.step_word(int(np.clip(round(r * 256), -32768, 32767))) for r in refs]
    assert all(-32768 <= w <= 32767 for w in words)
    twin = CompensatorF64(params)
    assert all(math.isfinite(twin.step(r)) for r in refs)


LOOP = st.dictionaries(st.sampled_from(LOOP_FIELDS) | st.text(max_size=4), ANY, max_size=3)
WAVE = st.builds(
    WaveParams,
    kind=st.sampled_from(["constant", "sine", "triangle"]) | ANY,
    mean_n=st.floats(-10, 10) | ANY,
    amplitude_n=st.floats(0, 10) | ANY,
    freq_hz=st.floats(0, 100) | ANY,
    phase0_turns=st.floats(-2, 2) | ANY,
)


@given(
    tick=st.sampled_from([1000, 1000.0, 500]) | ANY,
    sample=st.sampled_from([10_000, 10_000.0]) | ANY,
    source=st.sampled_from(["host", "wave"]) | ANY,
    comp=COMP,
    wave=WAVE,
    loop=LOOP,
    refs=REFS,
)
def test_fw_firmware_config_is_taken_or_names_the_field(
    tick, sample, source, comp, wave, loop, refs
):
    config = FirmwareConfig(
        tick_rate_hz=tick, sample_rate_hz=sample, source=source, comp=comp, wave=wave, loop=loop
    )
    fw = Firmware()
    try:
        fw.configure(config)
    except FirmwareConfigError as exc:
        fields = ("tick_rate_hz", "sample_rate_hz", "source", "comp.", "wave.", "loop.")
        assert _names_field(exc, fields), exc
        assert "\n" not in str(exc)
        event(f"refused: {exc.field.split('.')[0]}")
        return
    event("accepted")
    fw.start()
    for r in refs:
        word = fw.tick(r)
        assert -32768 <= word <= 32767
    assert fw.bad_access == 0
