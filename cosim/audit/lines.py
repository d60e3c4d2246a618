"""Narrow spectral lines in a residual that the input does not explain (cosim.audit.core): mains
pickup at 50 or 60 Hz and its harmonics, a motor's cogging, a fan. No cause of the vocabulary
makes a line the input does not have (each is a function of the input's history), so a line is
described, never named: the audit takes the lines it finds in the nominal model's residual out
of the output before any candidate is fitted or judged (`remove`), and reports them with what is
left.

A line is a peak of the residual's Welch spectrum (segments of SEGMENT_S, Hann window) that
- stands at least MIN_RATIO times above the spectrum's running median over BACKGROUND_HZ (a
  robust local background: a line fills a few of its bins);
- is narrow: at half its height it spans at most MAX_WIDTH_BINS bins (a sinusoid of constant
  frequency spans about 1.5 with the Hann window; a ringing that decays within 80 ms, many);
- is not the input's: it lies above the input's band (the frequency under which
  INPUT_BAND_SHARE of the measured input's variance lies: within it a line is not told from
  what the input drives, and none is looked for), the measured input tension has no peak of its
  own there (its spectrum within a bin of the line under INPUT_MAX_RATIO times its own running
  median), and, when the input is periodic (data.input_period_s), the line's least-squares
  frequency is not one of the first INPUT_HARMONICS multiples of its fundamental (a residual
  driven by a periodic input is periodic too: its harmonics are lines the input's own spectrum
  need not show);
- holds at least a given RMS (the decision rule's smallest effect, one LSB of Q7.8: a line
  under it is below what the controller can act on, and could not pass for a finding).
Its frequency is refined by least squares (the periodogram of the fit blocks' residual at
REFINE_STEPS points per 1/T within a bin, by one FFT, then Brent's method on the exact fit of a
sine and a cosine), its amplitude is that fit's, and it is flagged as mains when it lies within
a bin of a multiple of 50 Hz or 60 Hz. A line whose frequency wanders by more than about 1/T
over the record (T its length) is not one sinusoid: it is taken out only in part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import median_filter
from scipy.optimize import minimize_scalar
from scipy.signal import find_peaks, peak_widths, welch

from .data import FIT, WARMUP, AuditData, input_period_s

# Thresholds, chosen on the tuning records named in tests/audit/test_audit_lines.py and reported
# on the others there. On the tuning records without a line the largest peak above the input's
# band stood 3.5x its background (FMU sessions with each cause, the rig), 11x in a fig14 trace
# and 19x on the bench emulator (harmonics of the closed loop's 0.5 Hz sine, each 0.2 mN or
# less: under the RMS a line must hold); their lines stood 1100x and more. A line of 0.05 N in
# 0.03 N of noise stands about 1900x, one of 0.01 N about 70x (0.005 N, under 20x, is not found).
SEGMENT_S = 4.0  # Welch segments: bins of 0.25 Hz, as the residual's spectral peak (residual)
BACKGROUND_HZ = 10.0  # the running median's width: 41 bins, of which a line fills about 3
MIN_RATIO = 20.0
MAX_WIDTH_BINS = 3.0
INPUT_MAX_RATIO = 5.0  # the input's own peaks: its spectrum over its running median
# The input's band: below the frequency under which this share of its variance lies, no line is
# looked for. There the input's peaks crowd the running median (the FMU session's three sines
# within 2.5 Hz fill a third of its window), so its own peaks stand only 1-5x over it, and a
# cause's residual copies them: in the tuning records it stood up to 16x (a bending angle's, at
# 0.25 Hz). The band ends near 2 Hz for the FMU sessions, 1 Hz for the rig's ramps, 10 Hz for the
# closed loop's input in fig14 and on the bench emulator (the compensator's jumps).
INPUT_BAND_SHARE = 0.99
# Harmonics of a periodic input taken as its own; set, not tuned: on the bench emulator's 0.5 Hz
# sine those above the 3rd stood under 1 mN (and so under the RMS a line must hold)
INPUT_HARMONICS = 20
REFINE_STEPS = 4  # grid points per 1/T for the frequency's least squares (the peak's main lobe)
MAX_LINES = 8  # the strongest kept: mains and a few of its harmonics
MAINS_HZ = (50.0, 60.0)


@dataclass(frozen=True)
class Line:
    """A sinusoid a * cos(2 pi f t) + b * sin(2 pi f t) fitted to a residual."""

    freq_hz: float
    cos_n: float
    sin_n: float
    t0_s: float  # the time its phase is counted from (t = 0 in the formula)
    bin_hz: float  # the spectrum's bin width: the frequency's resolution for `mains`
    peak_ratio: float  # the Welch peak over its local background

    @property
    def amplitude_n(self) -> float:
        return math.hypot(self.cos_n, self.sin_n)

    @property
    def mains_hz(self) -> list[float]:
        """The mains frequencies (50, 60 Hz) of which the line is within a bin of a multiple."""
        return [
            m
            for m in MAINS_HZ
            if round(self.freq_hz / m) >= 1
            and abs(self.freq_hz - m * round(self.freq_hz / m)) <= self.bin_hz
        ]

    def wave(self, t_s: np.ndarray) -> np.ndarray:
        w = 2.0 * np.pi * self.freq_hz * (np.asarray(t_s, dtype=float) - self.t0_s)
        return self.cos_n * np.cos(w) + self.sin_n * np.sin(w)

    def describe(self, resid_var_n2: float) -> dict:
        """The line as audit.json gives it: frequency, amplitude, mains, share of a residual's
        variance."""
        share = 0.5 * self.amplitude_n**2 / resid_var_n2 if resid_var_n2 > 0 else 0.0
        return {
            "freq_hz": round(self.freq_hz, 4),
            "amplitude_n": round(self.amplitude_n, 5),
            "mains_hz": self.mains_hz,
            "share_pct": round(100.0 * min(share, 1.0), 2),
            "peak_to_background": round(self.peak_ratio, 1),
        }


def _spectrum(x: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Welch spectrum, its running median, and the frequencies."""
    nper = int(min(len(x), round(SEGMENT_S * rate_hz)))
    f, p = welch(x - np.mean(x), fs=rate_hz, nperseg=nper)
    bins = max(3, int(round(BACKGROUND_HZ / (f[1] - f[0]))) | 1)
    return f, p, median_filter(p, size=bins, mode="nearest")


def _fit(r: np.ndarray, t_s: np.ndarray, f_hz: float) -> tuple[float, float, float]:
    """Least-squares cosine and sine at f_hz: their coefficients and the sum of squares they
    remove (the 2x2 normal equations)."""
    w = 2.0 * np.pi * f_hz * t_s
    c, s = np.cos(w), np.sin(w)
    # sums, not BLAS dot products: a threaded BLAS on a busy machine took 20 ms a product here
    cc, ss, cs = np.sum(c * c), np.sum(s * s), np.sum(c * s)
    rc, rs = np.sum(r * c), np.sum(r * s)
    det = cc * ss - cs * cs
    if det <= 0.0:
        return 0.0, 0.0, 0.0
    a = (ss * rc - cs * rs) / det
    b = (cc * rs - cs * rc) / det
    return float(a), float(b), float(a * rc + b * rs)


def _refine(r: np.ndarray, t_s: np.ndarray, f0_hz: float, bin_hz: float, dt_s: float) -> float:
    """The frequency within a bin of f0_hz whose sinusoid removes most of r (least squares):
    the largest of the periodogram of r (its samples on their grid of dt_s, zeros between) at
    REFINE_STEPS points per 1/T, then Brent's method on the exact fit between its neighbours."""
    idx = np.round((t_s - t_s[0]) / dt_s).astype(np.int64)
    x = np.zeros(int(idx[-1]) + 1)
    x[idx] = r
    n = REFINE_STEPS * len(x)
    freqs = np.fft.rfftfreq(n, dt_s)
    near = np.flatnonzero(np.abs(freqs - f0_hz) <= bin_hz)
    power = np.abs(np.fft.rfft(x, n=n)[near]) ** 2
    k = int(near[np.argmax(power)])
    lo, hi = freqs[max(k - 1, 0)], freqs[min(k + 1, len(freqs) - 1)]
    best = minimize_scalar(
        lambda f: -_fit(r, t_s, f)[2], bounds=(lo, hi), method="bounded", options={"xatol": 1e-6}
    )
    return float(best.x) if -best.fun >= _fit(r, t_s, freqs[k])[2] else float(freqs[k])


def detect(
    resid: np.ndarray,
    t_in_n: np.ndarray,
    t_s: np.ndarray,
    rate_hz: float,
    fit: np.ndarray,
    period_s: float | None = None,
    min_rms_n: float = 0.0,
) -> list[Line]:
    """The lines of `resid` (a contiguous stretch: its spectrum) that the input `t_in_n` (of
    period `period_s`, None when it is not periodic) does not explain, strongest first; each
    fitted on the samples where `fit` is true, and kept when its RMS is at least min_rms_n."""
    f, p, bg = _spectrum(resid, rate_hz)
    df = float(f[1] - f[0])
    ratio = p / np.maximum(bg, np.finfo(float).tiny)
    peaks, _ = find_peaks(ratio, height=MIN_RATIO)
    peaks = peaks[peaks >= 2]  # not the mean's bins
    if peaks.size == 0:
        return []
    widths = peak_widths(ratio, peaks, rel_height=0.5)[0]
    _, p_in, bg_in = _spectrum(t_in_n, rate_hz)
    ratio_in = p_in / np.maximum(bg_in, np.finfo(float).tiny)
    band_hz = input_band_hz(f, p_in)
    kept = []
    for k, width in zip(peaks, widths, strict=True):
        if width > MAX_WIDTH_BINS or f[k] <= band_hz:
            continue
        if np.max(ratio_in[max(k - 1, 0) : k + 2]) >= INPUT_MAX_RATIO:
            continue
        kept.append(int(k))
    kept = sorted(kept, key=lambda k: -ratio[k])[:MAX_LINES]
    r = np.asarray(resid, dtype=float)[fit]
    t0 = float(t_s[0])  # phases from the record's start: a Unix time would cost them precision
    tf = np.asarray(t_s, dtype=float)[fit] - t0
    r = r - np.mean(r)
    out = []
    for k in kept:
        freq = _refine(r, tf, float(f[k]), df, 1.0 / rate_hz)
        if period_s and _harmonic(freq, period_s, float(tf[-1] - tf[0]), 1.0 / rate_hz):
            continue
        c, s, _ = _fit(r, tf, freq)
        line = Line(freq, c, s, t0, df, float(ratio[k]))
        if line.amplitude_n / math.sqrt(2.0) >= min_rms_n:
            r = r - line.wave(tf + t0)
            out.append(line)
    return out


def input_band_hz(f_hz: np.ndarray, psd: np.ndarray) -> float:
    """The frequency under which INPUT_BAND_SHARE of the input's variance lies (its Welch
    spectrum `psd` at `f_hz`)."""
    total = float(np.sum(psd))
    if total <= 0.0:
        return 0.0
    share = np.cumsum(psd) / total
    return float(f_hz[min(int(np.searchsorted(share, INPUT_BAND_SHARE)), len(f_hz) - 1)])


def _harmonic(freq_hz: float, period_s: float, span_s: float, dt_s: float) -> bool:
    """Whether freq_hz is one of the first INPUT_HARMONICS multiples of 1/period_s, within the
    record's resolution 1/span_s and the period's own (one sample) times the multiple. The
    harmonics of a slow input are closer than a Welch bin (0.5 Hz apart for a 2 s period):
    they are told apart on the least-squares frequency."""
    f0 = 1.0 / period_s
    n = round(freq_hz / f0)
    tol = 1.0 / span_s + n * f0 * dt_s / period_s
    return 1 <= n <= INPUT_HARMONICS and abs(freq_hz - n * f0) <= tol


def find(data: AuditData, resid: np.ndarray, min_rms_n: float) -> list[Line]:
    """The lines of a residual of `data` over its scored record (after the warm-up), fitted
    on its fit blocks only: the report blocks take no part in what `run` subtracts."""
    scored = data.roles != WARMUP
    t_in = data.t_in_meas_n[scored]
    return detect(
        resid[scored],
        t_in,
        data.t_s[scored],
        data.rate_hz,
        (data.roles == FIT)[scored],
        input_period_s(t_in, data.rate_hz),
        min_rms_n,
    )


def remove(lines: list[Line], t_s: np.ndarray) -> np.ndarray:
    """The sum of the lines' sinusoids at t_s (what `run` subtracts from the output)."""
    total = np.zeros(len(t_s))
    for line in lines:
        total += line.wave(t_s)
    return total
