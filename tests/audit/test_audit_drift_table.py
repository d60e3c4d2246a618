"""The friction drift's free form (cosim/audit/drift_table.py): a table of mu's change over the
record, fitted when a drift finding's fixed forms (linear, warm-up, step) leave the residual above
1.5x the noise floor, carried into the FMU as its drift table (fmu/README.md "Friction drift"),
and taken only when it fits the selection blocks better.

Which case chose what: the knots' count (16, the FMU's; cosim.audit.drift_table says why) was
set before any case was run; the penalty's grid and the Gauss-Newton's steps were set on the
tuning case, an overshooting warm-up on the rig of tests/audit/rig_models.py (not the FMU; seed
60, 60 s at 1 kHz, 0.03 N of noise), where the penalty chosen on the selection blocks sat inside
the grid (0.32). The report case, a two-stage warm-up (seed 61, other mu, spread and noise), was
run once after that and is written down as it came out (below CASES). The free form's minimum
size (the rule's min_rms_n, cosim.audit.drift_table) was added after the test on the FMU's
warm-up below showed a table taken for 3.9 mN on another seed (71): the noise's gain.
"""

from __future__ import annotations

import audit_cache
import numpy as np
import pytest
from rig_models import rig_record

from cosim.audit import core, drift_table, free_forms, report, twin
from cosim.audit.effects import FORMS
from cosim.audit.params import emitted_params
from cosim.audit.synthetic import fmu_record

FLOOR = free_forms.FLOOR_FACTOR


def test_the_fits_hats_are_the_fmus_table():
    """The fit's design (hat functions at the knots) gives the d(t) the FMU's table reads
    (twin.drift_table_value, held to the FMU in tests/audit/test_audit_cli.py), flat outside."""
    rng = np.random.default_rng(3)
    knots = rng.normal(0.0, 0.01, drift_table.KNOTS)
    t0, step = 2.0, 3.5
    t = np.linspace(-5.0, t0 + step * 20, 3001)
    params = drift_table._table_params(t0, step, knots)
    want = twin.drift_table_value(params, t)
    got = drift_table._hats(t, t0, step) @ knots
    assert np.max(np.abs(got - want)) < 1e-15
    assert want[0] == knots[0] and want[-1] == knots[-1]


def test_the_report_plots_the_learned_shape_against_the_fixed_form(tmp_path):
    """free_form.png: the table through its knots and the fixed form at the same knots, linked
    from the report with its caption."""
    knots_t = 2.0 + 3.5 * np.arange(drift_table.KNOTS)
    free = drift_table.FreeForm(
        fixed=next(f for f in FORMS["friction_drift"] if f.form == "warm-up"),
        accepted=True,
        why="taken",
        penalty=0.3,
        name="the drift table",
        axis="t (s)",
        quantity="change of mu [-]",
        knots_at=knots_t,
        table=0.01 * np.sin(knots_t / 10.0),
        fixed_at_knots=0.01 * (1.0 - np.exp(-knots_t / 8.0)),
        fmu_params=twin.DRIFT_TABLE_PARAMS,
        selection_rms_fixed_n=0.05,
        selection_rms_free_n=0.03,
        t=4.0,
        report_rms_fixed_n=0.05,
        report_rms_free_n=0.03,
    )
    name = report.free_form_plot(tmp_path, free)
    png = tmp_path / name
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert name in report.PLOT_CAPTIONS


@pytest.mark.slow
def test_the_free_form_is_not_taken_where_a_fixed_form_is_right(tmp_path, monkeypatch):
    """On the FMU's own warm-up (the fixed form exactly right; 20 s, no positions), the free form
    tried regardless of the residual's size is not taken, or, taken, no worse on the report
    blocks than the fixed form. On this seed the table, taken, would be worse there (0.02983
    against 0.02976 N): it follows the noise, and neither beats the form by the rule's
    separation on the selection blocks nor removes what a finding must."""
    path = fmu_record(
        tmp_path,
        {"mu_warmup": 0.012, "mu_warmup_tau": 4.0, "dead_zone_spread": 0.3},
        seed=72,
        duration_s=20.0,
        positions=False,
    )
    from cosim.results import trace  # noqa: PLC0415

    data = core.prepare(trace.read_trace(path, mode="measured"), str(path))
    warm = next(f for f in FORMS["friction_drift"] if f.form == "warm-up")
    fixed = core.fit_model(data, (warm,))
    # within 1.5x: not tried at all
    assert free_forms.needed(data, [warm], fixed, "friction_drift") is None
    monkeypatch.setattr(free_forms, "FLOOR_FACTOR", 0.0)
    free = drift_table.fit_free_form(data, [warm], fixed)
    assert free is not None and free.fixed is warm
    assert not free.accepted or free.report_rms_free_n <= free.report_rms_fixed_n, free.why
    assert ("not taken" in free.why) == (not free.accepted)


CASES = {
    # tuning: a warm-up that overshoots (rises to 0.0174 near 29 s, falls back towards 0.012)
    "tuning: an overshooting warm-up": dict(
        seed=60, mu=0.08, spread=0.3, noise_n=0.03, drift=("overshoot", 0.03, 12.0)
    ),
    # report: two stages of 0.012 each, 7 s apart in time constant, the second from 35 s
    "report: a two-stage warm-up": dict(
        seed=61, mu=0.085, spread=0.35, noise_n=0.025, drift=("two-stage", 0.024, 7.0)
    ),
}
# Each case is a whole audit of 60 s at 1 kHz, about 30 s of one core (its result kept in the
# test cache): run in make test-long. As they came out (the twin's figures on the report
# blocks, the FMU's within 1.5e-12 N):
# - tuning, the overshoot: the warm-up form named (0.0203, 94 % of the selection blocks'
#   residual), 1.63x the floor on the report blocks; the free form taken (selection blocks
#   0.0561 -> 0.0416 N, block t 2.7), 1.25x the floor.
# - report, the two stages: the linear form named (4.39e-4 /s, 91 %), 3.63x the floor; the free
#   form taken (0.0712 -> 0.0494 N, block t 3.1), 1.72x the floor: MISSED (REPORT_MISSES). Its
#   table has the two stages (a plateau near 0.010 from 20 to 32 s, then a rise to 0.027) but
#   the plateau sits below the rig's 0.014 (its linearised capstan answers a change of mu about
#   1.2x as strongly as the FMU's exponential law: tests/audit/test_audit_forms.py), and what is
#   left is not white (autocorrelation 0.69, a peak at 0.25 Hz).
REPORT_MISSES = {"report: a two-stage warm-up": "1.72x the floor (from 3.63x with the linear form)"}


def _audit(tmp_path, case, cache):
    path = rig_record(tmp_path, duration_s=60.0, **CASES[case])
    return audit_cache.audit(path, cache)


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("case", list(CASES))
def test_a_warm_up_of_another_shape_takes_the_free_form(tmp_path, case, test_cache_dir):
    """60 s at 1 kHz on the rig: friction_drift named alone; its best fixed form leaves the
    report blocks above 1.5x the noise floor; the free form, taken on the selection blocks,
    lowers them through the FMU; the report shows the table beside the fixed form and
    --emit-params writes it."""
    res = _audit(tmp_path, case, test_cache_dir)
    assert [f.effect.cause for f in res.findings] == ["friction_drift"], res.findings
    floor = res.data.noise_floor_n
    free = res.free_form
    assert free is not None, "the free form was not tried"
    assert free.report_rms_fixed_n > FLOOR * floor, free.why
    assert free.accepted, free.why
    # the gain through the FMU, on the report blocks, as for a fixed form
    assert res.holdout_rms_after_n < free.report_rms_fixed_n, free.why
    assert res.twin_fmu_max_diff_n < 1e-4
    # the extended model carries the table and not the fixed form's own parameter; the finding
    # still shows what its fixed form fitted
    p = res.extended.params
    f = res.findings[0]
    assert f.effect is free.fixed and p[free.fixed.fmu_param] == free.fixed.off
    assert np.allclose(twin.drift_table_knots(p), free.table)
    assert f.effect.describe(f.value) in f.evidence and f.value != free.fixed.off
    text = report.summary(res)
    assert "free form of friction_drift" in text and free.fixed.form in text
    assert all(row in text for row in free.table_text()), text
    assert report.FREE_FORM_PNG in report.plots(tmp_path, res)
    plant = emitted_params(res)[0]["plant"]
    assert all(k in plant for k in twin.DRIFT_TABLE_PARAMS), plant
    assert free.fixed.fmu_param not in plant


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize(
    "case",
    [
        pytest.param(c, marks=pytest.mark.xfail(strict=True, reason=REPORT_MISSES[c]))
        if c in REPORT_MISSES
        else c
        for c in CASES
    ],
)
def test_the_free_form_brings_the_warm_up_within_the_floor(tmp_path, case, test_cache_dir):
    """The acceptance's figure: the report blocks within 1.5x the noise floor through the FMU
    (the report case's miss kept as a strict xfail: it shows a fix when one comes)."""
    res = _audit(tmp_path, case, test_cache_dir)
    ratio = res.holdout_rms_after_n / res.data.noise_floor_n
    assert ratio <= FLOOR, (ratio, res.free_form.why if res.free_form else None)
