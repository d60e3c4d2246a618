"""Property-based tests of the params file (`bowden sim --params FILE`; Hypothesis, profiles in
tests/conftest.py): random JSON documents over the real keys, the FMU's variables and junk, with
numbers in and out of range, NaN, infinities, booleans, null, strings and nesting, and random
bytes. Each file ends in a configuration that the plant FMU and the firmware accept as it is
(no later surprise), or in one ValueError line that names the file and the offending key.
"""

from __future__ import annotations

import json
import math

from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from cosim.config.run import (
    CompensatorParams,
    ControllerParams,
    SimConfig,
    field_ranges,
    load_params,
)
from cosim.config.scenarios import HOME_M, get_scenario
from cosim.engines import experiment as sim
from cosim.parts import firmware
from cosim.parts.plant import Plant, fmu_variables

FMU_VARS = fmu_variables()
FIXTURE_OK = [HealthCheck.function_scoped_fixture]

JSON_LEAF = (
    st.none()
    | st.booleans()
    | st.integers(-(2**40), 2**40)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=8)
)
JSON_ANY = st.recursive(
    JSON_LEAF,
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=6,
)


def _near(lo: float | None, hi: float | None) -> st.SearchStrategy:
    """Numbers inside a range, on its edges and just outside it."""
    lo = -1e9 if lo is None else lo
    hi = 1e9 if hi is None else hi
    span = max(hi - lo, 1e-6)
    return st.floats(lo, hi) | st.sampled_from([lo, hi, lo - 0.01 * span, hi + 0.01 * span])


def _plant_value(name: str) -> st.SearchStrategy:
    var = FMU_VARS.get(name)
    if var is None or var.type == "Boolean":
        return JSON_LEAF
    near = _near(var.lo, var.hi)
    if var.type == "Integer":
        near = near.map(round) | near
    return near | JSON_LEAF


def _section(names: list[str], value) -> st.SearchStrategy:
    return st.dictionaries(st.sampled_from(names) | st.text(max_size=6), JSON_LEAF, max_size=0) | (
        st.lists(st.sampled_from(names) | st.text(max_size=6), max_size=4).flatmap(
            lambda keys: st.fixed_dictionaries({k: value(k) for k in keys})
        )
    )


RANGES = field_ranges(10_000.0)
CONTROLLER = list(ControllerParams.__dataclass_fields__)
COMPENSATOR = list(CompensatorParams.__dataclass_fields__)
PARAMS_DOC = st.fixed_dictionaries(
    {},
    optional={
        "sample_rate_hz": st.sampled_from([10_000, 10_000.0, 20_000, 9_999.5]) | JSON_LEAF,
        "firmware_rate_hz": st.sampled_from([1_000, 1_000.0, 2_000, 3_000]) | JSON_LEAF,
        "plant": _section(sorted(FMU_VARS), _plant_value) | JSON_ANY,
        "controller": _section(
            CONTROLLER, lambda k: _near(*RANGES.get(f"controller.{k}", (None, None))) | JSON_LEAF
        )
        | JSON_ANY,
        "compensator": _section(
            COMPENSATOR, lambda k: _near(*RANGES.get(f"compensator.{k}", (None, None))) | JSON_LEAF
        )
        | JSON_ANY,
        "no_such_key": JSON_ANY,
    },
)


def _keys(doc, prefix: str = "") -> set[str]:
    """Every key of a nested document (the one a message may name)."""
    out = set()
    if isinstance(doc, dict):
        for k, v in doc.items():
            out.add(str(k))
            out |= _keys(v)
    return out


def _check_accepted(cfg: SimConfig) -> None:
    """What an accepted configuration must be: within every range, and taken by the plant FMU
    and the firmware as it is."""
    cfg.validate()
    for name, value in cfg.plant.items():
        var = FMU_VARS[name]
        assert var.causality == "parameter" and name not in ("loop_routing", "drive_mode")
        if var.type == "Integer":
            assert isinstance(value, int)
        if var.lo is not None:
            assert var.lo <= value <= var.hi and math.isfinite(value)
    # The scenario's reach is checked before a run (the sheath may be too short for it); past
    # that check the plant must start.
    try:
        sim.check_reach(get_scenario("characterize"), cfg, None)
    except ValueError as exc:
        assert "plant.sheath_length" in str(exc) and "\n" not in str(exc)
        return
    plant = Plant({"drive_mode": 0, **cfg.plant}, inputs=dict(zip("xyz", HOME_M, strict=True)))
    plant.close()
    fw = firmware.make_firmware(
        "smooth",
        cfg.compensator,
        cfg.compensator.phi_rad if cfg.compensator.phi_rad is not None else 2 * math.pi,
        cfg.firmware_rate_hz,
        cfg.sample_rate_hz,
    )
    assert fw.config.tick_rate_hz == cfg.firmware_rate_hz


@settings(suppress_health_check=FIXTURE_OK)
@given(doc=PARAMS_DOC | JSON_ANY, n=st.integers(0, 10**9))
def test_params_file_is_a_usable_config_or_one_line_naming_file_and_key(tmp_path, doc, n):
    path = tmp_path / f"p{n}.json"
    path.write_text(json.dumps(doc))  # NaN and Infinity as Python's json writes them
    try:
        cfg = load_params(path)
    except ValueError as exc:
        message = str(exc)
        assert "\n" not in message, message
        assert message.startswith((str(path), "--params: ")), message
        keys = _keys(doc)
        if isinstance(doc, dict) and doc:
            named = any(k in message or repr(k) in message for k in keys)
            assert named or "top level" in message, message
        event("refused")
        return
    event("accepted")
    _check_accepted(cfg)


@settings(suppress_health_check=FIXTURE_OK)
@given(raw=st.binary(max_size=64), n=st.integers(0, 10**9))
def test_params_file_of_any_bytes_is_a_config_or_one_line(tmp_path, raw, n):
    path = tmp_path / f"b{n}.json"
    path.write_bytes(raw)
    try:
        cfg = load_params(path)
    except ValueError as exc:
        assert "\n" not in str(exc) and str(path) in str(exc), exc
        event("refused")
    else:
        event("accepted")
        _check_accepted(cfg)
