"""The audit finds an effect hidden in data it did not see being made.

Data are made by the plant FMU in drive mode 1 (cosim/audit/synthetic.py: a bench session of
30 s at 1 kHz, sensor noise on, positions held for seconds), with one effect of the vocabulary
switched on at a random magnitude (drawn here from the case's seed; the audit reads only the CSV
and a sidecar without mu). Required per named case: the cause right and not ambiguous, its value
close, the held-out residual brought close to the noise floor. Also: two effects at once (both
named), none (no finding), and a disturbance outside the vocabulary (50 Hz mains pickup on the
output sensor) that must stay unexplained, described as a line (tests/audit/test_audit_lines.py
has more); no case without one reports a line. The many-seed sweep of every cause
is `make audit-sweep` (cosim/studies/audit_sweep.py).
"""

from __future__ import annotations

import audit_cache
import numpy as np
import pytest

from cosim.audit import core
from cosim.audit.synthetic import CAUSE_SEEDS as SEEDS
from cosim.audit.synthetic import cause_magnitude as _magnitude
from cosim.audit.synthetic import fmu_record

DURATION_S = 30.0
# The held-out residual of the extended model may exceed the output sensor's noise floor by this
# factor: the input's smoothed noise passed through the friction model adds about 5 % (0.0315
# against 0.0299 N on FMU data with no effect), and a fitted parameter a little more.
FLOOR_FACTOR = 1.15
# Static friction's jumps: the breakaway falls on the sample where the smoothed input, noise
# and all, crosses the strands' threshold, so the input's noise moves every jump by samples and
# each misplaced jump leaves its size in the residual. The hidden parameters themselves leave
# 2.2x the floor on the report blocks of the tuning seed 113 (0.067 N on 0.030 N); the
# acceptance's factor of 2 holds for it.
FLOOR_FACTORS = {"static_friction": 2.0}


def _audit(path, cache) -> core.AuditResult:
    return audit_cache.audit(path, cache)


def _value_ok(cause: str, found: float, true: float) -> bool:
    if cause == "time_delay":  # the FMU reads the delay on its samples: +-1 sample and the
        return abs(found - true) <= 2e-3  # input noise's bias (an advance of about 1 ms)
    if cause == "sensor_gain":
        return abs((found - 1.0) - (true - 1.0)) <= 0.1 * abs(true - 1.0)
    return abs(found - true) <= 0.15 * abs(true)


# Reported, not met: a creep of -6.6 % with 0.57 s (seed 112, noise 0.036 N) is not named on
# FMU data. Its block t is now 6.5 (each block's drop per unit of the candidate's change), but
# it improves 8 of 12 selection blocks (the rule asks 9: most of it sits in the first block)
# and removes 0.021 N RMS, under half the combined noise (0.024 N). Its fit also stops along
# the valley where the creep and its time constant trade off: -3.8 % with 0.88 s from the
# default start, -6.4 % with 0.57 s from the truth's, the fit blocks' sums of squares 0.5 %
# apart. Where it sits (measured, not tuned): the creep changes the prediction in two of the 12
# selection blocks (the first, at the session's largest move, takes 74 % of its drop, 80 % with
# the truth's start); in the last four it changes nothing (the output held in the dead zone,
# the creep settled) and only mu's refit shifts the held levels by 3 mN, which costs those
# blocks 0.6-2.4 % each; the truth's creep, mu refitted, also improves 8 of 12. The nominal
# model already leaves 1.03x the floor on the report blocks. 60 s of the same session: still
# 8 of 12, block t 1.6: a cause this small in this record, not a form or the data's length.
# With the free forms: unchanged, and strict still. The free forms (cosim/audit/drift_table.py,
# cosim/audit/free_forms.py) are tried only for a finding of their cause (friction drift,
# bending error, slack), and only a free form taken can drop another finding (the backward
# check after it); here nothing is named, so none is tried and the audit takes the path above
# (the code it runs is the same, number for number, on a model with no free form's parameter).
# The shape is the FMU's own; what misses is the creep's size in this record, which no free
# form changes.
MISSED = {"load_cell_creep"}


@pytest.mark.parametrize(
    "cause",
    [
        pytest.param(
            c,
            marks=[
                pytest.mark.long,  # a known miss: make test-long shows a fix when one comes
                pytest.mark.xfail(
                    strict=True,
                    reason="missed on FMU data: 8 of 12 blocks improve, the rule asks 9",
                ),
            ],
        )
        if c in MISSED
        else c
        for c in SEEDS
    ],
)
def test_audit_names_the_hidden_effect(tmp_path, cause, test_cache_dir):
    seed = SEEDS[cause]
    rng = np.random.default_rng(seed)
    effect = _magnitude(cause, rng)
    noise = rng.uniform(0.02, 0.04)
    mu = rng.uniform(0.06, 0.1)
    path = fmu_record(tmp_path, effect, seed, DURATION_S, noise_std_n=noise, mu=mu)
    res = _audit(path, test_cache_dir)
    param, true = next(iter(effect.items()))  # the cause's own parameter (then its shape)
    named = [(f.effect.cause, f.value) for f in res.findings]
    assert [c for c, _ in named] == [cause], f"hidden {effect}, found {named}"
    f = res.findings[0]
    assert f.ambiguous_with is None, f.evidence
    assert f.effect.fmu_param == param
    assert _value_ok(cause, f.value, true), f"{param}: found {f.value}, hidden {true}"
    floor = res.data.noise_floor_n
    assert floor == pytest.approx(noise, rel=0.1)
    factor = FLOOR_FACTORS.get(cause, FLOOR_FACTOR)
    assert res.holdout_rms_after_n <= factor * floor, (res.holdout_rms_after_n, floor)
    assert res.holdout_rms_after_n < res.holdout_rms_before_n
    assert f.explains_pct > 0 and res.gain_pct > 0
    # the reported figure comes from the FMU, and the fitting twin agrees with it
    assert res.twin_fmu_max_diff_n < 1e-4
    # what the cause leaves in the nominal model's residual is no line (cosim.audit.lines)
    assert res.data.lines == () and res.unexplained["lines"] == [], res.unexplained["lines"]


def test_audit_names_two_effects_at_once(tmp_path, test_cache_dir):
    effect = {"sensor_tau": 0.009, "phi_offset_per_z": -0.6}
    path = fmu_record(tmp_path, effect, 201, DURATION_S, noise_std_n=0.03, mu=0.08)
    res = _audit(path, test_cache_dir)
    named = {f.effect.cause: f.value for f in res.findings}
    assert set(named) == {"lag", "bending_angle_error"}, named
    assert named["lag"] == pytest.approx(0.009, rel=0.15)
    assert named["bending_angle_error"] == pytest.approx(-0.6, rel=0.15)
    assert all(f.ambiguous_with is None for f in res.findings)
    assert res.holdout_rms_after_n <= FLOOR_FACTOR * res.data.noise_floor_n
    assert res.unexplained["lines"] == []
    # ordered by importance
    assert [f.explains_pct for f in res.findings] == sorted(
        (f.explains_pct for f in res.findings), reverse=True
    )


# make perf-audit's case (60 s of data, the longest audit here: 16 s of CPU cold) runs in make
# test-long: the rule it once failed is held in make test by
# tests/audit/test_audit_rule.py::test_an_effect_whose_size_follows_the_block_is_consistent (the
# block t per unit of the candidate's change, on this case's shape of drops), each of its two
# causes is named alone above, and two causes at once by test_audit_names_two_effects_at_once.
@pytest.mark.slow
@pytest.mark.long
def test_an_offset_with_a_tension_slope_names_both(tmp_path, test_cache_dir):
    # the slope's size follows the tension, so the t of the plain per-block drops was 1.99 and
    # only the offset was named; the block t per unit of the candidate's change names both (the
    # rule has no threshold chosen on this case)
    effect = {"sensor_offset": 0.5, "mu_tension_slope": 0.0012}
    path = fmu_record(tmp_path, effect, seed=902, duration_s=60.0)
    res = _audit(path, test_cache_dir)
    named = {f.effect.cause: f.value for f in res.findings}
    assert set(named) == {"sensor_offset", "tension_dependent_friction"}, named
    assert named["sensor_offset"] == pytest.approx(0.5, rel=0.05)
    assert named["tension_dependent_friction"] == pytest.approx(0.0012, rel=0.05)
    assert res.holdout_rms_after_n <= FLOOR_FACTOR * res.data.noise_floor_n


def test_audit_claims_no_gain_without_an_effect(tmp_path, test_cache_dir):
    path = fmu_record(tmp_path, {}, 301, DURATION_S, noise_std_n=0.03, mu=0.075)
    res = _audit(path, test_cache_dir)
    assert res.findings == [], [(f.effect.cause, f.value, f.evidence) for f in res.findings]
    assert res.holdout_rms_after_n == res.holdout_rms_before_n
    assert res.gain_pct == 0.0
    assert res.unexplained["white"] is True
    assert res.unexplained["lines"] == [] and res.data.lines == ()
    assert res.holdout_rms_before_n <= FLOOR_FACTOR * res.data.noise_floor_n
    # every candidate was tried and fell short of the rule on the selection blocks
    assert {c.effect.cause for c in res.rounds[0].candidates} == set(SEEDS)
    assert not any(c.significant for c in res.rounds[0].candidates)


def test_mains_pickup_stays_unexplained_with_its_frequency(tmp_path, test_cache_dir):
    path = fmu_record(tmp_path, {}, 401, DURATION_S, noise_std_n=0.03, mu=0.075, hum=(0.06, 50.0))
    res = _audit(path, test_cache_dir)
    assert res.findings == [], [(f.effect.cause, f.value) for f in res.findings]
    u = res.unexplained
    assert u["white"] is False
    assert u["peak_hz"] == pytest.approx(50.0, abs=0.5)
    assert u["peak_to_median_psd"] > 100
    # 0.06 N amplitude: 0.042 N RMS of hum on 0.03 N of noise
    assert u["rms_n"] == pytest.approx(np.hypot(0.03, 0.06 / np.sqrt(2)), rel=0.1)
    # described as a line, a multiple of the 50 Hz mains, and taken out before the fits
    (line,) = u["lines"]
    assert line["freq_hz"] == pytest.approx(50.0, abs=0.5)
    assert line["amplitude_n"] == pytest.approx(0.06, rel=0.2)
    assert line["mains_hz"] == [50.0] and line["removed_before_fits"] is True
    assert line["share_pct"] == pytest.approx(100 * 0.0018 / (0.0018 + 0.0009), abs=10.0)
