"""The emulator and `bowden bench` end to end: the C loop model held to rtl_model at every
sample, the native chain to its Python twin, then runs over the pty, the socket and python-can's
virtual bus; garbage both ways, a killed run, a version mismatch, a device already streaming,
persistence across a restart, and one bad input per option."""

import ctypes
import os
import random
import signal
import socket
import subprocess
import sys
import time

import numpy as np
import pytest

from cosim.bench.__main__ import main as bench_cli
from cosim.bench.emulate.emulator import Emulator
from cosim.bench.emulate.host_device import ChainConfig, Device, EmuLoop, LoopChain, load_library
from cosim.bench.link import messages as msgs
from cosim.bench.link import paramfiles
from cosim.bench.link import protocol as proto
from cosim.bench.link.client import BenchClient, SerialLink, VersionMismatchError
from cosim.bench.link.recorder import record_run
from cosim.parts import regmap, rtl_model
from cosim.project.paths import REPO_ROOT
from cosim.results import trace as trace_mod

WRITABLE = [
    name
    for name, reg in regmap.REGISTERS.items()
    if len(reg.fields) == 1 and reg.fields[0].access == "rw"
]


def test_c_loop_model_equals_rtl_model_at_every_sample():
    """emu_loop (C) against rtl_model.TensionLoopModel: random register writes (gains, limits,
    slew, watchdog, ADC window), CTRL pulses, ADC codes over the whole range and missing ADC
    samples, 30 000 ticks, every output compared."""
    lib = load_library()
    c = EmuLoop()
    lib.emu_loop_reset(ctypes.byref(c))
    py = rtl_model.TensionLoopModel()
    rng = random.Random(5)
    for k in range(30_000):
        if rng.random() < 0.05:
            name = rng.choice(WRITABLE)
            f = regmap.REGISTERS[name].fields[0]
            v = rng.randint(f.min, f.max)
            if name in ("KFF", "KP"):
                v = rng.randint(-2000, 2000)
            py.write(name, v)
            lib.emu_loop_write(ctypes.byref(c), regmap.REGISTERS[name].addr, regmap.encode(name, v))
        if rng.random() < 0.01:
            w = rng.choice([1, 1 | 8, 2 | 1, 4 | 1, 0, 1 | 2 | 4])
            py.write("CTRL", w)
            lib.emu_loop_write(ctypes.byref(c), regmap.CTRL, w)
        if rng.random() < 0.97:
            code = (
                rng.randint(-(1 << 23), (1 << 23) - 1)
                if rng.random() < 0.02
                else rng.randint(-40000, 40000)
            )
            py.adc_sample(code)
            lib.emu_loop_adc(ctypes.byref(c), code)
        out = py.tick()
        lib.emu_loop_tick(ctypes.byref(c))
        got = (
            c.u,
            c.t_in,
            c.integ,
            c.tc_eff,
            c.faults,
            bool(c.out_en),
            bool(c.saturated),
            bool(c.wdt_ramp),
            c.sample_count,
        )
        want = (
            out.u,
            out.t_in,
            out.integ,
            out.tc_eff,
            out.faults,
            out.out_en,
            out.saturated,
            out.wdt_ramp,
            out.sample_count,
        )
        assert got == want, f"tick {k}: C {got} != model {want}"


def _start(dev: Device, **params) -> None:
    for name, value in params.items():
        p = proto.param(name)
        payload = proto.pack("PARAM_SET", param=p.id, value=proto.word_from_value(p, value))
        dev.rx_bytes(0, proto.encode_frame(proto.Frame(msgs.MESSAGES["PARAM_SET"].id, 1, payload)))
    start = proto.Frame(
        msgs.MESSAGES["START"].id,
        2,
        proto.pack("START", duration_ticks=msgs.START_DURATION["CONTINUOUS"]),
    )
    dev.rx_bytes(0, proto.encode_frame(start))


def test_native_chain_equals_python_chain():
    """The C chain (emu_step) and the Python one (rtl_model + Plant) give the same command word
    and T_c at every FPGA sample of a run (paper law, 0.5 s of a 2 Hz sine, reversals inside)."""
    runs = {}
    for engine in ("native", "python"):
        dev = Device()
        chain = LoopChain(dev, ChainConfig(), engine=engine, record=5000)
        _start(dev, **{"source": "wave", "wave.freq_hz": 2.0, "comp.mode": "paper"})
        for _ in range(500):
            chain.step()
        runs[engine] = chain.recorded
        chain.close()
    (u_c, tc_c), (u_p, tc_p) = runs["native"], runs["python"]
    assert len(u_c) == len(u_p) == 5000
    assert np.abs(u_c).max() > 1000  # the loop did drive current
    np.testing.assert_array_equal(tc_c, tc_p)
    np.testing.assert_array_equal(u_c, u_p)


def test_board_interface_on_the_python_engine():
    """The emulator runs on the co-simulation's interface stage (cosim.parts.interface):
    with the board's ADC and PWM -> ESCON the command differs from the ideal chain's (the ADC
    delivers a sample every fifth tick), and the native engine refuses it rather than
    silently running the ideal one."""
    words = {}
    for iface in ("ideal", "board"):
        dev = Device()
        chain = LoopChain(dev, ChainConfig(interface=iface), engine="python", record=2000)
        _start(dev, source="wave")
        for _ in range(200):
            chain.step()
        words[iface] = chain.recorded[0]
        chain.close()
    assert np.abs(words["board"]).max() > 1000
    assert np.count_nonzero(words["board"] != words["ideal"]) > 1000
    with pytest.raises(ValueError, match="runs on the python engine"):
        LoopChain(Device(), ChainConfig(interface="board"), engine="native")


@pytest.fixture
def emulator():
    emu = Emulator(tcp_port=0).start()
    yield emu
    emu.stop()


def _check_trace(path, seconds, rate=1000.0):
    tr = trace_mod.read_trace(path)  # validates columns, spacing, sidecar
    n = int(round(seconds * rate))
    assert len(tr) == n
    np.testing.assert_array_equal(tr["sample"], np.arange(n))
    assert tr["T_out_N"].max() > 5.0  # the plant did pull
    return tr


@pytest.mark.parametrize("kind", ["pty", "socket", "can"])
def test_run_records_1khz_without_gaps(kind, emulator, tmp_path, capsys):
    out = tmp_path / f"{kind}.csv"
    if kind == "can":
        link = ["--can", f"virtual:bench_{os.getpid()}", "--emulate"]
    else:
        link = ["--port", emulator.urls["pty" if kind == "pty" else "socket"]]
    rc = bench_cli(["bench", *link, "run", "sine", "--seconds", "2", "--out", str(out), "--quiet"])
    text = capsys.readouterr()
    assert rc == 0, text.err
    assert "2000 samples of 2000, drops 0" in text.out
    tr = _check_trace(out, 2.0)
    assert tr.meta["source"] == "bowden bench" and tr.meta["compensator"] == "paper"
    assert tr.meta["columns_not_measured"] == ["x_m", "y_m", "z_m", "motor_angle_rad"]
    # The friction exponent in force travels in serial telemetry only (CAN's frames are full):
    # here the configured one, comp.mu * comp.phi_rad = 0.075 * 2 pi, to its UQ2.14 LSB.
    if kind == "can":
        assert "mu_phi" not in tr.columns and "est_faults" not in tr.columns
    else:
        np.testing.assert_allclose(tr["mu_phi"], 0.075 * 2 * np.pi, atol=2.0**-14)
        assert not np.any(tr["est_faults"])


def test_garbage_both_ways_is_counted_and_the_run_goes_on(emulator, tmp_path):
    link = SerialLink(emulator.urls["pty"])
    client = BenchClient(link)
    client.connect()
    junk = bytes(random.Random(3).randrange(1, 256) for _ in range(300))

    def on_sample(n):
        if n in (300, 900, 1500):
            emulator.inject_garbage()  # device -> host, between frames
        if n in (600, 1200):
            link.write_raw(junk)  # host -> device
            link.write_raw(b"\x00")

    res = record_run(
        client,
        tmp_path / "g.csv",
        seconds=2.0,
        waveform="triangle",
        mean_n=8,
        amplitude_n=6,
        freq_hz=1.0,
        on_sample=on_sample,
    )
    assert (res.samples, res.drops, res.overflow) == (2000, 0, 0)
    assert link.stats.rejected >= 2  # the emulator's bursts, counted by the host
    st = client.stats()
    assert st["rx_crc_errors"] + st["rx_framing_errors"] + st["rx_short"] + st["rx_overlong"] >= 2
    _check_trace(tmp_path / "g.csv", 2.0)
    link.close()


def test_killed_run_leaves_a_readable_file(emulator, tmp_path):
    out = tmp_path / "killed.csv"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "cosim.bench",
            "bench",
            "--port",
            emulator.urls["socket"],
            "run",
            "sine",
            "--seconds",
            "30",
            "--out",
            str(out),
            "--quiet",
        ],
        cwd=REPO_ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    # The rows go to killed.partial.csv until the run ends (then onto --out): a SIGKILL leaves
    # them there, and --out as it was.
    partial = tmp_path / "killed.partial.csv"
    out.write_text("an earlier recording\n")
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # wait for more than 2 s of flushed rows
            if partial.exists() and partial.read_text().count("\n") > 2100:
                break
            time.sleep(0.1)
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.wait(timeout=10)
    assert out.read_text() == "an earlier recording\n"
    tr = trace_mod.read_trace(partial)
    assert len(tr) > 2000
    np.testing.assert_array_equal(tr["sample"], np.arange(len(tr)))
    # The device keeps running a run whose host died; the next session stops it on connect.
    client = BenchClient(SerialLink(emulator.urls["socket"]))
    assert client.hello().running
    info = client.connect()
    assert not info.running and not client.hello().running
    assert info.table_hash == msgs.TABLE_HASH
    client.link.close()


def test_device_already_streaming_is_stopped_on_connect(emulator, tmp_path):
    a = BenchClient(SerialLink(emulator.urls["pty"]))
    a.connect()
    a.set("source", "wave")
    a.simple("START", duration_ticks=msgs.START_DURATION["CONTINUOUS"])  # until STOP
    a.link.close()  # gone without STOP: the device streams into the pty's buffer
    time.sleep(0.15)
    b = BenchClient(SerialLink(emulator.urls["pty"]))  # opening the pty flushes its buffer
    # ... so let the stream queue up again before the first request, well within the device's
    # host watchdog (HOST_WATCHDOG.TIMEOUT_MS after START it stops the run by itself)
    time.sleep(0.1)
    assert b.hello().running and b.stale_telemetry > 0  # the reply was found among telemetry
    info = b.connect()
    assert not info.running and not b.hello().running
    assert b.get("comp.mode") == "paper"  # replies are found among the stale frames
    res = record_run(
        b, tmp_path / "s.csv", seconds=1.0, waveform="step", mean_n=8, amplitude_n=2, freq_hz=2.0
    )
    assert (res.samples, res.drops) == (1000, 0)
    b.link.close()


def test_version_mismatch_is_one_clear_line(capsys):
    emu = Emulator(tcp_port=0, pty=False, identity=(msgs.PROTOCOL_VERSION, 0xDEADBEEF)).start()
    try:
        rc = bench_cli(["bench", "--port", emu.urls["socket"], "info"])
    finally:
        emu.stop()
    err = capsys.readouterr().err.strip()
    assert rc == 1 and len(err.splitlines()) == 1
    assert f"table {msgs.TABLE_HASH:08x}" in err and "table deadbeef" in err
    assert "version mismatch" in err
    with pytest.raises(VersionMismatchError):
        raise VersionMismatchError(err)


def test_settings_survive_an_emulator_restart(tmp_path, capsys):
    flash = tmp_path / "flash.bin"
    for step in ("set", "check"):
        emu = Emulator(tcp_port=0, pty=False, flash_path=flash).start()
        url = emu.urls["socket"]
        try:
            if step == "set":
                assert (
                    bench_cli(["bench", "--port", url, "set", "loop.kp=0.07", "comp.mode=smooth"])
                    == 0
                )
                assert bench_cli(["bench", "--port", url, "persist"]) == 0
                assert bench_cli(["bench", "--port", url, "backup", str(tmp_path / "b.json")]) == 0
                assert bench_cli(["bench", "--port", url, "set", "loop.kp=0.01"]) == 0
            else:
                assert bench_cli(["bench", "--port", url, "get", "loop.kp", "comp.mode"]) == 0
                assert bench_cli(["bench", "--port", url, "defaults"]) == 0
                assert bench_cli(["bench", "--port", url, "restore", str(tmp_path / "b.json")]) == 0
                assert bench_cli(["bench", "--port", url, "info"]) == 0
        finally:
            emu.stop()
    out = capsys.readouterr().out
    assert "loop.kp    0.0699463 A/N" in out and "comp.mode  smooth" in out
    # every writable parameter of the backup: the table's count, read from the plan restore makes
    writable = len(paramfiles.restore_plan(tmp_path / "b.json")[0])
    assert writable == sum(not p.read_only for p in msgs.PARAMS)
    assert f"restored {writable} parameters" in out and "configuration flash" in out


@pytest.mark.parametrize("target", ["host", "soc"])
@pytest.mark.parametrize(
    ("where", "words"),
    [
        ("/proc/x.bin", "flash file /proc/x.bin: cannot be written in /proc"),
        ("missing/flash.bin", "missing/flash.bin: the folder {tmp}/missing does not exist"),
        ("", "flash file {tmp}: not a regular file"),
        ("short.bin", "flash file {tmp}/short.bin: 1000 bytes, a flash image has"),
    ],
)
def test_a_flash_file_that_cannot_be_kept_is_refused_before_the_start(
    target, where, words, tmp_path, monkeypatch, capsys
):
    """--flash is checked before anything starts, for both targets: the emulator used to start
    on /proc/x.bin and fail at the first save (the simulated board stopped, the client read
    only 'read failed'; the host emulator's thread died). Nothing is started (a board or an
    emulator that starts fails the test), nothing is written."""

    def started(*args, **kwargs):
        raise AssertionError("the emulator started")

    monkeypatch.setattr("cosim.bench.emulate.emulator.Emulator", started)
    monkeypatch.setattr("cosim.bench.emulate.soc.harness.SocBoard", started)
    (tmp_path / "short.bin").write_bytes(b"\0" * 1000)
    flash = where if where.startswith("/") else str(tmp_path / where) if where else str(tmp_path)
    rc = bench_cli(["emulate", "--target", target, "--flash", flash, "--seconds", "0.1"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1, err
    assert err.startswith("bowden emulate: ") and words.format(tmp=tmp_path) in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["short.bin"]


def test_a_flash_file_lost_while_the_emulator_runs_stops_it_in_one_line(tmp_path):
    """The flash's folder removed under a running `bowden emulate`: the next save failed in the
    emulator's thread (a traceback), the controller was gone and the command went on until
    --seconds and exited 0. It now stops at once: one line naming the file, exit 1."""
    folder = tmp_path / "kept"
    folder.mkdir()
    cmd = [sys.executable, "-m", "cosim.bench", "emulate", "--no-pty", "--seconds", "30"]
    proc = subprocess.Popen(
        [*cmd, "--flash", str(folder / "flash.bin")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=REPO_ROOT,
    )
    try:
        url = next(line.split()[4] for line in proc.stdout if "socket://" in line)
        for p in folder.iterdir():
            p.unlink()
        folder.rmdir()
        client = BenchClient(SerialLink(url))
        try:
            client.connect()
            client.simple("PERSIST")  # the device's flash changes: the emulator saves it
        finally:
            client.link.close()
        out, err = proc.communicate(timeout=10)
    finally:
        proc.kill()
    assert proc.returncode == 1, (out, err)
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith("bowden emulate: the emulated controller stopped after "), err
    assert f"No such file or directory: {folder / 'flash.bin'}" in err, err


@pytest.mark.parametrize(
    ("option", "rc", "words"),
    [
        (["--tcp-port", "BUSY"], 1, "--tcp-port BUSY: Address already in use"),
        (
            ["--can", "nope:x"],
            1,
            '--can nope:x: cannot open the bus (Unknown interface type "nope")',
        ),
        (
            ["--interface", "adc", "--engine", "native"],
            2,
            "--engine native has the ideal interface only: --interface adc runs on the Python",
        ),
    ],
)
def test_emulate_start_problems_name_the_option(option, rc, words, capsys):
    """A port in use or a bus that does not open was an errno line naming no option; --engine
    native given with --interface adc was replaced by the Python engine, silently."""
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = str(busy.getsockname()[1])
        args = [port if a == "BUSY" else a for a in option]
        got = bench_cli(["emulate", "--no-pty", "--seconds", "0.1", *args])
    err = capsys.readouterr().err
    assert got == rc and err.count("\n") == 1, err
    assert err.startswith("bowden emulate: " + words.replace("BUSY", port)), err


# A value this host or the device refuses is a usage error (exit 2), and so is a backup file that
# is missing (refused before the link opens, as diff refuses it).
@pytest.mark.parametrize(
    ("args", "rc", "words"),
    [
        (["set", "comp.nope=1"], 2, "unknown parameter 'comp.nope'"),
        (["set", "comp.mu=2"], 2, "device error INVALID_VALUE: comp.mu: outside [0, 1]"),
        (["set", "comp.mode=fast"], 2, "expected one of none, paper, smooth"),
        (["set", "tick_rate_hz=500"], 2, "tick_rate_hz is read-only"),
        (["set", "comp.mu"], 2, "expected NAME=VALUE"),
        (["get", "x.y"], 2, "unknown parameter 'x.y'"),
        (["restore", "/no/such.json"], 2, "does not exist"),
        (["run", "stream", "--seconds", "1", "--out", "x.csv"], 2, "needs --ref"),
    ],
)
def test_bad_inputs_are_one_line(args, rc, words, emulator, capsys):
    got = bench_cli(["bench", "--port", emulator.urls["socket"], *args])
    err = capsys.readouterr().err.strip()
    assert got == rc and len(err.splitlines()) == 1 and words in err, err


def test_bad_links_and_options(capsys, tmp_path):
    assert bench_cli(["bench", "info"]) == 2
    assert "one of --port URL, --can INTERFACE:CHANNEL or --emulate is required" in (
        capsys.readouterr().err
    )
    assert bench_cli(["bench", "--port", "x"]) == 2
    assert "a COMMAND is required: info, get, set" in capsys.readouterr().err
    assert bench_cli(["bench", "--port", str(tmp_path / "nope"), "info"]) == 1
    assert "cannot open" in capsys.readouterr().err
    assert bench_cli(["bench", "--can", "virtual", "info"]) == 2
    assert "expected INTERFACE:CHANNEL" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        bench_cli(["bench", "--port", "x", "run", "sine", "--seconds", "-1", "--out", "y"])
    assert exc.value.code == 2 and "expected a number > 0" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        bench_cli(["emulate", "--position", "1,2"])
    assert "expected X,Y,Z" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    emu = Emulator(tcp_port=0, pty=False).start()
    try:
        assert bench_cli(["bench", "--port", emu.urls["socket"], "restore", str(bad)]) == 2
        assert "is not a JSON backup" in capsys.readouterr().err
        ref = tmp_path / "ref.csv"
        ref.write_text("T_ref_N\n1.0\nabc\n")
        args = ["bench", "--port", emu.urls["socket"], "run", "stream", "--ref", str(ref)]
        # A reference file that cannot be used is the user's to fix, as every file named: exit 2.
        assert bench_cli([*args, "--seconds", "1", "--out", str(tmp_path / "r.csv")]) == 2
        assert f"{ref}:3: T_ref 'abc' is not a finite number" in capsys.readouterr().err
        fifo = tmp_path / "ref.fifo"
        os.mkfifo(fifo)  # no writer: reading it would wait for ever
        args[-1] = str(fifo)
        assert bench_cli([*args, "--seconds", "1", "--out", str(tmp_path / "r.csv")]) == 2
        assert f"--ref {fifo}: not a regular file" in capsys.readouterr().err
    finally:
        emu.stop()


def test_stream_run_follows_the_samples(emulator, tmp_path):
    """`run stream`: arbitrary T_ref samples, flow-controlled into the device's buffer."""
    ref = tmp_path / "ref.csv"
    t = np.arange(1500) / 1000.0
    values = 6.0 + 4.0 * np.sign(np.sin(2 * np.pi * 1.5 * t))
    ref.write_text("T_ref_N\n" + "\n".join(f"{v:.4f}" for v in values) + "\n")
    out = tmp_path / "stream.csv"
    rc = bench_cli(
        [
            "bench",
            "--port",
            emulator.urls["socket"],
            "run",
            "stream",
            "--ref",
            str(ref),
            "--seconds",
            "1.5",
            "--out",
            str(out),
            "--quiet",
        ]
    )
    assert rc == 0
    tr = _check_trace(out, 1.5)
    np.testing.assert_array_equal(tr["T_ref_N"], np.round(values * 256) / 256)
    assert not np.any(tr["faults"].astype(int) & msgs.FAULTS["STREAM_UNDERRUN"])
