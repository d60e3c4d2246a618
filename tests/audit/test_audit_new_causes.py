"""Three effects real rigs have, each an FMU parameter and a cause of the audit's vocabulary
(fmu/README.md "Slack", "Sensor saturation", "Load-cell creep"), hidden in data of the rig
written here (tests/audit/rig_models.py: its own code, not the FMU's), named by the audit alone
and brought to the noise floor through the FMU.

Which cases chose what: the rig's magnitudes (slack 5 N, a hard full scale of 9 N, creep 6 %
with 1 s) and the effects' starts (cosim/audit/effects.py, fit.py) were chosen on the tuning
seeds 32 (slack), 33 (saturation) and 34 (creep), 40 s each, mu 0.08, spread 0.3, noise 0.03 N;
the cases below use other seeds, mu, spreads and noise and were run once those were fixed, and
are reported as they came out (MISSED_STATIC). The decision rule is the one of test_audit_rule.py
(not tuned here).

Static friction (fmu/README.md "Static friction", the rig's `static_ratio`) is a cause of the
vocabulary too (`static_friction`, mu_static_excess; found on FMU data in test_audit_causes.py),
but on this rig it is not reliably found (MISSED_STATIC, strict xfail, make test-long): the
rig's 12 strands break loose at other instants than the FMU's lumped ones, and the sum of
squares has several valleys in the excess and the spread. Tuning seeds (40 s, noise 0.03 N
unless said; with the FMU's 8 strands of then): 31 with mu 0.08, spread 0.3, static_ratio 1.4:
the best of four starts of mu, the spread and the excess left 0.09 N on the report blocks (3x
the floor; the nominal model 0.108 N) and the audit named sensor_gain (ambiguous with
sensor_offset); 31 with spread 0 and ratio 1.4: each jump of about 2 N falls a sample or two off
and leaves 3.5x; 31 with spread 0.1 and ratio 1.3: tension_dependent_friction was named (wrong)
until the excess's start was scanned with the spread (cosim.audit.fit._breakaway_starts), then
static_friction alone, 0.0231 for 0.3 x 0.08, with 2.3x the floor left; 46 (mu 0.085, spread
0.25, noise 0.025 N, ratio 1.3): nothing named before and after that change (static_friction 33
%, block t 1.8 in 67 % of the blocks), 2.7x the floor left. What it is and is not (tuning seed 31,
ratio 1.4, spread 0.3, with the FMU's 32 strands): not the fit's start (static friction fitted
from the rig's own values, mu 0.08, spread 0.3 and an excess of 0.4 x 0.08, removes 40 % of the
selection blocks' residual, from the scan's start 51 %, sensor_gain 1.024 57 %), nor the rig's
segments' linearised law (a rig whose breakaway log-width is exactly 1.4x its sliding one in
every strand: sensor_gain 1.019 named). It is the count of jumps: each strand jumps as it
breaks loose, and with the FMU's own law and log-normal distribution, noise-free, a braid of 12
strands is 72 mN RMS from the FMU's 32 after the fit, one of 128 strands 28 mN, one of 32 strands
2 mN (with 48 strands in the rig the audit still named sensor_gain, 1.015). The FMU's static
friction fixes the staircase at 32 steps (fmu/README.md "Strands of the gradual dead zone"); a
rig's other count is structure the vocabulary lacks, and that a gain is named for it instead of
nothing is the miss.

With the free forms (cosim/audit/drift_table.py, cosim/audit/free_forms.py): unchanged, and
strict still. A free form is tried only for a finding of its cause (friction drift, bending
error, slack), and only a free form taken can drop another finding; here sensor_gain is named,
so none is tried and the audit takes the path above (the same code, number for number, on a
model with no free form's parameter). The shape this case lacks is static friction's count of
jumps; its free form would be the strands' breakaway widths as a table (the FMU fixes them at
the log-normal quantiles), which is not built.
"""

from __future__ import annotations

import audit_cache
import pytest
from rig_models import rig_record

pytestmark = pytest.mark.slow

DURATION_S = 40.0
# the acceptance's factor: a named cause leaves the held-out residual within 2x the noise floor
FLOOR_FACTOR = 2.0

CASES = {
    "slack below 6 N, ramps": (
        dict(seed=42, mu=0.085, spread=0.35, noise_n=0.025, drive="ramp", slack_n=6.0),
        "slack",
        ("slack_tension", 6.0, 0.1),
    ),
    "a hard full scale of 10 N": (
        dict(seed=43, mu=0.075, spread=0.25, noise_n=0.035, full_scale_n=10.0),
        "sensor_saturation",
        ("sensor_full_scale", 10.0, 0.03),
    ),
    "creep -6 % with 0.8 s": (
        dict(seed=45, mu=0.08, spread=0.25, noise_n=0.03, creep=-0.06, creep_tau_s=0.8),
        "load_cell_creep",
        ("sensor_creep", -0.06, 0.15),
    ),
    # Missed while the FMU's gradual dead zone had 8 strands: named alone and 1.5x the floor
    # left, but valued 3.3 % with 1.2 s, as the nominal model's mismatch to the rig's braid took
    # part of the creep (its 8 strands left 27-53 mN RMS against the continuous distribution of
    # thresholds: fmu/README.md "Strands of the gradual dead zone"). With 32 strands, a count
    # chosen by that study and the audit's time budget, not on this case, it was run once and
    # met.
    "creep 5 % with 1.5 s": (
        dict(seed=44, mu=0.09, spread=0.3, noise_n=0.02, creep=0.05, creep_tau_s=1.5),
        "load_cell_creep",
        ("sensor_creep", 0.05, 0.15),
    ),
}


# Reported, not met (run once, after the tuning above): sensor_gain (1.015) is named, a wrong
# cause, leaving 3.2x the floor; static_friction removes 10 % of the selection blocks' residual
# (block t 1.7), sensor_gain 70 % (t 4.0, 83 % of the blocks). The same with the FMU's 32
# strands instead of 8 (sensor_gain 1.0154, 69 %, t 3.9; 3.2x the floor).
MISSED_STATIC = {
    "static friction 1.35x the sliding one": (
        dict(seed=47, mu=0.075, spread=0.15, noise_n=0.025, static_ratio=1.35),
        "static_friction",
        ("mu_static_excess", 0.35 * 0.075, 0.3),
    ),
}


@pytest.mark.parametrize(
    "case",
    [
        *CASES,
        *(
            pytest.param(
                c,
                marks=[
                    pytest.mark.long,
                    pytest.mark.xfail(
                        strict=True,
                        reason="sensor_gain named: the rig's strands break loose unlike the FMU's",
                    ),
                ],
            )
            for c in MISSED_STATIC
        ),
    ],
)
def test_a_new_cause_on_the_rig_is_named_alone_and_brought_to_the_floor(
    tmp_path, case, test_cache_dir
):
    kw, cause, value = {**CASES, **MISSED_STATIC}[case]
    path = rig_record(tmp_path, duration_s=DURATION_S, **kw)
    res = audit_cache.audit(path, test_cache_dir)
    named = [(f.effect.cause, f.value) for f in res.findings]
    assert [c for c, _ in named] == [cause], named
    f = res.findings[0]
    assert f.explains_pct > 0.0 and f.ambiguous_with is None, f.evidence
    param, true, rel = value
    assert res.extended.params[param] == pytest.approx(true, rel=rel), res.extended.params
    assert res.holdout_rms_after_n <= FLOOR_FACTOR * res.data.noise_floor_n
    assert res.holdout_rms_after_n < res.holdout_rms_before_n
    assert res.twin_fmu_max_diff_n < 1e-4
