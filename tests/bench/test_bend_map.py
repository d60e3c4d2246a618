"""calibrate's map of the bending angle (cosim.bench.rig.bend_map): the plane through the ratios,
its bounds and inputs; on the stepped emulator, the ratio it fits at each position is the plant
FMU's own phi(p) / phi(home) (the FMU's bending-angle errors, which no compensator parameter
holds), also when home's model misses part of the plant; `bowden bench calibrate --map` writes
it, asks the user to move the end-effector on a device, and refuses a bad position in one line;
the sensorless study sets each run's angle from it."""

import argparse
import json

import numpy as np
import pytest

from cosim.bench import command_tools as bench_tools
from cosim.bench.__main__ import main as bench_cli
from cosim.bench.api import Bench
from cosim.bench.emulate.host_device import ChainConfig
from cosim.bench.link.client import BenchError
from cosim.bench.rig import bend_map as bm
from cosim.bench.rig import calibrate as cal
from cosim.bench.rig.run import STATUS_OUT_EN as OUT_EN
from cosim.engines.harness import open_plant
from cosim.parts.geometry import bending_angle
from cosim.studies import calibrated_robustness as cr

HOME = (0.0, 0.5, 0.0)
# A plant whose bending angle moves with the end-effector along z and y (fmu/README.md,
# "Effects": phi_offset_per_z, phi_offset_per_y, rad/m) and whose mu is not the nominal.
PLANT = {"mu": 0.09, "phi_offset_per_z": 0.8, "phi_offset_per_y": -0.4}
# Stated tolerance of a fitted ratio against the FMU's: measured 4e-5 at the default positions
# and 5e-5 for the plane at (0, 0.75, -0.3) (the emulated load cell's 1/256 N words, the input's
# smoothing); 2e-4 leaves a margin of 4x, and is a fiftieth of the 1 % the sensorless study
# shows the map taking away.
RATIO_TOL = 2e-4


def _phi(position) -> float:
    """The FMU's bending angle (its `phi` output, with the bending-angle errors) at a position."""
    from cosim.config.run import SimConfig  # noqa: PLC0415

    cfg = SimConfig.from_dict({"plant": PLANT}, source="test")
    plant = open_plant(cfg, True, tuple(position))
    try:
        return float(plant.y[plant.PHI])
    finally:
        plant.close()


def _points(ratios: dict) -> list[bm.Point]:
    return [bm.Point(p, k, 0.1, 0.01) for p, k in ratios.items()]


def test_the_plane_goes_through_three_ratios_and_holds_its_bounds():
    g = np.array([0.05, -0.1, 0.2])
    pts = {p: 1.0 + float(g @ (np.array(p) - HOME)) for p in bm.DEFAULT_POSITIONS_M}
    m = bm.fit_plane(HOME, _points(pts))
    assert m.gradient_per_m == pytest.approx(tuple(g), abs=1e-12)
    assert m.residual == pytest.approx(0.0, abs=1e-12)
    assert m.ratio((0.0, 0.75, -0.3)) == pytest.approx(1.0 - 0.025 - 0.06, abs=1e-12)
    assert m.phi_at(6.0, HOME) == 6.0
    # far out the plane is held to the map's bounds
    assert m.ratio((0.0, 0.5, 3.0)) == bm.K_MAX and m.ratio((0.0, 0.5, -3.0)) == bm.K_MIN


def test_a_direction_not_measured_stays_unchanged_and_a_bent_sheath_shows_as_a_miss():
    m = bm.fit_plane(HOME, _points({(0.0, 0.5, 0.2): 1.02}))
    assert m.gradient_per_m == pytest.approx((0.0, 0.0, 0.1))
    assert m.ratio((0.3, 0.2, 0.0)) == 1.0  # x and y: not measured
    # an error curved along z (the same either side of home): the plane through home has no
    # slope along z and misses both by all of it, and says so
    m = bm.fit_plane(
        HOME,
        _points({(0.0, 0.5, 0.2): 1.02, (0.0, 0.5, -0.2): 1.02, (0.0, 0.7, 0.0): 1.0}),
    )
    assert m.gradient_per_m == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    assert m.residual == pytest.approx(0.02, rel=1e-9)


@pytest.mark.parametrize(
    ("points", "message"),
    [([], "at least one position besides home"), ([(HOME, 1.0)], "is home itself")],
)
def test_a_map_without_a_position_apart_from_home_is_refused(points, message):
    with pytest.raises(bm.BendMapError, match=message):
        bm.fit_plane(HOME, _points(dict(points)))


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("0,0.5", "'0,0.5' is not a position x,y,z in m"),
        ("0,0.5,0;a,b,c", "'a,b,c' is not a position"),
        ("0,0.5,nan", "'0,0.5,nan' is not a position"),
        (" ; ", "no position given"),
    ],
)
def test_bad_positions_are_named(text, message):
    with pytest.raises(bm.BendMapError, match=message):
        bm.parse_positions(text)
    assert bm.parse_positions("0.2,0.5,0; 0,0.7,0;") == ((0.2, 0.5, 0.0), (0.0, 0.7, 0.0))


def test_a_map_file_round_trips_and_a_broken_one_is_named(tmp_path):
    m = bm.fit_plane(HOME, _points({(0.0, 0.5, 0.2): 1.02}))
    m.home_ratio = 1.01
    m.write(tmp_path / bm.FILE)
    back = bm.read(tmp_path / bm.FILE)
    assert back.to_dict() == m.to_dict()
    (tmp_path / "bad.json").write_text('{"home_m": [0, 0.5]}')
    with pytest.raises(bm.BendMapError, match="home_m: expected three finite numbers"):
        bm.read(tmp_path / "bad.json")


@pytest.mark.slow
@pytest.mark.parametrize("model_mu", [0.09, 0.085])
def test_the_fitted_ratios_are_the_plants_own_bending_angles(model_mu, tmp_path):
    """On the stepped emulator the map's ratio at each position is the FMU's phi(p) / phi(home);
    with home's model 6 % off the plant's mu, home's own ratio takes the miss out of every
    position (home_ratio near 0.09 / 0.085) and the positions' ratios stay the plant's."""
    opts = cal.Options(out_dir=tmp_path, audit_plots=False, predict=False)
    phi_home = float(bending_angle(*HOME, 1.0, True))
    lines = []
    m = cal.make_bend_map(
        bm.emulated_at(PLANT),
        bm.DEFAULT_POSITIONS_M,
        {"mu": model_mu},
        phi_home,
        0.0,
        opts,
        say=lines.append,
    )
    true_home = _phi(HOME)
    assert m.home_ratio == pytest.approx(0.09 / model_mu * true_home / phi_home, rel=RATIO_TOL)
    for pt in m.points:
        assert pt.ratio == pytest.approx(_phi(pt.position_m) / true_home, abs=RATIO_TOL)
    # the plane, away from where it was measured (the FMU's errors are linear in the position)
    run = (0.0, 0.75, -0.3)
    assert m.ratio(run) == pytest.approx(_phi(run) / true_home, abs=2 * RATIO_TOL)
    assert len(lines) == 4 and (tmp_path / bm.FILE).is_file()
    assert [p.file for p in m.points] == ["map_1.csv", "map_2.csv", "map_3.csv"]


@pytest.mark.slow
def test_calibrate_map_on_the_emulator_writes_the_map_and_its_section(tmp_path, capsys):
    out = tmp_path / "cal"
    rc = bench_cli(
        [
            "bench",
            "--emulate",
            "--plant",
            ",".join(f"{k}={v}" for k, v in PLANT.items()),
            "calibrate",
            "--out",
            str(out),
            "--quiet",
            "--map",
            "0,0.5,0.2",
        ]
    )
    text = capsys.readouterr().out
    assert rc == 0, text
    rep = json.loads((out / "calibration.json").read_text())
    (pt,) = rep["bend_map"]["points"]
    assert pt["ratio"] == pytest.approx(_phi((0.0, 0.5, 0.2)) / _phi(HOME), abs=RATIO_TOL)
    assert bm.read(out / bm.FILE).to_dict() == rep["bend_map"]
    md = (out / "calibration.md").read_text()
    assert "## Bending angle over the workspace" in md and "| 0, 0.5, 0.2 |" in md
    assert "the host sets comp.phi_rad" in text


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("0,0.5", "--map: '0,0.5' is not a position x,y,z in m"),
        ("0,1.2,0", "--map: position (0, 1.2, 0) m is outside the workspace"),
    ],
)
def test_a_bad_map_position_is_one_line_and_exit_2(value, message, tmp_path, capsys):
    out = tmp_path / "d"
    rc = bench_cli(["bench", "--emulate", "calibrate", "--out", str(out), "--map", value])
    err = capsys.readouterr().err
    assert rc == 2 and message in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists()


def _device_at(client, answers):
    """bench_at as on a device (not --emulate), the user's answers to its prompts given."""
    args = argparse.Namespace(emulate=False)
    stops = []

    def after_run():
        stops.append(client.request("STOP"))

    def fake_input(*_):
        a = answers.pop(0)
        if isinstance(a, BaseException):
            raise a
        return a

    return bench_tools._bench_at(client, args, after_run), stops, fake_input


@pytest.mark.slow
def test_on_a_device_the_user_is_asked_to_move_and_the_output_is_off_after_each_run(
    tmp_path, capsys, monkeypatch
):
    with Bench(emulate=True, chain=ChainConfig(plant=PLANT)) as bench:
        at, stops, fake_input = _device_at(bench.client, ["", ""])
        monkeypatch.setattr("builtins.input", fake_input)
        opts = cal.Options(out_dir=tmp_path, audit_plots=False, predict=False)
        m = cal.make_bend_map(at, [(0.0, 0.5, 0.2)], {"mu": 0.09}, 2 * np.pi, 0.0, opts, say=print)
        running = bench.client.hello().running
        _, faults = bench.client.request("FAULTS_GET")
    text = capsys.readouterr().out
    assert text.count("move the end-effector to") == 2
    assert "move the end-effector to (0, 0.5, 0) m (the output is disabled)" in text
    assert "move the end-effector to (0, 0.5, 0.2) m" in text
    assert len(stops) == 2 and not running and not faults["fpga_status"] & OUT_EN
    # the emulated device stays at home: nothing moved, the ratio is 1
    assert m.points[0].ratio == pytest.approx(1.0, abs=RATIO_TOL)


@pytest.mark.parametrize("answer", [EOFError(), KeyboardInterrupt()])
def test_no_answer_or_ctrl_c_at_the_prompt_ends_the_map_before_any_run(answer, tmp_path):
    with Bench(emulate=True) as bench:
        at, stops, fake_input = _device_at(bench.client, [answer])
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr("builtins.input", fake_input)
            expected = BenchError if isinstance(answer, EOFError) else KeyboardInterrupt
            opts = cal.Options(out_dir=tmp_path, audit_plots=False, predict=False)
            with pytest.raises(expected):
                cal.make_bend_map(
                    at, [(0.0, 0.5, 0.2)], {"mu": 0.075}, 2 * np.pi, 0.0, opts, say=print
                )
    assert stops == [] and not list(tmp_path.glob("map_*.csv"))


def test_the_study_sets_each_runs_angle_from_the_map():
    m = bm.fit_plane(HOME, _points({(0.0, 0.5, 0.2): 1.02}))
    comp = {n: 0.0 for n in cr.COMP_KEYS}
    comp.update({"device_phi_rad": 6.0, "bend_map": m.to_dict()})
    v = cr.run_values({"position_m": [0.0, 0.5, 0.1]}, comp)
    assert v["compensator.phi_rad"] == pytest.approx(6.0 * 1.01)
    # without the map, calibrate's angle
    v = cr.run_values({"position_m": [0.0, 0.5, 0.1]}, {**comp, "bend_map": None})
    assert v["compensator.phi_rad"] == 6.0


def test_the_map_helper_gives_the_angle_and_names_bad_input(tmp_path, capsys):
    m = bm.fit_plane(HOME, _points({(0.0, 0.5, 0.2): 1.02}))
    m.write(tmp_path / bm.FILE)
    f = str(tmp_path / bm.FILE)
    assert bm.main([f, "--phi-home", "6", "--at", "0,0.5,0.1"]) == 0
    assert capsys.readouterr().out.strip() == "(0, 0.5, 0.1) m: k 1.0100, comp.phi_rad 6.0600"
    for argv, message in (
        ([f, "--phi-home", "-1", "--at", "0,0.5,0"], "--phi-home -1: expected an angle"),
        ([f, "--phi-home", "6", "--at", "0,0.5"], "--at: '0,0.5' is not a position"),
        ([f + "x", "--phi-home", "6", "--at", "0,0.5,0"], "cannot read a bending-angle map"),
    ):
        assert bm.main(argv) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1, err
