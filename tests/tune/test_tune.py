"""bowden tune (cosim/tune): the stability probe sees a limit cycle, the shipped gains hold the
stated Kp margin, the defaults agree everywhere, and the procedure's rule (lowest SCORE among
stable points, margin required) is the one it applies, on the tune scenario only."""

from __future__ import annotations

import ctypes
import json
import math

import pytest

import cosim.studies.tune as tn
from cosim.config.run import SimConfig
from cosim.config.scenarios import TUNE_SCENARIO
from cosim.parts import regmap
from cosim.parts.firmware import CompConfig, load_library
from cosim.parts.firmware import CompensatorParams as FwComp

# The margin stated in hdl/README.md for the shipped gains (`bowden tune` measured x3.05).
STATED_KP_MARGIN = tn.MIN_KP_MARGIN


def test_tune_hold_probe_sees_the_limit_cycle_and_the_default_holds():
    """On the board's chain (ADS131M02, the one the shipped gains were tuned on) Kp = 0.7 A/N
    rings (the ADC's age and the PWM's delay; measured 1.28 N peak-to-peak, asserted > 1 N); the
    shipped gains hold (0.038 N), and still hold at the stated margin on Kp (0.038 N at x3)."""
    cfg = SimConfig()
    assert cfg.board.adc == "ads131m02"
    ringing = tn.limit_cycle_pp_n(tn.with_params(cfg, kp_a_per_n=0.7), "board")
    assert ringing > 4 * tn.LIMIT_CYCLE_PP_N, ringing
    assert tn.limit_cycle_pp_n(cfg, "board") <= tn.LIMIT_CYCLE_PP_N
    kp = cfg.controller.kp_a_per_n * STATED_KP_MARGIN
    assert tn.stable(tn.with_params(cfg, kp_a_per_n=kp), "board"), kp


def test_tune_defaults_agree_across_regmap_firmware_and_cosim():
    """The tuned point is the register map's reset (KP, KI_TS at 10 kHz), the firmware's
    compensator default and the co-simulation's default."""
    cfg = SimConfig()
    kp_word = regmap.REGISTERS["KP"].fields[0].reset
    ki_word = regmap.REGISTERS["KI_TS"].fields[0].reset
    assert kp_word == round(cfg.controller.kp_a_per_n * 2**13)
    assert ki_word == round(cfg.controller.ki_a_per_n_s / cfg.sample_rate_hz * 2**20)
    fw = FwComp()
    c = cfg.compensator
    want = (c.preview_ticks, c.lead_ticks, c.ramp_ticks, round(c.band_n * 256))
    assert (fw.preview_ticks, fw.lead_ticks, fw.ramp_ticks, round(fw.band_n * 256)) == want
    lib = load_library()
    cc = CompConfig()
    lib.comp_config_default(ctypes.byref(cc))  # the C firmware's own defaults
    assert (cc.preview_ticks, cc.lead_ticks, cc.ramp_ticks, cc.band_n_q8) == want


def test_tune_procedure_takes_the_lowest_score_of_stable_points(monkeypatch):
    """With the simulations replaced by a known landscape: unstable points are never chosen,
    the lowest SCORE wins at each stage, the margin is the last stable factor, and only the
    tune scenario is scored."""
    scenarios = []

    def fake_stable(cfg, interface):
        return cfg.controller.kp_a_per_n < 0.3 and cfg.controller.ki_a_per_n_s < 7.0

    def fake_score(cfg, compensator, interface, scenario=TUNE_SCENARIO):
        scenarios.append(scenario)
        c, k = cfg.compensator, cfg.controller
        s = abs(k.ki_a_per_n_s - 14.0) + abs(c.band_n - 2.0) + 10 * abs(k.kp_a_per_n - 0.05)
        if compensator == "preview":
            s += abs(c.ramp_ticks - 120) / 40 + abs(c.preview_ticks - 70) / 10 + c.lead_ticks
        return s, s, s

    monkeypatch.setattr(tn, "stable", fake_stable)
    monkeypatch.setattr(tn, "score", fake_score)
    r = tn.tune("board", confirm=False)
    assert set(scenarios) == {TUNE_SCENARIO}
    assert r.kp_a_per_n == 0.05  # the best candidate, all <= Kp_crit / 3 (Kp_crit ~ 0.36)
    assert r.ki_a_per_n_s == 5.0 and r.band_n == 2.0  # Ki 10 scores better, but cycles
    assert (r.ramp_ticks, r.preview_ticks, r.lead_ticks) == (120, 70, 0)
    assert r.kp_margin >= tn.MIN_KP_MARGIN and math.isfinite(r.kp_critical_a_per_n)
    assert "chosen: Kp 0.05" in r.summary()
    assert r.params()["compensator"]["ramp_ticks"] == 120


def test_tune_fails_when_the_margin_is_short(monkeypatch):
    """A landscape where the best gains sit just below a limit cycle: the run fails, naming the
    margin, rather than ship them."""
    monkeypatch.setattr(tn, "stable", lambda cfg, i: cfg.controller.kp_a_per_n < 0.09)
    monkeypatch.setattr(tn, "score", lambda cfg, comp, i, scenario=TUNE_SCENARIO: (1.0, 1.0, 1.0))
    monkeypatch.setattr(tn, "KP_CANDIDATES", (0.05, 0.07))
    with pytest.raises(RuntimeError, match="Kp margin"):
        tn.tune("board", confirm=False)


def test_tune_cli_starts_from_a_params_file_and_keeps_it(monkeypatch, tmp_path, capsys):
    """`bowden tune --params F` tunes the chain F describes (here the ADS1220 front-end) and
    writes F with the chosen point over it, so `bowden sim --params` runs that same chain."""
    from cosim.cli import main

    seen = {}

    def fake_tune(interface, cfg, confirm, log):
        seen["adc"] = cfg.board.adc
        return tn.TuneResult(interface, 0.05, 2.5, 0.5, 100, 0, 200, 0.19, 3.05)

    monkeypatch.setattr(tn, "tune", fake_tune)
    src = tmp_path / "ads1220.json"
    src.write_text('{"board": {"adc": "ads1220"}, "controller": {"kp_a_per_n": 0.3}}')
    out = tmp_path / "out"
    assert main(["tune", "--params", str(src), "--out", str(out), "--quiet"]) == 0
    assert seen == {"adc": "ads1220"}
    written = json.loads((out / "tuned_params.json").read_text())
    assert written["board"] == {"adc": "ads1220"}
    assert written["controller"] == {"kp_a_per_n": 0.05, "ki_a_per_n_s": 2.5}
    assert written["compensator"]["ramp_ticks"] == 200


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "does not exist"),
        ('{"board": {"adc": "ads9999"}}', "board.adc must be one of"),
    ],
)
def test_tune_cli_names_a_bad_params_file(monkeypatch, tmp_path, capsys, content, message):
    """A missing or invalid --params file: one line naming it, exit 2, nothing tuned."""
    from cosim.cli import main

    monkeypatch.setattr(tn, "tune", lambda **kw: pytest.fail("tuned despite a bad file"))
    src = tmp_path / "p.json"
    if content is not None:
        src.write_text(content)
    assert main(["tune", "--params", str(src), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("bowden tune: ") and message in err and "\n" not in err, err


def test_tune_cli_names_a_short_margin_once(monkeypatch, tmp_path, capsys):
    """A tuning that fails (here: the margin) is one line with the command's name once, exit 1,
    and no params file."""
    from cosim.cli import main

    monkeypatch.setattr(tn, "stable", lambda cfg, i: cfg.controller.kp_a_per_n < 0.09)
    monkeypatch.setattr(tn, "score", lambda cfg, comp, i, scenario=TUNE_SCENARIO: (1.0, 1.0, 1.0))
    monkeypatch.setattr(tn, "KP_CANDIDATES", (0.05, 0.07))
    out = tmp_path / "o"
    assert main(["tune", "--no-confirm", "--out", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("bowden tune: Kp margin x") and err.count("bowden tune") == 1, err
    assert not (out / "tuned_params.json").exists()
