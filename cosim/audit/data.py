"""The audit's data: a measured trace made ready for fitting (cosim.audit.core, step 1).

The input tension drives the model, the output tension is what it must predict. Above
MAX_RATE_HZ the record is decimated (a zero-phase FIR); the input tension is smoothed with a
Savitzky-Golay filter (SMOOTH_S) so that its sensor noise does not enter the friction model as
false reversals, except across fast changes, which are kept as measured (smooth_input). The
record is cut into blocks that take turns as fit, selection, fit, report blocks (after WARMUP_S).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import decimate, fftconvolve, savgol_filter

from cosim.parts.geometry import bending_angle, in_workspace
from cosim.results import trace as trace_mod

from . import plausible, twin

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
# whose roles repeat ROLE_PATTERN. 48 blocks give 12 selection blocks, the folds of the decision
# (decision.DecisionRule): with 6 (24 blocks) a sign over the folds says little.
WARMUP_S = 1.0
BLOCK_TARGET_COUNT = 48
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


class AuditError(ValueError):
    """Data the audit cannot work on; the message names the file and what is expected."""


@dataclass
class AuditData:
    """A measured record prepared for the audit (see the module docstring)."""

    source: str
    t_s: np.ndarray  # uniform sample times
    t_in_meas_n: np.ndarray  # input tension as measured
    t_out_n: np.ndarray  # output tension as measured (less its lines): what the model predicts
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
    # narrow lines the input does not explain (cosim.audit.lines), found in the nominal model's
    # residual and taken out of t_out_n before any candidate is fitted or judged (run); their
    # sum, so that the output as measured is t_out_n + lines_n
    lines: tuple = ()
    lines_n: np.ndarray | None = None

    @property
    def t_out_meas_n(self) -> np.ndarray:
        """The output tension as measured, lines and all (t_out_n is without the lines)."""
        return self.t_out_n if self.lines_n is None else self.t_out_n + self.lines_n

    @property
    def has_positions(self) -> bool:
        return self.positions_m is not None

    @property
    def mu_fixed(self) -> bool:
        """mu is the sidecar's and not fitted. Without positions the model fits the product
        mu*phi as mu at phi_ref_rad whether or not the sidecar gives mu (phi_rad then follows)."""
        return self.mu_given is not None and self.has_positions

    @property
    def spans_m(self) -> tuple[float, float, float]:
        """How far x, y and z move over the record (0 without positions)."""
        if not self.has_positions:
            return (0.0, 0.0, 0.0)
        x, y, z = (float(v) for v in np.ptp(self.positions_m, axis=0))
        return (x, y, z)

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

    def block_indices(self, roles: tuple[int, ...]) -> list[np.ndarray]:
        """Sample indices of each block whose role is one of `roles`, in time order (adjacent
        blocks never share a role: ROLE_PATTERN)."""
        edges = np.flatnonzero(np.diff(self.roles)) + 1
        starts = np.concatenate([[0], edges])
        ends = np.concatenate([edges, [len(self.roles)]])
        return [
            np.arange(a, b) for a, b in zip(starts, ends, strict=True) if self.roles[a] in roles
        ]

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
        x, y, z = (positions[:, i].copy() for i in range(3))
        phi_ref = None
    else:
        p = twin.fixed_position(length)
        phi_ref = float(bending_angle(p[0], p[1], p[2], length, loop))
        phi = np.full(n, phi_ref)
        x = y = z = np.zeros(n)
    inputs = twin.PlantInputs(
        t_in_n=t_in_s,
        phi_rad=np.asarray(phi, dtype=float),
        z_m=z,
        x_m=x,
        y_m=y,
        position_m=positions,
        t0_s=float(t_s[0]),
        dt_s=dt,
        sheath_length_m=length,
        loop_routing=loop,
    )
    why = plausible.refusal(source, t_in, t_out, input_noise, noise_std(t_out))
    if why:
        raise AuditError(why)
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
