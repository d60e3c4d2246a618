"""Bad input: fmi2Error with a message naming the variable and the allowed range; the FMU
never crashes and never outputs NaN."""

from __future__ import annotations

import math

import pytest

from cosim.parts.geometry import bending_angle
from cosim.parts.plant import Plant, PlantError


@pytest.mark.parametrize(
    "name, value, allowed",
    [
        ("mu", -0.1, "[0, 1]"),
        ("mu", math.nan, "[0, 1]"),
        ("sheath_length", -1.0, "[0.01, 10]"),
        ("sheath_length", 0.0, "[0.01, 10]"),
        ("spool_radius", math.inf, "[0.001, 0.1]"),
        ("noise_std", -0.5, "[0, 10]"),
        ("sensor_delay", 0.5, "[0, 0.2]"),
        ("sensor_gain", 0.0, "[0.1, 10]"),
        ("drive_mode", 2, "[0, 1]"),
        ("seed", -3, "[0, 2.14748e+09]"),
        ("max_step", 1.0, "[1e-07, 0.001]"),
    ],
)
def test_out_of_range_parameter_is_refused(fmu_path, name, value, allowed):
    with pytest.raises(PlantError) as err:
        Plant({name: value}, fmu_path=fmu_path)
    assert f"{name} = " in str(err.value)
    assert f"allowed range is {allowed}" in str(err.value)


@pytest.mark.parametrize("name", ["current_cmd", "T_in_cmd", "x", "y", "z"])
@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_non_finite_input_is_refused_and_outputs_stay_finite(make_plant, name, value):
    plant = make_plant()
    plant.step_current(1.0, 1e-3)
    before = list(plant.y)
    plant.u[["current_cmd", "T_in_cmd", "x", "y", "z"].index(name)] = value
    with pytest.raises(PlantError, match=f"{name} = (nan|inf|-inf) is not a finite number"):
        plant.step(1e-4)
    assert list(plant.y) == before
    for out in ("T_in", "T_out", "T_in_meas", "T_out_meas", "phi", "current"):
        assert math.isfinite(plant.get(out))


def test_current_command_beyond_the_q3_12_range_is_refused(make_plant):
    plant = make_plant()
    plant.u[Plant.CURRENT_CMD] = 9.0
    with pytest.raises(
        PlantError, match=r"current_cmd = 9 is out of range; allowed range is \[-8, 8\]"
    ):
        plant.step(1e-4)


@pytest.mark.parametrize(
    "position",
    [(1.2, 0.0, 0.0), (0.0, 0.8, -0.8), (0.0, -0.1, 0.0), (0.0, 0.0, 1.0 + 1e-6)],
)
@pytest.mark.parametrize("loop_routing", [True, False])
def test_position_outside_the_workspace_is_refused(make_plant, fmu_path, position, loop_routing):
    x, y, z = position
    with pytest.raises(PlantError, match=r"outside the reachable workspace: allowed is sqrt"):
        Plant({"loop_routing": loop_routing}, {"x": x, "y": y, "z": z}, fmu_path=fmu_path)
    plant = make_plant({"loop_routing": loop_routing})
    plant.step(1e-4)
    plant.u[Plant.X], plant.u[Plant.Y], plant.u[Plant.Z] = position
    with pytest.raises(PlantError, match=r"sheath_length = 1 m and y >= 0"):
        plant.step(1e-4)
    # back inside, the run goes on
    plant.u[Plant.X], plant.u[Plant.Y], plant.u[Plant.Z] = 0.0, 0.6, -0.2
    plant.step(1e-4)
    expected = bending_angle(0.0, 0.6, -0.2, 1.0, loop_routing)
    assert plant.y[Plant.PHI] == pytest.approx(expected, abs=1e-12)


def test_workspace_boundary_itself_is_allowed(make_plant):
    for position in [(0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.6, 0.0, 0.8)]:
        x, y, z = position
        for loop in (True, False):
            plant = make_plant({"loop_routing": loop}, {"x": x, "y": y, "z": z})
            assert math.isfinite(plant.y[Plant.PHI])


def test_fixed_parameter_cannot_change_after_initialisation(make_plant):
    plant = make_plant()
    with pytest.raises(PlantError, match="parameter mu is fixed"):
        plant.set("mu", 0.1)


def test_outputs_cannot_be_set(make_plant):
    plant = make_plant()
    with pytest.raises(PlantError, match="T_out is an output and cannot be set"):
        plant.set("T_out", 1.0)


@pytest.mark.parametrize("step_s", [0.0, -1e-4, math.nan])
def test_bad_communication_step_is_refused(make_plant, step_s):
    plant = make_plant()
    with pytest.raises(PlantError, match="communicationStepSize .* must be > 0"):
        plant.step(step_s)


def test_extreme_but_allowed_inputs_stay_finite(make_plant):
    """Full-scale current commands at the extremes of the allowed parameters, bang-bang."""
    plant = make_plant(
        {
            "mu": 1.0,
            "free_length": 0.001,
            "cable_EA": 1e8,
            "loadcell_stiffness": 1e9,
            "motor_inertia": 1e-9,
            "current_limit": 8.0,
            "max_step": 1e-3,
        },
        {"x": 0.0, "y": 0.01, "z": 0.0},
    )
    for k in range(2000):
        plant.step_current(8.0 if (k // 50) % 2 else -8.0, 1e-4)
        assert all(math.isfinite(v) for v in plant.y), list(plant.y)


def test_stiffest_cable_with_the_largest_step_stays_stable(make_plant):
    """The motor and the cable are integrated implicitly together, so even the stiffest
    allowed cable with the largest allowed internal step gives bounded tensions: at most the
    overshoot of a stall at the current limit (8 A -> 91 N static)."""
    plant = make_plant(
        {
            "free_length": 0.001,
            "cable_EA": 1e8,
            "loadcell_stiffness": 1e9,
            "motor_inertia": 1e-9,
            "motor_damping": 0.0,
            "current_limit": 8.0,
            "max_step": 1e-3,
        }
    )
    stall_n = 8.0 * 5.4 * 0.9 * 0.0234 / 0.01
    peak = 0.0
    for k in range(3000):
        plant.step_current(8.0 if (k // 300) % 2 else 0.0, 1e-3)
        assert all(math.isfinite(v) for v in plant.y)
        peak = max(peak, plant.y[Plant.T_IN])
    assert stall_n * 0.9 < peak < 2.0 * stall_n


@pytest.mark.parametrize("value", [math.inf, math.nan, 0.5])
def test_an_integer_parameter_that_is_not_a_whole_number_is_refused_by_name(value):
    """Plant.set of drive_mode = inf, nan or 0.5: a PlantError naming the parameter (it was a
    bare OverflowError or ValueError from int(), or 0.5 silently set as 0)."""
    with pytest.raises(PlantError, match="drive_mode"):
        Plant({"drive_mode": value})
