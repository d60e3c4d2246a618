"""The full-system co-simulation behind `bowden emulate --target soc`: bowden_soc executing the
RV32 firmware in Verilator (cosim/bench/soc), reached by `bowden bench`, unchanged, over a pty.

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
import time

import pytest

from cosim.bench.soc import build as soc_build

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
        assert ok(board.bench("info")).count("running") == 0
    finally:
        code, _, err = board.ctrl_c()
    assert code == 130, err


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


def test_host_only_options_are_refused(soc_lib):
    r = subprocess.run(
        [*BOWDEN, "emulate", "--target", "soc", "--can", "virtual:x"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert r.returncode == 2 and "--can" in r.stderr and r.stderr.count("\n") == 1, r


def test_adc_crc_is_the_data_sheets(soc_lib):
    """harness.cpp's frame CRC (soc_adc_crc) is CRC-16/CCITT-FALSE as TI SBAS853A 8.5.1.11
    defines it: the catalogued check value 0x29B1 of "123456789", and the value tests/hdl's model
    (which the RTL reader is tested against) gives for a frame of STATUS, CH0, CH1."""
    from hdl_sim import crc16_ccitt, word_bits  # noqa: PLC0415

    from cosim.bench.soc.harness import adc_crc  # noqa: PLC0415

    bits = [(byte >> (7 - i)) & 1 for byte in b"123456789" for i in range(8)]
    assert adc_crc(bits) == 0x29B1
    frame = word_bits(0x050300) + word_bits(0x123456) + word_bits(-5)
    assert adc_crc(frame) == crc16_ccitt(frame)
