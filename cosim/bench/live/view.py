"""The live view of a run: `bowden bench run --live` and `bowden bench watch`.

T_ref, T_c, T_in, T_out, the current command and the fault bits over a rolling window, in the
terminal (plotext; works over SSH) or as a page in a local browser (served on 127.0.0.1 only, by
the standard library's http.server, drawn by a small script on a canvas: nothing is fetched
from elsewhere).

The recording comes first. The thread that records hands every telemetry frame to
`LiveBuffer.add`, which writes one row of a preallocated ring (a memory-mapped file) and moves a
counter: no lock, no allocation, nothing a view can hold up. The views run in a process of their
own (`ViewProcess`: `python -m cosim.bench.live`), which maps the same ring and copies its window
out of it (`LiveBuffer.window`), so drawing, JSON and HTTP never take the recording process's
interpreter; the ring holds twice the longest window, so the rows being copied are never the
ones being written.
"""

from __future__ import annotations

import errno
import json
import math
import os
import select
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import parse_qs, urlparse

import numpy as np

from cosim import _signals
from cosim.bench.link.client import fault_names

from .page import PAGE

Q7_8_LSB_N = 1.0 / 256.0
Q3_12_LSB_A = 1.0 / 4096.0

# Signal name -> (telemetry field, scale to SI, unit). The order is the display order.
SIGNALS = {
    "T_ref": ("t_ref", Q7_8_LSB_N, "N"),
    "T_c": ("t_c", Q7_8_LSB_N, "N"),
    "T_in": ("t_in", Q7_8_LSB_N, "N"),
    "T_out": ("t_out", Q7_8_LSB_N, "N"),
    "current": ("current", Q3_12_LSB_A, "A"),
    "faults": ("faults", 1.0, ""),
}
_FIELDS = ("sample",) + tuple(f for f, _, _ in SIGNALS.values())
WINDOW_RANGE_S = (1.0, 60.0)
DEFAULT_WINDOW_S = 8.0
DEFAULT_FPS = 10.0
# The smallest terminal the view draws in (columns, rows): two panels of plotext's least height
# (8 rows, with the status lines under them) and a time axis that can be read. A smaller one
# gets a one-line note instead; one that reports no size (0x0) too.
MIN_TERMINAL = (40, 12)
# How long the recording process waits, once the run has ended, for its view to draw the end
# and exit, before it ends the view itself (a view stopped or hung must not hold the command).
STOP_WAIT_S = 5.0
ORPHAN_MESSAGE = (
    "the recording process is gone (killed?): the view stopped here; the device stops a run "
    "whose host falls silent by itself (its host watchdog)"
)
NO_RUN_MESSAGE = (
    "No run is active: this page shows a run while `bowden bench run --live web` or "
    "`bowden bench watch --live web` records one."
)


def parse_signals(text: str) -> list[str]:
    """`--signals T_ref,T_out,current`: names checked (ValueError naming the bad one)."""
    names = list(dict.fromkeys(s.strip() for s in text.split(",") if s.strip()))  # once each
    bad = [n for n in names if n not in SIGNALS]
    if bad or not names:
        raise ValueError(
            f"--signals {text!r}: {'unknown ' + ', '.join(bad) if bad else 'empty'}; "
            f"choose from {','.join(SIGNALS)}"
        )
    return names


def channel_list(text: str) -> tuple[int, ...]:
    """`--channels 0,1` of the view process: the channels' numbers, each once, in order."""
    chans = tuple(dict.fromkeys(int(c) for c in text.split(",") if c.strip()))
    if not chans or min(chans) < 0:
        raise ValueError(f"--channels {text!r}: expected channel numbers from 0, e.g. 0,1")
    return chans


def series_name(signal: str, channel: int, channels: tuple[int, ...]) -> str:
    """A trace's name: the signal's alone for one channel (as it always was), `T_out[1]` for
    channel 1 of several."""
    return signal if len(channels) == 1 else f"{signal}[{channel}]"


class LiveBuffer:
    """The last `capacity_s` seconds of telemetry, written by one thread (the recorder), read by
    any number of views without locks (see the module docstring). With `path` the ring is a
    memory-mapped file that a view process maps too (`attach`). One ring a channel shown
    (`channels`, the device's channel numbers; frames of another channel are not kept); row 0
    of each holds its row count."""

    def __init__(
        self,
        rate_hz: float = 1000.0,
        capacity_s: float = 2 * WINDOW_RANGE_S[1],
        path: str | None = None,
        attach: bool = False,
        channels: tuple[int, ...] = (0,),
    ):
        self.rate_hz = float(rate_hz)
        self.capacity = int(capacity_s * rate_hz) + 1
        self.channels = tuple(channels)
        self._ring = {c: k for k, c in enumerate(self.channels)}
        shape = (len(self.channels), self.capacity + 1, len(_FIELDS))
        if path is None:
            self._mem = np.zeros(shape, dtype=np.int64)
        else:
            self._mem = np.memmap(path, dtype=np.int64, mode="r" if attach else "w+", shape=shape)
        self.path = path
        self._n = [0] * len(self.channels)  # the writer's own counts
        self.active = False
        self.label = ""  # what is running (waveform, file)
        self.message = NO_RUN_MESSAGE  # what a view says when no run is active

    @property
    def count(self) -> int:
        """Rows ever written to the first channel's ring (only `add` moves it)."""
        return self.count_of(self.channels[0])

    def count_of(self, channel: int) -> int:
        """Rows ever written to `channel`'s ring."""
        return int(self._mem[self._ring[channel], 0, 0])

    def start(self, label: str, rate_hz: float) -> None:
        """A run begins: `label` says what it is."""
        self.rate_hz = float(rate_hz)
        self.label = label
        self._n = [0] * len(self.channels)
        self._mem[:, 0, 0] = 0
        self.active = True

    def stop(self, message: str) -> None:
        """The run ended; `message` says how (views show it)."""
        self.message = message
        self.active = False

    def add(self, t: dict) -> None:
        """One telemetry frame (the recorder's thread): one row of its channel's ring, then the
        count. A frame of a channel not shown is dropped here."""
        k = self._ring.get(t.get("channel", 0))
        if k is None:
            return
        n = self._n[k]
        row = self._mem[k, 1 + n % self.capacity]
        for i, name in enumerate(_FIELDS):
            row[i] = t[name]
        self._n[k] = n + 1
        self._mem[k, 0, 0] = n + 1

    def window(self, seconds: float, channel: int | None = None) -> dict[str, np.ndarray]:
        """The last `seconds` of samples of `channel` (the first shown by default): `t_s` (from
        the sample index) and every signal in SI units (faults as the bit mask), oldest first."""
        k = self._ring[self.channels[0] if channel is None else channel]
        n = int(self._mem[k, 0, 0])
        want = min(n, int(seconds * self.rate_hz), self.capacity // 2)
        idx = 1 + np.arange(n - want, n) % self.capacity
        rows = np.array(self._mem[k, idx])
        out = {"sample": rows[:, 0], "t_s": rows[:, 0] / self.rate_hz}
        for i, (name, (_, scale, _)) in enumerate(SIGNALS.items(), start=1):
            out[name] = rows[:, i] if name == "faults" else rows[:, i] * scale
        return out


def _decimate(n: int, points: int) -> slice:
    return slice(None, None, max(1, -(-n // max(points, 1))))


def snapshot(buffer: LiveBuffer, signals: list[str], window_s: float, points: int) -> dict:
    """What a view draws: the last `window_s` of `signals` decimated to about `points` samples
    (`t_s`, `series`), the latest sample at full precision (`latest`), the faults now and in the
    window, and the run's state (`active`, `label`, `message`). Plain data (JSON, pickle).

    With several channels every signal is a trace a channel (`series_name`: `T_out[1]`), on the
    first channel's time axis: each channel's samples are placed by their sample index
    (interpolated where a frame of one channel was lost and not of another), and a fault is
    named with its channel (`1:STALE_ADC`)."""
    b = buffer
    chans = b.channels
    names = [series_name(s, c, chans) for c in chans for s in signals]
    w = b.window(window_s)
    n = len(w["t_s"])
    doc = {
        "active": b.active,
        "label": b.label,
        "message": "" if b.active else b.message,
        "window_s": window_s,
        "rate_hz": b.rate_hz,
        "channels": list(chans),
        "signals": names,
        "units": {series_name(s, c, chans): SIGNALS[s][2] for c in chans for s in signals},
        "samples": n,
    }
    if not n:
        return doc
    cut = _decimate(n, points)
    doc["t_s"] = np.round(w["t_s"][cut], 6).tolist()
    doc["series"], values, now, seen = {}, {}, [], []
    for c in chans:
        wc = w if c == chans[0] else b.window(window_s, c)
        tag = "" if len(chans) == 1 else f"{c}:"
        if not len(wc["t_s"]):
            continue  # no frame of this channel yet
        for s in signals:
            if s == "faults":
                continue
            on_axis = wc[s][cut] if wc is w else np.interp(w["sample"][cut], wc["sample"], wc[s])
            doc["series"][series_name(s, c, chans)] = np.round(on_axis, 6).tolist()
        for s in SIGNALS:
            if s != "faults":
                values[series_name(s, c, chans)] = float(wc[s][-1])
        now += [tag + f for f in fault_names(int(wc["faults"][-1]))]
        seen += [
            tag + f for f in fault_names(int(np.bitwise_or.reduce(wc["faults"].astype(np.int64))))
        ]
    doc["latest"] = {
        "sample": int(w["sample"][-1]),
        "t_s": float(w["t_s"][-1]),
        "values": values,
        "faults": now,
    }
    doc["faults_in_window"] = seen
    return doc


# --- terminal ------------------------------------------------------------------------------------


def render_text(snap: dict, cols: int, rows: int, fps: float = 0.0) -> str:
    """One frame of the terminal view from a `snapshot`: plotext's canvas (tensions above, the
    current below), then the latest values and the faults."""
    import plotext as plt  # noqa: PLC0415 (only the terminal view needs it)

    signals = snap["signals"]
    tensions = [s for s in signals if snap["units"][s] == "N"]
    currents = [s for s in signals if snap["units"][s] == "A"]
    panels = [p for p in (tensions, currents) if p]
    plt.main()  # back to the whole figure: clear_figure clears only the active subplot
    plt.clear_figure()
    plt.theme("clear")
    canvas = ""
    if panels:
        plt.plot_size(cols, max(rows - 3, 8))
        plt.subplots(len(panels), 1)
        t_end = snap["latest"]["t_s"] if snap["samples"] else 0.0
        for k, names in enumerate(panels, start=1):
            plt.subplot(k, 1)
            for name in names:
                if name in snap.get("series", {}):
                    plt.plot(snap["t_s"], snap["series"][name], label=name, marker="braille")
            plt.xlim(t_end - snap["window_s"], t_end)
            plt.ylabel(snap["units"][names[0]])
            if k == 1:
                what = snap["label"] or "no run"
                plt.title(f"bowden bench live: {what}  (last {snap['window_s']:g} s)")
            if k == len(panels):
                plt.xlabel("t (s)")
        canvas = plt.build() + "\n"
    return canvas + status_text(snap, fps)


def status_text(snap: dict, fps: float = 0.0) -> str:
    """The two lines under the plot: the latest sample's values, the faults, the frame rate."""
    if not snap["samples"]:
        return snap["message"] if not snap["active"] else "waiting for the first sample ..."
    last = snap["latest"]
    parts = [f"t {last['t_s']:8.3f} s", f"sample {last['sample']}"]
    for name in snap["signals"]:
        if not name.startswith("faults") and name in last["values"]:
            parts.append(f"{name} {last['values'][name]:7.3f} {snap['units'][name]}")
    now = ",".join(last["faults"]) or "none"
    seen = ",".join(snap["faults_in_window"]) or "none"
    line2 = f"faults now {now}; in the window {seen}   {fps:4.1f} fps"
    if not snap["active"]:
        line2 += f"   | {snap['message']}"
    return "  ".join(parts) + "\n" + line2


HIDE_CURSOR = "\x1b[?25l"
SHOW_CURSOR = "\x1b[?25h\n"


def too_small_text(cols: int, rows: int) -> str:
    """The one line a terminal too small for the view gets (cut to its width when it has one)."""
    if cols <= 0 or rows <= 0:
        text = (
            f"live view: the terminal reports its size as {cols}x{rows}: nothing drawn (the run "
            "is recorded; `stty cols 100 rows 30` gives it one)"
        )
    else:  # what matters first: a narrow terminal shows only the start of the line
        need = "x".join(str(v) for v in MIN_TERMINAL)
        text = f"{cols}x{rows}: too small for the live view (it needs {need}); nothing drawn"
    return text[:cols] if cols > 0 else text


def _terminal_size(out) -> tuple[int, int]:
    """The terminal's size as the terminal says it now (it follows a resize; COLUMNS and LINES
    in the environment may be stale), else shutil's guess."""
    try:
        return tuple(os.get_terminal_size(out.fileno()))
    except (OSError, ValueError, AttributeError):
        return tuple(shutil.get_terminal_size((100, 30)))


class TermView:
    """The terminal view: a thread that draws a `snapshot` of the ring with plotext up to `fps`
    times a second on `out` (the terminal), at the terminal's size or `size`. Counts the frames
    and the time spent drawing them (wall and CPU)."""

    def __init__(
        self,
        buffer: LiveBuffer,
        signals: list[str] | None = None,
        window_s: float = DEFAULT_WINDOW_S,
        fps: float = DEFAULT_FPS,
        out=None,
        size: tuple[int, int] | None = None,
    ) -> None:
        self.buffer = buffer
        self.signals = signals or list(SIGNALS)
        self.window_s = window_s
        self.period_s = 1.0 / fps
        self.out = out or sys.stdout
        self.size = size
        self.frames = 0
        self.draw_s = 0.0  # wall time spent drawing
        self.cpu_s = 0.0  # CPU time spent drawing (the cost, whatever else the machine runs)
        self.failed = ""  # why drawing stopped, when a frame failed
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._t0 = 0.0

    def start(self) -> TermView:
        self._t0 = time.monotonic()
        self.out.write("\x1b[2J" + HIDE_CURSOR)  # clear the screen, hide the cursor
        self._thread = threading.Thread(target=self._loop, name="bowden-live-term", daemon=True)
        self._thread.start()
        return self

    def draw(self) -> None:
        """One frame."""
        t, c = time.monotonic(), time.thread_time()
        cols, rows = self.size or _terminal_size(self.out)
        if cols < MIN_TERMINAL[0] or rows < MIN_TERMINAL[1]:
            text = too_small_text(cols, rows)
        else:
            # plotext fits a plot to shutil's terminal size, which reads COLUMNS and LINES first.
            os.environ["COLUMNS"], os.environ["LINES"] = str(cols), str(rows)
            snap = snapshot(self.buffer, self.signals, self.window_s, points=2 * cols)
            fps = self.frames / max(t - self._t0, 1e-9)
            # Each line cleared to its end (ESC [K) and the rest of the screen below (ESC [J): a
            # line of an earlier, longer frame must not linger beside or under this one.
            text = render_text(snap, cols, rows, fps).replace("\n", "\x1b[K\n")
        self.out.write("\x1b[H" + text + "\x1b[K\x1b[J")
        self.out.flush()
        self.frames += 1
        self.draw_s += time.monotonic() - t
        self.cpu_s += time.thread_time() - c

    def _draw_or_give_up(self) -> bool:
        """One frame; a frame that fails ends the drawing with one line saying why (the view is
        not worth a traceback in the run's terminal, and the recording does not depend on it)."""
        if self.failed:
            return False
        try:
            self.draw()
            return True
        except Exception as exc:  # noqa: BLE001 (any: the run goes on without its view)
            self.failed = f"{type(exc).__name__}: {exc}"
        try:
            self.out.write(f"\r\x1b[Klive view: stopped drawing ({self.failed})\n")
            self.out.flush()
        except (OSError, ValueError):
            pass  # the terminal is gone
        return False

    def _loop(self) -> None:
        next_t = time.monotonic()
        while not self._stop.is_set() and self._draw_or_give_up():
            next_t = max(next_t + self.period_s, time.monotonic() - self.period_s)
            self._stop.wait(max(0.0, next_t - time.monotonic()))

    def stop(self) -> None:
        """The last frame (how the run ended), then the cursor back."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=10.0)
        self._draw_or_give_up()
        self.show_cursor()

    def show_cursor(self) -> None:
        """The cursor back (start hid it), on a line of its own."""
        try:
            self.out.write(SHOW_CURSOR)
            self.out.flush()
        except (OSError, ValueError):
            pass  # the terminal is gone


# --- web page ------------------------------------------------------------------------------------


POINTS_RANGE = (10, 20_000)  # samples a /data.json answer may ask for


def data_query(query: str, default_window_s: float) -> tuple[float, int]:
    """`/data.json`'s `window` (s) and `points` from a query string: a window outside
    WINDOW_RANGE_S and points outside POINTS_RANGE are brought to the nearest end; ValueError
    (the page's 400, with this reason) for what is not a finite number."""
    q = parse_qs(query, keep_blank_values=True)
    window_text = q.get("window", [None])[0]
    points_text = q.get("points", ["2000"])[0]
    lo, hi = WINDOW_RANGE_S
    try:
        window_s = default_window_s if window_text is None else float(window_text)
    except ValueError:
        window_s = math.nan
    if not math.isfinite(window_s):
        raise ValueError(
            f"window={window_text[:40]}: expected seconds, a finite number ({lo:g}..{hi:g})"
        )
    try:
        points = int(points_text) if len(points_text) <= 12 else None
    except ValueError:
        points = None
    if points is None:
        p_lo, p_hi = POINTS_RANGE
        raise ValueError(f"points={points_text[:40]}: expected a whole number ({p_lo}..{p_hi})")
    return min(max(window_s, lo), hi), min(max(points, POINTS_RANGE[0]), POINTS_RANGE[1])


class _QuietServer(ThreadingHTTPServer):
    """http.server that never prints: the run's terminal is not its log. A request that fails
    (the page went away mid-answer) is dropped; the recording process does not see it."""

    def handle_error(self, request, client_address) -> None:
        pass


class LiveServer:
    """The page and its data on http://127.0.0.1:PORT/ (never another interface): `/` is the
    page, `/data.json?window=S&points=N` the window it draws (JSON; `active` false and
    `message` when no run is active), in a thread of its own."""

    def __init__(
        self,
        buffer: LiveBuffer,
        port: int = 0,
        signals: list[str] | None = None,
        window_s: float = DEFAULT_WINDOW_S,
    ) -> None:
        self.buffer = buffer
        self.signals = signals or list(SIGNALS)
        self.window_s = window_s
        self.requests = 0
        self._cache: tuple = (None, 0.0, b"")
        self._cache_lock = threading.Lock()
        page = PAGE
        server = self

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:  # noqa: N802 (http.server's name)
                try:
                    self._get()
                except Exception as exc:  # noqa: BLE001 (an answer, not a traceback in the run)
                    self._send(500, "text/plain", f"{type(exc).__name__}: {exc}\n".encode())

            def _get(self) -> None:
                server.requests += 1
                url = urlparse(self.path)
                if url.path == "/":
                    self._send(200, "text/html; charset=utf-8", page.encode())
                elif url.path == "/data.json":
                    try:
                        window, points = data_query(url.query, server.window_s)
                    except ValueError as exc:
                        self._send(400, "text/plain; charset=utf-8", f"{exc}\n".encode())
                        return
                    self._send(200, "application/json", server.body(window, points))
                else:
                    self._send(404, "text/plain", b"not found: / and /data.json\n")

            def _send(self, code: int, kind: str, body: bytes) -> None:
                self.send_response(code)
                self.send_header("Content-Type", kind)
                self.send_header("Cache-Control", "no-store")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                try:
                    self.wfile.write(body)
                except (BrokenPipeError, ConnectionResetError):
                    pass  # the page went away (a tab closed): nothing to answer

            def log_message(self, *args) -> None:  # quiet: the terminal belongs to the run
                pass

        self.httpd = _QuietServer(("127.0.0.1", port), Handler)
        self.httpd.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/"
        self._thread: threading.Thread | None = None

    def body(self, window_s: float, points: int) -> bytes:
        """`/data.json`'s bytes; one snapshot serves every request of the next 40 ms (pages open
        in several tabs cost the recording process no more than one)."""
        key, now = (window_s, points), time.monotonic()
        with self._cache_lock:
            if self._cache[0] != key or now - self._cache[1] > 0.04:
                self._cache = (key, now, json.dumps(self.data(window_s, points)).encode())
            return self._cache[2]

    def data(self, window_s: float, points: int) -> dict:
        """What `/data.json` answers: a `snapshot` of the window, about `points` samples."""
        return snapshot(self.buffer, self.signals, window_s, points)

    def start(self) -> LiveServer:
        self._thread = threading.Thread(
            target=self.httpd.serve_forever, name="bowden-live-web", daemon=True
        )
        self._thread.start()
        return self

    def stop(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
        if self._thread is not None:
            self._thread.join(timeout=5.0)


def ring_file() -> str:
    """A new file for a mapped ring, in memory where the system offers it (/dev/shm)."""
    import tempfile  # noqa: PLC0415

    where = "/dev/shm" if os.access("/dev/shm", os.W_OK) else None
    fd, path = tempfile.mkstemp(prefix="bowden-live-", suffix=".ring", dir=where)
    os.close(fd)
    return path


# --- the view process ----------------------------------------------------------------------------


class ViewProcess:
    """A view (`kind` "term" or "web") of `buffer` in a process of its own (see the module
    docstring): `python -m cosim.bench.live` maps the ring, draws or serves it, and follows the
    run's state (label, active, message) that `update` and `stop` send it. For "web", `url` is
    the page's address once `start` returns. `sink`: draw into this file instead of the
    terminal (benchmarks); `size`: the terminal's columns and rows instead of asking it.
    After `stop`, `ended` says what went wrong with the view, if anything (one line)."""

    def __init__(
        self,
        buffer: LiveBuffer,
        kind: str,
        signals: list[str] | None = None,
        window_s: float = DEFAULT_WINDOW_S,
        http_port: int = 0,
        sink: str | None = None,
        size: tuple[int, int] | None = None,
    ) -> None:
        if buffer.path is None:
            raise ValueError("a view process needs a LiveBuffer with a path (a mapped ring)")
        self.buffer = buffer
        self.kind = kind
        self.signals = signals or list(SIGNALS)
        self.window_s = window_s
        self.http_port = http_port
        self.sink = sink
        self.size = size
        self.url = ""
        self.frames = 0
        self.draw_s = self.cpu_s = 0.0
        self.requests = 0
        self.ended = ""
        self._proc: subprocess.Popen | None = None
        self._ready = None

    def start(self) -> ViewProcess:
        r, w = os.pipe()
        b = self.buffer
        argv = [sys.executable, "-m", "cosim.bench.live", "--fd", str(w), "--kind", self.kind]
        argv += ["--ring", b.path, "--rate", repr(b.rate_hz), "--capacity", str(b.capacity)]
        argv += ["--signals", ",".join(self.signals), "--window", repr(self.window_s)]
        argv += ["--http-port", str(self.http_port), "--sink", self.sink or "-"]
        argv += ["--channels", ",".join(str(c) for c in b.channels)]
        if self.size:
            argv += ["--size", f"{self.size[0]}x{self.size[1]}"]
        self._proc = subprocess.Popen(argv, stdin=subprocess.PIPE, pass_fds=(w,), text=True)
        os.close(w)
        self._ready = os.fdopen(r, "r")
        self.update()
        if self.kind == "web":
            line = self._line(30.0)
            if not line.startswith("url "):
                self.stop()
                why = line.removeprefix("error ") or "no answer"
                raise OSError(f"the live page did not start ({why})")
            self.url = line.split()[1]
        return self

    def _line(self, timeout_s: float) -> str:
        """The view's next line on the ready pipe within `timeout_s` ("" when none: the view
        ended, or is stopped, or did not answer in time)."""
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            if select.select([self._ready], [], [], min(left, 0.1))[0]:
                return self._ready.readline().strip()  # (EOF: the view is gone)
            if _stopped(self._proc.pid):
                return ""  # SIGSTOP: it will not answer
        return ""

    def _send(self, doc) -> None:
        try:
            self._proc.stdin.write(json.dumps(doc) + "\n")
            self._proc.stdin.flush()
        except (BrokenPipeError, OSError, ValueError):
            pass  # the view is gone (its terminal closed): the recording goes on

    def update(self) -> None:
        """Send the run's state (label, active, message) to the view."""
        b = self.buffer
        self._send({"label": b.label, "active": b.active, "message": b.message})

    def stop(self, message: str | None = None, wait_s: float = STOP_WAIT_S) -> None:
        """The run ended (`message` says how): the view shows it, ends, and reports its counts.
        A view that has not ended within `wait_s` (stopped by SIGSTOP: at once) is killed;
        `ended` then says so, and the terminal's cursor, which the view hid, is shown again."""
        if message is not None:
            self.buffer.stop(message)
        self.update()
        self._send(None)
        t0 = time.monotonic()
        counts = self._line(wait_s).split()
        if len(counts) == 4:
            self.frames, self.requests = int(counts[0]), int(counts[3])
            self.draw_s, self.cpu_s = float(counts[1]), float(counts[2])
        try:
            self._proc.stdin.close()
        except OSError:
            pass
        stopped = _stopped(self._proc.pid)
        try:
            # It answered: it is ending. It did not: only what is left of the wait.
            left = 2.0 if len(counts) == 4 else wait_s - (time.monotonic() - t0)
            self._proc.wait(timeout=0 if stopped else max(left, 0.1))
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
            how = "was stopped (SIGSTOP)" if stopped else f"did not end within {wait_s:g} s"
            self.ended = f"the view {how}: ended it"
        else:
            rc = self._proc.returncode
            if rc:
                self.ended = f"the view had ended early ({_exit_text(rc)})"
        self._ready.close()
        if self.ended and self.kind == "term":
            self.restore_terminal()

    def restore_terminal(self) -> None:
        """Show the cursor again where the view drew (the view hides it, and shows it when it
        ends; one killed or stopped could not)."""
        try:
            if self.sink:
                with open(self.sink, "a") as out:
                    out.write(SHOW_CURSOR)
            else:
                sys.stdout.write(SHOW_CURSOR)
                sys.stdout.flush()
        except (OSError, ValueError):
            pass  # the terminal is gone


def _exit_text(returncode: int) -> str:
    if returncode >= 0:
        return f"status {returncode}"
    try:
        return f"by {signal.Signals(-returncode).name}"
    except ValueError:
        return f"by signal {-returncode}"


def _bind_error(port: int, exc: OSError) -> str:
    """Why the page's port cannot be had, in a few words."""
    if exc.errno == errno.EADDRINUSE:
        return f"port {port} is in use"
    if exc.errno == errno.EACCES:
        return f"port {port} needs privileges this user has not (ports below 1024)"
    return f"port {port}: {exc.strerror or exc}"


def check_http_port(port: int) -> str | None:
    """Whether the page could be served on 127.0.0.1:`port` now (0: any free one, always):
    None, or why not (`port 8080 is in use`). Checked before a run starts; the view binds it
    again (another program may take it meanwhile: the view then says so, as here)."""
    if port == 0:
        return None
    probe = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        # As http.server binds: SO_REUSEADDR, so that a connection of a page just closed
        # (TIME_WAIT) does not count as the port in use.
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        probe.bind(("127.0.0.1", port))
    except OSError as exc:
        return _bind_error(port, exc)
    finally:
        probe.close()
    return None


class _Terminated(BaseException):
    """SIGTERM in the view process: unwinds to where the cursor is shown again."""


def _terminated(signum, _frame) -> None:
    raise _Terminated


def _stopped(pid: int) -> bool:
    """Process `pid` is stopped (SIGSTOP, SIGTSTP: state T in /proc/PID/stat); False where
    there is no /proc."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] in ("T", "t")
    except (OSError, IndexError):
        return False


def view_main(argv: list[str]) -> int:
    """The view process: map the ring, start the view, follow the state lines on stdin until
    `null`; then write `frames draw_s cpu_s requests` on --fd."""
    import argparse  # noqa: PLC0415

    p = argparse.ArgumentParser(prog="python -m cosim.bench.live")
    for name in ("--fd", "--capacity", "--http-port"):
        p.add_argument(name, type=int, required=True)
    for name in ("--rate", "--window"):
        p.add_argument(name, type=float, required=True)
    for name in ("--kind", "--ring", "--signals", "--sink"):
        p.add_argument(name, required=True)
    p.add_argument("--size", default=None)
    p.add_argument("--channels", type=channel_list, default=(0,))
    a = p.parse_args(argv)
    # Ctrl-C reaches the whole process group: the recording process stops the run and then
    # this view (which shows how the run ended), not the other way round.
    _signals.ignore(signal.SIGINT)
    # SIGTERM ends the view, but with the cursor shown again (it is hidden while it draws).
    _signals.handle(signal.SIGTERM, _terminated)
    try:
        return _view_run(a)
    except _Terminated:
        _signals.default(signal.SIGTERM)
        os.kill(os.getpid(), signal.SIGTERM)  # ended by SIGTERM, as the recording process sees
        return 128 + signal.SIGTERM


def _view_run(a) -> int:
    # The recording comes first: on a busy machine the view draws less often, the recording
    # process (and an emulated device beside it) keeps its share of the CPU.
    os.nice(10)
    buf = LiveBuffer(
        a.rate,
        capacity_s=(a.capacity - 1) / a.rate,
        path=a.ring,
        attach=True,
        channels=a.channels,
    )
    signals = a.signals.split(",")
    ready = os.fdopen(a.fd, "w", buffering=1)
    term = web = None
    out = None
    if a.kind == "web":
        try:
            web = LiveServer(buf, port=a.http_port, signals=signals, window_s=a.window).start()
        except OSError as exc:  # the recording process says it, in one line
            _tell(ready, f"error {_bind_error(a.http_port, exc)}")
            return 1
        _tell(ready, f"url {web.url}")
    else:
        out = open(a.sink, "w") if a.sink != "-" else sys.stdout  # noqa: SIM115 (closed below)
        size = tuple(int(v) for v in a.size.split("x")) if a.size else None
        term = TermView(buf, signals, a.window, out=out, size=size).start()
    orphan = True  # until the recording process says the run has ended
    try:
        for line in sys.stdin:  # the run's state, until `null` (or the recording process is gone)
            try:
                state = json.loads(line)
            except ValueError:
                break  # half a line: its writer died while writing it
            if state is None:
                orphan = False
                break
            buf.label, buf.active, buf.message = state["label"], state["active"], state["message"]
    except _Terminated:
        if term is not None:
            term.show_cursor()
        raise
    if orphan:  # killed outright: nobody else will say so, nor remove the ring
        buf.active, buf.message = False, ORPHAN_MESSAGE
        try:
            os.unlink(a.ring)  # (mapped here and in any other view: they keep their pages)
        except OSError:
            pass
    if term is not None:
        term.stop()
        if out is not sys.stdout:
            out.close()
    if web is not None:
        web.stop()
    frames, draw_s, cpu_s = (term.frames, term.draw_s, term.cpu_s) if term else (0, 0.0, 0.0)
    _tell(ready, f"{frames} {draw_s} {cpu_s} {web.requests if web else 0}")
    return 0


def _tell(ready, line: str) -> None:
    """A line to the recording process, which may be gone (killed outright): then nobody asks."""
    try:
        ready.write(line + "\n")
    except OSError:
        pass
