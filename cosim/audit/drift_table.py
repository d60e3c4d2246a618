"""The friction drift's free form (cosim.audit.core, after the decision): mu_eff(t) = mu + d(t),
d a smooth function of time, for a drift whose fixed forms (effects.FORMS: linear, warm-up, step)
fall short of the data.

When friction_drift is a finding and the extended model still leaves the selection blocks' residual
above free_forms.FLOOR_FACTOR times the noise floor (free_forms.needed), the drift's form is fitted
again as the FMU's drift table (fmu/README.md "Friction drift"): d(t) linear between KNOTS evenly
spaced knots over the record, held flat outside, in place of the fixed form's own parameter (set to
"off"). The table is fitted on the fit blocks by penalised least squares, its second differences
weighed by a penalty chosen on the selection blocks:

1. Start: the knots at the fixed form's d(t), so that the first model is the fixed form's.
2. Gauss-Newton on the knots (mu, the spread and the other findings held): the output's slope
   in a knot is taken as its slope in mu at that sample times the knot's hat function there,
   J(t) h_i(t) (a slow change of mu acts where the cable slides, as a change of mu does; the
   drift's scan makes the same approximation, cosim.audit.fit._scan_start). Each step solves
   (A'A + lam s D'D) c = A'r + A'A c0 on the fit blocks (D the second differences, s the mean
   of A'A's diagonal, so that lam has no unit), for each lam of free_forms.PENALTY_GRID; the
   lam whose linearised prediction fits the selection blocks best is taken, and the step is kept
   only if the fit blocks' sum of squares (the exact twin) falls (free_forms.penalised_steps,
   the steps every free form takes).
3. mu, the spread and the other findings refitted with the table held (cosim.audit.fit).

The free form replaces the fixed one only if it fits the selection blocks better by a plain
block t of the rule's separation (the same test as one fixed form replacing another) and removes
from the fixed form's residual there at least the RMS a finding must remove (the rule's
min_rms_n): its penalty was chosen on those blocks, and a table that follows the noise can gain a
little there by that choice alone. The report blocks, where the gain is then measured through the
FMU, take no part. The cause stays
friction_drift: the free form is the same physics in another shape.

KNOTS = 16 (the FMU's BOWDEN_DRIFT_KNOTS): a knot every 4 s over a minute (every 80 s over 20
minutes), so a change over tens of seconds has several, while each knot's span still holds a fit
block on a one-minute record (blocks of about 1.2 s, two in four fitted); finer knots add
parameters that only the penalty then ties together, coarser ones miss a turn of a few seconds.
"""

from __future__ import annotations

import numpy as np

from . import free_forms, twin
from .data import REPORT, AuditData
from .decision import RULE, DecisionRule
from .effects import Effect
from .fit import Model, _Evaluator, fit_model
from .free_forms import FreeForm

KNOTS = twin.DRIFT_TABLE_KNOTS
# The penalty's weights tried (free_forms.PENALTY_GRID, relative to the mean diagonal of A'A:
# module docstring) were chosen with the tuning case of tests/audit/test_audit_drift_table.py (an
# overshooting warm-up): its choice sat inside the grid.
D_MU = 1e-3  # mu's change for the output's slope in mu (as fit.SCAN_D_MU)
# the knots' range: mu's change the table may make (inside the FMU's [-1, 1])
KNOT_BOUNDS = (-0.5, 0.5)


def fixed_change(params: dict[str, float], t_s: np.ndarray, start_s: float) -> np.ndarray:
    """mu's change of the drift's fixed forms at times t_s (the FMU's laws: fmu/README.md
    "Friction drift"; start_s the FMU's start, from which the warm-up counts)."""
    p = twin._full(params)
    t = np.asarray(t_s, dtype=np.float64)
    d = p["mu_drift"] * t
    if p["mu_warmup"] != 0.0:
        d = d + p["mu_warmup"] * (1.0 - np.exp(-(t - start_s) / p["mu_warmup_tau"]))
    if p["mu_step"] != 0.0:
        d = d + np.where(t >= p["mu_step_time"], p["mu_step"], 0.0)
    return d


def _hats(t_s: np.ndarray, t0_s: float, step_s: float) -> np.ndarray:
    """The knots' hat functions at t_s (n x KNOTS): the table's d(t) is hats @ knots."""
    s = np.clip((t_s - t0_s) / step_s, 0.0, KNOTS - 1.0)
    i = np.minimum(s.astype(np.int64), KNOTS - 2)
    f = s - i
    out = np.zeros((len(t_s), KNOTS))
    rows = np.arange(len(t_s))
    out[rows, i] = 1.0 - f
    out[rows, i + 1] += f
    return out


def _table_params(t0_s: float, step_s: float, knots: np.ndarray) -> dict[str, float]:
    out = {"mu_drift_table_t0": float(t0_s), "mu_drift_table_dt": float(step_s)}
    out.update({k: float(v) for k, v in zip(twin.DRIFT_TABLE_KNOT_PARAMS, knots, strict=True)})
    return out


def fit_free_form(
    data: AuditData, found: list[Effect], current: Model, rule: DecisionRule = RULE
) -> FreeForm | None:
    """The drift's free form for the model `current` with the findings `found` (module
    docstring), or None when it is not needed (free_forms.needed)."""
    drift = free_forms.needed(data, found, current, "friction_drift")
    if drift is None:
        return None
    inp = data.inputs
    n = len(inp.t_in_n)
    t0 = float(inp.t0_s)
    step = max((n - 1) * inp.dt_s, inp.dt_s) / (KNOTS - 1)
    knots_t = t0 + step * np.arange(KNOTS)
    fixed_knots = fixed_change(current.params, knots_t, t0)
    params = dict(current.params)
    params[drift.fmu_param] = drift.off
    params.update(_table_params(t0, step, fixed_knots))

    ev = _Evaluator(data)
    idx, nf = free_forms.fit_points(data, ev)
    # the time the friction of a sample's step uses (twin._friction: the step's start)
    t_idx = np.where(idx > 0, t0 + (idx - 1.0) * inp.dt_s, t0)
    hats = _hats(t_idx, t0, step)
    d2 = np.diff(np.eye(KNOTS), 2, axis=0)
    pen = d2.T @ d2
    y = data.t_out_n[idx]

    def linearise(params: dict[str, float], pred: np.ndarray):
        knots = twin.drift_table_knots(params)
        slope = (ev.reading({**params, "mu": params["mu"] + D_MU}, idx) - pred) / D_MU
        a = slope[:, None] * hats
        r = y - pred
        af, rf, as_, rs = a[:nf], r[:nf], a[nf:], r[nf:]
        g = af.T @ af
        scale = float(np.trace(g)) / KNOTS
        if not scale > 0.0:
            return None
        rhs = af.T @ rf + g @ knots

        def candidate(lam: float):
            c = np.clip(np.linalg.solve(g + lam * scale * pen, rhs), *KNOT_BOUNDS)
            return rs - as_ @ (c - knots), {**params, **_table_params(t0, step, c)}

        return candidate

    params, lam_used = free_forms.penalised_steps(ev, idx, nf, y, params, linearise)
    others = free_forms.other_findings(current, "friction_drift")
    model = fit_model(data, others, params)
    table = twin.drift_table_knots(model.params)
    accepted, verdict, figures = free_forms.judge(data, current, model, rule)
    why = (
        f"the drift as a table of {KNOTS} knots ({step:.3g} s apart, penalty {lam_used:.2g} chosen "
        f"on the selection blocks) against its form {drift.form}: {verdict}"
    )
    return FreeForm(
        fixed=drift,
        accepted=accepted,
        why=why,
        penalty=float(lam_used),
        name="the drift table",
        axis="t (s)",
        quantity="change of mu [-]",
        knots_at=knots_t,
        table=table,
        fixed_at_knots=fixed_knots,
        fmu_params=twin.DRIFT_TABLE_PARAMS,
        selection_rms_fixed_n=figures["sel_fixed"],
        selection_rms_free_n=figures["sel_free"],
        t=figures["t"],
        report_rms_fixed_n=current.rms(data, REPORT),
        report_rms_free_n=model.rms(data, REPORT),
        model=model if accepted else None,
    )
