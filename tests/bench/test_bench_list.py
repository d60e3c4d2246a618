"""`bowden bench list` and `--port auto` against emulators on ptys, TCP and a CAN bus: what each
controller says, a device of another table marked, a run in progress left running, and the bad
cases (none found, several found) in one line each. pyserial cannot list ptys or socket:// URLs,
so the tests hand their ports to `discover.serial_ports`."""

import json
import os

import pytest

from cosim.bench.__main__ import main as bench_cli
from cosim.bench.emulate.emulator import Emulator
from cosim.bench.link import discover
from cosim.bench.link import messages as msgs
from cosim.bench.link.client import BenchClient, SerialLink


@pytest.fixture
def two_emulators():
    a = Emulator(tcp_port=0).start()
    b = Emulator(tcp_port=0, pty=False, identity=(msgs.PROTOCOL_VERSION, 0xDEADBEEF)).start()
    yield a, b
    a.stop()
    b.stop()


@pytest.fixture
def silent_pty():
    """A pty nobody answers on (a serial port with no controller behind it)."""
    master, slave = os.openpty()
    yield os.ttyname(slave)
    os.close(master)
    os.close(slave)


@pytest.fixture(autouse=True)
def own_runtime_dir(monkeypatch, tmp_path):
    """Locks and the emulators' registry in this test's own folder: a `bowden emulate` of
    someone else on this machine is not found here, nor are this test's emulators there."""
    folder = tmp_path / "runtime"
    folder.mkdir()
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(folder))
    return folder


def _ports(monkeypatch, ports):
    monkeypatch.setattr(discover, "serial_ports", lambda: list(ports))


def test_list_prints_every_controller_and_skips_the_rest(
    two_emulators, silent_pty, monkeypatch, capsys, tmp_path
):
    a, b = two_emulators
    _ports(monkeypatch, [a.urls["pty"], silent_pty, str(tmp_path / "gone"), b.urls["socket"]])
    assert bench_cli(["bench", "list"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split() == [
        "port",
        "node",
        "firmware",
        "(build)",
        "protocol",
        "table",
        "channels",
        "state",
    ]
    rows = {line.split()[0]: line for line in out[1:3]}
    assert set(rows) == {a.urls["pty"], b.urls["socket"]}
    mine = rows[a.urls["pty"]].split()
    assert (
        mine[1] == "-"
        and mine[4] == str(msgs.PROTOCOL_VERSION)
        and mine[5] == f"{msgs.TABLE_HASH:08x}"
        and mine[6] == "1"
    )
    assert "idle, configuration defaults" in rows[a.urls["pty"]]
    assert "deadbeef" in rows[b.urls["socket"]] and "(host: other)" in rows[b.urls["socket"]]
    assert "(host: other)" not in rows[a.urls["pty"]]
    assert out[3].startswith("note: a controller marked 'host: other'")


def test_list_leaves_a_run_running(two_emulators, monkeypatch, capsys, kept_alive):
    a, _ = two_emulators
    owner = BenchClient(SerialLink(a.urls["socket"]))
    owner.connect()
    owner.set("source", "wave")
    owner.simple("START", duration_ticks=5000)
    try:
        _ports(monkeypatch, [a.urls["pty"]])
        with kept_alive(owner):  # the owner's host stays alive, as a recording one does
            assert bench_cli(["bench", "list"]) == 0
        assert "running, configuration defaults, unsaved changes" in capsys.readouterr().out
        assert owner.hello().running  # HELLO only: the run goes on
    finally:
        owner.request("STOP")
        owner.link.close()


def test_port_auto_uses_the_only_controller(two_emulators, silent_pty, monkeypatch, capsys):
    a, _ = two_emulators
    _ports(monkeypatch, [silent_pty, a.urls["pty"]])
    assert bench_cli(["bench", "--port", "auto", "info"]) == 0
    assert f"device        {a.urls['pty']}" in capsys.readouterr().out


def test_port_auto_refuses_several_and_none(two_emulators, silent_pty, monkeypatch, capsys):
    a, b = two_emulators
    _ports(monkeypatch, [a.urls["pty"], b.urls["socket"]])
    assert bench_cli(["bench", "--port", "auto", "info"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "2 controllers found, name one with --port" in err
    assert a.urls["pty"] in err and b.urls["socket"] in err
    _ports(monkeypatch, [silent_pty])
    assert bench_cli(["bench", "--port", "auto", "info"]) == 1
    err = capsys.readouterr().err.strip()
    assert err == (
        "bowden bench: --port auto: no controller answered HELLO (1 serial port(s) probed)"
    )
    _ports(monkeypatch, [])
    assert bench_cli(["bench", "list"]) == 1
    err = capsys.readouterr().err.strip()
    assert err == "bowden bench list: no controller answered HELLO (pyserial lists no ports)"


def test_list_finds_every_node_of_a_can_bus(capsys):
    bus = f"virtual:list_{os.getpid()}"
    one = Emulator(pty=False, tcp_port=0, can=bus).start()
    five = Emulator(pty=False, tcp_port=0, can=bus).start()
    try:
        c = BenchClient(SerialLink(five.urls["socket"]))
        c.connect()
        c.set("dev.can_node", 5)  # in force at once: the device now answers as node 5
        c.link.close()
        assert bench_cli(["bench", "--can", bus, "list"]) == 0
        rows = capsys.readouterr().out.splitlines()[1:]
        assert [r.split()[:2] for r in rows] == [[bus, "1"], [bus, "5"]]
        assert "idle, configuration defaults, unsaved changes" in rows[1]
        assert "idle, configuration defaults" in rows[0] and "unsaved" not in rows[0]
    finally:
        one.stop()
        five.stop()
    assert bench_cli(["bench", "--can", f"virtual:empty_{os.getpid()}", "list"]) == 1
    assert "no controller answered HELLO on virtual:empty" in capsys.readouterr().err


def test_list_names_a_busy_port_and_its_holder(two_emulators, monkeypatch, capsys):
    """A port another client records on is listed as busy with the holder's pid (its lock says
    who), not skipped as if no controller were there; nothing is sent to it."""
    a, b = two_emulators
    owner = BenchClient(SerialLink(a.urls["pty"]))
    owner.connect()
    owner.set("source", "wave")
    owner.simple("START", duration_ticks=5000)
    try:
        _ports(monkeypatch, [a.urls["pty"]])
        assert bench_cli(["bench", "list"]) == 0
        out = capsys.readouterr().out.splitlines()
        assert len(out) == 2 and out[1].split()[:6] == [a.urls["pty"], "-", "-", "-", "-", "-"]
        assert f"busy: in use by another client (pid {os.getpid()}:" in out[1]
        # --port auto: the only controller is busy: the holder's refusal, as a session meets it.
        assert bench_cli(["bench", "--port", "auto", "info"]) == 1
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1
        assert f"{a.urls['pty']}, is in use by another client (pid {os.getpid()}:" in err
        # With another controller beside it, which one is meant is the user's to say.
        _ports(monkeypatch, [a.urls["pty"], b.urls["socket"]])
        assert bench_cli(["bench", "--port", "auto", "info"]) == 2
        err = capsys.readouterr().err
        assert "2 controllers found" in err and f"{a.urls['pty']} (busy: pid {os.getpid()}" in err
        assert b.urls["socket"] in err
        assert owner.hello().running  # the run went on
    finally:
        owner.request("STOP")
        owner.link.close()


def test_list_and_port_auto_find_a_registered_emulator(monkeypatch, capsys, own_runtime_dir):
    """pyserial cannot list a pty: a findable emulator names its own in the runtime folder while
    it runs, and the file goes when it stops."""
    _ports(monkeypatch, [])
    emu = Emulator(tcp_port=0, findable=True).start()
    try:
        assert [e["urls"] for e in discover.registered_emulators()] == [emu.urls]
        assert bench_cli(["bench", "list"]) == 0
        rows = capsys.readouterr().out.splitlines()[1:]
        assert [r.split()[0] for r in rows] == [emu.urls["pty"]]  # once, not once a URL
        assert bench_cli(["bench", "--port", "auto", "info"]) == 0
        assert f"device        {emu.urls['pty']}" in capsys.readouterr().out
    finally:
        emu.stop()
    assert list(own_runtime_dir.glob("bowden-emulator-*")) == []
    assert bench_cli(["bench", "list"]) == 1
    assert "no controller answered HELLO" in capsys.readouterr().err


def test_a_stale_registration_is_ignored_and_removed(monkeypatch, capsys, own_runtime_dir):
    """An emulator killed outright leaves its file: its process is gone, so `list` does not
    probe its URLs (a later device there is not that emulator) and removes the file."""
    import subprocess
    import sys

    _ports(monkeypatch, [])
    gone = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        check=True,
        capture_output=True,
        text=True,
    )
    emu = Emulator(tcp_port=0, pty=False).start()  # answers, but is not the registered one
    stale = own_runtime_dir / "bowden-emulator-1-0.json"
    stale.write_text(
        json.dumps({"pid": int(gone.stdout), "start": None, "urls": {"socket": emu.urls["socket"]}})
    )
    try:
        assert discover.registered_ports() == []
        assert not stale.exists()
        stale.write_text(
            json.dumps(
                {"pid": int(gone.stdout), "start": None, "urls": {"socket": emu.urls["socket"]}}
            )
        )
        assert bench_cli(["bench", "list"]) == 1
        assert "no controller answered HELLO" in capsys.readouterr().err
        # The same pid given to a new process since (its start time differs): stale too.
        stale.write_text(
            json.dumps({"pid": os.getpid(), "start": "1", "urls": {"socket": emu.urls["socket"]}})
        )
        assert discover.registered_ports() == []
    finally:
        emu.stop()


def test_bowden_emulate_is_findable_until_it_ends(own_runtime_dir, monkeypatch):
    """`bowden emulate` registers itself; SIGTERM (its usual end) removes the file, SIGKILL
    leaves one that `list` finds stale."""
    import signal
    import subprocess
    import sys
    import time

    _ports(monkeypatch, [])
    env = {**os.environ, "XDG_RUNTIME_DIR": str(own_runtime_dir)}
    for sig, left in ((signal.SIGTERM, 0), (signal.SIGKILL, 1)):
        emu = subprocess.Popen(
            [sys.executable, "-m", "cosim.bench", "emulate", "--no-tcp"],
            env=env,
            stdout=subprocess.PIPE,
            text=True,
        )
        try:
            lines = [emu.stdout.readline() for _ in range(2)]
            pty = lines[1].split("--port ")[1].split()[0]
            deadline = time.monotonic() + 10
            while not discover.registered_ports() and time.monotonic() < deadline:
                time.sleep(0.05)
            assert discover.registered_ports() == [pty]
            assert discover.probe_port(pty) is not None  # it answers
        finally:
            emu.send_signal(sig)
            emu.wait(timeout=10)
            emu.stdout.close()
        assert len(list(own_runtime_dir.glob("bowden-emulator-*"))) == left, sig
        assert discover.registered_ports() == []


# `bowden emulate` with a signal sent to itself at one moment of its start or stop (argv: the
# moment, the signal, the entry point). It prints how many registry files there were then.
_SIGNAL_AT = """
import os, signal, sys
from pathlib import Path
from cosim.bench.emulate import emulator
moment, sig, entry = sys.argv[1], getattr(signal, sys.argv[2]), sys.argv[3]

def signal_now():
    files = list(Path(os.environ["XDG_RUNTIME_DIR"]).glob("bowden-emulator-*"))
    print(f"registry files at the signal: {len(files)}", flush=True)
    os.kill(os.getpid(), sig)

register, start, stop = emulator.register_emulator, emulator.Emulator.start, emulator.Emulator.stop
if moment == "registered":  # inside start(): the file just written, the thread not started
    def patched(urls):
        path = register(urls)
        signal_now()
        return path
    emulator.register_emulator = patched
elif moment == "started":  # start() returned, before the command's wait
    def patched(self):
        start(self)
        signal_now()
        return self
    emulator.Emulator.start = patched
else:  # "stopping": --seconds is over, stop() begins
    def patched(self):
        signal_now()
        stop(self)
    emulator.Emulator.stop = patched
if entry == "bowden":
    from cosim.cli import main
else:
    from cosim.bench.__main__ import main
seconds = "0.5" if moment == "stopping" else "30"
sys.exit(main(["emulate", "--no-tcp", "--seconds", seconds]))
"""


@pytest.mark.parametrize("entry", ["bowden", "python -m cosim.bench"])
@pytest.mark.parametrize(
    ("moment", "sig"),
    [
        ("registered", "SIGTERM"),
        ("started", "SIGTERM"),
        ("started", "SIGINT"),
        ("stopping", "SIGTERM"),
        ("stopping", "SIGINT"),
    ],
)
def test_a_signal_at_any_moment_of_the_start_or_stop_removes_the_registry_file(
    moment, sig, entry, own_runtime_dir
):
    """The handler used to be put in place after the start, and taken away before the stop: a
    SIGTERM in between killed `python -m cosim.bench emulate` outright, and raised in `bowden
    emulate` where nothing stopped the emulator, leaving its registry file each time (and a
    Ctrl-C there was a traceback). Now a signal at any of those moments ends the command
    cleanly: SIGTERM as its usual end (exit 0, the line a run's end prints), SIGINT in one line
    (exit 130); the file goes either way."""
    import subprocess
    import sys

    proc = subprocess.run(
        [sys.executable, "-c", _SIGNAL_AT, moment, sig, entry],
        env={**os.environ, "XDG_RUNTIME_DIR": str(own_runtime_dir)},
        capture_output=True,
        text=True,
        timeout=60,
    )
    out, err = proc.stdout, proc.stderr
    assert "registry files at the signal: 1" in out, (out, err)
    assert list(own_runtime_dir.glob("bowden-emulator-*")) == [], (proc.returncode, out, err)
    if sig == "SIGTERM":
        assert proc.returncode == 0 and err == "", (proc.returncode, out, err)
        assert "bowden emulate: stopped after " in out, out
    else:
        assert proc.returncode == 130, (proc.returncode, out, err)
        assert err.startswith("bowden emulate: interrupted by SIGINT: stopped after "), err
        assert err.count("\n") == 1, err


def test_list_bad_and_odd_arguments_are_one_line_each(silent_pty, capsys, monkeypatch, tmp_path):
    """A port named with --port that is not listed says why; what list cannot take is a usage
    error (exit 2), not ignored: an empty --port, --emulate without the bus it would join, a
    --can that is no INTERFACE:CHANNEL; a runtime folder that cannot hold the port locks is
    said once, not taken for ports without controllers."""
    _ports(monkeypatch, [silent_pty])
    gone = tmp_path / "gone"
    cases = [
        (["--port", str(gone), "list"], 1, f"no controller answered HELLO on {gone} (cannot open"),
        (
            ["--port", silent_pty, "--timeout", "0.2", "list"],
            1,
            f"no controller answered HELLO on {silent_pty} (no answer to HELLO within 0.2 s)",
        ),
        (["--port", "", "list"], 2, "--port is empty"),
        (["--emulate", "list"], 2, "--emulate lists an emulator on the --can bus given"),
        (["--can", "bogus", "list"], 2, "--can bogus: expected INTERFACE:CHANNEL"),
    ]
    for argv, status, text in cases:
        assert bench_cli(["bench", *argv]) == status, argv
        err = capsys.readouterr().err
        assert len(err.splitlines()) == 1 and text in err, (argv, err)
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(gone))
    assert bench_cli(["bench", "list"]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and f"cannot make a port lock in {gone}" in err, err
