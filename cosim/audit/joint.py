"""The audit's joint search (cosim.audit.core, step 4b): every cause at once, then taken out.

Forward selection (step 4) adds one cause a round, and a cause becomes a finding only when,
added alone to the model, it fits the selection blocks consistently. With several effects in
the data at once (a cable has them all: a tension slope, a slack, friction with the cable's
speed, a load cell's lag and gain) none of them does: each explains part of the residual in some
blocks and bends the model in others, so no round passes the rule, or the cause that passes is
one that stands in for several. On the tuning set of random plants a load cell's creep was
named where the plant had a slope, a slack and a wide spread of the dead zone, and nothing
followed it; the residual it left was a hundred times the noise.

The joint search comes from the other side (backward elimination, the counterpart of forward
selection in stepwise regression). It starts from the forward selection's findings and every other
cause that removed at least `core.FORM_SCREEN_PCT` % of the selection blocks' residual in some
round, all fitted together: in the form and from the value of its round where it removed most, none
whose shape ended at a bound. Every round counts, not only the first: a large effect hides the
smaller ones in round 1 (a slack of 4 N removed 95 %, a load cell's lag of 8 ms 0 %), and the model
they show in may have lost its finding to the backward check since. Causes are then taken out while
the decision rule does not need them: a cause stays only when the model with the rest refitted is
worse by the rule (decision.judge: what `decision._backward` asks of every finding).
- First, in one step, every cause whose removal, with the rest held at their values, costs less
  than the rule's least share of the selection blocks' residual or its least RMS. Assumption:
  refitting the rest only brings the model without it closer to the full one, so such a cause
  removes less still once the rest are refitted, and the rule cannot need it. (Only those two
  of the rule's tests shrink with the refit; the block t and the share of blocks improved do
  not: held, a breakaway's removal changes only the blocks after a reversal.) It saves the
  refits of the causes that are plainly absent, the larger part of the search's cost.
- Then one at a time, the cause whose removal costs least first, each judged with the rest
  refitted, until every cause left is needed.

Its model replaces the forward selection's only when the decision rule would take it as it takes a
finding: against the forward selection's model it removes the rule's share of the selection blocks'
residual, consistently over the blocks (decision.judge). Where its causes hold the forward
selection's, that is the rule's test of what it adds; where they differ, of the one explanation
against the other. The report blocks take no part in it. It runs only when the forward selection
left a residual on the selection blocks above JOINT_WHEN_ABOVE times the combined sensor noise and
sampling error: a record the forward selection explains needs no more, and costs nothing more.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from . import twin
from .data import REPORT, SELECT, AuditData
from .decision import Candidate, DecisionRule, Finding, Round, block_stats, judge
from .effects import Effect
from .fit import Model, fit_model

# The forward selection's residual on the selection blocks, in multiples of the combined sensor
# noise and sampling error, above which the joint search runs: the factor within which the
# audit's tests ask a named cause to bring the held-out residual (tests/audit/test_audit_rule.py,
# FLOOR_FACTOR). Below it the forward selection has reached the floor.
JOINT_WHEN_ABOVE = 2.0


@dataclass
class JointSearch:
    """What the joint search tried, what it kept and whether it replaced the forward selection."""

    started: tuple[str, ...]  # the causes of the full model
    kept: tuple[str, ...]
    dropped_held: tuple[str, ...]  # taken out with the rest held (the first step)
    dropped_refitted: tuple[str, ...]  # taken out one at a time, the rest refitted
    block_t: float  # the rule's block t of the joint model against the forward selection's
    taken: bool
    why: str
    model: Model | None = None
    withouts: dict[str, Model] = field(default_factory=dict)
    effects: tuple[Effect, ...] = ()

    def to_dict(self) -> dict:
        return {
            "started": list(self.started),
            "kept": list(self.kept),
            "dropped_with_the_rest_held": list(self.dropped_held),
            "dropped_with_the_rest_refitted": list(self.dropped_refitted),
            "block_t": None if not math.isfinite(self.block_t) else round(self.block_t, 4),
            "taken": self.taken,
            "why": self.why,
        }


def combined_noise_n(data: AuditData) -> float:
    """The combined sensor noise and sampling error (DecisionRule.min_rms_n's sum)."""
    return math.sqrt(data.noise_floor_n**2 + data.input_noise_n**2 + data.sampling_error_n**2)


def wanted(data: AuditData, forward: Model) -> bool:
    """Whether the forward selection left more than the floor on the selection blocks."""
    return forward.rms(data, SELECT) > JOINT_WHEN_ABOVE * combined_noise_n(data)


def search(
    data: AuditData,
    rounds: list[Round],
    forward: Model,
    baseline: Model,
    rule: DecisionRule,
    min_pct: float,
) -> JointSearch | None:
    """The joint search (module docstring) from the forward selection's model and the
    candidates of its rounds; None when no other cause qualifies for the full model."""
    named = {e.cause for e in forward.effects}
    best: dict[str, Candidate] = {}
    for rnd in rounds:
        for c in rnd.candidates:
            if c.effect.cause in named or c.at_bound is not None or c.explained_pct < min_pct:
                continue
            if c.effect.cause not in best or c.explained_pct > best[c.effect.cause].explained_pct:
                best[c.effect.cause] = c
    cands = list(best.values())
    effects = [*forward.effects, *(c.effect for c in cands)]
    if len(effects) < 2 or not cands:
        return None
    started = tuple(e.cause for e in effects)
    # from the forward selection's model, each other cause at the value of its best round
    start = dict(forward.params)
    for c in cands:
        start.update({p: c.model.params[p] for p in c.effect.fmu_params})
    full = fit_model(data, tuple(effects), start)

    # 1. every cause that removes too little even with the rest held (one step)
    min_rms_n = rule.min_rms_n(data.noise_floor_n, data.input_noise_n, data.sampling_error_n)
    held_out: list[Effect] = []
    for e in effects:
        params = {k: v for k, v in full.params.items() if k not in e.fmu_params}
        without = Model(
            tuple(f for f in effects if f is not e), params, twin.simulate(data.inputs, params)
        )
        stats = block_stats(data, without.residual(data), full.residual(data))
        if stats.explained_pct < rule.min_explained_pct or stats.removed_rms_n < min_rms_n:
            held_out.append(e)
    if held_out:
        effects = [e for e in effects if e not in held_out]
        gone = {p for e in held_out for p in e.fmu_params}
        start = {k: v for k, v in full.params.items() if k not in gone}
        full = fit_model(data, tuple(effects), start) if effects else baseline

    # 2. one at a time, the rest refitted, the one whose removal costs least first
    refitted_out: list[Effect] = []
    withouts: dict[str, Model] = {}
    while effects:
        withouts = {}
        weakest = None
        for e in effects:
            rest = tuple(f for f in effects if f is not e)
            start = {k: v for k, v in full.params.items() if k not in e.fmu_params}
            without = fit_model(data, rest, start) if rest else baseline
            withouts[e.cause] = without
            stats, needed = judge(data, without, full, rule)
            if not needed and (weakest is None or stats.explained_pct < weakest[1]):
                weakest = (e, stats.explained_pct)
        if weakest is None:
            break
        effects.remove(weakest[0])
        refitted_out.append(weakest[0])
        full = withouts[weakest[0].cause]

    kept = tuple(e.cause for e in effects)
    stats = judge(data, forward, full, rule) if effects else None
    if stats is None:
        taken, why = False, "the rule needs none of the causes together"
    elif set(kept) == {e.cause for e in forward.effects}:
        taken, why = False, "the same causes as the forward selection"
    else:
        st, taken = stats
        why = (
            f"against the forward selection's model it removes {st.explained_pct:.0f} % of the "
            f"selection blocks' residual (block t = {st.t:.1f}, better in "
            f"{100 * st.improved_share:.0f} % of them): "
            + ("the rule takes it" if taken else "the rule does not take it")
        )
    return JointSearch(
        started=started,
        kept=kept,
        dropped_held=tuple(e.cause for e in held_out),
        dropped_refitted=tuple(e.cause for e in refitted_out),
        block_t=stats[0].t if stats else -math.inf,
        taken=taken,
        why=why,
        model=full if effects else None,
        withouts=withouts,
        effects=tuple(effects),
    )


def findings(data: AuditData, js: JointSearch, baseline: Model, rule: DecisionRule) -> list:
    """The joint search's causes as findings, in order of importance: each with the share of the
    baseline's report-block residual that the model loses without it (the rest refitted), and
    the rule's statistics of the full model against that model on the selection blocks."""
    base_ms = baseline.ms(data, REPORT)
    full_ms = js.model.ms(data, REPORT)
    out = []
    for e in js.effects:
        without = js.withouts[e.cause]
        stats, _ = judge(data, without, js.model, rule)
        out.append(
            Finding(
                effect=e,
                value=float(js.model.params[e.fmu_param]),
                explains_pct=100.0 * (without.ms(data, REPORT) - full_ms) / base_ms
                if base_ms > 0
                else 0.0,
                selection_pct=stats.explained_pct,
                t=stats.t,
                improved_share=stats.improved_share,
                runner_up=None,
                runner_up_pct=None,
                separation_t=None,
            )
        )
    return sorted(out, key=lambda f: -f.explains_pct)
