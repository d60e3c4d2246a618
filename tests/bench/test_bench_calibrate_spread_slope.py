"""Two of calibrate's findings that cost the sensorless mode most on its worst tuning plants
(docs/results.md, "Where the sensorless mode's worst plants lose"), on a record made as calibrate
makes it (the identification run of the emulated controller) of a plant that hides both: a wide
gradual dead zone (spread 0.49) with a friction slope of -0.001 /N and a soft cable, the sizes of
the worst tuning plant of random_plants_tuning.yaml.

- The audit's nominal fit (cosim.audit.fit, SPREAD_RESTARTS): started from a spread of 0 it
  stays there (the spread's effect is of second order at 0); from the restart it finds the
  spread.
- calibrate's joint fit of mu (cosim.bench.rig.calibrate, JOINT_WITH_MU): the mu it fits with the
  slope is the friction at zero tension; proposed, it comes with that slope.

The audit's rounds are stood in for by one round whose candidate is the slope, unnamed (as in
tests/bench/test_bench_calibrate_joint_mu.py): the full audit of the record takes some 15 s."""

from types import SimpleNamespace

import pytest
from identification_record import identification_record  # tests/bench

from cosim.audit import core, fit
from cosim.audit.decision import RULE, BlockStats, Candidate, Round
from cosim.audit.effects import BY_PARAM
from cosim.audit.fit import SPREAD, fit_model
from cosim.bench.rig import calibrate as cal

PLANT = {"mu": 0.0855, "dead_zone_spread": 0.49, "mu_tension_slope": -0.001, "cable_EA": 5500.0}


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    """The identification run on PLANT (prepared for the audit) and the device's comp.* values."""
    return identification_record(PLANT, tmp_path_factory.mktemp("spread_slope"))


@pytest.mark.slow  # the emulated identification run and the fits: 5-15 s
def test_a_wide_spread_the_fit_from_near_zero_leaves_out_is_found_from_the_restart(
    record, monkeypatch
):
    """The spread's effect is of second order at 0, so a fit that starts there stays there; the
    restart from 0.5 finds it. (From SPREAD_START, 0.05, the fit finds it on this record too: the
    trap at 0.05 that a tuning plant showed came with the FMU's strands at slope-free widths.)"""
    data, _ = record
    stalled = fit_model(data, (), {SPREAD: 0.0})
    assert stalled.params[SPREAD] < 1e-9  # the stationary point (measured: 2e-17)
    monkeypatch.setattr(fit, "SPREAD_START", 0.0)
    monkeypatch.setattr(fit, "SPREAD_RESTARTS", ())
    assert fit_model(data, ()).params[SPREAD] < 1e-9  # without a restart the trap holds
    monkeypatch.setattr(fit, "SPREAD_RESTARTS", (0.5,))
    nominal = fit_model(data, ())
    # measured 0.407 for the plant's 0.49: the slope the nominal model lacks narrows its turn
    assert 0.3 < nominal.params[SPREAD] < 0.6
    assert nominal.rms(data, core.FIT) < 0.5 * stalled.rms(data, core.FIT)


def _stand_in(data, slope_pct: float):
    nominal = fit_model(data, ())
    stats = BlockStats(slope_pct, 0.1, 1.0, 0.6, 0.0, 9, ())
    cand = Candidate(BY_PARAM["mu_tension_slope"], nominal, stats, significant=False)
    return SimpleNamespace(
        data=data, extended=nominal, findings=[], rounds=[Round(nominal, [cand], None, {})],
        rule=RULE,
    )  # fmt: skip


@pytest.mark.slow
def test_the_joint_fits_mu_is_proposed_with_the_slope_it_was_fitted_with(record):
    data, device = record
    changes = {
        c.name: c for c in cal.propose(_stand_in(data, 45.0), device, device["comp.phi_rad"])
    }
    mu, slope = changes["comp.mu"], changes["comp.mu_slope_per_n"]
    assert mu.status == "change" and mu.stats["joint_with"] == ["mu_tension_slope"], mu.reason
    assert mu.proposed == pytest.approx(PLANT["mu"], abs=0.003)
    assert slope.status == "change", slope.reason
    # scaled by the bending angles as mu is (the audit's 2 pi, the device's in its word)
    assert slope.proposed == pytest.approx(mu.stats["joint_params"]["mu_tension_slope"], rel=1e-6)
    assert slope.proposed == pytest.approx(PLANT["mu_tension_slope"], abs=2e-4)
    # a slope the joint fit did not take (below JOINT_MIN_PCT) stays the extended model's, 0
    weak = cal.propose(_stand_in(data, cal.JOINT_MIN_PCT / 2), device, device["comp.phi_rad"])
    assert next(c for c in weak if c.name == "comp.mu_slope_per_n").proposed is None


@pytest.mark.slow
def test_a_passing_mu_is_fitted_again_with_a_slope_the_audit_saw(record):
    """A device whose mu is far from the plant's (0.05): the extended model's mu passes the rule
    against it, but it is the friction at the record's tensions (0.073 here: mu(T) at about
    12 N); with a slope
    the audit saw without naming it (JOINT_WHEN_SEEN), the joint fit's mu and slope are
    proposed."""
    data, device = record
    far = {**device, "comp.mu": 0.05}
    changes = {c.name: c for c in cal.propose(_stand_in(data, 45.0), far, far["comp.phi_rad"])}
    mu, slope = changes["comp.mu"], changes["comp.mu_slope_per_n"]
    assert mu.status == "change" and mu.stats["joint_with"] == ["mu_tension_slope"], mu.reason
    assert mu.proposed == pytest.approx(PLANT["mu"], abs=0.003)
    assert slope.proposed == pytest.approx(PLANT["mu_tension_slope"], abs=2e-4)
    # without the slope seen, the extended model's mu, and no slope
    weak = {
        c.name: c
        for c in cal.propose(_stand_in(data, cal.JOINT_MIN_PCT / 2), far, far["comp.phi_rad"])
    }
    assert "joint_with" not in weak["comp.mu"].stats

    # between mu(T) at the output's top (15 N) and at the mean of the record's inlet tensions
    # (about 8 N), and well off the plant's mu at zero tension (measured: 0.0732)
    def mu_at(t_n: float) -> float:
        return PLANT["mu"] + PLANT["mu_tension_slope"] * t_n

    assert mu_at(15.0) < weak["comp.mu"].proposed < mu_at(8.0)
    assert weak["comp.mu_slope_per_n"].proposed is None
