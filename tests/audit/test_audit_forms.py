"""A cause in more than one form (cosim/audit/effects.py, FORMS): the form hidden in data of the
rig written here (tests/audit/rig_models.py: its own laws, not the FMU's), the cause and its
form named alone, the form printed with the finding, the held-out residual brought within 2x
the noise floor through the FMU.

Viscous friction has two forms (fmu/README.md "Viscous friction"): mu rising with the cable's
speed (`mu_viscous`) or with the inlet tension's rate (`mu_viscous_tension_rate`). The rig's
forms: every strand's mu raised by a coefficient times |dT_in/dt| (central differences of the
true input), or times the rate of its cable's elastic stretch (its four segments' held tensions).
Friction drift has three (fmu/README.md "Friction drift"): linear in time (`mu_drift`), an
exponential warm-up from the start (`mu_warmup`, `mu_warmup_tau`) and a step at an instant
(`mu_step`, `mu_step_time`); the rig changes every strand's mu by its own time course. The
sensor's lag has two (fmu/README.md "Sensor dynamics"): first order (`sensor_tau`) and a
critically damped second order (`sensor_tau2`); the rig's second-order sensor is discretised by
the bilinear transform, the FMU's exactly for a held input. The bending angle's error has three
(fmu/README.md "Bending angle error"): a bending added in proportion to x, y or z
(`phi_offset_per_x`, `_y`, `_z`); the rig adds it to its braid's bending at held positions.

Which cases chose what: the form's bounds, start and scale and the screen that fits further
forms (cosim.audit.core.FORM_SCREEN_PCT, the rule's minimum share), the drift forms' scans
(cosim.audit.fit._scan_start) and the rule that another form must beat the first by the rule's
separation t were set on the tuning seeds 32 (tension rate 0.002 and 0.001 s/N, wandering
input; warm-up -0.012 with 8 s), 33 (cable speed 20 and 6 s/m; a step of +0.008 at 23.4 s) and
34 (tension rate 0.001 s/N, ramps; linear +2.5e-4 /s), 40 s each, mu 0.08, spread 0.3, noise
0.03 N; the lag's forms on 32 (second order 8 and 30 ms), 33 (first order 10 ms) and 34 (second
order 15 and 20 ms, ramps), where they showed what the forms cannot tell: a second-order lag of
8 ms on the wandering input fits as well in the first order (0.0362 against 0.0366 N) and a
delay of 16 ms took it, and on ramps a delay took 15 and 20 ms (lag ambiguous with it); the
bending error's forms on 32 (x, 0.8 rad/m: the x form chosen, 27 % of the selection blocks, but
block t 2.4 under the rule's; 2 rad/m named x, 2.03), 33 (y, 1 rad/m: named y, 0.995) and 34
(y, 2 rad/m: named y, 1.95), where the forms along x and y were found to need fitting whatever
the form along z removes (the coordinates are independent: cosim.audit.effects, `screened`);
nothing else was set on them. The cases below
use other seeds, mu, spreads, noise and magnitudes and were run once those were fixed; they are
reported as they came out (MISSED). The decision rule is the one of test_audit_rule.py.
"""

from __future__ import annotations

import audit_cache
import pytest
from rig_models import rig_record

from cosim.audit import report

pytestmark = pytest.mark.slow

DURATION_S = 40.0
FLOOR_FACTOR = 2.0  # the acceptance's factor

CASES = {
    "drift, a step of -0.009 at 17.7 s, ramps": (
        dict(
            seed=46,
            mu=0.075,
            spread=0.25,
            noise_n=0.035,
            drive="ramp",
            drift=("step", -0.009, 17.7),
        ),
        "friction_drift",
        "step",
        # the linearised capstan again: about 1.1x in the amplitude; the instant within 0.1 s
        ("mu_step", -0.009, 0.3),
    ),
    "lag, second order 25 ms, wandering input": (
        dict(seed=48, mu=0.09, spread=0.25, noise_n=0.025, lag2_s=0.025),
        "lag",
        "second order",
        ("sensor_tau2", 0.025, 0.15),
    ),
    # Missed while the FMU's gradual dead zone had 8 strands (its discretisation left
    # 27-53 mN RMS against the continuous distribution: fmu/README.md "Strands of the gradual
    # dead zone"): the warm-up was named with a wrong sensor_offset beside it (the same for the
    # first-order lag below, in LONG_CASES). With 32 strands, a count chosen by that study and
    # the audit's time budget, not on these cases, each was run once and met.
    "drift, a warm-up of +0.01 with 5 s": (
        dict(seed=45, mu=0.09, spread=0.35, noise_n=0.025, drift=("warm-up", 0.01, 5.0)),
        "friction_drift",
        "warm-up",
        ("mu_warmup", 0.01, 0.3),
    ),
    "bending error along x, at positions": (
        dict(seed=50, mu=0.09, spread=0.25, noise_n=0.025, positions=True, bend=(0, 1.5)),
        "bending_angle_error",
        "x",
        ("phi_offset_per_x", 1.5, 0.15),
    ),
}
# Run in make test-long (each a whole audit of up to 30 s of one worker; make test keeps one case
# of each kind): the bending error on another coordinate; the linear drift at held positions
# (make test names it on FMU data, test_audit_causes.py); the first-order lag in its form (make
# test names it on this rig, test_audit_rule.py), which with 8 strands was named in the right
# form but ambiguous with time_delay (83 % against 86 % of the selection blocks' residual, block
# t 0.4), and with 32 was run once and met (24.2 ms, 1.07x the floor).
LONG_CASES = {
    # Met with 8 strands (1.5e-3 s/N alone). With 32 the form was named (1.63e-3 s/N, 96 %),
    # and then load_cell_creep, -11 % with its fastest 50 ms, 20 % of what the form left, block t
    # 4.6: a lead standing in for the rates' timing (the FMU filters the rate with 10 ms and
    # uses the previous sample's, fmu/README.md "Viscous friction"; the rig takes central
    # differences of the true input), 1.8x the floor. Since a form whose time constant ends at a
    # bound of its range is not a finding (cosim.audit.effects.Shape.at_bound, a rule set
    # without running a case), it was run once more: the form alone, 1.51e-3 s/N, 1.89x the
    # floor, and the creep printed as not named.
    "tension rate 1.2e-3 s/N, wandering input": (
        dict(seed=42, mu=0.085, spread=0.35, noise_n=0.025, viscous_rate_s_n=0.0012),
        "viscous_friction",
        "tension rate",
        # the rig's linearised capstan (a segment passes T (1 - mu dphi)) and its strands'
        # additive excess make a change of mu act about 1.2x as strongly as in the FMU's
        # exponential law: the fitted coefficient comes out that much higher
        ("mu_viscous_tension_rate", 0.0012, 0.35),
    ),
    "drift, linear -2e-4 /s, at positions": (
        dict(
            seed=47,
            mu=0.085,
            spread=0.3,
            noise_n=0.02,
            positions=True,
            drift=("linear", -2e-4, 0.0),
        ),
        "friction_drift",
        "linear",
        ("mu_drift", -2e-4, 0.3),
    ),
    "lag, first order 25 ms, wandering input": (
        dict(seed=49, mu=0.075, spread=0.35, noise_n=0.03, lag_s=0.025),
        "lag",
        "first order",
        ("sensor_tau", 0.025, 0.15),
    ),
    "bending error along y, at positions": (
        dict(seed=51, mu=0.075, spread=0.35, noise_n=0.035, positions=True, bend=(1, -1.2)),
        "bending_angle_error",
        "y",
        ("phi_offset_per_y", -1.2, 0.15),
    ),
}
# Reported, not met (each run once on its report seed; the figures with the FMU's 32 strands):
# - ramps at held positions (seed 43, mu 0.075, spread 0.25, noise 0.035 N, 1e-3 s/N): the
#   right cause and form (98 % of the selection blocks' residual, block t 55, 1.11e-3 s/N), but
#   0.124 N left held-out, 3.5x the floor (3.6x with 8 strands). At every reversal of a
#   triangle the rate passes through zero, the friction drops to mu alone and the output
#   latches at the loading line of mu; the rig's rate dips for one sample at the peak, the
#   FMU's filtered rate for about 10 ms after it, and the rig's linearised capstan answers a
#   change of mu 1.2x as strongly, so each ramp's unloading is left 0.1-0.3 N off with a sign
#   that depends on its rate. Measured since, noise-free on tuning seed 34's ramps with one
#   strand (the rig's and the FMU's laws otherwise agree there to 0.3 %): whether the rig
#   latches at all depends on how its top is sampled. A top on one sample has a central
#   difference of 0 there, and the rig latches at the loading line of mu as the FMU does (the
#   FMU 0.04-0.07 N below it through the dead zone); a top on two equal samples has +-r/2 at
#   both, the rate's friction never leaves, and the FMU, whose filtered rate passes through
#   zero, latches 0.45 N above the rig (a top of 18.41 N). The audit now places this residual
#   on the unloading branch (`sits while the input tension falls`).
# - the cable-speed form on the rig (seed 44, mu 0.09, 8 s/m): with 8 strands viscous_friction
#   was named in the tension-rate form (90 % against 81 % for the cable speed); with 32,
#   time_delay (55 ms, 23 % of the selection blocks' residual, block t 3.6), a wrong cause,
#   3.8x the floor left. The rig's cable has four segments per strand, so in a dead zone its
#   stretch still moves with a fifth of the input's rate and then in steps, neither the FMU's
#   cable speed (32 segments: its inlet speed starts from zero after a reversal and grows as the
#   sliding part spreads) nor its tension rate. (On the FMU's own data the cable-speed form is
#   named: test_audit_causes.py.)
# With the free forms (cosim/audit/drift_table.py, cosim/audit/free_forms.py): both unchanged,
# and strict still. A free form is tried only for a finding of its cause (friction drift,
# bending error, slack), and only a free form taken can drop another finding; here the findings
# are viscous_friction and time_delay, so none is tried and the audit takes the path above (the
# same code, number for number, on a model with no free form's parameter). Their shapes are of
# viscous friction: the latch at a sharp top follows how the rate passes through zero at a
# reversal (the FMU's 10 ms filter), the cable speed in a dead zone the rig's four segments. The
# free form for both would be mu's change as a table of the filtered rate or of the cable speed,
# which is not built; the cable speed's case would still have to be named viscous_friction first.
MISSED = {
    "tension rate 1e-3 s/N, ramps at positions": (
        dict(
            seed=43,
            mu=0.075,
            spread=0.25,
            noise_n=0.035,
            viscous_rate_s_n=0.001,
            drive="ramp",
            positions=True,
        ),
        "viscous_friction",
        "tension rate",
        ("mu_viscous_tension_rate", 0.001, 0.35),
    ),
    "cable speed 8 s/m, wandering input": (
        dict(seed=44, mu=0.09, spread=0.3, noise_n=0.03, viscous_speed_s_m=8.0),
        "viscous_friction",
        "cable speed",
        None,
    ),
}
# what a case's last round keeps out only by a shape at a bound (measured on its one run)
HELD_BACK = {"tension rate 1.2e-3 s/N, wandering input": "load_cell_creep"}
WHY_MISSED = {
    "tension rate 1e-3 s/N, ramps at positions": "3.6x the floor: the latch at each reversal",
    "cable speed 8 s/m, wandering input": "named time_delay 55 ms (the rig's 4 segments)",
}
FORMS_OF = {
    "viscous_friction": {"cable speed", "tension rate"},
    "friction_drift": {"linear", "warm-up", "step"},
    "lag": {"first order", "second order"},
    "bending_angle_error": {"x", "y", "z"},
}


@pytest.mark.parametrize(
    "case",
    [
        *CASES,
        *(pytest.param(c, marks=pytest.mark.long) for c in LONG_CASES),
        *(
            # the known misses run in make test-long: they show a fix when one comes, and their
            # two minutes would take make test past its budget
            pytest.param(
                c, marks=[pytest.mark.long, pytest.mark.xfail(strict=True, reason=WHY_MISSED[c])]
            )
            for c in MISSED
        ),
    ],
)
def test_a_form_on_the_rig_is_named_with_its_cause_and_brought_to_the_floor(
    tmp_path, case, test_cache_dir
):
    kw, cause, form, value = {**CASES, **LONG_CASES, **MISSED}[case]
    path = rig_record(tmp_path, duration_s=DURATION_S, **kw)
    res = audit_cache.audit(path, test_cache_dir)
    named = [(f.effect.label, f.value) for f in res.findings]
    assert [c for c, _ in named] == [f"{cause} (form: {form})"], named
    f = res.findings[0]
    assert f.explains_pct > 0.0 and f.ambiguous_with is None, f.evidence
    # the form was chosen among all of the cause's, on the selection blocks, and the report
    # says so
    assert set(f.forms) == FORMS_OF[cause], f.forms
    text = report.summary(res)
    assert f"{cause} (form: {form})" in text
    assert f"its form {form} was chosen over" in f.evidence
    # a candidate of the last round kept out by a shape at a bound (the tension rate's case on
    # the wandering input: a creep at its fastest) is printed as not named, with why
    held_back = [
        c
        for c in res.rounds[-1].candidates
        if c.at_bound and not c.significant and res.rule.passes(c.stats, res.data)
    ]
    for c in held_back:
        assert f"not named {c.effect.label}" in text and c.at_bound in text, text
    if case in HELD_BACK:
        assert HELD_BACK[case] in [c.effect.cause for c in held_back], text
    if value is not None:
        param, true, rel = value
        assert res.extended.params[param] == pytest.approx(true, rel=rel), res.extended.params
    if form == "step":  # the rig's instant, within 0.1 s
        assert res.extended.params["mu_step_time"] == pytest.approx(kw["drift"][2], abs=0.1)
    assert res.holdout_rms_after_n <= FLOOR_FACTOR * res.data.noise_floor_n
    assert res.holdout_rms_after_n < res.holdout_rms_before_n
    assert res.twin_fmu_max_diff_n < 1e-4
