"""What is left after the findings, described (cosim.audit.core, step 5): size, whiteness,
dominant frequency, the signals it follows, and where it sits (near reversals, at low or high
input tension, while it rises or falls, early or late in the record, in outliers)."""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import median_filter
from scipy.signal import fftconvolve, welch

from cosim.results import trace as trace_mod

from . import lines
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


def describe_residual(data: AuditData, resid: np.ndarray, min_line_rms_n: float) -> dict:
    """Size, whiteness, dominant frequency and correlated signals of a residual, on the
    held-out (selection and report) blocks; the spectrum and its lines (cosim.audit.lines: those
    of at least min_line_rms_n RMS) over the scored record."""
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
    where, parts, outliers = locate(data, resid, held)
    # the lines of what is left, each with its share of the scored residual's variance and
    # whether it was taken out before the fits (core.run: data.lines)
    var = float(np.var(scored))
    found = [
        {
            **line.describe(var),
            "removed_before_fits": any(
                abs(line.freq_hz - taken.freq_hz) <= line.bin_hz for taken in data.lines
            ),
        }
        for line in lines.find(data, resid, min_line_rms_n)
    ]
    return {
        "rms_n": rms,
        "where": where,
        "where_rms_n": parts,
        "outliers": outliers,
        "noise_floor_n": data.noise_floor_n,
        "white": bool(max_acf < WHITE_MAX_ACF),
        "max_autocorrelation": max_acf,
        "peak_hz": float(f[k]),
        "peak_to_median_psd": peak_ratio,
        "lines": found,
        "correlates": correlates,
        "correlations": {n: round(c, 4) for n, c in corr.items()},
        "correlation_se": {n: round(v, 4) for n, v in se.items()},
    }


# Where the residual sits (locate): a part of the held-out record "holds" the residual when its
# RMS is at least WHERE_RATIO times that of the rest and its excess over the noise floor is at
# least WHERE_MIN_EXCESS of the floor; near a reversal means within REVERSAL_S after the input
# tension turned; rising and falling follow the sign of the smoothed input rate (the loading
# and the unloading branch of the friction's hysteresis). An outlier is a sample that stands
# more than OUTLIER_SIGMAS noise floors off the running median of the residual over
# OUTLIER_WINDOW samples around it: the Hampel identifier (R. K. Pearson, "Outliers in process
# modeling and identification", IEEE Trans. Control Syst. Technol. 10(1), 2002), with the
# noise floor as its scale. A spike stands off its neighbours; a residual that is large for a
# stretch (structure the model lacks, such as a whole unloading branch off) carries its median
# with it and is not counted: beyond the floor alone it once made "5322 outliers" of a ramp's
# every unloading.
WHERE_RATIO = 1.5
WHERE_MIN_EXCESS = 0.5
REVERSAL_S = 0.3
OUTLIER_SIGMAS = 6.0
OUTLIER_WINDOW = 11
REVERSAL_MIN_N = 0.05


def reversals(x: np.ndarray, h: float) -> list[int]:
    """Indices where x turns: its extremes between moves of more than h the other way (a
    turning point with hysteresis h, so the input's noise makes none)."""
    out: list[int] = []
    vals = np.asarray(x, dtype=float).tolist()
    lo = hi = vals[0]
    up, k_ext, x_ext = 0, 0, vals[0]
    for k, v in enumerate(vals):
        if up == 0:  # not moved yet by more than h either way
            lo, hi = min(lo, v), max(hi, v)
            if v > lo + h:
                up, k_ext, x_ext = 1, k, v
            elif v < hi - h:
                up, k_ext, x_ext = -1, k, v
        elif up * (v - x_ext) > 0:  # further on the same way: a new extreme
            k_ext, x_ext = k, v
        elif up * (x_ext - v) > h:  # turned by more than h: the extreme was a reversal
            out.append(k_ext)
            up, k_ext, x_ext = -up, k, v
    return out


def locate(data: AuditData, resid: np.ndarray, held: np.ndarray) -> tuple[list[str], dict, dict]:
    """Where the held-out residual sits: the parts of the record whose RMS stands out against
    the rest (a list of phrases, strongest first), each part's RMS, and the outliers (count,
    largest size, share of the residual's mean square)."""
    floor = data.noise_floor_n
    r = resid
    t_in = data.inputs.t_in_n
    turned = reversals(t_in, max(REVERSAL_MIN_N, 10.0 * data.input_noise_n))
    near = np.zeros(len(r), dtype=bool)
    span = max(1, int(round(REVERSAL_S * data.rate_hz)))
    for k in turned:
        near[k : k + span] = True
    lo_t, hi_t = np.percentile(t_in[held], [33.3, 66.7])
    half = data.t_s[held][len(data.t_s[held]) // 2] if held.any() else 0.0
    parts = {
        "near reversals": near,
        "at low input tension": t_in <= lo_t,
        "at high input tension": t_in >= hi_t,
        "while the input tension rises": data.rate_n_s > 0.0,
        "while the input tension falls": data.rate_n_s < 0.0,
        "early in the record": data.t_s < half,
        "late in the record": data.t_s >= half,
    }
    rms_of = {}
    where = []
    for name, mask in parts.items():
        inside, outside = r[held & mask], r[held & ~mask]
        if len(inside) < 10 or len(outside) < 10:
            continue
        a = float(np.sqrt(np.mean(inside * inside)))
        b = float(np.sqrt(np.mean(outside * outside)))
        rms_of[name] = round(a, 5)
        excess = math.sqrt(max(a * a - floor * floor, 0.0))
        if a >= WHERE_RATIO * b and excess >= WHERE_MIN_EXCESS * floor:
            where.append((a / b, f"{name} ({a:.3g} N RMS against {b:.3g} N elsewhere)"))
    off = (r - median_filter(r, size=OUTLIER_WINDOW, mode="nearest"))[held]
    big = np.abs(off) > OUTLIER_SIGMAS * floor
    total = float(np.sum(r[held] ** 2))
    outliers = {
        "count": int(np.sum(big)),
        # each outlier's size: how far it stands off its neighbours
        "largest_n": round(float(np.max(np.abs(off[big]))), 5) if big.any() else 0.0,
        "share_pct": round(100.0 * float(np.sum(off[big] ** 2)) / total, 2) if total else 0.0,
    }
    phrases = [p for _, p in sorted(where, key=lambda w: -w[0])]
    if outliers["count"] and outliers["share_pct"] >= 10.0:
        phrases.append(
            f"in {outliers['count']} outliers (up to {outliers['largest_n']:.3g} N, "
            f"{outliers['share_pct']:.0f} % of its mean square)"
        )
    return phrases, rms_of, outliers
