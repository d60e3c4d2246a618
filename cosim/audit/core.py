"""The model audit: fit the nominal model to measured data, name what it gets wrong from the
vocabulary (cosim.audit.effects), extend the model, and measure the gain on data no fit saw.

The steps (issue 9):

1. **Data.** A measured trace (cosim.results.trace, mode "measured"): the input tension drives the
   model, the output tension is what it must predict. Above MAX_RATE_HZ the record is decimated (a
   zero-phase FIR); the input tension is smoothed with a Savitzky-Golay filter (SMOOTH_S) so that
   its sensor noise does not enter the friction model as false reversals (an errors-in-variables
   bias: the capstan's dead zone would hold every noise peak), except across fast changes, which
   are kept as measured (smooth_input: the filter would ring there). The record is cut into
   blocks of BLOCK_S that take turns as fit, selection, fit, report blocks (after WARMUP_S), so
   each role covers the whole record and every position: parameters are fitted on the fit blocks
   only, the decision is taken on the selection blocks, and the gain is measured on the report
   blocks, which nothing else saw.
2. **Baseline.** The FMU's nominal physics (capstan friction with the dead zone, phi from the
   geometry) fitted with its one parameter mu (the product mu*phi when there are no positions).
3. **Candidates.** Each cause of the vocabulary is added in turn to the current model and all
   parameters are refitted together on the fit blocks; its score is the share of the selection
   blocks' residual mean square it removes.
4. **Decision** (DecisionRule, thresholds written once): forward selection; a candidate is a
   finding only when it is significant on the selection blocks; among significant candidates the
   one removing most is taken, and the round repeats with it in the model. A finding whose
   runner-up explained the same residual (it stops being significant once the finding is in) and
   that did not beat it significantly is marked ambiguous, naming the alternative.
5. **Report.** The baseline and the extended model are run through the FMU itself (drive mode 1,
   the measured input tension and positions); their residuals on the report blocks are the gain.
   What is left is described: size, whiteness, dominant frequency, the signals it follows.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import decimate, fftconvolve, savgol_filter, welch

from cosim.parts.geometry import bending_angle, in_workspace
from cosim.results import trace as trace_mod

from . import twin
from .effects import VOCABULARY, Effect

# --- data preparation ------------------------------------------------------------------------

# Above this rate the record is decimated: the friction and the sensor effects of the vocabulary
# live below 100 Hz, and the fit's cost grows with the samples.
MAX_RATE_HZ = 2000.0
# The shortest record that gives enough blocks of each role.
MIN_DURATION_S = 10.0
# Savitzky-Golay smoothing of the input tension: quintic over 41 ms (0.03 N of sensor noise drops
# to about 0.01 N). Measured on FMU data and on a rig of triangle ramps: a cubic over 21 ms left
# enough noise to blur a 6 ms lag and a 6 ms delay into each other (separation z 1.1, 2.6 here);
# a cubic over 41 ms rounds the corners of triangle ramps enough to look like viscous friction
# (0.39 sigma of residual removed by it on the rig, 0.22 sigma here).
SMOOTH_S = 0.041
SMOOTH_ORDER = 5
# Where the smoothing would move a sample by more than EDGE_SIGMAS input noise sigmas (and at
# least EDGE_MIN_N, for a noiseless input), the input is not smooth there and is kept as
# measured (smooth_input).
EDGE_SIGMAS = 5.0
EDGE_MIN_N = 1e-3
# Blocks: the record (after the warm-up, where the model's initial state may differ from the
# rig's) is cut into blocks of about BLOCK_TARGET_COUNT, between BLOCK_MIN_S and BLOCK_MAX_S long,
# whose roles repeat ROLE_PATTERN.
WARMUP_S = 1.0
BLOCK_TARGET_COUNT = 24
BLOCK_MIN_S = 0.5
BLOCK_MAX_S = 5.0
FIT, SELECT, REPORT, WARMUP = 0, 1, 2, -1
ROLE_PATTERN = (FIT, SELECT, FIT, REPORT)
# A bench recording's sidecar carries the compensator's mu (comp.mu read from the device) with
# "mu_source": "compensator": what the controller assumes, not a measurement of the plant. The
# audit fits mu then: taking it as known named four false causes for a plant whose mu was 0.09
# against the compensator's 0.075 (tests/audit/test_audit_bench.py).
MU_SOURCE_COMPENSATOR = "compensator"
ROLE_NAMES = {FIT: "fit", SELECT: "selection", REPORT: "report", WARMUP: "warm-up"}
# A periodic input (a bench's waveform) that the record holds at least MIN_PERIODS times can
# lock the blocks to its phase: a 12 s recording of a 0.5 Hz sine gets blocks of 0.5 s, whose
# fit/selection/fit/report cycle lasts one period, and every report block sees the same quarter
# of it (the held-out residual then measured there only: 12.6 mN against 4.9 mN over all
# phases, on the bench emulator). The input is periodic when it correlates with itself one
# period later by PERIODIC_MIN_R; when the selection or the report blocks see less than
# COVER_MIN of its phase (PHASE_BINS bins), the block is lengthened or shortened by the least
# (steps of 1 %, within BLOCK_MIN_S..BLOCK_MAX_S) that lets both see at least that much.
PERIODIC_MIN_R = 0.99
MIN_PERIODS = 5.0
COVER_MIN = 0.9
PHASE_BINS = 100


@dataclass(frozen=True)
class DecisionRule:
    """When a candidate becomes a finding (STYLE.md: a stated rule, thresholds written once).

    On the selection blocks, adding the candidate to the current model must
    - remove at least `min_explained_pct` % of the residual mean square,
    - with a paired z (paired_z: against the sensor's noise) of at least `min_z`,
    - and remove at least `min_effect_rms_n` of RMS (1/256 N: one LSB of the project's Q7.8
      tensions; a smaller effect is below what the controller can act on) and at least
      `min_effect_noise_ratio` times the combined sensor noise sqrt(sigma_out^2 + sigma_in^2):
      the input's sensor noise, smoothed, still passes through the dead zone of the friction
      model as a structured residual (the errors-in-variables bias of a hysteresis), which a
      candidate can partly absorb: on FMU data with no effect an offset of 0.011 N took 0.28
      sigma_out of it, and two candidates took 0.5 sigma_out on a closed-loop `bowden sim` trace
      while explaining nothing on its report blocks. The sampling error of the record joins
      the sensor noises in that sum (sampling_error_n): the record gives the input at its
      sample instants only, and where between two samples the unrecorded path of the input
      reaches its extremes, which the friction model holds, is unknown; with that instant
      uniform over a sample the nominal prediction is uncertain by its change over one sample
      / sqrt(12), RMS (as a quantizer's q / sqrt(12), in time). On the bench emulator (telemetry
      at 1 kHz of a plant run at 10 kHz, no sensor noise) this error left 2 to 11 mN that a
      sensor offset, gain or friction drift took 4 to 8 mN of, with z above 100.
    The largest such candidate is taken. It is marked ambiguous when the runner-up stops being
    significant once it is in the model and the two differ by a paired z under `separation_z`.
    At most `max_findings` rounds.
    """

    min_explained_pct: float = 2.0
    min_z: float = 4.0
    min_effect_rms_n: float = 1.0 / 256.0
    min_effect_noise_ratio: float = 0.5
    separation_z: float = 2.0
    max_findings: int = 4

    def min_rms_n(self, noise_out_n: float, noise_in_n: float, sampling_n: float = 0.0) -> float:
        """The smallest RMS a finding must remove on data with these sensor noises and this
        sampling error."""
        combined = math.sqrt(noise_out_n**2 + noise_in_n**2 + sampling_n**2)
        return max(self.min_effect_rms_n, self.min_effect_noise_ratio * combined)

    def text(self) -> str:
        return (
            f"a finding removes >= {self.min_explained_pct:g} % of the selection blocks' residual "
            f"mean square, with paired z >= {self.min_z:g} against the sensor noise and >= "
            f"{self.min_effect_rms_n * 1000:.1f} mN RMS and {self.min_effect_noise_ratio:g} x the "
            "combined sensor noise and sampling error; the largest is taken, then the next round"
        )


RULE = DecisionRule()

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


class AuditError(ValueError):
    """Data the audit cannot work on; the message names the file and what is expected."""


@dataclass
class AuditData:
    """A measured record prepared for the audit (see the module docstring)."""

    source: str
    t_s: np.ndarray  # uniform sample times
    t_in_meas_n: np.ndarray  # input tension as measured
    t_out_n: np.ndarray  # output tension as measured: what the model must predict
    inputs: twin.PlantInputs  # what drives the twin and the FMU (smoothed T_in, phi, z)
    positions_m: np.ndarray | None
    roles: np.ndarray  # FIT, SELECT, REPORT or WARMUP per sample
    rate_hz: float
    decimation: int
    block_s: float
    noise_floor_n: float  # output sensor's white noise (second differences, MAD)
    input_noise_n: float  # the same for the input sensor
    mu_given: float | None  # from the sidecar (then not fitted)
    phi_ref_rad: float | None  # no positions: the FMU's phi at its fixed position
    defaulted: tuple[str, ...]
    rate_n_s: np.ndarray  # smoothed dT_in/dt, for plots and correlates
    input_kept: int = 0  # samples of the input kept as measured (smooth_input: fast changes)
    block_note: str = ""  # why the block length is not the default (a periodic input)
    mu_from_compensator: bool = False  # the sidecar's mu was the compensator's: not used
    sampling_error_n: float = 0.0  # the nominal model's uncertainty from the sampling (run)

    @property
    def has_positions(self) -> bool:
        return self.positions_m is not None

    @property
    def mu_fixed(self) -> bool:
        """mu is the sidecar's and not fitted. Without positions the model fits the product
        mu*phi as mu at phi_ref_rad whether or not the sidecar gives mu (phi_rad then follows)."""
        return self.mu_given is not None and self.has_positions

    @property
    def z_span_m(self) -> float:
        return float(np.ptp(self.positions_m[:, 2])) if self.has_positions else 0.0

    def mask(self, role: int) -> np.ndarray:
        return self.roles == role

    def split_text(self) -> str:
        """The split, printed with every result."""
        parts = []
        for role in (FIT, SELECT, REPORT):
            n = int(np.sum(self.roles == role))
            parts.append(f"{ROLE_NAMES[role]} {n / self.rate_hz:.1f} s")
        return (
            f"blocks of {self.block_s:.2f} s in turn fit/selection/fit/report after "
            f"{WARMUP_S:g} s of warm-up: "
            + ", ".join(parts)
            + (f" ({self.block_note})" if self.block_note else "")
        )

    def blocks(self, role: int) -> list[tuple[float, float]]:
        """(start, end) times of the blocks of one role."""
        m = self.roles == role
        edges = np.flatnonzero(np.diff(np.concatenate([[0], m.astype(np.int8), [0]])))
        return [
            (float(self.t_s[a]), float(self.t_s[b - 1]))
            for a, b in zip(edges[::2], edges[1::2], strict=True)
        ]


def quantization_step(x: np.ndarray) -> float:
    """The smallest step between the distinct values of x: the resolution of a recording whose
    values sit on a grid (a bench recording's Q7.8 words are 1/256 N apart); 0.0 for a constant."""
    steps = np.diff(np.unique(np.asarray(x, dtype=float)))
    steps = steps[steps > 0]
    return float(steps.min()) if steps.size else 0.0


def noise_std(x: np.ndarray) -> float:
    """White-noise standard deviation of a smooth signal plus noise: the MAD of the second
    differences (whose variance is 6 sigma^2 for white noise; a smooth tension adds little), and
    never below the quantization noise q / sqrt(12) of a signal on a grid of step q. Without
    that floor a noiseless quantized recording (most second differences exactly 0) gives a MAD
    of 0, and every candidate's significance against it is infinite."""
    x = np.asarray(x, dtype=float)
    d2 = np.diff(x, 2)
    if d2.size < 3:
        return 0.0
    mad = float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6.0))
    return max(mad, quantization_step(x) / math.sqrt(12.0))


def prepare(tr: trace_mod.Trace, source: str) -> AuditData:
    """Turn a measured trace into AuditData; AuditError names what the audit cannot use."""
    t = np.asarray(tr["t_s"], dtype=float)
    rate = float(tr.meta["sample_rate_hz"])
    duration = len(t) / rate  # n samples, one per 1/rate: a 10 s recording at 1 kHz is 10 s
    if duration < MIN_DURATION_S:
        raise AuditError(
            f"{source}: {duration:.2f} s of data; the audit needs at least {MIN_DURATION_S:g} s "
            "(blocks to fit on, to decide on and to report on)"
        )
    length = float(tr.meta["sheath_length_m"])
    loop = bool(tr.meta["loop_routing"])
    positions = None
    if tr.has_positions:
        positions = np.column_stack([tr["x_m"], tr["y_m"], tr["z_m"]]).astype(float)
        ok = in_workspace(positions[:, 0], positions[:, 1], positions[:, 2], length)
        if not np.all(ok):
            i = int(np.flatnonzero(~ok)[0])
            x, y, z = positions[i]
            raise AuditError(
                f"{source}: data row {i + 1}: position x, y, z = ({x:g}, {y:g}, {z:g}) m is "
                f"outside the workspace of a {length:g} m sheath (sqrt(x^2 + y^2 + z^2) <= "
                f"{length:g} m and y >= 0; sheath_length_m in the sidecar, default 1 m)"
            )
    t_in = np.asarray(tr["T_in_N"], dtype=float)
    t_out = np.asarray(tr["T_out_N"], dtype=float)
    q = max(1, math.ceil(rate / MAX_RATE_HZ - 1e-9))
    if q > 1:
        # zero-phase FIR decimation of the tensions; positions move slowly and are picked
        t_in = decimate(t_in, q, ftype="fir", zero_phase=True)
        t_out = decimate(t_out, q, ftype="fir", zero_phase=True)
        if positions is not None:
            positions = positions[::q]
        rate /= q
    n = len(t_in)
    dt = 1.0 / rate
    t_s = t[0] + dt * np.arange(n)
    win = max(SMOOTH_ORDER + 2, int(round(SMOOTH_S * rate)) | 1)
    win = min(win, (n - 1) | 1 if n % 2 == 0 else n)
    input_noise = noise_std(t_in)
    t_in_s, kept = smooth_input(t_in, win, input_noise)
    rate_n_s = savgol_filter(t_in, max(win, int(round(0.05 * rate)) | 1), 2, deriv=1, delta=dt)
    if positions is not None:
        phi = bending_angle(positions[:, 0], positions[:, 1], positions[:, 2], length, loop)
        z = positions[:, 2].copy()
        phi_ref = None
    else:
        p = twin.fixed_position(length)
        phi_ref = float(bending_angle(p[0], p[1], p[2], length, loop))
        phi = np.full(n, phi_ref)
        z = np.zeros(n)
    inputs = twin.PlantInputs(
        t_in_n=t_in_s,
        phi_rad=np.asarray(phi, dtype=float),
        z_m=z,
        position_m=positions,
        t0_s=float(t_s[0]),
        dt_s=dt,
        sheath_length_m=length,
        loop_routing=loop,
    )
    roles, block_s, block_note = _roles(n, rate, t_in)
    mu = tr.meta.get("mu")
    if tr.meta.get("mu_source") == MU_SOURCE_COMPENSATOR:
        mu = None  # the controller's setting, not the plant's: fitted
    return AuditData(
        source=source,
        t_s=t_s,
        t_in_meas_n=t_in,
        t_out_n=t_out,
        inputs=inputs,
        positions_m=positions,
        roles=roles,
        rate_hz=rate,
        decimation=q,
        block_s=block_s,
        block_note=block_note,
        mu_from_compensator=tr.meta.get("mu_source") == MU_SOURCE_COMPENSATOR,
        noise_floor_n=noise_std(t_out),
        input_noise_n=input_noise,
        mu_given=None if mu is None else float(mu),
        phi_ref_rad=phi_ref,
        defaulted=tuple(tr.defaulted),
        rate_n_s=rate_n_s,
        input_kept=kept,
    )


def smooth_input(t_in: np.ndarray, win: int, noise_n: float) -> tuple[np.ndarray, int]:
    """The input tension smoothed where it is smooth, kept as measured where it is not.

    The Savitzky-Golay filter (SMOOTH_ORDER over `win` samples) removes the sensor noise, but
    across a fast change (a compensator switching its feedforward at a reversal moves T_in by
    many newtons within a few ms) it overshoots and rings; the friction model holds every
    extreme of its input, so the ringing becomes a residual that follows the tension rate (on a
    bench recording it gave 0.13 N and four false findings). A sample is an edge when the filter
    moves it by more than EDGE_SIGMAS input noise sigmas; every sample whose filter window
    reaches an edge keeps its measured value. On white noise alone (the filter moves a sample by
    about 0.9 sigma) a false edge has a probability of about 1e-6 per sample. Returns the input
    and the number of samples kept as measured."""
    x = np.asarray(t_in, dtype=float)
    s = savgol_filter(x, win, SMOOTH_ORDER)
    threshold = EDGE_SIGMAS * max(noise_n, EDGE_MIN_N)
    edge = np.abs(x - s) > threshold
    if not np.any(edge):
        return s, 0
    half = win // 2
    near = np.convolve(edge.astype(np.int8), np.ones(2 * half + 1, dtype=np.int8), "same") > 0
    return np.where(near, x, s), int(np.count_nonzero(near))


def input_period_s(t_in: np.ndarray, rate: float) -> float | None:
    """The period of a periodic input (a bench's waveform), else None: the lag of the largest
    autocorrelation after its first zero, up to a third of the record, when the input one
    period later correlates with itself by at least PERIODIC_MIN_R."""
    x = np.asarray(t_in, dtype=float) - np.mean(t_in)
    n = len(x)
    if n < 6 or not np.any(x):
        return None
    acf = fftconvolve(x, x[::-1], mode="full")[n - 1 :] / (n - np.arange(n))
    hi = n // 3
    neg = np.flatnonzero(acf[:hi] < 0.0)
    if neg.size == 0:
        return None
    k = int(neg[0] + np.argmax(acf[neg[0] : hi]))
    a, b = x[:-k], x[k:]
    if np.std(a) == 0.0 or np.std(b) == 0.0:
        return None
    return k / rate if float(np.corrcoef(a, b)[0, 1]) >= PERIODIC_MIN_R else None


def phase_coverage(roles: np.ndarray, rate: float, period_s: float) -> float:
    """The smaller share of the input's period (in PHASE_BINS bins) that the selection blocks
    and the report blocks each see."""
    phase = ((np.arange(len(roles)) / rate) % period_s / period_s * PHASE_BINS).astype(np.int64)
    return min(len(np.unique(phase[roles == role])) / PHASE_BINS for role in (SELECT, REPORT))


def _pattern(n: int, rate: float, warm: int, block_s: float) -> np.ndarray:
    idx = (np.arange(n - warm) / (block_s * rate)).astype(np.int64)
    roles = np.full(n, WARMUP, dtype=np.int8)
    roles[warm:] = np.asarray(ROLE_PATTERN, dtype=np.int8)[idx % len(ROLE_PATTERN)]
    return roles


def _roles(n: int, rate: float, t_in: np.ndarray) -> tuple[np.ndarray, float, str]:
    """Roles per sample, the block length, and a note when the block was moved off the
    input's period (see PERIODIC_MIN_R)."""
    warm = min(n, int(round(WARMUP_S * rate)))
    span_s = (n - warm) / rate
    block_s = min(BLOCK_MAX_S, max(BLOCK_MIN_S, span_s / BLOCK_TARGET_COUNT))
    roles = _pattern(n, rate, warm, block_s)
    period = input_period_s(t_in[warm:], rate)
    if period is None or span_s < MIN_PERIODS * period:
        return roles, block_s, ""
    seen = phase_coverage(roles, rate, period)
    if seen >= COVER_MIN:
        return roles, block_s, ""
    for change in np.arange(0.01, 0.5, 0.01):
        for b in (block_s * (1.0 + change), block_s * (1.0 - change)):
            if BLOCK_MIN_S <= b <= BLOCK_MAX_S:
                trial = _pattern(n, rate, warm, b)
                cover = phase_coverage(trial, rate, period)
                if cover >= COVER_MIN:
                    note = (
                        f"blocks of {block_s:.2f} s would put the selection and the report "
                        f"blocks at {100 * seen:.0f} % of the input's {period:.3g} s period; "
                        f"{b:.2f} s puts them at {100 * cover:.0f} %"
                    )
                    return trial, b, note
    return roles, block_s, ""


# --- models ------------------------------------------------------------------------------------

MU_BOUNDS = (1e-4, 1.0)
MU_SCALE = 0.01
# Fits use at most this many residuals of the fit blocks (evenly strided): enough for the
# parameters, and it keeps the Jacobian small.
MAX_FIT_RESIDUALS = 20_000


@dataclass
class Model:
    """The twin with some effects on: parameters (FMU names) and its prediction of T_out_meas."""

    effects: tuple[Effect, ...]
    params: dict[str, float]
    prediction: np.ndarray
    nfev: int = 0

    def residual(self, data: AuditData) -> np.ndarray:
        return data.t_out_n - self.prediction

    def ms(self, data: AuditData, role: int) -> float:
        r = self.residual(data)[data.roles == role]
        return float(np.mean(r * r))

    def rms(self, data: AuditData, role: int) -> float:
        return math.sqrt(self.ms(data, role))


def fit_model(
    data: AuditData,
    effects: tuple[Effect, ...],
    start: dict[str, float] | None = None,
    free: tuple[Effect, ...] | None = None,
) -> Model:
    """Fit mu (unless the sidecar gives it) and the parameters of the `free` effects (default:
    all of `effects`) together on the fit blocks, the others held at `start`; the delay on its
    grid of whole samples (scanned, then its neighbours with the rest refitted)."""
    free = tuple(effects) if free is None else tuple(free)
    start = dict(start or {})
    params: dict[str, float] = {"mu": data.mu_given if data.mu_fixed else 0.075}
    params.update({k: v for k, v in start.items() if k != "mu" or not data.mu_fixed})
    for e in effects:
        if e.fmu_param not in params:
            # bounded at "off" (viscous, lag): start a little inside
            lo, hi = e.bounds
            params[e.fmu_param] = e.off + (e.scale if e.off <= lo else 0.0)
    names: list[str] = [] if data.mu_fixed else ["mu"]
    names += [e.fmu_param for e in free if not e.discrete]
    delay = next((e for e in free if e.discrete), None)
    fit_idx = np.flatnonzero(data.roles == FIT)
    stride = max(1, math.ceil(len(fit_idx) / MAX_FIT_RESIDUALS))
    idx = fit_idx[::stride]
    nfev = 0
    if delay is None:
        if names:
            params, nfev = _least_squares(data, params, names, idx)
    else:
        # Coordinate descent: scan the delay with the rest held, refit the rest, until the scan
        # stays; then walk to neighbouring delays (the rest refitted) while that fits better, as
        # mu and the delay trade off near the optimum.
        dt = data.inputs.dt_s
        m = twin.delay_samples(_scan_delay(data, params, fit_idx), dt)
        for _ in range(6):
            params[delay.fmu_param] = m * dt
            if names:
                params, n_eval = _least_squares(data, params, names, idx)
                nfev += n_eval
            m_new = twin.delay_samples(_scan_delay(data, params, fit_idx), dt)
            if m_new == m:
                break
            m = m_new
        best = (_sse(data, params, idx), params)
        m_max = int(round(delay.bounds[1] / dt))
        for step in (-1, 1):
            m = twin.delay_samples(best[1][delay.fmu_param], dt) + step
            while 0 <= m <= m_max:
                trial = {**best[1], delay.fmu_param: m * dt}
                if names:
                    trial, n_eval = _least_squares(data, trial, names, idx)
                    nfev += n_eval
                sse = _sse(data, trial, idx)
                if sse >= best[0]:
                    break
                best = (sse, trial)
                m += step
        params = best[1]
    pred = twin.simulate(data.inputs, params)
    return Model(effects=tuple(effects), params=params, prediction=pred, nfev=nfev)


def _sse(data: AuditData, params: dict[str, float], idx: np.ndarray) -> float:
    r = data.t_out_n[idx] - twin.simulate(data.inputs, params)[idx]
    return float(r @ r)


def _bounds_and_scale(name: str) -> tuple[float, float, float]:
    if name == "mu":
        return MU_BOUNDS[0], MU_BOUNDS[1], MU_SCALE
    from .effects import BY_PARAM  # noqa: PLC0415

    e = BY_PARAM[name]
    return e.bounds[0], e.bounds[1], e.scale


def _least_squares(data, params, names, idx):
    lo, hi, scale = (np.array(v) for v in zip(*(_bounds_and_scale(n) for n in names), strict=True))
    x0 = np.clip(np.array([params[n] for n in names]), lo, hi) / scale
    y = data.t_out_n[idx]

    cache: dict[tuple, np.ndarray] = {}

    def fun(x):
        p = dict(params)
        p.update(zip(names, x * scale, strict=True))
        # the sensor's parameters do not change the friction: reuse its output
        key = tuple(p.get(k, 0.0) for k in twin.FRICTION_PARAMS)
        if key not in cache:
            cache.clear()
            cache[key] = twin.friction_output(data.inputs, p)
        return twin.sensor_output(cache[key], p, data.inputs.dt_s)[idx] - y

    res = least_squares(
        fun,
        x0,
        bounds=(lo / scale, hi / scale),
        x_scale=1.0,
        diff_step=1e-4,
        max_nfev=20 * (len(names) + 1),
        xtol=1e-5,
        ftol=1e-6,
    )
    out = dict(params)
    out.update(zip(names, (res.x * scale).tolist(), strict=True))
    return out, int(res.nfev)


def _scan_delay(data: AuditData, params: dict[str, float], fit_idx: np.ndarray) -> float:
    """The whole-sample delay that fits best with the other parameters held (0 .. 0.2 s or a
    twentieth of the record): the sums of squares of every shift from two correlations."""
    dt = data.inputs.dt_s
    p = {**params, "sensor_delay": 0.0}
    offset = p.get("sensor_offset", 0.0)
    b = twin.sensor_output(twin.friction_output(data.inputs, p), p, dt) - offset
    n = len(b)
    m_max = int(min(0.2, 0.05 * n * dt) / dt)
    w = np.zeros(n)
    w[fit_idx] = 1.0
    yw = (data.t_out_n - offset) * w
    # the sensor reads b[0] before the start: b_ext[m_max + i - m] = b[i - m]
    b_ext = np.concatenate([np.full(m_max, b[0]), b])
    # S1(m) = sum_i yw_i b_ext[m_max + i - m], S2(m) = sum_i w_i b_ext[m_max + i - m]^2
    s1 = fftconvolve(b_ext, yw[::-1], mode="valid")[::-1]
    s2 = fftconvolve(b_ext**2, w[::-1], mode="valid")[::-1]
    sse = s2[: m_max + 1] - 2.0 * s1[: m_max + 1]
    return int(np.argmin(sse)) * dt


# --- decision ----------------------------------------------------------------------------------


def paired_z(
    data: AuditData, r_a: np.ndarray, r_b: np.ndarray, roles: tuple[int, ...] = (SELECT,)
) -> float:
    """How surely model b fits the samples of some roles better than model a (residuals r_a,
    r_b), against the sensor's noise: the summed drop of the squared residual,
    sum(r_a^2 - r_b^2), over the spread that white noise of the noise floor sigma alone would
    give it, 2 sigma sqrt(sum delta^2) with delta = r_a - r_b the change between the models.
    A real effect gives z near sqrt(sum delta^2) / (2 sigma); a candidate that only fits noise
    gives z of order 1 or below (it fits the fit blocks' noise, not these samples')."""
    m = np.isin(data.roles, roles)
    ra, rb = r_a[m], r_b[m]
    d_sum = float(np.sum(ra * ra - rb * rb))
    delta = ra - rb
    se = 2.0 * data.noise_floor_n * math.sqrt(float(delta @ delta))
    if se == 0.0:
        return 0.0 if d_sum == 0.0 else math.copysign(math.inf, d_sum)
    return d_sum / se


@dataclass
class Candidate:
    """One candidate tried in one round: its fitted model and held-out score."""

    effect: Effect
    model: Model
    explained_pct: float  # of the current model's selection-block residual mean square
    removed_rms_n: float
    z: float
    significant: bool


@dataclass
class Round:
    current: Model
    candidates: list[Candidate]
    chosen: Candidate | None
    skipped: dict[str, str]  # cause -> why it was not tried


@dataclass
class Finding:
    """A named cause: the fitted FMU parameter, its share of the held-out residual and why."""

    effect: Effect
    value: float
    explains_pct: float  # of the baseline's report-block residual mean square
    selection_pct: float
    z: float
    runner_up: str | None
    runner_up_pct: float | None
    separation_z: float | None
    ambiguous_with: str | None = None
    evidence: str = ""


@dataclass
class AuditResult:
    """Everything the audit found, with what a reader needs to judge it."""

    data: AuditData
    baseline: Model
    extended: Model
    rounds: list[Round]
    findings: list[Finding]
    steps: list[Model]  # baseline, then the model after each finding in order
    fmu_baseline: np.ndarray
    fmu_extended: np.ndarray
    twin_fmu_max_diff_n: float
    unexplained: dict
    rule: DecisionRule = RULE
    wall_s: float = 0.0
    extras: dict = field(default_factory=dict)

    def rms_report(self, prediction: np.ndarray) -> float:
        r = (self.data.t_out_n - prediction)[self.data.roles == REPORT]
        return float(np.sqrt(np.mean(r * r)))

    @property
    def holdout_rms_before_n(self) -> float:
        return self.rms_report(self.fmu_baseline)

    @property
    def holdout_rms_after_n(self) -> float:
        return self.rms_report(self.fmu_extended)

    @property
    def gain_pct(self) -> float:
        """Share of the report blocks' residual mean square the extension removes."""
        before = self.holdout_rms_before_n
        return 100.0 * (1.0 - (self.holdout_rms_after_n / before) ** 2) if before > 0 else 0.0


Progress = Callable[[str, float], None]


def run(
    data: AuditData, rule: DecisionRule = RULE, progress: Progress | None = None
) -> AuditResult:
    """The audit of prepared data (module docstring); progress(message, fraction) while it fits."""
    import time  # noqa: PLC0415

    t_start = time.perf_counter()
    say = progress or (lambda msg, frac: None)
    usable = [e for e in VOCABULARY if e.applicable(data.has_positions, data.z_span_m) is None]
    skipped = {
        e.cause: e.applicable(data.has_positions, data.z_span_m)
        for e in VOCABULARY
        if e not in usable
    }
    total = 2 + len(usable) * 2 + 4
    done = 0

    def tick(msg: str) -> None:
        nonlocal done
        done += 1
        say(msg, min(1.0, done / total))

    tick("fitting the nominal model (capstan friction, dead zone, phi from the geometry)")
    baseline = fit_model(data, ())
    data.sampling_error_n = sampling_error(data, baseline.prediction)
    current = baseline
    steps = [baseline]
    rounds: list[Round] = []
    found: list[Effect] = []
    for _ in range(rule.max_findings):
        cands: list[Candidate] = []
        ms0 = current.ms(data, SELECT)
        r0 = current.residual(data)
        for e in usable:
            if e in found:
                continue
            tick(f"round {len(rounds) + 1}: {e.cause} ({e.fmu_param})")
            # every parameter refitted together: a finding fitted alone absorbs part of an
            # effect not yet in the model (an offset takes some of a tension-dependent friction)
            m = fit_model(data, (*found, e), current.params)
            ms1 = m.ms(data, SELECT)
            removed = ms0 - ms1
            pct = 100.0 * removed / ms0 if ms0 > 0 else 0.0
            z = paired_z(data, r0, m.residual(data))
            rms_removed = math.sqrt(max(removed, 0.0))
            sig = pct >= rule.min_explained_pct and z >= rule.min_z
            sig = sig and rms_removed >= rule.min_rms_n(
                data.noise_floor_n, data.input_noise_n, data.sampling_error_n
            )
            cands.append(Candidate(e, m, pct, rms_removed, z, sig))
        sig = sorted((c for c in cands if c.significant), key=lambda c: -c.explained_pct)
        chosen = sig[0] if sig else None
        rounds.append(Round(current, cands, chosen, dict(skipped)))
        if chosen is None:
            break
        found.append(chosen.effect)
        current = chosen.model
        steps.append(current)
    dropped: list[str] = []
    withouts = {found[0].cause: steps[0]} if len(found) == 1 else {}
    if len(found) > 1:
        tick("checking each finding against the model without it")
        found, steps, dropped, withouts = _backward(data, found, steps, rule)
        current = steps[-1]
        rounds = [r for r in rounds if r.chosen is None or r.chosen.effect in found]
    findings = _findings(data, rounds, steps, withouts, rule)

    tick("running the nominal model through the FMU")
    fmu_base = twin.run_fmu(data.inputs, baseline.params)
    tick("running the extended model through the FMU")
    fmu_ext = twin.run_fmu(data.inputs, current.params) if findings else fmu_base.copy()
    diff = float(np.max(np.abs(fmu_ext - current.prediction)))
    tick("describing what is left")
    unexplained = describe_residual(data, data.t_out_n - fmu_ext)
    result = AuditResult(
        data=data,
        baseline=baseline,
        extended=current,
        rounds=rounds,
        findings=findings,
        steps=steps,
        fmu_baseline=fmu_base,
        fmu_extended=fmu_ext,
        twin_fmu_max_diff_n=diff,
        unexplained=unexplained,
        rule=rule,
    )
    for f in findings:
        f.evidence = _evidence(result, f)
    if dropped:
        result.extras["dropped_by_backward_check"] = dropped
    result.wall_s = time.perf_counter() - t_start
    return result


def sampling_error(data: AuditData, prediction: np.ndarray) -> float:
    """The prediction's uncertainty from the sampling of its input (DecisionRule): the RMS of
    its change over one sample / sqrt(12), over the scored record."""
    step = np.diff(prediction)[data.roles[1:] != WARMUP]
    return float(np.sqrt(np.mean(step * step)) / math.sqrt(12.0)) if step.size else 0.0


def _passes(data: AuditData, without: Model, with_: Model, rule: DecisionRule) -> bool:
    """The decision rule for `with_` against `without` on the selection blocks."""
    ms0, ms1 = without.ms(data, SELECT), with_.ms(data, SELECT)
    removed = ms0 - ms1
    pct = 100.0 * removed / ms0 if ms0 > 0 else 0.0
    z = paired_z(data, without.residual(data), with_.residual(data))
    return (
        pct >= rule.min_explained_pct
        and z >= rule.min_z
        and math.sqrt(max(removed, 0.0))
        >= rule.min_rms_n(data.noise_floor_n, data.input_noise_n, data.sampling_error_n)
    )


def _backward(data, found, steps, rule):
    """Drop any finding that the others make unnecessary (the rule, applied to the model without
    it), refitting the models of the remaining findings in their order; repeat until none drops.
    Also returns the model without each remaining finding (for its share of the residual)."""
    found = list(found)
    dropped: list[str] = []
    while True:
        full = steps[-1]
        withouts: dict[str, Model] = {}
        for e in found:
            rest = tuple(f for f in found if f is not e)
            start = {k: v for k, v in full.params.items() if k != e.fmu_param}
            withouts[e.cause] = fit_model(data, rest, start) if rest else steps[0]
            if len(found) > 1 and not _passes(data, withouts[e.cause], full, rule):
                found.remove(e)
                dropped.append(e.cause)
                steps = [steps[0]]
                for i in range(1, len(found) + 1):
                    steps.append(fit_model(data, tuple(found[:i]), withouts[e.cause].params))
                break
        else:
            return found, steps, dropped, withouts


def phi_text(data: AuditData, mu: float) -> tuple[float | None, str]:
    """The bending angle behind a fitted mu, and where it comes from."""
    if data.has_positions:
        return None, "from the geometry of the positions (cosim.parts.geometry)"
    routing = "loop routing" if data.inputs.loop_routing else "free sag"
    if data.mu_given is None:
        return data.phi_ref_rad, (
            f"no positions: phi assumed constant, {data.phi_ref_rad:.4f} rad ({routing} at x = 0,"
            f" y = L/2, z = 0); mu is fitted for it (only mu*phi is observable)"
        )
    phi = mu * data.phi_ref_rad / data.mu_given
    return phi, f"no positions: phi fitted as a constant with the sidecar's mu = {data.mu_given:g}"


def _findings(
    data: AuditData, rounds: list[Round], steps: list[Model], withouts: dict, rule
) -> list[Finding]:
    """The findings in order of importance. explains_pct: the share of the baseline's residual
    mean square on the report blocks that the extended model loses when this finding is taken
    out (and the rest refitted); with interacting effects the shares may add up to more than the
    total gain."""
    base_ms = steps[0].ms(data, REPORT)
    full_ms = steps[-1].ms(data, REPORT)
    out: list[Finding] = []
    for i, rnd in enumerate(rounds):
        c = rnd.chosen
        if c is None:
            break
        others = sorted((o for o in rnd.candidates if o is not c), key=lambda o: -o.explained_pct)
        runner = others[0] if others else None
        sep = None
        ambiguous = None
        if runner is not None and runner.explained_pct > 0:
            # Both have as many parameters, so the fit blocks favour neither: the separation
            # uses them with the selection blocks (the report blocks stay unseen).
            sep = paired_z(data, runner.model.residual(data), c.model.residual(data), (FIT, SELECT))
            nxt = rounds[i + 1] if i + 1 < len(rounds) else None
            still = nxt is not None and any(
                o.effect is runner.effect and o.significant for o in nxt.candidates
            )
            if runner.significant and not still and sep < rule.separation_z:
                ambiguous = runner.effect.cause
        before = withouts[c.effect.cause].ms(data, REPORT)
        out.append(
            Finding(
                effect=c.effect,
                value=float(c.model.params[c.effect.fmu_param]),
                explains_pct=100.0 * (before - full_ms) / base_ms if base_ms > 0 else 0.0,
                selection_pct=c.explained_pct,
                z=c.z,
                runner_up=runner.effect.cause if runner else None,
                runner_up_pct=runner.explained_pct if runner else None,
                separation_z=sep,
                ambiguous_with=ambiguous,
            )
        )
    # the final values are those of the extended model (refitted with every finding)
    final = steps[-1].params
    for f in out:
        f.value = float(final[f.effect.fmu_param])
    return sorted(out, key=lambda f: -f.explains_pct)


def _evidence(result: AuditResult, f: Finding) -> str:
    """One sentence: why this cause, in numbers."""
    text = (
        f"{f.effect.describe(f.value)} removes {f.selection_pct:.0f} % of the residual on the "
        f"selection blocks (paired z = {f.z:.1f})"
    )
    if f.runner_up is not None and f.runner_up_pct is not None:
        text += f"; the next candidate, {f.runner_up}, removes {max(f.runner_up_pct, 0):.0f} %"
        if f.separation_z is not None and math.isfinite(f.separation_z):
            text += f" (worse by z = {f.separation_z:.1f})"
    if f.ambiguous_with:
        text += (
            f"; {f.ambiguous_with} explains the same residual and is not significantly worse, "
            "so the two are not told apart by these data"
        )
    return text + "."


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
