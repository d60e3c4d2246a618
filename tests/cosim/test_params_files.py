"""The recommended params files (cosim/config/params/) load as `bowden sim --params` and
`cosim.studies.calibrated_robustness --params` read them, and hold the configuration
docs/results.md measured for their mode."""

from __future__ import annotations

import json

import pytest

from cosim.config.run import load_params
from cosim.project.paths import PACKAGE_DIR
from cosim.studies import calibrated_robustness as cr

PARAMS = PACKAGE_DIR / "config" / "params"


@pytest.mark.parametrize("path", sorted(PARAMS.glob("*.json")), ids=lambda p: p.name)
def test_a_params_file_loads_as_bowden_sim_reads_it(path):
    cfg = load_params(path)
    assert cfg.to_dict() != load_params(None).to_dict()  # it sets something
    assert cr.overlay_of([], str(path))  # and the study lays it over calibrate's proposals


def test_the_far_end_mode_is_the_measured_configuration():
    """docs/results.md, "The far-end mode after calibrate": the correction and the reversal table
    at the rates chosen on the tuning set, the online estimate off, kv 1e-3 A s/N; the plant's
    own values (mu, offset, slope, spread) come from `bowden bench calibrate`, not from here. The
    breakaway term and the rate term are off over calibrate's proposals: the correction and the
    reversal table take their place ("The far-end mode with the audit's joint search")."""
    cfg = load_params(PARAMS / "far_end_after_calibrate.json")
    c = cfg.compensator
    assert (c.est_enable, c.corr_enable, c.corr_rev_enable) == (0, 1, 1)
    assert (c.corr_ki_shift, c.corr_hold_ticks, c.corr_limit) == (6, 30, 0.5)
    assert (c.corr_rev_ki_shift, c.corr_rev_bin_shift, c.corr_rev_lead_ticks) == (4, 6, 0)
    assert (c.corr_rev_leak_shift, c.corr_rev_limit_n) == (12, 0.5)
    assert cfg.controller.kv_a_s_per_n == 0.001
    nominal = load_params(None).compensator
    assert (c.mu, c.offset_n, c.mu_slope_per_n, c.dead_zone_spread) == (
        nominal.mu,
        nominal.offset_n,
        nominal.mu_slope_per_n,
        nominal.dead_zone_spread,
    )
    # set by the file (so laid over calibrate's proposals), not left at the nominal 0
    written = json.loads((PARAMS / "far_end_after_calibrate.json").read_text())["compensator"]
    assert (written["breakaway"], written["mu_per_inlet_rate"]) == (0.0, 0.0)
    assert (c.breakaway, c.mu_per_inlet_rate) == (0.0, 0.0)


def test_the_sensorless_mode_is_the_measured_configuration():
    """docs/results.md, "With the dead-zone inverse": the preview compensator (`--compensator
    preview`) with calibrate's proposals, no far-end loop (neither the online estimate nor the
    correction) and kv 1e-3 A s/N; the plant's own values come from calibrate."""
    cfg = load_params(PARAMS / "sensorless_after_calibrate.json")
    c = cfg.compensator
    assert (c.est_enable, c.corr_enable, c.corr_rev_enable) == (0, 0, 0)
    assert cfg.controller.kv_a_s_per_n == 0.001
    nominal = load_params(None)
    assert c == nominal.compensator  # the sensorless mode differs from nominal in kv alone
