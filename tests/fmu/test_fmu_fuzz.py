"""Property-based tests of the plant FMU through its handle (cosim.parts.plant; Hypothesis, profiles
in tests/conftest.py): parameters and inputs in and out of the ranges of modelDescription.xml,
NaN, infinities and values of the wrong type; serialised states with random doubles written into
them. Each run ends in finite outputs or in a PlantError whose message names the variable (or
the state member); never NaN, never a crash."""

from __future__ import annotations

import math
import struct

import numpy as np
from hypothesis import event, given
from hypothesis import strategies as st

from cosim.parts.plant import OUTPUT_NAMES, Plant, PlantError, fmu_variables

VARS = fmu_variables()
PARAMS = [v for v in VARS.values() if v.causality == "parameter"]
INPUTS = ["current_cmd", "T_in_cmd", "x", "y", "z"]
IN_PLANE = {"x": 0.0, "y": 0.6, "z": -0.2}


def _value(var) -> st.SearchStrategy:
    if var.type == "Boolean":
        return st.booleans()
    lo, hi = var.lo, var.hi
    span = hi - lo
    inside = st.floats(lo, hi) if var.type == "Real" else st.integers(int(lo), int(hi))
    edges = st.sampled_from([lo - 0.01 * span - 1, hi + 0.01 * span + 1, math.nan, math.inf])
    return inside | inside | edges


PARAM_SETS = st.lists(st.sampled_from(PARAMS), max_size=4, unique_by=lambda v: v.name).flatmap(
    lambda vs: st.fixed_dictionaries({v.name: _value(v) for v in vs})
)
STEPS = st.lists(
    st.fixed_dictionaries(
        {
            "current_cmd": st.floats(-8, 8) | st.sampled_from([9.0, math.nan]),
            "x": st.floats(-0.3, 0.3),
            "y": st.floats(0.2, 0.8),
            "z": st.floats(-0.5, 0.5) | st.sampled_from([math.inf]),
        }
    ),
    min_size=1,
    max_size=30,
)


def _names_a_variable(message: str, names) -> bool:
    return any(n in message for n in names)


@given(params=PARAM_SETS, steps=STEPS, h=st.sampled_from([1e-4, 1e-3, 3.3e-5]))
def test_fmu_parameters_and_inputs_give_finite_outputs_or_name_the_variable(params, steps, h):
    try:
        plant = Plant(params, inputs=IN_PLANE)
    except PlantError as exc:
        assert _names_a_variable(str(exc), [*params, "x", "y", "z"]), exc
        event("refused at initialisation")
        return
    try:
        for step in steps:
            for i, name in enumerate(("current_cmd", "x", "y", "z")):
                plant.u[INPUTS.index(name)] = step[name]
                del i
            try:
                out = plant.step(h)
            except PlantError as exc:
                assert _names_a_variable(str(exc), [*INPUTS, "max_step", "position"]), exc
                event("refused at a step")
                return
            assert all(math.isfinite(out[k]) for k in range(len(OUTPUT_NAMES)))
        event("finite outputs at every step")
    finally:
        plant.close()


@given(
    writes=st.lists(
        st.tuples(
            st.integers(0, 10**9),
            st.sampled_from([math.nan, math.inf, -math.inf, -1.0, 1e300, -1e300, 0.0, 0.5]),
        ),
        min_size=1,
        max_size=3,
    )
)
def test_fmu_deserialised_state_is_refused_or_steps_to_finite_outputs(writes):
    a = Plant({"noise_std": 0.1, "sensor_delay": 0.002}, inputs=IN_PLANE)
    b = Plant({"noise_std": 0.1, "sensor_delay": 0.002}, inputs=IN_PLANE)
    try:
        for k in range(200):
            a.u[Plant.CURRENT_CMD] = 1.0 + 0.5 * math.sin(k / 20)
            a.step(1e-4)
        state = a._fmu.getFMUState()
        blob = bytearray(a._fmu.serializeFMUState(state))
        a._fmu.freeFMUState(state)
        for pos, value in writes:
            at = 8 * (pos % (len(blob) // 8))
            blob[at : at + 8] = struct.pack("<d", value)
        try:
            restored = b._fmu.deSerializeFMUstate(bytes(blob))
        except Exception:  # noqa: BLE001 (fmpy raises its own exception type)
            msg = b.messages[-1]
            assert msg.startswith(("serialised state rejected", "the bytes are not")), msg
            event("state refused")
            return
        b._fmu.setFMUState(restored)
        b._fmu.freeFMUState(restored)
        b.time_s = a.time_s
        for _ in range(20):
            try:
                out = b.step(1e-4)
            except PlantError:
                event("state taken, a step refused")
                return
            assert np.all(np.isfinite(np.ctypeslib.as_array(out)))
        event("state taken, finite outputs")
    finally:
        a.close()
        b.close()
