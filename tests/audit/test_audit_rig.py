"""The audit on data from a model it did not write.

A quasi-static rig written here, independently of the plant FMU and of the audit's twin: the
paper's characterisation (ramps of the input tension up and down, Sec. VI-A) repeated with random
peaks and periods while the end-effector is held at a new position every few seconds; lumped
capstan friction (Eq. 1-3) as a state machine of its three regimes; an output sensor whose rollers
add 0.5 N (paper Sec. VI-A, Fig. 11) and sensors with white noise. 60 s at 1 kHz; only
t_s, T_in_N, T_out_N, x_m, y_m, z_m and a sidecar without mu, as the issue asks.
"""

from __future__ import annotations

import json
import math

import audit_cache
import numpy as np
import pytest

from cosim.parts.geometry import bending_angle
from cosim.results import trace

RATE_HZ = 1000.0
MU_RIG = 0.09
ROLLER_OFFSET_N = 0.5
NOISE_N = 0.025


def rig_record(folder, seed: int, duration_s: float = 60.0):
    rng = np.random.default_rng(seed)
    n = int(duration_s * RATE_HZ)
    t = np.arange(n) / RATE_HZ
    # ramps: 0.5 N -> peak -> 0.5 N, peak 8..24 N, 2..4 s per cycle
    t_in = np.empty(n)
    k = 0
    while k < n:
        period = int(rng.uniform(2.0, 4.0) * RATE_HZ)
        peak = rng.uniform(8.0, 24.0)
        phase = np.arange(period) / period
        t_in[k : k + period] = (0.5 + (peak - 0.5) * (1.0 - np.abs(2.0 * phase - 1.0)))[: n - k]
        k += period
    # held positions, a new one every 3..6 s (moved within one sample: a quasi-static rig)
    pos = np.empty((n, 3))
    k = 0
    while k < n:
        hold = int(rng.uniform(3.0, 6.0) * RATE_HZ)
        r = rng.uniform(0.35, 0.8)
        az, el = rng.uniform(-0.3, 0.3), rng.uniform(-0.6, 0.6)
        pos[k : k + hold] = [r * math.sin(az), r * math.cos(az) * math.cos(el), r * math.sin(el)]
        k += hold
    phi = bending_angle(pos[:, 0], pos[:, 1], pos[:, 2], 1.0, True)
    # friction: three regimes (pulling, holding, releasing) of the lumped capstan
    t_out = np.empty(n)
    held = t_in[0] * math.exp(-MU_RIG * phi[0])
    for i in range(n):
        pull = t_in[i] * math.exp(-MU_RIG * phi[i])
        release = t_in[i] * math.exp(MU_RIG * phi[i])
        if held < pull:  # the cable slides towards the end-effector
            held = pull
        elif held > release:  # it slides back
            held = release
        t_out[i] = held  # otherwise it sticks: the dead zone
    meas_in = t_in + rng.normal(0.0, NOISE_N, n)
    meas_out = t_out + ROLLER_OFFSET_N + rng.normal(0.0, NOISE_N, n)
    path = folder / "rig.csv"
    header = "t_s,T_in_N,T_out_N,x_m,y_m,z_m"
    data = np.column_stack([t, meas_in, meas_out, pos])
    np.savetxt(path, data, fmt="%.6f", delimiter=",", header=header, comments="")
    meta = {"sample_rate_hz": RATE_HZ, "sheath_length_m": 1.0, "loop_routing": True}
    trace.meta_path(path).write_text(json.dumps(meta))
    return path


def test_audit_finds_the_rollers_offset_on_a_rig_it_did_not_model(tmp_path, test_cache_dir):
    path = rig_record(tmp_path, seed=501)
    res = audit_cache.audit(path, test_cache_dir)
    named = {f.effect.cause: f.value for f in res.findings}
    assert list(named) == ["sensor_offset"], named
    assert named["sensor_offset"] == pytest.approx(ROLLER_OFFSET_N, abs=0.03)
    assert res.extended.params["mu"] == pytest.approx(MU_RIG, rel=0.02)
    assert res.data.noise_floor_n == pytest.approx(NOISE_N, rel=0.1)
    assert res.holdout_rms_after_n <= 1.15 * res.data.noise_floor_n
    assert res.gain_pct > 90.0
    assert res.unexplained["lines"] == []  # the ramps' residual holds no line
