"""Test data made by the plant FMU in drive mode 1 (the audit's acceptance data): a bench session
with the end-effector held at a new position every few seconds while the input tension wanders,
sensor noise on, and the hidden effects switched on by the caller. The hidden magnitudes and seeds
live in the tests; the audit reads only the CSV and a sidecar without mu."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from cosim.parts.plant import Plant
from cosim.results import trace as tr

RATE_HZ = 1000.0


def session(seed: int, duration_s: float, rate_hz: float = RATE_HZ):
    """Input tension and positions of a random bench session: holds of 2.5-5 s at positions in
    the region of the paper's Fig. 12 (0.25 s cosine moves), and a tension made of three random
    sines between about 1 and 22 N with reversals of every size."""
    rng = np.random.default_rng(seed)
    n = int(round(duration_s * rate_hz))
    t = np.arange(n) / rate_hz
    freqs = rng.uniform([0.15, 0.5, 1.2], [0.4, 1.1, 2.5])
    amps = rng.uniform([4.0, 1.5, 0.5], [6.0, 3.0, 1.2])
    phases = rng.uniform(0, 2 * np.pi, 3)
    t_in = 11.0 + sum(
        a * np.sin(2 * np.pi * f * t + p) for a, f, p in zip(amps, freqs, phases, strict=True)
    )
    t_in = np.maximum(t_in, 0.5)
    pos = np.empty((n, 3))
    k = 0
    prev = np.array([0.0, 0.5, 0.0])
    while k < n:
        hold = int(rng.uniform(2.5, 5.0) * rate_hz)
        new = np.array([rng.uniform(-0.1, 0.1), rng.uniform(0.3, 0.7), rng.uniform(-0.3, 0.3)])
        move = min(int(0.25 * rate_hz), hold)
        w = 0.5 - 0.5 * np.cos(np.pi * np.arange(1, move + 1) / move)
        seg = np.vstack([prev + (new - prev) * w[:, None], np.tile(new, (hold - move, 1))])
        pos[k : k + hold] = seg[: n - k]
        k += hold
        prev = new
    return t, t_in, pos


def fmu_record(
    folder: Path,
    effects: dict[str, float],
    seed: int,
    duration_s: float = 40.0,
    noise_std_n: float = 0.03,
    mu: float = 0.075,
    loop_routing: bool = True,
    hum: tuple[float, float] | None = None,
    positions: bool = True,
    name: str = "rig.csv",
) -> Path:
    """Write `name` (t_s, T_in_N, T_out_N and, with positions, x_m, y_m, z_m) and a sidecar
    without mu; `hum` = (amplitude N, frequency Hz) adds mains pickup to the output sensor."""
    t, t_in, pos = session(seed, duration_s)
    params = {
        "drive_mode": 1,
        "noise_std": noise_std_n,
        "seed": seed,
        "mu": mu,
        "loop_routing": loop_routing,
        **effects,
    }
    if not positions:
        pos = np.tile([0.0, 0.5, 0.0], (len(t), 1))
    out_in = np.empty(len(t))
    out_out = np.empty(len(t))
    with Plant(
        params, inputs={"T_in_cmd": t_in[0], "x": pos[0, 0], "y": pos[0, 1], "z": pos[0, 2]}
    ) as p:
        out_in[0], out_out[0] = p.y[p.T_IN_MEAS], p.y[p.T_OUT_MEAS]
        u = p.u
        for k in range(1, len(t)):
            u[1], u[2], u[3], u[4] = t_in[k], pos[k, 0], pos[k, 1], pos[k, 2]
            y = p.step(1.0 / RATE_HZ)
            out_in[k], out_out[k] = y[p.T_IN_MEAS], y[p.T_OUT_MEAS]
    if hum is not None:
        amp, freq = hum
        out_out = out_out + amp * np.sin(2 * np.pi * freq * t + 0.3)
    cols = {"t_s": t, "T_in_N": out_in, "T_out_N": out_out}
    if positions:
        cols.update({"x_m": pos[:, 0], "y_m": pos[:, 1], "z_m": pos[:, 2]})
    path = Path(folder) / name
    data = np.column_stack(list(cols.values()))
    np.savetxt(path, data, fmt="%.9g", delimiter=",", header=",".join(cols), comments="")
    meta = {"sample_rate_hz": RATE_HZ, "sheath_length_m": 1.0, "loop_routing": loop_routing}
    tr.meta_path(path).write_text(json.dumps(meta))
    return path


# The hidden causes' magnitudes and seeds: the test of the audit's causes (tests/audit) and the
# accuracy sweep (cosim/studies/audit_sweep.py) draw from the same ranges.
def cause_magnitude(cause: str, rng: np.random.Generator) -> dict[str, float]:
    sign = rng.choice([-1.0, 1.0])
    # The first eight are drawn together, as they always were, so that each of their cases
    # keeps its data (noise and mu are drawn after them); the later causes draw after those.
    first = {
        "sensor_offset": {"sensor_offset": sign * rng.uniform(0.2, 1.0)},
        "sensor_gain": {"sensor_gain": 1.0 + sign * rng.uniform(0.03, 0.1)},
        "viscous_friction": {"mu_viscous": rng.uniform(0.8, 2.5)},
        "tension_dependent_friction": {"mu_tension_slope": sign * rng.uniform(6e-4, 2e-3)},
        "bending_angle_error": {"phi_offset_per_z": sign * rng.uniform(0.3, 1.0)},
        "lag": {"sensor_tau": rng.uniform(0.006, 0.02)},
        "time_delay": {"sensor_delay": rng.uniform(0.006, 0.02)},
        "friction_drift": {"mu_drift": sign * rng.uniform(1.5e-4, 5e-4)},
    }
    if cause in first:
        return first[cause]
    return {
        "slack": lambda: {"slack_tension": rng.uniform(4.0, 7.0)},
        "sensor_saturation": lambda: {
            "sensor_full_scale": rng.uniform(9.0, 11.0),
            "sensor_saturation_knee": rng.uniform(0.0, 1.5),
        },
        "load_cell_creep": lambda: {
            "sensor_creep": sign * rng.uniform(0.03, 0.08),
            "sensor_creep_tau": rng.uniform(0.5, 2.0),
        },
        "static_friction": lambda: {"mu_static_excess": rng.uniform(0.015, 0.04)},
    }[cause]()


# cause -> seed of its case (session, noise and magnitude)


CAUSE_SEEDS = {
    "sensor_offset": 101,
    "sensor_gain": 102,
    "viscous_friction": 103,
    "tension_dependent_friction": 104,
    "bending_angle_error": 105,
    "lag": 106,
    "time_delay": 107,
    "friction_drift": 108,
    "slack": 110,
    "sensor_saturation": 111,
    "load_cell_creep": 112,
    "static_friction": 114,  # (113: the tuning seed of its fit's start, not a case)
}
