"""The studies that take a sweep specification (cosim.studies.calibrated_robustness,
cosim.studies.tracking_floor) read its plants from the spec's axes, whatever they are, and join
a mode's results by plant and position."""

import contextlib
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from cosim.project.paths import REPO_ROOT
from cosim.studies import calibrated_robustness as cr
from cosim.studies import tracking_floor as tf
from cosim.studies.sweep.spec import parse_spec

RANDOM = {
    "scenario": "fig14",
    "sampling": "random",
    "samples": 4,
    "seed": 5,
    "config": {"plant": {"noise_std": 0.01}},
    "axes": {
        "compensator": ["preview"],
        "position_m": [[0.0, 0.6, 0.0], [0.0, 0.4, 0.25]],
        "plant.mu": {"min": 0.05, "max": 0.1, "n": 2},
        "plant.dead_zone_spread": {"min": 0.0, "max": 0.6, "n": 2},
    },
}


def test_a_random_specs_plants_come_from_its_axes_over_its_base_plant():
    spec = parse_spec(RANDOM)
    plants = [cr.plant_of(spec, p.values) for p in spec.points()]
    assert len({json.dumps(p, sort_keys=True) for p in plants}) == 4  # one plant a point
    for p, point in zip(plants, spec.points(), strict=True):
        assert set(p) == {"noise_std", "mu", "dead_zone_spread"}
        assert p["mu"] == point.values["plant.mu"] and 0.05 <= p["mu"] <= 0.1
        assert p["noise_std"] == 0.01


def test_a_grids_plants_are_the_product_of_its_plant_axes():
    grid = {
        "scenario": "fig14",
        "axes": {
            "compensator.est_enable": [0, 1],
            "position_m": [[0.0, 0.6, 0.0]],
            "plant.mu": [0.06, 0.09],
            "plant.cable_EA": [6400, 9600],
        },
    }
    spec = parse_spec(grid)
    plants = {json.dumps(cr.plant_of(spec, p.values), sort_keys=True) for p in spec.points()}
    assert len(plants) == 4  # est_enable does not make a plant


def test_the_floor_joins_a_modes_rows_by_plant_and_position(tmp_path):
    """A mode's rows (a sweep folder's points) are matched to the floor's by plant and position,
    not by the controller's axes; the ratios are the mode's figure over the floor's."""
    spec = parse_spec(RANDOM)
    points = [p.values for p in spec.points()]
    floors = [
        {"rms_error_pct": 0.5, "peak_error_pct": 2.0}
        | {"true_rms_error_pct": 0.5, "true_peak_error_pct": 2.0}
        for _ in points
    ]
    folder = tmp_path / "sweep" / "points"
    folder.mkdir(parents=True)
    for i, v in enumerate(points):
        row = {"rms_error_pct": 1.0 + i, "peak_error_pct": 4.0, "status": "ok"}
        values = {**v, "compensator.est_enable": 1}  # a controller axis the floor ignores
        (folder / f"{i}.json").write_text(json.dumps({"values": values, "row": row}))
    mode = tf.load_mode(tmp_path / "sweep")
    lines = tf.summary(points, floors, {"estimate": mode})
    row = next(line for line in lines if line.startswith("| estimate, far-end reading"))
    rms = [1.0 + i for i in range(len(points))]
    assert f"| {np.median(rms):.2f} % | {max(rms):.2f} % |" in row
    assert f"RMS {np.median(rms) / 0.5:.1f}x / {max(rms) / 0.5:.1f}x" in row
    assert "peak 2.0x / 2.0x" in row
    assert "no floor) on 0 |" in row
    # a floor above the mode's error (the oracle rang) is counted, not taken for a floor
    floors[0] = {**floors[0], "rms_error_pct": 9.0}
    row = next(line for line in tf.summary(points, floors, {"e": mode}) if line.startswith("| e,"))
    assert "no floor) on 1 |" in row


def test_the_oracles_set_values_are_the_escons_duty_levels():
    levels = tf._levels(4.0)
    assert len(levels) == 801 and levels[0] == -4.0 and levels[-1] == 4.0
    assert np.allclose(np.diff(levels), 0.01)


def _floor_plant(duration_s: float) -> "tf.FloorPlant":
    spec = parse_spec({"scenario": "fig14", "duration_s": duration_s, "axes": {}})
    (point,) = spec.points()
    return tf.FloorPlant(spec.run_spec(point))


def test_the_refinement_learns_a_current_trajectory_from_nothing():
    """The floor's refinement (P-type ILC on the exact model) from a seed of no current at all,
    on the nominal plant, at a learning gain of 0.5: within six iterations the true RMS falls
    below a fifth of the seed's (it starts at T_ref's own RMS, 12.1 N; 1.56 N at the sixth),
    every iterate is a trajectory the drive can take (one ESCON level a PWM period, within
    +-I_max), and the plant's gain and delay it reads are the cable's (a positive static gain;
    the response peaks after the drive's and the cable's lag, not at once)."""
    fp = _floor_plant(1.6)
    r = tf.refine(fp, np.zeros(fp.n), iterations=6, gain=0.5)
    hist = r["history_rms_n"]
    assert len(hist) == 7 and min(hist) < 0.2 * hist[0], hist
    assert r["gain_n_per_a"] > 0 and 0 < r["delay_samples"] < 400, r
    for key in ("rms_commands", "peak_commands"):
        cmd = r[key]
        assert cmd.shape == (fp.n,)
        assert np.all(np.abs(cmd) <= fp.levels[-1])
        assert np.all(np.isin(cmd, fp.levels))
        held = cmd[: fp.n // fp.ratio * fp.ratio].reshape(-1, fp.ratio)
        assert np.all(held == held[:, :1])  # one set value a PWM period
    # the kept iterate is the best one seen, and its replay on the exact model agrees
    assert fp.true_error_n(fp.true_out(r["rms_commands"]))[0] == pytest.approx(min(hist), rel=1e-9)


def test_a_floor_is_the_best_of_the_oracle_a_modes_run_and_the_refinement(tmp_path):
    """floor_point with a mode's point as a seed (here the default controller on the nominal
    plant, 1.6 s of fig14): both the oracle's and the mode's trajectory are candidates, the
    refinement runs from the better of them, and the floor's RMS and peak are the lowest of
    everything tried (so never above the oracle's nor the mode's own)."""
    spec_path = tmp_path / "spec.yaml"
    spec_path.write_text(json.dumps({"scenario": "fig14", "duration_s": 1.6, "axes": {}}))
    (point,) = parse_spec(json.loads(spec_path.read_text())).points()
    r = tf.floor_point(str(spec_path), point.values, seeds={"m": point.values}, iterations=2)
    seeds = r["seeds_true_rms_pct"]
    assert set(seeds) == {"oracle", "mode m"}
    assert r["true_rms_error_pct"] <= min(seeds.values())
    assert r["true_peak_error_pct"] <= r["oracle"]["true_peak_error_pct"]
    assert r["from"] in ("oracle", "mode m") or r["from"].startswith("refined from ")
    assert len(r["refine"]["history_rms_n"]) == 3
    assert r["breakaway_peak_bound_pct"] is None and r["breakaway_bound_holds"]


def test_the_breakaway_bound_rests_on_the_plants_own_jump():
    """The floor's lower bound on the peak for a sharp breakaway (tracking_floor.
    breakaway_peak_bound_pct) takes the jump at a release to be c T_s, c = 1 - e^(-b phi): the
    exact model, pulled to 8.5 N and let go slowly, drops by that in one sample (within 1 %), and
    the bound is R (c / 2) / (1 + c / 2) of the reference's maximum, 8.13 % for b = 0.031 at
    phi = 2 pi. Without a breakaway there is no bound."""
    spec = parse_spec(
        {
            "scenario": "fig14",
            "duration_s": 1.6,
            "config": {
                "plant": {"mu_static_excess": 0.031, "dead_zone_spread": 0.0, "mu_viscous": 0.0}
            },
            "axes": {},
        }
    )
    (point,) = spec.points()
    fp = tf.FloorPlant(spec.run_spec(point))
    t = np.arange(fp.n) * fp.dt
    out = fp.true_out(fp.project(np.interp(t, [0, 0.6, 0.8, 1.6], [0, 1.2, 1.2, 0.2])))
    drop = np.diff(out)
    k = int(np.argmin(drop))
    phi = float(np.min(fp.phi_rad()))
    c = 1 - np.exp(-0.031 * phi)
    assert out[k] > 8.0 and -drop[k] == pytest.approx(c * out[k], rel=0.01), (out[k], drop[k])
    bound = tf.breakaway_peak_bound_pct(fp)
    assert bound == pytest.approx(100 * (c / 2) / (1 + c / 2), rel=1e-12)
    assert bound == pytest.approx(8.13, abs=0.01)
    assert tf.breakaway_bound_holds(fp)
    assert tf.breakaway_peak_bound_pct(_floor_plant(0.2)) is None


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--only", "3,x"], "--only 3,x: not whole numbers"),
        (["--only", "99"], "--only: 99 is not a plant of this spec (0 .. 3)"),
        (["--refine", "-1"], "--refine -1: iterations in [0, 1000]"),
        (["--limit", "0"], "--limit 0: at least 1"),
        (["--workers", "0"], "--workers 0: 1 to 256"),
        (["--mode", "far={dir}/other.json"], "--mode far: {dir}/other.json: not the results of "
         "cosim.studies.calibrated_robustness (its points and rows, one row per point)"),
        (["--mode", "far={dir}/rowless.json"], "--mode far: {dir}/rowless.json: a point without "
         "its values or its scored row"),
        (["--mode", "far={dir}/text.json"], "--mode far: {dir}/text.json is not JSON (Expecting "
         "value: line 1 column 1 (char 0))"),
        (["--mode", "far={dir}"], "--mode far: {dir}: no sweep's points in it (points/*.json)"),
        (["--mode", "={dir}/other.json"], "--mode ={dir}/other.json: expected NAME=RESULTS with "
         "an existing sweep folder or JSON file"),
        (["--mode", "far={dir}/ok.json", "--mode", "far={dir}/ok.json"],
         "--mode far={dir}/ok.json: a second mode named far"),
    ],
)  # fmt: skip
def test_a_bad_floor_option_is_one_line_and_runs_nothing(tmp_path, capsys, args, says):
    spec = tmp_path / "spec.yaml"
    spec.write_text(json.dumps(RANDOM))
    (tmp_path / "other.json").write_text('{"table": []}')
    (tmp_path / "rowless.json").write_text('{"points": [{"plant.mu": 0.08}], "rows": [{}]}')
    (tmp_path / "text.json").write_text("rms 1.2 %")
    (tmp_path / "ok.json").write_text(
        '{"points": [{"plant.mu": 0.08}], "rows": [{"rms_error_pct": 1, "peak_error_pct": 2}]}'
    )
    args = [a.format(dir=tmp_path) for a in args]
    assert tf.main(["--spec", str(spec), "--out", str(tmp_path / "out"), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"tracking_floor: {says.format(dir=tmp_path)}", err
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
@pytest.mark.parametrize("study", ["tracking_floor", "calibrated_robustness"])
def test_ctrl_c_in_a_study_is_one_line_and_leaves_no_worker(tmp_path, study):
    """Ctrl-C at the terminal (SIGINT to the whole process group) while the workers run: one
    line, exit 130, and no worker left behind (they would run on for half a minute each)."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        # A command started in the background of a non-interactive shell (`make test &`) has
        # SIGINT ignored, and so has every process it starts: there is no Ctrl-C to deliver.
        pytest.skip("SIGINT is ignored in this test run (started in the background)")
    spec = REPO_ROOT / "cosim" / "studies" / "sweep" / "examples" / "random_plants_report.yaml"
    args = ["--spec", str(spec), "--out", str(tmp_path / "out"), "--workers", "1"]
    proc = subprocess.Popen(
        [sys.executable, "-m", f"cosim.studies.{study}", *args],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        time.sleep(6)  # the worker has started its first plant
        assert proc.poll() is None
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=20)
        assert proc.returncode == 130, err
        assert err.strip() == f"{study}: interrupted; its workers are stopped", err
        time.sleep(0.5)
        with pytest.raises(ProcessLookupError):
            os.killpg(proc.pid, 0)  # nobody is left in the group
    finally:  # a failure above must not leave the study running on for minutes
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()


def test_the_overlay_lies_over_calibrates_proposals_and_the_estimates_0(tmp_path):
    """--params and --set (the far-end mode after calibrate): the file's compensator and
    controller, then each --set, laid over the spec point, the estimate's 0 and calibrate's
    proposals; a --leave'd proposal keeps the device's value."""
    params = tmp_path / "far.json"
    params.write_text(
        json.dumps(
            {"compensator": {"corr_enable": 1, "est_enable": 1}, "controller": {"kv_a_s_per_n": 0}}
        )
    )
    overlay = cr.overlay_of(
        ["controller.kv_a_s_per_n=1e-3", "compensator.corr_rev_enable=1"], str(params)
    )
    assert overlay == {
        "compensator.corr_enable": 1,
        "compensator.est_enable": 1,
        "controller.kv_a_s_per_n": 0.001,  # --set after the file
        "compensator.corr_rev_enable": 1,
    }
    point = {"plant.mu": 0.09, "compensator.est_enable": 1, "compensator.mu": 0.075}
    comp = {k: 0.5 for k in cr.COMP_KEYS} | {"compensator.mu": 0.09}
    plain = cr.run_values(point, comp, leave=["compensator.dead_zone_spread"])
    assert plain["compensator.est_enable"] == 0 and plain["compensator.mu"] == 0.09
    assert "compensator.dead_zone_spread" not in plain and "compensator.corr_enable" not in plain
    laid = cr.run_values(point, comp, overlay=overlay | {"compensator.mu": 0.08})
    assert laid["compensator.est_enable"] == 1 and laid["compensator.corr_enable"] == 1
    assert laid["compensator.mu"] == 0.08 and laid["compensator.dead_zone_spread"] == 0.5
    assert laid["plant.mu"] == 0.09 and laid["controller.kv_a_s_per_n"] == 0.001


def test_a_calibration_made_before_the_breakaway_gets_it_from_its_findings(tmp_path):
    """A kept calibration (calibration.json and before.json) whose report has no breakaway
    proposal: reused, the study proposes it from the audit's static friction finding as
    calibrate does (scaled by the bending angles, judged with the other applied changes); a share
    of 0 leaves it at the device's 0, and a report without the finding proposes nothing. Without
    a before.json the device is the emulated controller's defaults (where the study starts)."""
    from cosim.bench.link.messages import PARAM_BY_NAME  # noqa: PLC0415
    from cosim.bench.link.protocol import word_from_value  # noqa: PLC0415

    phi = 2 * np.pi
    words = {"comp.mode": 3, "comp.mu": word_from_value(PARAM_BY_NAME["comp.mu"], 0.075)}
    words["comp.phi_rad"] = word_from_value(PARAM_BY_NAME["comp.phi_rad"], phi)

    def kept(folder, findings, before=True):
        folder.mkdir()
        if before:
            (folder / "before.json").write_text(
                json.dumps({"params": {n: {"word": w} for n, w in words.items()}})
            )
        changes = [
            {
                "name": "comp.mu",
                "status": "change",
                "proposed": 0.09,
                "current": 0.075,
                "reason": "",
            }
        ]
        report = {
            "audit": {"phi_rad": 0.9 * phi, "findings": findings},
            "device_phi_rad": phi,
            "changes": changes,
            "tare": {"offset_n": 0.0},
        }
        (folder / "calibration.json").write_text(json.dumps(report))
        return str(folder)

    stick = [{"cause": "static_friction", "param": "mu_static_excess", "value": 0.03}]
    with_it = kept(tmp_path / "a", stick)
    out = cr.calibrate_plant({}, with_it, reuse=True)
    assert out["compensator.breakaway"] == pytest.approx(0.03 * 0.9, rel=1e-9)
    assert out["decisions"]["comp.breakaway"] == "change" and out["compensator.mu"] == 0.09
    assert out["device_phi_rad"] == phi  # the angle its proposals are scaled to
    assert (
        cr.calibrate_plant({}, with_it, reuse=True, breakaway_share=0.0)["compensator.breakaway"]
        == 0.0
    )
    emulated = cr.calibrate_plant({}, kept(tmp_path / "c", stick, before=False), reuse=True)
    assert emulated["compensator.breakaway"] == out["compensator.breakaway"]
    none = cr.calibrate_plant({}, kept(tmp_path / "b", []), reuse=True)
    assert none["compensator.breakaway"] == 0.0
    assert none["decisions"]["comp.breakaway"] == "unchanged"


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--set", "compensator.corr_enabl=1"], "compensator: unknown key 'corr_enabl'"),
        (["--set", "compensator.corr_rev_ki_shift=1"], "corr_rev_ki_shift must be in [2, 16]"),
        (["--set", "plant.mu=0.1"], "expected compensator.FIELD=VALUE or controller.FIELD"),
        (["--set", "controller.kv_a_s_per_n"], "expected compensator.FIELD=VALUE"),
        (["--params", "{dir}/plant.json"], "'plant' is not this study's to set"),
        (["--params", "{dir}/missing.json"], "missing.json does not exist"),
        (["--score-from-s", "-1"], "--score-from-s must be in [0, the runs' 6.0 s); got -1.0"),
        (["--map", "0,0.5"], "--map: '0,0.5' is not a position x,y,z in m"),
        (["--limit", "-3"], "--limit -3: at least 1"),
        (["--workers", "0"], "--workers 0: 1 to 256"),
        (["--workers", "257"], "--workers 257: 1 to 256"),
        (["--calibrations", "{dir}/plant.json"], "plant.json is a file, not a folder"),
        (["--reuse", "--calibrations", "{dir}/gone"], "--reuse: {dir}/gone does not exist"),
    ],
)
def test_a_bad_overlay_or_score_start_is_one_line_and_runs_nothing(tmp_path, capsys, args, says):
    (tmp_path / "plant.json").write_text('{"plant": {"mu": 0.1}}')
    out = tmp_path / "out"
    argv = [a.format(dir=tmp_path) for a in args] + ["--out", str(out)]
    assert cr.main(argv) == 2
    err = capsys.readouterr().err
    says = says.format(dir=tmp_path)
    assert err.count("\n") == 1 and err.startswith("calibrated_robustness: ") and says in err, err
    assert not out.exists() and not (tmp_path / "gone").exists()


def test_a_study_refuses_an_out_that_is_a_file_before_it_runs(tmp_path, capsys):
    """--out naming a file: one line before the first calibration, not a traceback after an
    hour's runs (the table is written last)."""
    spec = tmp_path / "spec.yaml"
    spec.write_text(json.dumps(RANDOM))
    afile = tmp_path / "table.json"
    afile.write_text("{}")
    assert cr.main(["--spec", str(spec), "--out", str(afile)]) == 2
    assert capsys.readouterr().err == f"calibrated_robustness: {afile} is a file, not a folder\n"
    assert tf.main(["--spec", str(spec), "--out", str(afile / "floors")]) == 2
    assert capsys.readouterr().err == f"tracking_floor: {afile} is a file, not a folder\n"
    assert afile.read_text() == "{}"


@pytest.mark.slow  # a worker process starts the firmware: 2-10 s on the shared machine
def test_a_run_the_firmware_refuses_is_one_line(tmp_path, capsys):
    """The overlay is checked key by key before anything runs; a combination only the firmware
    refuses (the online estimate with calibrate's friction slope) is one line once the runs
    start, not a broken worker pool."""
    spec = tmp_path / "one.yaml"
    spec.write_text(
        json.dumps(
            {
                "scenario": "fig14",
                "duration_s": 0.2,
                "sampling": "random",
                "samples": 1,
                "seed": 1,
                "axes": {
                    "compensator": ["preview"],
                    "plant.mu": {"min": 0.08, "max": 0.09, "n": 2},
                },
            }
        )
    )
    change = {"status": "change", "reason": "", "current": 0.0}
    report = {
        "changes": [
            {"name": "comp.mu", "proposed": 0.085} | change,
            {"name": "comp.offset_n", "proposed": 0.0} | change,
            {"name": "comp.mu_slope_per_n", "proposed": 5e-4} | change,
            {"name": "comp.dead_zone_spread", "proposed": 0.0} | change,
            {"name": "comp.breakaway", "proposed": 0.0} | change,
            {"name": "comp.slack_tension_n", "proposed": 0.0} | change,
            {"name": "comp.mu_per_inlet_rate", "proposed": 0.0} | change,
        ],
        "tare": {"offset_n": 0.0},
    }
    (tmp_path / "cal" / "cal_000").mkdir(parents=True)
    (tmp_path / "cal" / "cal_000" / "calibration.json").write_text(json.dumps(report))
    argv = ["--spec", str(spec), "--calibrations", str(tmp_path / "cal"), "--reuse"]
    argv += ["--out", str(tmp_path / "out"), "--workers", "1"]
    assert cr.main([*argv, "--set", "compensator.est_enable=1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the firmware refused a run: est.enable" in err, err
    assert "comp.mu_slope_per_n = 0" in err


def test_the_plants_own_values_map_to_the_compensators():
    """--truth: the FMU's parameters as the compensator's. The terms that act through their
    product with phi are scaled by the plant's phi over the compensator's; the spread and the
    slack are not; the cell's offset is the tare's, so the tension offset is 0; the cable-speed
    friction becomes the rate term through the cable's stretch in the sheath (mean of the two
    branches, at the plant's own cable_EA, the FMU's default where the plant has none); a slope
    the compensator refuses is clipped to its range."""
    plant = {
        "mu": 0.08,
        "mu_tension_slope": 4e-4,
        "dead_zone_spread": 0.3,
        "mu_static_excess": 0.02,
        "slack_tension": 2.5,
        "mu_viscous": 2.0,
        "sensor_offset": 0.4,
    }
    phi = 2 * np.pi
    t = cr.true_compensator(plant, 1.1 * phi, phi)
    assert t["compensator.mu"] == pytest.approx(0.088, rel=1e-12)
    assert t["compensator.mu_slope_per_n"] == pytest.approx(4.4e-4, rel=1e-12)
    assert t["compensator.breakaway"] == pytest.approx(0.022, rel=1e-12)
    assert t["compensator.dead_zone_spread"] == 0.3 and t["compensator.slack_tension_n"] == 2.5
    assert t["compensator.offset_n"] == 0.0
    # the inlet moves by the stretch in the sheath, L/EA (1 -+ e^-+a)/(+-a), plus the cell's
    # give e^-+a / k_lc, per N of the inlet tension (a = mu phi, here at the plant's phi)
    a = 0.08 * 1.1 * phi
    up = 2.0 * (1 / 8000 * -np.expm1(-a) / a + np.exp(-a) / 2e5)
    dn = 2.0 * (1 / 8000 * np.expm1(a) / a + np.exp(a) / 2e5)
    assert t["compensator.mu_per_inlet_rate"] == pytest.approx(1.1 * (up + dn) / 2, rel=1e-9)
    stiff = cr.true_compensator({**plant, "cable_EA": 16000.0}, phi, phi)
    assert stiff["compensator.mu_per_inlet_rate"] < 0.6 * t["compensator.mu_per_inlet_rate"]
    # an absent parameter is the FMU's default: mu 0.075, nothing else
    nominal = cr.true_compensator({}, phi, phi)
    assert nominal["compensator.mu"] == pytest.approx(0.075)
    assert all(nominal[k] == 0.0 for k in cr.COMP_KEYS if k != "compensator.mu")
    # mu + s * 48 N >= 0 (comp.h, COMP_MU_SLOPE_RANGE_N): the plant's -1.2e-3 at mu 0.0525
    steep = cr.true_compensator({"mu": 0.0525, "mu_tension_slope": -1.2e-3}, phi, phi)
    assert steep["compensator.mu_slope_per_n"] == pytest.approx(-0.0525 / 48)
    only = cr.true_compensator(plant, phi, phi, ("compensator.slack_tension_n",))
    assert only == {"compensator.slack_tension_n": 2.5}


def test_the_plants_own_values_lie_between_the_proposals_and_the_overlay():
    point = {"plant.mu": 0.09, "compensator.mu": 0.075}
    comp = {k: 0.5 for k in cr.COMP_KEYS}
    truth = {"compensator.mu": 0.09, "compensator.breakaway": 0.02}
    v = cr.run_values(point, comp, truth=truth, overlay={"compensator.breakaway": 0.0})
    assert v["compensator.mu"] == 0.09 and v["compensator.breakaway"] == 0.0
    assert v["compensator.slack_tension_n"] == 0.5 and v["compensator.est_enable"] == 0


def test_a_points_bending_angles_are_the_plants_at_its_position_and_the_compensators_at_home():
    """The sweep configures the compensator with the plant's phi at the scenario's start (home,
    [0, 0.5, 0] for fig14) and runs the plant at the point's position: with a bending error along
    y the two differ by the error's slope times the distance along y."""
    from cosim.parts.geometry import bending_angle  # noqa: PLC0415

    spec = str(REPO_ROOT / "cosim" / "studies" / "sweep" / "examples" / "random_plants_tuning.yaml")
    values = {"compensator": "preview", "position_m": [0.0, 0.25, 0.0]}
    values["plant.phi_offset_per_y"] = 0.4
    phi_plant, phi_comp = cr.phi_of_point(spec, values)
    assert phi_plant == pytest.approx(bending_angle(0.0, 0.25, 0.0, 1.0, True) + 0.1, abs=1e-9)
    assert phi_comp == pytest.approx(bending_angle(0.0, 0.5, 0.0, 1.0, True) + 0.2, abs=1e-9)


def test_a_run_takes_the_angle_calibrates_proposals_are_scaled_to():
    """calibrate proposes mu for the device's comp.phi_rad (only mu*phi is observed): the run
    takes that angle, not the sweep's default (the plant's phi at home with its bending error,
    which calibrate's mu*phi already holds); the overlay still wins, and a calibration that does
    not say its angle leaves the sweep's."""
    comp = {k: 0.0 for k in cr.COMP_KEYS} | {"compensator.mu": 0.08, "device_phi_rad": 6.25}
    assert cr.run_values({}, comp)["compensator.phi_rad"] == 6.25
    laid = cr.run_values({}, comp, overlay={"compensator.phi_rad": 6.0})
    assert laid["compensator.phi_rad"] == 6.0
    assert "compensator.phi_rad" not in cr.run_values({}, comp | {"device_phi_rad": None})
    assert "device_phi_rad" not in cr.run_values({}, comp)
