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

import json
import os
import select
import shutil
import signal
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
    any number of views without locks (see the module docstring). With `path` the ring is a
    memory-mapped file that a view process maps too (`attach`); row 0 holds the row count."""

    def __init__(
        self,
        rate_hz: float = 1000.0,
        capacity_s: float = 2 * WINDOW_RANGE_S[1],
        path: str | None = None,
        attach: bool = False,
    ):
        self.rate_hz = float(rate_hz)
        self.capacity = int(capacity_s * rate_hz) + 1
        shape = (self.capacity + 1, len(_FIELDS))
        if path is None:
            self._mem = np.zeros(shape, dtype=np.int64)
        else:
            self._mem = np.memmap(path, dtype=np.int64, mode="r" if attach else "w+", shape=shape)
        self.path = path
        self._n = 0  # the writer's own count
        self.active = False
        self.label = ""  # what is running (waveform, file)
        self.message = NO_RUN_MESSAGE  # what a view says when no run is active

    @property
    def count(self) -> int:
        """Rows ever written (only `add` moves it)."""
        return int(self._mem[0, 0])

    def start(self, label: str, rate_hz: float) -> None:
        """A run begins: `label` says what it is."""
        self.rate_hz = float(rate_hz)
        self.label = label
        self._n = 0
        self._mem[0, 0] = 0
        self.active = True

    def stop(self, message: str) -> None:
        """The run ended; `message` says how (views show it)."""
        self.message = message
        self.active = False

    def add(self, t: dict) -> None:
        """One telemetry frame (the recorder's thread): one row, then the count."""
        n = self._n
        row = self._mem[1 + n % self.capacity]
        for i, name in enumerate(_FIELDS):
            row[i] = t[name]
        self._n = n + 1
        self._mem[0, 0] = n + 1

    def window(self, seconds: float) -> dict[str, np.ndarray]:
        """The last `seconds` of samples: `t_s` (from the sample index) and every signal in SI
        units (faults as the bit mask), oldest first."""
        n = self.count
        want = min(n, int(seconds * self.rate_hz), self.capacity // 2)
        idx = 1 + np.arange(n - want, n) % self.capacity
        rows = np.array(self._mem[idx])
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
    doc["t_s"] = np.round(w["t_s"][cut], 6).tolist()
    doc["series"] = {s: np.round(w[s][cut], 6).tolist() for s in signals if s != "faults"}
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
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._t0 = 0.0

    def start(self) -> TermView:
        self._t0 = time.monotonic()
        self.out.write("\x1b[2J\x1b[?25l")  # clear the screen, hide the cursor
        self._thread = threading.Thread(target=self._loop, name="bowden-live-term", daemon=True)
        self._thread.start()
        return self

    def draw(self) -> None:
        """One frame."""
        t, c = time.monotonic(), time.thread_time()
        cols, rows = self.size or _terminal_size(self.out)
        # plotext fits a plot to shutil's terminal size, which reads COLUMNS and LINES first.
        os.environ["COLUMNS"], os.environ["LINES"] = str(cols), str(rows)
        snap = snapshot(self.buffer, self.signals, self.window_s, points=2 * cols)
        fps = self.frames / max(t - self._t0, 1e-9)
        # Each line cleared to its end (ESC [K) and the rest of the screen below (ESC [J): a line
        # of an earlier, longer frame must not linger beside or under this one.
        text = render_text(snap, cols, rows, fps).replace("\n", "\x1b[K\n")
        self.out.write("\x1b[H" + text + "\x1b[K\x1b[J")
        self.out.flush()
        self.frames += 1
        self.draw_s += time.monotonic() - t
        self.cpu_s += time.thread_time() - c

    def _loop(self) -> None:
        next_t = time.monotonic()
        while not self._stop.is_set():
            self.draw()
            next_t = max(next_t + self.period_s, time.monotonic() - self.period_s)
            self._stop.wait(max(0.0, next_t - time.monotonic()))

    def stop(self) -> None:
        """The last frame (how the run ended), then the cursor back."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=10.0)
        self.draw()
        self.out.write("\x1b[?25h\n")
        self.out.flush()


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
        self._cache: tuple = (None, 0.0, b"")
        self._cache_lock = threading.Lock()
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
                    body = server.body(window, max(10, min(points, 20000)))
                    self._send(200, "application/json", body)
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

        self.httpd = ThreadingHTTPServer(("127.0.0.1", port), Handler)
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
    terminal (benchmarks); `size`: the terminal's columns and rows instead of asking it."""

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
        self._proc: subprocess.Popen | None = None
        self._ready = None

    def start(self) -> ViewProcess:
        r, w = os.pipe()
        b = self.buffer
        argv = [sys.executable, "-m", "cosim.bench.live", "--fd", str(w), "--kind", self.kind]
        argv += ["--ring", b.path, "--rate", repr(b.rate_hz), "--capacity", str(b.capacity)]
        argv += ["--signals", ",".join(self.signals), "--window", repr(self.window_s)]
        argv += ["--http-port", str(self.http_port), "--sink", self.sink or "-"]
        if self.size:
            argv += ["--size", f"{self.size[0]}x{self.size[1]}"]
        self._proc = subprocess.Popen(argv, stdin=subprocess.PIPE, pass_fds=(w,), text=True)
        os.close(w)
        self._ready = os.fdopen(r, "r")
        self.update()
        if self.kind == "web":
            line = self._line(30.0)
            if not line.startswith("url "):
                self.stop("")
                raise OSError(f"the live page did not start ({line or 'no answer'})")
            self.url = line.split()[1]
        return self

    def _line(self, timeout_s: float) -> str:
        if select.select([self._ready], [], [], timeout_s)[0]:
            return self._ready.readline().strip()
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

    def stop(self, message: str | None = None) -> None:
        """The run ended (`message` says how): the view shows it, ends, and reports its counts."""
        if message is not None:
            self.buffer.stop(message)
        self.update()
        self._send(None)
        counts = self._line(20.0).split()
        if len(counts) == 4:
            self.frames, self.requests = int(counts[0]), int(counts[3])
            self.draw_s, self.cpu_s = float(counts[1]), float(counts[2])
        try:
            self._proc.stdin.close()
        except OSError:
            pass
        try:
            self._proc.wait(timeout=10.0)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        self._ready.close()


def _view_main(argv: list[str]) -> int:
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
    a = p.parse_args(argv)
    # Ctrl-C reaches the whole process group: the recording process stops the run and then
    # this view (which shows how the run ended), not the other way round.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # The recording comes first: on a busy machine the view draws less often, the recording
    # process (and an emulated device beside it) keeps its share of the CPU.
    os.nice(10)
    buf = LiveBuffer(a.rate, capacity_s=(a.capacity - 1) / a.rate, path=a.ring, attach=True)
    signals = a.signals.split(",")
    ready = os.fdopen(a.fd, "w", buffering=1)
    term = web = None
    out = None
    if a.kind == "web":
        web = LiveServer(buf, port=a.http_port, signals=signals, window_s=a.window).start()
        ready.write(f"url {web.url}\n")
    else:
        out = open(a.sink, "w") if a.sink != "-" else sys.stdout  # noqa: SIM115 (closed below)
        size = tuple(int(v) for v in a.size.split("x")) if a.size else None
        term = TermView(buf, signals, a.window, out=out, size=size).start()
    for line in sys.stdin:  # the run's state, until `null` (or the recording process is gone)
        state = json.loads(line)
        if state is None:
            break
        buf.label, buf.active, buf.message = state["label"], state["active"], state["message"]
    if term is not None:
        term.stop()
        if out is not sys.stdout:
            out.close()
    if web is not None:
        web.stop()
    frames, draw_s, cpu_s = (term.frames, term.draw_s, term.cpu_s) if term else (0, 0.0, 0.0)
    ready.write(f"{frames} {draw_s} {cpu_s} {web.requests if web else 0}\n")
    return 0


if __name__ == "__main__":
    sys.exit(_view_main(sys.argv[1:]))
