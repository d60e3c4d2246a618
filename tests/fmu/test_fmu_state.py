"""FMU state save/restore, serialisation, and a variable communication step."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from cosim.parts.plant import Plant

# everything that carries state on: noise generator, sensor lag and delay line, drift
STATEFUL = {
    "noise_std": 0.2,
    "seed": 5,
    "sensor_tau": 0.003,
    "sensor_delay": 0.0123,
    "mu_drift": 0.001,
    "mu_viscous": 2.0,
}


def _drive(plant: Plant, n: int, k0: int = 0) -> np.ndarray:
    out = np.empty((n, 8))
    for k in range(n):
        t = (k0 + k) * 1e-4
        plant.u[Plant.CURRENT_CMD] = 1.5 + 1.0 * np.sin(2 * np.pi * 3 * t)
        plant.u[Plant.Z] = -0.2 + 0.1 * np.sin(2 * np.pi * t)
        out[k] = plant.step(1e-4)
    return out


def test_get_set_state_round_trip(make_plant):
    plant = make_plant(STATEFUL)
    _drive(plant, 1500)
    state = plant.get_state()
    first = _drive(plant, 1500, 1500)
    plant.set_state(state)
    assert plant.get("current") == pytest.approx(plant.get("current"))
    second = _drive(plant, 1500, 1500)
    plant.free_state(state)
    assert np.array_equal(first, second)  # bit-exact, noise and delay line included
    assert np.ptp(first[:, Plant.T_OUT_MEAS] - first[:, Plant.T_OUT]) > 0.1  # noise present


def test_state_restores_into_another_instance_via_serialisation(make_plant):
    a = make_plant(STATEFUL)
    b = make_plant(STATEFUL)
    _drive(a, 800)
    fmu_a, fmu_b = a._fmu, b._fmu
    state = fmu_a.getFMUState()
    blob = fmu_a.serializeFMUState(state)
    fmu_a.freeFMUState(state)
    restored = fmu_b.deSerializeFMUstate(blob)
    fmu_b.setFMUState(restored)
    fmu_b.freeFMUState(restored)
    b.time_s = a.time_s
    assert np.array_equal(_drive(a, 700, 800), _drive(b, 700, 800))


def test_variable_step_matches_fixed_step(make_plant):
    """Drive mode 0 with communication steps from 7 us to 1 ms gives the trajectory of the
    fixed 100 us step at the common points (inputs held piecewise constant in both)."""
    fixed = make_plant()
    variable = make_plant()
    rng = np.random.default_rng(0)
    t = 0.0
    errors = []
    for block in range(200):
        current = 2.0 + np.sin(block / 7.0)
        fixed.u[Plant.CURRENT_CMD] = current
        variable.u[Plant.CURRENT_CMD] = current
        for _ in range(10):
            fixed.step(1e-4)
        remaining = 1e-3
        while remaining > 1e-12:
            h = min(remaining, float(rng.choice([7e-6, 3.3e-5, 1e-4, 2.5e-4, 1e-3])))
            variable.step(h)
            remaining -= h
        t += 1e-3
        errors.append(abs(fixed.y[Plant.T_IN] - variable.y[Plant.T_IN]))
    assert fixed.y[Plant.T_IN] > 10.0
    assert max(errors) < 0.02  # N, of about 20 N: integration error only


def test_variable_step_is_exact_in_drive_mode_1(make_plant):
    """Quasi-static friction has no integration error: any step sequence gives the same."""
    a = make_plant({"drive_mode": 1})
    b = make_plant({"drive_mode": 1})
    for value in np.linspace(0, 20, 50).tolist() + np.linspace(20, 3, 50).tolist():
        a.u[Plant.T_IN_CMD] = value
        b.u[Plant.T_IN_CMD] = value
        a.step(1e-4)
        b.step(3.7e-3)
        assert a.y[Plant.T_OUT] == pytest.approx(b.y[Plant.T_OUT], rel=1e-12)


def _blob_with(blob: bytes, old: float, new: float) -> bytes:
    """The serialised state with every copy of the double `old` replaced by `new`."""
    pattern = struct.pack("<d", old)
    assert pattern in blob, f"{old!r} not found in the state"
    return blob.replace(pattern, struct.pack("<d", new))


@pytest.mark.parametrize(
    ("what", "old_value", "new_value", "message"),
    [
        ("state", "current", math.nan, "is not finite"),
        ("state", "current", math.inf, "is not finite"),
        ("parameter", 0.075, math.nan, "mu = nan; allowed range is [0, 1]"),
        ("parameter", 0.075, 5.0, "mu = 5; allowed range is [0, 1]"),
        ("input", 0.6, 1e300, "y = 1e+300; allowed range is [-10, 10]"),
        ("tension", "T_out", -1.0, "is not a tension >= 0"),
    ],
)
def test_deserialised_state_with_nan_or_out_of_range_values_is_refused(
    make_plant, what, old_value, new_value, message
):
    """fmi2DeSerializeFMUstate checks what it is given (the bytes may come
    from a file); a refused state leaves the instance as it was."""
    a = make_plant(STATEFUL)
    b = make_plant(STATEFUL)
    _drive(a, 800)
    fmu_a, fmu_b = a._fmu, b._fmu
    state = fmu_a.getFMUState()
    blob = bytes(fmu_a.serializeFMUState(state))
    fmu_a.freeFMUState(state)
    if isinstance(old_value, str):  # an output and the state member it copies
        old_value = a.y[Plant.CURRENT if old_value == "current" else Plant.T_OUT]
        assert old_value > 0.1
    bad = _blob_with(blob, old_value, new_value)
    with pytest.raises(Exception, match="deSerialize|fmi2DeSerializeFMUstate|status"):
        fmu_b.deSerializeFMUstate(bad)
    assert message in b.messages[-1], b.messages[-1]
    assert b.messages[-1].startswith("serialised state rejected")
    # The untouched bytes still restore: the check refuses only what is wrong.
    restored = fmu_b.deSerializeFMUstate(blob)
    fmu_b.setFMUState(restored)
    fmu_b.freeFMUState(restored)
    b.time_s = a.time_s
    assert np.array_equal(_drive(a, 100, 800), _drive(b, 100, 800))
