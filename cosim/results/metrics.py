"""Figures of merit of a run: tracking error as in the paper, fixed point against float, and the
capstan fit of a characterisation.

Tracking error (paper Sec. VI-C): e = T_ref - T_out, with T_out as the output sensor reads it;
RMS and peak of |e| in N and in % of the maximum reference tension of the evaluated window (the
paper: 0.65 N = 4.3 % and 2 N = 13.3 % of 15 N).

Fixed against float: the co-simulated fixed-point chain (RTL + firmware) against the double
reference on the same scenario and plant; the current command compared in LSB of its Q3.12 word
(1/4096 A) and T_out in N.

Error split at reversals (why a compensator or a routing wins): the paper blames its peak error
on "abrupt change of input tension when the direction of increment of reference tension changes"
(Sec. VI-C), while a wrong bending angle (no loop routing) spoils the friction model everywhere.
`reversal_split` separates the two: the error in a window after each reversal of T_ref, and the
error elsewhere.

Capstan fit (paper Eq. 1-3 quasi-static, Fig. 2): cosim.results.capstan_fit, with a constant sensor
offset (the paper saw 0.5 N from the rollers of its sensor), reported per position.
"""

from __future__ import annotations

import math

import numpy as np

from . import capstan_fit

# LSB of the Q3.12 current command (hdl/README.md, register map).
CURRENT_LSB_A = 1.0 / 4096.0

# The paper's results (Sec. VI-C, Fig. 14).
PAPER_RMS_PCT = 4.3
PAPER_PEAK_PCT = 13.3
PAPER_RMS_N = 0.65
PAPER_PEAK_N = 2.0
PAPER_MAX_REF_N = 15.0


def tracking_error(
    t_s: np.ndarray, t_ref_n: np.ndarray, t_out_n: np.ndarray, settle_s: float = 0.0
) -> dict[str, float]:
    """RMS and peak of T_ref - T_out over t >= settle_s, in N and in % of max |T_ref| there.

    The percentages are None when T_ref is zero over the whole window (no scale to divide by):
    a figure with no value, written as null in result.json, never NaN."""
    t_s = np.asarray(t_s, dtype=np.float64)
    mask = t_s >= settle_s
    if not np.any(mask):
        raise ValueError(f"settle_s = {settle_s:g} s leaves no sample (run ends at {t_s[-1]:g} s)")
    err = np.asarray(t_ref_n, dtype=np.float64)[mask] - np.asarray(t_out_n, dtype=np.float64)[mask]
    max_ref = float(np.max(np.abs(np.asarray(t_ref_n)[mask])))
    rms = float(np.sqrt(np.mean(err * err)))
    peak = float(np.max(np.abs(err)))
    scale = 100.0 / max_ref if max_ref > 0 else None
    return {
        "rms_error_n": rms,
        "rms_error_pct": rms * scale if scale is not None else None,
        "peak_error_n": peak,
        "peak_error_pct": peak * scale if scale is not None else None,
        "max_ref_n": max_ref,
    }


# Window after a reversal of T_ref counted as "near the reversal": the dead zone plus the loop's
# settling after the jump of T_c last about 0.25 s on fig14 (0.5 Hz reference, see README).
REVERSAL_WINDOW_S = 0.3


def reversal_times(t_s: np.ndarray, t_ref_n: np.ndarray, band_n: float) -> np.ndarray:
    """Times at which T_ref changes direction, found with a hysteresis of `band_n` (a reversal
    counts once T_ref has moved band_n back from its extreme), reported at the extreme itself."""
    if band_n <= 0:
        raise ValueError(f"reversal_times: band_n must be > 0 N, got {band_n}")
    ref = np.asarray(t_ref_n, dtype=np.float64).tolist()
    times = []
    direction = 0  # +1 rising, -1 falling, 0 until T_ref has moved band_n from its start
    k_ext = 0  # the extreme in the current direction
    for k, v in enumerate(ref):
        if direction == 0:
            if abs(v - ref[0]) >= band_n:
                direction = 1 if v > ref[0] else -1
                k_ext = k
        elif (v - ref[k_ext]) * direction > 0:
            k_ext = k
        elif (ref[k_ext] - v) * direction >= band_n:
            times.append(float(t_s[k_ext]))
            direction = -direction
            k_ext = k
    return np.asarray(times)


def reversal_split(
    t_s: np.ndarray,
    t_ref_n: np.ndarray,
    t_out_n: np.ndarray,
    settle_s: float = 0.0,
    window_s: float = REVERSAL_WINDOW_S,
    before_s: float = 0.0,
) -> dict[str, float]:
    """RMS and peak of T_ref - T_out within `window_s` after each reversal of T_ref (and
    `before_s` before it: a compensator that acts ahead of the reversal, the preview mode, moves
    error there) and away from reversals (t >= settle_s in both), in N. The reversal hysteresis
    is 1 % of max |T_ref|."""
    t = np.asarray(t_s, dtype=np.float64)
    ref = np.asarray(t_ref_n, dtype=np.float64)
    err = ref - np.asarray(t_out_n, dtype=np.float64)
    revs = reversal_times(t, ref, band_n=max(0.01 * float(np.max(np.abs(ref))), 1e-9))
    near = np.zeros(t.shape, dtype=bool)
    for tr in revs.tolist():
        near |= (t >= tr - before_s) & (t < tr + window_s)
    valid = t >= settle_s
    out = {"reversal_window_s": float(window_s), "reversals": int(np.sum(revs >= settle_s))}
    for name, mask in (("near_reversal", near & valid), ("away", ~near & valid)):
        e = err[mask]
        out[f"rms_{name}_n"] = float(np.sqrt(np.mean(e * e))) if e.size else 0.0
        out[f"peak_{name}_n"] = float(np.max(np.abs(e))) if e.size else 0.0
    return out


def fixed_vs_float(
    current_fixed_a: np.ndarray,
    current_float_a: np.ndarray,
    t_out_fixed_n: np.ndarray,
    t_out_float_n: np.ndarray,
    full_scale_n: float,
) -> dict[str, float]:
    """RMS and maximum differences of the current command (LSB) and of T_out (N, % of full
    scale) between the fixed-point run and the float reference, sample by sample."""
    n = min(len(current_fixed_a), len(current_float_a), len(t_out_fixed_n), len(t_out_float_n))
    if n == 0:
        raise ValueError("fixed_vs_float: no samples to compare")
    du = (np.asarray(current_fixed_a[:n]) - np.asarray(current_float_a[:n])) / CURRENT_LSB_A
    dt = np.asarray(t_out_fixed_n[:n]) - np.asarray(t_out_float_n[:n])
    t_out_rms = float(np.sqrt(np.mean(dt * dt)))
    return {
        "current_rms_lsb": float(np.sqrt(np.mean(du * du))),
        "current_max_lsb": float(np.max(np.abs(du))),
        "t_out_rms_n": t_out_rms,
        "t_out_max_n": float(np.max(np.abs(dt))),
        "full_scale_n": float(full_scale_n),
        "t_out_rms_pct_fs": 100.0 * t_out_rms / full_scale_n,
    }


def fit_capstan(t_in_n: np.ndarray, t_out_n: np.ndarray, phi_rad: float) -> dict[str, float]:
    """The capstan fit of cosim.results.capstan_fit (with a sensor offset) as a result.json entry:
    mu, mu_phi, offset_n, rms_residual_n and the efficiency exp(-mu*phi)."""
    fit = capstan_fit.fit_capstan(t_in_n, t_out_n, phi_rad, fit_offset=True)
    mu_phi = fit.mu * fit.phi_rad
    return {
        "mu": fit.mu,
        "mu_phi": mu_phi,
        "offset_n": fit.offset_n,
        "rms_residual_n": fit.rms_residual_n,
        "efficiency": math.exp(-mu_phi),
    }
