"""Does the live view cost telemetry? (`make perf-live`, part of `make perf`)

`bowden emulate` in a process of its own (the device, as on a bench: 1 kHz telemetry over its
pty at 921600 baud), and in this one a session that records a run of --seconds while the live
views work as they would for a user: the terminal view drawing every frame (into /dev/null, at
the size of a 120 x 40 terminal) and the page's server answering a poller that fetches
`/data.json` as often as the page does. Prints the samples recorded against those expected,
the drops, the device's overflow count, the frames drawn per second and the draw time.

    python -m cosim.perf.live_view --seconds 60
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from cosim.bench.link.api import Bench
from cosim.bench.live import view as live

# What an open page does, in a process of its own: a request per frame, 80 ms apart at most,
# one character printed per answer.
_POLLER = """
import sys, time, urllib.request
while True:
    t = time.monotonic()
    with urllib.request.urlopen(sys.argv[1], timeout=5) as r:
        r.read()
    print(".", flush=True)
    time.sleep(max(0.0, 0.08 - (time.monotonic() - t)))
"""


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m cosim.perf.live_view")
    p.add_argument("--seconds", type=float, default=60.0)
    p.add_argument(
        "--views",
        choices=("term", "web", "both", "none"),
        default="both",
        help="none: the same run without a view (the machine's own figure, to compare)",
    )
    args = p.parse_args(argv)
    emu = subprocess.Popen(
        [sys.executable, "-m", "cosim.bench", "emulate", "--no-tcp"],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        pty = None
        for line in emu.stdout:
            m = re.search(r"--port (\S+) info", line)
            if m:
                pty = m.group(1)
                break
        if pty is None:
            print("live_view: the emulator did not start", file=sys.stderr)
            return 1
        return _measure(pty, args.seconds, args.views)
    finally:
        emu.terminate()
        emu.wait(timeout=10)


def _measure(pty: str, seconds: float, views: str) -> int:
    buf = live.LiveBuffer(path=live.ring_file())
    kinds = {"term": ["term"], "web": ["web"], "both": ["term", "web"], "none": []}[views]
    procs: dict[str, live.ViewProcess] = {}
    poller = None
    polls = 0
    out = Path(tempfile.mkdtemp(prefix="bowden-live-bench-")) / "run.csv"
    t0 = time.monotonic()
    try:
        with Bench(pty) as b:
            buf.start("sine (benchmark)", 1000.0)
            for kind in kinds:  # as `run --live` starts them (the terminal's into /dev/null)
                procs[kind] = live.ViewProcess(
                    buf, kind, sink=os.devnull if kind == "term" else None, size=(120, 40)
                ).start()
            if "web" in procs:  # an open page is another process: fetch as the page does
                poller = subprocess.Popen(
                    [sys.executable, "-c", _POLLER, procs["web"].url + "data.json?points=1000"],
                    stdout=subprocess.PIPE,
                    text=True,
                )
            run = b.run("sine", seconds, out=out, on_telemetry=buf.add)
    finally:
        wall = time.monotonic() - t0
        if poller is not None:
            poller.terminate()
            polls = len(poller.communicate()[0].split())
        for view in procs.values():
            view.stop("run ended")
        Path(buf.path).unlink(missing_ok=True)
    print(f"live view benchmark: {seconds:g} s run at 1 kHz over the emulator's pty, views {views}")
    print(
        f"  recorded {run.samples} of {run.expected} samples, drops {run.drops}, device overflow "
        f"{run.result.overflow}, link errors {run.result.link_rejected}"
    )
    if "term" in procs:
        term = procs["term"]
        cpu_ms = 1e3 * term.cpu_s / max(term.frames, 1)
        print(
            f"  terminal view (plotext, 120 x 40, in the view process): {term.frames} frames in "
            f"{wall:.1f} s = {term.frames / wall:.1f} fps; per frame "
            f"{1e3 * term.draw_s / max(term.frames, 1):.0f} ms wall, {cpu_ms:.0f} ms CPU "
            f"(a free core: {1e3 / max(cpu_ms, 1e-9):.0f} fps)"
        )
    if "web" in procs:
        print(f"  page data: {polls} answers of /data.json = {polls / wall:.1f} per second")
    print(f"  load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; trace {out}")
    return 0 if run.complete else 1


if __name__ == "__main__":
    sys.exit(main())
