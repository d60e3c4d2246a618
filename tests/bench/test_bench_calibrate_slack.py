"""calibrate's slack proposal (comp.slack_tension_n, cosim.bench.rig.calibrate.slack_seen and
slack_change): from the first of its sources that holds a slack, clipped to the compensator's
limits as the other proposals are, and the same from a stored report (slack_of_report). The
proposal on an emulated plant's record with slack is in test_bench_calibrate_joint_mu.py."""

import pytest

from cosim.bench.rig import calibrate as cal
from cosim.studies.calibrated_robustness import _device_before

FINDINGS = {"slack_tension": 3.3, "mu_viscous": 2.2}
JOINT = {"slack_tension": 3.37, "mu_viscous": 2.5}
CANDIDATES = [
    {
        "cause": "slack",
        "params": {"slack_tension": 3.9},
        "selection_explains_pct": 45.0,
        "at_bound": None,
    },
    {
        "cause": "lag",
        "params": {"sensor_tau": 0.002},
        "selection_explains_pct": 60.0,
        "at_bound": None,
    },
]


def test_the_first_source_that_holds_a_slack_gives_it():
    every = ("finding", "joint", "candidate")
    rounds = [CANDIDATES]
    assert cal.slack_seen(FINDINGS, JOINT, rounds, every)[0] == 3.3
    assert cal.slack_seen({}, JOINT, rounds, every)[0] == 3.37
    assert cal.slack_seen({}, None, rounds, every)[0] == 3.9
    assert cal.slack_seen({}, None, rounds, ("finding", "joint")) == (None, "")
    # a candidate below JOINT_MIN_PCT or at a bound is not a slack the audit saw
    weak = [{**CANDIDATES[0], "selection_explains_pct": cal.JOINT_MIN_PCT - 1}]
    bound = [{**CANDIDATES[0], "at_bound": "at its lower bound"}]
    assert cal.slack_seen({}, None, [weak], every) == (None, "")
    assert cal.slack_seen({}, None, [bound], every) == (None, "")
    assert cal.slack_seen({}, {"mu_viscous": 2.5}, [], every) == (None, "")
    # "candidate" reads the last round only; "any_round" the round where it removed the most
    first = [{**CANDIDATES[0], "params": {"slack_tension": 3.5}, "selection_explains_pct": 50.0}]
    two = [first, weak]
    assert cal.slack_seen({}, None, two, ("candidate",)) == (None, "")
    assert cal.slack_seen({}, None, two, ("any_round",))[0] == 3.5
    assert cal.slack_seen({}, None, [first, CANDIDATES], ("any_round",))[0] == 3.5


def _report(findings: dict, joint: dict | None) -> dict:
    mu_stats = {"joint_with": list(joint), "joint_params": joint} if joint else {}
    return {
        "audit": {"findings": [{"param": k, "value": v} for k, v in findings.items()]},
        "changes": [
            {"name": "comp.mu", "status": "change", "proposed": 0.06, "stats": mu_stats},
        ],
        "device_phi_rad": 2 * 3.141592653589793,
    }


@pytest.fixture(scope="module")
def device(tmp_path_factory):
    # the emulated controller's defaults (no before.json): slack off
    return _device_before(tmp_path_factory.mktemp("cal"))


def test_a_stored_report_gives_the_slack_calibrate_proposes(device):
    assert device["comp.slack_tension_n"] == 0.0
    audit = {"rounds": [{"candidates": CANDIDATES}]}
    c = cal.slack_of_report(_report({}, JOINT), audit, device)
    # the choice on the tuning set (docs/results.md, "The slack term")
    assert cal.SLACK_SOURCES == ("finding", "joint", "any_round")
    assert (c.status, c.proposed) == ("change", 3.37)
    assert "joint fit" in c.reason
    c = cal.slack_of_report(_report({}, None), audit, device)
    assert (c.status, c.proposed) == ("change", 3.9)
    assert "slack candidate (45 %" in c.reason
    c = cal.slack_of_report(_report({}, None), {"rounds": []}, device)
    assert (c.status, c.proposed) == ("unchanged", None)
    # a device with a slack the audit no longer sees turns the term off
    c = cal.slack_of_report(_report({}, None), {}, {**device, "comp.slack_tension_n": 3.0})
    assert (c.status, c.proposed) == ("change", 0.0)


def test_a_slack_beyond_the_compensators_limit_is_clipped(device):
    c = cal.slack_of_report(_report({"slack_tension": 70.0}, None), {}, device)
    assert c.status == "clipped"
    assert c.proposed == 64.0  # the limit, COMP_SLACK_MAX_Q8
    assert "clipped from 70 to 64" in c.reason
