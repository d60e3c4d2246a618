"""The audit's noise floor (cosim.audit.core.noise_std): every significance test divides by it,
so it must be right on noisy float data and never zero on a noiseless quantized recording (a
bench recording's tensions are Q7.8 words, 1/256 N apart)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.audit import core

RATE_HZ = 1000.0


def _tension(n: int) -> np.ndarray:
    t = np.arange(n) / RATE_HZ
    return 8.5 + 6.5 * np.sin(2 * np.pi * 0.5 * t)


@pytest.mark.parametrize("sigma_n", [0.005, 0.03, 0.1])
def test_white_noise_on_a_smooth_tension_is_measured_within_ten_percent(sigma_n):
    x = _tension(20_000) + np.random.default_rng(7).normal(0.0, sigma_n, 20_000)
    assert core.noise_std(x) == pytest.approx(sigma_n, rel=0.10)


def test_a_noiseless_quantized_recording_has_the_quantization_noise_as_its_floor():
    q = 1.0 / 256.0  # a Q7.8 telemetry word
    x = np.round(_tension(15_000) / q) * q
    d2 = np.diff(x, 2)
    assert np.mean(d2 == 0.0) > 0.5  # most second differences vanish: the MAD alone says 0
    assert core.quantization_step(x) == pytest.approx(q, rel=1e-9)
    assert core.noise_std(x) == pytest.approx(q / math.sqrt(12.0), rel=1e-9)


def test_float_data_keeps_its_measured_noise_not_a_grid_floor():
    x = _tension(5_000) + np.random.default_rng(3).normal(0.0, 0.02, 5_000)
    assert core.quantization_step(x) < 1e-5
    assert core.noise_std(x) == pytest.approx(0.02, rel=0.15)
