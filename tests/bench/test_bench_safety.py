"""Safety next to a motor: every exit path of a `bowden bench` run (SIGINT, SIGTERM, a dropped
link, an error, a second client) leaves the device stopped with the FPGA's output disabled, as a
fresh client sees it; a run is never endless unless asked for; bad values are refused before
anything is sent or written."""

import os
import signal
import subprocess
import sys
import time

import pytest

from cosim.bench import messages as msgs
from cosim.bench.__main__ import main as bench_cli
from cosim.bench.client import BenchClient, DeviceError, SerialLink
from cosim.bench.emulator import Emulator
from cosim.parts import regmap
from cosim.project.paths import REPO_ROOT

OUT_EN = 1 << next(f.lsb for f in regmap.REGISTERS["STATUS"].fields if f.name == "OUT_EN")


@pytest.fixture
def emulator():
    emu = Emulator(tcp_port=0).start()
    yield emu
    emu.stop()


def _device_state(url: str) -> tuple[bool, bool]:
    """(running, output enabled) as a fresh client sees them, without sending STOP first."""
    client = BenchClient(SerialLink(url))
    try:
        running = client.hello().running
        _, faults = client.request("FAULTS_GET")
        return running, bool(faults["fpga_status"] & OUT_EN)
    finally:
        client.link.close()


def _start_run(url: str, out, seconds: float = 30.0) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "cosim", "bench", "--port", url, "run", "sine"]
        + ["--seconds", str(seconds), "--out", str(out), "--quiet"],
        cwd=REPO_ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_running(folder, proc, rows: int = 300) -> None:
    """Until a CSV in `folder` holds `rows` rows (the run is under way)."""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        for f in folder.glob("*.csv"):
            if f.read_text().count("\n") > rows:
                return
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.05)
    raise AssertionError("the run did not start")


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
@pytest.mark.parametrize("kind", ["socket", "pty"])
def test_a_signal_stops_the_device_and_disables_the_output(emulator, tmp_path, sig, code, kind):
    url = emulator.urls[kind]
    proc = _start_run(url, tmp_path / "b.csv")
    try:
        _wait_running(tmp_path, proc)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert _device_state(url) == (False, False), err  # (running, output enabled)
    assert proc.returncode == code, err
    assert "stopped" in err and "output disabled" in err and "confirmed" in err, err
    assert len(err.strip().splitlines()) == 1, err


def test_zero_duration_start_is_refused_by_the_device(emulator):
    client = BenchClient(SerialLink(emulator.urls["socket"]))
    try:
        client.connect()
        client.set("source", "wave")
        with pytest.raises(DeviceError, match="duration"):
            client.simple("START", duration_ticks=0)
        assert not client.hello().running
        # Until STOP only when asked for explicitly.
        client.simple("START", duration_ticks=msgs.START_DURATION["CONTINUOUS"])
        assert client.hello().running
        client.request("STOP")
        assert not client.hello().running
    finally:
        client.link.close()


@pytest.mark.parametrize("seconds", ["0.0004", "1e9"])
def test_durations_outside_the_tick_range_are_refused_naming_seconds(tmp_path, capsys, seconds):
    keep = tmp_path / "keep.csv"
    keep.write_text("precious\n")
    rc = bench_cli(["bench", "--emulate", "run", "sine", "--seconds", seconds, "--out", str(keep)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "--seconds" in err, err
    assert keep.read_text() == "precious\n"
    assert sorted(os.listdir(tmp_path)) == ["keep.csv"]
