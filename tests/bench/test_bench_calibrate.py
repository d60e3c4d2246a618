"""`bowden bench calibrate` (cosim.bench.rig.calibrate) on the emulated controller: it finds a plant
mu the compensator does not know and applies it, proposes nothing on the nominal plant, refuses
values outside the compensator's limits, never touches the loop gains, and leaves the device as
it was when the link drops mid-run (before.json written, one line); bad options are one line and
exit 2. The stepped emulator (no wall clock) keeps these to seconds, the longer ones are marked
slow; the runs over real links are in tests/bench/test_bench_calibrate_links.py."""

import argparse
import json
import math
from pathlib import Path

import numpy as np
import pytest

from cosim.bench import command_tools as bench_tools
from cosim.bench.__main__ import main as bench_cli
from cosim.bench.api import Bench
from cosim.bench.emulate.emulator import SteppedLink
from cosim.bench.emulate.host_device import ChainConfig
from cosim.bench.link import messages as msgs
from cosim.bench.link.client import BenchClient, BenchError
from cosim.bench.link.protocol import value_from_word
from cosim.bench.rig import calibrate as cal

# Stated tolerance of the mu found on the emulated plant (whose mu the audit fits to 5e-4 on a
# sine, tests/audit/test_audit_bench.py): 1 % of the plant's.
MU_TOLERANCE = 0.01
LOOP = [p.name for p in msgs.PARAMS if p.name.startswith("loop.")]


def _calibrate(bench_or_client, info, out, apply=False, persist=False, say=None, predict=False):
    """calibrate without the audit's plots, and without the prediction's two emulated runs
    (1.1 to 1.4 s of CPU of a 4 to 5 s calibration) unless the test asserts on the prediction
    (`predict`): neither enters the proposal, the write or the verification the tests judge."""
    lines = []
    opts = cal.Options(
        out_dir=out, apply=apply, persist=persist, audit_plots=False, predict=predict
    )
    client = getattr(bench_or_client, "client", bench_or_client)
    outcome = cal.run_calibration(client, info, opts, say=say or lines.append)
    return outcome, lines


def _words(client) -> dict:
    return client.params()


def _before(out) -> dict:
    doc = json.loads((out / "before.json").read_text())
    assert doc["bowden_bench_backup"] and doc["table_hash"] == f"{msgs.TABLE_HASH:08x}"
    return {n: e["word"] for n, e in doc["params"].items()}


def test_identification_covers_the_range_both_ways_at_several_rates():
    seq, pieces = cal.identification_sequence(1000.0)
    lo, hi = cal.TENSION_RANGE_N
    assert seq.min() == pytest.approx(lo) and seq.max() == pytest.approx(hi, abs=0.05)
    slope = np.diff(seq) * 1000.0
    for rate in cal.RATES_N_S:  # each rate, up and down
        assert np.count_nonzero(np.isclose(slope, rate, rtol=0.02)) > 100
        assert np.count_nonzero(np.isclose(slope, -rate, rtol=0.02)) > 100
    assert len(seq) / 1000.0 >= 10.0 + cal.START_HOLD_S  # the audit's shortest record
    assert pieces[0].start_s == 0 and pieces[-1].end_s == pytest.approx(len(seq) / 1000.0)
    assert all(p.why for p in pieces)
    # a sine of the verification is not among its pieces: ramps and holds only
    assert set(np.round(np.abs(slope[slope != 0]))) <= {5, 10, 15, 40}


@pytest.fixture(scope="module")
def off_plant(tmp_path_factory):
    """calibrate --apply on a plant whose mu is 0.09 (the compensator says 0.075)."""
    out = tmp_path_factory.mktemp("off") / "cal"
    with Bench(emulate=True, plant={"mu": 0.09}) as bench:
        outcome, lines = _calibrate(bench, bench.connect_info, out, apply=True, predict=True)
        after = _words(bench.client)
    return out, outcome, lines, after


def test_calibrate_finds_a_mu_the_compensator_does_not_know_and_applies_it(off_plant):
    out, outcome, lines, after = off_plant
    assert outcome.exit_code == 0, lines
    rep = outcome.report
    mu = value_from_word(msgs.PARAM_BY_NAME["comp.mu"], after["comp.mu"])
    assert mu == pytest.approx(0.09, rel=MU_TOLERANCE)
    assert rep["applied"] == {"comp.mu": pytest.approx(mu)} and rep["applied_kept"]
    m = rep["measured"]
    assert m["after"]["rms_error_n"] < 0.5 * m["before"]["rms_error_n"]
    # the prediction (emulated controller with the audited plant) is the measurement here
    assert rep["predicted"]["after"]["rms_error_n"] == pytest.approx(
        m["after"]["rms_error_n"], rel=0.05
    )
    before = _before(out)
    changed = {n for n in before if before[n] != after[n]}
    assert changed == {"comp.mu"}  # loop gains, source, wave.* as they were
    for name in (
        "identification.csv",
        "verify_before.csv",
        "verify_after.csv",
        "audit/audit.json",
        "audit/report.md",
        "audit/params.json",
        "calibration.json",
        "calibration.md",
        "calibration.png",
    ):
        assert (out / name).is_file(), name
    assert any(line.startswith("  comp.mu: 0.075 -> 0.0899") for line in lines), lines
    assert "restore it with:" in lines[0] and "before.json" in lines[1]


@pytest.mark.slow
def test_calibrate_takes_the_dead_zone_spread_to_the_compensator(tmp_path):
    """A plant with a gradual dead zone (spread 0.4, the nominal mu): the audit's spread is
    proposed without the finding rule (UNGATED), applied, and the verification's error drops."""
    with Bench(emulate=True, plant={"dead_zone_spread": 0.4}) as bench:
        outcome, lines = _calibrate(bench, bench.connect_info, tmp_path / "c", apply=True)
        after = _words(bench.client)
    assert outcome.exit_code == 0, lines
    spread = next(c for c in outcome.report["changes"] if c["name"] == "comp.dead_zone_spread")
    assert spread["status"] == "change", spread
    assert spread["proposed"] == pytest.approx(0.4, abs=0.1)
    word = value_from_word(
        msgs.PARAM_BY_NAME["comp.dead_zone_spread"], after["comp.dead_zone_spread"]
    )
    assert word == pytest.approx(spread["proposed"], abs=1e-6)
    m = outcome.report["measured"]
    assert m["after"]["rms_error_n"] < 0.7 * m["before"]["rms_error_n"], m


# A whole calibration with --apply (17 s of CPU): in `make test-long`, its steps (the proposal,
# its limits, a kept report) covered by the shorter tests above.
@pytest.mark.slow
@pytest.mark.long
def test_calibrate_takes_the_breakaway_to_the_compensator(tmp_path):
    """A plant with static friction (mu_static_excess 0.03, the nominal mu) and a device in
    preview mode: the audit names it, calibrate proposes it as comp.breakaway (the device's phi
    is the plant's), applies it and keeps it, the verification's peak falling by a third
    (measured 3.41 -> 1.95 N, RMS 0.94 -> 0.74 N). In paper mode the same proposal is undone
    (RMS 0.46 -> 0.65 N): paper's jump of the gain at the reversal, with the term's half
    breakaway on top, makes the tension loop's T_in undershoot past the breakaway at once."""
    with Bench(emulate=True, plant={"mu_static_excess": 0.03}) as bench:
        bench.set(comp_mode="preview")
        outcome, lines = _calibrate(bench, bench.connect_info, tmp_path / "c", apply=True)
        after = _words(bench.client)
    assert outcome.exit_code == 0, lines
    brk = next(c for c in outcome.report["changes"] if c["name"] == "comp.breakaway")
    assert brk["status"] == "change", brk
    assert brk["proposed"] == pytest.approx(0.03, abs=0.005)
    word = value_from_word(msgs.PARAM_BY_NAME["comp.breakaway"], after["comp.breakaway"])
    assert word == pytest.approx(brk["proposed"], abs=1e-6)
    m = outcome.report["measured"]
    assert m["after"]["peak_error_n"] < 0.7 * m["before"]["peak_error_n"], m
    assert m["after"]["rms_error_n"] < m["before"]["rms_error_n"], m


def test_nominal_plant_gives_nothing_to_change(tmp_path):
    with Bench(emulate=True) as bench:
        outcome, lines = _calibrate(bench, bench.connect_info, tmp_path / "c", apply=True)
        after = _words(bench.client)
    assert outcome.exit_code == 0
    assert any(line.startswith("nothing to change") for line in lines), lines
    assert outcome.report["applied"] == [] and "measured" not in outcome.report
    mu = next(c for c in outcome.report["changes"] if c["name"] == "comp.mu")
    # the fitted mu differs from 0.075 in the last bits: judged, and not significant
    assert mu["status"] in ("not significant", "unchanged") and mu["proposed"] is None
    assert after == _before(tmp_path / "c")


def test_a_value_outside_the_compensators_limits_is_clipped_to_the_limit(tmp_path):
    """A device set to phi = 0.3 rad against a plant of 2 pi: the plant's mu*phi (0.47) needs
    comp.mu 1.57, outside the compensator's [0, 1]: clipped to 1 with the reason, applied, and
    kept because the verification improves (mu*phi 0.0225 -> 0.3 of the plant's 0.47)."""
    with Bench(emulate=True) as bench:
        bench.set(comp_phi_rad=0.3)
        info = bench.info()
        outcome, lines = _calibrate(bench, info, tmp_path / "c", apply=True)
        after = _words(bench.client)
    mu = next(c for c in outcome.report["changes"] if c["name"] == "comp.mu")
    assert mu["status"] == "clipped" and "outside the compensator's limits" in mu["reason"]
    assert mu["proposed"] == pytest.approx(1.0, abs=1e-8)
    assert "clipped from 1.5" in mu["reason"]
    assert value_from_word(msgs.PARAM_BY_NAME["comp.mu"], after["comp.mu"]) == pytest.approx(1.0)
    assert outcome.report["applied_kept"]


def _device(**values) -> dict:
    """The emulated device's defaults as values by name, with `values` (dotted names as
    comp_mu) set."""
    client = BenchClient(SteppedLink(ChainConfig()))
    client.connect()
    try:
        words = client.params()
    finally:
        client.link.close()
    dev = {n: value_from_word(msgs.PARAM_BY_NAME[n], w) for n, w in words.items()}
    dev.update({k.replace("_", ".", 1): v for k, v in values.items()})
    return dev


def _change(name: str, current: float, proposed: float) -> cal.Change:
    return cal.Change(name, "", current, proposed, 0.0, current, "change", "removes ...")


def test_a_measured_negative_tension_slope_is_taken():
    """-0.0008 /N at mu 0.075 on loop routing: the slope of a real cable (mu stays positive up
    to 94 N), refused while the compensator asked mu + 128 N * slope >= 0."""
    dev = _device()
    changes = [_change("comp.mu", 0.075, 0.09), _change("comp.mu_slope_per_n", 0.0, -0.0008)]
    cal._check_limits(changes, dev, dev["comp.phi_rad"])
    assert [c.status for c in changes] == ["change", "change"], [c.reason for c in changes]


def test_a_value_beyond_the_limits_is_clipped_and_the_others_still_apply():
    """A slope of -0.01 /N (beyond the word's 1/128 and mu + 48 N * slope >= 0) is clipped to
    the limit at the device's mu, -0.075 / 48; mu's change applies beside it."""
    dev = _device()
    changes = [_change("comp.mu", 0.075, 0.09), _change("comp.mu_slope_per_n", 0.0, -0.01)]
    cal._check_limits(changes, dev, dev["comp.phi_rad"])
    mu, slope = changes
    assert mu.status == "change" and mu.proposed == 0.09
    assert slope.status == "clipped" and "clipped from -0.01" in slope.reason
    assert slope.proposed == pytest.approx(-0.075 / 48, rel=1e-6)
    assert slope.proposed >= -0.075 / 48 - 1e-9  # on the side the compensator takes


def test_values_that_hold_alone_but_not_together_keep_the_most_that_does():
    """mu 0.075 -> 0.05 and a slope of -0.0013 /N each hold with the device's other values, not
    together (0.05 - 48 N * 0.0013 < 0): mu applies and the slope is clipped to -0.05 / 48."""
    dev = _device()
    changes = [_change("comp.mu", 0.075, 0.05), _change("comp.mu_slope_per_n", 0.0, -0.0013)]
    cal._check_limits(changes, dev, dev["comp.phi_rad"])
    mu, slope = changes
    assert mu.status == "change" and mu.proposed == 0.05
    assert slope.status == "clipped" and "to hold with comp.mu" in slope.reason
    assert slope.proposed == pytest.approx(-0.05 / 48, rel=1e-5)
    together = {**dev, "comp.mu": 0.05, slope.name: slope.proposed}
    assert cal._comp_refuses(together, str(dev["comp.mode"])) is None


def test_a_dead_zone_spread_beyond_the_limits_is_clipped_and_mu_still_applies():
    """The audit's spread 1.3 is beyond the compensator's [0, 1]: clipped to 1 with the reason,
    mu's change applied beside it."""
    dev = _device()
    changes = [_change("comp.mu", 0.075, 0.09), _change("comp.dead_zone_spread", 0.0, 1.3)]
    cal._check_limits(changes, dev, dev["comp.phi_rad"])
    mu, spread = changes
    assert mu.status == "change" and mu.proposed == 0.09
    assert spread.status == "clipped" and "clipped from 1.3" in spread.reason
    assert spread.proposed == pytest.approx(1.0, abs=1e-6) and spread.proposed <= 1.0


def test_a_spread_that_holds_alone_but_not_with_mu_keeps_the_widest_strand_at_4():
    """mu 0.16 on loop routing (mu*phi 1.005) with spread 0.95: the widest strand
    1.005 e^(1.534 * 0.95) = 4.3 > 4, so the spread is clipped to about ln(4 / 1.005) / 1.534
    = 0.90 with mu's change applied."""
    dev = _device()
    changes = [_change("comp.mu", 0.075, 0.16), _change("comp.dead_zone_spread", 0.0, 0.95)]
    cal._check_limits(changes, dev, dev["comp.phi_rad"])
    mu, spread = changes
    assert mu.status == "change" and mu.proposed == 0.16
    assert spread.status == "clipped" and "to hold with comp.mu" in spread.reason
    assert spread.proposed == pytest.approx(math.log(4 / (0.16 * 2 * math.pi)) / 1.5341, abs=2e-3)


def test_the_breakaway_is_the_audits_static_friction_scaled_by_the_bending_angles():
    """A static friction finding of 0.02 at the audit's phi 2 pi on a device at phi 5.0: the
    compensator's m_s is 0.02 * 2 pi / 5 (only m_s*phi is observed), times calibrate's share;
    without a finding nothing changes, and a breakaway the device has goes off."""
    dev = _device()
    c = cal.breakaway_change(0.02, 2 * math.pi, dev, 5.0)
    assert c.status == "change" and c.proposed == pytest.approx(
        cal.BREAKAWAY_SHARE * 0.02 * 2 * math.pi / 5.0
    )
    assert "static friction finding" in c.reason
    none = cal.breakaway_change(None, 2 * math.pi, dev, 5.0)
    assert none.status == "unchanged" and not none.applies
    off = cal.breakaway_change(None, 2 * math.pi, {**dev, "comp.breakaway": 0.03}, 5.0)
    assert off.status == "change" and off.proposed == 0.0


def test_a_breakaway_beyond_the_limits_is_clipped_and_mu_still_applies():
    """A finding of 0.3 is beyond the compensator's [0, 0.25]: clipped to 0.25 with the reason;
    with mu 0.25 on loop routing the hold's exponent (2 mu + 9/8 m_s) phi <= 4 leaves m_s about
    (4 / 2 pi - 0.5) / 1.125 = 0.1214 beside mu's change, from a report written before calibrate
    proposed a breakaway (its findings and its applied changes)."""
    dev = _device()
    b = cal.breakaway_change(0.3, dev["comp.phi_rad"], dev, dev["comp.phi_rad"], share=1.0)
    cal._check_limits([b], dev, dev["comp.phi_rad"])
    assert b.status == "clipped" and "clipped from 0.3" in b.reason
    assert b.proposed == pytest.approx(0.25, abs=1e-6) and b.proposed <= 0.25
    report = {
        "audit": {
            "phi_rad": dev["comp.phi_rad"],
            "findings": [{"cause": "static_friction", "param": "mu_static_excess", "value": 0.2}],
        },
        "device_phi_rad": dev["comp.phi_rad"],
        "changes": [{"name": "comp.mu", "status": "change", "proposed": 0.25}],
    }
    b = cal.breakaway_of_report(report, dev, share=1.0)
    assert b.status == "clipped" and "clipped from 0.2" in b.reason
    assert b.proposed == pytest.approx((4 / dev["comp.phi_rad"] - 0.5) / 1.125, abs=1e-4)
    assert cal._comp_refuses({**dev, "comp.mu": 0.25, b.name: b.proposed}, "paper") is None


@pytest.mark.slow
def test_a_device_phi_of_zero_refuses_mu(tmp_path):
    """comp.phi_rad 0: no comp.mu gives the plant's mu*phi; refused with the reason."""
    with Bench(emulate=True) as bench:
        bench.set(comp_phi_rad=0.0)
        outcome, _ = _calibrate(bench, bench.info(), tmp_path / "c", apply=True)
        after = _words(bench.client)
    c = {c["name"]: c for c in outcome.report["changes"]}
    assert c["comp.mu"]["status"] == "refused" and "comp.phi_rad is 0" in c["comp.mu"]["reason"]
    assert c["comp.mu_slope_per_n"]["status"] == "unchanged"  # 0, and the audit found none
    assert after == _before(tmp_path / "c")
    json.loads((tmp_path / "c" / "calibration.json").read_text())  # valid JSON (no NaN)


@pytest.mark.slow
def test_an_offset_the_device_has_and_the_plant_does_not_is_taken_back(tmp_path):
    """A value the device holds is judged as the audit's value is: an offset of 0.5 N that the
    plant does not have makes the audit's model worse, so it goes back to 0."""
    with Bench(emulate=True) as bench:
        bench.set(comp_offset_n=0.5)
        outcome, _ = _calibrate(bench, bench.info(), tmp_path / "c")
    c = {c["name"]: c for c in outcome.report["changes"]}
    assert c["comp.offset_n"]["status"] == "change"
    assert c["comp.offset_n"]["proposed"] == pytest.approx(0.0, abs=0.02)


@pytest.mark.slow
def test_the_tare_keeps_a_sensor_offset_out_of_the_compensator(tmp_path):
    """A far-end load cell that reads 0.4 N above the cable (the plant's sensor_offset): the tare
    reads it at zero load, and the compensator's offset stays 0 (before the tare, the audit took
    the cell's error for the tension's and proposed comp.offset_n 0.4, shifting the cable's
    tension by it); mu is still found."""
    with Bench(emulate=True, plant={"mu": 0.09, "sensor_offset": 0.4}) as bench:
        outcome, lines = _calibrate(bench, bench.info(), tmp_path / "c")
    rep = outcome.report
    assert rep["tare"]["offset_n"] == pytest.approx(0.4, abs=0.02)
    tare_line = next(line for line in lines if line.startswith("tare: "))
    assert f"reads {rep['tare']['offset_n']:+.3f} N at zero load" in tare_line, tare_line
    c = {c["name"]: c for c in rep["changes"]}
    assert c["comp.offset_n"]["status"] in ("unchanged", "not significant"), c["comp.offset_n"]
    assert c["comp.mu"]["proposed"] == pytest.approx(0.09, rel=MU_TOLERANCE)


def test_loop_gains_are_never_among_the_changes():
    assert all(name.startswith("comp.") for name in cal.AUDITED)
    assert not set(cal.AUDITED) & set(LOOP)


# --- a link that drops mid-run --------------------------------------------------------------


class DroppingLink:
    """A stepped emulator's link that fails (reads and writes raise as a pulled cable does)
    once `when(link)` says so, for `down_calls` calls (None: for good)."""

    def __init__(self, inner: SteppedLink, when, down_calls: int | None = None):
        self.inner = inner
        self.when = when
        self.down_calls = down_calls
        self.starts = 0
        self.dropped = False
        self._left = 0

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def _check(self) -> None:
        if not self.dropped and self.when(self):
            self.dropped = True
            self._left = self.down_calls if self.down_calls is not None else 1 << 62
        if self._left > 0:
            self._left -= 1
            raise BenchError(f"{self.inner.url}: read failed (link dropped)")

    def send(self, frame) -> None:
        self._check()
        if frame.msg == msgs.MESSAGES["START"].id:
            self.starts += 1
        self.inner.send(frame)

    def recv(self, timeout_s: float):
        self._check()
        return self.inner.recv(timeout_s)


def _drop_run(tmp_path, when, down_calls, plant=None):
    inner = SteppedLink(ChainConfig(plant=plant))
    link = DroppingLink(inner, when, down_calls)
    client = BenchClient(link, timeout_s=0.2)
    info = client.connect()
    before = client.params()
    out = tmp_path / "c"
    with pytest.raises(cal.CalibrationError) as exc:
        _calibrate(client, info, out, apply=True)
    # the device as a fresh client sees it
    probe = BenchClient(inner)
    probe.connect()
    state = probe.params(), probe.hello().running
    inner.close()
    msg = str(exc.value)
    assert "\n" not in msg and str(out / "before.json") in msg
    assert _before(out) == before
    return msg, before, state


def test_a_link_drop_during_identification_leaves_the_device_as_it_was(tmp_path):
    msg, before, (after, running) = _drop_run(
        tmp_path, lambda link: link.starts == 2 and link.inner.chain.ticks > 3000, None
    )
    assert "during the identification run" in msg and "no compensator value was written" in msg
    assert "could not be put back" in msg and "restore with" in msg
    # nothing written: the run settings the link could not put back are the run's only
    assert {n for n in before if before[n] != after[n]} <= set(cal.RUN_PARAMS)
    assert after["comp.mu"] == before["comp.mu"] and not running


@pytest.mark.slow
def test_a_link_drop_after_the_changes_are_written_undoes_them(tmp_path):
    """The link fails during the verification after the write and comes back (for the run's
    failure and the first try of putting back: calibrate.PUT_BACK_TRIES): the written value is
    put back, and so is everything the runs set."""
    msg, before, (after, running) = _drop_run(
        tmp_path,
        lambda link: link.starts == 4 and link.inner.chain.ticks % 1000 == 500,
        down_calls=2,
        plant={"mu": 0.09},
    )
    assert "during the verification after the changes" in msg, msg
    assert "the values written (comp.mu) were put back" in msg, msg
    assert after == before and not running


@pytest.mark.slow
def test_a_link_lost_for_good_after_the_write_says_how_to_restore(tmp_path):
    msg, before, (after, _) = _drop_run(
        tmp_path,
        lambda link: link.starts == 4 and link.inner.chain.ticks % 1000 == 500,
        down_calls=None,
        plant={"mu": 0.09},
    )
    assert "could NOT be put back" in msg and "RAM only" in msg and "restore with" in msg
    assert after["comp.mu"] != before["comp.mu"]  # what the message says the device holds


# --- the command line -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("link", "command"),
    [
        ({"port": "/dev/ttyUSB0"}, "bowden bench --port /dev/ttyUSB0 restore"),
        (
            {"can": "socketcan:can0", "node": 3},
            "bowden bench --can socketcan:can0 --node 3 restore",
        ),
        # an emulated device ends with the command: `--emulate restore` would start a new one
        ({"emulate": True}, None),
        ({"can": "virtual:calibrate", "emulate": True}, None),
    ],
)
def test_the_restore_command_is_given_for_a_device_that_outlives_the_calibration(link, command):
    args = argparse.Namespace(**{"port": None, "can": None, "node": 1, "emulate": False, **link})
    assert bench_tools.restore_command(args) == command


@pytest.mark.parametrize("hint", [None, "bowden bench --port /dev/ttyUSB0 restore"])
def test_a_failed_calibration_says_how_to_get_the_configuration_back(hint, tmp_path, monkeypatch):
    """With a real device, the restore command; with an emulated one (no command), that the
    device ends with the command: never a restore into a new emulated device."""

    def link_lost(client, opts, before_words, state, **kw):
        state.step, state.written = "the verification after the changes", ["comp.mu"]
        raise BenchError("the link went down")

    def put_back_fails(client, before_words, keep):
        raise BenchError("no answer")

    monkeypatch.setattr(cal, "_calibrate", link_lost)
    monkeypatch.setattr(cal, "_put_back", put_back_fails)
    lines = []
    opts = cal.Options(out_dir=tmp_path / "c", apply=True, restore_hint=hint)
    with Bench(emulate=True) as bench, pytest.raises(cal.CalibrationError) as exc:
        cal.run_calibration(bench.client, bench.connect_info, opts, say=lines.append)
    backup = tmp_path / "c" / "before.json"
    msg = str(exc.value)
    if hint is None:
        assert lines == [
            f"saved the device's configuration to {backup} (the emulated device ends with this "
            "command: nothing to restore)"
        ]
        assert "restore with" not in msg
        assert f"the emulated device ends with this command ({backup} holds what it had)" in msg
    else:
        assert lines == [
            f"saved the device's configuration to {backup}; restore it with:",
            f"  {hint} {backup}",
        ]
        assert f"restore with {hint} {backup}" in msg


@pytest.mark.parametrize(
    ("setup", "extra", "message"),
    [
        ("file", [], "is a file, not a folder"),
        ("full", [], "exists and is not empty; --force writes into it"),
        ("none", ["--persist"], "--persist saves what --apply writes: give --apply too"),
        # used to be found after the session opened: exit 1, "No such file or directory"
        ("proc", [], "calibrate --out /proc/bowden-cal: cannot write in /proc"),
        ("under a file", [], "is a file, not a folder"),
    ],
)
def test_bad_calibrate_options_are_one_line_and_exit_2(setup, extra, message, tmp_path, capsys):
    out = tmp_path / "d"
    if setup == "proc":
        out = Path("/proc/bowden-cal")
    elif setup == "under a file":
        (tmp_path / "f").write_text("x")
        out = tmp_path / "f" / "d"
    elif setup == "file":
        out.write_text("x")
    elif setup == "full":
        out.mkdir()
        (out / "keep.txt").write_text("mine")
    rc = bench_cli(["bench", "--emulate", "calibrate", "--out", str(out), *extra])
    err = capsys.readouterr().err
    assert rc == 2 and message in err and len(err.strip().splitlines()) == 1, err
    if setup == "full":
        assert [p.name for p in out.iterdir()] == ["keep.txt"]


@pytest.mark.slow
def test_calibrate_command_applies_and_persists_on_the_stepped_emulator(tmp_path, capsys):
    out = tmp_path / "cal"
    rc = bench_cli(
        [
            "bench",
            "--emulate",
            "--plant",
            "mu=0.06",
            "calibrate",
            "--out",
            str(out),
            "--apply",
            "--persist",
            "--quiet",
        ]
    )
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "nothing to restore" in text and "saved in flash" in text
    assert "bowden bench --emulate restore" not in text  # a new emulated device, on defaults
    rep = json.loads((out / "calibration.json").read_text())
    assert rep["persisted"] and rep["applied"]["comp.mu"] == pytest.approx(0.06, rel=MU_TOLERANCE)
    assert any(p.suffix == ".png" for p in (out / "audit").iterdir())
    assert "| comp.mu | 0.075 |" in (out / "calibration.md").read_text()


@pytest.mark.slow
def test_a_change_that_makes_the_verification_worse_is_undone(tmp_path, monkeypatch):
    """A proposal gone wrong (comp.mu 0.03 on the nominal plant, planted in place of the
    audit's): the verification after is worse, the value is put back, exit 1."""
    real = cal.propose

    def wrong(result, device, phi):
        changes = real(result, device, phi)
        for c in changes:
            if c.name == "comp.mu":
                c.proposed, c.status, c.reason = 0.03, "change", "planted"
        return changes

    monkeypatch.setattr(cal, "propose", wrong)
    with Bench(emulate=True) as bench:
        outcome, lines = _calibrate(bench, bench.connect_info, tmp_path / "c", apply=True)
        after = _words(bench.client)
    assert outcome.exit_code == 1
    m = outcome.report["measured"]
    assert m["after"]["rms_error_n"] > m["before"]["rms_error_n"]
    assert not outcome.report["applied_kept"] and "the changes are undone" in lines[-2]
    assert after == _before(tmp_path / "c")
