"""The live view of a run: `bowden bench run --live` and `bowden bench watch`.

T_ref, T_c, T_in, T_out, the current command and the fault bits over a rolling window, in the
terminal (plotext; works over SSH) or as a page in a local browser (served on 127.0.0.1 only, by
the standard library's http.server, drawn by a small script on a canvas: nothing is fetched
from elsewhere).

The recording comes first. The thread that records hands every telemetry frame to
`LiveBuffer.add`, which writes one row of a preallocated ring and moves a counter: no lock, no
allocation, nothing a drawing can hold up. The views run in their own threads and copy the
window out of the ring (`LiveBuffer.window`); the ring holds twice the longest window, so the
rows being copied are never the ones being written.
"""

from __future__ import annotations

import json
import os
import select
import shutil
import subprocess
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import parse_qs, urlparse

import numpy as np

from .client import fault_names
from .live_page import PAGE

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
NO_RUN_MESSAGE = (
    "No run is active: this page shows a run while `bowden bench run --live web` or "
    "`bowden bench watch --live web` records one."
)


def parse_signals(text: str) -> list[str]:
    """`--signals T_ref,T_out,current`: names checked (ValueError naming the bad one)."""
    names = [s.strip() for s in text.split(",") if s.strip()]
    bad = [n for n in names if n not in SIGNALS]
    if bad or not names:
        raise ValueError(
            f"--signals {text!r}: {'unknown ' + ', '.join(bad) if bad else 'empty'}; "
            f"choose from {','.join(SIGNALS)}"
        )
    return names


class LiveBuffer:
    """The last `capacity_s` seconds of telemetry, written by one thread (the recorder), read by
    any number (the views) without locks (see the module docstring)."""

    def __init__(self, rate_hz: float = 1000.0, capacity_s: float = 2 * WINDOW_RANGE_S[1]):
        self.rate_hz = float(rate_hz)
        self.capacity = int(capacity_s * rate_hz) + 1
        self._ring = np.zeros((self.capacity, len(_FIELDS)), dtype=np.int64)
        self.count = 0  # rows ever written; only add() moves it
        self.active = False
        self.label = ""  # what is running (waveform, file)
        self.message = NO_RUN_MESSAGE  # what a view says when no run is active

    def start(self, label: str, rate_hz: float) -> None:
        """A run begins: `label` says what it is."""
        self.rate_hz = float(rate_hz)
        self.label = label
        self.count = 0
        self.active = True

    def stop(self, message: str) -> None:
        """The run ended; `message` says how (views show it)."""
        self.message = message
        self.active = False

    def add(self, t: dict) -> None:
        """One telemetry frame (the recorder's thread)."""
        row = self._ring[self.count % self.capacity]
        for i, name in enumerate(_FIELDS):
            row[i] = t[name]
        self.count += 1

    def window(self, seconds: float) -> dict[str, np.ndarray]:
        """The last `seconds` of samples: `t_s` (from the sample index) and every signal in SI
        units (faults as the bit mask), oldest first."""
        n = self.count
        want = min(n, int(seconds * self.rate_hz), self.capacity // 2)
        idx = np.arange(n - want, n) % self.capacity
        rows = self._ring[idx]
        out = {"sample": rows[:, 0], "t_s": rows[:, 0] / self.rate_hz}
        for i, (name, (_, scale, _)) in enumerate(SIGNALS.items(), start=1):
            out[name] = rows[:, i] if name == "faults" else rows[:, i] * scale
        return out


def _decimate(n: int, points: int) -> slice:
    return slice(None, None, max(1, -(-n // points)))


def snapshot(buffer: LiveBuffer, signals: list[str], window_s: float, points: int) -> dict:
    """What a view draws: the last `window_s` of `signals` decimated to about `points` samples
    (`t_s`, `series`), the latest sample at full precision (`latest`), the faults now and in the
    window, and the run's state (`active`, `label`, `message`). Plain data (JSON, pickle)."""
    b = buffer
    w = b.window(window_s)
    n = len(w["t_s"])
    doc = {
        "active": b.active,
        "label": b.label,
        "message": "" if b.active else b.message,
        "window_s": window_s,
        "rate_hz": b.rate_hz,
        "signals": list(signals),
        "units": {s: SIGNALS[s][2] for s in signals},
        "samples": n,
    }
    if not n:
        return doc
    cut = _decimate(n, points)
    doc["t_s"] = [round(float(v), 6) for v in w["t_s"][cut]]
    doc["series"] = {s: [round(float(v), 6) for v in w[s][cut]] for s in signals if s != "faults"}
    seen = int(np.bitwise_or.reduce(w["faults"].astype(np.int64)))
    doc["latest"] = {
        "sample": int(w["sample"][-1]),
        "t_s": float(w["t_s"][-1]),
        "values": {s: float(w[s][-1]) for s in SIGNALS if s != "faults"},
        "faults": fault_names(int(w["faults"][-1])),
    }
    doc["faults_in_window"] = fault_names(seen)
    return doc


# --- terminal ------------------------------------------------------------------------------------


def render_text(snap: dict, cols: int, rows: int, fps: float = 0.0) -> str:
    """One frame of the terminal view from a `snapshot`: plotext's canvas (tensions above, the
    current below), then the latest values and the faults."""
    import plotext as plt  # noqa: PLC0415 (only the terminal view needs it)

    signals = snap["signals"]
    tensions = [s for s in signals if snap["units"][s] == "N"]
    panels = [p for p in (tensions, ["current"] if "current" in signals else []) if p]
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
                if snap["samples"]:
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
        if name != "faults":
            parts.append(f"{name} {last['values'][name]:7.3f} {snap['units'][name]}")
    now = ",".join(last["faults"]) or "none"
    seen = ",".join(snap["faults_in_window"]) or "none"
    line2 = f"faults now {now}; in the window {seen}   {fps:4.1f} fps"
    if not snap["active"]:
        line2 += f"   | {snap['message']}"
    return "  ".join(parts) + "\n" + line2


def _terminal_size(out) -> tuple[int, int]:
    """The terminal's size as the terminal says it now (it follows a resize; COLUMNS and LINES
    in the environment may be stale), else shutil's guess."""
    try:
        return tuple(os.get_terminal_size(out.fileno()))
    except (OSError, ValueError, AttributeError):
        return tuple(shutil.get_terminal_size((100, 30)))


def _render_main(ready_fd: int, sink: str, size: tuple[int, int] | None) -> None:
    """The terminal view's drawing, in a process of its own (`python -m cosim.bench.live`: its
    own core and interpreter, plotext being pure Python): says `ready` on `ready_fd`, reads one
    snapshot (a JSON line on stdin), draws it on stdout (or into `sink`), and so on until the
    line `null`; then writes `frames draw_s` on `ready_fd`."""
    out = open(sink, "w") if sink != "-" else sys.stdout  # noqa: SIM115 (closed at the end)
    ready = os.fdopen(ready_fd, "w", buffering=1)
    frames, draw_s, t0 = 0, 0.0, time.monotonic()
    out.write("\x1b[2J\x1b[?25l")  # clear the screen, hide the cursor
    try:
        while True:
            ready.write("ready\n")
            line = sys.stdin.readline()
            snap = json.loads(line) if line else None
            if snap is None:
                break
            t = time.monotonic()
            cols, rows = size or _terminal_size(out)
            # plotext fits a plot to shutil's terminal size, which reads COLUMNS and LINES first.
            os.environ["COLUMNS"], os.environ["LINES"] = str(cols), str(rows)
            fps = frames / max(t - t0, 1e-9)
            out.write("\x1b[H" + render_text(snap, cols, rows, fps) + "\x1b[J")
            out.flush()
            frames += 1
            draw_s += time.monotonic() - t
        out.write("\x1b[?25h\n")  # the cursor back
        out.flush()
        ready.write(f"{frames} {draw_s}\n")
    except (BrokenPipeError, KeyboardInterrupt):
        pass  # the recording goes on without the view


class TermView:
    """The terminal view: a thread here takes a `snapshot` up to `fps` times a second, whenever
    the drawing process says it is ready for one (a slow terminal skips frames, never queues
    them), and that process draws it with plotext on this terminal (or into `sink`, a file)."""

    def __init__(
        self,
        buffer: LiveBuffer,
        signals: list[str] | None = None,
        window_s: float = DEFAULT_WINDOW_S,
        fps: float = DEFAULT_FPS,
        sink: str | None = None,
        size: tuple[int, int] | None = None,
    ) -> None:
        self.buffer = buffer
        self.signals = signals or list(SIGNALS)
        self.window_s = window_s
        self.period_s = 1.0 / fps
        self.sink = sink
        self.size = size
        self.frames = 0  # drawn (known after stop)
        self.draw_s = 0.0  # time the process spent drawing them
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._proc: subprocess.Popen | None = None
        self._ready = None

    def start(self) -> TermView:
        r, w = os.pipe()
        size = [] if self.size is None else [str(self.size[0]), str(self.size[1])]
        self._proc = subprocess.Popen(
            [sys.executable, "-m", "cosim.bench.live", str(w), self.sink or "-", *size],
            stdin=subprocess.PIPE,
            pass_fds=(w,),
            text=True,
        )
        os.close(w)
        self._ready = os.fdopen(r, "r")
        self._thread = threading.Thread(target=self._feed, name="bowden-live-term", daemon=True)
        self._thread.start()
        return self

    def _snapshot(self) -> dict:
        cols = (self.size or _terminal_size(sys.stdout))[0]
        return snapshot(self.buffer, self.signals, self.window_s, points=2 * cols)

    def _wait_ready(self, timeout_s: float) -> str | None:
        if select.select([self._ready], [], [], timeout_s)[0]:
            return self._ready.readline().strip() or None
        return None

    def _send(self, snap: dict | None) -> None:
        self._proc.stdin.write(json.dumps(snap) + "\n")
        self._proc.stdin.flush()

    def _feed(self) -> None:
        next_t = time.monotonic()
        try:
            while not self._stop.is_set():
                if self._wait_ready(0.05) == "ready":
                    self._send(self._snapshot())
                    next_t = max(next_t + self.period_s, time.monotonic() - self.period_s)
                    self._stop.wait(max(0.0, next_t - time.monotonic()))
        except (BrokenPipeError, OSError, ValueError):
            pass  # the drawing process is gone (its terminal closed): the run goes on

    def stop(self) -> None:
        """Draw the last frame (how the run ended), end the process, collect its counts."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        try:
            for snap in (self._snapshot(), None):
                if self._wait_ready(10.0) == "ready":
                    self._send(snap)
            counts = self._wait_ready(10.0)
            if counts:
                frames, draw_s = counts.split()
                self.frames, self.draw_s = int(frames), float(draw_s)
        except (BrokenPipeError, OSError, ValueError):
            pass
        try:
            self._proc.stdin.close()
        except OSError:
            pass
        try:
            self._proc.wait(timeout=5.0)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        self._ready.close()


# --- web page ------------------------------------------------------------------------------------


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
        page = PAGE
        server = self

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:  # noqa: N802 (http.server's name)
                server.requests += 1
                url = urlparse(self.path)
                if url.path == "/":
                    self._send(200, "text/html; charset=utf-8", page.encode())
                elif url.path == "/data.json":
                    q = parse_qs(url.query)
                    try:
                        window = float(q.get("window", [server.window_s])[0])
                        points = int(q.get("points", ["2000"])[0])
                    except ValueError:
                        self._send(400, "text/plain", b"window and points must be numbers\n")
                        return
                    window = min(max(window, WINDOW_RANGE_S[0]), WINDOW_RANGE_S[1])
                    body = json.dumps(server.data(window, max(10, min(points, 20000))))
                    self._send(200, "application/json", body.encode())
                else:
                    self._send(404, "text/plain", b"not found: / and /data.json\n")

            def _send(self, code: int, kind: str, body: bytes) -> None:
                self.send_response(code)
                self.send_header("Content-Type", kind)
                self.send_header("Cache-Control", "no-store")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args) -> None:  # quiet: the terminal belongs to the run
                pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", port), Handler)
        self.httpd.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/"
        self._thread: threading.Thread | None = None

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


if __name__ == "__main__":  # the terminal view's drawing process (TermView.start)
    _size = (int(sys.argv[3]), int(sys.argv[4])) if len(sys.argv) > 4 else None
    _render_main(int(sys.argv[1]), sys.argv[2], _size)
