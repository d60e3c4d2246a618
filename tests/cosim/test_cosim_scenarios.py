"""Scenario definitions and run configuration (cosim/config/scenarios.py)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from cosim.config import run as run_cfg
from cosim.config import scenarios as sc


def test_cosim_scenarios_characterize_is_the_papers_ramp():
    cfg = run_cfg.SimConfig()
    scen = sc.get_scenario("characterize")
    inp = sc.sample_inputs(scen, cfg)
    assert scen.duration_s == pytest.approx(15.0)  # 3 s, five times (Sec. VI-A)
    assert len(inp.t_s) == 150_000
    assert inp.t_ref_n.max() == pytest.approx(24.0, abs=0.01)
    peaks = np.flatnonzero(np.isclose(inp.t_ref_n, 24.0))
    np.testing.assert_allclose(inp.t_s[peaks], [1.5, 4.5, 7.5, 10.5, 13.5])
    assert inp.t_ref_n.min() == 0.0
    # Held in the loop's plane: phi = 2*pi with loop routing.
    assert np.all(inp.x_m == 0.0)


def test_cosim_scenarios_positions_hold_each_position_and_stay_in_the_workspace():
    cfg = run_cfg.SimConfig()
    scen = sc.get_scenario("positions")
    inp = sc.sample_inputs(scen, cfg)
    assert len(scen.segments) == len(sc.POSITIONS_M)
    for seg in scen.segments:
        k = int((seg.t_end_s - 0.01) * cfg.sample_rate_hz)
        got = (inp.x_m[k], inp.y_m[k], inp.z_m[k])
        assert got == pytest.approx(seg.position_m)
    r = np.sqrt(inp.x_m**2 + inp.y_m**2 + inp.z_m**2)
    assert r.max() < sc.SHEATH_LENGTH_M and inp.y_m.min() >= 0.0  # paper Eq. 13
    # Moves are smooth: no jump larger than 1 mm per sample.
    step = np.sqrt(np.diff(inp.x_m) ** 2 + np.diff(inp.y_m) ** 2 + np.diff(inp.z_m) ** 2)
    assert step.max() < 1e-3


def test_cosim_scenarios_fig14_reference_and_motion():
    cfg = run_cfg.SimConfig()
    scen = sc.get_scenario("fig14")
    inp = sc.sample_inputs(scen, cfg)
    assert scen.duration_s == 30.0
    assert inp.t_ref_n.max() == pytest.approx(15.0, abs=1e-6)  # paper: max reference 15 N
    settled = inp.t_s >= scen.settle_s
    assert inp.t_ref_n[settled].min() == pytest.approx(sc.FIG14_MIN_N, abs=1e-3)
    assert np.ptp(inp.y_m) > 0.2 and np.ptp(inp.z_m) > 0.3 and np.ptp(inp.x_m) > 0.05
    # Shortened runs take the first samples of the same scenario.
    short = sc.sample_inputs(scen, cfg, duration_s=2.0)
    np.testing.assert_array_equal(short.t_ref_n, inp.t_ref_n[:20_000])


def test_cosim_scenarios_unknown_name_is_a_clear_error():
    with pytest.raises(ValueError, match="scenario must be one of characterize, positions"):
        sc.get_scenario("fig15")


def test_cosim_scenarios_kff_matches_the_contract():
    # paper Table I: 0.01 / (5.4 * 0.9 * 0.0234) ~ 0.088 A/N
    assert run_cfg.KFF_A_PER_N == pytest.approx(0.088, abs=5e-4)


def test_cosim_scenarios_params_file_overrides_and_validation(tmp_path):
    p = tmp_path / "p.json"
    p.write_text(json.dumps({"plant": {"mu": 0.09}, "controller": {"kp_a_per_n": 0.1}}))
    cfg = run_cfg.load_params(p)
    assert cfg.plant == {"mu": 0.09} and cfg.controller.kp_a_per_n == 0.1
    assert cfg.decimation == 10
    cases = [
        ({"sample_rate_hz": 10_000, "firmware_rate_hz": 3000}, "must be a whole number"),
        ({"controller": {"i_limit_a": 9.0}}, r"controller.i_limit_a must be in \[0, 7.9997\]"),
        (
            {"controller": {"ki_a_per_n_s": 400.0}},
            r"controller.ki_a_per_n_s must be in \[0, 312.5\]",
        ),
        ({"compensator": {"mu": -0.1}}, r"compensator.mu must be in \[0, 1\]"),
        ({"compensator": {"phi_rad": 20.0}}, r"compensator.phi_rad must be in \[0, 12.56"),
        ({"compensator": {"band_n": 0.0}}, r"compensator.band_n must be in"),
        ({"controller": {"kp": 1}}, "unknown key 'kp'"),
        ({"plant": {"mu": "high"}}, "plant.mu must be a number"),
        ({"plant": {"mu": math.nan}}, "plant.mu must be in"),
        ({"speed": 1}, "unknown key 'speed'"),
    ]
    for data, message in cases:
        p.write_text(json.dumps(data))
        with pytest.raises(ValueError, match=message):
            run_cfg.load_params(p)
    p.write_text("{not json")
    with pytest.raises(ValueError, match="is not valid JSON"):
        run_cfg.load_params(p)
    with pytest.raises(ValueError, match="does not exist"):
        run_cfg.load_params(tmp_path / "missing.json")


def test_cosim_sim_cli_rejects_bad_input_before_running(tmp_path, capsys):
    from cosim import cli

    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"controller": {"kp_a_per_n": 9}}))
    assert cli.main(["sim", "fig14", "--out", str(tmp_path), "--duration", "-1"]) == 2
    assert (
        "--duration must be in [0.01, 3600] s (at least 10 firmware ticks"
        in capsys.readouterr().err
    )
    assert cli.main(["sim", "fig14", "--out", str(tmp_path), "--params", str(bad)]) == 2
    assert "controller.kp_a_per_n must be in [0, 3.9998]; got 9" in capsys.readouterr().err
    assert not (tmp_path / "result.json").exists()


def test_cosim_demo_table_prints_the_figures_of_the_json(tmp_path):
    from cosim.studies import demo

    paths = []
    for i, (comp, loop) in enumerate((("paper", True), ("smooth", True), ("paper", False))):
        result = {
            "scenario": "fig14",
            "compensator": comp,
            "loop_routing": loop,
            "rms_error_n": 0.5 + i / 7,
            "rms_error_pct": 3.0 + i / 3,
            "peak_error_n": 2.0 + i / 9,
            "peak_error_pct": 13.0 + i / 11,
            "fixed_vs_float": {
                "current_rms_lsb": 0.75,
                "current_max_lsb": 2.0,
                "t_out_rms_n": 3e-4,
            },
            "simulated_per_wall": 1.1,
        }
        path = tmp_path / f"r{i}.json"
        path.write_text(json.dumps(result))
        paths.append(path)
    table = demo.table_from_files(paths)
    for i, path in enumerate(paths):
        r = json.loads(path.read_text())
        row = [line for line in table.splitlines() if line.startswith("fig14")][i].split()
        assert row[1] == r["compensator"] and row[2] == ("on" if r["loop_routing"] else "off")
        assert [float(v) for v in row[3:7]] == [
            round(r["rms_error_n"], 3),
            round(r["rms_error_pct"], 1),
            round(r["peak_error_n"], 3),
            round(r["peak_error_pct"], 1),
        ]
    assert "paper Fig.14" in table and "4.3" in table and "13.3" in table
