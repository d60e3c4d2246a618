"""calibrate's proposal of the rate term (comp.mu_per_inlet_rate, cosim.bench.rig.calibrate
seen_by_audit, inlet_rate_friction and viscous_change): from the first of its sources that holds
a viscous friction in either of the audit's forms, the cable-speed form converted through the
sheath's compliance, scaled by the bending angles like mu, clipped to the compensator's limits,
and the same from a stored report (viscous_of_report)."""

import math

import pytest

from cosim.audit.twin import CABLE_EA_N, LOADCELL_N_PER_M
from cosim.bench.rig import calibrate as cal
from cosim.studies.calibrated_robustness import _device_before

PHI = 2 * math.pi
MU = 0.075
SPEED = {
    "cause": "viscous_friction",
    "params": {"mu_viscous": 2.0},
    "selection_explains_pct": 52.0,
    "at_bound": None,
}
RATE = {**SPEED, "params": {"mu_viscous_tension_rate": 4e-4}, "selection_explains_pct": 40.0}


def test_the_cable_speed_form_is_the_rate_form_through_the_cables_compliance():
    # tension-rate form: m_r itself
    assert cal.inlet_rate_friction("mu_viscous_tension_rate", 4e-4, MU, PHI, 1.0) == 4e-4
    # cable-speed form: on a sliding branch v_c = r_in (L / EA (1 - e^-a)/a + e^-a / k_lc)
    # loading and (L / EA (e^a - 1)/a + e^a / k_lc) unloading (a = mu phi, the FMU's cable_EA
    # and load cell); the term takes their mean
    a = MU * PHI
    load = 1.5 / CABLE_EA_N * (1 - math.exp(-a)) / a + math.exp(-a) / LOADCELL_N_PER_M
    unload = 1.5 / CABLE_EA_N * (math.exp(a) - 1) / a + math.exp(a) / LOADCELL_N_PER_M
    got = cal.inlet_rate_friction("mu_viscous", 2.0, MU, PHI, 1.5)
    assert got == pytest.approx(2.0 * (load + unload) / 2, rel=1e-12)
    # a longer sheath, a larger compliance
    assert cal.inlet_rate_friction("mu_viscous", 2.0, MU, PHI, 3.0) > 1.9 * got


def test_the_first_source_that_holds_a_viscous_friction_gives_it():
    every = ("finding", "joint", "candidate")
    params = cal.VISCOUS_AUDIT_PARAMS

    def seen(findings, joint, rounds, sources=every):
        return cal.seen_by_audit(params, "viscous friction", findings, joint, rounds, sources)

    assert seen({"mu_viscous": 2.2}, None, [[RATE]])[:2] == ("mu_viscous", 2.2)
    assert seen({}, {"mu_viscous_tension_rate": 3e-4}, [[SPEED]])[:2] == (
        "mu_viscous_tension_rate",
        3e-4,
    )
    assert seen({}, None, [[SPEED]])[:2] == ("mu_viscous", 2.0)
    # the round where it removed the most, in either form
    assert seen({}, None, [[RATE], [SPEED]], ("any_round",))[:2] == ("mu_viscous", 2.0)
    assert seen({}, None, [[SPEED], [RATE]], ("candidate",))[:2] == (
        "mu_viscous_tension_rate",
        4e-4,
    )
    weak = {**SPEED, "selection_explains_pct": cal.JOINT_MIN_PCT - 1}
    assert seen({}, None, [[weak]]) == (None, None, "")
    assert seen({"slack_tension": 3.0}, {"slack_tension": 3.0}, []) == (None, None, "")


def _report(findings: dict, joint: dict | None) -> dict:
    mu_stats = {"joint_with": list(joint), "joint_params": joint} if joint else {}
    return {
        "audit": {
            "findings": [{"param": k, "value": v} for k, v in findings.items()],
            "mu": MU,
            "phi_rad": PHI,
        },
        "changes": [
            {"name": "comp.mu", "status": "change", "proposed": MU, "stats": mu_stats},
        ],
        "device_phi_rad": PHI,
    }


@pytest.fixture(scope="module")
def device(tmp_path_factory):
    # the emulated controller's defaults (no before.json): the rate term off
    return _device_before(tmp_path_factory.mktemp("cal"))


def test_a_stored_report_gives_the_rate_term_calibrate_proposes(device):
    assert device["comp.mu_per_inlet_rate"] == 0.0
    # the choice on the tuning set (docs/results.md, "Friction with the cable's speed")
    assert cal.VISCOUS_SOURCES == ("finding", "joint")
    audit = {"rounds": [{"candidates": [SPEED]}], "data": {"sheath_length_m": 1.0}}
    c = cal.viscous_of_report(_report({"mu_viscous": 2.0}, None), audit, device)
    want = cal.inlet_rate_friction("mu_viscous", 2.0, MU, PHI, 1.0)
    assert c.status == "change"
    assert c.proposed == pytest.approx(want, rel=1e-12)
    assert "viscous friction finding (mu_viscous 2 s/m)" in c.reason
    # the joint fit's tension-rate form, taken as it is
    c = cal.viscous_of_report(_report({}, {"mu_viscous_tension_rate": 3e-4}), audit, device)
    assert (c.status, c.proposed) == ("change", 3e-4)
    # a round's candidate alone is not among the chosen sources
    c = cal.viscous_of_report(_report({}, None), audit, device)
    assert (c.status, c.proposed) == ("unchanged", None)
    # a device whose rate term the audit no longer sees turns it off
    on = {**device, "comp.mu_per_inlet_rate": 2e-4}
    c = cal.viscous_of_report(_report({}, None), audit, on)
    assert (c.status, c.proposed) == ("change", 0.0)
    # with the far-end correction in service the term is left off
    far = {**on, "corr.enable": 1.0}
    c = cal.viscous_of_report(_report({"mu_viscous": 2.0}, None), audit, far)
    assert (c.status, c.proposed) == ("change", 0.0)
    assert "far-end correction is in service" in c.reason


def test_a_rate_term_beyond_the_compensators_limit_is_clipped(device):
    audit = {"data": {"sheath_length_m": 1.0}}
    c = cal.viscous_of_report(_report({"mu_viscous_tension_rate": 0.1}, None), audit, device)
    assert c.status == "clipped"
    assert c.proposed == pytest.approx(1 / 16, abs=1e-8)  # COMP_VISC_MAX: 1/16 s/N
    # scaled by the bending angles like mu: the device's phi twice the audit's halves it
    rep = {**_report({"mu_viscous_tension_rate": 4e-4}, None), "device_phi_rad": 2 * PHI}
    c = cal.viscous_of_report(rep, audit, device)
    assert c.proposed == pytest.approx(2e-4, rel=1e-6)
