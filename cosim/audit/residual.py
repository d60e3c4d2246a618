"""What is left after the findings, described (cosim.audit.core, step 5): size, whiteness,
dominant frequency and the signals it follows."""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import fftconvolve, welch

from cosim.results import trace as trace_mod

from .data import REPORT, SELECT, WARMUP, AuditData

# The unexplained residual is "white" when no autocorrelation at lags up to WHITE_LAGS_S exceeds
# WHITE_MAX_ACF (a correlated part of under about 15 % of its variance: the input's smoothed
# sensor noise, passed through the friction model, leaves about 0.1 on FMU data with no effect).
# A signal "correlates" with it when |r| >= CORRELATE_MIN_R and |r| is at least CORRELATE_Z
# standard errors, the standard error from Bartlett's formula (a slow signal such as a position
# held for seconds has few independent values, and a slow residual meets it by chance).
WHITE_LAGS_S = 0.1
WHITE_MAX_ACF = 0.15
CORRELATE_MIN_R = 0.1
CORRELATE_Z = 3.0


def _acf(x: np.ndarray) -> np.ndarray:
    """Autocorrelation at lags 0 .. n/4 (FFT)."""
    xc = np.asarray(x, dtype=float) - np.mean(x)
    var = float(xc @ xc)
    if var == 0.0:
        return np.zeros(1)
    full = fftconvolve(xc, xc[::-1], mode="full")[len(xc) - 1 :] / var
    return full[: max(1, len(xc) // 4)]


def describe_residual(data: AuditData, resid: np.ndarray) -> dict:
    """Size, whiteness, dominant frequency and correlated signals of a residual, on the
    held-out (selection and report) blocks; the spectrum over the scored record."""
    held = (data.roles == SELECT) | (data.roles == REPORT)
    r = resid[held]
    rms = float(np.sqrt(np.mean(r * r)))
    rc = r - np.mean(r)
    lags = max(1, int(round(WHITE_LAGS_S * data.rate_hz)))
    var = float(rc @ rc)
    acf = (
        fftconvolve(rc, rc[::-1], mode="full")[len(rc) : len(rc) + lags] / var
        if var > 0
        else np.zeros(lags)
    )
    max_acf = float(np.max(np.abs(acf)))
    scored = resid[data.roles != WARMUP]
    nper = int(min(len(scored), round(4.0 * data.rate_hz)))
    f, pxx = welch(scored - np.mean(scored), fs=data.rate_hz, nperseg=nper)
    band = f > 0.2
    k = int(np.argmax(np.where(band, pxx, -1.0)))
    peak_ratio = float(pxx[k] / np.median(pxx[band])) if np.any(band) else 0.0
    signals = {
        "T_in_N": data.inputs.t_in_n,
        "dT_in/dt": data.rate_n_s,
        "|dT_in/dt|": np.abs(data.rate_n_s),
        "T_out_N": data.t_out_n,
        "t_s": data.t_s,
    }
    if data.has_positions:
        for j, name in enumerate(trace_mod.POSITION_COLUMNS):
            signals[name] = data.positions_m[:, j]
    corr, se = {}, {}
    acf_r = _acf(r)
    for name, sig in signals.items():
        s = sig[held]
        if np.std(s) > 0 and np.std(r) > 0:
            corr[name] = float(np.corrcoef(r, s)[0, 1])
            # Bartlett: var(r_xy) ~ (1/n) sum_k rho_x(k) rho_y(k) over all lags
            lags_n = min(len(acf_r), len(s))
            bartlett = 2.0 * float(acf_r[:lags_n] @ _acf(s)[:lags_n]) - 1.0
            se[name] = math.sqrt(max(bartlett, 1.0) / len(s))
    correlates = sorted(
        (n for n, c in corr.items() if abs(c) >= CORRELATE_MIN_R and abs(c) >= CORRELATE_Z * se[n]),
        key=lambda n: -abs(corr[n]),
    )
    return {
        "rms_n": rms,
        "noise_floor_n": data.noise_floor_n,
        "white": bool(max_acf < WHITE_MAX_ACF),
        "max_autocorrelation": max_acf,
        "peak_hz": float(f[k]),
        "peak_to_median_psd": peak_ratio,
        "correlates": correlates,
        "correlations": {n: round(c, 4) for n, c in corr.items()},
        "correlation_se": {n: round(v, 4) for n, v in se.items()},
    }
