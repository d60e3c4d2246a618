"""`bowden tune`: choose the loop gains, the smooth band and the preview parameters on the `tune`
scenario only, and state the stability margin ("honest tuning": chosen on one scenario, reported
on others).

Procedure (one command, deterministic; the lead re-runs it when the board's chain changes):

1. **Stability limit.** A hold probe (T_ref eased to HOLD_REF_N and held, end-effector at home,
   smooth compensator) through the chosen interface (default: the board's chain). The loop is in
   a limit cycle when the peak-to-peak of T_in over the last LIMIT_WINDOW_S exceeds
   LIMIT_CYCLE_PP_N (above the ESCON's duty quantization, which dithers T_in by about 0.09 N on
   a stable loop). Kp is swept up by KP_STEP from the smallest candidate until the first limit
   cycle: Kp_crit.
2. **Gains.** Kp from KP_CANDIDATES with Kp <= Kp_crit / MIN_KP_MARGIN, Ki from KI_CANDIDATES;
   each pair must hold without a limit cycle; the pair with the lowest sum of the SCOREs of the
   smooth inverse (band GAINS_BAND_N) and of the preview mode (at its starting point
   GAINS_PREVIEW) on `tune` wins: the FPGA has one set of gains, and it must serve both modes
   that give it a continuous T_c (a higher Ki helps preview's ramps but rings on the smooth
   inverse's faster change of branch).
3. **Smooth band** B from BAND_CANDIDATES (smooth on `tune`, lowest SCORE).
4. **Preview.** The ramp D from RAMP_CANDIDATES and the horizon P = D/2 + lag, lag from
   LAG_CANDIDATES (the change of branch centred lag ticks before the reversal; negative: after
   it), then the lead L from LEAD_CANDIDATES (preview on `tune`, lowest SCORE).
5. **Margin.** Kp swept up from the chosen one (KP_STEP) with the chosen Ki until a limit cycle:
   the Kp margin is the last stable factor (at least MIN_KP_MARGIN, else the run fails).
6. **Confirmation.** The chosen point is run once on `tune` through the fixed-point chain (the
   firmware's host build and the RTL's bit-exact model, cosim.engines.reference.run_model_chain),
   which the RTL co-simulation equals at every sample (tests/cosim).

SCORE = RMS % + PEAK_WEIGHT * peak % (stage 2: the sums over the two modes) of the error
T_ref - T_out over t >= settle (in % of the maximum reference), from the float reference
(cosim.engines.reference: the double loop and compensator twin with the same interface timing) for
speed. fig14 and the held-out scenarios
(cosim.config.scenarios.HELD_OUT_SCENARIOS) are never run here.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from cosim.config.run import SimConfig
from cosim.config.scenarios import HOME_M, TUNE_SCENARIO, Scenario, _ease, get_scenario

# The rule, written once.
PEAK_WEIGHT = 0.25
MIN_KP_MARGIN = 3.0  # gain margin on Kp (about 9.5 dB)
LIMIT_CYCLE_PP_N = 0.25
LIMIT_WINDOW_S = 1.0
HOLD_REF_N = 8.0
HOLD_DURATION_S = 4.0
KP_STEP = 1.25
KP_SWEEP_MAX = 3.9  # the KP register's range (Q2.13)
KP_CANDIDATES = (0.025, 0.05, 0.1)
KI_CANDIDATES = (2.5, 5.0, 10.0)
BAND_CANDIDATES = (0.5, 1.0, 2.0, 4.0)
RAMP_CANDIDATES = (40, 80, 120, 200)
LAG_CANDIDATES = (-20, 0, 10)
# Preview point at which the gains are compared (stage 2): a change of branch over 160 ticks
# centred on the reversal.
GAINS_PREVIEW = {"preview_ticks": 60, "lead_ticks": 0, "ramp_ticks": 120}
GAINS_BAND_N = 1.0
LEAD_CANDIDATES = (0, 4, 8)


def hold_scenario() -> Scenario:
    """The stability probe: T_ref eased to HOLD_REF_N and held, end-effector at home."""
    return Scenario(
        name="hold",
        duration_s=HOLD_DURATION_S,
        description=f"T_ref eased to {HOLD_REF_N:g} N and held (stability probe of bowden tune)",
        t_ref=lambda t: HOLD_REF_N * _ease(t),
        trajectory=lambda t: tuple(c * np.ones_like(t) for c in HOME_M),
        settle_s=HOLD_DURATION_S - LIMIT_WINDOW_S,
    )


def with_params(cfg: SimConfig, **changes) -> SimConfig:
    """A copy of cfg with controller.* / compensator.* fields changed (`kp_a_per_n=...`)."""
    ctrl = {k: v for k, v in changes.items() if hasattr(cfg.controller, k)}
    comp = {k: v for k, v in changes.items() if hasattr(cfg.compensator, k)}
    unknown = set(changes) - set(ctrl) - set(comp)
    if unknown:
        raise ValueError(f"unknown parameters {sorted(unknown)}")
    out = dataclasses.replace(
        cfg,
        controller=dataclasses.replace(cfg.controller, **ctrl),
        compensator=dataclasses.replace(cfg.compensator, **comp),
    )
    out.validate("tune")
    return out


def limit_cycle_pp_n(cfg: SimConfig, interface: str) -> float:
    """Peak-to-peak of T_in (N) over the last LIMIT_WINDOW_S of the hold probe."""
    from cosim.engines.reference import run_reference  # noqa: PLC0415

    scen = hold_scenario()
    rec = run_reference(
        scen, cfg, "smooth", True, 2.0 * math.pi, progress=False, interface=interface
    )
    n = int(round(LIMIT_WINDOW_S * cfg.sample_rate_hz))
    t_in = rec["T_in_N"][-n:]
    return float(np.max(t_in) - np.min(t_in))


def stable(cfg: SimConfig, interface: str) -> bool:
    """No limit cycle in the hold probe (peak-to-peak of T_in <= LIMIT_CYCLE_PP_N)."""
    return limit_cycle_pp_n(cfg, interface) <= LIMIT_CYCLE_PP_N


def kp_limit(cfg: SimConfig, interface: str, kp_start: float) -> tuple[float, float]:
    """(last stable Kp, first Kp in a limit cycle) sweeping up from kp_start by KP_STEP with the
    other gains of cfg; the first is 0 when kp_start itself cycles, the second inf when none up to
    the register's range does."""
    last, kp = 0.0, kp_start
    while kp <= KP_SWEEP_MAX:
        if not stable(with_params(cfg, kp_a_per_n=kp), interface):
            return last, kp
        last, kp = kp, kp * KP_STEP
    return last, math.inf


def score(cfg: SimConfig, compensator: str, interface: str, scenario: str = TUNE_SCENARIO):
    """(SCORE, RMS %, peak %) of `compensator` on `scenario`, float reference."""
    from cosim.engines.reference import resolve_phi, run_reference  # noqa: PLC0415
    from cosim.results import metrics  # noqa: PLC0415

    scen = get_scenario(scenario)
    phi = resolve_phi(scen, cfg, True)
    rec = run_reference(scen, cfg, compensator, True, phi, progress=False, interface=interface)
    e = metrics.tracking_error(rec["t_s"], rec["T_ref_N"], rec["T_out_N"], scen.settle_s)
    rms, peak = e["rms_error_pct"], e["peak_error_pct"]
    return rms + PEAK_WEIGHT * peak, rms, peak


@dataclass
class TuneResult:
    """What `bowden tune` chose, the margin, and every point it tried (for the table)."""

    interface: str
    kp_a_per_n: float
    ki_a_per_n_s: float
    band_n: float
    preview_ticks: int
    lead_ticks: int
    ramp_ticks: int
    kp_critical_a_per_n: float  # first Kp in a limit cycle with the chosen Ki
    kp_margin: float  # last stable Kp / chosen Kp
    tried: list[dict] = field(default_factory=list)
    confirm: dict | None = None  # the fixed-point chain at the chosen point

    def params(self) -> dict:
        """The chosen point as a params file (`bowden sim --params`)."""
        return {
            "controller": {"kp_a_per_n": self.kp_a_per_n, "ki_a_per_n_s": self.ki_a_per_n_s},
            "compensator": {
                "band_n": self.band_n,
                "preview_ticks": self.preview_ticks,
                "lead_ticks": self.lead_ticks,
                "ramp_ticks": self.ramp_ticks,
            },
        }

    def summary(self) -> str:
        lines = [
            f"bowden tune: scenario {TUNE_SCENARIO} only, interface {self.interface}, float "
            f"reference; SCORE = RMS % + {PEAK_WEIGHT:g} x peak %",
            "",
            "| stage | point | RMS % | peak % | SCORE | stable |",
            "| --- | --- | --- | --- | --- | --- |",
        ]
        for t in self.tried:
            rms = "" if t.get("rms") is None else f"{t['rms']:.2f}"
            peak = "" if t.get("peak") is None else f"{t['peak']:.2f}"
            sc = "" if t.get("score") is None else f"{t['score']:.2f}"
            st = "" if t.get("stable") is None else ("yes" if t["stable"] else "LIMIT CYCLE")
            lines.append(f"| {t['stage']} | {t['point']} | {rms} | {peak} | {sc} | {st} |")
        lines += [
            "",
            f"chosen: Kp {self.kp_a_per_n:g} A/N, Ki {self.ki_a_per_n_s:g} A/(N s), smooth band "
            f"{self.band_n:g} N, preview P {self.preview_ticks} ticks, lead L {self.lead_ticks} "
            f"ticks, ramp D {self.ramp_ticks} ticks",
            f"Kp margin: x{self.kp_margin:.2f} (limit cycle from Kp "
            f"{self.kp_critical_a_per_n:.3g} A/N; required >= x{MIN_KP_MARGIN:g})",
        ]
        if self.confirm:
            c = self.confirm
            lines.append(
                f"confirmed on {TUNE_SCENARIO}, fixed-point chain (firmware + RTL model): "
                f"preview RMS {c['rms']:.2f} %, peak {c['peak']:.2f} % (float: "
                f"{c['float_rms']:.2f} / {c['float_peak']:.2f} %)"
            )
        return "\n".join(lines)


def tune(
    interface: str = "board",
    cfg: SimConfig | None = None,
    confirm: bool = True,
    log: Callable[[str], None] = lambda _: None,
) -> TuneResult:
    """Run the procedure of the module docstring and return the result."""
    base = cfg or SimConfig()
    tried: list[dict] = []

    def note(stage: str, point: str, sc=None, st=None):
        entry = {"stage": stage, "point": point, "stable": st}
        if sc is not None:
            entry.update(score=sc[0], rms=sc[1], peak=sc[2])
        tried.append(entry)
        log(
            f"  {stage}: {point}"
            + (f"  RMS {sc[1]:.2f} % peak {sc[2]:.2f} % SCORE {sc[0]:.2f}" if sc else "")
            + ("" if st is None else ("  stable" if st else "  LIMIT CYCLE"))
        )

    # 1. Stability limit with the current Ki.
    log("1. Kp stability limit (hold probe)")
    _, kp_crit0 = kp_limit(base, interface, KP_CANDIDATES[0])
    note("Kp limit", f"limit cycle from Kp {kp_crit0:.3g} A/N", st=None)
    allowed = [kp for kp in KP_CANDIDATES if kp <= kp_crit0 / MIN_KP_MARGIN] or [KP_CANDIDATES[0]]

    # 2. Gains.
    log("2. gains (smooth + preview at their starting points, on tune)")
    best = None
    for kp in allowed:
        for ki in KI_CANDIDATES:
            c = with_params(base, kp_a_per_n=kp, ki_a_per_n_s=ki)
            ok = stable(c, interface)
            sc = None
            if ok:
                sm = score(with_params(c, band_n=GAINS_BAND_N), "smooth", interface)
                pv = score(with_params(c, **GAINS_PREVIEW), "preview", interface)
                sc = tuple(a + b for a, b in zip(sm, pv, strict=True))
            note("gains", f"Kp {kp:g}, Ki {ki:g}", sc, ok)
            if ok and (best is None or sc[0] < best[0]):
                best = (sc[0], kp, ki)
    if best is None:
        raise RuntimeError("no (Kp, Ki) candidate holds without a limit cycle")
    _, kp, ki = best
    gains = with_params(base, kp_a_per_n=kp, ki_a_per_n_s=ki)

    # 3. Smooth band.
    log("3. smooth band")
    best = None
    for band in BAND_CANDIDATES:
        sc = score(with_params(gains, band_n=band), "smooth", interface)
        note("band", f"B {band:g} N", sc)
        if best is None or sc[0] < best[0]:
            best = (sc[0], band)
    band = best[1]
    gains = with_params(gains, band_n=band)

    # 4. Preview: ramp and horizon, then lead.
    log("4. preview horizon and ramp, then lead")
    best = None
    for ramp in RAMP_CANDIDATES:
        for lag in LAG_CANDIDATES:
            p = max(0, min(128, ramp // 2 + lag))
            sc = score(
                with_params(gains, preview_ticks=p, lead_ticks=0, ramp_ticks=ramp),
                "preview",
                interface,
            )
            note("preview", f"D {ramp}, P {p}", sc)
            if best is None or sc[0] < best[0]:
                best = (sc[0], p, ramp)
    _, p, ramp = best
    best = None
    for lead in LEAD_CANDIDATES:
        c = with_params(gains, preview_ticks=p, lead_ticks=min(lead, p), ramp_ticks=ramp)
        sc = score(c, "preview", interface)
        note("lead", f"L {min(lead, p)}", sc)
        if best is None or sc[0] < best[0]:
            best = (sc[0], min(lead, p), sc)
    _, lead, sc_chosen = best
    chosen = with_params(gains, preview_ticks=p, lead_ticks=lead, ramp_ticks=ramp)

    # 5. Margin with the chosen gains.
    log("5. Kp margin of the chosen gains")
    last, first_bad = kp_limit(chosen, interface, kp)
    margin = last / kp if kp > 0 else 0.0
    note(
        "margin",
        f"stable to Kp {last:.3g}, limit cycle at {first_bad:.3g}",
        st=margin >= MIN_KP_MARGIN,
    )
    if margin < MIN_KP_MARGIN:
        raise RuntimeError(
            f"Kp margin x{margin:.2f} of the chosen gains is below x{MIN_KP_MARGIN:g}"
        )

    result = TuneResult(
        interface=interface,
        kp_a_per_n=kp,
        ki_a_per_n_s=ki,
        band_n=band,
        preview_ticks=p,
        lead_ticks=lead,
        ramp_ticks=ramp,
        kp_critical_a_per_n=first_bad,
        kp_margin=margin,
        tried=tried,
    )
    if confirm:
        log("6. confirmation in the fixed-point chain")
        result.confirm = confirm_fixed(chosen, interface, sc_chosen)
    return result


def confirm_fixed(cfg: SimConfig, interface: str, float_score) -> dict:
    """The chosen point on `tune` through the fixed-point chain (firmware + RTL model)."""
    from cosim.engines.reference import resolve_phi, run_model_chain  # noqa: PLC0415
    from cosim.results import metrics  # noqa: PLC0415

    scen = get_scenario(TUNE_SCENARIO)
    phi = resolve_phi(scen, cfg, True)
    rec = run_model_chain(scen, cfg, "preview", True, phi, interface=interface)
    e = metrics.tracking_error(rec["t_s"], rec["T_ref_N"], rec["T_out_N"], scen.settle_s)
    return {
        "rms": e["rms_error_pct"],
        "peak": e["peak_error_pct"],
        "float_rms": float_score[1],
        "float_peak": float_score[2],
    }
