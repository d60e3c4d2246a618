"""What makes long records affordable (cosim/audit/fit.py, MAX_FIT_FRICTION_SAMPLES and
FRICTION_CACHE; cosim/audit/twin.py, sensor_output_at) gives the numbers it stands in for.

- the sensor read at chosen samples is the sensor read everywhere, then indexed (exactly);
- the friction loop with its exponentials computed once per change is the FMU's (held by the
  twin-FMU test) and is not run again for the sensor's parameters;
- on a record longer than MAX_FIT_FRICTION_SAMPLES (and on every record, at least on a grid of
  FIT_FRICTION_STEP_S) the fits run the friction on every q-th sample: the reading stays within
  a small fraction of the noise floor of the full-rate one, and the fitted parameters stay those
  of the full-rate fit;
- the fits' linear algebra runs OpenBLAS on one thread (cosim/audit/blas.py).
"""

from __future__ import annotations

import numpy as np
import pytest

from cosim.audit import fit, twin
from cosim.audit.data import FIT, prepare
from cosim.audit.effects import BY_CAUSE
from cosim.audit.synthetic import fmu_record
from cosim.results import trace

SENSORS = [
    {},
    {"sensor_offset": 0.3, "sensor_gain": 1.04},
    {"sensor_tau": 0.012, "sensor_full_scale": 14.0, "sensor_saturation_knee": 0.8},
    {"sensor_delay": 0.007, "sensor_full_scale": 12.0},
    {"sensor_creep": -0.05, "sensor_creep_tau": 0.7, "sensor_tau": 0.004, "sensor_delay": 0.003},
]


@pytest.mark.parametrize("sensor", SENSORS)
def test_the_sensor_read_at_chosen_samples_is_the_sensor_read_everywhere(sensor):
    rng = np.random.default_rng(5)
    t_out = 8.0 + np.cumsum(rng.normal(0.0, 0.05, 5000))
    idx = np.sort(rng.choice(5000, 700, replace=False))
    whole = twin.sensor_output(t_out, sensor, 1e-3)[idx]
    assert np.array_equal(twin.sensor_output_at(t_out, sensor, 1e-3, idx), whole)


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    folder = tmp_path_factory.mktemp("long")
    path = fmu_record(
        folder, {"sensor_offset": 0.4, "mu_tension_slope": 0.001}, seed=7, duration_s=40.0
    )
    return prepare(trace.read_trace(path, "measured"), str(path))


def test_the_sensors_parameters_do_not_run_the_friction_again(record, monkeypatch):
    # offset, gain, lag, creep act after the plant: the Jacobian's columns for them reuse the
    # friction of the point they are taken at (before, a one-entry cache ran it again for each)
    data = record
    calls = []
    real = twin.friction_output

    def counting(inputs, params, smooth=False):
        calls.append(dict(params))
        return real(inputs, params, smooth=smooth)

    monkeypatch.setattr(twin, "friction_output", counting)
    ev = fit._Evaluator(data)
    idx = np.flatnonzero(data.roles == FIT)[::50]
    p = {"mu": 0.08, "dead_zone_spread": 0.05, "sensor_offset": 0.1, "sensor_gain": 1.0}
    ev.reading(p, idx)  # the point
    ev.reading({**p, "mu": 0.0801}, idx)  # a friction parameter's column
    ev.reading({**p, "dead_zone_spread": 0.0501}, idx)
    for name, value in (("sensor_offset", 0.1001), ("sensor_gain", 1.0001), ("sensor_tau", 1e-4)):
        ev.reading({**p, name: value}, idx)  # a sensor parameter's column: the point's friction
    assert len(calls) == 3 and ev.friction_runs == 3
    ev.reading({**p, "mu_tension_slope": 1e-4}, idx)
    assert len(calls) == 4


def test_a_long_record_is_fitted_on_a_coarser_friction_grid_with_the_same_result(
    record, monkeypatch
):
    data = record
    effects = (BY_CAUSE["sensor_offset"], BY_CAUSE["tension_dependent_friction"])
    # every record at 1 kHz is fitted on a 2 ms grid (FIT_FRICTION_STEP_S); the reference here
    # is the fit at the full rate
    assert fit._Evaluator(data).q == 2
    monkeypatch.setattr(fit, "FIT_FRICTION_STEP_S", 0.0)
    full = fit.fit_model(data, effects)
    ev_full = fit._Evaluator(data)
    assert ev_full.q == 1
    monkeypatch.setattr(fit, "MAX_FIT_FRICTION_SAMPLES", len(data.t_out_n) // 8)
    ev = fit._Evaluator(data)
    assert ev.q == 8
    idx = ev.on_grid(np.flatnonzero(data.roles == FIT), 1)
    assert np.all(idx % 8 == 0) and len(idx) > 1000
    # the reading on the coarse grid against the full-rate one, sensor with memory or not
    for sensor in ({}, {"sensor_tau": 0.01, "sensor_creep": 0.04, "sensor_creep_tau": 0.8}):
        p = {**full.params, **sensor}
        diff = ev.reading(p, idx) - ev_full.reading(p, idx)
        assert np.sqrt(np.mean(diff * diff)) < 0.1 * data.noise_floor_n
    coarse = fit.fit_model(data, effects)
    for name in ("mu", "sensor_offset", "mu_tension_slope"):
        assert coarse.params[name] == pytest.approx(full.params[name], rel=0.02), name
    # the model it returns is simulated at the full rate
    assert np.array_equal(coarse.prediction, twin.simulate(data.inputs, coarse.params))
    assert coarse.friction_runs < full.friction_runs * 2


@pytest.mark.parametrize(
    "effect",
    [
        {},
        {"mu_viscous": 3.0, "dead_zone_spread": 0.3},
        {"mu_drift": 2e-3, "mu_tension_slope": 1e-3},
        {"sensor_creep": 0.05, "sensor_creep_tau": 0.5, "sensor_tau": 0.01},
        {"mu_static_excess": 0.03, "dead_zone_spread": 0.2, "slack_tension": 4.0},
    ],
)
def test_the_fmu_with_one_internal_step_per_sample_is_the_fmu_at_its_default(effect):
    # drive mode 1 holds the inlet tension over a sample: the internal steps repeat the same
    # profile, so the audit's FMU runs (twin.fmu_step_for) report what the default step gives
    n, dt = 3000, 1e-3
    t = np.arange(n) * dt
    t_in = 10 + 6 * np.sin(2 * np.pi * 0.9 * t) + 2 * np.sin(2 * np.pi * 2.7 * t + 1)
    z = 0.3 * np.sin(1.3 * t)
    pos = np.column_stack([0.05 * np.sin(t), 0.5 + 0.2 * np.sin(0.7 * t), z])
    from cosim.parts.geometry import bending_angle  # noqa: PLC0415

    phi = bending_angle(pos[:, 0], pos[:, 1], pos[:, 2], 1.0, True)
    inputs = twin.PlantInputs(t_in, phi, z, pos, 0.0, dt, 1.0, True)
    params = {"mu": 0.08, **effect}
    default = twin.run_fmu(inputs, params)
    one = twin.run_fmu(inputs, params, max_step_s=twin.fmu_step_for(dt))
    assert twin.fmu_step_for(dt) == dt
    # within 1e-4 N; with creep and lag together the default's lag sees the creep move within
    # a sample (1.6e-4 N here, twin.py's docstring), the per-sample step as the twin does
    tol = 5e-4 if "sensor_creep" in effect and "sensor_tau" in effect else 1e-4
    assert np.max(np.abs(one - default)) < tol, np.max(np.abs(one - default))
    assert np.max(np.abs(one - twin.simulate(inputs, params))) < 1e-4


@pytest.mark.parametrize("tau_s", [0.004, 0.05, 1.5])
def test_a_lag_on_the_coarse_grid_is_the_full_rate_lag_of_the_interpolated_input(tau_s):
    q, dt = 12, 1e-3
    coarse = np.cumsum(np.random.default_rng(0).normal(0.0, 1.0, 300))
    n = (len(coarse) - 1) * q + 1
    full = np.interp(np.arange(n), np.arange(0, n, q), coarse)
    lagged = twin.sensor_output(full, {"sensor_tau": tau_s}, dt)[::q]
    assert np.max(np.abs(fit._grid_lag(coarse, tau_s, dt, q) - lagged)) < 1e-12


def test_static_frictions_jumps_have_a_slope_in_the_fits_only():
    # the exact twin moves each breakaway jump by whole samples, so a small change of the
    # excess changes nothing and the least squares sees no slope; the fits' twin (smooth)
    # spreads each jump over its sample by where the threshold was crossed: its output has the
    # same slope from two step sizes, and differs from the exact one only on jump samples
    n, dt = 4000, 1e-3
    t = np.arange(n) * dt
    t_in = 10 + 6 * np.sin(2 * np.pi * 0.9 * t) + 2 * np.sin(2 * np.pi * 2.7 * t + 1)
    phi = np.full(n, 4.0)
    inputs = twin.PlantInputs(t_in, phi, np.zeros(n), None, 0.0, dt, 1.0, True)
    p = {"mu": 0.08, "dead_zone_spread": 0.2, "mu_static_excess": 0.03}

    def out(excess: float, smooth: bool) -> np.ndarray:
        return twin.friction_output(inputs, {**p, "mu_static_excess": excess}, smooth=smooth)

    exact = out(0.03, False)
    assert np.array_equal(exact, twin.friction_output(inputs, p))  # the default is exact
    assert np.array_equal(out(0.03 + 1e-8, False), exact)  # no slope: the problem
    smooth = out(0.03, True)
    slope_a = (out(0.03 + 1e-6, True) - smooth) / 1e-6
    slope_b = (out(0.03 + 1e-7, True) - smooth) / 1e-7
    assert np.sum(slope_a**2) > 0.0
    assert np.sum(slope_a * slope_b) / np.sqrt(np.sum(slope_a**2) * np.sum(slope_b**2)) > 0.99
    jumps = np.abs(np.diff(exact, prepend=exact[0]))
    differ = np.flatnonzero(np.abs(smooth - exact) > 1e-9)
    # each strand breaks loose once after each reversal of the input: one jump sample each
    reversals = int(np.sum(np.diff(np.sign(np.diff(t_in))) != 0))
    assert 0 < len(differ) <= twin.N_STRAND * reversals
    assert np.all(np.abs(smooth - exact)[differ] <= jumps[differ] + 1e-9)
    # without static friction the fits' twin is the exact one
    p0 = {**p, "mu_static_excess": 0.0}
    assert np.array_equal(
        twin.friction_output(inputs, p0, smooth=True), twin.friction_output(inputs, p0)
    )


@pytest.mark.parametrize(
    "effect",
    [
        {"mu_warmup": 0.01, "mu_warmup_tau": 5.0},  # widths change a little every sample
        {"mu_viscous_tension_rate": 0.002},  # ... and by more where the rate moves fast
    ],
)
def test_small_width_changes_keep_the_strands_on_the_fmus_numbers(effect):
    # the twin updates the strands' factors by a polynomial of the change where it is small
    # (twin.STRAND_STEP_MAX) and exactly again every STRAND_EXACT_EVERY samples: over 40 s the
    # FMU, which takes a libm exp per strand and step, agrees to round-off
    n, dt = 40000, 1e-3
    t = np.arange(n) * dt
    rng = np.random.default_rng(3)
    t_in = 11 + 5 * np.sin(2 * np.pi * 0.3 * t) + 2 * np.sin(2 * np.pi * 1.1 * t)
    t_in = t_in + 0.01 * rng.standard_normal(n)
    inputs = twin.PlantInputs(t_in, np.full(n, 2 * np.pi), np.zeros(n), None, 0.0, dt, 1.0, True)
    params = {"mu": 0.09, "dead_zone_spread": 0.5, **effect}
    a = twin.simulate(inputs, params)
    b = twin.run_fmu(inputs, params, max_step_s=twin.fmu_step_for(dt))
    assert np.max(np.abs(a - b)) < 1e-9


@pytest.mark.parametrize(
    "effect",
    [
        {},
        {"mu_drift": 1e-3, "phi_offset_per_z": 0.5},
        {"mu_warmup": 0.01, "mu_warmup_tau": 3.0, "slack_tension": 6.0},
        {"mu_static_excess": 0.03},
        {"mu_static_excess": 0.01, "mu_step": 0.01, "mu_step_time": 7.0},
    ],
)
def test_the_fits_slopes_come_with_the_same_friction(effect):
    # twin.friction_derivatives runs the friction once with its derivatives in mu, the spread
    # and static friction's excess beside it (the fits' Jacobian columns for them): its output
    # is friction_output's to the bit, and each derivative is the central difference's except
    # on the few samples where a step of the parameter moves a clamp or a jump by a sample
    n, dt = 12000, 1e-3
    t = np.arange(n) * dt
    rng = np.random.default_rng(1)
    t_in = 10 + 6 * np.sin(2 * np.pi * 0.9 * t) + 2 * np.sin(2 * np.pi * 2.7 * t + 1)
    t_in = t_in + 0.01 * rng.standard_normal(n)
    phi = 4.0 + np.repeat(rng.uniform(-1, 1, n // 2000), 2000) + 0.1 * np.sin(t)
    inputs = twin.PlantInputs(t_in, phi, 0.3 * np.sin(0.5 * t), None, 0.0, dt, 1.0, True)
    p = {"mu": 0.08, "dead_zone_spread": 0.3, **effect}
    assert twin.derivatives_supported(p)
    for smooth in (False, True):
        value, slopes = twin.friction_derivatives(inputs, p, smooth=smooth)
        assert np.array_equal(value, twin.friction_output(inputs, p, smooth=smooth))
    h = 1e-10  # (a clamp that a step of 1e-8 in mu moves by a sample: 9 samples of this input)
    for name in twin.DERIVATIVE_PARAMS:
        if p.get(name, 0.0) == 0.0:
            continue  # (no slope at static friction's "off": the fits difference it)
        up = twin.friction_output(inputs, {**p, name: p[name] + h}, smooth=True)
        down = twin.friction_output(inputs, {**p, name: p[name] - h}, smooth=True)
        central = (up - down) / (2 * h)
        off = np.abs(central - slopes[name]) > 1e-3 * np.max(np.abs(central))
        assert np.count_nonzero(off) <= 4, (name, np.flatnonzero(off))
    # not supported where a friction term follows the cable's motion or the tension
    assert not twin.derivatives_supported({**p, "mu_viscous": 1.0})
    assert not twin.derivatives_supported({**p, "mu_tension_slope": 1e-3})


def test_a_fit_with_the_slopes_ends_where_the_differences_end(record, monkeypatch):
    # the Jacobian's columns for mu and the spread from the slopes (fit._least_squares) and by
    # forward differences (as before) lead to the same fitted parameters
    data = record
    effects = (BY_CAUSE["sensor_offset"],)
    exact = fit.fit_model(data, effects)
    monkeypatch.setattr(twin, "derivatives_supported", lambda params: False)
    differences = fit.fit_model(data, effects)
    for name in ("mu", "dead_zone_spread", "sensor_offset"):
        assert exact.params[name] == pytest.approx(differences.params[name], rel=1e-3), name
    assert exact.friction_runs < differences.friction_runs


def test_the_audit_runs_openblas_on_one_thread_and_gives_the_count_back():
    # numpy's and scipy's OpenBLAS (separate copies): one thread inside, the count before after
    from threadpoolctl import ThreadpoolController  # noqa: PLC0415

    from cosim.audit import blas  # noqa: PLC0415

    controller = ThreadpoolController()
    libs = controller.select(internal_api="openblas")
    assert len(libs.lib_controllers) >= 2, "numpy's and scipy's OpenBLAS not found"

    def counts() -> list[int]:
        return [
            lib.num_threads
            for lib in ThreadpoolController().select(internal_api="openblas").lib_controllers
        ]

    with controller.limit(limits=2, user_api="blas"):
        with blas.one_thread():
            assert counts() == [1] * len(libs.lib_controllers)
        assert counts() == [2] * len(libs.lib_controllers)
