"""The paper's experiments as co-simulation scenarios (a run's configuration: cosim.config.run).

A scenario says what the world does: the reference tension T_ref(t) that the processor's
compensator receives and the end-effector trajectory (x, y, z)(t) that moves the sheath. Both are
computed up front for every FPGA sample (numpy arrays), so that the closed loop only indexes them.

Coordinates follow the paper's Fig. 6 and 7 (Sec. III): the actuator outlet A is at the origin,
the sheath leaves it along +Y, and the end-effector C sits at (x, y, z) in metres with its own
outlet also along +Y. Loop routing keeps phi = 2*pi for any C in the loop's plane (x = 0).

Scenarios (paper Sec. VI):

- ``characterize`` (Fig. 11): T_ref ramped from 0 to 24 N and back in 3 s, five times, with the
  end-effector held in the loop's plane (phi = 2*pi with loop routing); the capstan model fitted
  to (T_in, T_out) returns mu.
- ``positions`` (Fig. 12, 13): the same ramp, two cycles at each of five end-effector positions;
  the fitted friction mu*phi per position shows the spread, with and without loop routing.
  The paper's text does not give the coordinates of Fig. 12; the five positions below are our
  choice (named assumption): a spread over the workspace of a 1 m sheath, four of them in the
  loop's plane and one out of it.
- ``fig14`` (Fig. 14): a sinusoidal T_ref between 2 N and 15 N (0.5 Hz) while the end-effector
  moves in 3-D, 30 s. The paper gives the maximum (15 N) and that the end-effector "changes its
  position in 3-D space"; frequency, minimum and path are our choice (named assumption). The path
  is a slow Lissajous figure that sweeps the same region as the Fig. 12 positions below
  (y 0.25 .. 0.75 m, z -0.3 .. +0.3 m, x -0.1 .. +0.1 m), so that the experiment of Fig. 14 sees
  the friction change that Fig. 13 measures: without loop routing phi then moves over about
  2.6 .. 5.3 rad around the 4.2 rad the compensator is calibrated with; with it, 2*pi .. 2*pi+0.02.
  A path that stays near the calibration point (an earlier choice, +-0.15 m in y) hides that
  change, and the paper law then does better without the loop only because its smaller mu*phi
  makes smaller jumps of T_c at reversals (see cosim/README.md, "Why").
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from cosim.config.run import SimConfig

SCENARIO_NAMES = (
    "characterize",
    "positions",
    "fig14",
    "tune",
    "sine1hz",
    "triangle",
    "multisine",
    "fig14path2",
)
# Issue 11's split: gains, the smooth band and the preview horizon are chosen on `tune` only
# (cosim/tune); fig14 and the held-out scenarios are only reported, never tuned on.
TUNE_SCENARIO = "tune"
HELD_OUT_SCENARIOS = ("sine1hz", "triangle", "multisine", "fig14path2")


# Friction identified in the paper (Sec. VI-A, Fig. 11) and the sheath of Table I.
MU_PAPER = 0.075
SHEATH_LENGTH_M = 1.0

# Ramp of the characterisation (Sec. VI-A): "increased up to 24 N and decreased, over 3 seconds,
# and repeated 5 times".
RAMP_PEAK_N = 24.0
RAMP_PERIOD_S = 3.0
RAMP_CYCLES = 5

# Fig. 14: maximum reference 15 N (Sec. VI-C); the rest is our choice (see module docstring).
FIG14_MAX_N = 15.0
FIG14_MIN_N = 2.0
FIG14_FREQ_HZ = 0.5
FIG14_DURATION_S = 30.0
# Half-widths (x, y, z) of the end-effector's path in fig14: the region of POSITIONS_M.
FIG14_SWING_M = (0.10, 0.25, 0.30)
FIG14_PATH_PERIODS_S = (15.0, 10.0, 7.5)

# Fig. 12 stand-in: (x, y, z) in m, see module docstring.
POSITIONS_M = (
    (0.0, 0.60, 0.00),
    (0.0, 0.40, 0.25),
    (0.0, 0.75, -0.30),
    (0.0, 0.25, 0.00),
    (0.20, 0.50, 0.00),
)
POSITION_CYCLES = 2
# Start (and home) position of the characterisation and of fig14: in the loop's plane.
HOME_M = (0.0, 0.50, 0.0)


@dataclass(frozen=True)
class Segment:
    """A stretch of a scenario during which the end-effector holds one position."""

    t_start_s: float
    t_end_s: float
    position_m: tuple[float, float, float]


@dataclass(frozen=True)
class Scenario:
    """What the world does during a run: reference tension and end-effector trajectory."""

    name: str
    duration_s: float
    description: str
    t_ref: Callable[[np.ndarray], np.ndarray]
    trajectory: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]
    # Start-up excluded from the tracking metrics (the loop starts from a slack cable).
    settle_s: float = 0.0
    # Positions held in turn (for the per-position friction fit); empty if not relevant.
    segments: tuple[Segment, ...] = ()

    def sample_times(self, sample_rate_hz: float, duration_s: float | None = None) -> np.ndarray:
        """Times of the FPGA samples t_k = k / f_s, k = 0 .. n-1, for the run's duration."""
        n = n_samples(duration_s if duration_s is not None else self.duration_s, sample_rate_hz)
        return np.arange(n, dtype=np.float64) / sample_rate_hz


def n_samples(duration_s: float, sample_rate_hz: float) -> int:
    """Number of samples of a run (at least one)."""
    return max(1, int(round(duration_s * sample_rate_hz)))


def _triangle(t: np.ndarray, peak: float, period_s: float) -> np.ndarray:
    """0 -> peak -> 0 in each period (the characterisation ramp)."""
    phase = np.mod(t, period_s) / period_s
    return peak * (1.0 - np.abs(2.0 * phase - 1.0))


def _hold(position: tuple[float, float, float]):
    def trajectory(t: np.ndarray):
        one = np.ones_like(t)
        return position[0] * one, position[1] * one, position[2] * one

    return trajectory


def _characterize(cycles: int = RAMP_CYCLES) -> Scenario:
    return Scenario(
        name="characterize",
        duration_s=cycles * RAMP_PERIOD_S,
        description=(
            f"T_ref ramped 0 -> {RAMP_PEAK_N:g} N -> 0 in {RAMP_PERIOD_S:g} s, {cycles} times, "
            f"end-effector held at {HOME_M} m (paper Fig. 11)"
        ),
        t_ref=lambda t: _triangle(t, RAMP_PEAK_N, RAMP_PERIOD_S),
        trajectory=_hold(HOME_M),
        segments=(Segment(0.0, cycles * RAMP_PERIOD_S, HOME_M),),
    )


def _positions() -> Scenario:
    seg_s = POSITION_CYCLES * RAMP_PERIOD_S
    segments = tuple(Segment(i * seg_s, (i + 1) * seg_s, p) for i, p in enumerate(POSITIONS_M))
    starts = np.array([s.t_start_s for s in segments])
    pos = np.array([s.position_m for s in segments])
    move_s = 0.2  # the end-effector moves to the next position while T_ref is near zero

    def trajectory(t: np.ndarray):
        idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(segments) - 1)
        prev = np.maximum(idx - 1, 0)
        # Smooth (cosine) move over the first move_s of a segment, from the previous position.
        a = np.clip((t - starts[idx]) / move_s, 0.0, 1.0)
        w = 0.5 - 0.5 * np.cos(np.pi * a)
        w = np.where(idx == 0, 1.0, w)
        p = pos[prev] + (pos[idx] - pos[prev]) * w[:, None]
        return p[:, 0], p[:, 1], p[:, 2]

    return Scenario(
        name="positions",
        duration_s=len(segments) * seg_s,
        description=(
            f"the characterisation ramp, {POSITION_CYCLES} cycles at each of {len(segments)} "
            "end-effector positions (paper Fig. 12, 13)"
        ),
        t_ref=lambda t: _triangle(t, RAMP_PEAK_N, RAMP_PERIOD_S),
        trajectory=trajectory,
        segments=segments,
    )


def _fig14() -> Scenario:
    mid = 0.5 * (FIG14_MAX_N + FIG14_MIN_N)
    amp = 0.5 * (FIG14_MAX_N - FIG14_MIN_N)

    def t_ref(t: np.ndarray) -> np.ndarray:
        # Before the first minimum the reference eases in from zero over 0.5 s, so the loop
        # starts gently.
        return (mid - amp * np.cos(2.0 * np.pi * FIG14_FREQ_HZ * t)) * _ease(t)

    return Scenario(
        name="fig14",
        duration_s=FIG14_DURATION_S,
        description=(
            f"sinusoidal T_ref {FIG14_MIN_N:g} .. {FIG14_MAX_N:g} N at {FIG14_FREQ_HZ:g} Hz while "
            "the end-effector moves in 3-D (paper Fig. 14)"
        ),
        t_ref=t_ref,
        trajectory=_fig14_path(),
        settle_s=1.0,
    )


def _fig14_path():
    """fig14's end-effector path: a slow Lissajous path around HOME_M over the region of the
    Fig. 12 positions: in-plane (y, z) swings of 0.25 m and 0.3 m and an out-of-plane (x) swing
    of 0.1 m, periods 10 s, 7.5 s and 15 s (|C| <= 0.82 m, inside the 1 m workspace)."""
    return _lissajous(FIG14_SWING_M, FIG14_PATH_PERIODS_S)


def _ease(t: np.ndarray, ramp_in_s: float = 0.5) -> np.ndarray:
    """Raised-cosine ease-in from 0 over ramp_in_s: every scenario starts from a slack cable."""
    a = np.clip(t / ramp_in_s, 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * a)


def _lissajous(swing_m, periods_s, centre_m=HOME_M):
    """An end-effector path sin-swinging about centre_m with half-widths swing_m (x, y, z)."""

    def trajectory(t: np.ndarray):
        return tuple(
            c + s * np.sin(2.0 * np.pi * t / p)
            for c, s, p in zip(centre_m, swing_m, periods_s, strict=True)
        )

    return trajectory


# Tuning scenario (cosim/README.md, "Tuning"): a chirp, so that the chosen parameters see reversals
# from slow to sharp; its own range (3 .. 13 N) and a small path near home. Held-out scenarios
# below differ in frequency, amplitude, wave shape or path; none of them is used by the tuning.
TUNE_DURATION_S = 12.0
HELD_OUT_DURATION_S = 10.0


def _tune() -> Scenario:
    f0, f1, dur = 0.3, 1.2, TUNE_DURATION_S

    def t_ref(t: np.ndarray) -> np.ndarray:
        # Phase of a linear chirp f0 -> f1 over the run.
        phase = 2.0 * np.pi * (f0 * t + 0.5 * (f1 - f0) / dur * t * t)
        return (8.0 - 5.0 * np.cos(phase)) * _ease(t)

    return Scenario(
        name="tune",
        duration_s=dur,
        description="chirp 0.3 -> 1.2 Hz, T_ref 3 .. 13 N, small 3-D path (used to tune only)",
        t_ref=t_ref,
        trajectory=_lissajous((0.05, 0.10, 0.10), (11.0, 9.0, 13.0)),
        settle_s=1.0,
    )


def _held_out(name: str, description: str, t_ref, trajectory=None) -> Scenario:
    """A held-out scenario: HELD_OUT_DURATION_S long, errors from 1 s, on the fig14 path unless
    another trajectory is given."""
    return Scenario(
        name=name,
        duration_s=HELD_OUT_DURATION_S,
        description=f"held out: {description}",
        t_ref=t_ref,
        trajectory=trajectory or _fig14_path(),
        settle_s=1.0,
    )


def _sine1hz() -> Scenario:
    return _held_out(
        "sine1hz",
        "sine 1 Hz, T_ref 4 .. 20 N, the fig14 path",
        lambda t: (12.0 - 8.0 * np.cos(2.0 * np.pi * 1.0 * t)) * _ease(t),
    )


def _triangle_ref() -> Scenario:
    def t_ref(t: np.ndarray) -> np.ndarray:
        # 2 .. 14 N at 0.4 Hz: constant slopes and sharp reversals (the hardest for a lag).
        return (2.0 + _triangle(t, 12.0, 2.5)) * _ease(t)

    return _held_out("triangle", "triangle 0.4 Hz, T_ref 2 .. 14 N, the fig14 path", t_ref)


def _multisine() -> Scenario:
    def t_ref(t: np.ndarray) -> np.ndarray:
        w = 2.0 * np.pi * t
        s = 3.0 * np.sin(w * 0.3) + 2.5 * np.sin(w * 0.7 + 1.0) + 1.5 * np.sin(w * 1.3 + 2.0)
        return (9.0 + s) * _ease(t)  # about 2 .. 16 N

    return _held_out(
        "multisine", "0.3 + 0.7 + 1.3 Hz sines, T_ref about 2 .. 16 N, the fig14 path", t_ref
    )


def _fig14path2() -> Scenario:
    return _held_out(
        "fig14path2",
        "the fig14 reference on another path (wider out of the plane)",
        _fig14().t_ref,
        _lissajous((0.20, 0.15, 0.20), (6.0, 8.0, 5.0), (0.0, 0.55, 0.05)),
    )


_SCENARIOS = {
    "characterize": _characterize,
    "positions": _positions,
    "fig14": _fig14,
    "tune": _tune,
    "sine1hz": _sine1hz,
    "triangle": _triangle_ref,
    "multisine": _multisine,
    "fig14path2": _fig14path2,
}


def get_scenario(name: str) -> Scenario:
    """The scenario called `name` (one of SCENARIO_NAMES)."""
    if name in _SCENARIOS:
        return _SCENARIOS[name]()
    raise ValueError(f"scenario must be one of {', '.join(SCENARIO_NAMES)}; got {name!r}")


def held_at(scen: Scenario, position_m) -> Scenario:
    """The scenario with its reference but the end-effector held at `position_m` (x, y, z in m)
    throughout: one point of a workspace map (the paper's Fig. 8 and 13; `bowden sweep`)."""
    p = tuple(float(v) for v in position_m)
    if len(p) != 3 or not all(math.isfinite(v) for v in p):
        raise ValueError(f"position_m must be three finite numbers (x, y, z); got {position_m!r}")
    segments = (Segment(0.0, scen.duration_s, p),) if scen.segments else ()
    return replace(scen, trajectory=_hold(p), segments=segments)


@dataclass
class Inputs:
    """The scenario sampled at the FPGA rate: what the closed loop indexes per sample."""

    t_s: np.ndarray
    t_ref_n: np.ndarray  # at every FPGA sample; the firmware reads it at its own ticks
    x_m: np.ndarray
    y_m: np.ndarray
    z_m: np.ndarray


def firmware_t_ref(scenario: Scenario, cfg: SimConfig, compensator: str, inp: Inputs):
    """The T_ref the host hands the firmware at each FPGA sample: T_ref(t_k), or in preview mode
    T_ref(t_k + P / f_fw), P = compensator.preview_ticks (comp.h: on a board the firmware
    generates the reference, so it knows it P ticks ahead)."""
    if compensator != "preview":
        return inp.t_ref_n
    ahead_s = int(cfg.compensator.preview_ticks) / cfg.firmware_rate_hz
    return np.asarray(scenario.t_ref(inp.t_s + ahead_s), dtype=np.float64)


def sample_inputs(scenario: Scenario, cfg: SimConfig, duration_s: float | None = None) -> Inputs:
    """Evaluate the scenario's reference and trajectory at every FPGA sample."""
    t = scenario.sample_times(cfg.sample_rate_hz, duration_s)
    x, y, z = scenario.trajectory(t)
    return Inputs(
        t_s=t,
        t_ref_n=np.asarray(scenario.t_ref(t), dtype=np.float64),
        x_m=np.asarray(x, dtype=np.float64),
        y_m=np.asarray(y, dtype=np.float64),
        z_m=np.asarray(z, dtype=np.float64),
    )
