"""`bowden bench calibrate` over real links, in real time (the emulator behind a pty, a socket
and a python-can bus): the whole calibration over a pty and over CAN, Ctrl-C during it, and the
controller gone mid-run. Apart from tests/bench/test_bench_calibrate.py so that the test runner's
workers take the two files in parallel."""

import json
import signal
import subprocess
import sys
import threading
import time

import pytest

from cosim.bench.__main__ import main as bench_cli
from cosim.bench.emulate.emulator import Emulator
from cosim.bench.emulate.host_device import ChainConfig
from cosim.bench.link.client import BenchClient, SerialLink
from cosim.bench.rig.run import STATUS_OUT_EN
from cosim.project.paths import REPO_ROOT

# As tests/bench/test_bench_calibrate.py: the plant's mu found to 1 %.
MU_TOLERANCE = 0.01


def _before(out) -> dict:
    doc = json.loads((out / "before.json").read_text())
    return {n: e["word"] for n, e in doc["params"].items()}


def _real_time_calibrate(args, out, capsys):
    rc = bench_cli([*args, "calibrate", "--out", str(out), "--apply", "--quiet"])
    captured = capsys.readouterr()
    assert rc == 0, captured.out + captured.err
    rep = json.loads((out / "calibration.json").read_text())
    assert rep["applied"]["comp.mu"] == pytest.approx(0.09, rel=MU_TOLERANCE)
    m = rep["measured"]
    assert m["after"]["rms_error_n"] < 0.5 * m["before"]["rms_error_n"]
    return captured.out


@pytest.mark.slow
@pytest.mark.long
def test_calibrate_over_a_pty_in_real_time(tmp_path, capsys):
    emu = Emulator(tcp_port=None, chain=ChainConfig(plant={"mu": 0.09})).start()
    try:
        text = _real_time_calibrate(["bench", "--port", emu.urls["pty"]], tmp_path / "c", capsys)
        assert f"bowden bench --port {emu.urls['pty']} restore" in text
        probe = BenchClient(SerialLink(emu.urls["pty"]))
        try:
            probe.connect()
            assert probe.get("comp.mu") == pytest.approx(0.09, rel=MU_TOLERANCE)
            assert not probe.hello().running
        finally:
            probe.link.close()
    finally:
        emu.stop()


@pytest.mark.slow
@pytest.mark.long
def test_calibrate_over_can_in_real_time(tmp_path, capsys):
    args = ["bench", "--can", "virtual:calibrate", "--emulate", "--plant", "mu=0.09"]
    text = _real_time_calibrate(args, tmp_path / "c", capsys)
    assert "nothing to restore" in text and "--emulate restore" not in text  # it ends here


@pytest.mark.slow
def test_ctrl_c_stops_the_device_and_puts_the_configuration_back(tmp_path):
    """SIGINT during the identification run (a `bowden bench` process on the emulator's socket):
    exit 130, one line, the device stopped with its output disabled, the run's settings put
    back."""
    emu = Emulator(tcp_port=0, pty=False).start()
    url = emu.urls["socket"]
    out = tmp_path / "c"
    try:
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "cosim",
                "bench",
                "--port",
                url,
                "calibrate",
                "--out",
                str(out),
                "--apply",
                "--quiet",
            ],
            cwd=REPO_ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            deadline = time.monotonic() + 60
            ident = out / "identification.csv"
            while not (ident.exists() and ident.read_text().count("\n") > 500):
                assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
                time.sleep(0.05)
            proc.send_signal(signal.SIGINT)
            _, err = proc.communicate(timeout=30)
        finally:
            if proc.poll() is None:
                proc.kill()
        assert proc.returncode == 130, err
        assert "interrupted by SIGINT" in err and "output disabled" in err
        assert len(err.strip().splitlines()) == 1, err
        probe = BenchClient(SerialLink(url))
        try:
            assert not probe.hello().running
            _, faults = probe.request("FAULTS_GET")
            assert not faults["fpga_status"] & STATUS_OUT_EN
            assert probe.params() == _before(out)
        finally:
            probe.link.close()
    finally:
        emu.stop()
    assert not (out / "calibration.json").exists()


@pytest.mark.slow
def test_the_emulator_gone_mid_run_is_one_line_with_before_json(tmp_path, capsys):
    """The controller disappears during the identification (the emulator stopped under the
    command, its socket closed): one line naming the step and before.json, exit 1."""
    emu = Emulator(tcp_port=0, pty=False).start()
    out = tmp_path / "c"
    ident = out / "identification.csv"

    def kill_when_running() -> None:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if ident.exists() and ident.read_text().count("\n") > 2000:
                break
            time.sleep(0.05)
        emu.stop()

    killer = threading.Thread(target=kill_when_running, daemon=True)
    killer.start()
    try:
        rc = bench_cli(
            [
                "bench",
                "--port",
                emu.urls["socket"],
                "--timeout",
                "0.3",
                "calibrate",
                "--out",
                str(out),
                "--apply",
                "--quiet",
            ]
        )
    finally:
        killer.join()
        emu.stop()
    err = capsys.readouterr().err.strip()
    assert rc == 1, err
    assert len(err.splitlines()) == 1, err
    assert "during the identification run" in err and "no compensator value was written" in err
    assert str(out / "before.json") in err and (out / "before.json").is_file()
    assert not (out / "calibration.json").exists()
