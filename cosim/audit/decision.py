"""The audit's decision (cosim.audit.core, step 4): when a candidate becomes a finding."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .data import FIT, REPORT, SELECT, AuditData
from .effects import Effect
from .fit import Model, fit_model


@dataclass(frozen=True)
class DecisionRule:
    """When a candidate becomes a finding (a stated rule, thresholds written once).

    The selection blocks are the folds. Adding the candidate to the current model (every
    parameter refitted on the fit blocks) must, on the selection blocks,
    - remove at least `min_explained_pct` % of their residual mean square;
    - remove it consistently: a block t of at least `min_block_t`, the per-block drops of the
      mean square d_j against the per-block size of the candidate's change of the prediction
      v_j (block_stats: a weighted t over the blocks). This takes the significance from the
      residual's block-to-block variability, not from white noise: with structure the model
      lacks, a candidate that bends the model a little helps some blocks and hurts others, and
      against white sensor noise alone such a candidate got z of 96 and 299 on rig data while
      it made the held-out fit worse. The drops are judged per unit of the change the
      candidate makes in the block (d_j = g v_j + e_j, Var e_j proportional to v_j: what white
      noise gives, 4 sigma^2 v_j / N_j): an effect whose size follows the block (a creep or a
      tension slope, large where the tension moves or is high, nothing elsewhere) is as
      consistent as one of constant size, where the t of the plain drops (all v_j equal)
      counted its large blocks' drops as spread (a 0.5 N offset with a tension slope of
      1.2e-3/N got the slope's block t of 1.99, a creep of 5 % 1.98);
    - improve at least `min_improved_share` of the blocks (a sign test over the blocks: it does
      not ask every block to gain as much, as the t does, so an effect that lives where the
      input moves fast, or late in the record, is not penalised for the quiet blocks; and it
      does not ask that no block gets worse: with two effects in the data the right one, added
      alone, made one block in twelve worse by up to 90 % while the mu refitted with it
      absorbed part of the other effect there);
    - remove at least `min_effect_rms_n` of RMS (1/256 N: one LSB of the project's Q7.8
      tensions; a smaller effect is below what the controller can act on) and at least
      `min_effect_noise_ratio` times the combined sensor noise and sampling error
      sqrt(sigma_out^2 + sigma_in^2 + sampling^2): the input's sensor noise, smoothed, still
      passes through the dead zone of the friction model as a structured residual (an
      errors-in-variables bias of a hysteresis) that a candidate can partly absorb; the record
      gives the input at its sample instants only, and where between two samples it reaches
      its extremes, which the friction model holds, is unknown (sampling_error).
    A candidate whose form's shape (a time constant, a knee: effects.Shape) ends at a bound of its
    range that is not a value of the form is not significant, whatever it removes: the data ask
    for a value the form does not have, and the cause stands in for something else (a load
    cell's creep at its fastest acts as a lead and took the place of the timing of a friction).
    The largest such candidate is taken. It is marked ambiguous when the runner-up stops being
    significant once it is in the model and the two differ by a block t (fit and selection
    blocks) under `separation_t`. At most `max_findings` rounds. The report blocks take no part
    in any of it. The thresholds were chosen on the tuning cases of tests/audit/test_audit_rule.py
    and are reported on the other cases there.
    """

    min_explained_pct: float = 2.0
    min_block_t: float = 2.0
    min_improved_share: float = 0.75
    min_effect_rms_n: float = 1.0 / 256.0
    min_effect_noise_ratio: float = 0.5
    separation_t: float = 2.0
    max_findings: int = 4

    def min_rms_n(self, noise_out_n: float, noise_in_n: float, sampling_n: float = 0.0) -> float:
        """The smallest RMS a finding must remove on data with these sensor noises and this
        sampling error."""
        combined = math.sqrt(noise_out_n**2 + noise_in_n**2 + sampling_n**2)
        return max(self.min_effect_rms_n, self.min_effect_noise_ratio * combined)

    def text(self) -> str:
        return (
            f"a finding removes >= {self.min_explained_pct:g} % of the selection blocks' residual "
            f"mean square, consistently over the selection blocks (block t >= "
            f"{self.min_block_t:g} from the blocks' own spread, each block's drop taken per "
            "unit of the change the candidate makes there, >= "
            f"{100 * self.min_improved_share:.0f} % of the blocks better), and >= "
            f"{self.min_effect_rms_n * 1000:.1f} mN RMS and {self.min_effect_noise_ratio:g} x the "
            "combined sensor noise and sampling error, and its form's time constant or knee is not "
            "at a bound of its range; the largest is taken, then the next round; the report "
            "blocks take no part"
        )

    def passes(self, stats: BlockStats, data: AuditData) -> bool:
        return (
            stats.explained_pct >= self.min_explained_pct
            and stats.t >= self.min_block_t
            and stats.improved_share >= self.min_improved_share
            and stats.removed_rms_n
            >= self.min_rms_n(data.noise_floor_n, data.input_noise_n, data.sampling_error_n)
        )


RULE = DecisionRule()


@dataclass(frozen=True)
class BlockStats:
    """How a model b fits the blocks of some roles against a model a (block_stats)."""

    explained_pct: float  # share of a's mean square over those blocks that b removes
    removed_rms_n: float  # sqrt of the mean-square drop (0 when b is worse)
    t: float  # the drop per unit of b's change over its standard error from the blocks' spread
    improved_share: float  # share of blocks where b fits better
    worst_z: float  # the most negative per-block drop in white-noise standard errors (shown only)
    blocks: int
    per_block_pct: tuple[float, ...]  # each block's drop, % of a's mean square in it
    t_plain: float = 0.0  # the t of the plain per-block drops (every block weighs the same)


# A t or z without a spread (identical blocks) is capped here, not infinite: audit.json has no inf.
T_CAP = 1e9


def block_stats(
    data: AuditData,
    r_a: np.ndarray,
    r_b: np.ndarray,
    roles: tuple[int, ...] = (SELECT,),
    weighted: bool = True,
) -> BlockStats:
    """Residual r_b against r_a block by block (DecisionRule). Per block j of the roles: the
    drop of the mean square d_j = mean(r_a^2 - r_b^2) and the size of b's change of the
    prediction v_j = mean((r_a - r_b)^2). t is the weighted least-squares slope of d_j on v_j
    (through 0, Var d_j proportional to v_j) over its standard error from the blocks' spread:
    g = sum(d) / sum(v), s^2 = sum((d_j - g v_j)^2 / v_j) / (K - 1), t = g sqrt(sum v) / s
    (blocks with v_j = 0 have d_j = 0 and no weight); with weighted=False every v_j is 1, the
    one-sample t of the drops, mean(d) / (sd(d) / sqrt(K)) (t_plain). A block's z =
    sum(r_a^2 - r_b^2) / (2 sigma sqrt(sum (r_a - r_b)^2)), what white noise of the noise floor
    sigma alone would make of it."""
    sq_a = r_a * r_a
    sq_b = r_b * r_b
    drops, sizes, pcts, zs = [], [], [], []
    for idx in data.block_indices(roles):
        da = float(np.sum(sq_a[idx]))
        d = da - float(np.sum(sq_b[idx]))
        delta = r_a[idx] - r_b[idx]
        dd = float(delta @ delta)
        se = 2.0 * data.noise_floor_n * math.sqrt(dd)
        drops.append(d / len(idx))
        sizes.append(dd / len(idx))
        pcts.append(100.0 * d / da if da > 0 else 0.0)
        zs.append(d / se if se > 0 else (0.0 if d == 0 else math.copysign(T_CAP, d)))
    m = np.isin(data.roles, roles)
    ms_a = float(np.mean(sq_a[m]))
    removed = ms_a - float(np.mean(sq_b[m]))
    k = len(drops)
    d = np.asarray(drops)
    t_plain = _slope_t(d, np.ones(k))
    return BlockStats(
        explained_pct=100.0 * removed / ms_a if ms_a > 0 else 0.0,
        removed_rms_n=math.sqrt(max(removed, 0.0)),
        t=_slope_t(d, np.asarray(sizes)) if weighted else t_plain,
        improved_share=float(np.mean(d > 0)) if k else 0.0,
        worst_z=float(min(zs)) if zs else 0.0,
        blocks=k,
        per_block_pct=tuple(pcts),
        t_plain=t_plain,
    )


def _slope_t(d: np.ndarray, v: np.ndarray) -> float:
    """t of g in d_j = g v_j + e_j, Var e_j proportional to v_j (block_stats); capped."""
    use = v > 0
    d, v = d[use], v[use]
    k = len(d)
    total = float(np.sum(v))
    if k == 0 or total <= 0:
        return 0.0
    g = float(np.sum(d)) / total
    s2 = float(np.sum((d - g * v) ** 2 / v)) / (k - 1) if k > 1 else 0.0
    if s2 > 0:
        return max(-T_CAP, min(T_CAP, g * math.sqrt(total) / math.sqrt(s2)))
    return 0.0 if g == 0 else math.copysign(T_CAP, g)


@dataclass
class Candidate:
    """One candidate tried in one round: its fitted model and its selection-block statistics."""

    effect: Effect
    model: Model
    stats: BlockStats
    significant: bool
    # the cause's forms fitted in this round (effects.FORMS), each with the share of the
    # selection blocks' residual it removed; empty when only the first form was fitted
    forms: dict[str, float] = field(default_factory=dict)
    # why its fit is not an estimate of its form (a shape at a bound: effects.Shape.at_bound);
    # such a candidate is not significant, whatever it removes
    at_bound: str | None = None

    @property
    def explained_pct(self) -> float:  # of the current model's selection-block mean square
        return self.stats.explained_pct

    @property
    def removed_rms_n(self) -> float:
        return self.stats.removed_rms_n

    @property
    def t(self) -> float:
        return self.stats.t


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
    t: float  # block t on the selection blocks (DecisionRule)
    improved_share: float  # share of the selection blocks it fits better
    runner_up: str | None
    runner_up_pct: float | None
    separation_t: float | None
    ambiguous_with: str | None = None
    evidence: str = ""
    forms: dict[str, float] = field(default_factory=dict)  # Candidate.forms of its round


def judge(
    data: AuditData, without: Model, with_: Model, rule: DecisionRule
) -> tuple[BlockStats, bool]:
    """The decision rule for `with_` against `without` on the selection blocks."""
    stats = block_stats(data, without.residual(data), with_.residual(data))
    return stats, rule.passes(stats, data)


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
            start = {k: v for k, v in full.params.items() if k not in e.fmu_params}
            withouts[e.cause] = fit_model(data, rest, start) if rest else steps[0]
            if len(found) > 1 and not judge(data, withouts[e.cause], full, rule)[1]:
                found.remove(e)
                dropped.append(e.cause)
                steps = [steps[0]]
                for i in range(1, len(found) + 1):
                    steps.append(fit_model(data, tuple(found[:i]), withouts[e.cause].params))
                break
        else:
            return found, steps, dropped, withouts


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
            sep = block_stats(
                data,
                runner.model.residual(data),
                c.model.residual(data),
                (FIT, SELECT),
                weighted=False,
            ).t
            nxt = rounds[i + 1] if i + 1 < len(rounds) else None
            still = nxt is not None and any(
                o.effect.cause == runner.effect.cause and o.significant for o in nxt.candidates
            )
            if runner.significant and not still and sep < rule.separation_t:
                ambiguous = runner.effect.cause
        before = withouts[c.effect.cause].ms(data, REPORT)
        out.append(
            Finding(
                effect=c.effect,
                value=float(c.model.params[c.effect.fmu_param]),
                explains_pct=100.0 * (before - full_ms) / base_ms if base_ms > 0 else 0.0,
                selection_pct=c.explained_pct,
                t=c.t,
                improved_share=c.stats.improved_share,
                runner_up=runner.effect.cause if runner else None,
                runner_up_pct=runner.explained_pct if runner else None,
                separation_t=sep,
                ambiguous_with=ambiguous,
                forms=dict(c.forms),
            )
        )
    # the final values are those of the extended model (refitted with every finding)
    final = steps[-1].params
    for f in out:
        f.value = float(final[f.effect.fmu_param])
    return sorted(out, key=lambda f: -f.explains_pct)
