"""The model audit: fit the nominal model to measured data, name what it gets wrong from the
vocabulary (cosim.audit.effects), extend the model, and measure the gain on data no fit saw.

The steps (modules: data, fit, decision, residual):

1. **Data.** A measured trace (cosim.results.trace, mode "measured"): the input tension drives
   the model, the output tension is what it must predict. Above MAX_RATE_HZ the record is
   decimated (a
   zero-phase FIR); the input tension is smoothed with a Savitzky-Golay filter (SMOOTH_S) so that
   its sensor noise does not enter the friction model as false reversals (an errors-in-variables
   bias: the capstan's dead zone would hold every noise peak), except across fast changes, which
   are kept as measured (smooth_input: the filter would ring there). The record is cut into
   blocks of BLOCK_S that take turns as fit, selection, fit, report blocks (after WARMUP_S), so
   each role covers the whole record and every position: parameters are fitted on the fit blocks
   only, the decision is taken on the selection blocks, and the gain is measured on the report
   blocks, which nothing else saw.
2. **Baseline.** The FMU's nominal physics (capstan friction with the dead zone, phi from the
   geometry) fitted with mu (the product mu*phi when there are no positions) and the spread of
   the friction thresholds that makes the dead zone's turn gradual (dead_zone_spread). Narrow
   lines in its residual that the input does not explain (mains pickup, a motor's cogging:
   cosim.audit.lines) are taken out of the output, fitted on the fit blocks, and the baseline
   is fitted again: no cause makes such a line, so none may be judged on one.
3. **Candidates.** Each cause of the vocabulary is added in turn to the current model and all
   parameters are refitted together on the fit blocks; its score is the share of the selection
   blocks' residual mean square it removes.
4. **Decision** (decision.DecisionRule, thresholds written once): forward selection; a candidate
   is a finding only when it improves the fit consistently over the selection blocks, each
   block a fold, with its significance taken from the blocks' own spread (not from white
   noise); among such candidates the one removing most is taken, and the round repeats with it
   in the model. A finding whose runner-up explained the same residual (it stops being
   significant once the finding is in) and that did not beat it significantly is marked
   ambiguous, naming the alternative. When the residual it leaves is still above twice the
   combined noise, the joint search (cosim.audit.joint) fits every cause that showed in some round
   together with the findings and takes causes out while the rule does not need them; its model
   replaces the forward selection's when the rule takes it against that model.
5. **Report.** The baseline and the extended model are run through the FMU itself (drive mode 1,
   the measured input tension and positions, one internal step per sample: twin.fmu_step_for);
   their residuals on the report blocks are the gain (of the output less its lines). What is
   left (of the output as measured) is described: size, whiteness, dominant frequency, its
   lines, the signals it follows.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from . import blas, drift_table, free_forms, joint, lines, plausible, twin
from .data import (  # noqa: F401 (the audit's names, one import away)
    BLOCK_TARGET_COUNT,
    COVER_MIN,
    FIT,
    PERIODIC_MIN_R,
    REPORT,
    SELECT,
    SMOOTH_ORDER,
    SMOOTH_S,
    WARMUP,
    WARMUP_S,
    AuditData,
    AuditError,
    _pattern,
    _roles,
    input_period_s,
    noise_std,
    phase_coverage,
    prepare,
    quantization_step,
    smooth_input,
)
from .decision import (  # noqa: F401
    RULE,
    BlockStats,
    Candidate,
    DecisionRule,
    Finding,
    Round,
    _backward,
    _findings,
    block_stats,
    judge,
)
from .effects import FORMS, VOCABULARY, Effect
from .fit import Model, fit_model
from .free_forms import FreeForm
from .residual import describe_residual


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
    warnings: list[str] = field(default_factory=list)  # plausible: one line per reason
    extras: dict = field(default_factory=dict)
    # the free forms tried, taken or not, in the order tried: the drift's table
    # (cosim.audit.drift_table), the bending error's surface and the slack's table
    # (cosim.audit.free_forms)
    free_forms: list[FreeForm] = field(default_factory=list)

    @property
    def free_form(self) -> FreeForm | None:
        """The first free form tried, or None."""
        return self.free_forms[0] if self.free_forms else None

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
    """The audit of prepared data (module docstring); progress(message, fraction) while it fits.
    OpenBLAS runs on one thread meanwhile (cosim.audit.blas: the fits' products are small)."""
    with blas.one_thread():
        return _run(data, rule, progress)


def _run(data: AuditData, rule: DecisionRule, progress: Progress | None) -> AuditResult:
    import time  # noqa: PLC0415

    t_start = time.perf_counter()
    say = progress or (lambda msg, frac: None)
    # a cause is fitted when one of its forms can be (the bending error when x, y or z moves),
    # in the first form that can; it is skipped with its first form's reason otherwise
    usable = [fs[0] for fs in (_applicable_forms(data, e) for e in VOCABULARY) if fs]
    skipped = {
        e.cause: e.applicable(data.has_positions, data.spans_m)
        for e in VOCABULARY
        if e.cause not in {u.cause for u in usable}
    }
    total = 2 + len(usable) * 2 + 5
    done = 0

    def tick(msg: str) -> None:
        nonlocal done
        done += 1
        say(msg, min(1.0, done / total))

    tick("fitting the nominal model (capstan friction, dead zone, phi from the geometry)")
    baseline = fit_model(data, ())
    found_lines = lines.find(data, data.t_out_n - baseline.prediction, rule.min_effect_rms_n)
    if found_lines:
        # no cause makes a line the input does not have: taken out of the output before any
        # candidate is fitted or judged, so that none can stand in for it (cosim.audit.lines)
        tick("taking the residual's lines out of the output; fitting the nominal model again")
        data.lines_n = lines.remove(found_lines, data.t_s)
        data.lines = tuple(found_lines)
        data.t_out_n = data.t_out_n - data.lines_n
        data.noise_floor_n = noise_std(data.t_out_n)
        baseline = fit_model(data, ())
    data.sampling_error_n = sampling_error(data, baseline.prediction)
    current = baseline
    steps = [baseline]
    rounds: list[Round] = []
    found: list[Effect] = []
    for _ in range(rule.max_findings):
        cands: list[Candidate] = []
        r0 = current.residual(data)
        for e in usable:
            if e.cause in {f.cause for f in found}:
                continue
            tick(f"round {len(rounds) + 1}: {e.cause} ({e.fmu_param})")
            cands.append(_candidate(data, found, e, current, r0, rule))
        sig = sorted((c for c in cands if c.significant), key=lambda c: -c.explained_pct)
        chosen = sig[0] if sig else None
        rounds.append(Round(current, cands, chosen, dict(skipped)))
        _release_predictions(cands, chosen)
        if chosen is None:
            break
        found.append(chosen.effect)
        current = chosen.model
        steps.append(current)
    every_round = list(rounds)  # before the backward check drops any (the joint search's)
    dropped: list[str] = []
    withouts = {found[0].cause: steps[0]} if len(found) == 1 else {}
    if len(found) > 1:
        tick("checking each finding against the model without it")
        found, steps, dropped, withouts = _backward(data, found, steps, rule)
        current = steps[-1]
        rounds = [r for r in rounds if r.chosen is None or r.chosen.effect in found]
    findings = _findings(data, rounds, steps, withouts, rule)
    # several effects at once: every cause together, then taken out (cosim.audit.joint)
    searched = None
    if every_round and joint.wanted(data, current):
        tick("the joint search: every cause together, then taken out while the rule allows")
        searched = joint.search(data, every_round, current, baseline, rule, FORM_SCREEN_PCT)
        if searched is not None and searched.taken:
            found = list(searched.effects)
            current = searched.model
            steps = [baseline, current]
            findings = joint.findings(data, searched, baseline, rule)
    # a drift finding whose fixed forms leave the residual above the noise: its free form, the
    # drift table (cosim.audit.drift_table), in its place when it fits the selection blocks better
    tried = []
    for fit_free in (drift_table.fit_free_form, *free_forms.FITS) if findings else ():
        # the bending error's surface and the slack's table (cosim.audit.free_forms) likewise,
        # each against the model with the free forms taken before it
        free = fit_free(data, found, current, rule)
        if free is not None:
            tried.append(free)
            if free.accepted:
                current = free.model
    if tried:
        tick("fitted the free forms of " + ", ".join(f.fixed.cause for f in tried))
    stand_ins: list[str] = []
    if any(f.accepted for f in tried) and len(findings) > 1:
        found, current, stand_ins = _stand_ins_dropped(data, found, current, tried, rule)
        findings = [f for f in findings if f.effect in found]

    tick("running the nominal model through the FMU")
    step = twin.fmu_step_for(data.inputs.dt_s)
    fmu_base = twin.run_fmu(data.inputs, baseline.params, max_step_s=step)
    tick("running the extended model through the FMU")
    fmu_ext = (
        twin.run_fmu(data.inputs, current.params, max_step_s=step) if findings else fmu_base.copy()
    )
    diff = float(np.max(np.abs(fmu_ext - current.prediction)))
    tick("describing what is left")
    unexplained = describe_residual(data, data.t_out_meas_n - fmu_ext, rule.min_effect_rms_n)
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
        free_forms=tried,
    )
    for f in findings:
        f.evidence = _evidence(result, f)
    result.warnings = plausibility_warnings(data, result)
    if dropped:
        result.extras["dropped_by_backward_check"] = dropped
    if searched is not None:
        result.extras["joint_search"] = searched.to_dict()
    if stand_ins:
        result.extras["dropped_after_free_form"] = stand_ins
    result.wall_s = time.perf_counter() - t_start
    return result


# A cause's further forms (effects.FORMS) are fitted only when its first form removes at least
# this share (%) of the selection blocks' residual mean square: the rule's minimum share, so a
# cause that could not become a finding in any form that resembles its first costs no more fits.
FORM_SCREEN_PCT = RULE.min_explained_pct


def _applicable_forms(data: AuditData, e: Effect) -> list[Effect]:
    """The forms of e's cause that can be fitted on these data, the first form first."""
    return [
        f
        for f in FORMS.get(e.cause, (e,))
        if f.applicable(data.has_positions, data.spans_m) is None
    ]


def _candidate(
    data: AuditData,
    found: list[Effect],
    e: Effect,
    current,
    r0: np.ndarray,
    rule: DecisionRule,
) -> Candidate:
    """The cause of `e` added to the current model in its best form. Every parameter is
    refitted together (a finding fitted alone absorbs part of an effect not yet in the model:
    an offset takes some of a tension-dependent friction). The form is chosen as the cause is,
    on the selection blocks only: the first form, unless others fit those blocks better by a
    block t of the rule's separation_t, and then the one of those that passes the rule and
    removes most; the others' shares are kept for the report (Candidate.forms)."""

    def fit(form: Effect) -> Candidate:
        m = fit_model(data, (*found, form), current.params)
        stats = block_stats(data, r0, m.residual(data))
        # a form whose shape ends at a bound that is not one of its values is not an estimate
        # of that form, however much it removes (effects.Shape.at_bound)
        why = next((w for sh in form.shape if (w := sh.at_bound(m.params[sh.fmu_param]))), None)
        return Candidate(form, m, stats, rule.passes(stats, data) and why is None, at_bound=why)

    first = fit(e)
    forms = [first]
    screen = first.explained_pct >= FORM_SCREEN_PCT
    forms += [
        fit(f) for f in _applicable_forms(data, e) if f is not e and (screen or not f.screened)
    ]
    # another form replaces the first only when it fits the selection blocks better by a block
    # t of the rule's separation (the plain t of the per-block differences): a warm-up with a
    # long time constant is a linear drift, and the simpler, first form stays then
    r_first = first.model.residual(data)
    better = [
        c
        for c in forms[1:]
        if block_stats(data, r_first, c.model.residual(data), (SELECT,), weighted=False).t
        >= rule.separation_t
    ]
    best = max(better, key=lambda c: (c.significant, c.explained_pct)) if better else first
    best.forms = {c.effect.form: c.explained_pct for c in forms} if len(forms) > 1 else {}
    for c in forms:
        if c is not best:
            c.model.prediction = None
    return best


def _release_predictions(cands: list[Candidate], chosen: Candidate | None) -> None:
    """Free the full-length predictions of a round's candidates that nothing reads again (all
    but the chosen one and its runner-up, which _findings compares): on 20 minutes of 1 kHz data
    each is 10 MB, some 30 of them per audit."""
    if chosen is None:
        keep: set[int] = set()
    else:
        others = sorted((c for c in cands if c is not chosen), key=lambda c: -c.explained_pct)
        keep = {id(chosen), *(id(c) for c in others[:1])}
    for c in cands:
        if id(c) not in keep:
            c.model.prediction = None


def plausibility_warnings(data: AuditData, result: AuditResult) -> list[str]:
    """The data's and the fit's plausibility (cosim.audit.plausible): T_out above T_in while
    loading, mu or a finding's parameter at the bound of its range."""
    from .fit import MU_BOUNDS  # noqa: PLC0415

    out = plausible.data_warnings(data.inputs.t_in_n, data.t_out_n, data.rate_n_s)
    if not data.mu_fixed:
        why = plausible.at_bound("mu", result.extended.params["mu"], *MU_BOUNDS)
        if why:
            out.append(why)
    for f in result.findings:
        why = plausible.at_bound(f.effect.fmu_param, f.value, *f.effect.bounds)
        if why:
            out.append(f"{f.effect.cause}: {why}")
    why = twin_fmu_warning(result.twin_fmu_max_diff_n, data.noise_floor_n)
    if why:
        out.append(why)
    return out


# The fitting twin and the FMU must agree far below the noise (a test holds them within 1e-4 N
# under strong effects); beyond this share of the noise floor the report says by how much.
TWIN_FMU_MAX_FLOOR_SHARE = 0.1


def twin_fmu_warning(diff_n: float, noise_floor_n: float) -> str | None:
    """One line when the twin that fitted and decided and the FMU that reports differ by more
    than TWIN_FMU_MAX_FLOOR_SHARE of the noise floor (or by a non-finite amount), else None."""
    if math.isfinite(diff_n) and diff_n <= TWIN_FMU_MAX_FLOOR_SHARE * noise_floor_n:
        return None
    return (
        f"the fitting twin and the FMU differ by up to {diff_n * 1000:.1f} mN "
        f"({diff_n / noise_floor_n:.2g} x the noise floor) on the extended model: the held-out "
        "figures are the FMU's, the fits and the decision the twin's"
        if noise_floor_n > 0
        else f"the fitting twin and the FMU differ by up to {diff_n * 1000:.1f} mN"
    )


def sampling_error(data: AuditData, prediction: np.ndarray) -> float:
    """The prediction's uncertainty from the sampling of its input (DecisionRule): the RMS of
    its change over one sample / sqrt(12), over the scored record."""
    step = np.diff(prediction)[data.roles[1:] != WARMUP]
    return float(np.sqrt(np.mean(step * step)) / math.sqrt(12.0)) if step.size else 0.0


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


def _stand_ins_dropped(
    data: AuditData, found: list[Effect], current: Model, tried: list[FreeForm], rule
) -> tuple[list[Effect], Model, list[str]]:
    """The backward check (decision._backward) again once a free form is taken: a finding of
    another cause that the rule no longer needs beside it (it stood in for what the fixed form's
    shape missed) is dropped, the model refitted without it with the free form held; repeated
    until none drops."""
    free_causes = {f.fixed.cause for f in tried if f.accepted}
    found = list(found)
    dropped: list[str] = []
    while True:
        for e in found:
            if e.cause in free_causes:
                continue
            rest = tuple(f for f in current.effects if f is not e)
            start = {k: v for k, v in current.params.items() if k not in e.fmu_params}
            without = fit_model(data, rest, start)
            if not judge(data, without, current, rule)[1]:
                found.remove(e)
                dropped.append(e.cause)
                current = without
                break
        else:
            return found, current, dropped


def finding_params(result: AuditResult, f: Finding) -> dict[str, float]:
    """The extended model's parameters with the finding's own value: where a free form took the
    place of its fixed form (cosim.audit.drift_table, cosim.audit.free_forms), the fixed form's
    parameter is off in the extended model (or one of the free form's coefficients), and the
    finding shows what that form fitted."""
    return {**result.extended.params, f.effect.fmu_param: f.value}


def _evidence(result: AuditResult, f: Finding) -> str:
    """One sentence: why this cause, in numbers."""
    text = (
        f"{f.effect.describe_all(finding_params(result, f))} removes {f.selection_pct:.0f} % of "
        f"the residual on the selection blocks (block t = {f.t:.1f}, better in "
        f"{100 * f.improved_share:.0f} % of them)"
    )
    if f.runner_up is not None and f.runner_up_pct is not None:
        text += f"; the next candidate, {f.runner_up}, removes {max(f.runner_up_pct, 0):.0f} %"
        if f.separation_t is not None and math.isfinite(f.separation_t):
            text += f" (worse by block t = {f.separation_t:.1f})"
    if f.forms:
        others = ", ".join(
            f"{name} {max(pct, 0):.0f} %" for name, pct in f.forms.items() if name != f.effect.form
        )
        text += f"; its form {f.effect.form} was chosen over {others} on the selection blocks"
    if f.ambiguous_with:
        text += (
            f"; {f.ambiguous_with} explains the same residual and is not significantly worse, "
            "so the two are not told apart by these data"
        )
    return text + "."
