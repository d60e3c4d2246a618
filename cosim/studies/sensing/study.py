"""The sensing study: tracking error and Kp margin of the closed loop per load-cell front-end.

Every option runs the float reference (cosim.engines.reference: the compensator's double twin, the
RTL loop's double model, the plant FMU) with the board's PWM -> ESCON stage
(cosim.parts.interface.PwmEscon, the same for all) and one way of sensing T_in:

- ``ideal``: a fresh T_in_meas(t_k+1) at every 10 kHz tick, no delay (the bound: what no ADC
  gives);
- ``ads1220``: the board's ADS1220 (2 kSPS, single-cycle filter, cosim.parts.interface.ADC_PARTS),
  the loop at 10 kHz holding the latest result for about five ticks;
- ``ads1220-drdy``: the same ADC with the loop stepped only on a new result (the loop run on the
  ADC's data-ready, about 1976 Hz): its Ki*Ts is scaled to the conversion period so that Ki in
  A/(N s) stays the same, the command is held between results. Named assumption: the RTL would
  compute on the result's arrival; here the step falls on the next 10 kHz tick (<= 0.1 ms later,
  as in the other options);
- ``ads131m02``: an ADS131M02 (32 kSPS, sinc3, 2 channels) in place of the ADS1220, the loop at
  10 kHz: a result of at most a few tens of microseconds at every tick.

Figures per option (loop routing on, the gains chosen before this study: STUDY_CONFIG):

- tracking error T_ref - T_out (paper Sec. VI-C, cosim.results.metrics.tracking_error) for the
  compensators ``paper`` and ``smooth`` on fig14 and on two scenarios with other references
  (SCENARIOS), and its RMS within REVERSAL_WINDOW_S after the reversals (cosim.results.metrics.
  reversal_split), where the paper puts its peak error;
- the sample age: mean time from the centre of the filter's kernel (half its window: the group
  delay of a linear-phase filter) to the tick that uses the result (`sample_age_s`);
- the Kp margin: the largest factor on Kp (Ki fixed) before the loop no longer settles after a
  step of T_ref at a fixed end-effector (`kp_margin`).

Nothing here is tuned: the gains, the smooth band and the scenarios were the project's defaults
(`bowden tune` on the ADS1220 chain) or fixed below before the figures were seen. The defaults
were re-tuned on the ADS131M02 after this study chose it (Kp 0.1 A/N); the study keeps the gains
it was decided with, so that no option is compared with gains tuned for another.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, replace

import numpy as np

from cosim.config.run import SimConfig
from cosim.config.scenarios import HOME_M, Scenario, get_scenario
from cosim.engines.reference import make_float_loop, resolve_phi, run_reference
from cosim.parts.interface import ADC_PARTS, AdcModel, Chain, make_chain
from cosim.project.cliargs import ArgumentParser, finite_float
from cosim.results import metrics

# Sensing options, in the order of the table.
OPTIONS = {
    "ideal": "ideal ADC: fresh T_in at every 10 kHz tick",
    "ads1220": "ADS1220 2 kSPS, loop at 10 kHz",
    "ads1220-drdy": "ADS1220 2 kSPS, loop on its DRDY",
    "ads131m02": "ADS131M02 32 kSPS sinc3, loop at 10 kHz",
}
COMPENSATORS = ("paper", "smooth")

# Kp margin probe: T_ref eases in to PROBE_LOW_N, steps to PROBE_HIGH_N at PROBE_STEP_S with the
# end-effector held at HOME_M. Above some Kp the loop no longer settles: it keeps a limit cycle
# whose amplitude grows with Kp (bounded by the PWM's and the plant's non-linearities, so it
# does not run away). Below it, T_in keeps only the dither of the PWM's 0.1 % duty step
# (10 mA): at most 0.11 N peak-to-peak for every option at the default Kp. A limit cycle is
# counted when T_in's peak-to-peak over the last PROBE_WINDOW_S is PROBE_PP_N (1 % of fig14's
# 15 N) or more: the cycles seen at onset are 0.18 .. 0.37 N, and they hold at 3 s (measured
# at the factors 2 .. 11 when this study was written).
PROBE_LOW_N = 6.0
PROBE_HIGH_N = 8.0
PROBE_STEP_S = 0.5
PROBE_DURATION_S = 2.0
PROBE_WINDOW_S = 0.5
PROBE_PP_N = 0.15
# Factors searched: [1, MARGIN_MAX] by bisection in log2 to MARGIN_STEPS halvings. The register
# KP is Q2.13 (< 4 A/N): 64 x the default 0.05 A/N is already beyond what the RTL can hold.
MARGIN_MAX = 64.0
MARGIN_STEPS = 7


def _sine(name: str, low_n: float, high_n: float, freq_hz: float, duration_s: float) -> Scenario:
    """fig14's 3-D path with another sinusoidal reference low .. high at freq (eased in)."""
    fig14 = get_scenario("fig14")
    mid, amp = 0.5 * (high_n + low_n), 0.5 * (high_n - low_n)

    def t_ref(t: np.ndarray) -> np.ndarray:
        ease = np.clip(t / 0.5, 0.0, 1.0)
        return (mid - amp * np.cos(2.0 * np.pi * freq_hz * t)) * (0.5 - 0.5 * np.cos(np.pi * ease))

    return replace(
        fig14,
        name=name,
        duration_s=duration_s,
        description=f"sine {low_n:g} .. {high_n:g} N at {freq_hz:g} Hz, fig14's 3-D path",
        t_ref=t_ref,
    )


def _triangle(name: str, low_n: float, high_n: float, period_s: float, duration_s: float):
    """fig14's 3-D path with a triangle reference low .. high (eased in from zero)."""
    fig14 = get_scenario("fig14")

    def t_ref(t: np.ndarray) -> np.ndarray:
        phase = np.mod(t, period_s) / period_s
        tri = low_n + (high_n - low_n) * (1.0 - np.abs(2.0 * phase - 1.0))
        ease = np.clip(t / 0.5, 0.0, 1.0)
        return tri * (0.5 - 0.5 * np.cos(np.pi * ease))

    return replace(
        fig14,
        name=name,
        duration_s=duration_s,
        description=f"triangle {low_n:g} .. {high_n:g} N, period {period_s:g} s, fig14's path",
        t_ref=t_ref,
    )


def _scenarios() -> dict[str, Scenario]:
    # Fixed before any figure of this study was seen: a faster, larger sine and a triangle.
    return {
        "fig14": get_scenario("fig14"),
        "sine1hz": _sine("sine1hz", 3.0, 20.0, 1.0, 15.0),
        "triangle": _triangle("triangle", 2.0, 12.0, 4.0, 16.0),
    }


SCENARIOS = tuple(_scenarios())


class _FreshFlag:
    """The float interface stage `inner`, noting whether tick k+1 gets a new ADC result."""

    def __init__(self, inner: Chain) -> None:
        self.inner = inner
        self.fresh = True  # the start-up sample

    def start(self, t_in_n: float):
        self.fresh = True
        return self.inner.start(t_in_n)

    def drive(self, k: int, u):
        return self.inner.drive(k, u)

    def sense(self, k: int, t_in_n: float):
        v = self.inner.sense(k, t_in_n)
        self.fresh = v is not None
        return v


class _DrdyLoop:
    """The float loop stepped only on a tick that has a new ADC result; the command is held
    between results (the loop run at the ADC's data rate)."""

    def __init__(self, loop, flag: _FreshFlag) -> None:
        self.loop = loop
        self.flag = flag
        self.u_a = 0.0

    def step(self, tc_n: float, t_in_n: float) -> float:
        if self.flag.fresh:
            self.u_a = self.loop.step(tc_n, t_in_n)
        return self.u_a


def _adc_cfg(cfg: SimConfig, part: str) -> SimConfig:
    return replace(cfg, board=replace(cfg.board, adc=part))


def make_option(name: str, cfg: SimConfig, kp_factor: float = 1.0):
    """(chain, loop) of the float reference for sensing option `name` (one of OPTIONS), with the
    board's PWM -> ESCON and Kp multiplied by kp_factor."""
    if name not in OPTIONS:
        raise ValueError(f"sensing option must be one of {', '.join(OPTIONS)}; got {name!r}")
    part = "ads131m02" if name == "ads131m02" else "ads1220"
    board = make_chain(_adc_cfg(cfg, part), "board", fixed=False)
    loop = make_float_loop(cfg)
    loop = replace(loop, kp_a_per_n=loop.kp_a_per_n * kp_factor)
    if name == "ideal":
        chain = Chain("ideal+pwm", None, board.pwm, False, 0, 0, board.dt)
        return chain, loop
    if name == "ads1220-drdy":
        # Ki*Ts per step of the loop: Ts is the conversion period, not the 10 kHz tick.
        period_s = board.adc.period
        loop = replace(loop, ki_ts_a_per_n=loop.ki_ts_a_per_n * period_s * cfg.sample_rate_hz)
        flag = _FreshFlag(board)
        return flag, _DrdyLoop(loop, flag)
    return board, loop


def sample_age_s(name: str, cfg: SimConfig, duration_s: float = 0.1) -> float:
    """Mean age of the T_in sample a loop step uses: from the centre of the conversion's kernel
    (filter order x period / 2 before DRDY) to the tick that uses it, over `duration_s` of ticks
    (every tick for a 10 kHz loop, the ticks with a new result for ``ads1220-drdy``; 0 for the
    ideal ADC)."""
    if name not in OPTIONS:
        raise ValueError(f"sensing option must be one of {', '.join(OPTIONS)}; got {name!r}")
    if name == "ideal":
        return 0.0
    b = cfg.board
    part = ADC_PARTS["ads131m02" if name == "ads131m02" else "ads1220"]
    half = part.sclk_half_clks if b.sclk_half_clks is None else int(b.sclk_half_clks)
    adc = AdcModel(part, cfg.sample_rate_hz, b.clk_hz, half, b.adc_phase_s)
    adc.record(0.0)
    ages = []
    centre_s = None
    for k in range(int(round(duration_s * cfg.sample_rate_hz))):
        adc.record(0.0)
        fresh = adc.deliver(k) is not None
        if fresh:
            d = adc.phase + (adc.last + 1) * adc.period
            centre_s = d - 0.5 * part.filter_order * adc.period
        if centre_s is not None and (fresh or name != "ads1220-drdy"):
            ages.append((k + 1) / cfg.sample_rate_hz - centre_s)
    return float(np.mean(ages))


def _probe() -> Scenario:
    def t_ref(t: np.ndarray) -> np.ndarray:
        ease = np.clip(t / 0.3, 0.0, 1.0)
        low = PROBE_LOW_N * (0.5 - 0.5 * np.cos(np.pi * ease))
        return np.where(t >= PROBE_STEP_S, PROBE_HIGH_N, low)

    def trajectory(t: np.ndarray):
        return tuple(np.full_like(t, c) for c in HOME_M)

    return Scenario(
        name="kp-probe",
        duration_s=PROBE_DURATION_S,
        description=f"T_ref step {PROBE_LOW_N:g} -> {PROBE_HIGH_N:g} N, end-effector held",
        t_ref=t_ref,
        trajectory=trajectory,
    )


def settles(name: str, cfg: SimConfig, kp_factor: float, phi_rad: float | None = None) -> bool:
    """True when the loop of option `name` with Kp x kp_factor settles after the probe's step:
    T_in's peak-to-peak over the last PROBE_WINDOW_S is below PROBE_PP_N."""
    scen = _probe()
    phi = resolve_phi(scen, cfg, True) if phi_rad is None else phi_rad
    chain, loop = make_option(name, cfg, kp_factor)
    rec = run_reference(scen, cfg, "none", True, phi, progress=False, chain=chain, loop=loop)
    t = rec["t_s"]
    t_in = rec["T_in_N"][t >= t[-1] - PROBE_WINDOW_S]
    pp = float(np.max(t_in) - np.min(t_in))
    return math.isfinite(pp) and pp < PROBE_PP_N


def kp_margin(name: str, cfg: SimConfig) -> float:
    """The largest factor on Kp (in [1, MARGIN_MAX], to 2^(log2(MARGIN_MAX) / 2^MARGIN_STEPS))
    at which option `name`'s loop still settles; 0 if it does not at the default Kp, MARGIN_MAX
    if it still does there."""
    phi = resolve_phi(_probe(), cfg, True)
    if not settles(name, cfg, 1.0, phi):
        return 0.0
    if settles(name, cfg, MARGIN_MAX, phi):
        return MARGIN_MAX
    lo, hi = 0.0, math.log2(MARGIN_MAX)  # settles at 2^lo, not at 2^hi
    for _ in range(MARGIN_STEPS):
        mid = 0.5 * (lo + hi)
        if settles(name, cfg, 2.0**mid, phi):
            lo = mid
        else:
            hi = mid
    return 2.0**lo


@dataclass
class Row:
    """One option's figures on one scenario with one compensator."""

    option: str
    scenario: str
    compensator: str
    rms_pct: float
    peak_pct: float
    rms_near_reversal_n: float


def run_one(
    option: str,
    scenario: str,
    compensator: str,
    cfg: SimConfig,
    duration_s: float | None = None,
) -> Row:
    """Tracking error of option `option` on `scenario` (one of SCENARIOS) with `compensator`."""
    scens = _scenarios()
    if scenario not in scens:
        raise ValueError(f"scenario must be one of {', '.join(scens)}; got {scenario!r}")
    scen = scens[scenario]
    phi = resolve_phi(scen, cfg, True)
    chain, loop = make_option(option, cfg)
    rec = run_reference(
        scen, cfg, compensator, True, phi, duration_s, progress=False, chain=chain, loop=loop
    )
    err = metrics.tracking_error(rec["t_s"], rec["T_ref_N"], rec["T_out_N"], scen.settle_s)
    split = metrics.reversal_split(rec["t_s"], rec["T_ref_N"], rec["T_out_N"], scen.settle_s)
    return Row(
        option,
        scenario,
        compensator,
        err["rms_error_pct"],
        err["peak_error_pct"],
        split["rms_near_reversal_n"],
    )


# The gains of the decision (bowden tune on the ADS1220 chain, before this study).
STUDY_GAINS = {"kp_a_per_n": 0.05, "ki_a_per_n_s": 2.5}


def study_config() -> SimConfig:
    """The project's defaults with the gains the study was decided with (STUDY_GAINS)."""
    cfg = SimConfig()
    cfg.controller = replace(cfg.controller, **STUDY_GAINS)
    return cfg


def run_study(
    cfg: SimConfig | None = None,
    scenarios: tuple[str, ...] = SCENARIOS,
    duration_s: float | None = None,
    margins: bool = True,
    log=None,
) -> dict:
    """All options on `scenarios` with both compensators, plus sample age and Kp margin per
    option: {"rows": [Row...], "age_s": {option: s}, "kp_margin": {option: factor}}."""
    cfg = cfg or study_config()
    rows = []
    for scenario in scenarios:
        for option in OPTIONS:
            for comp in COMPENSATORS:
                if log:
                    log(f"{scenario}: {option}, {comp}")
                rows.append(run_one(option, scenario, comp, cfg, duration_s))
    ages = {o: sample_age_s(o, cfg) for o in OPTIONS}
    margin = {}
    if margins:
        for option in OPTIONS:
            if log:
                log(f"Kp margin: {option}")
            margin[option] = kp_margin(option, cfg)
    return {"rows": rows, "age_s": ages, "kp_margin": margin}


def table(result: dict) -> str:
    """The study as a Markdown table: one line per option and scenario."""
    lines = [
        "| scenario | sensing | paper RMS / peak % | smooth RMS / peak % "
        "| near-reversal RMS N (paper / smooth) |",
        "| --- | --- | --- | --- | --- |",
    ]
    by = {(r.scenario, r.option, r.compensator): r for r in result["rows"]}
    for scenario in dict.fromkeys(r.scenario for r in result["rows"]):
        for option in OPTIONS:
            p, s = by[(scenario, option, "paper")], by[(scenario, option, "smooth")]
            lines.append(
                f"| {scenario} | {option} | {p.rms_pct:.2f} / {p.peak_pct:.2f} "
                f"| {s.rms_pct:.2f} / {s.peak_pct:.2f} "
                f"| {p.rms_near_reversal_n:.3f} / {s.rms_near_reversal_n:.3f} |"
            )
    lines += ["", "| sensing | mean sample age ms | Kp margin (x Kp before no settling) |"]
    lines.append("| --- | --- | --- |")
    for option in OPTIONS:
        m = result["kp_margin"].get(option)
        if m is None:
            shown = "not run"
        elif m >= MARGIN_MAX:
            shown = f">= {MARGIN_MAX:g}"
        else:
            shown = f"{m:.1f}"
        lines.append(f"| {option} | {1e3 * result['age_s'][option]:.3f} | {shown} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(
        prog="python -m cosim.studies.sensing",
        description="The sensing study: tracking error and Kp margin per load-cell front-end "
        "(float reference, board PWM -> ESCON)",
    )
    p.add_argument(
        "--scenario",
        action="append",
        choices=SCENARIOS,
        help="scenario to run (repeatable; default: all)",
    )
    p.add_argument(
        "--duration", type=finite_float, default=None, help="simulated seconds per run (cap)"
    )
    p.add_argument("--no-margin", action="store_true", help="skip the Kp margin search")
    args = p.parse_args(argv)
    if args.duration is not None and not 2.0 <= args.duration <= 3600.0:
        p.error(f"argument --duration: must be in [2, 3600] s; got {args.duration:g}")
    try:
        result = run_study(
            scenarios=tuple(args.scenario or SCENARIOS),
            duration_s=args.duration,
            margins=not args.no_margin,
            log=lambda m: print(m, file=sys.stderr),
        )
    except (FileNotFoundError, RuntimeError, ValueError) as exc:
        print(f"python -m cosim.studies.sensing: {exc}", file=sys.stderr)
        return 1
    print(table(result))
    return 0


__all__ = ["OPTIONS", "SCENARIOS", "kp_margin", "make_option", "run_study", "sample_age_s"]
