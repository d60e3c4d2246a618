"""Figures of the bench protocol (`make perf-proto`, part of `make perf`):

- the Cortex-M4 code size of the protocol and device code (build/bench/cortex-m4/size.txt);
- instructions per frame on the host under callgrind (firmware/perf/perf_proto.c): decoding a
  telemetry frame byte by byte, and packing + encoding one;
- the host decoders' frames per second (Python: cosim.bench.link.protocol.FrameDecoder; C: the
  firmware's proto_rx_byte, natively);
- 60 s of 1 kHz telemetry over the emulator's pseudo-terminal (`python -m cosim.bench emulate`
  in its own process, recorded by this one): samples, drops, the device's overflow count, and
  the gaps between frame arrivals (p50, p99, max). Target: zero drops.

    python -m cosim.perf.rig [--cg PERF_PROTO] [--size SIZE_TXT] [--seconds 60]
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from cosim.bench.link import messages as msgs
from cosim.bench.link.protocol import Frame, FrameDecoder, encode_frame, pack


def callgrind_per_frame(exe: Path, mode: str, frames: int = 20000) -> float | None:
    """Instructions inside perf_run per frame, or None without valgrind."""
    if shutil.which("valgrind") is None:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "cg.out"
        subprocess.run(
            ["valgrind", "--tool=callgrind", "--toggle-collect=perf_run",
             f"--callgrind-out-file={out}", str(exe), mode, str(frames)],
            check=True, capture_output=True, text=True,
        )  # fmt: skip
        m = re.search(r"^(?:summary|totals):\s+(\d+)", out.read_text(), re.MULTILINE)
    return int(m.group(1)) / frames if m else None


def telemetry_wire(n: int) -> bytes:
    parts = []
    for i in range(n):
        payload = pack(
            "TELEMETRY", time_us=i * 1000, sample=i, overflow=0, t_ref=i % 3000,
            t_c=-(i % 2000), t_in=i % 999, t_out=i % 777, current=i % 4000, faults=0, status=33,
        )  # fmt: skip
        parts.append(encode_frame(Frame(msgs.MESSAGES["TELEMETRY"].id, 0, payload)))
    return b"".join(parts)


def python_decoder_fps(n: int = 100_000) -> float:
    wire = telemetry_wire(1000) * (n // 1000)
    dec = FrameDecoder()
    t0 = time.perf_counter()
    got = 0
    for i in range(0, len(wire), 4096):  # as a link delivers it: 4 kB reads
        got += len(dec.feed(wire[i : i + 4096]))
    dt = time.perf_counter() - t0
    assert got == n and dec.stats.rejected == 0
    return n / dt


def c_decoder_fps(exe: Path, n: int = 2_000_000) -> float:
    t0 = time.perf_counter()
    subprocess.run([str(exe), "decode", str(n)], check=True, capture_output=True)
    return n / (time.perf_counter() - t0)


def pty_run(seconds: float) -> dict:
    """Record `seconds` of telemetry from an emulator in another process, over its pty."""
    from cosim.bench.link.client import BenchClient, SerialLink  # noqa: PLC0415
    from cosim.bench.link.recorder import record_run  # noqa: PLC0415

    emu = subprocess.Popen(
        [sys.executable, "-m", "cosim.bench", "emulate", "--no-tcp", "--seconds",
         str(seconds + 60)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        url = None
        deadline = time.monotonic() + 120
        while url is None and time.monotonic() < deadline:
            line = emu.stdout.readline()
            if not line:
                break
            m = re.search(r"--port (/dev/\S+)", line)
            url = m.group(1) if m else None
        if url is None:
            raise RuntimeError("the emulator did not start: " + emu.stderr.read()[-500:])
        link = SerialLink(url)
        client = BenchClient(link)
        client.connect()
        arrivals: list[float] = []
        with tempfile.TemporaryDirectory() as tmp:
            res = record_run(
                client, Path(tmp) / "bench.csv", seconds=seconds, waveform="sine",
                mean_n=8.5, amplitude_n=6.5, freq_hz=0.5,
                on_sample=lambda n: arrivals.append(time.perf_counter()),
            )  # fmt: skip
        faults = client.faults()
        link.close()
    finally:
        emu.terminate()
        try:
            out, _ = emu.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            emu.kill()
            out = ""
    gaps_ms = np.diff(np.asarray(arrivals)) * 1e3
    lag = re.search(r"lag behind real time at most ([\d.]+) ms, (\d+) overrun", out or "")
    return {
        "samples": res.samples, "expected": res.expected, "drops": res.drops,
        "overflow": res.overflow, "link_rejected": res.link_rejected,
        "gap_p50_ms": float(np.percentile(gaps_ms, 50)),
        "gap_p99_ms": float(np.percentile(gaps_ms, 99)),
        "gap_max_ms": float(gaps_ms.max()), "device_faults": faults["device_faults"],
        "emulator_lag_ms": float(lag.group(1)) if lag else None,
        "overruns": int(lag.group(2)) if lag else None,
    }  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cg", type=Path, default=None, help="build/bench/host/perf_proto")
    ap.add_argument("--size", type=Path, default=None, help="build/bench/cortex-m4/size.txt")
    ap.add_argument("--seconds", type=float, default=60.0)
    args = ap.parse_args(argv)
    load = Path("/proc/loadavg").read_text().split()[0] if Path("/proc/loadavg").exists() else "?"
    print(f"bench protocol figures (load average {load} on this machine)")
    if args.size is not None and args.size.exists():
        text = args.size.read_text()
        total = re.search(r"^total\s+(\d+)\s+(\d+)\s+(\d+)\s+(\d+)", text, re.MULTILINE)
        ram = re.search(r"dev_t\s+(\d+)", text)
        if total:
            print(
                f"  Cortex-M4 protocol + device code: {total.group(1)} bytes of code, "
                f"{total.group(2)} read-only; dev_t {ram.group(1) if ram else '?'} bytes of RAM"
            )
    if args.cg is not None:
        for mode in ("decode", "encode"):
            per = callgrind_per_frame(args.cg, mode)
            if per is None:
                print("  callgrind: valgrind not found: instructions per frame NOT measured")
                break
            print(f"  {mode} one telemetry frame (x86-64, callgrind): {per:.0f} instructions")
        print(f"  C decoder (proto_rx_byte, native): {c_decoder_fps(args.cg) / 1e6:.2f} M frames/s")
    print(f"  Python decoder (FrameDecoder, 4 kB reads): {python_decoder_fps():,.0f} frames/s")
    r = pty_run(args.seconds)
    verdict = "met" if r["drops"] == 0 and r["samples"] == r["expected"] else "MISSED"
    print(
        f"  telemetry over the emulator's pty, {args.seconds:g} s at 1 kHz: {r['samples']} of "
        f"{r['expected']} samples, drops {r['drops']}, device overflow {r['overflow']}, link "
        f"errors {r['link_rejected']}; arrival gaps p50 {r['gap_p50_ms']:.2f} ms, p99 "
        f"{r['gap_p99_ms']:.2f} ms, max {r['gap_max_ms']:.1f} ms; emulator lag at most "
        f"{r['emulator_lag_ms']} ms, {r['overruns']} overrun(s) (target zero drops: {verdict})"
    )
    return 0 if verdict == "met" else 1


if __name__ == "__main__":
    sys.exit(main())
