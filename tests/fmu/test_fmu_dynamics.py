"""Drive mode 0: current loop, motor, gearhead, spool and elastic cable (paper Table I)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.parts.plant import Plant

KT, GEAR, EFF_GEAR, RADIUS = 0.0234, 5.4, 0.9, 0.01
N_PER_A = GEAR * EFF_GEAR * KT / RADIUS  # 11.37 N/A: the inverse of the contract's Kff


def test_static_torque_balance(make_plant, current_runner):
    """Held current: T_in = i * N * eta * k_t / r (2 A -> 22.7 N, the paper's ~24 N)."""
    plant = make_plant()
    out = current_runner(plant, np.full(5000, 2.0))
    assert out[-1, Plant.T_IN] == pytest.approx(2.0 * N_PER_A, rel=1e-6)
    assert out[-1, Plant.CURRENT] == pytest.approx(2.0, rel=1e-12)
    assert abs(out[-1, Plant.MOTOR_SPEED]) < 1e-3
    # the spool has taken up the cable's stretch: about 3 mm, i.e. 1.6 motor rad
    take_up_m = out[-1, Plant.MOTOR_ANGLE] * RADIUS / GEAR
    assert 1e-3 < take_up_m < 5e-3


def test_current_loop_is_a_first_order_lag_with_limit(make_plant):
    plant = make_plant({"current_bandwidth": 1000.0, "current_limit": 3.0})
    tau = 1.0 / (2 * math.pi * 1000.0)
    plant.step_current(1.0, tau)
    assert plant.y[Plant.CURRENT] == pytest.approx(1.0 - math.exp(-1.0), rel=1e-9)
    for _ in range(100):
        plant.step_current(7.5, 1e-4)
    assert plant.y[Plant.CURRENT] == pytest.approx(3.0, rel=1e-9)


def test_input_tension_cannot_jump(make_plant, current_runner):
    """A current step takes up the cable's slack stretch through the motor's inertia: T_in
    rises over milliseconds (spring-mass mode of the cable and the reflected inertia)."""
    plant = make_plant()
    out = current_runner(plant, np.full(2000, 2.0))
    final = 2.0 * N_PER_A
    t_in = out[:, Plant.T_IN]
    assert t_in[0] < 0.01 * final  # after 100 us
    k_half = int(np.argmax(t_in > 0.5 * final))
    assert 1e-3 < (k_half + 1) * 1e-4 < 50e-3
    # the default damping makes the cable mode about critically damped: no overshoot
    assert t_in.max() < 1.001 * final


def test_lightly_damped_drive_rings_at_the_cable_mode(make_plant, current_runner):
    """With little damping the spring-mass mode of cable and reflected inertia shows: about
    28 Hz while the sheath slides (README, "Integration")."""
    plant = make_plant({"motor_damping": 2e-5})
    current_runner(plant, np.full(5000, 0.5))
    out = current_runner(plant, np.full(3000, 1.0))
    t_in = out[:, Plant.T_IN]
    assert t_in.max() > 1.3 * N_PER_A  # overshoot of the 0.5 A -> 1 A step
    k_peak = int(np.argmax(t_in))
    half_period_s = (k_peak + 1) * 1e-4
    assert 1 / (2 * half_period_s) == pytest.approx(28.0, rel=0.15)


def test_output_is_isometric(make_plant, current_runner):
    """The cable ends at a stiff load cell: T_out follows T_in through the friction only,
    there is no output motion, so with mu = 0 both ends carry the same tension."""
    plant = make_plant({"mu": 0.0})
    out = current_runner(plant, np.linspace(0, 2.0, 3000))
    assert np.allclose(out[:, Plant.T_OUT], out[:, Plant.T_IN], rtol=1e-12)


def test_quasi_static_current_ramp_shows_the_capstan_slopes(make_plant, current_runner):
    """Slow current triangle in drive mode 0: T_out/T_in on the loading and unloading lines."""
    plant = make_plant()
    n = 20000
    current = np.concatenate([np.linspace(0.05, 2.0, n), np.linspace(2.0, 0.05, n)])
    out = current_runner(plant, current)
    eff = math.exp(-0.075 * 2 * math.pi)
    ratio = out[:, Plant.T_OUT] / out[:, Plant.T_IN]
    assert np.allclose(ratio[n // 2 : n], eff, rtol=2e-3)
    assert np.allclose(ratio[-n // 10 :], 1 / eff, rtol=2e-3)


def test_slack_cable_carries_no_tension(make_plant, current_runner):
    plant = make_plant()
    current_runner(plant, np.full(2000, 1.0))
    out = current_runner(plant, np.full(3000, -0.5))
    assert out[-1, Plant.T_IN] == 0.0 and out[-1, Plant.T_OUT] == 0.0
    assert out[-1, Plant.MOTOR_SPEED] < 0.0  # the spool unwinds freely
