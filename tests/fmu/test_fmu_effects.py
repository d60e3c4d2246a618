"""Each effect parameter is off by default and changes the outputs as its name says."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.parts.plant import Plant

MU = 0.075
PHI = 2 * math.pi
EFF = math.exp(-MU * PHI)


def ramp(plant: Plant, tension_n: np.ndarray, dt_s: float = 1e-4) -> np.ndarray:
    out = np.empty((len(tension_n), 8))
    for k, value in enumerate(tension_n.tolist()):
        plant.u[Plant.T_IN_CMD] = value
        out[k] = plant.step(dt_s)
    return out


def loading_mu(out: np.ndarray, k: int, phi: float = PHI) -> float:
    """Friction coefficient seen at sample k on the loading line."""
    return -math.log(out[k, Plant.T_OUT] / out[k, Plant.T_IN]) / phi


def test_effects_are_off_by_default(make_plant):
    plant = make_plant({"drive_mode": 1})
    out = ramp(plant, np.linspace(0, 20, 2000))
    assert np.array_equal(out[:, Plant.T_OUT_MEAS], out[:, Plant.T_OUT])
    assert np.array_equal(out[:, Plant.T_IN_MEAS], out[:, Plant.T_IN])
    assert loading_mu(out, -1) == pytest.approx(MU, rel=1e-12)


def test_sensor_offset_shifts_only_the_output_sensor(make_plant):
    plant = make_plant({"drive_mode": 1, "sensor_offset": 0.5})
    out = ramp(plant, np.linspace(0, 20, 500))
    assert np.allclose(out[:, Plant.T_OUT_MEAS] - out[:, Plant.T_OUT], 0.5, atol=1e-12)
    assert np.array_equal(out[:, Plant.T_IN_MEAS], out[:, Plant.T_IN])


def test_sensor_gain_scales_the_output_sensor(make_plant):
    plant = make_plant({"drive_mode": 1, "sensor_gain": 1.1})
    out = ramp(plant, np.linspace(0, 20, 500))
    assert np.allclose(out[:, Plant.T_OUT_MEAS], 1.1 * out[:, Plant.T_OUT], rtol=1e-12)


def test_mu_viscous_raises_friction_with_cable_speed(make_plant):
    """The same 0 -> 20 N ramp in 2 s, 0.2 s and 0.02 s: the faster, the more friction."""
    seen = []
    for n in (20000, 2000, 200):
        plant = make_plant({"drive_mode": 1, "mu_viscous": 5.0})
        out = ramp(plant, np.linspace(0, 20, n))
        seen.append(loading_mu(out, -1))
    # At 20 N the cable inside the sheath has stretched about 2 mm (mostly 16 N * 1 m / EA of
    # 8000 N), so the slow ramp moves it at about 1 mm/s and the middle one at about 10 mm/s
    # (a little less: the added friction lowers the stretch).
    assert seen[0] == pytest.approx(MU + 5.0 * 0.001, abs=3e-4)
    assert seen[1] == pytest.approx(MU + 5.0 * 0.009, abs=3e-3)
    assert seen[2] > seen[1] + 0.1


def test_mu_viscous_tension_rate_raises_friction_with_the_inlet_tension_rate(make_plant):
    """The second form of viscous friction (fmu/README.md "Viscous friction"): the same 0 -> 20 N
    ramp in 2 s and 0.2 s, so 10 and 100 N/s; once the 10 ms filter of the rate has settled,
    the loading line's mu is mu + mu_viscous_tension_rate * rate, whatever the cable's speed."""
    rate_coef = 1e-3
    for n, rate in ((20000, 10.0), (2000, 100.0)):
        plant = make_plant({"drive_mode": 1, "mu_viscous_tension_rate": rate_coef})
        out = ramp(plant, np.linspace(0, 20, n))
        assert loading_mu(out, -1) == pytest.approx(MU + rate_coef * rate, rel=1e-3)
    # held: the rate decays with the filter and mu returns to the plain coefficient's loading
    # line at a new loading (the held tension itself stays in the dead zone)
    plant = make_plant({"drive_mode": 1, "mu_viscous_tension_rate": rate_coef})
    ramp(plant, np.linspace(0, 20, 2000))
    ramp(plant, np.full(2000, 20.0))
    out = ramp(plant, np.linspace(20, 24, 40000))
    assert loading_mu(out, -1) == pytest.approx(MU + rate_coef * 1.0, rel=1e-3)


def test_friction_drift_warms_up_from_the_start_or_steps_at_an_instant(make_plant):
    """The drift's other forms (fmu/README.md "Friction drift"): a slow ramp keeps the cable on
    its loading line, whose mu is mu + mu_warmup (1 - exp(-(t - t_start)/tau)), or mu + mu_step
    once t >= mu_step_time; t_start is the FMU's start time (the make_plant fixture's 0)."""
    n, dt = 20000, 1e-4  # 2 s of loading, 0 -> 20 N
    plant = make_plant({"drive_mode": 1, "mu_warmup": -0.02, "mu_warmup_tau": 0.5})
    out = ramp(plant, np.linspace(0, 20, n), dt)
    for k in (4999, 9999, n - 1):  # the friction of a step uses the time at its start
        t = k * dt
        expected = MU - 0.02 * (1.0 - math.exp(-t / 0.5))
        assert loading_mu(out, k) == pytest.approx(expected, rel=1e-6)
    # (a falling mu, so that the loading cable follows it at once: a rising one would hold it
    # in a dead zone until the input caught up)
    plant = make_plant({"drive_mode": 1, "mu_step": -0.01, "mu_step_time": 1.00005})
    out = ramp(plant, np.linspace(0, 20, n), dt)
    assert loading_mu(out, 9999) == pytest.approx(MU, rel=1e-9)  # starts at t = 0.9999 s
    assert loading_mu(out, 10001) == pytest.approx(MU - 0.01, rel=1e-9)
    assert loading_mu(out, n - 1) == pytest.approx(MU - 0.01, rel=1e-9)


def test_friction_drift_table_is_linear_between_its_knots_and_flat_outside(make_plant):
    """The drift's free form (fmu/README.md "Friction drift"): mu + d(t), d linear between the
    16 knots mu_drift_table_0 .. 15 at mu_drift_table_t0 + i * mu_drift_table_dt, held at the
    end knots outside them; read on a slow falling-mu loading line, as the warm-up above (every
    knot below the last, so the loading cable follows it at once)."""
    n, dt = 20000, 1e-4  # 2 s of loading, 0 -> 20 N
    knots = [-0.001 * i for i in range(16)]
    table = {f"mu_drift_table_{i}": v for i, v in enumerate(knots)}
    t0, step = 0.5, 0.05  # the knots from 0.5 s to 1.25 s
    plant = make_plant(
        {"drive_mode": 1, "mu_drift_table_t0": t0, "mu_drift_table_dt": step, **table}
    )
    out = ramp(plant, np.linspace(0, 20, n), dt)
    for k in (2000, 6001, 7251, 9000, n - 1):  # the friction of a step uses the time at its start
        t = k * dt
        s = min(max((t - t0) / step, 0.0), 15.0)
        i = min(int(s), 14)
        expected = MU + knots[i] + (s - i) * (knots[i + 1] - knots[i])
        assert loading_mu(out, k) == pytest.approx(expected, rel=1e-6), k
    # a table of zeros is off: every output bit for bit the default's, wherever its knots sit
    runs = []
    for params in ({}, {"mu_drift_table_t0": 0.3, "mu_drift_table_dt": 0.01}):
        plant = make_plant({"drive_mode": 1, "dead_zone_spread": 0.3, **params})
        runs.append(ramp(plant, 10 + 5 * np.sin(np.linspace(0, 12, 4000)), 1e-3))
    assert np.array_equal(runs[0], runs[1])


def test_sensor_tau2_reads_a_step_through_two_equal_stages(make_plant):
    """The second-order form of the sensor's lag (fmu/README.md "Sensor dynamics"): a step of
    the true output is read as 1 - (1 + t/tau) exp(-t/tau) of it (critically damped), at any
    internal step, and not at all by the input sensor."""
    tau = 0.01
    plant = make_plant({"drive_mode": 1, "sensor_tau2": tau, "max_step": 1e-4})
    ramp(plant, np.full(500, 10.0), 1e-3)  # settled at 10 N on the loading line
    before = plant.y[Plant.T_OUT]
    out = ramp(plant, np.full(400, 14.0), 1e-3)
    step = out[0, Plant.T_OUT] - before
    t = np.arange(1, 401) * 1e-3
    expected = before + step * (1.0 - (1.0 + t / tau) * np.exp(-t / tau))
    assert np.allclose(out[:, Plant.T_OUT_MEAS], expected, atol=1e-9 * step)
    assert np.array_equal(out[:, Plant.T_IN_MEAS], out[:, Plant.T_IN])


def test_mu_tension_slope_makes_friction_grow_with_tension(make_plant):
    plant = make_plant({"drive_mode": 1, "mu_tension_slope": 0.002})
    out = ramp(plant, np.linspace(0, 20, 2000))
    low = loading_mu(out, 99)  # about 1 N
    high = loading_mu(out, -1)  # 20 N
    assert low == pytest.approx(MU + 0.002 * 0.8, abs=0.002)
    assert high > low + 0.015


def test_phi_offset_per_z_changes_the_bending_angle_with_z(make_plant):
    base = make_plant({"drive_mode": 1}, {"x": 0.0, "y": 0.5, "z": -0.3})
    tilted = make_plant({"drive_mode": 1, "phi_offset_per_z": 0.8}, {"x": 0.0, "y": 0.5, "z": -0.3})
    assert tilted.y[Plant.PHI] == pytest.approx(base.y[Plant.PHI] + 0.8 * -0.3, abs=1e-12)
    out = ramp(tilted, np.linspace(0, 20, 200))
    assert out[-1, Plant.T_OUT] / out[-1, Plant.T_IN] == pytest.approx(
        math.exp(-MU * (PHI - 0.24)), rel=1e-9
    )


def test_phi_offset_per_x_and_y_change_the_bending_angle_with_x_and_y(make_plant):
    """The bending error's forms along x and y (fmu/README.md "Bending angle error"): each adds
    its coefficient times its coordinate to phi, they add with z's, and the friction sees it."""
    where = {"x": 0.2, "y": 0.5, "z": -0.3}
    base = make_plant({"drive_mode": 1}, where)
    for params, extra in (
        ({"phi_offset_per_x": 1.5}, 1.5 * 0.2),
        ({"phi_offset_per_y": -1.2}, -1.2 * 0.5),
        ({"phi_offset_per_x": 1.5, "phi_offset_per_y": -1.2, "phi_offset_per_z": 0.8}, -0.54),
    ):
        bent = make_plant({"drive_mode": 1, **params}, where)
        assert bent.y[Plant.PHI] == pytest.approx(base.y[Plant.PHI] + extra, abs=1e-12)
        out = ramp(bent, np.linspace(0, 20, 200))
        assert out[-1, Plant.T_OUT] / out[-1, Plant.T_IN] == pytest.approx(
            math.exp(-MU * bent.y[Plant.PHI]), rel=1e-9
        )


def test_the_bending_surface_adds_its_quadratic_terms_to_phi(make_plant):
    """The bending error's free form (fmu/README.md "Bending angle error"): each quadratic term
    adds its coefficient times its pair of coordinates to phi, beside the linear terms."""
    where = {"x": 0.2, "y": 0.5, "z": -0.3}
    base = make_plant({"drive_mode": 1}, where)
    terms = {"xx": 0.04, "yy": 0.25, "zz": 0.09, "xy": 0.1, "xz": -0.06, "yz": -0.15}
    for ab, product in terms.items():
        bent = make_plant({"drive_mode": 1, f"phi_offset_per_{ab}": 2.0}, where)
        assert bent.y[Plant.PHI] == pytest.approx(base.y[Plant.PHI] + 2.0 * product, abs=1e-12)
    surface = {"phi_offset_per_x": 1.5, "phi_offset_per_xz": -4.0, "phi_offset_per_yy": 3.0}
    bent = make_plant({"drive_mode": 1, **surface}, where)
    assert bent.y[Plant.PHI] == pytest.approx(base.y[Plant.PHI] + 0.3 + 0.24 + 0.75, abs=1e-12)
    out = ramp(bent, np.linspace(0, 20, 200))
    assert out[-1, Plant.T_OUT] / out[-1, Plant.T_IN] == pytest.approx(
        math.exp(-MU * bent.y[Plant.PHI]), rel=1e-9
    )


def test_the_slack_table_takes_its_share_off_the_output(make_plant):
    """The slack's free form (fmu/README.md "Slack"): on a loading ramp the output is the
    table-less output times 1 - L(T_in), L linear between the knots at i * slack_table_dt and
    falling to 0 at 8 * slack_table_dt, 0 above; a table of zeros leaves every output bit for
    bit."""
    knots = [0.9, 0.8, 0.6, 0.5, 0.35, 0.2, 0.1, 0.05]
    table = {"slack_table_dt": 1.5, **{f"slack_table_{i}": v for i, v in enumerate(knots)}}
    t_in = np.linspace(0.1, 20, 2000)
    base = ramp(make_plant({"drive_mode": 1}), t_in)
    out = ramp(make_plant({"drive_mode": 1, **table}), t_in)
    lost = np.interp(out[:, Plant.T_IN], 1.5 * np.arange(9), [*knots, 0.0], right=0.0)
    assert np.allclose(out[:, Plant.T_OUT], base[:, Plant.T_OUT] * (1.0 - lost), rtol=1e-12)
    assert np.array_equal(out[-100:, Plant.T_OUT], base[-100:, Plant.T_OUT])  # above 12 N
    zeros = ramp(make_plant({"drive_mode": 1, "slack_table_dt": 0.7}), t_in)
    assert np.array_equal(zeros, base)


def test_sensor_tau_lags_the_output_sensor(make_plant):
    tau = 0.01
    plant = make_plant({"drive_mode": 1, "sensor_tau": tau})
    out = ramp(plant, np.full(300, 10.0))  # a step to 10 N at t = 0
    final = 10.0 * EFF
    assert out[0, Plant.T_OUT] == pytest.approx(final)
    k_tau = round(tau / 1e-4) - 1  # sample at t = tau
    assert out[k_tau, Plant.T_OUT_MEAS] == pytest.approx(final * (1 - math.exp(-1)), rel=1e-6)
    assert out[-1, Plant.T_OUT_MEAS] == pytest.approx(final * (1 - math.exp(-3)), rel=1e-6)


def test_sensor_delay_delays_the_output_sensor(make_plant):
    delay = 0.0125
    plant = make_plant({"drive_mode": 1, "sensor_delay": delay})
    out = ramp(plant, np.concatenate([np.full(100, 0.0), np.linspace(0, 20, 400)]))
    t = np.arange(1, len(out) + 1) * 1e-4
    # T_out_meas(t) = T_out(t - delay): compare on the true signal shifted by 125 samples
    shift = round(delay / 1e-4)
    assert np.allclose(out[shift:, Plant.T_OUT_MEAS], out[:-shift, Plant.T_OUT], atol=1e-9)
    assert np.all(out[t < 0.01 + delay, Plant.T_OUT_MEAS] == 0.0)


def test_mu_drift_changes_friction_over_time(make_plant):
    plant = make_plant({"drive_mode": 1, "mu_drift": 0.002})
    ramp(plant, np.full(10000, 5.0), dt_s=1e-3)  # hold 10 s
    plant.u[Plant.T_IN_CMD] = 0.0
    plant.step(1e-3)  # release completely, then load again at t ~ 10 s
    out = ramp(plant, np.linspace(0, 20, 100), dt_s=1e-3)
    assert loading_mu(out, -1) == pytest.approx(MU + 0.002 * plant.time_s, rel=1e-3)


def test_noise_is_seeded_and_deterministic(make_plant):
    runs = []
    for seed in (7, 7, 8):
        plant = make_plant({"drive_mode": 1, "noise_std": 0.3, "seed": seed})
        runs.append(ramp(plant, np.full(4000, 10.0)))
    assert np.array_equal(runs[0], runs[1])
    assert not np.array_equal(runs[0][:, Plant.T_OUT_MEAS], runs[2][:, Plant.T_OUT_MEAS])
    noise = runs[0][:, Plant.T_IN_MEAS] - runs[0][:, Plant.T_IN]
    assert np.std(noise) == pytest.approx(0.3, rel=0.05)
    assert abs(np.mean(noise)) < 0.02
    assert np.array_equal(runs[0][:, Plant.T_OUT], runs[2][:, Plant.T_OUT])  # truth unaffected
