"""`bowden sim` and `bowden demo` as a new user meets them: relative
output folders, params files that name unknown or command-line-owned FMU variables, durations
too short for the metrics, SIGINT/SIGTERM during a real run, and error messages that give a
field's real range. Bad input is one line on stderr, exit status 2, and nothing is run.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from cosim import cli
from cosim.engines import experiment as sim

# The shortest run bowden accepts at the default rates (sim.MIN_FIRMWARE_TICKS at 1 kHz).
MIN_DURATION_S = 0.01


def _bowden(*args: str, cwd: Path | None = None, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "cosim", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        check=False,
        **kwargs,
    )


def _strict_json(path: Path):
    """json.loads that refuses NaN and infinities, as strict readers do."""

    def refuse(token):
        raise ValueError(f"{path}: {token} is not JSON")

    return json.loads(path.read_text(), parse_constant=refuse)


def _one_error_line(err: str, command: str = "sim") -> str:
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"bowden {command}: "), err
    assert "Traceback" not in err
    return lines[0]


def _params(tmp_path: Path, data, name: str = "p.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return path


def _sim_error(capsys, tmp_path, *args: str) -> str:
    """In-process `bowden sim fig14 --out OUT ARGS`: must fail with status 2 before running
    (a short run's options, so that a bad input that is accepted costs little)."""
    out = tmp_path / "out"
    short = ["--duration", "0.02", "--bus", "lean", "--no-reference", "--quiet"]
    assert cli.main(["sim", "fig14", "--out", str(out), *short, *args]) == 2
    assert not out.exists()  # nothing was run or written
    return _one_error_line(capsys.readouterr().err)


# --- item 1 (relative --out), item 4 (strict result.json at the shortest run), item 3 (sidecar)


def test_sim_with_a_relative_out_folder_writes_strict_json_and_the_plants_own_values(tmp_path):
    """A relative --out from another folder (the simulator runs in its own folder), at the
    shortest duration accepted: result.json is strict JSON, and the sidecar reports the plant's
    mu (the FMU's default), not the compensator's belief from the params file."""
    _params(tmp_path, {"compensator": {"mu": 0.09}})
    res = _bowden(
        "sim",
        "fig14",
        "--out",
        "rel/out",
        "--duration",
        str(MIN_DURATION_S),
        "--params",
        "p.json",
        "--bus",
        "lean",
        "--no-reference",
        "--quiet",
        cwd=tmp_path,
    )
    assert res.returncode == 0, res.stderr
    out = tmp_path / "rel" / "out"
    result = _strict_json(out / "result.json")
    assert result["samples"] == 100 and result["loop_routing"] is True
    assert all(math.isfinite(result[k]) for k in ("rms_error_pct", "peak_error_pct"))
    meta = _strict_json(out / "trace.meta.json")
    assert meta["mu"] == 0.075 and meta["loop_routing"] is True
    assert result["compensator_mu"] == 0.09
    assert not list(out.glob(".writing-*"))  # the staging folder is gone


def test_an_empty_out_folder_is_refused(capsys, tmp_path):
    assert cli.main(["sim", "fig14", "--out", "", "--quiet"]) == 2
    line = _one_error_line(capsys.readouterr().err)
    assert "argument --out: expected the name of a folder; got ''" in line


# --- item 2, 3, 9: params files ---------------------------------------------------------------


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        # item 2: an unknown FMU variable was a KeyError traceback
        ({"plant": {"no_such_param": 1.0}}, "'no_such_param' is not a parameter of the FMU"),
        # a near miss is named; a table's numbered entries are listed as one
        ({"plant": {"slack_tabel_1": 0.1}}, "FMU (did you mean 'slack_table_1'?); parameters:"),
        ({"plant": {"slack_tabel_1": 0.1}}, ", slack_table_0..7"),
        # item 3: the command line owns loop routing, the closed loop owns the drive mode
        ({"plant": {"loop_routing": 0}}, "plant.loop_routing is set on the command line"),
        ({"plant": {"loop_routing": False}}, "plant.loop_routing is set on the command line"),
        ({"plant": {"drive_mode": 1}}, "plant.drive_mode is fixed by the closed loop"),
        ({"plant": {"drive_mode": 0.7}}, "plant.drive_mode is fixed by the closed loop"),
        # an input is the scenario's, an output the FMU's
        ({"plant": {"x": 0.1}}, "'x' is an FMU input"),
        ({"plant": {"T_out": 3.0}}, "'T_out' is an FMU output"),
        # Integer parameters take whole numbers: nothing is truncated
        ({"plant": {"seed": 2.5}}, "plant.seed must be a whole number in [0, 2.14748e+09]"),
        # item 9: the field's real range (the FMU's modelDescription), not a catch-all one
        ({"plant": {"mu": math.nan}}, "plant.mu must be in [0, 1]; got NaN"),
        ({"plant": {"mu": 1e400}}, "plant.mu must be in [0, 1]; got Infinity"),
        ({"plant": {"mu": True}}, "plant.mu must be a number in [0, 1]; got true"),
        ({"plant": {"mu": None}}, "plant.mu must be a number in [0, 1]; got null"),
        ({"plant": {"sheath_length": 20.0}}, "plant.sheath_length must be in [0.01, 10]"),
        ({"controller": {"kp_a_per_n": math.nan}}, "controller.kp_a_per_n must be in [0, 3.9998]"),
        ({"controller": {"kp_a_per_n": True}}, "kp_a_per_n must be a number in [0, 3.9998]"),
        (
            {"controller": {"i_limit_a": None}},
            "controller.i_limit_a must be a number in [0, 7.9997]",
        ),
        ({"compensator": {"mu": 1e400}}, "compensator.mu must be in [0, 1]; got Infinity"),
        ({"compensator": {"band_n": None}}, "compensator.band_n must be a number in [0.00390625"),
        # rates are whole Hz (the firmware takes integers)
        ({"firmware_rate_hz": 1000.5}, "firmware_rate_hz must be a whole number in [1, 65535]"),
        ({"sample_rate_hz": math.nan}, "sample_rate_hz must be in [1, 1e+06]; got NaN"),
        # item 3: a params file cannot contradict the scenario: fig14 reaches 0.82 m
        (
            {"plant": {"sheath_length": 0.5}},
            "plant.sheath_length = 0.5 m is shorter than the reach",
        ),
    ],
)
def test_params_file_errors_name_the_field_and_its_real_range(capsys, tmp_path, data, expected):
    path = _params(tmp_path, data)
    line = _sim_error(capsys, tmp_path, "--params", str(path))
    assert expected in line, line
    if "reach" not in line:
        assert str(path) in line  # the file is named


def test_params_file_that_is_not_utf8_is_named(capsys, tmp_path):
    path = tmp_path / "latin1.json"
    path.write_bytes('{"plant": {"mu": 0.09}, "note": "caf\xe9"}'.encode("latin-1"))
    line = _sim_error(capsys, tmp_path, "--params", str(path))
    assert f"--params: {path} is not valid JSON (not UTF-8 text: byte 0xe9 at offset" in line


def test_params_file_that_is_a_folder_or_nested_too_deep_is_one_line(capsys, tmp_path):
    line = _sim_error(capsys, tmp_path, "--params", str(tmp_path))
    assert f"--params: {tmp_path} is a folder, not a params file" in line
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    line = _sim_error(capsys, tmp_path, "--params", str(deep))
    assert "nested too deeply" in line


def test_params_file_that_is_a_device_is_refused_before_it_is_read(capsys, tmp_path):
    """The params file's reader is the bench's (cosim.project.datafile): /dev/zero would be read
    without end, a FIFO would block the open; both are refused as not a regular file."""
    line = _sim_error(capsys, tmp_path, "--params", "/dev/zero")
    assert line.startswith("bowden") and "--params: /dev/zero is not a regular file" in line, line


# --- item 4: durations ------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("command", "value", "expected"),
    [
        ("demo", "-5", "--duration must be in [0.01, 3600] s (at least 10 firmware ticks"),
        ("demo", "nan", "argument --duration: expected a finite number; got 'nan'"),
        ("demo", "1e400", "argument --duration: expected a finite number; got '1e400'"),
        ("sim", "1e-9", "--duration must be in [0.01, 3600] s (at least 10 firmware ticks"),
        ("sim", "0.009", "--duration must be in [0.01, 3600] s"),
        ("sim", "inf", "argument --duration: expected a finite number; got 'inf'"),
        ("sim", "3601", "--duration must be in [0.01, 3600] s"),
    ],
)
def test_durations_too_short_or_not_finite_are_refused_with_the_minimum(
    capsys, tmp_path, command, value, expected
):
    out = tmp_path / "out"
    argv = [command, "--out", str(out), "--quiet", "--duration", value]
    if command == "sim":
        argv.insert(1, "fig14")
    assert cli.main(argv) == 2
    line = _one_error_line(capsys.readouterr().err, command)
    assert expected in line, line
    assert not out.exists()


# --- item 5: SIGINT / SIGTERM on a real run ---------------------------------------------------


def _descendants(pid: int) -> list[psutil.Process]:
    try:
        return psutil.Process(pid).children(recursive=True)
    except psutil.NoSuchProcess:
        return []


def _alive(proc: psutil.Process) -> bool:
    try:
        return proc.is_running() and proc.status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_stops_the_run_and_its_simulator_and_keeps_what_was_written(tmp_path, sig):
    """The signal goes to `bowden` alone (kill PID; the harder case for SIGINT too, since a
    terminal's Ctrl-C also reaches the simulator's group). Afterwards: no process of the run is
    left, one line on stderr, status 128 + signal, and the files of an earlier run are whole."""
    out = tmp_path / "out"
    out.mkdir()
    earlier = out / "result.json"
    earlier.write_text('{"earlier": "run"}\n')
    proc = subprocess.Popen(
        [sys.executable, "-m", "cosim", "sim", "fig14", "--duration", "30", "--bus", "lean"]
        + ["--no-reference", "--quiet", "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # the test can end everything if the run misbehaves
    )
    progress = out / "sim" / "progress.txt"
    children: list[psutil.Process] = []
    try:
        deadline = time.monotonic() + 120
        # Wait until the closed loop runs: the simulator is up and reports samples done.
        while time.monotonic() < deadline and proc.poll() is None:
            children = _descendants(proc.pid)
            if progress.is_file() and progress.read_text().strip() not in ("", "0") and children:
                break
            time.sleep(0.2)
        assert proc.poll() is None and children, "the run did not start"
        os.kill(proc.pid, sig)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 128 + sig, err
    line = _one_error_line(err)
    assert f"interrupted by {signal.Signals(sig).name}" in line
    left = [p for p in children if _alive(p)]
    assert not left, [(p.pid, p.name()) for p in left]
    assert earlier.read_text() == '{"earlier": "run"}\n'
    assert (out / "sim" / "spec.json").is_file()  # written before the signal, kept


def test_a_short_positions_run_skips_the_fits_it_cannot_make():
    """Found by the run suite (tests/test_cli_fuzz.py): `bowden sim positions --duration 0.05`
    tried to fit the first segment after its 0.3 s move, on no samples, and failed."""
    import numpy as np

    from cosim.config.run import SimConfig
    from cosim.config.scenarios import get_scenario

    n = 500
    rec = {
        "t_s": np.arange(n) / 10_000.0,
        "phi_rad": np.full(n, 6.3),
        "T_in_N": np.linspace(0, 5, n),
        "T_out_N": np.linspace(0, 4, n),
    }
    assert sim.friction_fits(get_scenario("positions"), SimConfig(), rec) == []
