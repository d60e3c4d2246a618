"""Figures of merit (cosim/results/metrics.py) on signals whose answer is known in closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.results import metrics
from cosim.results.capstan_fit import capstan_output


def test_cosim_metrics_tracking_error_of_a_sine_error():
    t = np.arange(100_000) / 10_000.0
    t_ref = 15.0 * np.ones_like(t)
    err = 0.5 * np.sin(2 * np.pi * t)  # RMS 0.5/sqrt(2), peak 0.5
    out = metrics.tracking_error(t, t_ref, t_ref - err, settle_s=0.0)
    assert out["rms_error_n"] == pytest.approx(0.5 / math.sqrt(2), rel=1e-4)
    assert out["peak_error_n"] == pytest.approx(0.5, rel=1e-6)
    assert out["rms_error_pct"] == pytest.approx(100 * 0.5 / math.sqrt(2) / 15.0, rel=1e-4)
    assert out["peak_error_pct"] == pytest.approx(100 * 0.5 / 15.0, rel=1e-6)


def test_cosim_metrics_settle_window_excludes_start_and_rejects_empty_window():
    t = np.arange(10) * 0.1
    t_ref = np.full(10, 10.0)
    t_out = t_ref.copy()
    t_out[0] = 0.0  # a start-up error that settle_s must hide
    assert metrics.tracking_error(t, t_ref, t_out, settle_s=0.05)["peak_error_n"] == 0.0
    assert metrics.tracking_error(t, t_ref, t_out)["peak_error_n"] == 10.0
    with pytest.raises(ValueError, match="settle_s = 5 s leaves no sample"):
        metrics.tracking_error(t, t_ref, t_out, settle_s=5.0)


def test_cosim_metrics_fixed_vs_float_counts_lsb():
    u_float = np.linspace(-1, 1, 1000)
    u_fixed = u_float + np.where(np.arange(1000) % 2 == 0, 2, -2) * metrics.CURRENT_LSB_A
    out = metrics.fixed_vs_float(u_fixed, u_float, np.ones(1000) * 1.01, np.ones(1000), 64.0)
    assert out["current_rms_lsb"] == pytest.approx(2.0)
    assert out["current_max_lsb"] == pytest.approx(2.0)
    assert out["t_out_max_n"] == pytest.approx(0.01)
    assert out["t_out_rms_pct_fs"] == pytest.approx(100 * 0.01 / 64.0)


def test_cosim_metrics_fit_capstan_recovers_mu_and_offset():
    mu, phi = 0.075, 2 * math.pi
    t = np.arange(15_000) / 1000.0
    t_in = 24.0 * (1.0 - np.abs(2.0 * np.mod(t, 3.0) / 3.0 - 1.0))
    t_out = capstan_output(t_in, mu, phi) + 0.5
    fit = metrics.fit_capstan(t_in, t_out, phi_rad=phi)
    assert fit["mu"] == pytest.approx(mu, rel=1e-3)
    assert fit["mu_phi"] == pytest.approx(mu * phi, rel=1e-3)
    assert fit["efficiency"] == pytest.approx(math.exp(-mu * phi), rel=1e-3)
    assert fit["offset_n"] == pytest.approx(0.5, abs=1e-3)
    with pytest.raises(ValueError, match="phi_rad = 0.0 must be > 0"):
        metrics.fit_capstan(t_in, t_out, phi_rad=0.0)


def test_cosim_metrics_reversal_times_of_a_sine_with_a_quantized_plateau():
    t = np.arange(40_000) / 10_000.0
    ref = 8.5 - 6.5 * np.cos(2 * np.pi * 0.5 * t)  # extremes at 1 s (max), 2 s (min), 3 s (max)
    ref = np.round(ref * 256) / 256  # Q7.8 steps: flat runs at the extremes must not chatter
    revs = metrics.reversal_times(t, ref, band_n=0.15)
    assert len(revs) == 3
    np.testing.assert_allclose(revs, [1.0, 2.0, 3.0], atol=0.02)
    with pytest.raises(ValueError, match="band_n"):
        metrics.reversal_times(t, ref, band_n=0.0)


def test_cosim_metrics_reversal_split_puts_each_error_where_it_occurs():
    t = np.arange(40_000) / 10_000.0
    ref = 8.5 - 6.5 * np.cos(2 * np.pi * 0.5 * t)
    # A 2 N error during 0.1 s after each reversal, and 0.1 N everywhere else.
    err = np.full_like(t, 0.1)
    for tr in (1.0, 2.0, 3.0):
        err[(t >= tr) & (t < tr + 0.1)] = 2.0
    out = metrics.reversal_split(t, ref, ref - err, settle_s=0.5, window_s=0.3)
    assert out["reversals"] == 3
    assert out["peak_near_reversal_n"] == pytest.approx(2.0)
    assert out["peak_away_n"] == pytest.approx(0.1)
    # Near: a third of each 0.3 s window at 2 N, the rest at 0.1 N.
    assert out["rms_near_reversal_n"] == pytest.approx(math.sqrt((4.0 + 2 * 0.01) / 3), rel=0.01)
    assert out["rms_away_n"] == pytest.approx(0.1)
