"""The cable's far end moved by the input end_displacement (fmu/README.md, "Cable
compatibility", A17): what a joint's pulley sets when the FMU is composed with one."""

from __future__ import annotations

import pytest

from cosim.parts.plant import PlantError

GEAR_RATIO, SPOOL_RADIUS_M = 5.4, 0.01  # the FMU's defaults (gear_ratio, spool_radius)


def _hold(make_plant, d_m: float, steps: int = 200):
    """Drive mode 1 at 10 N with the far end at d_m: the motor follows kinematically."""
    plant = make_plant({"drive_mode": 1})
    plant.set("T_in_cmd", 10.0)
    plant.set("end_displacement", d_m)
    plant.u[1] = 10.0
    for _ in range(steps):
        y = plant.step(1e-4)
    return list(y)


def test_end_displacement_moves_the_spool_not_the_tensions(make_plant):
    """The same tensions with the far end 2 mm out: the spool takes up 2 mm less, so the motor
    turns back by d * N / r (to 1e-9 rad); a sign error or a missing term fails it."""
    at_rest = _hold(make_plant, 0.0)
    pulled = _hold(make_plant, 0.002)
    assert pulled[0] == pytest.approx(at_rest[0], abs=1e-12)  # T_in
    assert pulled[1] == pytest.approx(at_rest[1], abs=1e-9)  # T_out
    turn_rad = pulled[5] - at_rest[5]
    assert turn_rad == pytest.approx(-0.002 * GEAR_RATIO / SPOOL_RADIUS_M, abs=1e-9)


def test_a_pulled_far_end_loads_the_cable_and_a_released_one_slackens_it(make_plant):
    """Drive mode 0 with the motor holding about 10 N: pulling the far end 1 mm out raises the
    tension at once (the motor's inertia holds the spool for a step), releasing it 1 mm more
    than the cable's stretch leaves it slack (T_in = 0)."""
    out = {}
    for d_m in (0.0, 0.001, -0.01):
        plant = make_plant({"drive_mode": 0})
        set_end = plant.input_setter("end_displacement")
        plant.u[0] = 0.88  # A: about 10 N through the gearhead
        for _ in range(3000):
            plant.step(1e-4)
        set_end(d_m)
        out[d_m] = plant.step(1e-4)[0]
    assert out[0.001] > out[0.0] + 1.0
    assert out[-0.01] == 0.0
    assert out[0.0] > 5.0


def test_end_displacement_outside_its_range_is_refused(make_plant):
    plant = make_plant()
    with pytest.raises(PlantError, match="end_displacement"):
        plant.input_setter("end_displacement")(1.5)
    with pytest.raises(KeyError, match="no Real input"):
        plant.input_setter("mu")
