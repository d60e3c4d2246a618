"""Free forms of a named cause (cosim.audit.core, after the decision) besides the drift's table
(cosim.audit.drift_table): the same physics in a flexible shape, for a finding whose fixed forms
leave the selection blocks above FLOOR_FACTOR times the noise floor.

- The bending error's surface: phi_eff = phi + sum_a c_a a + sum_ab c_ab a b (fmu/README.md
  "Bending angle error"), the three linear terms (the fixed forms' phi_offset_per_x, _y, _z,
  together: a bending along a learned direction) and the six quadratic ones
  (phi_offset_per_xx ..), in place of the one coordinate a fixed form follows. The penalty is
  a ridge on the quadratic terms: its largest weight leaves the plane.
- The slack's table: the share of the output lost, L(T_in), on the FMU's SLACK_KNOTS knots at
  T_in = i dT (fmu/README.md "Slack"), falling as T_in rises (a monotone table, as a spring's
  take-up), in place of the fixed law's slack_tension. The knots span TOP_FACTOR times the
  fixed form's slack_tension (at most the input's INPUT_QUANTILE), so that a knee softer than
  the fixed law's corner has knots on both sides of it. The penalty weighs the table's second
  differences (its last knot falling to the implicit 0 after it).

Both are fitted as the drift's table is (cosim.audit.drift_table): from the fixed form's own
shape, by Gauss-Newton on the fit blocks with the penalty's weight lam chosen on the selection
blocks from PENALTY_GRID at each step (the linearised prediction's fit there), a step kept only
if the fit blocks' sum of squares (the exact twin) falls; then mu, the spread and the other
findings refitted with the free form held. The output is linear in the slack table's knots, and
close to linear in the bending's coefficients over a step; the columns are taken by differences
(one friction run each). A free form is taken under the drift table's rule (drift_table.accept):
it must fit the selection blocks better than the fixed form by the rule's block t and remove at
least what a finding must; the report blocks take no part. The cause stays the same: the free
form is its physics in another shape.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import lsq_linear

from . import twin
from .data import FIT, REPORT, SELECT, AuditData
from .decision import RULE, DecisionRule, block_stats
from .effects import Effect
from .fit import Model, _Evaluator, fit_model

# Tried when the model with the finding leaves the selection blocks' RMS above this many times
# the noise floor (the drift table's factor).
FLOOR_FACTOR = 1.5
# lam's grid (relative to the mean diagonal of A'A) and the Gauss-Newton steps, every free form's
PENALTY_GRID = tuple(float(x) for x in np.geomspace(1e-4, 1e3, 15))
GN_STEPS = 4
SLACK_KNOTS = twin.SLACK_TABLE_KNOTS
# the slack table's span: this many times the fixed form's slack_tension, at most the input
# tension's INPUT_QUANTILE quantile (knots above it would hold few samples). Chosen on the
# tuning case of tests/audit/test_audit_free_forms.py, a soft knee whose loss ends near 1.4x the
# fixed form's slack_tension: 1.6, 2.0 and 2.5 left 1.13x, 1.10x and 1.19x the noise floor (the
# wider span, the coarser knots at the knee)
TOP_FACTOR = 2.0
INPUT_QUANTILE = 0.95
# the columns' differences: a knot's share, a bending coefficient (rad/m, rad/m^2)
D_SLACK = 0.01
D_BEND = 0.05
BEND_LINEAR = ("phi_offset_per_x", "phi_offset_per_y", "phi_offset_per_z")
BEND_PARAMS = (*BEND_LINEAR, *twin.BEND_SURFACE_PARAMS)
BEND_BOUNDS = ((-10.0, 10.0),) * 3 + ((-50.0, 50.0),) * 6  # inside the FMU's +-100
# fitted with the free form's coefficients, unpenalised: name, step of the column's difference
EXTRA = (("mu", 1e-4), ("dead_zone_spread", 1e-3))


@dataclass
class FreeForm:
    """A free form tried for a finding, what it gave, and whether it was taken."""

    fixed: Effect  # the finding's fixed form it was weighed against
    accepted: bool
    why: str  # one line: taken or not, with the figures
    penalty: float  # lam, chosen on the selection blocks
    name: str  # what it is in the FMU: "the drift table", ...
    axis: str  # the knots' abscissa with its unit ("t (s)"), or "term" for coefficients
    quantity: str  # what the table holds, with its unit
    knots_at: np.ndarray | tuple  # the knots' abscissae (numbers), or the terms' names
    table: np.ndarray  # the free form's values at the knots (or its coefficients)
    fixed_at_knots: np.ndarray  # the fixed form's there
    fmu_params: tuple[str, ...]  # every FMU parameter it sets (--emit-params)
    selection_rms_fixed_n: float
    selection_rms_free_n: float
    t: float  # plain block t of free against fixed on the selection blocks
    report_rms_fixed_n: float  # the twin's, on the report blocks (measured, never decided on)
    report_rms_free_n: float
    model: Model | None = None  # the model with the free form (kept when accepted)

    def table_text(self) -> list[str]:
        """The learned table beside the fixed form's, one knot (or term) a line."""
        rows = [f"{self.axis:>9}{'free form':>12}{self.fixed.form or 'fixed':>12}"]
        for at, d, f in zip(self.knots_at, self.table, self.fixed_at_knots, strict=True):
            at_text = f"{at:>9}" if isinstance(at, str) else f"{at:>9.2f}"
            rows.append(f"{at_text}{d:>+12.5f}{f:>+12.5f}")
        return rows

    def to_dict(self) -> dict:
        return {
            "cause": self.fixed.cause,
            "fixed_form": self.fixed.form,
            "name": self.name,
            "accepted": self.accepted,
            "why": self.why,
            "penalty": self.penalty,
            "axis": self.axis,
            "quantity": self.quantity,
            "knots_at": [a if isinstance(a, str) else round(float(a), 6) for a in self.knots_at],
            "table": [round(float(x), 8) for x in self.table],
            "fixed_at_knots": [round(float(x), 8) for x in self.fixed_at_knots],
            "selection_rms_fixed_n": round(self.selection_rms_fixed_n, 6),
            "selection_rms_free_n": round(self.selection_rms_free_n, 6),
            "block_t": round(self.t, 4) if math.isfinite(self.t) else None,
            "report_rms_fixed_n": round(self.report_rms_fixed_n, 6),
            "report_rms_free_n": round(self.report_rms_free_n, 6),
        }


def needed(data: AuditData, found: list[Effect], current: Model, cause: str) -> Effect | None:
    """The finding of `cause` whose free form is to be tried, or None: it is among the findings
    and the model leaves the selection blocks above FLOOR_FACTOR x the noise floor."""
    e = next((f for f in found if f.cause == cause), None)
    if e is None or current.prediction is None:
        return None
    if current.rms(data, SELECT) <= FLOOR_FACTOR * data.noise_floor_n:
        return None
    return e


def judge(
    data: AuditData, current: Model, model: Model, rule: DecisionRule
) -> tuple[bool, str, dict]:
    """Whether the free form's `model` is taken over the fixed form's `current`: better on the
    selection blocks by the rule's separation t and by at least the RMS a finding must remove;
    the figures for its line."""
    stats = block_stats(data, current.residual(data), model.residual(data), (SELECT,), False)
    sel_fixed = current.rms(data, SELECT)
    sel_free = model.rms(data, SELECT)
    floor = rule.min_rms_n(data.noise_floor_n, data.input_noise_n, data.sampling_error_n)
    accepted = (
        stats.t >= rule.separation_t and sel_free < sel_fixed and stats.removed_rms_n >= floor
    )
    text = (
        f"selection blocks {sel_fixed:.4f} -> {sel_free:.4f} N RMS "
        f"({stats.removed_rms_n * 1000:.1f} mN removed, at least {floor * 1000:.1f}), block t "
        f"{stats.t:.1f} (at least {rule.separation_t:g}): {'taken' if accepted else 'not taken'}"
    )
    figures = {"t": float(stats.t), "sel_fixed": sel_fixed, "sel_free": sel_free}
    return accepted, text, figures


def other_findings(current: Model, cause: str) -> tuple[Effect, ...]:
    """The findings of `current` but the one of `cause`: held beside a free form of that cause."""
    return tuple(e for e in current.effects if e.cause != cause)


def _other_parameters(others: tuple[Effect, ...]) -> dict[str, tuple[float, float, float]]:
    """The other findings' parameters the least squares moves: name -> (difference's step,
    lower and upper bound)."""
    out = {}
    for e in others:
        if not e.discrete:
            out[e.fmu_param] = (1e-2 * e.scale, *e.bounds)
        for sh in e.shape:
            if not sh.scanned:
                out[sh.fmu_param] = (1e-2 * sh.scale, *sh.bounds)
    return out


def _penalised_gauss_newton(
    data: AuditData,
    params: dict[str, float],
    names: tuple[str, ...],
    delta: float,
    solve: Callable[[np.ndarray, np.ndarray, float, float], np.ndarray],
    others: tuple[Effect, ...] = (),
) -> tuple[dict[str, float], float]:
    """The coefficients `names` of `params` fitted on the fit blocks with the penalty's weight
    chosen on the selection blocks (module docstring), together with mu, the spread and the
    other findings' parameters (the fixed form's fit moved them to stand in for its shape where
    it missed). solve(A, b, lam, scale) returns the values that minimise |A c - b|^2 plus the
    form's penalty inside its constraints, A's columns the coefficients' and then, unpenalised
    and unbounded, the others' (held to their bounds after)."""
    moved = {n: (h, -np.inf, np.inf) for n, h in EXTRA if n != "mu" or not data.mu_fixed}
    moved.update(_other_parameters(others))
    steps = {**dict.fromkeys(names, delta), **{n: v[0] for n, v in moved.items()}}
    k = len(names)
    extra = tuple(moved)
    lo = np.array([moved[n][1] for n in extra])
    hi = np.array([moved[n][2] for n in extra])
    names = (*names, *extra)
    ev = _Evaluator(data)
    idx, nf = fit_points(data, ev)
    y = data.t_out_n[idx]

    def linearise(params: dict[str, float], pred: np.ndarray):
        coef = np.array([params[n] for n in names])
        cols = []
        for n in names:
            h = steps[n]
            cols.append((ev.reading({**params, n: params[n] + h}, idx) - pred) / h)
        a = np.column_stack(cols)
        b = y - pred + a @ coef
        af, bf, as_, bs = a[:nf], b[:nf], a[nf:], b[nf:]
        scale = float(np.trace(af[:, :k].T @ af[:, :k])) / k
        if not scale > 0.0:
            return None

        def candidate(lam: float):
            c = solve(af, bf, lam, scale)
            c[k:] = np.clip(c[k:], lo, hi)
            return bs - as_ @ c, {**params, **{n: float(v) for n, v in zip(names, c, strict=True)}}

        return candidate

    return penalised_steps(ev, idx, nf, y, params, linearise)


def fit_points(data: AuditData, ev: _Evaluator) -> tuple[np.ndarray, int]:
    """The samples a free form is fitted on: the fit blocks' and then the selection blocks' on
    the evaluator's grid (the fit blocks' thinned to at most about 20 000), and how many of them
    are the fit blocks'."""
    fit_idx = np.flatnonzero(data.roles == FIT)
    stride = max(1, math.ceil(len(fit_idx) / 20_000))
    fi = ev.on_grid(fit_idx, stride)
    si = ev.on_grid(np.flatnonzero(data.roles == SELECT), stride)
    return np.concatenate([fi, si]), len(fi)


def penalised_steps(
    ev: _Evaluator,
    idx: np.ndarray,
    nf: int,
    y: np.ndarray,
    params: dict[str, float],
    linearise: Callable,
) -> tuple[dict[str, float], float]:
    """Gauss-Newton on a free form's parameters with the penalty's weight chosen on the selection
    blocks (module docstring), the steps every free form takes alike. `idx` are the samples
    (fit_points: the first `nf` the fit blocks'), `y` the output there. `linearise(params,
    pred)` linearises the model at `params` (whose reading at `idx` is `pred`) and gives a
    function of the penalty's weight lam that returns the linear step's residual on the
    selection blocks and the parameters it leads to, or None when no step can be made. A step
    is kept only if the fit blocks' sum of squares through the twin falls; the parameters and
    the weight of the last step kept."""
    pred = ev.reading(params, idx)
    sse_fit = float(np.sum((y[:nf] - pred[:nf]) ** 2))
    lam_used = PENALTY_GRID[0]
    for _ in range(GN_STEPS):
        candidate = linearise(params, pred)
        if candidate is None:
            break
        best = None
        for lam in PENALTY_GRID:
            e, trial = candidate(lam)
            sse = float(e @ e)
            if best is None or sse < best[0]:
                best = (sse, lam, trial)
        _, lam, trial = best
        pred_t = ev.reading(trial, idx)
        sse_t = float(np.sum((y[:nf] - pred_t[:nf]) ** 2))
        if sse_t >= sse_fit:
            break
        improvement = (sse_fit - sse_t) / sse_fit
        params, pred, sse_fit, lam_used = trial, pred_t, sse_t, lam
        if improvement < 1e-4:
            break
    return params, float(lam_used)


def _result(
    data: AuditData,
    current: Model,
    fixed: Effect,
    params: dict[str, float],
    lam: float,
    rule: DecisionRule,
    head: str,
    **fields,
) -> FreeForm:
    table_of = fields.pop("table_of")
    others = other_findings(current, fixed.cause)
    model = fit_model(data, others, params)
    accepted, verdict, fig = judge(data, current, model, rule)
    return FreeForm(
        fixed=fixed,
        accepted=accepted,
        why=f"{head} (penalty {lam:.2g} chosen on the selection blocks) against its form "
        f"{fixed.form or fixed.fmu_param}: {verdict}",
        penalty=lam,
        selection_rms_fixed_n=fig["sel_fixed"],
        selection_rms_free_n=fig["sel_free"],
        t=fig["t"],
        report_rms_fixed_n=current.rms(data, REPORT),
        report_rms_free_n=model.rms(data, REPORT),
        model=model if accepted else None,
        table=table_of(model.params),
        **fields,
    )


# --- the bending error's surface ----------------------------------------------------------------


def fit_bend_surface(
    data: AuditData, found: list[Effect], current: Model, rule: DecisionRule = RULE
) -> FreeForm | None:
    """The bending error's quadratic surface for the model `current` (module docstring), or
    None when it is not needed (needed) or the data have no positions."""
    fixed = needed(data, found, current, "bending_angle_error")
    if fixed is None or not data.has_positions:
        return None
    params = dict(current.params)
    for n in BEND_PARAMS:
        params.setdefault(n, 0.0)
    start = np.array([params[n] for n in BEND_PARAMS])
    n_lin = len(BEND_LINEAR)
    lo = np.array([b[0] for b in BEND_BOUNDS])
    hi = np.array([b[1] for b in BEND_BOUNDS])
    ridge = np.diag([0.0] * n_lin + [1.0] * (len(BEND_PARAMS) - n_lin))

    def solve(a, b, lam, scale):
        m = a.shape[1]
        pen = np.zeros((m, m))
        pen[: len(ridge), : len(ridge)] = ridge
        c = np.linalg.solve(a.T @ a + lam * scale * pen + 1e-9 * scale * np.eye(m), a.T @ b)
        c[: len(lo)] = np.clip(c[: len(lo)], lo, hi)
        return c

    others = other_findings(current, fixed.cause)
    params, lam = _penalised_gauss_newton(data, params, BEND_PARAMS, D_BEND, solve, others)

    def coefficients(p):
        return np.array([float(p.get(n, 0.0)) for n in BEND_PARAMS])

    return _result(
        data,
        current,
        fixed,
        params,
        lam,
        rule,
        "the bending error as a quadratic surface of the position (3 linear, 6 quadratic terms)",
        name="the bending error's surface",
        axis="term",
        quantity="bending per metre [rad/m] or square metre [rad/m^2]",
        knots_at=tuple(n.removeprefix("phi_offset_per_") for n in BEND_PARAMS),
        fixed_at_knots=start,
        fmu_params=BEND_PARAMS,
        table_of=coefficients,
    )


# --- the slack's table --------------------------------------------------------------------------


def fixed_slack_loss(slack_tension_n: float, t_in_n: np.ndarray) -> np.ndarray:
    """The share of the output the fixed law loses at t_in_n: 1 - min(1, T_in / slack_tension)
    (fmu/README.md "Slack"; 0 with the law off)."""
    t = np.asarray(t_in_n, dtype=np.float64)
    if slack_tension_n <= 0.0:
        return np.zeros_like(t)
    return 1.0 - np.clip(t / slack_tension_n, 0.0, 1.0)


def slack_step_n(data: AuditData, slack_tension_n: float) -> float:
    """The slack table's knot spacing for a fixed form's slack_tension (module docstring)."""
    top = min(TOP_FACTOR * slack_tension_n, float(np.quantile(data.inputs.t_in_n, INPUT_QUANTILE)))
    return max(top, slack_tension_n) / SLACK_KNOTS


def fit_slack_table(
    data: AuditData, found: list[Effect], current: Model, rule: DecisionRule = RULE
) -> FreeForm | None:
    """The slack's monotone table for the model `current` (module docstring), or None when it
    is not needed (needed)."""
    fixed = needed(data, found, current, "slack")
    if fixed is None:
        return None
    slack_n = float(current.params[fixed.fmu_param])
    step = slack_step_n(data, slack_n)
    knots_at = step * np.arange(SLACK_KNOTS)
    start = np.clip(fixed_slack_loss(slack_n, knots_at), 0.0, 1.0)
    params = dict(current.params)
    params[fixed.fmu_param] = fixed.off
    params["slack_table_dt"] = step
    params.update(dict(zip(twin.SLACK_TABLE_KNOT_PARAMS, start.tolist(), strict=True)))
    # the table as sums of non-negative falls: L_i = sum_{j >= i} f_j (monotone by its bounds)
    u = np.triu(np.ones((SLACK_KNOTS, SLACK_KNOTS)))
    d2 = np.diff(np.eye(SLACK_KNOTS + 1), 2, axis=0)[:, :SLACK_KNOTS]  # the last knot to 0
    pen = d2 @ u

    def solve(a, b, lam, scale):
        e = a.shape[1] - SLACK_KNOTS
        m = np.vstack(
            [
                np.hstack([a[:, :SLACK_KNOTS] @ u, a[:, SLACK_KNOTS:]]),
                np.hstack([math.sqrt(lam * scale) * pen, np.zeros((len(pen), e))]),
            ]
        )
        rhs = np.concatenate([b, np.zeros(len(pen))])
        lo = np.r_[np.zeros(SLACK_KNOTS), np.full(e, -np.inf)]
        hi = np.r_[np.ones(SLACK_KNOTS), np.full(e, np.inf)]
        x = lsq_linear(m, rhs, bounds=(lo, hi), method="bvls").x
        return np.r_[np.clip(u @ x[:SLACK_KNOTS], 0.0, 1.0), x[SLACK_KNOTS:]]

    others = other_findings(current, fixed.cause)
    params, lam = _penalised_gauss_newton(
        data, params, twin.SLACK_TABLE_KNOT_PARAMS, D_SLACK, solve, others
    )
    return _result(
        data,
        current,
        fixed,
        params,
        lam,
        rule,
        f"the slack as a falling table of the share lost, {SLACK_KNOTS} knots {step:.3g} N apart",
        name="the slack table",
        axis="T_in (N)",
        quantity="share of the output lost [-]",
        knots_at=knots_at,
        fixed_at_knots=start,
        fmu_params=twin.SLACK_TABLE_PARAMS,
        table_of=twin.slack_table_knots,
    )


FITS = (fit_bend_surface, fit_slack_table)
