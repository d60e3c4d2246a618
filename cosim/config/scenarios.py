"""The paper's experiments as co-simulation scenarios, and the configuration of a run.

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

import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

import numpy as np

from cosim.parts.firmware import MODES
from cosim.parts.interface import ADC_PARTS
from cosim.project.cliargs import shown

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
# The firmware's compensator modes (firmware/include/comp.h, mirrored by cosim.parts.firmware).
COMPENSATORS = tuple(MODES)

# The paper's bench: Table I (Maxon RE25 k_t 23.4 mNm/A, 5.4:1 gearhead, efficiency ~0.9
# assumed, spool radius ~10 mm). Kff = r / (N * eta * k_t) in A/N (contract.md).
SPOOL_RADIUS_M = 0.010
GEAR_RATIO = 5.4
GEAR_EFFICIENCY = 0.9
TORQUE_CONSTANT_NM_PER_A = 0.0234
KFF_A_PER_N = SPOOL_RADIUS_M / (GEAR_RATIO * GEAR_EFFICIENCY * TORQUE_CONSTANT_NM_PER_A)

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


# Tuning scenario (issue 11): a chirp, so that the chosen parameters see reversals from slow to
# sharp; its own range (3 .. 13 N) and a small path near home. Held-out scenarios below differ in
# frequency, amplitude, wave shape or path; none of them is used by the tuning.
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


# --- configuration of a run -----------------------------------------------------------------


@dataclass
class ControllerParams:
    """The tension loop's gains and limits in SI units (the RTL holds them in fixed point).

    Kff from the bench (contract.md); Kp and Ki chosen for a loop that tracks T_c within a few
    milliseconds against the FMU's drive, motor and cable (tuned in co-simulation; see README).
    """

    kff_a_per_n: float = KFF_A_PER_N
    kp_a_per_n: float = 0.1
    # Kp and Ki chosen by `bowden tune` on the tune scenario only (board chain, ADS131M02): Kp
    # margin x3.05 before a limit cycle (hold probe, cosim/tune); the register map's reset values.
    ki_a_per_n_s: float = 2.5
    i_limit_a: float = 4.0  # ESCON 36/2 peak current (RTL reset value of I_LIMIT)
    slew_n_per_sample: float = 0.0  # 0 = slew limit off


@dataclass
class CompensatorParams:
    """The friction compensator's configuration (firmware): mu, phi, smooth band."""

    mu: float = MU_PAPER
    # None: phi of the sheath at the scenario's start position (calibrated once, as in the
    # paper, where the compensator uses the friction identified in the characterisation).
    phi_rad: float | None = None
    # H as the firmware default (4 LSB of Q7.8); B chosen by `bowden tune` (the firmware default).
    band_n: float = 0.5  # smooth inverse: tension band over which T_c changes branch
    hysteresis_n: float = 4.0 / 256.0  # direction detector's dead band on T_ref
    offset_n: float = 0.0  # output sensor offset the compensator aims around (audit extension)
    mu_slope_per_n: float = 0.0  # friction rising with tension (audit extension)
    tc_min_n: float = 0.0  # floor of T_c, firmware and RTL (TC_MIN): a cable cannot push
    # Preview mode (comp.h): T_ref handed preview_ticks firmware ticks ahead; the gain applies to
    # T_ref lead_ticks ahead; a change of branch takes ramp_ticks. Chosen by `bowden tune` on
    # the tune scenario (hdl/README.md).
    preview_ticks: int = 60
    lead_ticks: int = 0
    ramp_ticks: int = 120


# Rates in whole Hz: the firmware takes them as unsigned integers (fw.h), and its checks bound them
# (fw.c: sample rate 1 .. 1e6 Hz, tick rate 1 .. 65535 Hz).
RATE_RANGES_HZ = {"sample_rate_hz": (1, 1_000_000), "firmware_rate_hz": (1, 65_535)}

# FMU parameters a params file may not set, and why: the command line, the scenario or the closed
# loop own them, and result.json and the trace's sidecar report them from there.
PLANT_OWNED = {
    "loop_routing": "is set on the command line (--no-loop-routing) and reported in result.json",
    "drive_mode": "is fixed by the closed loop, which drives the motor by its current command "
    "(drive_mode 0)",
}


def field_ranges(sample_rate_hz: float) -> dict[str, tuple[float, float]]:
    """Allowed range of every controller, compensator and board field, by dotted name.

    Controller: the register words (hdl/regmap/bowden_regs.json): KFF and KP Q2.13, KI_TS
    +-1/32 A/N per sample (so Ki up to sample_rate_hz / 32 A/(N s)), I_LIMIT UQ3.12, SLEW UQ7.8.
    Compensator: the firmware's checks (firmware/include/comp.h)."""
    return {
        "controller.kff_a_per_n": (0.0, 3.9998),
        "controller.kp_a_per_n": (0.0, 3.9998),
        "controller.ki_a_per_n_s": (0.0, sample_rate_hz / 32.0),
        "controller.i_limit_a": (0.0, 7.9997),
        "controller.slew_n_per_sample": (0.0, 127.99),
        "compensator.mu": (0.0, 1.0),
        "compensator.phi_rad": (0.0, 4.0 * math.pi),
        "compensator.band_n": (1.0 / 256.0, 128.0),
        "compensator.hysteresis_n": (1.0 / 256.0, 32.0),
        "compensator.offset_n": (-64.0, 64.0),
        "compensator.mu_slope_per_n": (-1 / 128, 1 / 128),
        "compensator.tc_min_n": (0.0, 64.0),
        "compensator.preview_ticks": (0, 128),
        "compensator.lead_ticks": (0, 128),
        "compensator.ramp_ticks": (1, 256),
        # The board's chain (cosim.parts.interface): conversion timing, reader and PWM clocks,
        # ESCON.
        "board.adc_period_s": (1e-6, 0.1),
        "board.adc_phase_s": (0.0, 0.1),
        "board.sclk_half_clks": (1, 1024),
        "board.clk_hz": (1e5, 1e9),
        "board.pwm_hz": (10.0, 5000.0),
        "board.pwm_imax_q12": (1, 32767),
        "board.escon_imax_a": (0.01, 100.0),
        "board.escon_duty_resolution": (0.0, 0.1),
        "board.escon_duty_error": (-0.1, 0.1),
    }


# Fields that take null (the default: the scenario's phi, the ADC part's own period and reader
# clock) and fields
# that are whole numbers (clock counts, register words).
NULLABLE_FIELDS = {"compensator.phi_rad", "board.adc_period_s", "board.sclk_half_clks"}
WHOLE_FIELDS = {
    "board.sclk_half_clks",
    "board.pwm_imax_q12",
    "compensator.preview_ticks",
    "compensator.lead_ticks",
    "compensator.ramp_ticks",
}


@dataclass
class BoardParams:
    """The board's sensing and actuation chain (cosim.parts.interface, `--interface board|adc`): the
    load-cell ADC and the ESCON's PWM set value, with their datasheet defaults."""

    # A part of cosim.parts.interface.ADC_PARTS: the board's ADS131M02 (hdl/README.md, "Sensing"),
    # or the first boards' ADS1220.
    adc: str = "ads131m02"
    adc_period_s: float | None = None  # None: the part's conversion period
    adc_phase_s: float = 0.0  # first conversion window starts at t = phase
    # Reader SCLK half period in board clocks; None: the part's reader default
    # (cosim.parts.interface.AdcPart.sclk_half_clks: ADS1220 8 = 3 MHz, ADS131M02 4 = 6 MHz at 48
    # MHz).
    sclk_half_clks: float | None = None
    clk_hz: float = 48e6  # board clock (iCE40 UP5K top): PWM resolution, reader timing
    pwm_hz: float = 5000.0  # ESCON PWM set value frequency (bowden_core PWM_HZ)
    pwm_imax_q12: float = 16384  # current at 90 % duty, Q3.12 (bowden_core PWM_IMAX_Q12)
    escon_imax_a: float = 4.0  # ESCON set value range: 10 % = -I, 90 % = +I
    escon_duty_resolution: float = 0.001  # the ESCON's duty measurement step (0: continuous)
    escon_duty_error: float = 0.0  # constant duty error of the ESCON's measurement (0..1)


@dataclass
class SimConfig:
    """Everything a run needs besides the scenario: rates, plant, controller, compensator."""

    sample_rate_hz: float = 10_000.0  # FPGA tension loop (issue 4 default)
    firmware_rate_hz: float = 1_000.0  # processor's compensator tick (issue 5 default)
    plant: dict[str, float] = field(default_factory=dict)  # FMU parameter overrides by name
    controller: ControllerParams = field(default_factory=ControllerParams)
    compensator: CompensatorParams = field(default_factory=CompensatorParams)
    board: BoardParams = field(default_factory=BoardParams)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict, source: str = "params") -> SimConfig:
        """Build a configuration from a (partial) dict; unknown keys and bad values are errors
        (ValueError: one line naming `source`, the key and its allowed range)."""
        if not isinstance(data, dict):
            raise ValueError(f"{source}: expected a JSON object at the top level")
        cfg = cls()
        known = [f.name for f in fields(cls)]
        for key in data:
            if key not in known:
                raise ValueError(f"{source}: unknown key {key!r} (allowed: {', '.join(known)})")
        for key, (lo, hi) in RATE_RANGES_HZ.items():
            if key in data:
                value = _number(data[key], f"{source}: {key}", lo, hi, whole=True)
                setattr(cfg, key, float(value))
        if "plant" in data:
            cfg.plant = plant_overrides(data["plant"], f"{source}: plant")
        ranges = field_ranges(cfg.sample_rate_hz)
        cfg.controller = _sub(
            ControllerParams, data.get("controller", {}), source, "controller", ranges
        )
        cfg.compensator = _sub(
            CompensatorParams, data.get("compensator", {}), source, "compensator", ranges
        )
        cfg.board = _sub(BoardParams, data.get("board", {}), source, "board", ranges)
        cfg.validate(source)
        return cfg

    def validate(self, source: str = "params") -> None:
        """Raise ValueError naming the first variable that is out of its allowed range."""
        for key, (lo, hi) in RATE_RANGES_HZ.items():
            _number(getattr(self, key), f"{source}: {key}", lo, hi, whole=True)
        ratio = self.sample_rate_hz / self.firmware_rate_hz
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(
                f"{source}: sample_rate_hz / firmware_rate_hz must be a whole number >= 1; got "
                f"{self.sample_rate_hz:g} / {self.firmware_rate_hz:g}"
            )
        for name, (lo, hi) in field_ranges(self.sample_rate_hz).items():
            group, key = name.split(".")
            value = getattr(getattr(self, group), key)
            if name in NULLABLE_FIELDS and value is None:
                continue
            _number(value, f"{source}: {name}", lo, hi, whole=name in WHOLE_FIELDS)
        c = self.compensator
        if c.lead_ticks > c.preview_ticks:
            raise ValueError(
                f"{source}: compensator.lead_ticks must be in [0, compensator.preview_ticks = "
                f"{c.preview_ticks:g}]; got {c.lead_ticks!r}"
            )
        b = self.board
        if not isinstance(b.adc, str) or b.adc not in ADC_PARTS:
            raise ValueError(
                f"{source}: board.adc must be one of {', '.join(ADC_PARTS)}; got {b.adc!r}"
            )
        ratio = self.sample_rate_hz / b.pwm_hz
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(
                f"{source}: board.pwm_hz must divide sample_rate_hz ({self.sample_rate_hz:g}); "
                f"got {b.pwm_hz:g}"
            )

    @property
    def decimation(self) -> int:
        """FPGA samples per firmware tick."""
        return int(round(self.sample_rate_hz / self.firmware_rate_hz))


def _show(value, limit: int = 60) -> str:
    """A value from a params file as it was written there (JSON), on one line, shortened."""
    try:
        text = json.dumps(value)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _number(value, name: str, lo: float, hi: float, whole: bool = False) -> float:
    kind = "a whole number" if whole else "a number"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name} must be {kind} in [{lo:g}, {hi:g}]; got {_show(value)}")
    v = float(value)
    if not math.isfinite(v) or v < lo or v > hi:
        raise ValueError(f"{name} must be in [{lo:g}, {hi:g}]; got {_show(value)}")
    if whole and v != math.floor(v):
        raise ValueError(f"{name} must be {kind} in [{lo:g}, {hi:g}]; got {_show(value)}")
    return v


def plant_overrides(plant, source: str) -> dict[str, float | int]:
    """FMU parameter overrides checked against the FMU's own modelDescription.xml: parameters
    only, not those the command line or the closed loop own (PLANT_OWNED), each of its type and
    within its range; Integer parameters take whole numbers only (nothing is truncated)."""
    from cosim.parts.plant import fmu_variables  # noqa: PLC0415 (reads the built FMU)

    if not isinstance(plant, dict):
        raise ValueError(f"{source} must be an object of FMU parameter values by name")
    variables = fmu_variables()
    settable = [
        v.name
        for v in variables.values()
        if v.causality == "parameter" and v.name not in PLANT_OWNED
    ]
    out: dict[str, float | int] = {}
    for key, value in plant.items():
        var = variables.get(key)
        if key in PLANT_OWNED:
            raise ValueError(f"{source}.{key} {PLANT_OWNED[key]}; a params file cannot set it")
        if var is None or var.causality != "parameter":
            what = (
                f"is an FMU {var.causality} (the scenario and the loop drive it)"
                if var is not None
                else "is not a parameter of the FMU"
            )
            raise ValueError(f"{source}: {key!r} {what}; parameters: {', '.join(settable)}")
        if var.type == "Boolean":
            if not isinstance(value, bool):
                raise ValueError(f"{source}.{key} must be true or false; got {_show(value)}")
            out[key] = value
            continue
        lo = var.lo if var.lo is not None else -math.inf
        hi = var.hi if var.hi is not None else math.inf
        v = _number(value, f"{source}.{key}", lo, hi, whole=var.type == "Integer")
        out[key] = int(v) if var.type == "Integer" else v
    return out


def _sub(cls, data, source: str, group: str, ranges: dict[str, tuple[float, float]]):
    if not isinstance(data, dict):
        raise ValueError(f"{source}: {group} must be a JSON object")
    obj = cls()
    known = {f.name: f for f in fields(cls)}
    for key, value in data.items():
        if key not in known:
            raise ValueError(
                f"{source}: {group}: unknown key {key!r} (allowed: {', '.join(known)})"
            )
        name = f"{group}.{key}"
        if value is None and name in NULLABLE_FIELDS:
            obj = replace(obj, **{key: None})
            continue
        if name == "board.adc":
            if not isinstance(value, str):
                raise ValueError(
                    f"{source}: board.adc must be the name of an ADC ({', '.join(ADC_PARTS)}); "
                    f"got {_show(value)}"
                )
            obj = replace(obj, adc=value)
            continue
        lo, hi = ranges[name]
        number = _number(value, f"{source}: {name}", lo, hi, whole=name in WHOLE_FIELDS)
        obj = replace(obj, **{key: int(number) if name in WHOLE_FIELDS else number})
    return obj


def load_params(path: str | Path | None) -> SimConfig:
    """The default configuration, overridden by the JSON file `path` when given; ValueError (one
    line naming the file and what is wrong) for a file that cannot be used."""
    if path is None:
        return SimConfig()
    p = Path(path)
    name = shown(p)
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise ValueError(f"--params: file {name} does not exist") from None
    except OSError as exc:
        raise ValueError(f"--params: cannot read {name} ({exc.strerror or exc})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"--params: {name} is not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset "
            f"{exc.start}); expected a JSON object"
        ) from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"--params: {name} is not valid JSON ({exc})") from None
    except RecursionError:
        raise ValueError(f"--params: {name} is nested too deeply to be a params file") from None
    return SimConfig.from_dict(data, source=name)


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
