"""A rig written here, independently of the plant FMU and of the audit's twin, to judge the audit
on data it cannot reproduce exactly.

The cable is a braid of STRANDS parallel strands that share the inlet tension equally; each strand
runs through the sheath as SEGMENTS lumped segments in series, and each segment is a Coulomb
contact with the linearised capstan law (a segment of bending dphi passes T (1 - mu_j dphi) when
the cable slides towards the end-effector and T / (1 - mu_j dphi) when it slides back, and holds
its output tension in between). The strands' friction coefficients mu_j follow a log-normal
distribution around the rig's mu: the strands leave their dead zones one after another, so the
output turns gradually at every reversal, as measured cables do, instead of the sharp corner of a
single capstan (a distribution of friction thresholds: the distributed-element model of
W. D. Iwan, "A distributed-element model for hysteresis and its steady-state dynamic response",
J. Appl. Mech. 33 (1966) 893-900). None of this is the FMU's equations (exponential capstan
factors on one chain of 32 segments, sharp corners).

Inputs: a wandering input tension (three random sines, as an operator would drive a bench) or
the paper's triangle ramps, at a fixed position (no position columns) or at held positions.
Disturbances and effects are added here, each in its own form, so that the tests can hide them.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from numba import njit

from cosim.results import trace

RATE_HZ = 1000.0
STRANDS = 12
SEGMENTS = 4
# the rig's cable for its viscous friction along the sheath (rig_record): 1 m of a braided line
# of 6 kN axial rigidity (assumed)
RIG_LENGTH_M = 1.0
RIG_EA_N = 6000.0


def wandering_input(rng: np.random.Generator, n: int) -> np.ndarray:
    t = np.arange(n) / RATE_HZ
    freqs = rng.uniform([0.15, 0.5, 1.2], [0.4, 1.1, 2.5])
    amps = rng.uniform([4.0, 1.5, 0.5], [6.0, 3.0, 1.2])
    phases = rng.uniform(0, 2 * np.pi, 3)
    x = 11.0 + sum(
        a * np.sin(2 * np.pi * f * t + p) for a, f, p in zip(amps, freqs, phases, strict=True)
    )
    return np.maximum(x, 0.5)


def ramp_input(rng: np.random.Generator, n: int) -> np.ndarray:
    x = np.empty(n)
    k = 0
    while k < n:
        period = int(rng.uniform(2.0, 4.0) * RATE_HZ)
        peak = rng.uniform(8.0, 24.0)
        phase = np.arange(period) / period
        x[k : k + period] = (1.0 + (peak - 1.0) * (1.0 - np.abs(2.0 * phase - 1.0)))[: n - k]
        k += period
    return x


def strand_mus(mu: float, spread: float, rng: np.random.Generator) -> np.ndarray:
    """STRANDS friction coefficients, log-normal with median mu and log-sd `spread`, at the
    quantiles of the distribution (so the rig's spread does not depend on the seed)."""
    from scipy.stats import norm  # noqa: PLC0415

    q = (np.arange(STRANDS) + 0.5) / STRANDS
    return mu * np.exp(spread * norm.ppf(q))


@njit(cache=True)
def _chain(held, j, t, c_pull, c_release, segments):
    """One strand's segments for an input tension t; the direction its last segment slid."""
    moved = 0.0
    for s in range(segments):
        pull = t * (1.0 - c_pull)
        release = t / (1.0 - c_release)
        moved = 0.0
        if held[j, s] < pull:
            held[j, s] = pull
            moved = 1.0
        elif held[j, s] > release:
            held[j, s] = release
            moved = -1.0
        t = held[j, s]
    return t, moved


@njit(cache=True)
def _braid(t_in, phi, mus, extra_mu, segments, static_ratio):
    n = t_in.shape[0]
    held = np.zeros((mus.shape[0], segments))
    # each strand's last slide at the end-effector: +1 pulled, -1 released, 0 not yet. A strand
    # is inextensible along the sheath: after a reversal it moves at the end-effector only once
    # static friction (static_ratio times the sliding one, in every segment) is overcome along
    # its whole length; then every segment drops to sliding friction at once (stick-slip).
    slid = np.zeros(mus.shape[0])
    out = np.empty(n)
    along = np.empty(n)  # the mean tension along the cable: the input and every segment's
    for k in range(n):
        dphi = phi[k] / segments
        total = 0.0
        for j in range(mus.shape[0]):
            c = max(0.0, min(0.9, (mus[j] + extra_mu[k]) * dphi))
            c_stuck = max(0.0, min(0.9, static_ratio * c))
            c_pull = c if slid[j] > 0.0 else c_stuck
            c_release = c if slid[j] < 0.0 else c_stuck
            t, moved = _chain(held, j, t_in[k], c_pull, c_release, segments)
            if moved != 0.0 and moved != slid[j]:
                slid[j] = moved  # broke loose: the whole strand slides with sliding friction
                t, moved = _chain(held, j, t_in[k], c, c, segments)
            total += t
        out[k] = total / mus.shape[0]
        along[k] = (t_in[k] + np.sum(held) / mus.shape[0]) / (segments + 1)
    return out, along


def braid_output(t_in, phi, mus, extra_mu=None, static_ratio: float = 1.0) -> np.ndarray:
    """True output tension of the braid for an input tension and a bending angle per sample;
    `extra_mu` (per sample) adds to every strand's mu (friction that follows something else);
    `static_ratio` > 1: a strand breaks loose after a reversal only at that multiple of its
    sliding friction, then jumps to the sliding bound (stick-slip)."""
    t_in = np.ascontiguousarray(t_in, dtype=float)
    extra = np.zeros(len(t_in)) if extra_mu is None else np.ascontiguousarray(extra_mu, float)
    phi = np.ascontiguousarray(phi, float)
    return _braid(t_in, phi, np.asarray(mus, float), extra, SEGMENTS, float(static_ratio))[0]


def braid_mean_tension(t_in, phi, mus, static_ratio: float = 1.0) -> np.ndarray:
    """The braid's mean tension along the cable per sample (its input and its segments' held
    tensions, averaged over the strands), without extra friction."""
    t_in = np.ascontiguousarray(t_in, dtype=float)
    phi = np.ascontiguousarray(phi, float)
    extra = np.zeros(len(t_in))
    return _braid(t_in, phi, np.asarray(mus, float), extra, SEGMENTS, float(static_ratio))[1]


def held_positions(rng: np.random.Generator, n: int) -> np.ndarray:
    pos = np.empty((n, 3))
    k = 0
    while k < n:
        hold = int(rng.uniform(3.0, 6.0) * RATE_HZ)
        r = rng.uniform(0.35, 0.8)
        az, el = rng.uniform(-0.3, 0.3), rng.uniform(-0.6, 0.6)
        pos[k : k + hold] = [r * math.sin(az), r * math.cos(az) * math.cos(el), r * math.sin(el)]
        k += hold
    return pos


def rig_record(
    folder: Path,
    seed: int,
    duration_s: float = 60.0,
    mu: float = 0.08,
    spread: float = 0.3,
    noise_n: float = 0.03,
    drive: str = "wander",
    positions: bool = False,
    offset_n: float = 0.0,
    gain: float = 1.0,
    lag_s: float = 0.0,
    periodic: tuple[float, float] | None = None,
    static_ratio: float = 1.0,
    slack_n: float = 0.0,
    slack_knee: float = 0.0,
    full_scale_n: float = 0.0,
    creep: float = 0.0,
    creep_tau_s: float = 1.0,
    spikes: tuple[int, float] | None = None,
    ring: tuple[float, float, float] | None = None,
    viscous_rate_s_n: float = 0.0,
    viscous_speed_s_m: float = 0.0,
    friction_slope_per_n: float = 0.0,
    drift: tuple[str, float, float] | None = None,
    lag2_s: float = 0.0,
    bend: tuple | None = None,
    name: str = "rig.csv",
) -> Path:
    """Write a rig record (CSV and a sidecar without mu). `periodic` = (amplitude N, frequency
    Hz) adds a sinusoidal pickup to the output sensor (mains, a pump, a fan). The rig's own
    forms of five effects, each off by default:

    - `static_ratio`: static friction, breakaway at that multiple of the sliding friction in
      every segment, overcome along a strand's whole length before it moves (braid_output);
    - `slack_n`: the cable's pretension is taken up by a linear spring at the end-effector that
      the cable stretches fully only above this input tension; below it the end-effector sees
      the share t_in / slack_n of the braid's tension; with `slack_knee` k > 0 the spring
      stiffens gradually instead (a share none of the FMU's fixed laws has): the share is the
      hyperbolic turn (x + 1 - sqrt((x - 1)^2 + k^2)) / 2 + (sqrt(1 + k^2) - 1) / 2 of
      x = t_in / slack_n, clipped to [0, 1] (0 at no input, full from about (1 + k) slack_n);
    - `full_scale_n`: the output amplifier's rail: its reading is clipped there (before the
      noise of the acquisition);
    - `viscous_rate_s_n`: a lubricant's shear that follows how fast the tension changes: every
      strand's mu rises by viscous_rate_s_n * |dT_in/dt|, the input's rate by central
      differences of the true input (no filter);
    - `viscous_speed_s_m`: the lubricant's shear follows the cable's speed along the sheath
      instead: every strand's mu rises by viscous_speed_s_m * |v|, v the rate of the cable's
      elastic stretch, RIG_LENGTH_M / RIG_EA_N times the rate of the braid's mean tension along
      the cable (braid_mean_tension; central differences, no filter; of the braid without the
      viscous part: one pass, the part's effect on the stretch is second order);
    - `friction_slope_per_n`: friction that changes with the tension the cable carries (a liner
      pressed harder, a lubricant squeezed out): every strand's mu rises by friction_slope_per_n
      times the braid's mean tension along the cable (braid_mean_tension, of the braid without
      it: one pass), the same rise in every segment, where the FMU's slope follows each
      segment's own tension;
    - `drift` = (form, size, time): every strand's mu changes over the record, "linear" by size
      per second from the start (time unused), "warm-up" by size * (1 - exp(-t / time)) (the
      lubricant settling from the start), "step" by size from the instant time on (a new
      stretch of liner reached, a lubricant lost); two shapes none of the FMU's fixed forms has:
      "overshoot" by size * (1 - exp(-t / time)) - 0.6 size (1 - exp(-t / (3 time))), a warm-up
      that rises to about 0.58 size near 2.4 time and falls back to 0.4 size (a liner that
      heats past its running temperature before the cooling catches up, a lubricant first
      spread, then partly wiped off), and "two-stage" by half of size as a warm-up of time from
      the start and the other half as one of time from 5 time on (two contacts warming one after
      the other);
    - `lag2_s`: the output sensor as a critically damped second-order system of two equal time
      constants (a load cell's mass on its spring, or an amplifier's two-pole filter), by the
      bilinear transform (after the first-order `lag_s` when both are set);
    - `bend` = (axis, size rad/m): the sheath bends by more than the geometry says as the
      end-effector moves along one coordinate (0 x, 1 y, 2 z; needs `positions`), as at a
      clamp it wraps around further: the braid's phi rises by size * coordinate (at least 0),
      seen through the rig's own friction (its strands' spread of mu, four segments, the
      linearised capstan law); `axis` may also be a direction (three numbers, normalised here),
      and a third element `power` 2 makes the rise size * (the position along it)^2 (rad/m^2):
      a bend that follows a combination of the coordinates, or grows the further the
      end-effector moves that way, which no fixed form along one coordinate has;
    - `creep`, `creep_tau_s`: the load cell's spring and a viscoelastic element in parallel (a
      standard linear solid): a share `creep` of a change in tension is read only as the element
      relaxes with creep_tau_s (integrated by backward Euler at the sample rate).

    Two disturbances no cause explains: `spikes` = (count, amplitude N), isolated one-sample
    spikes of either sign on the output sensor (electrical interference); `ring` = (amplitude N,
    frequency Hz, decay s), a decaying oscillation of the output after every reversal of the
    input (the cable's vibration when it breaks loose).
    """
    rng = np.random.default_rng(seed)
    n = int(round(duration_s * RATE_HZ))
    t = np.arange(n) / RATE_HZ
    t_in = wandering_input(rng, n) if drive == "wander" else ramp_input(rng, n)
    if positions:
        from cosim.parts.geometry import bending_angle  # noqa: PLC0415

        pos = held_positions(rng, n)
        phi = bending_angle(pos[:, 0], pos[:, 1], pos[:, 2], 1.0, True)
    else:
        pos = None
        phi = np.full(n, 2.0 * math.pi)  # loop routing in the loop's plane (paper Sec. III-A)
    if bend is not None:
        axis, size, *power = bend
        if isinstance(axis, int):
            along = pos[:, axis]
        else:
            w = np.asarray(axis, dtype=float)
            along = pos @ (w / np.linalg.norm(w))
        phi = np.maximum(0.0, phi + size * along ** (power[0] if power else 1))
    extra_mu = None
    mus = strand_mus(mu, spread, rng)
    if viscous_rate_s_n != 0.0:
        extra_mu = viscous_rate_s_n * np.abs(np.gradient(t_in) * RATE_HZ)
    if drift is not None:
        form, size, when = drift
        if form == "linear":
            change = size * t
        elif form == "warm-up":
            change = size * (1.0 - np.exp(-t / when))
        elif form == "overshoot":
            change = size * (1.0 - np.exp(-t / when)) - 0.6 * size * (1.0 - np.exp(-t / (3 * when)))
        elif form == "two-stage":
            late = np.maximum(t - 5.0 * when, 0.0)
            change = 0.5 * size * (2.0 - np.exp(-t / when) - np.exp(-late / when))
        else:
            change = np.where(t >= when, size, 0.0)
        extra_mu = change if extra_mu is None else extra_mu + change
    if friction_slope_per_n != 0.0 or viscous_speed_s_m != 0.0:
        along = braid_mean_tension(t_in, phi, mus, static_ratio=static_ratio)
    if friction_slope_per_n != 0.0:
        extra_mu = (0.0 if extra_mu is None else extra_mu) + friction_slope_per_n * along
    if viscous_speed_s_m != 0.0:
        speed = RIG_LENGTH_M / RIG_EA_N * np.gradient(along) * RATE_HZ
        extra_mu = (0.0 if extra_mu is None else extra_mu) + viscous_speed_s_m * np.abs(speed)
    out = braid_output(t_in, phi, mus, extra_mu=extra_mu, static_ratio=static_ratio)
    if slack_n > 0.0 and slack_knee > 0.0:
        x = t_in / slack_n
        soft = 0.5 * (x + 1.0 - np.sqrt((x - 1.0) ** 2 + slack_knee**2))
        out = out * np.clip(soft + 0.5 * (math.sqrt(1.0 + slack_knee**2) - 1.0), 0.0, 1.0)
    elif slack_n > 0.0:
        out = out * np.clip(t_in / slack_n, 0.0, 1.0)
    if creep != 0.0:
        relaxed = np.empty(n)
        state = out[0]
        h = 1.0 / (RATE_HZ * creep_tau_s)
        for k in range(n):
            state = (state + h * out[k]) / (1.0 + h)
            relaxed[k] = state
        out = (1.0 - creep) * out + creep * relaxed
    if lag_s > 0.0:  # the output sensor's own first-order lag, by its exact discrete pole
        a = math.exp(-1.0 / (RATE_HZ * lag_s))
        y = np.empty(n)
        acc = out[0]
        for k in range(n):
            acc = a * acc + (1.0 - a) * out[k]
            y[k] = acc
        out = y
    if lag2_s > 0.0:  # a critically damped second-order sensor, 1 / (lag2_s s + 1)^2, by
        # the bilinear transform at the sample rate, starting settled
        from scipy.signal import bilinear, lfilter, lfilter_zi  # noqa: PLC0415

        b, a = bilinear([1.0], [lag2_s**2, 2.0 * lag2_s, 1.0], fs=RATE_HZ)
        out = lfilter(b, a, out, zi=lfilter_zi(b, a) * out[0])[0]
    reading = gain * out + offset_n
    if full_scale_n > 0.0:
        reading = np.minimum(reading, full_scale_n)
    meas_out = reading + rng.normal(0.0, noise_n, n)
    if periodic is not None:
        amp, freq = periodic
        meas_out = meas_out + amp * np.sin(2 * np.pi * freq * t + 0.7)
    if spikes is not None:
        count, amp = spikes
        where = np.random.default_rng(seed + 7).choice(n, count, replace=False)
        meas_out[where] += amp * np.where(np.arange(count) % 2 == 0, 1.0, -1.0)
    if ring is not None:
        amp, freq, decay = ring
        turns = np.flatnonzero(np.diff(np.sign(np.diff(t_in))) != 0) + 1
        for k in turns:
            m = min(n - k, int(5 * decay * RATE_HZ))
            tt = np.arange(m) / RATE_HZ
            meas_out[k : k + m] += amp * np.sin(2 * np.pi * freq * tt) * np.exp(-tt / decay)
    meas_in = t_in + rng.normal(0.0, noise_n, n)
    cols = {"t_s": t, "T_in_N": meas_in, "T_out_N": meas_out}
    if pos is not None:
        cols.update({"x_m": pos[:, 0], "y_m": pos[:, 1], "z_m": pos[:, 2]})
    path = Path(folder) / name
    np.savetxt(
        path,
        np.column_stack(list(cols.values())),
        fmt="%.6f",
        delimiter=",",
        header=",".join(cols),
        comments="",
    )
    meta = {"sample_rate_hz": RATE_HZ, "sheath_length_m": 1.0, "loop_routing": True}
    trace.meta_path(path).write_text(json.dumps(meta))
    return path
