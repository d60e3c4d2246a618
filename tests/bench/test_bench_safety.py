"""Safety next to a motor: every exit path of a `bowden bench` run (SIGINT, SIGTERM, a dropped
link, an error, a second client) leaves the device stopped with the FPGA's output disabled, as a
fresh client sees it; a run is never endless unless asked for; bad values are refused before
anything is sent or written."""

import argparse
import os
import signal
import subprocess
import sys
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cosim.bench import command as bench_cli_mod
from cosim.bench.__main__ import main as bench_cli
from cosim.bench.emulate.emulator import Emulator, SteppedLink
from cosim.bench.emulate.host_device import ChainConfig
from cosim.bench.link import messages as msgs
from cosim.bench.link.client import (
    BenchClient,
    BenchError,
    BenchUsageError,
    DeviceError,
    SerialLink,
)
from cosim.bench.link.protocol import ProtocolError
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


@pytest.mark.parametrize("kind", ["socket", "pty"])
def test_a_link_drop_stops_the_device_and_disables_the_output(emulator, tmp_path, kind):
    """The host killed outright (SIGKILL: no handler runs, no STOP is sent; on a pty the device
    sees a link that merely fell silent, as with a pulled cable): the device's host watchdog
    stops the run and disables the output within HOST_WATCHDOG.TIMEOUT_MS, and counts it. A
    device without the watchdog runs the 30 s waveform on."""
    url = emulator.urls[kind]
    before = _host_timeouts(url)
    proc = _start_run(url, tmp_path / "b.csv")
    try:
        _wait_running(tmp_path, proc, rows=1000)  # > 2 timeouts in: the keep-alive works
        assert _device_state_after_kill(proc, url) == (False, False)  # (running, output)
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate()
    assert _host_timeouts(url) == before + 1


def test_a_run_the_host_watchdog_stopped_says_so(tmp_path, capsys, monkeypatch):
    """A host too loaded to keep its link alive (its keep-alive never sent): the device stops
    the run after HOST_WATCHDOG.TIMEOUT_MS, and the tool says that this was the cause, not only
    that the device stopped early, and keeps what was recorded."""
    monkeypatch.setattr(BenchClient, "keep_alive", lambda self, *a, **k: False)
    out = tmp_path / "run.csv"
    rc = bench_cli(["bench", "--emulate", "run", "sine", "--seconds", "3", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 1, err
    assert "device stopped early: True" in err, err
    assert (
        "the device's host watchdog stopped the run: it received nothing from this host for "
        f"{msgs.HOST_WATCHDOG['TIMEOUT_MS']} ms" in err
    ), err
    rows = out.read_text().splitlines()
    timeout_ticks = msgs.HOST_WATCHDOG["TIMEOUT_MS"]  # the emulator's tick is 1 ms
    assert timeout_ticks - 50 <= len(rows) - 1 <= timeout_ticks + 50, len(rows)


def _host_timeouts(url: str) -> int:
    probe = BenchClient(SerialLink(url))
    try:
        return probe.stats()["host_timeouts"]
    finally:
        probe.link.close()


def _device_state_after_kill(proc, url: str) -> tuple[bool, bool]:
    """SIGKILL the host; then what a fresh client sees once the watchdog's timeout has passed
    (it waits for it, with room for a loaded machine, never longer than 3 timeouts)."""
    timeout_s = msgs.HOST_WATCHDOG["TIMEOUT_MS"] / 1e3
    proc.kill()
    proc.wait()
    killed = time.monotonic()
    time.sleep(timeout_s)
    state = _device_state(url)
    while state != (False, False) and time.monotonic() - killed < 3 * timeout_s:
        time.sleep(0.05)
        state = _device_state(url)
    return state


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


@pytest.mark.parametrize("name", ["loop.kp", "loop.ki_ts", "loop.kff"])
def test_gains_of_the_wrong_sign_are_refused_at_host_device_and_register_map(name, capsys):
    # The register map documents the limit; the parameter table takes it from there.
    p = msgs.PARAM_BY_NAME[name]
    assert p.lo == 0
    # The host refuses before sending (a usage error, naming the parameter and the range).
    rc = bench_cli(["bench", "--emulate", "set", f"{name}=-0.001"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and name in err and "[0," in err, err
    # The device's settings check refuses the raw word too.
    client = BenchClient(SteppedLink(ChainConfig()))
    try:
        client.connect()
        before = client.get_word(name)
        with pytest.raises(DeviceError, match="INVALID_VALUE"):
            client.set_word(name, -8)
        assert client.get_word(name) == before
    finally:
        client.link.close()


@pytest.mark.parametrize(
    ("assignment", "message"),
    [
        ("comp.preview_ticks=200", "comp.preview_ticks: outside [0, 128] ticks"),
        ("comp.mode=7", "comp.mode: must be 0 (none), 1 (paper), 2 (smooth) or 3 (preview)"),
    ],
)
def test_device_messages_reach_the_user_in_full(assignment, message, capsys):
    rc = bench_cli(["bench", "--emulate", "set", assignment])
    err = capsys.readouterr().err.strip()
    assert rc != 0 and len(err.splitlines()) == 1 and message in err, err


@pytest.mark.parametrize("kind", ["socket", "pty"])
def test_a_second_client_is_refused_naming_the_holder_and_the_run_goes_on(
    emulator, kind, capsys, kept_alive
):
    url = emulator.urls[kind]
    first = BenchClient(SerialLink(url))
    try:
        first.connect()
        first.set("source", "wave")
        first.simple("START", duration_ticks=60_000)
        with kept_alive(first):
            rc = bench_cli(["bench", "--port", url, "get", "loop.kp"])
        err = capsys.readouterr().err.strip()
        assert rc == 1 and len(err.splitlines()) == 1, err
        assert "in use by another client" in err and f"pid {os.getpid()}" in err, err
        assert first.hello().running  # the second client did not stop the first one's run
    finally:
        first.request("STOP")
        first.link.close()
    assert bench_cli(["bench", "--port", url, "get", "loop.kp"]) == 0  # the lock went with it


def _stepped_client() -> BenchClient:
    client = BenchClient(SteppedLink(ChainConfig()))
    client.connect()
    return client


def test_backup_refuses_non_regular_targets_and_overwriting_without_force(tmp_path, capsys):
    base = ["bench", "--emulate", "backup"]
    fifo = tmp_path / "fifo"  # a node that is not a regular file (as /dev/full is)
    os.mkfifo(fifo)
    for target, words in [(fifo, "not a regular file"), (tmp_path, "is a folder")]:
        assert bench_cli([*base, str(target)]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and words in err, err
    assert fifo.is_fifo()
    assert os.listdir(tmp_path) == ["fifo"]  # no stray NAME.tmp
    fifo.unlink()
    b = tmp_path / "b.json"
    b.write_text("an earlier backup\n")
    assert bench_cli([*base, str(b)]) == 2
    assert "--force" in capsys.readouterr().err and b.read_text() == "an earlier backup\n"
    assert bench_cli([*base, str(b), "--force"]) == 0
    assert '"bowden_bench_backup"' in b.read_text() and os.listdir(tmp_path) == ["b.json"]


def _backup(tmp_path, capsys) -> tuple:
    import json

    b = tmp_path / "b.json"
    assert bench_cli(["bench", "--emulate", "backup", str(b)]) == 0
    capsys.readouterr()
    return b, json.loads(b.read_text())


def test_restore_is_all_or_nothing(tmp_path, capsys):
    import json

    b, doc = _backup(tmp_path, capsys)
    # adc_min above adc_max: refused as a whole, whatever the order of the entries.
    p = doc["params"]
    p["loop.adc_min"], p["loop.adc_max"] = dict(p["loop.adc_max"]), dict(p["loop.adc_min"])
    p["loop.kp"] = {"word": 100, "value": "0.012207 A/N"}  # a valid change before the bad pair
    b.write_text(json.dumps(doc))
    client = _stepped_client()
    try:
        before = client.params()
        with pytest.raises(BenchError, match="nothing written"):
            write_all_from_backup(client, b)
        assert client.params() == before
    finally:
        client.link.close()


def write_all_from_backup(client, path):
    class A:
        file = str(path)

    return bench_cli_mod._cmd_restore(client, A, None)


def test_restore_refuses_a_value_that_disagrees_with_its_word(tmp_path, capsys):
    import json

    b, doc = _backup(tmp_path, capsys)
    doc["params"]["loop.kp"]["value"] = "0.5 A/N"  # edited by hand; the word still says 0.1
    b.write_text(json.dumps(doc))
    rc = bench_cli(["bench", "--emulate", "restore", str(b)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "loop.kp" in err and "disagree" in err, err
    # The value alone is taken (converted); the word alone too.
    del doc["params"]["loop.kp"]["word"]
    b.write_text(json.dumps(doc))
    client = _stepped_client()
    try:
        write_all_from_backup(client, b)
        assert client.get_word("loop.kp") == 4096
    finally:
        client.link.close()


def test_restore_of_a_deeply_nested_json_is_one_line(tmp_path, capsys):
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    rc = bench_cli(["bench", "--emulate", "restore", str(deep)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "nested too deeply" in err, err


def test_restore_exits_2_for_its_file_and_1_for_what_the_device_refuses(tmp_path, capsys):
    """A backup that is missing, a folder, unreadable or not JSON is the user's to fix: one line,
    exit 2, as diff says it, before the link opens (the port named does not exist). A backup
    whose words the device refuses as a set once the link is open (adc_min above adc_max, each
    word in its own range) is the device's answer, not a usage error: exit 1, nothing written."""
    import json

    no_port = str(tmp_path / "no-port")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    for path, words in (
        (tmp_path / "missing.json", "does not exist"),
        (tmp_path, "is a folder, not a backup or params file"),
        (bad / "x.json", "cannot read it (Not a directory)"),
        (bad, "is not a JSON backup"),
    ):
        rc = bench_cli(["bench", "--port", no_port, "restore", str(path)])
        err = capsys.readouterr().err
        assert rc == 2 and err.count("\n") == 1 and words in err, (path, err)
        assert err.startswith("bowden bench: restore: "), err
    fifo = tmp_path / "backup.fifo"
    os.mkfifo(fifo)  # no writer: opening it would wait for ever
    for command in ("restore", "diff"):
        rc = bench_cli(["bench", "--port", no_port, command, str(fifo)])
        err = capsys.readouterr().err
        assert rc == 2 and err.count("\n") == 1 and "is not a regular file" in err, err
    with pytest.raises(BenchUsageError, match="does not exist"):  # called alone, as the API may
        write_all_from_backup(None, tmp_path / "missing.json")
    b, doc = _backup(tmp_path, capsys)
    p = doc["params"]
    p["loop.adc_min"], p["loop.adc_max"] = dict(p["loop.adc_max"]), dict(p["loop.adc_min"])
    b.write_text(json.dumps(doc))
    rc = bench_cli(["bench", "--emulate", "restore", str(b)])
    err = capsys.readouterr().err
    assert rc == 1 and err.count("\n") == 1 and "INVALID_VALUE" in err, err
    assert "nothing written" in err and str(b) in err, err


def test_set_is_all_or_nothing_and_takes_no_fraction_of_a_count(capsys):
    client = _stepped_client()
    try:
        before = client.params()
        with pytest.raises(BenchError, match="nothing written"):
            bench_cli_mod.write_all(
                client,
                [
                    (msgs.PARAM_BY_NAME["loop.adc_min"], 100),
                    (msgs.PARAM_BY_NAME["loop.adc_max"], -100),
                ],
                "set",
            )
        assert client.params() == before
        # A valid pair that needs the second write first (adc_min above the old adc_max).
        lo, hi = msgs.PARAM_BY_NAME["loop.adc_min"], msgs.PARAM_BY_NAME["loop.adc_max"]
        bench_cli_mod.write_all(client, [(lo, 0), (hi, 1000)], "set")
        done = bench_cli_mod.write_all(client, [(lo, 2000), (hi, 3000)], "set")
        assert {p.name: w for p, w in done} == {"loop.adc_min": 2000, "loop.adc_max": 3000}
    finally:
        client.link.close()
    rc = bench_cli(["bench", "--emulate", "set", "comp.preview_ticks=2.5"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "comp.preview_ticks=2.5: expected a whole number" in err, err


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--emulate", "run", "sine", "--position", "100,0,0"], "--position 100,0,0: outside"),
        (["--emulate", "run", "sine", "--position", "5,5,5"], "--position 5,5,5: outside"),
        (["--emulate", "run", "sine", "--sheath-length", "1e9"], "--sheath-length 1e+09: outside"),
        (["--emulate", "run", "sine", "--out", "{tmp}"], "is a folder"),
    ],
)
def test_run_options_are_checked_before_anything_is_written(args, words, tmp_path, capsys):
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    if "--out" not in args:
        args += ["--out", str(tmp_path / "r.csv")]
    rc = bench_cli(["bench", *args, "--seconds", "0.1", "--quiet"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and words in err, err
    assert os.listdir(tmp_path) == []


def test_emulate_position_outside_the_workspace_names_the_option(capsys):
    rc = bench_cli(["emulate", "--no-pty", "--no-tcp", "--position", "5,5,5", "--seconds", "0.1"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "--position 5,5,5" in err, err


# --- Hypothesis: bench commands ------------------------------------------------------------------

_NAMES = st.sampled_from(
    [p.name for p in msgs.PARAMS] + ["loop.kp", "loop.ki_ts", "loop.kff", "no.such", ""]
)
_TEXT_VALUES = st.one_of(
    st.integers(min_value=-(10**60), max_value=10**60).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["9" * 400, "-0.001", "2.5", "smooth", "nan", "1e400", "", "0x10"]),
)


@pytest.fixture(scope="module")
def stepped():
    client = BenchClient(SteppedLink(ChainConfig()))
    client.connect()
    yield client
    client.link.close()


@settings(deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(assignments=st.lists(st.tuples(_NAMES, _TEXT_VALUES), min_size=1, max_size=3))
def test_any_set_is_applied_whole_or_refused_whole_in_one_line(stepped, assignments):
    """`bench set` with any names and values: all applied, or one usage line (exit 2) and the
    device's words unchanged; a negative gain is never applied."""
    watched = {n for n, _ in assignments if n in msgs.PARAM_BY_NAME}
    watched |= {"loop.kp", "loop.ki_ts", "loop.kff", "loop.adc_min", "loop.adc_max"}
    before = {n: stepped.get_word(n) for n in sorted(watched)}
    args = argparse.Namespace(assignments=[f"{n}={v}" for n, v in assignments])
    try:
        bench_cli_mod._cmd_set(stepped, args, None)
    except (ProtocolError, BenchUsageError) as exc:
        assert "\n" not in str(exc)
        assert {n: stepped.get_word(n) for n in before} == before
        return
    assert all(stepped.get_word(g) >= 0 for g in ("loop.kp", "loop.ki_ts", "loop.kff"))
    undo = [(msgs.PARAM_BY_NAME[n], w) for n, w in before.items() if n in _WRITABLE]
    bench_cli_mod.write_all(stepped, undo, "undo")


_WRITABLE = {p.name for p in msgs.PARAMS if not p.read_only}


def test_a_second_client_of_a_can_node_is_refused_naming_the_holder():
    """CAN as serial: one client per node of a bus on this machine, the refusal naming the holder;
    another node of the same bus is free, and the lock goes with the client."""
    from cosim.bench.link.client import BenchError, CanLink  # noqa: PLC0415

    spec = f"virtual:lock_{os.getpid()}"
    first = CanLink(spec, node=1)
    try:
        with pytest.raises(BenchError) as refused:
            CanLink(spec, node=1)
        msg = str(refused.value)
        assert msg.startswith(f"--can {spec} node 1: in use by another client (pid {os.getpid()}")
        CanLink(spec, node=2).close()
    finally:
        first.close()
    CanLink(spec, node=1).close()
