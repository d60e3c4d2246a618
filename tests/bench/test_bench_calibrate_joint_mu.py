"""calibrate's mu when the audit's rule refuses it (cosim.bench.rig.calibrate.joint_mu): mu is
fitted again with what the audit saw but did not name, and proposed when that mu beats the
device's by the audit's rule.

The record is the identification run of the emulated controller (the stepped emulator, as
calibrate records it) on a plant with slack and friction with the cable's speed, which bias the
nominal model's mu upwards. The audit's rounds are stood in for by one round whose candidates
are those two causes (each removing about half the residual without passing the rule, as on the
random tuning plants with several effects at once) and an offset below JOINT_MIN_PCT: the full
audit of the record takes some 15 s, the decision alone a few."""

from pathlib import Path
from types import SimpleNamespace

import pytest
from identification_record import identification_record  # tests/bench

from cosim.audit.decision import RULE, BlockStats, Candidate, Round
from cosim.audit.effects import BY_PARAM
from cosim.audit.fit import fit_model
from cosim.bench.rig import CALIBRATED_PARAMS
from cosim.bench.rig import calibrate as cal

# Slack below 3.4 N and 2.5 s/m of cable-speed friction: tuning plant 9's sizes of both
# (random_plants_tuning.yaml), where calibrate kept the nominal mu.
EFFECTS = {"slack_tension": 3.4, "mu_viscous": 2.5}
# The joint fit finds the plant's mu to this (measured: 0.0679 for 0.068, 0.0749 for 0.075).
MU_TOLERANCE = 0.002


def _audit_stand_in(plant: dict, folder: Path):
    """The nominal model fitted to the plant's identification run, with one round of unnamed
    candidates (the module docstring)."""
    data, device = identification_record(plant, folder)
    nominal = fit_model(data, ())

    def unnamed(fmu_param: str, pct: float) -> Candidate:
        stats = BlockStats(pct, 0.1, 1.0, 0.6, 0.0, 9, ())
        return Candidate(BY_PARAM[fmu_param], nominal, stats, significant=False)

    cands = [unnamed("slack_tension", 45.0), unnamed("mu_viscous", 55.0)]
    cands.append(unnamed("sensor_offset", cal.JOINT_MIN_PCT / 2))
    result = SimpleNamespace(
        data=data,
        extended=nominal,
        findings=[],
        rounds=[Round(nominal, cands, None, {})],
        rule=RULE,
    )
    return result, device


def _change(result, device, name: str = "comp.mu") -> cal.Change:
    changes = cal.propose(result, device, device["comp.phi_rad"])
    return next(c for c in changes if c.name == name)


def _mu_change(result, device) -> cal.Change:
    return _change(result, device)


# The joint fit's slack on this record (measured: 3.33 N for the plant's 3.4).
SLACK_TOLERANCE_N = 0.25


def test_a_mu_the_nominal_fit_hides_behind_slack_is_proposed_from_the_joint_fit(tmp_path):
    result, device = _audit_stand_in({"mu": 0.068, **EFFECTS}, tmp_path)
    # one decision per parameter calibrate proposes, in the order the help and the study name
    changes = cal.propose(result, device, device["comp.phi_rad"])
    assert tuple(c.name for c in changes) == CALIBRATED_PARAMS
    assert device["comp.mu"] == pytest.approx(0.075)
    # the nominal model's mu absorbs the slack and the viscous friction: near the device's
    assert result.extended.params["mu"] == pytest.approx(0.073, abs=0.001)
    c = _mu_change(result, device)
    assert c.status == "change", c.reason
    assert c.proposed == pytest.approx(0.068, abs=MU_TOLERANCE)
    assert c.stats["joint_with"] == ["slack_tension", "mu_viscous"]  # not the offset (below)
    assert "which the audit saw but did not name" in c.reason
    # ...and the slack it found, which no finding names, becomes the compensator's slack term
    s = _change(result, device, "comp.slack_tension_n")
    assert s.status == "change", s.reason
    assert s.proposed == pytest.approx(EFFECTS["slack_tension"], abs=SLACK_TOLERANCE_N)
    assert s.proposed == c.stats["joint_params"]["slack_tension"]


def test_the_joint_fit_still_refuses_when_the_device_has_the_plants_mu(tmp_path):
    result, device = _audit_stand_in({"mu": 0.075, **EFFECTS}, tmp_path)
    c = _mu_change(result, device)
    assert c.status == "not significant", c.reason
    assert c.proposed is None
    assert c.stats["joint_with"] == ["slack_tension", "mu_viscous"]  # the joint fit was tried
    assert c.audit_value == pytest.approx(0.075, abs=MU_TOLERANCE)
    assert c.reason.startswith("fitted with slack_tension, mu_viscous, which the audit saw")
