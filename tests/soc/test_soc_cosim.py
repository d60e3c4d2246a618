"""The full-system co-simulation behind `bowden emulate --target soc`: bowden_soc executing the
RV32 firmware in Verilator (cosim/bench/emulate/soc), reached by `bowden bench`, unchanged, over
a pty.

The harness library is built once (the module's fixture; later builds find it up to date) and
every board here is a separate `bowden emulate --target soc` process, as a user starts it.
Simulated time runs at a fraction of real time, so the runs are short (a few hundred ms).
"""

from __future__ import annotations

import csv
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
from cobs import cobs

from cosim.bench.emulate.soc import build as soc_build
from cosim.bench.link import protocol

BOWDEN = [sys.executable, "-m", "cosim"]


@pytest.fixture(scope="module")
def soc_lib():
    assert soc_build.FW_HEX.exists(), "make firmware-soc first (make test builds it)"
    return soc_build.build()


class Emulated:
    """One `bowden emulate --target soc` process: its pty, stopped by Ctrl-C (SIGINT)."""

    def __init__(self, *args: str):
        self.proc = subprocess.Popen(
            [*BOWDEN, "emulate", "--target", "soc", *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.lines = []
        for line in self.proc.stdout:
            self.lines.append(line)
            m = re.search(r"--port (\S+) info", line)
            if m:
                self.pty = m.group(1)
                break
        else:
            raise AssertionError(f"no pty printed: {self.lines} {self.proc.stderr.read()}")

    def bench(self, *args: str, timeout_s: float = 60.0) -> subprocess.CompletedProcess:
        return subprocess.run(
            [*BOWDEN, "bench", "--port", self.pty, *args],
            capture_output=True,
            text=True,
            timeout=timeout_s,
        )

    def ctrl_c(self) -> tuple[int, str, str]:
        self.proc.send_signal(signal.SIGINT)
        out, err = self.proc.communicate(timeout=30)
        return self.proc.returncode, out, err


def ok(result: subprocess.CompletedProcess) -> str:
    assert result.returncode == 0, (result.args, result.stdout, result.stderr)
    return result.stdout


def test_bench_info_get_set_persist_power_cycle_load_run(soc_lib, tmp_path):
    """info, get, set, persist; Ctrl-C (one line, 130); the board powered again on the same flash
    file holds the persisted value; a set that is not persisted goes on `load`; a short run is
    recorded in the trace format."""
    flash = tmp_path / "flash.bin"
    board = Emulated("--flash", str(flash))
    try:
        info = ok(board.bench("info"))
        assert "configuration defaults" in info, info
        assert "faults        FPGA none; device none" in info, info
        kp0 = float(ok(board.bench("get", "loop.kp")).split()[1])
        ok(board.bench("set", "loop.kp=0.08"))
        assert "saved to flash" in ok(board.bench("persist"))
    finally:
        code, out, err = board.ctrl_c()
    assert code == 130, (code, out, err)
    assert len(err.strip().splitlines()) == 1 and "interrupted by SIGINT" in err, err
    assert flash.stat().st_size == 1 << 21
    assert not list(tmp_path.glob("flash.bin.tmp*")), "a temporary flash file was left"

    board = Emulated("--flash", str(flash))  # power cycle: the flash kept, the rest reset
    try:
        info = ok(board.bench("info"))
        assert "configuration flash" in info, info
        kp = float(ok(board.bench("get", "loop.kp")).split()[1])
        assert abs(kp - 0.08) < 1e-3 and abs(kp0 - 0.08) > 1e-3, (kp0, kp)
        ok(board.bench("set", "loop.kp=0.12"))
        ok(board.bench("load"))
        kp = float(ok(board.bench("get", "loop.kp")).split()[1])
        assert abs(kp - 0.08) < 1e-3, f"load gave {kp}, not the persisted 0.08"
        out = tmp_path / "x.csv"
        summary = ok(board.bench("run", "sine", "--seconds", "0.3", "--out", str(out), "--quiet"))
        assert "300 samples of 300, drops 0" in summary, summary
        with out.open() as f:
            rows = list(csv.DictReader(f))
        assert len(rows) == 300
        assert [int(r["sample"]) for r in rows] == list(range(300))
        t_ref = [float(r["T_ref_N"]) for r in rows]
        assert max(t_ref) > min(t_ref) + 1.0, "the sine reference did not move"
        # The plant in the loop: the FMU's T_in (through the ADS131M02's CH0 and the loop) follows
        # the firmware's T_c, driven by the PWM pin's current; T_out (CH1) moves with it.
        t_c = [float(r["T_c_N"]) for r in rows]
        t_in = [float(r["T_in_N"]) for r in rows]
        t_out = [float(r["T_out_N"]) for r in rows]
        late = range(200, 300)
        err = sum(abs(t_in[i] - t_c[i]) for i in late) / len(late)
        assert err < 1.0, f"T_in misses T_c by {err:.2f} N on average over the last 100 ms"
        assert max(t_in) - min(t_in) > 5.0 and max(t_out) - min(t_out) > 2.0
        assert ok(board.bench("info")).count("running") == 0
    finally:
        code, _, err = board.ctrl_c()
    assert code == 130, err


@pytest.mark.slow
@pytest.mark.long
def test_bench_talks_to_the_two_cable_soc(tmp_path):
    """`bowden emulate --target soc --channels 2`: bowden_soc with two cables (bowden_core_mc, an
    ADS131M04 at its pins, an ESCON and a plant FMU a cable) executing the two-cable image.
    `bowden bench` over its UART: info says 2 channels, a set on channel 1 changes channel 1
    only, and a run of both channels is recorded, a trace a channel, each cable's T_in following
    its own T_c through its own plant. Long: the two-cable SoC's model is a build of its own
    (some minutes), the run about a minute of wall time on an idle machine."""
    assert soc_build.fw_hex(2).exists(), "make firmware-soc first"
    soc_build.build(channels=2)
    board = Emulated("--channels", "2")
    try:
        assert any("2 cables, a plant FMU each" in line for line in board.lines), board.lines
        info = ok(board.bench("--channel", "all", "info"))
        assert "channels      2" in info and "channel 1: FPGA none" in info, info
        ok(board.bench("--channel", "1", "set", "loop.kp=0.08"))
        head, row = ok(board.bench("--channel", "all", "get", "loop.kp")).splitlines()[:2]
        assert head.split() == ["ch", "0", "ch", "1"], head
        kp0, kp1 = (float(v) for v in re.findall(r"-?\d+\.\d+", row))  # each with its unit
        assert abs(kp1 - 0.08) < 1e-3 and abs(kp0 - 0.08) > 1e-3, row
        out = tmp_path / "x.csv"
        run = board.bench(
            "--channel", "all", "run", "sine", "--seconds", "0.3", "--out", str(out), "--quiet",
            timeout_s=300.0,
        )  # fmt: skip
        ok(run)
        for k in (0, 1):
            with (tmp_path / f"x.ch{k}.csv").open() as f:
                rows = list(csv.DictReader(f))
            assert len(rows) == 300, (k, len(rows))
            assert [int(r["sample"]) for r in rows] == list(range(300)), k
            t_c = [float(r["T_c_N"]) for r in rows]
            t_in = [float(r["T_in_N"]) for r in rows]
            late = range(200, 300)
            err = sum(abs(t_in[i] - t_c[i]) for i in late) / len(late)
            assert err < 1.0, f"cable {k}: T_in misses T_c by {err:.2f} N over the last 100 ms"
            assert max(t_in) - min(t_in) > 5.0, k
    finally:
        code, _, err = board.ctrl_c()
    assert code == 130, err


def test_a_cable_count_the_soc_is_not_built_for_is_one_line():
    """--channels 3 with --target soc: one line naming it and the counts the SoC is built for,
    exit 2, before anything is built or started."""
    r = subprocess.run(
        [*BOWDEN, "emulate", "--target", "soc", "--channels", "3", "--seconds", "1"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r
    assert r.stderr == (
        "bowden emulate: --channels 3: the simulated SoC is built for 1, 2 or 4 cables\n"
    ), r.stderr


def test_bad_flash_file_is_one_line(soc_lib, tmp_path):
    """A flash file that is not a flash image: one line naming it, exit 2, the file untouched."""
    flash = tmp_path / "flash.bin"
    flash.write_bytes(b"\x00" * 1000)
    r = subprocess.run(
        [*BOWDEN, "emulate", "--target", "soc", "--flash", str(flash)],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert r.returncode == 2, r
    assert r.stderr.count("\n") == 1 and str(flash) in r.stderr and "1000 bytes" in r.stderr
    assert flash.read_bytes() == b"\x00" * 1000


def test_emulate_soc_stops_after_seconds(soc_lib):
    """--seconds ends the board (exit 0) with its figures; no process is left."""
    t0 = time.monotonic()
    r = subprocess.run(
        [*BOWDEN, "emulate", "--target", "soc", "--seconds", "1"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert r.returncode == 0, r
    assert "simulated time" in r.stdout and "firmware ticks" in r.stdout, r.stdout
    assert time.monotonic() - t0 < 30
    assert os.path.exists(soc_lib)


@pytest.fixture
def own_runtime_dir(monkeypatch, tmp_path):
    """The emulators' registry in this test's own folder (its processes inherit it): a `bowden
    emulate` of someone else on this machine is not found here, nor is this test's board there."""
    folder = tmp_path / "runtime"
    folder.mkdir()
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(folder))
    return folder


def test_the_board_is_findable_until_sigterm_ends_it(soc_lib, own_runtime_dir, monkeypatch, capsys):
    """`bowden emulate --target soc` was not in the registry the host emulator writes, so
    `bowden bench list` and `--port auto` (pyserial cannot list a pty) did not find it. It is
    now, while it runs, and SIGTERM ends it as the host emulator's (its figures, exit 0),
    removing the file."""
    from cosim.bench.__main__ import main as bench_cli  # noqa: PLC0415
    from cosim.bench.link import discover  # noqa: PLC0415

    monkeypatch.setattr(discover, "serial_ports", lambda: [])  # this machine's own: not probed
    board = Emulated()
    try:
        deadline = time.monotonic() + 60  # the board registers, then boots at its own pace
        while discover.probe_port(board.pty) is None:
            assert board.proc.poll() is None and time.monotonic() < deadline, "no HELLO_ACK"
        assert discover.registered_ports() == [board.pty]
        assert bench_cli(["bench", "list"]) == 0
        rows = capsys.readouterr().out.splitlines()[1:]
        assert [r.split()[0] for r in rows] == [board.pty] and "idle" in rows[0], rows
        assert bench_cli(["bench", "--port", "auto", "info"]) == 0
        assert f"device        {board.pty}" in capsys.readouterr().out
    finally:
        board.proc.send_signal(signal.SIGTERM)
        out, err = board.proc.communicate(timeout=30)
    assert board.proc.returncode == 0 and err == "", (board.proc.returncode, out, err)
    assert "bowden emulate: stopped after " in out and "firmware ticks" in out, out
    assert list(own_runtime_dir.glob("bowden-emulator-*")) == []
    assert discover.registered_ports() == []


def test_a_board_whose_run_ends_by_itself_is_no_longer_findable(soc_lib, own_runtime_dir):
    """The registry file goes when the board's run ends, not only when it is stopped (here its
    max_sim_s; an error ends it the same way): a board that no longer runs is not listed."""
    from cosim.bench.emulate.soc.harness import SocBoard  # noqa: PLC0415
    from cosim.bench.link import discover  # noqa: PLC0415

    # At most real time: its 50 ms of simulated time take longer than the look that follows.
    board = SocBoard(realtime=True, max_sim_s=0.05, findable=True).start()
    try:
        assert discover.registered_ports() == [board.pty_name]
        assert board.wait(60)
        assert list(own_runtime_dir.glob("bowden-emulator-*")) == []
    finally:
        board.stop()
    unfindable = SocBoard(realtime=False, max_sim_s=0.002).start()  # tests' own: not listed
    try:
        assert discover.registered_ports() == []
    finally:
        unfindable.stop()


@pytest.mark.parametrize(
    "option",
    [
        ("--can", "virtual:x"),
        ("--baud", "9600"),  # the board's UART bit time is fixed in the RTL
        ("--tcp-port", "5555"),
        ("--interface", "adc"),
        ("--engine", "python"),
    ],
)
def test_host_only_options_are_refused(soc_lib, option):
    """Each host-emulator option given with --target soc is named in one line, exit 2, before
    the board starts (it used to be ignored: the board ran, here for its one second)."""
    r = subprocess.run(
        [*BOWDEN, "emulate", "--target", "soc", "--seconds", "1", *option],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r
    assert r.stderr == f"bowden emulate: {option[0]} is not available with --target soc\n", r


def test_adc_crc_is_the_data_sheets(soc_lib):
    """harness.cpp's frame CRC (soc_adc_crc) is CRC-16/CCITT-FALSE as TI SBAS853A 8.5.1.11
    defines it: the catalogued check value 0x29B1 of "123456789", and the value tests/hdl's model
    (which the RTL reader is tested against) gives for a frame of STATUS, CH0, CH1."""
    from hdl_sim import crc16_ccitt, word_bits  # noqa: PLC0415

    from cosim.bench.emulate.soc.harness import adc_crc  # noqa: PLC0415

    bits = [(byte >> (7 - i)) & 1 for byte in b"123456789" for i in range(8)]
    assert adc_crc(bits) == 0x29B1
    frame = word_bits(0x050300) + word_bits(0x123456) + word_bits(-5)
    assert adc_crc(frame) == crc16_ccitt(frame)


# --- bad input ----------------------------------------------------------------------------------


def _frame(name: str, seq: int, **values) -> bytes:
    msg = protocol.msgs.MESSAGES[name].id
    return protocol.encode_frame(
        protocol.Frame(msg=msg, seq=seq, payload=protocol.pack(name, **values))
    )


def _read_frames(fd: int, decoder, until, timeout_s: float = 30.0) -> list:
    """Frames read from the pty until `until(frames)` or the timeout."""
    frames = []
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and not until(frames):
        try:
            frames += decoder.feed(os.read(fd, 4096))
        except BlockingIOError:
            time.sleep(0.01)
    return frames


def _wait_sim(board, sim_s: float, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while board.stats().sim_s < sim_s:
        assert board.running, board.error
        assert time.monotonic() < deadline, f"the board did not reach {sim_s} s"
        time.sleep(0.01)


def test_request_during_boot_is_dropped_then_answered(soc_lib):
    """PROTOCOL.md leaves a request the device did not take unanswered (the host retries) and
    firmware/soc/main.c drops what arrived during start-up: a HELLO sent before the board boots
    gets no reply, not even after boot; the next HELLO is answered."""
    from cosim.bench.emulate.soc.harness import SocBoard  # noqa: PLC0415

    board = SocBoard(realtime=False)
    fd = os.open(board.pty_name, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        early = _frame("HELLO", 1)
        os.write(fd, early)  # before the power-on: the bytes reach the UART during the boot
        board.start()
        decoder = protocol.FrameDecoder()
        _wait_sim(board, 0.05)
        stats = board.stats()
        assert stats.uart_rx_bytes == len(early) and 0 < stats.boot_ms < 50.0, stats
        assert _read_frames(fd, decoder, lambda f: False, timeout_s=0.3) == []
        os.write(fd, _frame("HELLO", 2))
        frames = _read_frames(fd, decoder, lambda f: any(x.seq == 2 for x in f))
        assert [(f.name, f.seq) for f in frames] == [("HELLO_ACK", 2)], frames
    finally:
        os.close(fd)
        board.stop()


def test_frame_with_a_bad_crc_is_dropped_and_counted(soc_lib):
    """A request whose CRC-32C fails is dropped without an answer (PROTOCOL.md, framing) and
    counted in STATS rx_crc_errors; the next good request is answered."""
    from cosim.bench.emulate.soc.harness import SocBoard  # noqa: PLC0415

    board = SocBoard(realtime=False).start()
    fd = os.open(board.pty_name, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        _wait_sim(board, 0.02)
        good = _frame("HELLO", 3)
        raw = bytearray(cobs.decode(good[1:-1]))
        raw[-1] ^= 0x01  # one bit of the CRC
        os.write(fd, b"\x00" + cobs.encode(bytes(raw)) + b"\x00")
        decoder = protocol.FrameDecoder()
        assert _read_frames(fd, decoder, lambda f: False, timeout_s=0.3) == []
        os.write(fd, _frame("STATS_GET", 4))
        frames = _read_frames(fd, decoder, lambda f: any(x.seq == 4 for x in f))
        assert [(f.name, f.seq) for f in frames] == [("STATS", 4)], frames
        counts = protocol.unpack("STATS", frames[0].payload)
        assert counts["rx_crc_errors"] == 1 and counts["rx_frames"] == 1, counts
    finally:
        os.close(fd)
        board.stop()


def _slot_seq(flash: Path) -> dict[int, int]:
    """The settings record's sequence number in each slot of a flash file (firmware/soc/
    spi_flash.h: two 4-KiB sectors at SPI_FLASH_SETTINGS_ADDR; flash.c: magic, sequence, ...)."""
    data = flash.read_bytes()
    seqs = {}
    for slot in (0, 1):
        at = SETTINGS_ADDR + slot * SECTOR_BYTES
        seqs[slot] = int.from_bytes(data[at + 4 : at + 8], "little")
    return seqs


def _corrupt(flash: Path, slot: int) -> None:
    data = bytearray(flash.read_bytes())
    data[SETTINGS_ADDR + slot * SECTOR_BYTES + 12] ^= 0x10  # a payload bit: the CRC fails
    flash.write_bytes(bytes(data))


SETTINGS_ADDR, SECTOR_BYTES = 0x100000, 4096


def test_corrupted_flash_record_falls_back_and_says_which(soc_lib, tmp_path):
    """Two records persisted (loop.kp 0.08 as record 1, 0.09 as record 2); the newer one
    corrupted in the flash file: the board powers up on the older one (`load` names record 1);
    both corrupted: the factory defaults (`info`: configuration defaults). In-process boards
    (no plant) and the scripting API: the same protocol as `bowden bench`, quicker to start."""
    from cosim.bench.api import Bench  # noqa: PLC0415
    from cosim.bench.emulate.soc.harness import SocBoard  # noqa: PLC0415

    flash = tmp_path / "flash.bin"

    def power_on():
        board = SocBoard(flash_path=flash, realtime=False).start()
        return board, Bench(board.pty_name)

    board, bench = power_on()
    try:
        for kp, record in ((0.08, 1), (0.09, 2)):
            bench.set(loop_kp=kp)
            assert bench.persist() == record
    finally:
        bench.close()
        board.stop()
    seqs = _slot_seq(flash)
    assert sorted(seqs.values()) == [1, 2], seqs
    newer = max(seqs, key=seqs.get)
    _corrupt(flash, newer)
    board, bench = power_on()
    try:
        assert bench.info().config_source == "flash"
        assert abs(bench.get("loop.kp")["loop.kp"] - 0.08) < 1e-3
        assert bench.client.simple("LOAD") == 1  # `bowden bench load`: "(record 1)"
    finally:
        bench.close()
        board.stop()
    _corrupt(flash, 1 - newer)
    board, bench = power_on()
    try:
        assert bench.info().config_source == "defaults"
        assert abs(bench.get("loop.kp")["loop.kp"] - 0.1) < 1e-3
    finally:
        bench.close()
        board.stop()


@pytest.mark.long
def test_recorded_run_is_read_by_audit(soc_lib, tmp_path):
    """A 12 s recorded run of the simulated board with the nominal plant FMU (the 10 s the audit
    needs, plus its warm-up): `bowden audit` reads it and names nothing (no effect was put into
    the plant; when this was written it said "findings none" with an RMS of 1.6 mN). Some
    minutes of wall time: make test-long."""
    board = Emulated()
    out = tmp_path / "run.csv"
    try:
        summary = ok(
            board.bench("run", "sine", "--seconds", "12", "--out", str(out), "--quiet",
                        timeout_s=900)
        )  # fmt: skip
        assert "12000 samples of 12000, drops 0" in summary, summary
    finally:
        board.ctrl_c()
    r = subprocess.run(
        [*BOWDEN, "audit", str(out), "--quiet"], capture_output=True, text=True, timeout=900
    )
    assert r.returncode == 0, r.stderr
    assert "findings none" in r.stdout, r.stdout


# --- the same bits --------------------------------------------------------------------------------


def _same_t_c(seconds: float) -> None:
    """One bench script (the sine of Fig. 14: 2 to 15 N at 0.5 Hz, the bench's default run) on
    the simulated board (the RV32 firmware binary, plant in the loop) and on the host emulator
    (the host library built from the same sources, stepped in this process): the T_ref and T_c
    words of the telemetry (what each firmware computed and wrote at its tick) are equal at every
    tick. T_in and T_out differ: the board's chain (ADS131M02, PWM, ESCON at the pins) is not the
    host emulator's ideal interface, and no T_c depends on them in this configuration."""
    import numpy as np  # noqa: PLC0415

    from cosim.bench.api import Bench  # noqa: PLC0415
    from cosim.bench.emulate.host_device import ChainConfig  # noqa: PLC0415
    from cosim.bench.emulate.host_device import _open_plant as open_plant  # noqa: PLC0415
    from cosim.bench.emulate.soc.harness import SocBoard  # noqa: PLC0415

    wave = {"mean_n": 8.5, "amplitude_n": 6.5, "freq_hz": 0.5}
    board = SocBoard(realtime=False, plant=open_plant(ChainConfig()), escon_imax_a=4.0).start()
    try:
        with tempfile.TemporaryDirectory() as tmp, Bench(board.pty_name) as bench:
            soc = bench.run("sine", seconds=seconds, out=f"{tmp}/soc.csv", **wave)
    finally:
        board.stop()
    with tempfile.TemporaryDirectory() as tmp, Bench(emulate=True) as bench:
        host = bench.run("sine", seconds=seconds, out=f"{tmp}/host.csv", **wave)
    n = int(round(seconds * 1000))
    assert soc.samples == host.samples == n and soc.drops == host.drops == 0
    for col in ("T_ref_N", "T_c_N"):
        differ = np.nonzero(soc[col] != host[col])[0]
        assert differ.size == 0, f"{col} differs at ticks {differ[:10]}"
    # Both branches of the compensator were taken: T_c above T_ref while it rises, below after
    # the reversal at its peak (t = 0.5 s).
    assert np.any(soc["T_c_N"] > soc["T_ref_N"] + 1.0) and np.any(
        soc["T_c_N"] < soc["T_ref_N"] - 1.0
    )
    # The loop's output follows on the board: T_in tracks T_c in the last 100 ms.
    late = slice(n - 100, n)
    assert np.mean(np.abs(soc["T_in_N"][late] - soc["T_c_N"][late])) < 1.0


def test_t_c_words_equal_the_host_librarys(soc_lib):
    _same_t_c(0.6)


@pytest.mark.long
def test_t_c_words_equal_the_host_librarys_over_two_periods(soc_lib):
    _same_t_c(4.0)


# The tick's budget: the SoC's clock / the tick rate (24000 clocks at 24 MHz and 1 kHz).
TICK_BUDGET_CLKS = soc_build.CLK_HZ // 1000


def test_parameter_sets_before_a_run_leave_the_ticks_on_time(soc_lib, tmp_path):
    """Parameters set and a run started straight after, as `bench run` does (source, wave.*,
    then START): the run ends without OVERRUN, no two ticks are two budgets apart, and no
    request's handling measured on the board (the firmware's receive phase, its reply
    included) takes a whole tick budget. One PARAM_SET used to hold the RV32 for 76 500
    clocks (three periods: OVERRUN). The sets cover a loop gain, the compensator's band (its
    1/band) and mode, and the reference's fields (bench.run's own). The aim of half a
    budget per request is not met yet (hdl/README.md, "The whole board simulated")."""
    from cosim.bench.api import Bench  # noqa: PLC0415
    from cosim.bench.emulate.soc.harness import SocBoard  # noqa: PLC0415

    board = SocBoard(realtime=False).start()
    try:
        with Bench(board.pty_name) as bench:
            board.clear_stats()
            bench.set(**{"loop.kp": 0.08, "comp.band_n": 0.75, "comp.mode": "smooth"})
            run = bench.run("sine", seconds=0.03, out=tmp_path / "run.csv", freq_hz=5.0)
            stats = board.stats()
    finally:
        board.stop()
    assert run.complete and "OVERRUN" not in run.faults, (run.faults, run.drops)
    assert stats.tick_gap_worst_clks < 2 * TICK_BUDGET_CLKS, stats
    assert 0 < stats.rx_worst_clks < TICK_BUDGET_CLKS, stats
