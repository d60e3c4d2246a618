"""Sheath friction in drive mode 1 (prescribed input tension): paper Fig. 2, 3 and 11."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.parts.geometry import bending_angle
from cosim.parts.plant import Plant
from cosim.results.capstan_fit import fit_capstan

MU = 0.075
PHI = 2 * math.pi


def triangle(peaks, n_per_leg):
    """Piecewise-linear path 0 -> peaks[0] -> peaks[1] -> ... with n_per_leg samples a leg."""
    points = [0.0, *peaks]
    legs = [
        np.linspace(a, b, n_per_leg + 1)[1:] for a, b in zip(points[:-1], points[1:], strict=True)
    ]
    return np.concatenate(legs)


def test_loading_and_unloading_slopes_and_dead_zone(make_plant, tension_runner):
    """Fig. 2: slope exp(-mu*phi) pulling, exp(+mu*phi) releasing, dead zone at reversals."""
    plant = make_plant({"drive_mode": 1})
    assert plant.y[Plant.PHI] == pytest.approx(PHI, abs=1e-12)
    n = 2000  # samples per leg of 0.2 s: quasi-static
    t_in = triangle([20.0, 2.0, 20.0], n)
    out = tension_runner(plant, t_in)
    T_in, T_out = out[:, Plant.T_IN], out[:, Plant.T_OUT]
    eff = math.exp(-MU * PHI)

    load = slice(n // 10, n)  # first leg
    slope_load = np.polyfit(T_in[load], T_out[load], 1)[0]
    assert slope_load == pytest.approx(eff, rel=0.01)
    assert np.allclose(T_out[load], eff * T_in[load], rtol=1e-9)

    # Releasing from 20 N: T_out holds (dead zone) until T_in = 20 N * exp(-2 mu phi)
    release = slice(n, 2 * n)
    t_rel, o_rel = T_in[release], T_out[release]
    corner = 20.0 * math.exp(-2 * MU * PHI)
    dead = t_rel > corner + 1e-6
    assert dead.sum() > n // 2
    assert np.allclose(o_rel[dead], 20.0 * eff, rtol=1e-12)
    slide = t_rel < corner - 0.5
    slope_unload = np.polyfit(t_rel[slide], o_rel[slide], 1)[0]
    assert slope_unload == pytest.approx(1 / eff, rel=0.01)
    assert np.allclose(o_rel[slide], t_rel[slide] / eff, rtol=1e-9)

    # Pulling again from 2 N: dead zone until T_in = 2 N * exp(2 mu phi), then loading line
    again = slice(2 * n, 3 * n)
    t_ag, o_ag = T_in[again], T_out[again]
    corner_up = 2.0 * math.exp(2 * MU * PHI)
    assert np.allclose(o_ag[t_ag < corner_up - 1e-6], 2.0 / eff, rtol=1e-12)
    on_line = t_ag > corner_up + 0.5
    assert np.allclose(o_ag[on_line], eff * t_ag[on_line], rtol=1e-9)


@pytest.mark.parametrize("y_m", [0.999, 0.9, 0.75, 0.6, 0.45, 0.3, 0.15, 0.02])
def test_efficiency_follows_bending_angle(make_plant, tension_runner, y_m):
    """Fig. 3: free sag along the outlet axis bends the sheath from 0 to 2*pi; the loading
    efficiency is exp(-mu*phi) with the phi of the geometry."""
    plant = make_plant({"drive_mode": 1, "loop_routing": False}, {"x": 0.0, "y": y_m, "z": 0.0})
    phi = plant.y[Plant.PHI]
    assert phi == pytest.approx(bending_angle(0.0, y_m, 0.0, 1.0, False), abs=1e-12)
    out = tension_runner(plant, np.linspace(0.1, 15.0, 200))
    assert out[-1, Plant.T_OUT] / out[-1, Plant.T_IN] == pytest.approx(math.exp(-MU * phi), 1e-9)


def test_efficiency_range_zero_to_two_pi(make_plant):
    phis = [
        make_plant({"loop_routing": False}, {"x": 0.0, "y": y, "z": 0.0}).y[Plant.PHI]
        for y in (1.0, 0.001)
    ]
    assert phis[0] == pytest.approx(0.0, abs=1e-9)
    assert phis[1] == pytest.approx(2 * math.pi, abs=0.01)


def characterisation(plant: Plant, cycles: int = 5, period_s: float = 3.0, peak_n: float = 24.0):
    """Paper Sec. VI-A: input ramped to 24 N and back over 3 s, five times (10 kHz samples)."""
    t = np.arange(1, int(round(cycles * period_s / 1e-4)) + 1) * 1e-4
    phase = np.mod(t, period_s) / period_s
    t_in = peak_n * (1.0 - np.abs(2.0 * phase - 1.0))
    out = np.empty((len(t), 2))
    u, step = plant.u, plant.step
    for k, value in enumerate(t_in.tolist()):
        u[Plant.T_IN_CMD] = value
        y = step(1e-4)
        out[k, 0] = y[Plant.T_IN_MEAS]
        out[k, 1] = y[Plant.T_OUT_MEAS]
    return out


def test_fig11_characterisation_fits_mu(make_plant):
    """Fig. 11: the capstan fit of a characterisation run (noisy sensors) returns mu = 0.075
    within 3 %."""
    plant = make_plant({"drive_mode": 1, "noise_std": 0.05, "seed": 11})
    out = characterisation(plant)
    fit = fit_capstan(out[:, 0], out[:, 1], plant.y[Plant.PHI])
    print(f"fitted mu = {fit.mu:.5f} (rms residual {fit.rms_residual_n:.3f} N)")
    assert fit.mu == pytest.approx(MU, rel=0.03)
    assert fit.rms_residual_n < 0.1  # noise 0.05 N on each sensor


def test_fig11_with_the_papers_sensor_offset(make_plant):
    """The paper saw about 0.5 N of offset; fitting the offset too recovers both."""
    plant = make_plant({"drive_mode": 1, "sensor_offset": 0.5})
    out = characterisation(plant, cycles=2)
    fit = fit_capstan(out[:, 0], out[:, 1], plant.y[Plant.PHI], fit_offset=True)
    assert fit.mu == pytest.approx(MU, rel=0.01)
    assert fit.offset_n == pytest.approx(0.5, abs=0.02)
