"""Recording a run: telemetry into the trace format (cosim/results/trace.py), flushed every second.

`TraceRecorder` writes the sidecar first, then the CSV header, then whole rows in blocks, one
`write` per block and at least one block a second, each followed by fsync: a run killed at any
moment (Ctrl-C, SIGKILL, a pulled cable) leaves a CSV whose rows are complete up to the last
second, readable by `python -m cosim.results.trace` and the model audit.

Columns: the trace format's (t_s from the sample index, tensions in N, current_A the current
command) and `sample`, `device_time_s`, `faults`, `status`, and over a serial link `mu_phi` (the
friction exponent the compensator applies: the online estimate while it is on) and `est_faults`
(the estimate's fault bits; CAN's two telemetry frames have no room for them). The bench does
not measure the end-effector position or the motor angle: x_m, y_m, z_m hold the position given
with --position (held constant) and motor_angle_rad is 0; the sidecar says so
(`columns_not_measured`, `position_source`).

`record_run` starts a run on a connected BenchClient and records it (sample gaps are drops: they
are counted and reported, never filled in). A run of several channels records each channel to its
own CSV (`channel_path`: NAME.chK.csv), the channel in its sidecar.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from cosim.parts.geometry import in_workspace
from cosim.results import trace as trace_mod

from . import messages as msgs
from .client import (
    BenchClient,
    BenchError,
    BenchUsageError,
    CanLink,
    channel_mask,
    fault_names,
)

Q7_8_LSB_N = 1.0 / 256.0
Q3_12_LSB_A = 1.0 / 4096.0
FLUSH_PERIOD_S = 1.0
EXTRA_COLUMNS = ("sample", "device_time_s", "faults", "status")
ESTIMATE_COLUMNS = ("mu_phi", "est_faults")  # serial telemetry only
MU_PHI_LSB = 1.0 / 16384.0  # TELEMETRY.mu_phi is UQ2.14


class TraceRecorder:
    """Append telemetry rows to a trace CSV; the sidecar is written when the recorder opens."""

    def __init__(
        self,
        csv_path: str | Path,
        meta: dict,
        position_m: tuple[float, float, float],
        estimate: bool = False,
        tick_rate_hz: float | None = None,
    ):
        self.path = Path(csv_path)
        meta = trace_mod.validate_meta(dict(meta), str(trace_mod.meta_path(self.path)))
        self.rate_hz = float(meta["sample_rate_hz"])
        # A sample's number counts the device's ticks: its time is the number over the tick
        # rate, which is the rows' rate (sample_rate_hz) times the telemetry divisor.
        self.tick_rate_hz = self.rate_hz if tick_rate_hz is None else float(tick_rate_hz)
        self.position = tuple(float(v) for v in position_m)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        mpath = trace_mod.meta_path(self.path)
        mpath.write_text(json.dumps(meta, indent=2, sort_keys=True) + "\n")
        self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        self.estimate = estimate
        columns = trace_mod.COLUMNS + EXTRA_COLUMNS + (ESTIMATE_COLUMNS if estimate else ())
        header = ",".join(columns) + "\n"
        os.write(self._fd, header.encode())
        os.fsync(self._fd)
        self._rows: list[str] = []
        self._last_flush = time.monotonic()
        self.rows = 0
        self._time_base = 0
        self._last_time_us: int | None = None

    def add(self, t: dict) -> None:
        """One telemetry sample (the TELEMETRY fields as unpacked)."""
        # Device time: microseconds that wrap at 2^32; unwrapped here.
        tu = t["time_us"]
        if self._last_time_us is not None and tu < self._last_time_us:
            self._time_base += 1 << 32
        self._last_time_us = tu
        x, y, z = self.position
        row = (
            f"{t['sample'] / self.tick_rate_hz:.9g},{t['t_ref'] * Q7_8_LSB_N:.9g},"
            f"{t['t_c'] * Q7_8_LSB_N:.9g},{t['t_in'] * Q7_8_LSB_N:.9g},"
            f"{t['t_out'] * Q7_8_LSB_N:.9g},{x:.9g},{y:.9g},{z:.9g},"
            f"{t['current'] * Q3_12_LSB_A:.9g},0,{t['sample']},"
            f"{(self._time_base + tu) * 1e-6:.9g},{t['faults']},{t['status']}"
        )
        if self.estimate:
            row += f",{t['mu_phi'] * MU_PHI_LSB:.9g},{t['est_faults']}"
        self._rows.append(row + "\n")
        self.rows += 1
        if time.monotonic() - self._last_flush >= FLUSH_PERIOD_S:
            self.flush()

    def flush(self) -> None:
        """Write the pending rows in one write and fsync them."""
        if self._rows:
            os.write(self._fd, "".join(self._rows).encode())
            self._rows.clear()
        os.fsync(self._fd)
        self._last_flush = time.monotonic()

    def close(self) -> None:
        if self._fd is not None:
            self.flush()
            os.close(self._fd)
            self._fd = None


@dataclass
class RunResult:
    """What a recording got: samples, gaps (drops), the device's overflow count, faults seen."""

    samples: int = 0
    expected: int = 0
    drops: int = 0
    gaps: list[tuple[int, int]] = field(default_factory=list)  # (first missing sample, count)
    overflow: int = 0
    faults: int = 0
    link_rejected: int = 0
    wall_s: float = 0.0
    stopped_early: bool = False

    def summary(self) -> str:
        names = ", ".join(fault_names(self.faults)) or "none"
        return (
            f"{self.samples} samples of {self.expected}, drops {self.drops}, device overflow "
            f"{self.overflow}, faults {names}, link errors {self.link_rejected}"
        )


WAVE_KINDS = ("sine", "triangle", "ramp", "step", "constant")


def run_ticks(seconds: float, tick_hz: float) -> int:
    """START's duration for `seconds` at the device's tick rate: at least one tick (a duration
    that rounds to nothing is refused, never sent), at most the largest timed run
    (START_DURATION.CONTINUOUS, one above it, means until STOP)."""
    longest = msgs.START_DURATION["CONTINUOUS"] - 1
    ticks = round(seconds * tick_hz) if math.isfinite(seconds) else longest + 1
    if ticks < 1:
        raise BenchUsageError(
            f"--seconds {seconds:g}: shorter than one tick ({1e3 / tick_hz:g} ms at {tick_hz:g} Hz)"
        )
    if ticks > longest:
        raise BenchUsageError(
            f"--seconds {seconds:g}: longer than the longest timed run ({longest} ticks, "
            f"{longest / tick_hz:.0f} s at {tick_hz:g} Hz)"
        )
    return ticks


def check_geometry(position_m, sheath_length_m: float, plant: dict | None = None) -> None:
    """--position inside the workspace of the sheath (Eq. 13 of the paper: within the sheath's
    length of the outlet, y >= 0) and --sheath-length in the trace format's range, before
    anything is sent or written. `plant`: the emulated plant's overrides (its sheath_length,
    when given, is the one the position must fit)."""
    lo, hi, unit, _ = trace_mod.META_RANGES["sheath_length_m"]
    if not lo <= sheath_length_m <= hi:
        raise BenchUsageError(
            f"--sheath-length {sheath_length_m:g}: outside [{lo:g}, {hi:g}] {unit}"
        )
    length = float((plant or {}).get("sheath_length", sheath_length_m))
    x, y, z = position_m
    if not bool(in_workspace(x, y, z, length)):
        raise BenchUsageError(
            f"--position {x:g},{y:g},{z:g}: outside the workspace of a {length:g} m sheath "
            f"(sqrt(x^2 + y^2 + z^2) <= {length:g} m and y >= 0)"
        )


def channel_path(out_csv: str | Path, channel: int, channels: tuple[int, ...]) -> Path:
    """Where channel `channel`'s rows go when `channels` run: the CSV given for a run of one
    channel, NAME.chK.csv beside it for a run of several."""
    out = Path(out_csv)
    if len(channels) == 1:
        return out
    return out.with_name(f"{out.stem}.ch{channel}{out.suffix}")


def record_run(
    client: BenchClient,
    out_csv: str | Path,
    *,
    seconds: float,
    waveform: str,
    mean_n: float,
    amplitude_n: float,
    freq_hz: float,
    stream_words: list[int] | None = None,
    position_m: tuple[float, float, float] = (0.0, 0.5, 0.0),
    loop_routing: bool = True,
    sheath_length_m: float = 1.0,
    progress: Callable[[str], None] | None = None,
    on_sample: Callable[[int], None] | None = None,
    tap: Callable[[dict], None] | None = None,
    channels: tuple[int, ...] | None = None,
) -> RunResult:
    """Configure the waveform (or the stream) of each channel in `channels`, start a run of
    `seconds` of those channels and record it (one CSV per channel: channel_path).

    waveform: one of WAVE_KINDS, or "stream" with `stream_words` (Q7.8 T_ref words, one per tick,
    the same for every channel). channels: the client's channel when none are given.
    tap: called with every telemetry frame after it is recorded (a live view; must not block).
    """
    channels = (client.channel,) if channels is None else tuple(channels)
    ticks = run_ticks(seconds, float(client.get("tick_rate_hz")))  # before anything is set
    for c in channels:
        if waveform == "stream":
            client.set("source", "host", channel=c)
        else:
            client.set("wave.kind", waveform, channel=c)
            client.set("wave.mean_n", mean_n, channel=c)
            client.set("wave.amplitude_n", amplitude_n, channel=c)
            client.set("wave.freq_hz", freq_hz, channel=c)
            client.set("source", "wave", channel=c)
    tick_hz = float(client.get("tick_rate_hz"))
    div = int(client.get("dev.telemetry_div"))
    rate_hz = tick_hz / div
    recs: dict[int, TraceRecorder] = {}
    for c in channels:
        meta = {
            "sample_rate_hz": rate_hz,
            "sheath_length_m": float(sheath_length_m),
            "loop_routing": bool(loop_routing),
            # The compensator's mu (the full trace format requires a mu): what the controller
            # assumes, not a measurement of the plant, so the audit fits its own (mu_source).
            "mu": float(client.get("comp.mu", channel=c)),
            "mu_source": "compensator",
            "source": "bowden bench",
            "device": client.link.url,
            "waveform": waveform,
            "compensator": client.get("comp.mode", channel=c),
            "phi_rad": float(client.get("comp.phi_rad", channel=c)),
            "position_m": list(position_m),
            "position_source": "--position (held constant; not measured)",
            "columns_not_measured": ["x_m", "y_m", "z_m", "motor_angle_rad"],
        }
        if len(channels) > 1 or c != 0:
            meta["channel"] = c
        if waveform != "stream":
            meta.update({"mean_n": mean_n, "amplitude_n": amplitude_n, "freq_hz": freq_hz})
        # The estimate's columns travel over a serial link only (CAN's telemetry frames are
        # full).
        recs[c] = TraceRecorder(
            channel_path(out_csv, c, channels),
            meta,
            position_m,
            estimate=not isinstance(client.link, CanLink),
            tick_rate_hz=tick_hz,
        )
    # Channel c's frames are the samples with sample % div == c % div (the device spreads the
    # channels' frames over the ticks: firmware/README.md, "Telemetry of several channels").
    first = {c: c % div for c in channels}
    result = RunResult(expected=sum(max(0, (ticks - first[c] + div - 1) // div) for c in channels))
    next_by_channel = dict(first)
    last_report = 0.0
    t0 = time.monotonic()

    def on_telemetry(t: dict) -> None:
        c = t.get("channel", 0)
        if c not in recs:
            return  # a channel this run did not start
        next_sample = next_by_channel[c]
        if t["sample"] > next_sample:  # frames lost on the way: say which
            missing = (t["sample"] - next_sample) // div
            result.drops += missing
            result.gaps.append((next_sample, missing))
        next_by_channel[c] = t["sample"] + div
        result.samples += 1
        result.overflow = t["overflow"]
        result.faults |= t["faults"]
        recs[c].add(t)
        if tap is not None:
            tap(t)
        if on_sample is not None:
            on_sample(result.samples)

    stream = list(stream_words or [])
    # Samples per request: STREAM takes 24 (channel 0), STREAM_CH 23 (its channel byte first).
    per = 24 if channels == (0,) else 23
    sent = 0
    try:
        if waveform == "stream":
            free = 0
            while sent < len(stream):  # prefill: the device holds DEV_STREAM_LEN samples
                chunk = stream[sent : sent + per]
                try:
                    free = min(client.stream(chunk, c) for c in channels)
                except BenchError as exc:
                    if "STREAM_FULL" not in str(exc):
                        raise
                    break
                sent += len(chunk)
                if free < per:
                    break
        client.on_telemetry = on_telemetry
        # Always with the mask: a channel this run does not record never drives its motor.
        client.simple("START", duration_ticks=ticks, channel_mask=channel_mask(channels))
        last_rx = time.monotonic()
        while result.samples < result.expected:
            n_before = result.samples
            # Top the device's buffer up: chunks of `per` while the ACKs say there is room.
            free = per
            while waveform == "stream" and sent < len(stream) and free >= per:
                try:
                    free = min(client.stream(stream[sent : sent + per], c) for c in channels)
                    sent += min(per, len(stream) - sent)
                except BenchError as exc:
                    if "STREAM_FULL" not in str(exc):
                        raise
                    break
            client.keep_alive()  # the device's host watchdog: a silent host stops the run
            client.poll(0.01 if waveform == "stream" else 0.05)  # telemetry: on_telemetry
            now = time.monotonic()
            if result.samples > n_before:
                last_rx = now
            elif now - last_rx > 2.0:
                result.stopped_early = True
                break  # the device stopped sending: report what came
            if min(next_by_channel.values()) >= ticks:
                break
            if progress is not None and now - last_report >= 0.25:
                last_report = now
                el = now - t0
                progress(progress_line(result, min(next_by_channel.values()), tick_hz, seconds, el))
    finally:
        client.on_telemetry = None
        for rec in recs.values():
            rec.close()
        result.wall_s = time.monotonic() - t0
        result.link_rejected = client.link.stats.rejected
    if math.isfinite(result.wall_s) and progress is not None:
        progress("")
    return result


def progress_line(
    result: RunResult, done_ticks: int, tick_hz: float, seconds: float, elapsed_s: float
) -> str:
    """The live line of a run: the run's own time, from the ticks every channel has reached (not
    the samples of all channels together, which counted a run of two channels twice as long),
    the ticks a second of wall time, and the drops, overflow and faults so far."""
    return (
        f"{done_ticks / tick_hz:6.1f}/{seconds:g} s  "
        f"{done_ticks / max(elapsed_s, 1e-9):6.0f} Hz  drops {result.drops}  "
        f"overflow {result.overflow}  faults {','.join(fault_names(result.faults)) or '-'}"
    )


def stderr_progress(line: str) -> None:
    """A live progress line on stderr (carriage return, cleared at the end)."""
    sys.stderr.write("\r" + line.ljust(78) + ("\n" if not line else ""))
    sys.stderr.flush()


def keep_recording(partial: Path, out: Path) -> bool:
    """Move a run's rows (and sidecar) onto `out` when it recorded any; otherwise remove the
    partial files and leave `out` as it was. True when `out` now holds the run."""
    meta = trace_mod.meta_path(partial)
    rows = 0
    if partial.exists():
        with partial.open("rb") as f:
            rows = sum(1 for _ in f) - 1
    if rows <= 0:
        for p in (partial, meta):
            p.unlink(missing_ok=True)
        return False
    if meta.exists():
        meta.replace(trace_mod.meta_path(out))
    partial.replace(out)
    return True
