"""`bowden bench list` and `--port auto` against emulators on ptys, TCP and a CAN bus: what each
controller says, a device of another table marked, a run in progress left running, and the bad
cases (none found, several found) in one line each. pyserial cannot list ptys or socket:// URLs,
so the tests hand their ports to `discover.serial_ports`."""

import os

import pytest

from cosim.bench import discover
from cosim.bench import messages as msgs
from cosim.bench.__main__ import main as bench_cli
from cosim.bench.client import BenchClient, SerialLink
from cosim.bench.emulator import Emulator


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


def _ports(monkeypatch, ports):
    monkeypatch.setattr(discover, "serial_ports", lambda: list(ports))


def test_list_prints_every_controller_and_skips_the_rest(
    two_emulators, silent_pty, monkeypatch, capsys, tmp_path
):
    a, b = two_emulators
    _ports(monkeypatch, [a.urls["pty"], silent_pty, str(tmp_path / "gone"), b.urls["socket"]])
    assert bench_cli(["bench", "list"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split() == ["port", "node", "firmware", "(build)", "protocol", "table", "state"]
    rows = {line.split()[0]: line for line in out[1:3]}
    assert set(rows) == {a.urls["pty"], b.urls["socket"]}
    mine = rows[a.urls["pty"]].split()
    assert (
        mine[1] == "-"
        and mine[4] == str(msgs.PROTOCOL_VERSION)
        and mine[5] == f"{msgs.TABLE_HASH:08x}"
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
