"""A recorded run at the rig (`bowden bench run` and `watch`) and the way every run ends: STOP,
then the device's own word that it stopped and that the FPGA's drive output is off
(stop_and_confirm, which `calibrate` calls after each of its runs too). SIGINT and SIGTERM
during a bench command raise Interrupted once (Signals); the command line parses the options and
calls cmd_run.
"""

from __future__ import annotations

import contextlib
import csv
import math
import os
import sys
import time
from pathlib import Path

from cosim import _signals
from cosim.bench.link import messages as msgs
from cosim.bench.link.client import BenchClient, BenchError, BenchUsageError
from cosim.bench.link.protocol import ProtocolError
from cosim.bench.link.recorder import (
    RunResult,
    channel_path,
    keep_recording,
    record_run,
    run_ticks,
    stderr_progress,
)
from cosim.bench.live import view as live
from cosim.parts import regmap
from cosim.project.interrupt import Interrupted

# The FPGA's drive enable in the STATUS register (FAULTS.fpga_status).
STATUS_OUT_EN = 1 << next(f.lsb for f in regmap.REGISTERS["STATUS"].fields if f.name == "OUT_EN")


class Signals:
    """SIGINT and SIGTERM raise Interrupted in the main thread, once: a later signal is noted,
    not raised, so that it cannot cut short the STOP that follows. Inside `hold()` (stopping the
    device) a signal is noted and raised when the hold ends."""

    def __init__(self) -> None:
        self.signum: int | None = None
        self._raised = False
        self._holding = False
        self._previous: dict = {}

    def __enter__(self) -> Signals:
        self._previous = _signals.install(self._handler)
        return self

    def __exit__(self, *exc) -> None:
        _signals.restore(self._previous)

    def _handler(self, signum, _frame) -> None:
        if self.signum is None:
            self.signum = signum
        if not self._raised and not self._holding:
            self._raised = True
            raise Interrupted(signum)

    @contextlib.contextmanager
    def hold(self):
        self._holding = True
        try:
            yield
        finally:
            self._holding = False
        if self.signum is not None and not self._raised:
            self._raised = True
            raise Interrupted(self.signum)


def stop_and_confirm(client: BenchClient, tries: int = 3, settle_s: float = 0.5) -> str | None:
    """Send STOP, then ask the device: None when HELLO says no run is active and the FPGA's
    STATUS shows the drive output disabled; otherwise why that could not be confirmed. The FPGA
    takes STOP's CTRL write at its next sample: STATUS is read again for up to `settle_s`."""
    client.on_telemetry = None
    why = "no answer"
    for _ in range(tries):
        try:
            client.request("STOP")
            deadline = time.monotonic() + settle_s
            while True:
                running = client.hello().running
                out_en = client.faults()["fpga_status"] & STATUS_OUT_EN
                if (not running and not out_en) or time.monotonic() >= deadline:
                    break
                client.poll(0.02)  # (the stepped emulator advances its loop here)
        except (BenchError, ProtocolError, OSError) as exc:
            why = str(exc)
            continue
        if not running and not out_en:
            return None
        why = "a run is still active" if running else "the FPGA's output is still enabled"
    return why


def _read_ref(path: str) -> list[int]:
    """The T_ref words of a stream's reference file. A file that cannot be used is a usage error
    (exit 2), as every other file the command line names."""
    p = Path(path)
    if p.exists() and not p.is_dir() and not p.is_file():  # a FIFO would block the read
        raise BenchUsageError(f"--ref {p}: not a regular file")
    try:
        text = p.read_text()
    except FileNotFoundError:
        raise BenchUsageError(f"--ref {p}: no such file") from None
    except IsADirectoryError:
        raise BenchUsageError(f"--ref {p}: is a folder; give a CSV file") from None
    except UnicodeDecodeError:
        raise BenchUsageError(f"--ref {p}: not a text CSV") from None
    except OSError as exc:
        raise BenchUsageError(f"--ref {p}: cannot read it ({exc.strerror or exc})") from None
    rows = list(csv.reader(text.splitlines()))
    if not rows:
        raise BenchUsageError(f"--ref {p}: empty")
    header = [h.strip() for h in rows[0]]
    col = header.index("T_ref_N") if "T_ref_N" in header else 0
    start = 1 if not _is_number(rows[0][col] if col < len(rows[0]) else "") else 0
    words = []
    for i, row in enumerate(rows[start:], start=start + 1):
        if not row:
            continue
        cell = row[col] if col < len(row) else ""
        if not _is_number(cell):
            raise BenchUsageError(f"--ref {p}:{i}: T_ref {cell!r} is not a finite number")
        v = float(cell)
        if not -128.0 <= v <= 127.99:
            raise BenchUsageError(f"--ref {p}:{i}: T_ref {v:g} N outside [-128, 127.99] N")
        words.append(round(v * 256.0))
    if not words:
        raise BenchUsageError(f"--ref {p}: no samples")
    return words


def _is_number(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def cmd_run(client: BenchClient, args, info) -> int:
    """`bowden bench run` (and `watch`): the waveform of `args` recorded to `args.out` with the view
    `args.live` asks for; every way out passes through stop_and_confirm, and `args.stop_report`
    says what the device answered. `args.signals`: the run's Signals."""
    words = None
    if args.waveform == "stream":
        if not args.ref:
            raise BenchUsageError("run stream needs --ref FILE.csv (T_ref_N, one row per tick)")
        words = _read_ref(args.ref)
    elif args.ref:
        raise BenchUsageError("--ref is for `run stream` only")
    out = _run_target(args.out)
    if client.stale_telemetry:
        print(
            f"note: the device was streaming when we connected: stopped it "
            f"({client.stale_telemetry} stale frames skipped)",
            file=sys.stderr,
        )
    # The run's rows go to NAME.partial.csv, moved onto --out when the run ends (a failed run
    # never wipes an earlier recording; a run killed with SIGKILL leaves the partial file).
    partial = out.with_name(f"{out.stem}.partial{out.suffix}")
    # The channels --channel names (one CSV each when several: NAME.chK.csv).
    channels = tuple(getattr(args, "channel_list", None) or (client.channel,))
    outs = [channel_path(out, c, channels) for c in channels]
    watchdog_stops = _host_timeouts(client)  # to say, if the run ends early, whether it was that
    result = None
    try:
        result = record_with_view(
            client,
            args,
            partial,
            f"{args.waveform} -> {out}",
            seconds=args.seconds,
            waveform=args.waveform,
            mean_n=args.mean,
            amplitude_n=args.amplitude,
            freq_hz=args.freq,
            stream_words=words,
            position_m=args.position,
            loop_routing=args.loop_routing,
            sheath_length_m=args.sheath_length,
            progress=None if args.quiet else stderr_progress,
            channels=channels,
        )
    finally:
        # Every way out of a run (the end, a signal, a link error, an exception, a full disk)
        # passes here: STOP, then the device's own word that it stopped and the output is off.
        with args.signals.hold():
            why_not = stop_and_confirm(client)
            args.stop_report = (
                "device stopped, output disabled (confirmed by the device)"
                if why_not is None
                else f"the device did NOT confirm that it stopped ({why_not}): it ends the run "
                "by itself after --seconds; switch the drive off"
            )
            kept = [
                keep_recording(channel_path(partial, c, channels), o)
                for c, o in zip(channels, outs, strict=True)
            ]
            if result is None and any(kept):
                held = ", ".join(str(o) for o, k in zip(outs, kept, strict=True) if k)
                args.stop_report = f"{held} hold the samples up to now; {args.stop_report}"
    named = ", ".join(str(o) for o in outs)
    if why_not is not None:
        raise BenchError(f"{named}: {result.summary()}")
    print(f"{named}: {result.summary()} ({result.wall_s:.1f} s)")
    for first, count in result.gaps[:5]:
        print(f"  gap: {count} sample(s) missing from sample {first}")
    if result.drops or result.stopped_early:
        print(
            f"bowden bench: the recording is incomplete ({result.drops} dropped, device stopped "
            f"early: {result.stopped_early}); python -m cosim.results.trace will name the first "
            "gap",
            file=sys.stderr,
        )
        if result.stopped_early:
            print(f"bowden bench: {_early_stop_cause(client, watchdog_stops)}", file=sys.stderr)
        return 1
    return 0


def _host_timeouts(client: BenchClient) -> int | None:
    """The device's count of runs its host watchdog stopped (STATS.host_timeouts), or None
    when it does not answer."""
    try:
        return int(client.stats()["host_timeouts"])
    except (BenchError, ProtocolError, OSError, KeyError):
        return None


def _early_stop_cause(client: BenchClient, watchdog_stops: int | None) -> str:
    """Why the device stopped sending before the run's end, as far as it says: its host watchdog
    (the count went up during the run), or not that."""
    after = _host_timeouts(client) if watchdog_stops is not None else None
    if after is None:
        return (
            "the device stopped sending telemetry before the run's end (its counters did not "
            "answer)"
        )
    if after > watchdog_stops:
        timeout_ms = msgs.HOST_WATCHDOG["TIMEOUT_MS"]
        return (
            f"the device's host watchdog stopped the run: it received nothing from this host for "
            f"{timeout_ms} ms (a host too loaded to keep its link alive, or one suspended); the "
            "output was disabled"
        )
    return "the device stopped sending telemetry before the run's end (not its host watchdog)"


def _run_target(text: str) -> Path:
    """--out checked before anything is sent or written: a CSV file name, not a folder."""
    out = Path(text)
    if out.is_dir() or text.endswith(os.sep):
        raise BenchUsageError(f"--out {text}: is a folder; give a CSV file name (e.g. run.csv)")
    if out.exists() and not out.is_file():
        raise BenchUsageError(f"--out {text}: not a regular file")
    return out


# --- live view -----------------------------------------------------------------------------------


def open_view(
    args, label: str, rate_hz: float, channels: tuple[int, ...] = (0,)
) -> live.ViewProcess:
    """Start the view `args.live` asks for in its own process (a page's address on stderr),
    with a trace a channel of `channels`."""
    buffer = live.LiveBuffer(rate_hz, path=live.ring_file(), channels=channels)
    buffer.start(label, rate_hz)
    try:
        view = live.ViewProcess(
            buffer, args.live, args.signal_list, args.window, http_port=args.http_port
        ).start()
    except BaseException:
        Path(buffer.path).unlink(missing_ok=True)
        raise
    if view.url:
        print(f"live view: {view.url} (this machine only)", file=sys.stderr, flush=True)
    return view


def record_with_view(client, args, out, label: str, **kw) -> RunResult:
    """record_run into `out`, with the live view `args.live` asks for when it asks for one (the
    progress line gives way to a terminal view)."""
    if not getattr(args, "live", None):
        return record_run(client, out, **kw)
    tick_hz = float(client.get("tick_rate_hz"))
    run_ticks(kw["seconds"], tick_hz)  # a duration refused before the view clears the screen
    rate_hz = tick_hz / int(client.get("dev.telemetry_div"))
    # A trace a channel the run records (the ring drops frames of any other).
    view = open_view(args, label, rate_hz, tuple(kw.get("channels") or (client.channel,)))
    if view.kind == "term":
        kw["progress"] = None
    result = None
    try:
        result = record_run(client, out, tap=view.buffer.add, **kw)
    finally:
        try:
            if result is None:  # interrupted or failed: the device before the view
                _stop_at_once(client, args)
        finally:
            view.stop(f"run ended: {result.summary()}" if result else "run interrupted")
            Path(view.buffer.path).unlink(missing_ok=True)
            if view.ended:  # killed, stopped or hung: the recording is whole all the same
                print(f"live view: {view.ended}", file=sys.stderr, flush=True)
    return result


def _stop_at_once(client, args) -> None:
    """STOP, before the view is given its seconds to show how the run ended (the motor is
    not kept driven while a view draws); the run's own exit path then stops the device again
    and asks it to confirm, and says when it could not."""
    client.on_telemetry = None
    with args.signals.hold():  # a second Ctrl-C does not cut the STOP short
        try:
            client.request("STOP")
        except (BenchError, ProtocolError, OSError):
            pass  # said by the confirmation that follows
