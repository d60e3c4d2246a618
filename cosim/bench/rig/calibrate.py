"""`bowden bench calibrate`: identify the plant at the bench, audit it, and (with `--apply`) take
what the audit found to the device's compensator and check it on the device's own T_out.

The steps (cosim/bench/README.md, "Calibration", says why each piece is there):

0. **Tare.** T_ref 0 for TARE_S with the cable at rest: the far-end load cell's reading at zero
   load is its own offset, which is taken off T_out before the audit, so that what the audit
   finds as an offset (comp.offset_n) is one of the tension, not the sensor's error.
1. **Identification.** A streamed T_ref (`identification_sequence`): holds, full-range ramps at
   three rates in both directions and small reversals at three tension levels, recorded with
   T_out (the far-end load cell) by the ordinary run path (cosim.bench.link.recorder).
2. **Audit.** `bowden audit` on the recording (cosim.audit.core): mu (the product mu*phi: the
   bench does not measure the position), the dead zone, and the effects of its vocabulary.
3. **Proposal** (`propose`). For each compensator parameter the audit can set (comp.mu,
   comp.offset_n, comp.mu_slope_per_n, comp.dead_zone_spread: cosim.audit.params) the device's value
   is put into the audit's extended model in place of the fitted one; the change is proposed only
   when the fitted value beats the device's by the audit's own decision rule (cosim.audit.decision:
   on the selection blocks, the same thresholds as a finding; a mu the rule refuses is fitted
   again with the effects the audit saw but did not name and judged in that model: joint_mu,
   and proposed with the friction slope that fit took (JOINT_WITH_MU; also for a mu the rule
   passes when the audit saw such a slope: JOINT_WHEN_SEEN);
   the dead zone's spread, a parameter of
   the audit's nominal model, without that rule: UNGATED; the breakaway, comp.breakaway, from the
   audit's static friction finding, which passed that rule as a finding; the slack,
   comp.slack_tension_n, from the slack the audit saw: SLACK_SOURCES; the friction with the
   cable's speed, comp.mu_per_inlet_rate, from the viscous friction it saw: VISCOUS_SOURCES),
   and only when the
   compensator takes it
   (the firmware's configuration check through cosim.parts.firmware). A value the compensator does
   not take is clipped to the nearest one it takes on the way from the device's value (status
   "clipped", the limit named), and a set that does not hold together keeps the most of it that
   does: one value never blocks the others. Loop gains are never among them.
3b. **The bending angle's map** (with Options.map_positions: bend_map, `--map`): the
   identification's first pieces at home and at further positions, the ratio of the bending
   angle at each to home's, and the plane through them (bend_map.json, the host's: nothing of it
   is written to the device).
4. **Prediction** (`predict`). The emulated controller (the device's firmware, the FPGA loop's
   model) with the audited plant and the device's compensator and loop settings runs the
   verification waveform with the device's values and with the proposed ones.
5. **Apply** (`--apply`): the device's configuration goes to before.json first; the changes are
   written as one set (the device's settings check decides: all or nothing); the verification
   waveform (a sine, which the identification does not contain) runs before and after, measured
   on the device's T_out. A verification that gets worse undoes the changes. `--persist` saves
   them in flash afterwards.

Every way out puts back what the runs changed (source, wave.*) and, unless the calibration
succeeded, the compensator values; the caller stops the device after each run
(`after_run`, cosim.bench.rig.run.stop_and_confirm).
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from cosim.bench.link import messages as msgs
from cosim.bench.link.client import BenchClient, BenchError, BenchUsageError
from cosim.bench.link.paramset import backup_doc, write_all, write_atomic
from cosim.bench.link.protocol import (
    ProtocolError,
    format_value,
    param,
    value_from_word,
    word_from_value,
)
from cosim.bench.link.recorder import record_run
from cosim.project.interrupt import Interrupted

from . import bend_map

# --- the identification sequence ---------------------------------------------------------------

# The tension range it covers (N): the bench's default waveform (mean 8.5, amplitude 6.5).
TENSION_RANGE_N = (2.0, 15.0)
# Ramp rates (N/s): quasi-static, the default sine's mean rate (4 * 6.5 N * 0.5 Hz = 13 N/s)
# and three times faster.
RATES_N_S = (5.0, 15.0, 40.0)
# Small reversals: +-1.5 N about three levels (low, middle, high of the range) at 10 N/s.
SMALL_LEVELS_N = (4.0, 8.5, 13.0)
SMALL_HALF_N = 1.5
SMALL_RATE_N_S = 10.0
HOLD_S = 0.5
START_HOLD_S = 1.0  # the audit's warm-up (cosim.audit.data.WARMUP_S)

# --- the tare ------------------------------------------------------------------------------------

# T_ref 0 with the cable at rest before anything else: the loop holds the inlet at zero tension, so
# the far-end load cell carries no load and reads its own offset. The reading is the median over
# the second half (the loop's start-up left out).
TARE_S = 1.0

# --- the verification waveform -------------------------------------------------------------------

# A sine (the identification has only ramps and holds) over the same range at 0.4 Hz, a
# frequency none of the identification's pieces has; measured from SETTLE_S (the loop starts
# from rest) to the end.
VERIFY = {"waveform": "sine", "mean_n": 8.5, "amplitude_n": 6.5, "freq_hz": 0.4}
VERIFY_SECONDS = 8.5
SETTLE_S = 1.0

# The compensator parameters the audit can set: device name -> (audit parameter, scaled by
# phi: the audit fits mu*phi at its phi, the device multiplies by its comp.phi_rad).
AUDITED = {
    "comp.mu": ("mu", True),
    "comp.offset_n": ("sensor_offset", False),
    "comp.mu_slope_per_n": ("mu_tension_slope", True),
    # the thresholds' log spread is a ratio of widths: the same at any phi
    "comp.dead_zone_spread": ("dead_zone_spread", False),
}
# Proposed as the audit fits them, without the finding rule (still judged on the compensator's
# limits): the dead zone's spread is a parameter of the audit's nominal model, whose effect lies
# in the turn after each reversal, so that the rule's share of better blocks (most blocks hold
# no reversal) refused spreads that track better in closed loop. Chosen on the tuning set of
# random plants (cosim/studies/sweep/examples/random_plants_tuning.yaml, docs/results.md
# "Sensorless after calibration on random plants").
UNGATED = frozenset({"comp.dead_zone_spread"})
# ...but only a change of at least this much: a spread of 0.05 narrows the first play's jump by
# 7 % of mu*phi (e^(-1.534 * 0.05)), and the audit fits spreads of 0.01-0.02 to plants that have
# none, which tracked no differently on the tuning plants.
UNGATED_MIN_STEP = {"comp.dead_zone_spread": 0.05}
# The breakaway (comp.breakaway, comp.h: static friction's excess after a reversal) is proposed
# from the audit's static_friction finding, which has passed the audit's rule as a finding (so
# the proposal is a function of the report's findings alone, and a stored calibration's report
# gives it again), scaled like mu by the ratio of the bending angles (only m_s*phi is observed)
# and by BREAKAWAY_SHARE, chosen on the tuning set of random plants (docs/results.md, "The
# breakaway term").
BREAKAWAY_AUDIT_PARAM = "mu_static_excess"
BREAKAWAY_SHARE = 1.0
# ... from the first of BREAKAWAY_SOURCES that holds a static friction (the slack's sources
# below: "finding" is the finding alone).
BREAKAWAY_SOURCES = ("finding",)
# mu with what the audit saw but did not name (`joint_mu`): when the audit's rule refuses the
# extended model's mu against the device's, mu is fitted again with the findings and every cause
# of the audit's last round that removed at least JOINT_MIN_PCT % of the selection blocks'
# residual without becoming a finding (slack at the range's bottom, friction with the cable's
# speed: with several such effects at once none passes the rule alone, and the mu fitted without
# them absorbs them), all refitted together on the fit blocks; the device's mu is then judged
# against that mu in that model by the same rule. The share (10, 20 or 35 %) was chosen on the
# tuning set of random plants (docs/results.md, "mu fitted with what the audit did not name").
JOINT_MIN_PCT = 35.0
# The terms of mu's own law that the joint fit can fit with mu (the friction's slope with the
# tension: the mu it fits is then the friction at zero tension, mu + s T the friction at T). When
# calibrate proposes the joint fit's mu it proposes these as that fit found them too, in place
# of the extended model's value: without its slope the joint mu is the friction at zero tension
# applied at every tension (a tuning plant with a slope of -0.00101 /N: the joint fit's mu
# 0.0824 with -0.00099 /N, the mu of its mean tension about 0.077; docs/results.md, "Where the
# sensorless mode's worst plants lose").
JOINT_WITH_MU = ("mu_tension_slope",)
# ... and a mu the rule passes is fitted jointly too when the audit's last round saw such a term
# without naming it (joint_mu's choice of causes), and proposed from that fit when it passes the
# same rule there: a mu fitted without the slope the record holds is the friction at the record's
# mean tension, off at both ends of the range. Chosen on the tuning set of random plants (the
# median + worst true RMS 7.44 -> 7.38: two plants better, two worse; docs/results.md, "Where the
# sensorless mode's worst plants lose").
JOINT_WHEN_SEEN = True
# The slack (comp.slack_tension_n, comp.h: the pretension lost below an input tension) is proposed
# from the slack the audit saw, by the first of SLACK_SOURCES that holds one: "finding" (its slack
# finding, which passed the audit's rule), "joint" (the slack the joint fit of mu refitted with
# mu: the audit saw it and did not name it), "candidate" (its last round's slack candidate that
# removed at least JOINT_MIN_PCT % of the selection blocks' residual, not at a bound, fitted with
# the findings before it), "any_round" (the same in any round, the one that removed the most).
# A function of the report and the audit's record alone, so that a stored calibration gives it
# again (slack_of_report). The slack is a tension at the inlet: no scaling by phi. The sources
# were chosen on the tuning set of random plants (docs/results.md, "The slack term": any round's
# candidate caught slack the later rounds' findings had made look smaller, on two of 24 plants).
SLACK_AUDIT_PARAM = "slack_tension"
SLACK_SOURCES = ("finding", "joint", "any_round")
# The friction that grows with the cable's speed (comp.mu_per_inlet_rate, comp.h: mu + m_r times
# the inlet tension's predicted rate) is proposed from the viscous friction the audit saw, by the
# first of VISCOUS_SOURCES that holds one (the sources as the slack's), in either of its forms:
# the inlet tension's rate (`mu_viscous_tension_rate`, s/N: m_r itself) or the cable's speed at
# the inlet (`mu_viscous`, s/m), which on a sliding branch is the inlet tension's rate times the
# cable's compliance inside the sheath and the load cell's give
# (cosim.parts.firmware.mu_per_inlet_rate_of_cable_speed, at the audit's mu, phi and sheath
# length and the FMU's cable_EA, which the audit's twin takes: only the product is observed),
# the mean of the loading and the unloading branch's (the compensator has one m_r). Not with the
# far-end correction in service (corr.enable 1): its reversal table learns the same periodic
# error, and the two together tracked worse than the correction alone. The sources and that rule
# were chosen on the tuning set of random plants (docs/results.md, "Friction with the cable's
# speed").
VISCOUS_AUDIT_PARAMS = ("mu_viscous_tension_rate", "mu_viscous")
VISCOUS_SOURCES = ("finding", "joint")
# What a run changes on the device (record_run) and calibrate puts back.
RUN_PARAMS = ("source", "wave.kind", "wave.mean_n", "wave.amplitude_n", "wave.freq_hz")
# What the prediction's emulated controller takes from the device: what shapes tracking
# (never the ADC's calibration, which belongs to the device's load cells).
LOOP_SHAPE = ("loop.kff", "loop.kp", "loop.ki_ts", "loop.i_limit", "loop.slew", "loop.slew_en")
TWIN_PARAMS = tuple(
    p.name
    for p in msgs.PARAMS
    if not p.read_only and (p.name.startswith(("comp.", "est.")) or p.name in LOOP_SHAPE)
)


@dataclass(frozen=True)
class Piece:
    """One piece of the identification sequence and why it is there."""

    name: str
    start_s: float
    end_s: float
    why: str


def _ramp(a: float, b: float, rate_n_s: float, tick_hz: float) -> np.ndarray:
    n = max(1, int(round(abs(b - a) / rate_n_s * tick_hz)))
    return a + (b - a) * np.arange(n) / n


def identification_sequence(
    tick_hz: float = 1000.0, range_n: tuple[float, float] = TENSION_RANGE_N
) -> tuple[np.ndarray, list[Piece]]:
    """T_ref samples (N, one per tick) and the pieces they are made of."""
    lo, hi = range_n
    parts: list[np.ndarray] = []
    pieces: list[Piece] = []

    def add(name: str, why: str, *arrays: np.ndarray) -> None:
        start = sum(len(a) for a in parts) / tick_hz
        parts.extend(arrays)
        pieces.append(Piece(name, start, sum(len(a) for a in parts) / tick_hz, why))

    def hold(v: float, s: float) -> np.ndarray:
        return np.full(int(round(s * tick_hz)), v)

    add(
        "start",
        "the loop starts from rest: the audit's warm-up, never scored",
        hold(lo, START_HOLD_S),
    )
    slow, mid, fast = RATES_N_S
    add(
        f"full range at {slow:g} N/s, both ways, with holds",
        "quasi-static friction over the whole range: mu multiplies the tension, an offset adds "
        "to it and a tension slope bends it, so only the whole range tells them apart; the "
        "holds at both ends show the settled output of each branch",
        _ramp(lo, hi, slow, tick_hz),
        hold(hi, HOLD_S),
        _ramp(hi, lo, slow, tick_hz),
        hold(lo, HOLD_S),
    )
    for rate, count in ((mid, 2), (fast, 3)):
        arrays = []
        for _ in range(count):
            arrays += [_ramp(lo, hi, rate, tick_hz), _ramp(hi, lo, rate, tick_hz)]
        add(
            f"full range at {rate:g} N/s x {count}",
            "the same range faster: friction that grows with speed (viscous) and a lagging or "
            "delayed sensor show only against the slow ramps; the reversals at the ends cross "
            "the dead zone at full tension",
            *arrays,
        )
    arrays = []
    cur = lo
    for level in SMALL_LEVELS_N:
        arrays.append(_ramp(cur, level - SMALL_HALF_N, mid, tick_hz))
        for _ in range(2):
            arrays += [
                _ramp(level - SMALL_HALF_N, level + SMALL_HALF_N, SMALL_RATE_N_S, tick_hz),
                _ramp(level + SMALL_HALF_N, level - SMALL_HALF_N, SMALL_RATE_N_S, tick_hz),
            ]
        cur = level - SMALL_HALF_N
    arrays += [_ramp(cur, lo, mid, tick_hz), hold(lo, HOLD_S)]
    add(
        f"reversals of +-{SMALL_HALF_N:g} N at {', '.join(f'{v:g}' for v in SMALL_LEVELS_N)} N",
        "small reversals inside the range: the dead zone after a reversal (its width grows "
        "with mu*phi and the tension) at three levels, and an input that is not periodic, so "
        "the audit's blocks do not lock to one phase",
        *arrays,
    )
    return np.concatenate(parts), pieces


# --- the proposal --------------------------------------------------------------------------------


@dataclass
class Change:
    """One compensator parameter: the device's value, the audit's, and the decision."""

    name: str  # device parameter
    audit_param: str
    current: float  # device units
    proposed: float | None  # device units (None: nothing to propose)
    audit_value: float  # the audit's extended model's value (its phi)
    device_as_audit: float | None  # the device's value in the audit's terms
    status: str  # "change", "clipped", "unchanged", "not significant", "refused"
    reason: str
    stats: dict = field(default_factory=dict)

    @property
    def applies(self) -> bool:
        return self.status in ("change", "clipped")


def audit_phi(data) -> float:
    """The bending angle behind the audit's mu: phi_ref without positions, else phi at the
    recording's (constant) position."""
    from cosim.parts.geometry import bending_angle  # noqa: PLC0415

    if data.phi_ref_rad is not None:
        return float(data.phi_ref_rad)
    x, y, z = (float(v) for v in np.mean(data.positions_m, axis=0))
    return float(bending_angle(x, y, z, data.inputs.sheath_length_m, data.inputs.loop_routing))


def joint_mu(result, min_pct: float | None = None):
    """The audit's extended model with mu refitted together with the causes of its last round
    that removed at least `min_pct` % of the selection blocks' residual without becoming findings
    (nor ending at a bound of their form; default JOINT_MIN_PCT): (the model, those causes'
    effects), or None when there are none."""
    from cosim.audit.fit import fit_model  # noqa: PLC0415

    extra = unnamed_causes(result, min_pct)
    if not extra:
        return None
    found = [f.effect for f in result.findings]
    return fit_model(result.data, (*found, *extra), result.extended.params), extra


def unnamed_causes(result, min_pct: float | None = None) -> list:
    """The effects of the audit's last round that removed at least `min_pct` % of the selection
    blocks' residual without becoming findings, nor ending at a bound of their form (default
    JOINT_MIN_PCT): what joint_mu fits with mu."""
    min_pct = JOINT_MIN_PCT if min_pct is None else min_pct
    named = {f.effect.cause for f in result.findings}
    last = result.rounds[-1] if result.rounds else None
    return [
        c.effect
        for c in (last.candidates if last is not None else ())
        if c.effect.cause not in named and c.at_bound is None and c.explained_pct >= min_pct
    ]


def propose(result, device: dict[str, float], phi_device_rad: float) -> list[Change]:
    """The changes the audit implies for the device's compensator values `device` (SI units by
    name), judged as the module docstring says."""
    from cosim.audit import twin  # noqa: PLC0415
    from cosim.audit.decision import block_stats  # noqa: PLC0415
    from cosim.audit.effects import BY_PARAM  # noqa: PLC0415

    data = result.data
    ext = result.extended
    phi_a = audit_phi(data)
    # device value = audit value * scale, for mu and slope (only mu*phi is observable)
    scale = _phi_scale(phi_a, phi_device_rad)
    r_ext = ext.residual(data)
    changes = []
    joint_law: dict[str, float] = {}  # the joint fit's parameters, when its mu is proposed
    for name, (aparam, by_phi) in AUDITED.items():
        p = param(name)
        k = scale if by_phi else 1.0
        # mu and the dead zone's spread belong to the nominal model (cosim.audit.params), off at 0
        off = BY_PARAM[aparam].off if aparam in BY_PARAM else 0.0
        a_val = float(ext.params.get(aparam, off))
        cur = float(device[name])
        if aparam in JOINT_WITH_MU and aparam in joint_law and math.isfinite(k):
            changes.append(_with_joint_mu(name, aparam, cur, joint_law[aparam], k))
            continue
        if not math.isfinite(k) and not (a_val == off and cur == off):
            changes.append(_phi_refused(name, aparam, cur, a_val, phi_device_rad, "mu*phi",
                                        " through mu"))  # fmt: skip
            continue
        dev_as_a = cur / k if math.isfinite(k) else cur
        target = a_val * k if math.isfinite(k) else a_val
        c = Change(name, aparam, cur, None, a_val, dev_as_a, "unchanged", "")
        if _same_word(p, target, cur):
            c.reason = "the audit's value is the device's (to its resolution)"
            changes.append(c)
            continue
        if name in UNGATED and abs(target - cur) < UNGATED_MIN_STEP[name]:
            c.reason = (
                f"the audit's {_fmt(a_val)} is within {UNGATED_MIN_STEP[name]:g} of the device's "
                f"{_fmt(dev_as_a)}: too small a change to propose"
            )
            changes.append(c)
            continue
        trial = {**ext.params, aparam: dev_as_a}
        r_dev = data.t_out_n - twin.simulate(data.inputs, trial)
        st = block_stats(data, r_dev, r_ext)
        c.stats = _stats_record(st)
        joint = None
        if name == "comp.mu" and not result.rule.passes(st, data):
            joint = _joint_mu_decision(result, dev_as_a)
        elif name == "comp.mu" and JOINT_WHEN_SEEN and _saw_unnamed(result, JOINT_WITH_MU):
            # a passing mu fitted without a slope the record holds: the joint fit's, when it
            # passes too
            joint = _joint_mu_decision(result, dev_as_a)
            if joint is not None and not result.rule.passes(joint[1], data):
                joint = None
        if joint is not None:
            a_val, st, with_, fitted = joint
            c.audit_value, target = a_val, a_val * k
            c.stats = {**_stats_record(st), "joint_with": with_, "joint_params": fitted}
        if name not in UNGATED and not result.rule.passes(st, data):
            c.status = "not significant"
            c.reason = (
                f"the audit's {_fmt(a_val)} against the device's {_fmt(dev_as_a)} removes "
                f"{max(st.explained_pct, 0):.1f} % of the residual (block t {st.t:.1f}, "
                f"{100 * st.improved_share:.0f} % of the blocks better); the audit's rule: "
                + result.rule.text().split(";")[0]
            )
            if joint is not None:
                c.reason = (
                    f"fitted with {', '.join(joint[2])}, which the audit saw but did not name, "
                    + c.reason
                )
            changes.append(c)
            continue
        c.proposed = target
        c.status = "change"
        c.reason = (
            f"removes {st.explained_pct:.1f} % of the residual against the device's value "
            f"(block t {st.t:.1f}, {100 * st.improved_share:.0f} % of the blocks better)"
        )
        if joint is not None:
            joint_law = dict(joint[3])
            c.reason = (
                f"fitted with {', '.join(joint[2])}, which the audit saw but did not name: "
                + c.reason
            )
        if name in UNGATED and not result.rule.passes(st, data):
            c.reason = (
                f"the audit's nominal model's value, proposed without the finding rule; it "
                f"{c.reason.split(' ', 1)[1]}"
            )
        changes.append(c)
    findings = {f.effect.fmu_param: float(f.value) for f in result.findings}
    rounds = [
        [
            {
                "cause": c.effect.cause,
                "params": {
                    n: float(c.model.params[n]) for n in c.effect.fmu_params if n in c.model.params
                },
                "selection_explains_pct": c.explained_pct,
                "at_bound": c.at_bound,
            }
            for c in rnd.candidates
        ]
        for rnd in result.rounds
    ]
    joint_params = next((c.stats.get("joint_params") for c in changes if c.name == "comp.mu"), None)
    brk = seen_by_audit(
        (BREAKAWAY_AUDIT_PARAM,), "static friction", findings, joint_params, rounds,
        BREAKAWAY_SOURCES,
    )  # fmt: skip
    changes.append(breakaway_change(brk[1], phi_a, device, phi_device_rad, source=brk[2]))
    changes.append(slack_change(*slack_seen(findings, joint_params, rounds), device))
    seen = seen_by_audit(
        VISCOUS_AUDIT_PARAMS, "viscous friction", findings, joint_params, rounds, VISCOUS_SOURCES
    )
    mu_a = float(ext.params.get("mu", device.get("comp.mu", 0.0)))
    changes.append(
        viscous_change(seen, mu_a, phi_a, data.inputs.sheath_length_m, device, phi_device_rad)
    )
    _check_limits(changes, device, phi_device_rad)
    return changes


def _saw_unnamed(result, params) -> bool:
    """Whether the audit's last round holds a cause of `params` (FMU parameters) that the joint
    fit of mu would take (unnamed_causes)."""
    return any(e.fmu_param in params for e in unnamed_causes(result))


def _with_joint_mu(name: str, aparam: str, cur: float, value: float, k: float) -> Change:
    """A compensator term of mu's law (JOINT_WITH_MU) proposed as the joint fit of mu fitted it,
    since the mu proposed is that fit's (scaled by the bending angles like mu: factor `k`)."""
    target = value * k
    c = Change(name, aparam, cur, None, value, cur / k, "unchanged", "")
    if _same_word(param(name), target, cur):
        c.reason = "the joint fit of mu's value is the device's (to its resolution)"
        return c
    c.proposed, c.status = target, "change"
    c.reason = (
        f"fitted with the mu proposed (the joint fit of mu, which the audit saw but did not "
        f"name: {aparam} {_fmt(value)}): that mu is the mu of the law with it"
    )
    return c


def _stats_record(st) -> dict:
    """A decision's block statistics as the calibration's record keeps them."""
    return {
        "explained_pct": st.explained_pct,
        "removed_rms_n": st.removed_rms_n,
        "block_t": st.t,
        "improved_share": st.improved_share,
        "blocks": st.blocks,
    }


def _joint_mu_decision(result, device_mu: float):
    """mu refitted with the effects the audit saw but did not name (joint_mu), and the block
    statistics of that model against the same model with the device's mu (in the audit's
    terms): (mu, stats, the effects' FMU parameters, those effects' parameters as fitted with mu),
    or None when there is no such model."""
    from cosim.audit import twin  # noqa: PLC0415
    from cosim.audit.decision import block_stats  # noqa: PLC0415

    joint = joint_mu(result)
    if joint is None:
        return None
    model, extra = joint
    data = result.data
    r_dev = data.t_out_n - twin.simulate(data.inputs, {**model.params, "mu": device_mu})
    st = block_stats(data, r_dev, model.residual(data))
    fitted = {p: float(model.params[p]) for e in extra for p in e.fmu_params}
    return float(model.params["mu"]), st, [e.fmu_param for e in extra], fitted


def _term_off(name: str, audit_param: str, cur: float, unseen: str, term: str) -> Change:
    """The decision for a term whose effect the audit did not see (`unseen` says so): nothing to
    change while it is off, else off (`term` names it)."""
    c = Change(name, audit_param, cur, None, 0.0, None, "unchanged", unseen)
    if cur != 0.0:
        c.status, c.proposed, c.reason = "change", 0.0, f"{unseen}: {term} goes off"
    return c


def _phi_scale(phi_audit_rad: float, phi_device_rad: float) -> float:
    """The factor from the audit's value of a term proportional to phi to the device's (only its
    product with phi is observed); NaN when the device's phi cannot carry it."""
    return phi_audit_rad / phi_device_rad if phi_device_rad > 0 else math.nan


def _phi_refused(name: str, aparam: str, cur: float, value: float, phi_device_rad: float,
                 what: str, how: str = "") -> Change:  # fmt: skip
    """The refusal of a term proportional to phi on a device whose comp.phi_rad cannot carry it
    (`what` names the product that cannot be set, `how` through what)."""
    c = Change(name, aparam, cur, None, value, None, "refused", "")
    c.reason = (
        f"comp.phi_rad is {phi_device_rad:g}: the device's {what} cannot be set{how} "
        "(set comp.phi_rad first)"
    )
    return c


def breakaway_change(
    audit_value: float | None,
    phi_audit_rad: float,
    device: dict[str, float],
    phi_device_rad: float,
    share: float = BREAKAWAY_SHARE,
    source: str = "its static friction finding",
) -> Change:
    """comp.breakaway from the static friction the audit saw (`audit_value` from `source`, None
    without one), before the compensator's limits (_check_limits)."""
    name = "comp.breakaway"
    cur = float(device.get(name, 0.0))
    if audit_value is None:
        return _term_off(name, BREAKAWAY_AUDIT_PARAM, cur, "the audit names no static friction",
                         "the breakaway term")  # fmt: skip
    scale = _phi_scale(phi_audit_rad, phi_device_rad)
    if not math.isfinite(scale):
        return _phi_refused(name, BREAKAWAY_AUDIT_PARAM, cur, audit_value, phi_device_rad,
                            "m_s*phi", " through the breakaway")  # fmt: skip
    target = share * audit_value * scale
    c = Change(name, BREAKAWAY_AUDIT_PARAM, cur, None, audit_value, cur / scale, "unchanged", "")
    if _same_word(param(name), target, cur):
        c.reason = "the audit's value is the device's (to its resolution)"
        return c
    c.proposed, c.status = target, "change"
    c.reason = f"is {source} ({BREAKAWAY_AUDIT_PARAM} {_fmt(audit_value)})" + (
        f" times the share {share:g}" if share != 1.0 else ""
    )
    return c


def breakaway_of_report(
    report: dict,
    device: dict,
    share: float = BREAKAWAY_SHARE,
    audit: dict | None = None,
    sources: tuple[str, ...] = BREAKAWAY_SOURCES,
) -> Change:
    """calibrate's comp.breakaway for a calibration report (its findings, bending angles and the
    other applied proposals) and its audit's record (`audit`, for the sources beyond the
    findings), judged on the compensator's limits with those proposals: what `propose` gives
    for the same audit."""
    a = report["audit"]
    findings = {f["param"]: f["value"] for f in a["findings"]}
    mu = next((c for c in report["changes"] if c["name"] == "comp.mu"), {})
    joint_params = (mu.get("stats") or {}).get("joint_params")
    rounds = [r["candidates"] for r in (audit or {}).get("rounds") or []]
    _, value, source = seen_by_audit(
        (BREAKAWAY_AUDIT_PARAM,), "static friction", findings, joint_params, rounds, sources
    )
    c = breakaway_change(value, a["phi_rad"], device, report["device_phi_rad"], share, source)
    return _judged_with_the_rest(c, report, device)


def _judged_with_the_rest(c: Change, report: dict, device: dict[str, float]) -> Change:
    """`c` judged on the compensator's limits with the stored report's other applied proposals."""
    applied = {
        x["name"]: x["proposed"]
        for x in report["changes"]
        if x["status"] in ("change", "clipped") and x["name"] != c.name
    }
    _check_limits([c], {**device, **applied}, report["device_phi_rad"])
    return c


def _seen_candidate(candidates: list[dict], aparams: tuple[str, ...]) -> dict | None:
    """The candidate among a round's (as the audit's record keeps them: cause, params,
    selection_explains_pct, at_bound) that holds one of `aparams` and removed at least
    JOINT_MIN_PCT % of the selection blocks' residual, not at a bound of its form, or None."""
    for c in candidates:
        if (
            any(a in c["params"] for a in aparams)
            and c["at_bound"] is None
            and c["selection_explains_pct"] >= JOINT_MIN_PCT
        ):
            return c
    return None


def seen_by_audit(
    aparams: tuple[str, ...],
    what: str,
    findings: dict[str, float],
    joint_params: dict | None,
    rounds: list[list[dict]],
    sources: tuple[str, ...],
) -> tuple[str | None, float | None, str]:
    """An effect the audit saw, in any of its FMU parameters `aparams` (the first named wins
    within a source), by the first of `sources` that holds one: "finding" (the findings' values
    by FMU parameter, which passed the audit's rule), "joint" (the joint fit of mu's parameters,
    None when it did not run), "candidate" / "any_round" (_seen_candidate of the last round / of
    every round, the one that removed the most). (the parameter, its value, where it was seen);
    (None, None, "") when none does. `what` names the effect in the text."""
    for source in sources:
        if source == "finding":
            got = next((a for a in aparams if a in findings), None)
            if got is not None:
                return got, float(findings[got]), f"its {what} finding"
        if source == "joint" and joint_params:
            got = next((a for a in aparams if a in joint_params), None)
            if got is not None:
                return got, float(joint_params[got]), f"the {what} the joint fit of mu found"
        if any(a in findings for a in aparams) or source not in ("candidate", "any_round"):
            continue
        chosen = rounds[-1:] if source == "candidate" else rounds
        seen = [c for c in (_seen_candidate(r, aparams) for r in chosen) if c is not None]
        if seen:
            c = max(seen, key=lambda c: c["selection_explains_pct"])
            got = next(a for a in aparams if a in c["params"])
            where = "last round's" if source == "candidate" else "rounds'"
            pct = c["selection_explains_pct"]
            text = f"its {where} {what} candidate ({pct:.0f} % of the selection residual)"
            return got, float(c["params"][got]), text
    return None, None, ""


def slack_seen(
    findings: dict[str, float],
    joint_params: dict | None,
    rounds: list[list[dict]],
    sources: tuple[str, ...] = SLACK_SOURCES,
) -> tuple[float | None, str]:
    """The slack tension (N) the audit saw and where it was seen (seen_by_audit with
    SLACK_SOURCES); (None, "") when it saw none."""
    _, value, source = seen_by_audit(
        (SLACK_AUDIT_PARAM,), "slack", findings, joint_params, rounds, sources
    )
    return value, source


def slack_change(audit_value: float | None, source: str, device: dict[str, float]) -> Change:
    """comp.slack_tension_n from the slack the audit saw (`audit_value` N from `source`, None
    without one), before the compensator's limits (_check_limits)."""
    name = "comp.slack_tension_n"
    cur = float(device.get(name, 0.0))
    if audit_value is None:
        return _term_off(name, SLACK_AUDIT_PARAM, cur, "the audit saw no slack", "the slack's root")
    c = Change(name, SLACK_AUDIT_PARAM, cur, None, audit_value, cur, "unchanged", "")
    if _same_word(param(name), audit_value, cur):
        c.reason = "the audit's value is the device's (to its resolution)"
        return c
    c.proposed, c.status = audit_value, "change"
    c.reason = f"is {source} ({SLACK_AUDIT_PARAM} {_fmt(audit_value)} N)"
    return c


def slack_of_report(
    report: dict, audit: dict, device: dict, sources: tuple[str, ...] = SLACK_SOURCES
) -> Change:
    """calibrate's comp.slack_tension_n for a calibration report (`report`, its calibration.json)
    and its audit's record (`audit`, audit/audit.json), judged on the compensator's limits with
    the report's other applied proposals: what `propose` gives for the same audit."""
    findings = {f["param"]: f["value"] for f in report["audit"]["findings"]}
    mu = next((c for c in report["changes"] if c["name"] == "comp.mu"), {})
    joint_params = (mu.get("stats") or {}).get("joint_params")
    rounds = [r["candidates"] for r in audit.get("rounds") or []]
    c = slack_change(*slack_seen(findings, joint_params, rounds, sources), device)
    return _judged_with_the_rest(c, report, device)


def inlet_rate_friction(
    aparam: str, value: float, mu: float, phi_rad: float, sheath_length_m: float
) -> float:
    """The audit's viscous friction (`aparam` of VISCOUS_AUDIT_PARAMS, its `value`) as mu's growth
    per unit of the inlet tension's rate (s/N) at the audit's mu and phi: the tension-rate form
    as it is, the cable-speed form through the cable's compliance (VISCOUS_AUDIT_PARAMS)."""
    from cosim.parts.firmware import mu_per_inlet_rate_of_cable_speed  # noqa: PLC0415

    if aparam == "mu_viscous_tension_rate":
        return value
    up, dn = mu_per_inlet_rate_of_cable_speed(value, mu, phi_rad, sheath_length_m)
    return 0.5 * (up + dn)


def viscous_change(
    seen: tuple[str | None, float | None, str],
    mu: float,
    phi_audit_rad: float,
    sheath_length_m: float,
    device: dict[str, float],
    phi_device_rad: float,
) -> Change:
    """comp.mu_per_inlet_rate from the viscous friction the audit saw (`seen`: seen_by_audit's
    parameter, value and source), scaled like mu by the ratio of the bending angles (only the
    product with phi is observed), before the compensator's limits (_check_limits)."""
    name = "comp.mu_per_inlet_rate"
    cur = float(device.get(name, 0.0))
    aparam, value, source = seen
    if aparam is None:
        unseen = "the audit saw no friction with the cable's speed"
        return _term_off(name, VISCOUS_AUDIT_PARAMS[0], cur, unseen, "the rate term")
    if device.get("corr.enable", 0.0) != 0.0:
        served = "the far-end correction is in service (corr.enable 1) and learns that error"
        return _term_off(name, aparam, cur, served, "the rate term")
    scale = _phi_scale(phi_audit_rad, phi_device_rad)
    m_r = inlet_rate_friction(aparam, value, mu, phi_audit_rad, sheath_length_m)
    if not math.isfinite(scale):
        return _phi_refused(name, aparam, cur, value, phi_device_rad, "rate term")
    target = m_r * scale
    c = Change(name, aparam, cur, None, value, None, "unchanged", "")
    if _same_word(param(name), target, cur):
        c.reason = "the audit's value is the device's (to its resolution)"
        return c
    c.proposed, c.status = target, "change"
    unit = "s/N" if aparam == "mu_viscous_tension_rate" else "s/m"
    c.reason = f"is {source} ({aparam} {_fmt(value)} {unit})"
    return c


def viscous_of_report(
    report: dict, audit: dict, device: dict, sources: tuple[str, ...] = VISCOUS_SOURCES
) -> Change:
    """calibrate's comp.mu_per_inlet_rate for a calibration report and its audit's record, judged
    on the compensator's limits with the report's other applied proposals: what `propose` gives
    for the same audit (the sheath's length from the record, 1 m, the audit's default, without
    one)."""
    findings = {f["param"]: f["value"] for f in report["audit"]["findings"]}
    mu = next((c for c in report["changes"] if c["name"] == "comp.mu"), {})
    joint_params = (mu.get("stats") or {}).get("joint_params")
    rounds = [r["candidates"] for r in audit.get("rounds") or []]
    seen = seen_by_audit(
        VISCOUS_AUDIT_PARAMS, "viscous friction", findings, joint_params, rounds, sources
    )
    a = report["audit"]
    length = float((audit.get("data") or {}).get("sheath_length_m", 1.0))
    # the audit's mu (a report from before it was kept: the device's, in the audit's terms)
    mu_a = a.get("mu", device.get("comp.mu", 0.0) * report["device_phi_rad"] / a["phi_rad"])
    c = viscous_change(seen, mu_a, a["phi_rad"], length, device, report["device_phi_rad"])
    return _judged_with_the_rest(c, report, device)


def _fmt(v: float) -> str:
    return f"{v:.5g}"


def _same_word(p, a: float, b: float) -> bool:
    """Whether two values are the same device word (a value beyond the word is not)."""
    try:
        return word_from_value(p, a) == word_from_value(p, b)
    except ProtocolError:
        return False


def _comp_refuses(values: dict[str, float], mode: str) -> str | None:
    """Why the firmware's compensator refuses this configuration (its own check, fixed point,
    through cosim.parts.firmware), or None."""
    from cosim.config.run import CompensatorParams  # noqa: PLC0415
    from cosim.parts.firmware import make_compensator  # noqa: PLC0415

    fields = {k.split(".", 1)[1]: v for k, v in values.items() if k.startswith("comp.")}
    fields.pop("mode", None)
    phi = fields.pop("phi_rad")
    try:
        make_compensator(mode, CompensatorParams(**fields), phi)
    except (ValueError, RuntimeError) as exc:
        return str(exc)
    return None


def _takes(name: str, value: float, values: dict, mode: str) -> str | None:
    """Why the device does not take `name` = value with the other values `values` (the
    protocol's word, then the compensator's configuration check), or None."""
    try:
        word_from_value(param(name), value)
    except ProtocolError as exc:
        return f"outside the parameter's range: {exc}"
    why = _comp_refuses({**values, name: value}, mode)
    return None if why is None else f"outside the compensator's limits: {why}"


# Bisection steps of a clipped value between the device's value and the proposed one: 2^-30 of
# the way, below every parameter's word.
CLIP_STEPS = 30


def _clipped(name: str, current: float, proposed: float, values: dict, mode: str):
    """The value nearest `proposed` on the way from `current` that the device takes with
    `values`, or None when only `current` (or nothing) is taken. The compensator's limits are
    intervals in each value (a range, a sign rule, a gain bound that grows with the value), so
    the values taken on the way form one piece from `current`."""
    if _takes(name, current, values, mode) is not None:
        return None
    lo, hi = 0.0, 1.0  # fraction of the way: lo taken, hi not
    for _ in range(CLIP_STEPS):
        mid = 0.5 * (lo + hi)
        if _takes(name, current + mid * (proposed - current), values, mode) is None:
            lo = mid
        else:
            hi = mid
    value = current + lo * (proposed - current)
    if _same_word(param(name), value, current):
        return None
    # The word nearest the limit may round outside it: step back a word until it is taken.
    p = param(name)
    word = word_from_value(p, value)
    step = 1 if proposed < current else -1
    for _ in range(4):
        if _takes(name, value_from_word(p, word), values, mode) is None:
            return value_from_word(p, word)
        word += step
    return None


def _check_limits(changes: list[Change], device: dict, phi_device_rad: float) -> None:
    """Each proposed value the device does not take alone (the protocol's word or the
    compensator's configuration check) is clipped to the nearest value it takes on the way from
    the device's value (status "clipped") or, if none, refused; then the values that do not hold
    together are left out one at a time, the later in AUDITED's order first (mu, the largest
    effect, is kept longest), each named with the reason. One value never blocks the others."""
    mode = str(device["comp.mode"])
    for c in changes:
        if not c.applies:
            continue
        why = _takes(c.name, c.proposed, device, mode)
        if why is None:
            continue
        clipped = _clipped(c.name, c.current, c.proposed, device, mode)
        if clipped is None:
            c.status, c.reason = "refused", why
            continue
        c.reason = (
            f"clipped from {_fmt(c.proposed)} to {_fmt(clipped)} ({why}); the audit's value "
            f"{c.reason}"
        )
        c.status, c.proposed = "clipped", clipped
    todo = [c for c in changes if c.applies]
    while todo:
        why = _comp_refuses({**device, **{c.name: c.proposed for c in todo}}, mode)
        if why is None:
            break
        left = todo.pop()
        others = {c.name: c.proposed for c in todo}
        kept = ", ".join(others) or "nothing else"
        clipped = _clipped(left.name, left.current, left.proposed, {**device, **others}, mode)
        if clipped is not None and _comp_refuses({**device, **others, left.name: clipped}, mode):
            clipped = None
        if clipped is not None:
            left.reason = (
                f"clipped from {_fmt(left.proposed)} to {_fmt(clipped)} to hold with {kept} "
                f"({why}); {left.reason}"
            )
            left.status, left.proposed = "clipped", clipped
            todo.append(left)
            continue
        left.status = "refused"
        left.reason = (
            f"left out: with {kept} it is outside the compensator's limits ({why}); "
            f"alone it would be taken"
        )


# --- the prediction ------------------------------------------------------------------------------


def verification_error(run_columns: dict) -> dict:
    """Tracking error of a verification run on its T_out (cosim.results.metrics)."""
    from cosim.results.metrics import tracking_error  # noqa: PLC0415

    return tracking_error(
        run_columns["t_s"], run_columns["T_ref_N"], run_columns["T_out_N"], SETTLE_S
    )


def predict(
    plant: dict,
    device_words: dict[str, int],
    changes: list[Change],
    position_m,
    loop_routing: bool,
    folder: Path,
) -> dict:
    """The verification waveform's tracking error on the emulated controller with the audited
    plant (`plant`: FMU parameters), the device's compensator, loop and estimator settings, and
    then the proposed values: {"before": {...}, "after": {...}}."""
    from cosim.bench.emulate.host_device import ChainConfig  # noqa: PLC0415
    from cosim.bench.link.api import Bench  # noqa: PLC0415

    out = {}
    chain = ChainConfig(position_m=tuple(position_m), loop_routing=loop_routing, plant=plant)
    proposed = {c.name: c.proposed for c in changes if c.applies}
    for label, extra in (("before", {}), ("after", proposed)):
        if label == "after" and not proposed:
            out["after"] = out["before"]  # nothing to change: the same run
            break
        with Bench(emulate=True, chain=chain) as twin:
            words = {n: device_words[n] for n in TWIN_PARAMS if n in device_words}
            words.update({n: word_from_value(param(n), v) for n, v in extra.items()})
            write_all(twin.client, [(param(n), w) for n, w in words.items()], "prediction")
            run = twin.run(
                VERIFY["waveform"],
                VERIFY_SECONDS,
                out=folder / f"predicted_{label}.csv",
                mean_n=VERIFY["mean_n"],
                amplitude_n=VERIFY["amplitude_n"],
                freq_hz=VERIFY["freq_hz"],
                position_m=tuple(position_m),
                loop_routing=loop_routing,
            )
            out[label] = verification_error(run.columns)
            out[label]["series"] = (run["t_s"], run["T_ref_N"], run["T_out_N"])
    return out


# --- the whole calibration -----------------------------------------------------------------------


class CalibrationError(BenchError):
    """A calibration that cannot go on (the message is the one line the user sees)."""


def check_out_dir(path: Path, force: bool) -> None:
    """--out: a folder that does not exist, or an empty one, or any with --force, where files
    can be written (a probe file is made and removed in it, or in the nearest folder above it
    that exists: nothing is made before the device is reached); a BenchUsageError names the
    problem."""
    if path.exists() and not path.is_dir():
        raise BenchUsageError(f"calibrate --out {path}: is a file, not a folder")
    if path.is_dir() and any(path.iterdir()) and not force:
        raise BenchUsageError(
            f"calibrate --out {path}: exists and is not empty; --force writes into it"
        )
    above = path.absolute()
    while not above.exists() and above != above.parent:
        above = above.parent
    if not above.is_dir():
        raise BenchUsageError(f"calibrate --out {path}: {above} is a file, not a folder")
    try:
        with tempfile.NamedTemporaryFile(dir=above, prefix=".bowden-calibrate.", suffix=".tmp"):
            pass
    except OSError as exc:
        raise BenchUsageError(
            f"calibrate --out {path}: cannot write in {above} ({exc.strerror or exc})"
        ) from None


@dataclass
class Options:
    out_dir: Path
    apply: bool = False
    persist: bool = False
    # The command line that restores before.json; None for an emulated device, which ends with
    # the calibration (a restore would start a new one).
    restore_hint: str | None = "bowden bench ... restore"
    position_m: tuple[float, float, float] = (0.0, 0.5, 0.0)
    loop_routing: bool = True
    sheath_length_m: float = 1.0
    audit_plots: bool = True  # the audit's PNGs (most of the time outside the runs)
    # The prediction's two emulated verification runs (a study that uses only the proposal
    # leaves them out; --apply measures on the device in any case).
    predict: bool = True
    # Read the far-end cell at zero load first (TARE_S) and take that offset off T_out: the
    # cable must be at rest and unloaded when calibrate starts. False: the audit's offset stands
    # for the sensor's and the tension's together (as before the tare).
    tare: bool = True
    # Further positions (m) at which to map the bending angle after the audit (bend_map: the
    # map's sequence at home and at each, the end-effector moved there by `bench_at`); none: no
    # map.
    map_positions: tuple = ()


@dataclass
class Outcome:
    """What calibrate did: the report (also in calibration.json) and the exit status."""

    report: dict
    exit_code: int


def run_calibration(
    client: BenchClient,
    info,
    opts: Options,
    *,
    after_run: Callable[[], None] | None = None,
    hold: Callable | None = None,
    say: Callable[[str], None] = print,
    progress: Callable[[str], None] | None = None,
    bench_at: Callable | None = None,
) -> Outcome:
    """The calibration (module docstring) on a connected client. `after_run` is called after
    every run however it ends (stop the device and confirm it; raise BenchError when that
    cannot be confirmed; default: STOP); `hold()` a context manager under which putting the
    configuration back is not cut short by a signal (cosim.bench.rig.run.Signals.hold).
    `bench_at(p)`: with opts.map_positions, a context manager that has the end-effector at p
    and gives (client, after_run) (make_bend_map): the user's rig moved there, or an emulated
    bench started there.

    However it ends, what the runs changed (source, wave.*) is written back, and so are the
    compensator values unless they were applied and verified. A link or device failure is one
    CalibrationError naming the step, what the device holds, and before.json."""
    import contextlib  # noqa: PLC0415

    hold = hold or contextlib.nullcontext
    after_run = after_run or (lambda: client.request("STOP"))
    out = opts.out_dir
    out.mkdir(parents=True, exist_ok=True)
    before = backup_doc(client, info)
    before_words = {n: e["word"] for n, e in before["params"].items()}
    # before.json first of all: whatever happens next, the configuration can be restored
    backup = out / "before.json"
    write_atomic(backup, json.dumps(before, indent=2) + "\n")
    if opts.apply and opts.restore_hint is not None:
        say(f"saved the device's configuration to {backup}; restore it with:")
        say(f"  {opts.restore_hint} {backup}")
    elif opts.apply:
        say(
            f"saved the device's configuration to {backup} (the emulated device ends with this "
            "command: nothing to restore)"
        )
    state = _State()
    failure: BaseException | None = None
    try:
        outcome = _calibrate(
            client,
            opts,
            before_words,
            state,
            after_run=after_run,
            say=say,
            progress=progress,
            bench_at=bench_at,
        )
        state.kept = bool(outcome.report.get("applied_kept"))
        return outcome
    except BaseException as exc:
        failure = exc
        raise
    finally:
        with hold():
            undo_error = None
            try:
                _put_back(client, before_words, keep=state.written if state.kept else [])
            except (BenchError, ProtocolError, OSError) as exc:
                undo_error = exc
        _explain(failure, undo_error, state, opts, backup)


@dataclass
class _State:
    step: str = "reading the device's configuration"
    written: list[str] = field(default_factory=list)  # compensator parameters --apply wrote
    kept: bool = False  # applied and verified


def _explain(failure, undo_error, state: _State, opts: Options, backup: Path) -> None:
    """One CalibrationError for a failure of the link or the device (or of putting the
    configuration back): the step, what the device holds now, the way back."""
    link_failure = isinstance(failure, (BenchError, OSError)) and not isinstance(
        failure, (BenchUsageError, CalibrationError)
    )
    if undo_error is None and not link_failure:
        return  # success, an interrupt, a usage error or one of ours: as it is
    if state.written and undo_error is not None:
        holds = (
            f"the values written ({', '.join(state.written)}) could NOT be put back "
            f"({undo_error}): the device holds them in RAM only (nothing was persisted); "
            f"{_way_back(opts, backup)}"
        )
    elif state.written:
        holds = f"the values written ({', '.join(state.written)}) were put back"
    elif undo_error is not None:
        holds = (
            f"no compensator value was written; the run settings (source, wave.*) could not "
            f"be put back ({undo_error}): {_way_back(opts, backup)}"
        )
    else:
        holds = "no compensator value was written"
    what = f"{failure}" if failure is not None else "putting the configuration back failed"
    if isinstance(failure, KeyboardInterrupt | Interrupted):
        if undo_error is None:
            return
        what = "interrupted"
    msg = f"calibrate: {what} during {state.step}; {holds}"
    if str(backup) not in holds:
        msg += f"; the configuration before: {backup}"
    if isinstance(failure, KeyboardInterrupt | Interrupted):
        import sys  # noqa: PLC0415

        print(msg, file=sys.stderr)
        return
    raise CalibrationError(msg) from None


def _way_back(opts: Options, backup: Path) -> str:
    """How to get the configuration of before.json back."""
    if opts.restore_hint is None:
        return f"the emulated device ends with this command ({backup} holds what it had)"
    return f"restore with {opts.restore_hint} {backup}"


# Putting the configuration back after a failure: tries, PUT_BACK_WAIT_S apart (a link that
# failed for a moment, as a CAN bus recovering from bus-off, gets another chance).
PUT_BACK_TRIES = 3
PUT_BACK_WAIT_S = 0.2


def _put_back(client, before_words: dict, keep: list[str]) -> None:
    """Write back every parameter the calibration changed except `keep` (the applied values)."""
    for attempt in range(PUT_BACK_TRIES):
        try:
            client.request("STOP")  # a run left active refuses every write (BUSY)
            now = client.params()
            todo = [
                (param(n), w)
                for n, w in before_words.items()
                if n not in keep and not param(n).read_only and now.get(n) != w
            ]
            if todo:
                write_all(client, todo, "putting back the device's configuration")
            return
        except (BenchError, OSError):
            if attempt == PUT_BACK_TRIES - 1:
                raise
            time.sleep(PUT_BACK_WAIT_S)


def _record(client, path: Path, after_run, opts: Options, progress, **kw):
    """One run (record_run) into `path`, the device stopped afterwards however it ends (a
    failure to confirm the stop does not hide the run's own failure)."""
    from cosim.bench.link.api import _read_columns  # noqa: PLC0415

    try:
        result = record_run(
            client,
            path,
            position_m=opts.position_m,
            loop_routing=opts.loop_routing,
            sheath_length_m=opts.sheath_length_m,
            progress=progress,
            **kw,
        )
    except BaseException:
        try:
            after_run()
        except BenchError:
            pass
        raise
    after_run()
    if result.drops or result.samples < result.expected:
        raise BenchError(f"the recording {path.name} is incomplete ({result.summary()})")
    return result, _read_columns(path)


def stream_record(client, path: Path, seq, after_run, opts: Options, progress, tick_hz: float):
    """T_ref samples `seq` (N, one per tick) streamed to the device and recorded into `path`
    (_record: the device stopped afterwards however it ends); the recording's columns."""
    _, cols = _record(
        client,
        path,
        after_run,
        opts,
        progress,
        seconds=len(seq) / tick_hz,
        waveform="stream",
        mean_n=0.0,
        amplitude_n=0.0,
        freq_hz=0.0,
        stream_words=[word_from_value(param("wave.mean_n"), v) for v in seq],
    )
    return cols


def _tare(client, path: Path, after_run, opts: Options, progress, tick_hz: float) -> dict:
    """The far-end load cell's reading at zero load (TARE_S of T_ref 0, the cable at rest): the
    median of T_out over the second half, and its spread (the 5-95 % range)."""
    ticks = max(2, int(round(TARE_S * tick_hz)))
    cols = stream_record(client, path, np.zeros(ticks), after_run, opts, progress, tick_hz)
    t = cols["t_s"]
    t_out = cols["T_out_N"][t >= 0.5 * t[-1]]
    if t_out.size == 0:
        raise CalibrationError(f"calibrate: {path.name}: the tare recorded no far-end sample")
    lo, hi = np.percentile(t_out, [5, 95])
    return {
        "offset_n": float(np.median(t_out)),
        "spread_n": float(hi - lo),
        "seconds": ticks / tick_hz,
        "file": path.name,
    }


def _check_far_end(columns: dict, path: Path) -> None:
    """T_out must be there and move with T_ref: the calibration rests on the far-end cell."""
    t_out = columns["T_out_N"][columns["t_s"] >= SETTLE_S]
    span = float(np.ptp(t_out)) if t_out.size else 0.0
    ref_span = float(np.ptp(columns["T_ref_N"]))
    if span < 0.25 * ref_span:
        raise CalibrationError(
            f"calibrate: {path.name}: T_out spans {span:.2f} N while T_ref spans "
            f"{ref_span:.2f} N: the far-end load cell (T_out) is missing or stuck; calibrate "
            "needs it (nothing was changed on the device)"
        )


def _calibrate(
    client, opts: Options, before_words, state, *, after_run, say, progress, bench_at=None
):
    from cosim.audit import core  # noqa: PLC0415
    from cosim.audit import params as audit_params  # noqa: PLC0415
    from cosim.audit import report as audit_report  # noqa: PLC0415
    from cosim.results import trace as trace_mod  # noqa: PLC0415

    out = opts.out_dir
    tick_hz = float(client.get("tick_rate_hz"))
    tare = {"offset_n": 0.0, "file": None}
    if opts.tare:
        state.step = "the tare"
        tare = _tare(client, out / "tare.csv", after_run, opts, progress, tick_hz)
        say(
            f"tare: the far-end load cell reads {tare['offset_n']:+.3f} N at zero load "
            f"(spread {tare['spread_n']:.3f} N): taken off T_out before the audit"
        )
    seq, pieces = identification_sequence(tick_hz)
    ident = out / "identification.csv"
    state.step = "the identification run"
    say(f"identification: {len(seq) / tick_hz:.1f} s streamed ({len(pieces)} pieces) -> {ident}")
    cols = stream_record(client, ident, seq, after_run, opts, progress, tick_hz)
    _check_far_end(cols, ident)

    state.step = "the audit"
    say("audit of the identification run ...")
    try:
        tr = trace_mod.read_trace(ident, mode="measured")
        tr.columns["T_out_N"] = tr.columns["T_out_N"] - tare["offset_n"]
        result = core.run(core.prepare(tr, str(ident)))
    except (trace_mod.TraceError, core.AuditError) as exc:
        raise CalibrationError(f"calibrate: the audit refused the recording: {exc}") from None
    audit_dir = out / "audit"
    audit_dir.mkdir(exist_ok=True)
    emitted, notes = audit_params.emitted_params(result)
    names = audit_report.plots(audit_dir, result) if opts.audit_plots else []
    result.extras["plots"] = names
    result.extras["emitted_params"] = {
        "file": "audit/params.json",
        "params": emitted,
        "notes": notes,
    }
    data_dict = audit_report.write_json(audit_dir / "audit.json", result)
    (audit_dir / "report.md").write_text(audit_report.markdown(result, data_dict, names))
    write_atomic(audit_dir / "params.json", json.dumps(emitted, indent=2) + "\n")

    device = {n: value_from_word(param(n), before_words[n]) for n in before_words}
    phi_dev = float(device["comp.phi_rad"])
    changes = propose(result, device, phi_dev)
    findings = [
        {
            "cause": f.effect.cause,
            "param": f.effect.fmu_param,
            "value": float(f.value),
            "compensator": f.effect.compensator_key,
        }
        for f in result.findings
    ]
    say(
        f"audit: mu*phi {result.extended.params['mu'] * audit_phi(result.data):.4f} "
        f"(device {device['comp.mu'] * phi_dev:.4f}); findings: "
        + (", ".join(f"{f['cause']} {f['value']:.4g}" for f in findings) or "none")
    )
    for w in result.warnings:
        say(f"  audit warning: {w}")
    for f in result.findings:
        if f.effect.compensator_key is None:
            say(f"  {f.effect.cause}: no compensator parameter (the loop gains are not changed)")
    to_apply = [c for c in changes if c.applies]
    say("proposed changes:")
    for c in changes:
        if c.applies:
            say(f"  {c.name}: {_fmt(c.current)} -> {_fmt(c.proposed)}  ({c.reason})")
        else:
            say(f"  {c.name}: {_fmt(c.current)} kept: {c.status}: {c.reason}")

    bend = None
    if opts.map_positions:
        state.step = "the bending angle's map"
        bend = _bend_map(bench_at, opts, result, tare, phi_dev, say, progress)

    state.step = "the prediction"
    pred, series = {}, {}
    if opts.predict:
        pred = predict(
            emitted["plant"], before_words, changes, opts.position_m, opts.loop_routing, out
        )
        pb, pa = pred["before"], pred["after"]
        say(
            f"predicted verification error (emulated controller, audited plant): RMS "
            f"{pb['rms_error_n']:.3f} N ({pb['rms_error_pct']:.2f} %) now"
            + (
                f" -> {pa['rms_error_n']:.3f} N ({pa['rms_error_pct']:.2f} %) with the changes"
                if to_apply
                else ""
            )
        )
        series = {"predicted_before": pb["series"], "predicted_after": pa["series"]}
    report = {
        "bowden_bench_calibration": 1,
        "device": client.link.url,
        "identification": {
            "file": ident.name,
            "seconds": len(seq) / tick_hz,
            "pieces": [asdict(p) for p in pieces],
        },
        "audit": {
            "dir": "audit",
            "mu": result.extended.params["mu"],
            "phi_rad": audit_phi(result.data),
            "findings": findings,
            "notes": notes,
            "holdout_rms_n": result.holdout_rms_after_n,
            "warnings": list(result.warnings),
        },
        "tare": tare,
        "device_phi_rad": phi_dev,
        "bend_map": None if bend is None else bend.to_dict(),
        "changes": [asdict(c) for c in changes],
        "verification": {**VERIFY, "seconds": VERIFY_SECONDS, "settle_s": SETTLE_S},
        "predicted": {k: _metrics(v) for k, v in pred.items()},
        "apply": opts.apply,
        "persist": opts.persist,
        "applied": [],
        "applied_kept": False,
        "persisted": False,
    }
    exit_code = 0
    if not to_apply:
        say(
            "nothing to change: the audit found no significant difference from the device's "
            "compensator values"
        )
    elif not opts.apply:
        say("(--apply writes them)")
    else:
        exit_code = _apply(
            client, opts, before_words, to_apply, state, report, series, after_run, say, progress
        )
    _write_reports(out, report, series)
    say(f"wrote {out / 'calibration.json'}, {out / 'calibration.md'}, {out / 'calibration.png'}")
    return Outcome(report, exit_code)


def map_sequence(tick_hz: float) -> np.ndarray:
    """The T_ref samples of the bending angle's map at each position: the identification's first
    bend_map.MAP_PIECES."""
    seq, pieces = identification_sequence(tick_hz)
    return seq[: int(round(pieces[bend_map.MAP_PIECES - 1].end_s * tick_hz))]


def _map_record(client, path: Path, position_m, after_run, opts, progress, tick_hz: float) -> Path:
    """Record the map's sequence at `position_m` into `path` (calibrate's run path: the device
    stopped afterwards however it ends)."""
    here = replace(opts, position_m=tuple(float(v) for v in position_m))
    stream_record(client, path, map_sequence(tick_hz), after_run, here, progress, tick_hz)
    return path


def make_bend_map(
    bench_at,
    positions,
    params: dict,
    phi_home_rad: float,
    tare_n: float,
    opts,
    say=print,
    progress=None,
) -> bend_map.BendMap:
    """The bending angle's map (cosim.bench.rig.bend_map) at `positions` around home
    (opts.position_m), written to opts.out_dir / bend_map.FILE with its recordings beside it
    (map_0.csv at home, map_1.csv, ...).
    `bench_at(p)` is a context manager that has the end-effector at p and gives (client,
    after_run): an emulated bench started there, or the user's rig moved there with the output
    off. params: home's audited model (FMU names), phi_home_rad the angle the audit saw it at,
    tare_n the far-end cell's tare. A position whose fit ends at a bound is left out (said);
    BendMapError when home's own fit does or no position is left."""
    home = tuple(float(v) for v in opts.position_m)
    points = []
    for i, p in enumerate((home, *positions)):
        with bench_at(p) as (client, after_run):
            tick_hz = float(client.get("tick_rate_hz"))
            path = _map_record(
                client, opts.out_dir / f"map_{i}.csv", p, after_run, opts, progress, tick_hz
            )
        try:
            pt = bend_map.point_of(path, p, params, phi_home_rad, tare_n)
        except bend_map.BendMapError as exc:
            if i == 0:
                raise bend_map.BendMapError(f"no map: home's own recording: {exc}") from None
            say(f"bending angle at {bend_map.show_position(p)} m: left out ({exc})")
            continue
        if i == 0:
            # home's own ratio: what home's model misses of the same sequence at home
            at_home = pt
            say(
                f"bending angle at home {bend_map.show_position(p)} m: {pt.ratio:.4f} x the "
                f"audit's (RMS {pt.rms_home_n:.4f} N, fitted {pt.rms_fit_n:.4f} N) -> {path.name}"
            )
            continue
        pt.ratio /= at_home.ratio
        say(
            f"bending angle at {bend_map.show_position(p)} m: {pt.ratio:.4f} x home's (RMS "
            f"against home's model {pt.rms_home_n:.4f} N, with the ratio {pt.rms_fit_n:.4f} N) "
            f"-> {path.name}"
        )
        points.append(pt)
    m = bend_map.fit_plane(home, points)
    m.home_ratio = at_home.ratio
    m.write(opts.out_dir / bend_map.FILE)
    return m


def _bend_map(bench_at, opts: Options, result, tare: dict, phi_dev: float, say, progress):
    """The bending angle's map (make_bend_map) after the audit, or None when it cannot be made
    (said; the calibration goes on: the map is the host's, nothing of it is written to the
    device)."""
    if bench_at is None:
        raise BenchUsageError("calibrate: a map of the bending angle needs bench_at")
    n = len(opts.map_positions)
    seconds = len(map_sequence(1000.0)) / 1000.0
    say(
        f"bending angle's map: {seconds:.1f} s at home and at each of {n} "
        f"position{'' if n == 1 else 's'} ..."
    )
    try:
        m = make_bend_map(
            bench_at,
            opts.map_positions,
            dict(result.extended.params),
            audit_phi(result.data),
            tare["offset_n"],
            opts,
            say=lambda line: say("  " + line),
            progress=progress,
        )
    except bend_map.BendMapError as exc:
        say(f"  no map of the bending angle: {exc}")
        return None
    g = ", ".join(f"{v:+.4f}" for v in m.gradient_per_m)
    say(
        f"  map: k(p) = 1 + ({g}) . (p - home) per m (largest miss {m.residual:.4f}); the host "
        f"sets comp.phi_rad = {phi_dev:.4f} * k(p) at each position ({bend_map.FILE})"
    )
    return m


def _metrics(m: dict) -> dict:
    return {k: v for k, v in m.items() if k != "series"}


def _verify(client, name, opts, after_run, progress, tare_n: float = 0.0):
    path = opts.out_dir / f"{name}.csv"
    _, cols = _record(client, path, after_run, opts, progress, seconds=VERIFY_SECONDS, **VERIFY)
    _check_far_end(cols, path)
    cols = {**cols, "T_out_N": cols["T_out_N"] - tare_n}  # the tension, not the sensor's error
    m = verification_error(cols)
    m["series"] = (cols["t_s"], cols["T_ref_N"], cols["T_out_N"])
    return m


def _apply(
    client, opts, before_words, to_apply, state, report, series, after_run, say, progress
) -> int:
    state.step = "the verification before the changes"
    say("verification before (the device's values) ...")
    tare_n = report["tare"]["offset_n"]
    vb = _verify(client, "verify_before", opts, after_run, progress, tare_n)
    todo = [(param(c.name), word_from_value(param(c.name), c.proposed)) for c in to_apply]
    state.step = "writing the changes"
    done = write_all(client, todo, "calibrate --apply")
    state.written.extend(p.name for p, _ in done)
    report["applied"] = {p.name: value_from_word(p, w) for p, w in done}
    for p, w in done:
        say(f"  wrote {p.name} = {format_value(p, w)}")
    state.step = "the verification after the changes"
    say("verification after (the calibrated values) ...")
    va = _verify(client, "verify_after", opts, after_run, progress, tare_n)
    series["measured_before"] = vb["series"]
    series["measured_after"] = va["series"]
    report["measured"] = {"before": _metrics(vb), "after": _metrics(va)}
    say(
        f"verification error on the device's T_out: RMS {vb['rms_error_n']:.3f} N "
        f"({vb['rms_error_pct']:.2f} %) -> {va['rms_error_n']:.3f} N "
        f"({va['rms_error_pct']:.2f} %), peak {vb['peak_error_n']:.2f} -> "
        f"{va['peak_error_n']:.2f} N"
    )
    if va["rms_error_n"] > vb["rms_error_n"]:
        say("bowden bench calibrate: the verification error rose: the changes are undone")
        return 1
    report["applied_kept"] = True
    if opts.persist:
        # the run parameters go back first (the caller's put-back would leave flash holding them)
        state.step = "saving in flash"
        _put_back(client, before_words, keep=state.written)
        seq = client.simple("PERSIST")
        report["persisted"] = True
        say(f"saved in flash (record {seq})")
    else:
        say("in RAM: `persist` (or calibrate --persist) saves them")
    return 0


def _write_reports(out: Path, report: dict, series: dict) -> None:
    write_atomic(out / "calibration.json", json.dumps(report, indent=2) + "\n")
    write_atomic(out / "calibration.md", markdown(report))
    _plot(out / "calibration.png", series)


def markdown(report: dict) -> str:
    """calibration.md: what was run, what the audit found, the changes and the errors."""
    lines = ["# Calibration", "", f"Device: {report['device']}", ""]
    tare = report.get("tare") or {}
    if tare.get("file"):
        lines += [
            f"Tare (`{tare['file']}`, {tare['seconds']:g} s at zero load): the far-end load cell "
            f"reads {tare['offset_n']:+.3f} N (spread {tare['spread_n']:.3f} N), taken off T_out "
            "before the audit and in the verification.",
            "",
        ]
    ident = report["identification"]
    lines += [
        f"## Identification ({ident['seconds']:.1f} s, `{ident['file']}`)",
        "",
        "| piece | from s | to s | why |",
        "| --- | --- | --- | --- |",
    ]
    lines += [
        f"| {p['name']} | {p['start_s']:.1f} | {p['end_s']:.1f} | {p['why']} |"
        for p in ident["pieces"]
    ]
    a = report["audit"]
    lines += [
        "",
        "## Audit (`audit/report.md`)",
        "",
        f"mu = {a['mu']:.5f} at phi = {a['phi_rad']:.4f} rad (mu*phi = "
        f"{a['mu'] * a['phi_rad']:.4f}); device phi = {report['device_phi_rad']:.4f} rad.",
        "",
        "Findings: "
        + (
            ", ".join(f"{f['cause']} ({f['param']} = {f['value']:.4g})" for f in a["findings"])
            or "none"
        )
        + ".",
    ]
    lines += [f"- note: {n}" for n in a["notes"]]
    lines += _bend_map_markdown(report)
    lines += [
        "",
        "## Changes",
        "",
        "| parameter | device | proposed | decision | reason |",
        "| --- | --- | --- | --- | --- |",
    ]
    for c in report["changes"]:
        prop = "" if c["proposed"] is None else f"{c['proposed']:.6g}"
        lines.append(
            f"| {c['name']} | {c['current']:.6g} | {prop} | {c['status']} | {c['reason']} |"
        )
    v = report["verification"]
    lines += [
        "",
        f"## Verification ({v['waveform']} {v['mean_n']:g} +- {v['amplitude_n']:g} N "
        f"at {v['freq_hz']:g} Hz, {v['seconds']:g} s, error from {v['settle_s']:g} s)",
        "",
        "| | RMS N | RMS % | peak N | peak % |",
        "| --- | --- | --- | --- | --- |",
    ]
    rows = [(f"predicted {k}", m) for k, m in report["predicted"].items()]
    rows += [(f"measured {k}", m) for k, m in report.get("measured", {}).items()]
    for label, m in rows:
        lines.append(
            f"| {label} | {m['rms_error_n']:.3f} | {m['rms_error_pct']:.2f} | "
            f"{m['peak_error_n']:.3f} | {m['peak_error_pct']:.2f} |"
        )
    lines += [
        "",
        f"Applied: {report['applied'] or 'nothing'}; kept: {report['applied_kept']}; "
        f"persisted: {report['persisted']}.",
        "",
        "![before/after](calibration.png)",
        "",
    ]
    return "\n".join(lines)


def _plot(path: Path, series: dict) -> None:
    if not series:  # neither predicted nor measured: nothing to draw
        return
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    measured = "measured_before" in series
    before = series["measured_before" if measured else "predicted_before"]
    after = series["measured_after" if measured else "predicted_after"]
    kind = "measured on the device" if measured else "predicted (emulated, audited plant)"
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 6), sharex=True, height_ratios=[2, 1.2])
    t, ref, tout = before
    ax1.plot(t, ref, color="k", lw=0.8, label="T_ref")
    ax1.plot(t, tout, color="tab:orange", lw=0.7, label="T_out before")
    ax1.plot(after[0], after[2], color="tab:blue", lw=0.7, label="T_out after")
    ax1.set_ylabel("tension [N]")
    ax1.legend(loc="upper right", fontsize=8)
    ax1.grid(alpha=0.3)
    ax1.set_title(f"verification: tracking before and after calibration ({kind})")
    ax2.plot(t, ref - tout, color="tab:orange", lw=0.6, label="T_ref - T_out before")
    ax2.plot(after[0], after[1] - after[2], color="tab:blue", lw=0.6, label="after")
    ax2.axvspan(0, SETTLE_S, color="0.9")
    ax2.set_ylabel("error [N]")
    ax2.set_xlabel("time [s]")
    ax2.legend(loc="upper right", fontsize=8)
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".png")
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=90)
        os.replace(tmp, path)
    finally:
        plt.close(fig)
        Path(tmp).unlink(missing_ok=True)


__all__ = [
    "AUDITED",
    "Change",
    "CalibrationError",
    "Options",
    "identification_sequence",
    "propose",
    "run_calibration",
]


def _bend_map_markdown(report: dict) -> list[str]:
    """calibration.md's section on the bending angle's map (none without one)."""
    m = report.get("bend_map")
    if not m:
        return []
    phi = report["device_phi_rad"]
    g = ", ".join(f"{v:+.4f}" for v in m["gradient_per_m"])
    home = ", ".join(f"{v:g}" for v in m["home_m"])
    lines = [
        "",
        "## Bending angle over the workspace (`bend_map.json`)",
        "",
        f"The map's sequence at home ({home}) m fits home's model with the bending angle times "
        f"{m['home_ratio']:.4f}; at each position, the ratio to that:",
        "",
        "| position m | k = phi / phi(home) | RMS with home's model N | RMS with k N | file |",
        "| --- | --- | --- | --- | --- |",
    ]
    for p in m["points"]:
        pos = ", ".join(f"{v:g}" for v in p["position_m"])
        lines.append(
            f"| {pos} | {p['ratio']:.4f} | {p['rms_home_n']:.4f} | {p['rms_fit_n']:.4f} | "
            f"`{p['file']}` |"
        )
    lines += [
        "",
        f"The plane k(p) = 1 + ({g}) . (p - home) per m misses the points by at most "
        f"{m['residual']:.4f}. The host that places the end-effector sets comp.phi_rad = "
        f"{phi:.4f} * k(p) at each position (`python -m cosim.bench.rig.bend_map "
        f"bend_map.json --phi-home {phi:.4f} --at X,Y,Z`); nothing of it is written to the device.",
    ]
    return lines
