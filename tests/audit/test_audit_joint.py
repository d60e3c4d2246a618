"""Several effects at once (cosim.audit.joint): the joint search names them where the forward
selection alone named a cause that stands in for them, or stopped short of the rest.

Which cases chose what: the joint search's design (which causes start, the step with the rest
held, when it replaces the forward selection) was chosen on the tuning set of random plants
(cosim/studies/sweep/examples/random_plants_tuning.yaml, its calibrations' identification records:
docs/results.md, "Several effects at once: the audit's joint search") and on the first rig case
below (TUNING: seed 81), which changed two choices: the search takes the causes of every round,
not only the first (there the slack removed 95 % in round 1, the lag 0 %), and the rule itself
decides whether its model replaces the forward selection's (a separation t of 1.8 had refused
it). The other rig cases (REPORT: the rig's own code, tests/audit/rig_models.py, not the FMU's)
were written after that and run once; they are reported as they came out: two met, four not
(MISSED, strict xfails). Seeds 82 and 83 came with the joint search; seeds 84 and 85, with the
rig's friction that changes with the tension, later, after tuning plants whose slope and slack
the audit had missed; seeds 86 and 87 after tuning plants whose positive slope the audit named
as a sensor's saturation beside cable-speed friction. The decision rule is the one of
test_audit_rule.py (not tuned here).
"""

from __future__ import annotations

import audit_cache
import numpy as np
import pytest
from rig_models import rig_record

from cosim.audit import joint
from cosim.audit.data import SELECT
from cosim.audit.decision import RULE, BlockStats, Candidate, Round
from cosim.audit.effects import BY_CAUSE
from cosim.audit.fit import Model

pytestmark = pytest.mark.slow

DURATION_S = 40.0
# the acceptance's factor: the named causes leave the held-out residual within 2x the noise floor
FLOOR_FACTOR = 2.0

TUNING = {
    "slack 4 N, a lag of 8 ms and a gain of 1.03, ramps": (
        dict(
            seed=81,
            mu=0.08,
            spread=0.3,
            noise_n=0.025,
            drive="ramp",
            slack_n=4.0,
            lag_s=0.008,
            gain=1.03,
        ),
        {
            "slack": ("slack_tension", 4.0, 0.1),
            "lag": ("sensor_tau", 0.008, 0.25),
            "sensor_gain": ("sensor_gain", 1.03, 0.01),
        },
    ),
}
REPORT = {
    "slack 3 N and friction rising with the tension, ramps": (
        dict(
            seed=84,
            mu=0.08,
            spread=0.25,
            noise_n=0.02,
            drive="ramp",
            slack_n=3.0,
            friction_slope_per_n=1.0e-3,
        ),
        {
            "slack": ("slack_tension", 3.0, 0.1),
            "tension_dependent_friction": ("mu_tension_slope", 1.0e-3, 0.3),
        },
    ),
    "cable-speed friction, slack 3 N and an offset of 0.3 N, ramps": (
        dict(
            seed=82,
            mu=0.07,
            spread=0.25,
            noise_n=0.03,
            drive="ramp",
            viscous_speed_s_m=6.0,
            slack_n=3.0,
            offset_n=0.3,
        ),
        {
            "viscous_friction": None,
            "slack": ("slack_tension", 3.0, 0.1),
            "sensor_offset": ("sensor_offset", 0.3, 0.15),
        },
    ),
    "a lag of 10 ms, an offset of -0.25 N and slack 5 N, wandering": (
        dict(
            seed=83,
            mu=0.09,
            spread=0.2,
            noise_n=0.02,
            slack_n=5.0,
            lag_s=0.010,
            offset_n=-0.25,
        ),
        {
            "lag": ("sensor_tau", 0.010, 0.25),
            "sensor_offset": ("sensor_offset", -0.25, 0.15),
            "slack": ("slack_tension", 5.0, 0.1),
        },
    ),
    "friction falling with the tension, slack 2 N and a lag of 6 ms, ramps": (
        dict(
            seed=85,
            mu=0.09,
            spread=0.2,
            noise_n=0.025,
            drive="ramp",
            friction_slope_per_n=-8.0e-4,
            slack_n=2.0,
            lag_s=0.006,
        ),
        {
            "tension_dependent_friction": ("mu_tension_slope", -8.0e-4, 0.3),
            "slack": ("slack_tension", 2.0, 0.1),
            "lag": ("sensor_tau", 0.006, 0.25),
        },
    ),
    "friction rising with the tension and strong cable-speed friction, ramps": (
        dict(
            seed=86,
            mu=0.09,
            spread=0.3,
            noise_n=0.025,
            drive="ramp",
            friction_slope_per_n=4.0e-4,
            viscous_speed_s_m=4.0,
        ),
        {
            "tension_dependent_friction": ("mu_tension_slope", 4.0e-4, 0.3),
            "viscous_friction": None,
        },
    ),
    "friction rising with the tension and cable-speed friction, ramps": (
        dict(
            seed=87,
            mu=0.09,
            spread=0.3,
            noise_n=0.025,
            drive="ramp",
            friction_slope_per_n=6.0e-4,
            viscous_speed_s_m=2.0,
        ),
        {
            "tension_dependent_friction": ("mu_tension_slope", 6.0e-4, 0.3),
            "viscous_friction": None,
        },
    ),
}
# Report cases kept to `make test-long` for the suite's time (met, each about 30 s of fits)
LONG = {"friction rising with the tension and cable-speed friction, ramps"}


# Reported, not met (each run once, with the rule and the search above), and why:
MISSED = {
    # sensor_gain and slack are named, the gain standing in for the offset and the cable-speed
    # friction; the joint search took out static friction, the cable-speed friction, the offset
    # and the creep one at a time, the rest refitted, each not needed beside the others by the rule
    "cable-speed friction, slack 3 N and an offset of 0.3 N, ramps": (
        "sensor_gain named for the offset and the speed term"
    ),
    # the right two causes at the rig's values (slack 3.009 N, slope 1.07e-3 /N, by the forward
    # selection alone), but 2.11x the floor on the report blocks (the rig's slope follows the
    # cable's mean tension, the FMU's each segment's own; which of the rig's differences leaves
    # the rest is not known)
    "slack 3 N and friction rising with the tension, ramps": "2.11x the floor, not 2x",
    # the right three causes, slope -8.46e-4 /N and slack 2.02 N, 1.13x the floor, but the lag in
    # its second-order form (two poles of 3.7 ms) for the rig's first-order 6 ms
    "friction falling with the tension, slack 2 N and a lag of 6 ms, ramps": (
        "the lag's second-order form taken for a first-order lag"
    ),
    # a sensor's saturation (full scale 13.3 N, its knee at the 2 N bound after the last refit)
    # named for the slope, 2.45x the floor: once the cable-speed friction is in the model, the
    # slope's fit from 0 stays at 0 (round 2: 0 % removed), since with this much speed friction
    # the twin's output moves by about 15 mN for any change of mu or the slope however small
    # (1e-12 included: the cable speed feeds the friction that stretches the cable, a loop whose
    # gain exceeds 1 in the dead zone), so the fit's differences see no slope; fitted from 3e-4
    # the slope reaches 2.9e-4 with 45 % less on the fit blocks
    "friction rising with the tension and strong cable-speed friction, ramps": (
        "sensor_saturation named for the slope: the fit's differences lost in the speed loop"
    ),
}
CASES = {**TUNING, **REPORT}
# On the tuning case's ramps a sensor's first-order lag and a pure delay of about its time
# constant differ only at the turns, and which of the two the joint search keeps is at the edge
# of its rule: run again from a fresh environment, the same code that had named the lag (9.3 ms)
# kept a delay of 9 ms (the slack and the gain right, 1.07x the floor). On the tuning case either
# form is the lag, its time held to the lag's within the same 25 %; the report cases keep their
# causes' own forms.
TUNING_SAME_ON_RAMPS = {"time_delay": ("lag", "sensor_delay")}


@pytest.mark.parametrize(
    "case",
    [
        # the tuning case's joint search starts from ten causes: minutes of fits (make test-long)
        *(pytest.param(c, marks=pytest.mark.long) for c in TUNING),
        *(c for c in REPORT if c not in MISSED and c not in LONG),
        *(pytest.param(c, marks=pytest.mark.long) for c in LONG),
        *(
            pytest.param(
                c,
                marks=[
                    pytest.mark.long,
                    pytest.mark.xfail(strict=True, reason=MISSED[c]),
                ],
            )
            for c in MISSED
        ),
    ],
)
def test_several_effects_on_the_rig_are_named_together(tmp_path, case, test_cache_dir):
    kw, hidden = CASES[case]
    path = rig_record(tmp_path, duration_s=DURATION_S, **kw)
    res = audit_cache.audit(path, test_cache_dir)
    found = {f.effect.cause: f for f in res.findings}
    if case in TUNING:
        for form, (cause, param) in TUNING_SAME_ON_RAMPS.items():
            if form in found and cause in hidden and cause not in found:
                found[cause] = found.pop(form)
                hidden = {**hidden, cause: (param, *hidden[cause][1:])}
    named = set(found)
    assert named == set(hidden), (named, res.extras.get("joint_search"))
    for cause, f in found.items():
        assert f.explains_pct > 0.0, f.evidence
        if hidden[cause] is not None:
            param, true, rel = hidden[cause]
            assert res.extended.params[param] == pytest.approx(true, rel=rel), res.extended.params
    assert res.holdout_rms_after_n <= FLOOR_FACTOR * res.data.noise_floor_n
    assert res.holdout_rms_after_n < res.holdout_rms_before_n


def test_a_record_the_forward_selection_explains_runs_no_joint_search(tmp_path, test_cache_dir):
    """One cause on the rig, brought to the floor by the forward selection: the joint search is
    not wanted, so it costs nothing and changes nothing."""
    path = rig_record(tmp_path, seed=26, duration_s=DURATION_S, mu=0.08, spread=0.3, lag_s=0.012)
    res = audit_cache.audit(path, test_cache_dir)
    assert [f.effect.cause for f in res.findings] == ["lag"]
    assert not joint.wanted(res.data, res.extended)
    assert "joint_search" not in res.extras


class _Data:
    """The few fields of AuditData that joint.wanted reads."""

    def __init__(self, noise: float, residual_rms: float):
        self.noise_floor_n = noise
        self.input_noise_n = noise
        self.sampling_error_n = 0.0
        n = 400
        self.roles = np.full(n, SELECT)
        self.t_out_n = np.full(n, residual_rms)


@pytest.mark.parametrize(
    ("residual_rms", "want"),
    [(2.0 * np.sqrt(2.0) * 0.01 * 0.999, False), (2.0 * np.sqrt(2.0) * 0.01 * 1.001, True)],
)
def test_the_joint_search_is_wanted_above_twice_the_combined_noise(residual_rms, want):
    data = _Data(0.01, residual_rms)
    model = Model((), {}, np.zeros(len(data.t_out_n)))
    assert joint.wanted(data, model) is want


def test_no_other_cause_that_qualifies_gives_no_joint_search():
    """Only a cause that removed at least the rule's share in some round joins the search; with
    none beside the forward selection's findings there is nothing to search."""
    model = Model((), {"mu": 0.08}, np.zeros(10))
    stats = BlockStats(0.99 * RULE.min_explained_pct, 0.01, 3.0, 1.0, 0.0, 9, ())
    weak = Candidate(BY_CAUSE["slack"], model, stats, significant=False)
    first = Round(model, [weak], None, {})
    assert joint.search(None, [first], model, model, RULE, RULE.min_explained_pct) is None
