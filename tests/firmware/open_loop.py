"""What the compensator law tests share: the nominal sheath, a reference with reversals of
several sizes, and the plant FMU driven open loop with a prescribed inlet tension."""

from __future__ import annotations

import math

import numpy as np

from cosim.parts.plant import Plant

LSB = 1.0 / 256.0
MU = 0.075
PHI = 2.0 * math.pi  # loop routing in the loop's plane (x = 0, the FMU's y = 0.5 m below)
FULL_SCALE_N = 15.0  # the figures' error in % of the 15 N maximum, as the sweeps score


def reference(n: int = 4000) -> np.ndarray:
    """Reversals of several sizes between 2 and 14 N at 1 kHz (the shape of fig14, not its
    waveform)."""
    t = np.arange(n) / 1000.0
    return 8.0 + 5.0 * np.sin(2 * np.pi * 0.5 * t) + 1.0 * np.sin(2 * np.pi * 1.3 * t)


def open_loop_t_out(plant: dict, t_in: np.ndarray) -> np.ndarray:
    """T_out of the FMU (nominal mu, drive mode 1: the inlet tension prescribed) for the inlet
    tension t_in at 1 kHz, from rest at t_in[0]; `plant` overrides or adds FMU parameters."""
    out = np.empty(len(t_in))
    inputs = {"T_in_cmd": float(t_in[0]), "x": 0.0, "y": 0.5, "z": 0.0}
    with Plant({"drive_mode": 1, "mu": MU, **plant}, inputs=inputs) as p:
        out[0] = p.y[p.T_OUT]
        for k in range(1, len(t_in)):
            p.u[1] = float(t_in[k])
            out[k] = p.step(1e-3)[p.T_OUT]
    return out
