"""The free forms of the bending error and the slack (cosim/audit/free_forms.py): the bending
as a quadratic surface of the position (its linear part a bending along a learned direction) and
the slack's lost share as a falling table of the input tension, fitted when a finding's fixed
forms leave the residual above 1.5x the noise floor, carried into the FMU (fmu/README.md
"Bending angle error", "Slack") and taken only when they fit the selection blocks better.

Which case chose what: the surface's terms (the FMU's: three linear, six quadratic), the slack
table's knot count (8, the FMU's), the penalty's grid and the Gauss-Newton steps (the drift
table's, cosim.audit.drift_table) were set before any case was run. On the tuning cases (the rig
of tests/audit/rig_models.py, not the FMU) the slack table's span was chosen (TOP_FACTOR: 1.6,
2.0 and 2.5 times the fixed form's slack_tension gave 1.13x, 1.10x and 1.19x the floor on the
soft knee of seed 62) and mu and the spread were made columns of the Gauss-Newton beside the
table (held at the fixed form's values, the table's falling end sat 0.01-0.02 low and mu stood in
for it: 1.60x). The report cases were run once after that and are written down as they came out
(below CASES), with one exception said there.
"""

from __future__ import annotations

import audit_cache
import numpy as np
import pytest
from rig_models import rig_record

from cosim.audit import core, free_forms, report, twin
from cosim.audit.effects import BY_CAUSE, FORMS
from cosim.audit.params import emitted_params
from cosim.audit.synthetic import fmu_record
from cosim.results import trace

FLOOR = free_forms.FLOOR_FACTOR


def test_the_slack_tables_start_is_the_fixed_law():
    """The table starts at the fixed form's lost share at its knots; with slack_tension on a
    knot, the FMU's table (twin.slack_table_value, held to the FMU in test_audit_cli.py) is then
    the fixed law 1 - min(1, T_in / slack_tension) at every tension, so the first model is the
    fixed form's."""
    slack_n = 6.0
    step = slack_n / 4
    knots = free_forms.fixed_slack_loss(slack_n, step * np.arange(free_forms.SLACK_KNOTS))
    params = {"slack_table_dt": step, **dict(zip(twin.SLACK_TABLE_KNOT_PARAMS, knots, strict=True))}
    t_in = np.linspace(-1.0, 20.0, 4001)
    lost = twin.slack_table_value(params, t_in)
    assert np.max(np.abs(lost - free_forms.fixed_slack_loss(slack_n, t_in))) < 1e-12


def test_the_report_plots_each_free_form(tmp_path):
    """free_form.png: a table through its knots beside its fixed form, a surface's terms as bars
    beside the fixed form's, one panel each, linked from the report with its caption."""
    common = dict(
        accepted=True,
        why="taken",
        penalty=0.3,
        selection_rms_fixed_n=0.05,
        selection_rms_free_n=0.03,
        t=4.0,
        report_rms_fixed_n=0.05,
        report_rms_free_n=0.03,
    )
    at = 1.5 * np.arange(free_forms.SLACK_KNOTS)
    slack = free_forms.FreeForm(
        fixed=BY_CAUSE["slack"],
        name="the slack table",
        axis="T_in (N)",
        quantity="share of the output lost [-]",
        knots_at=at,
        table=np.clip(1.0 - at / 9.0, 0.0, 1.0) ** 2,
        fixed_at_knots=free_forms.fixed_slack_loss(6.0, at),
        fmu_params=twin.SLACK_TABLE_PARAMS,
        **common,
    )
    terms = tuple(n.removeprefix("phi_offset_per_") for n in free_forms.BEND_PARAMS)
    bend = free_forms.FreeForm(
        fixed=next(f for f in FORMS["bending_angle_error"] if f.form == "z"),
        name="the bending error's surface",
        axis="term",
        quantity="bending per metre [rad/m] or square metre [rad/m^2]",
        knots_at=terms,
        table=np.linspace(-1.0, 1.0, len(terms)),
        fixed_at_knots=np.r_[0.0, 0.0, 1.2, np.zeros(6)],
        fmu_params=free_forms.BEND_PARAMS,
        **common,
    )
    name = report.free_form_plot(tmp_path, [slack, bend])
    png = tmp_path / name
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    assert name in report.PLOT_CAPTIONS
    assert bend.table_text()[3].split()[0] == "z" and len(slack.table_text()) == 9


@pytest.mark.slow
@pytest.mark.parametrize(
    "cause, effect, positions",
    [
        ("slack", {"slack_tension": 5.0, "dead_zone_spread": 0.3}, False),
        ("bending_angle_error", {"phi_offset_per_z": 1.2, "dead_zone_spread": 0.3}, True),
    ],
)
def test_the_free_form_is_no_worse_where_the_fixed_form_is_right(
    tmp_path, monkeypatch, cause, effect, positions
):
    """On the FMU's own slack law and bending along z (the fixed form exactly right; 12 s), the
    free form is not tried at the floor factor, and tried regardless of the residual's size it
    is not taken, or, taken, is no worse on the report blocks than the fixed form."""
    path = fmu_record(tmp_path, effect, seed=73, duration_s=12.0, positions=positions)
    data = core.prepare(trace.read_trace(path, mode="measured"), str(path))
    form = FORMS[cause][0]
    fixed = core.fit_model(data, (form,))
    fit = free_forms.fit_slack_table if cause == "slack" else free_forms.fit_bend_surface
    assert fit(data, [form], fixed) is None  # within 1.5x: not tried at all
    monkeypatch.setattr(free_forms, "FLOOR_FACTOR", 0.0)
    free = fit(data, [form], fixed)
    assert free is not None and free.fixed is form
    assert not free.accepted or free.report_rms_free_n <= free.report_rms_fixed_n, free.why
    assert ("not taken" in free.why) == (not free.accepted)


CASES = {
    # tuning: a slack whose spring stiffens gradually, ramps down to 1 N
    "tuning: slack with a soft knee": (
        dict(seed=62, mu=0.08, spread=0.3, noise_n=0.03, drive="ramp", slack_n=5.0, slack_knee=1.0),
        40.0,
        "slack",
    ),
    # tuning: a bending error along x + z (no coordinate's form alone)
    "tuning: a bending along x + z": (
        dict(seed=64, mu=0.08, spread=0.3, noise_n=0.03, positions=True, bend=((1, 0, 1), 2.0)),
        60.0,
        "bending_angle_error",
    ),
    "report: slack with a softer knee": (
        dict(
            seed=63, mu=0.075, spread=0.35, noise_n=0.035, drive="ramp", slack_n=6.0, slack_knee=1.5
        ),
        40.0,
        "slack",
    ),
    "report: slack with a sharper knee": (
        dict(
            seed=67, mu=0.09, spread=0.25, noise_n=0.025, drive="ramp", slack_n=4.0, slack_knee=0.6
        ),
        40.0,
        "slack",
    ),
    "report: a bending along y + z": (
        dict(seed=66, mu=0.085, spread=0.35, noise_n=0.035, positions=True, bend=((0, 1, 1), -1.8)),
        60.0,
        "bending_angle_error",
    ),
    "report: a bending that grows as the square along z - x": (
        dict(
            seed=65, mu=0.09, spread=0.25, noise_n=0.025, positions=True, bend=((-1, 0, 1), 1.5, 2)
        ),
        60.0,
        "bending_angle_error",
    ),
}
# Each case is a whole audit of 40-60 s at 1 kHz, 10-30 s of one core (its result kept in the
# test cache): run in make test-long. As they came out (the report blocks, x the noise floor:
# the fixed form's through the twin, the extended model's through the FMU, the twin within
# 1e-14 N of it):
# - tuning, the soft knee: slack named alone (7.43 N, 90 % of the selection blocks'
#   residual), 5.63x; the table taken (selection blocks 0.256 -> 0.038 N, block t 5.2), 1.10x.
# - tuning, x + z: bending_angle_error named in the form z (1.08 rad/m, 69 %), 2.33x; the
#   surface taken (0.076 -> 0.036 N, block t 2.9), 1.21x.
# - report, the softer knee (seed 63): run once before the other findings' parameters were
#   columns of the Gauss-Newton and before the backward check after a free form: slack and
#   sensor_offset named (a wrong cause: the offset stood in for the fixed law's corner), the
#   table taken, 2.32x. Those two changes were made for it (the exception), and it is no
#   longer a report case of them: now slack alone (the offset dropped after the table), 5.67x
#   -> 1.28x. The next case was set and run once after them.
# - report, the sharper knee (seed 67): slack alone (5.16 N, 93 %), 6.23x; the table taken
#   (0.201 -> 0.029 N, block t 4.5), 1.13x.
# - report, y + z (seed 66): bending_angle_error in the form z (-1.43 rad/m, 85 %), 1.90x;
#   the surface taken (0.070 -> 0.039 N, block t 3.7), 1.08x.
# - report, the square along z - x (seed 65): nothing named (NOT_NAMED), 1.38x left by the
#   nominal model.
# the cases the free form does not bring within 1.5x the floor
REPORT_MISSES: dict[str, str] = {}
# the cases whose cause is not named at all (no free form is tried without a finding)
NOT_NAMED = {
    # the form along z removes 14 % of the selection blocks' residual with block t 3.9, but
    # better in only 8 of 12 of them (the rule asks 75 %); the others less. The bending reaches
    # at most 0.54 rad (at the far ends of z - x), and the nominal model leaves 1.38x the floor.
    "report: a bending that grows as the square along z - x": "not named: z in 8 of 12 blocks",
}


def _audit(tmp_path, case, cache):
    kw, duration_s, _ = CASES[case]
    path = rig_record(tmp_path, duration_s=duration_s, **kw)
    return audit_cache.audit(path, cache)


def _xfail(misses):
    return [
        pytest.param(c, marks=pytest.mark.xfail(strict=True, reason=misses[c]))
        if c in misses
        else c
        for c in CASES
    ]


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("case", _xfail(NOT_NAMED))
def test_a_cause_of_another_shape_takes_its_free_form(tmp_path, case, test_cache_dir):
    """On the rig: the cause named alone (no wrong cause beside it); its fixed form leaves the
    report blocks above 1.5x the noise floor; the free form, taken on the selection blocks,
    lowers them through the FMU; the report shows it beside the fixed form and --emit-params
    writes it."""
    cause = CASES[case][2]
    res = _audit(tmp_path, case, test_cache_dir)
    assert [f.effect.cause for f in res.findings] == [cause], res.findings
    floor = res.data.noise_floor_n
    free = next((f for f in res.free_forms if f.fixed.cause == cause), None)
    assert free is not None, "the free form was not tried"
    assert free.report_rms_fixed_n > FLOOR * floor, free.why
    assert free.accepted, free.why
    assert res.holdout_rms_after_n < free.report_rms_fixed_n, free.why
    assert res.twin_fmu_max_diff_n < 1e-4
    p = res.extended.params
    assert np.allclose([p.get(n, 0.0) for n in free.fmu_params[-len(free.table) :]], free.table)
    text = report.summary(res)
    assert f"free form of {cause}" in text
    assert all(row in text for row in free.table_text()), text
    assert report.FREE_FORM_PNG in report.plots(tmp_path, res)
    plant = emitted_params(res)[0]["plant"]
    assert all(k in plant for k in free.fmu_params), plant
    if cause == "slack":
        assert plant.get("slack_tension", 0.0) == 0.0, plant  # the table in its place


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("case", _xfail({**NOT_NAMED, **REPORT_MISSES}))
def test_the_free_form_brings_the_cause_within_the_floor(tmp_path, case, test_cache_dir):
    """The acceptance's figure: the report blocks within 1.5x the noise floor through the FMU
    (a report case's miss kept as a strict xfail: it shows a fix when one comes)."""
    res = _audit(tmp_path, case, test_cache_dir)
    assert [f.effect.cause for f in res.findings] == [CASES[case][2]], res.findings
    ratio = res.holdout_rms_after_n / res.data.noise_floor_n
    assert ratio <= FLOOR, (ratio, [f.why for f in res.free_forms])
