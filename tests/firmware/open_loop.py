"""What the compensator law tests share: the nominal sheath, a reference with reversals of
several sizes, the input words a fixed-point law is held to its twin on, a configuration's
refusal by both twins, the plant FMU driven open loop with a prescribed inlet tension, and the
error of such a run in % of full scale."""

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


def twin_cases(n: int = 20000) -> list[tuple[str, np.ndarray]]:
    """The Q7.8 words a fixed-point law is held to its double twin on: a random walk over the
    whole range (fixed seed) and the reference's reversals."""
    rng = np.random.default_rng(38)
    walk = np.clip(np.cumsum(rng.integers(-60, 61, n)), -32768, 32767).astype(np.int16)
    return [("random walk", walk), ("reversals", np.round(reference() * 256).astype(np.int16))]


def error_pct(out: np.ndarray, ref: np.ndarray, settle: int = 1000) -> tuple[float, float]:
    """RMS and peak of out - ref after the first `settle` samples, in % of FULL_SCALE_N."""
    e = (out - ref)[settle:]
    return (
        100 * math.sqrt(float(np.mean(e**2))) / FULL_SCALE_N,
        100 * float(np.max(np.abs(e))) / FULL_SCALE_N,
    )


def fig14_sine(n: int = 6000) -> np.ndarray:
    """fig14's reference, 2 to 15 N at 0.5 Hz, at 1 kHz."""
    t = np.arange(n) / 1000.0
    return 8.5 - 6.5 * np.cos(2 * np.pi * 0.5 * t)


def preview_open_loop_pct(plant: dict, **law) -> tuple[float, float]:
    """RMS and peak error (% of full scale) of the FMU with `plant`'s effects driven open loop by
    the preview law (nominal mu and phi, `law`'s other CompensatorParams) on fig14's sine, given
    the reference its preview ahead."""
    from cosim.parts import firmware as fw  # noqa: PLC0415 (the host library, built by make)

    ref = fig14_sine()
    preview = fw.c_defaults()["preview_ticks"]
    ahead = np.concatenate([ref[preview:], np.full(preview, ref[-1])])
    comp = fw.CompensatorF64(fw.CompensatorParams(mode="preview", mu=MU, phi_rad=PHI, **law))
    return error_pct(open_loop_t_out(plant, comp.run(ahead)), ref)


def refusal_codes(params) -> tuple[int, int]:
    """The error codes with which the fixed point and its double twin refuse `params` (each must
    refuse: pytest.raises fails the test otherwise)."""
    import pytest  # noqa: PLC0415

    from cosim.parts import firmware as fw  # noqa: PLC0415

    with pytest.raises(fw.FirmwareConfigError) as fixed:
        fw.Compensator(params)
    with pytest.raises(fw.FirmwareConfigError) as twin:
        fw.CompensatorF64(params)
    return fixed.value.code, twin.value.code


def slack_turn_bound(
    q, words: np.ndarray, fixed: np.ndarray, twin: np.ndarray, tc1: np.ndarray, bound: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The fixed point's bound against the twin where the slack's turn caps T_c (comp.h). `q`
    the quantized parameters, `fixed` and `twin` the two T_c, `tc1` the twin's T_c without the
    slack (the root's argument), `bound` the documented bound at each step.

    The cap is T_eff times the ratio at the unloading branch's least T_c below S, whose fixed and
    twin values differ by that step's bound: where the cap is in force the bound grows by T_c
    times the largest relative bound of a rooted step, plus the ratio's 2^-16 of T_eff and
    1/2 LSB. The turn ends where its cap reaches S and T_c steps up to the law's, and the twins
    may end it a step apart: one still capped just below S, the other at or above it. Returns
    the bound, the mask of such edge steps (left out of the comparison) and the number of turns
    (the edge steps may be at most as many)."""
    s_n = q.slack_tension_n
    rooted = (tc1 > 0) & (tc1 < s_n)
    root = np.where(rooted, np.sqrt(np.maximum(tc1, 0.0) * s_n), tc1)
    turned = twin < root - 1e-9
    rel = float(np.max(bound[rooted & ~turned] / root[rooted & ~turned]))
    t_eff = np.abs(words * LSB - q.offset_n)
    bound = np.where(turned, bound + rel * twin + t_eff * 2.0**-16 + LSB / 2, bound)
    low, high = np.minimum(fixed, twin), np.maximum(fixed, twin)
    edge = (low > s_n * (1.0 - rel) - 2 * LSB) & (low < s_n) & (high >= s_n)
    turns = int(np.sum(np.diff(turned.astype(int)) == 1)) + int(turned[0])
    return bound, edge, turned, turns
