"""cosim.results.capstan_fit: the capstan model and its fit, on synthetic data."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.results.capstan_fit import capstan_output, fit_capstan


def test_model_has_both_slopes_and_the_dead_zone():
    t_in = np.concatenate([np.linspace(0, 10, 101), np.linspace(10, 0, 101)[1:]])
    out = capstan_output(t_in, 0.1, math.pi)
    eff = math.exp(-0.1 * math.pi)
    assert np.allclose(out[:101], eff * t_in[:101])
    release = t_in[101:]
    held = release > 10 * eff * eff
    assert np.allclose(out[101:][held], 10 * eff)
    assert np.allclose(out[101:][~held], release[~held] / eff)


def test_fit_recovers_mu_and_offset():
    rng = np.random.default_rng(1)
    t = np.linspace(0, 6, 6000)
    t_in = 12 * (1 - np.abs(2 * np.mod(t, 3) / 3 - 1))
    t_out = capstan_output(t_in, 0.09, 2 * math.pi) + 0.3 + rng.normal(0, 0.02, t.size)
    fit = fit_capstan(t_in, t_out, 2 * math.pi, fit_offset=True)
    assert fit.mu == pytest.approx(0.09, rel=0.01)
    assert fit.offset_n == pytest.approx(0.3, abs=0.01)


@pytest.mark.parametrize(
    "args, match",
    [
        ((np.zeros(5), np.zeros(5), 1.0), "at least 10"),
        ((np.zeros(20), np.zeros(21), 1.0), "equal length"),
        ((np.full(20, np.nan), np.zeros(20), 1.0), "finite"),
        ((np.zeros(20), np.zeros(20), 0.0), "phi_rad"),
    ],
)
def test_fit_rejects_bad_data(args, match):
    with pytest.raises(ValueError, match=match):
        fit_capstan(*args)
