"""A plain progress bar on stderr (no dependency): fraction done, simulated and wall time."""

from __future__ import annotations

import sys
import time
from typing import TextIO


class Progress:
    """Redraws one stderr line at most every `interval_s` of wall time.

    `update(k)` is cheap enough to call every few hundred samples from a simulation loop. On a
    stream that is not a terminal (a log file, a pipe) nothing is redrawn: the bar is written
    once, as its last state, when it closes, so that a log holds one line per run instead of
    every redraw run together.
    """

    def __init__(
        self,
        total: int,
        label: str,
        sample_rate_hz: float,
        stream: TextIO | None = None,
        interval_s: float = 0.5,
        enabled: bool = True,
        width: int = 30,
    ) -> None:
        self.total = max(1, int(total))
        self.label = label
        self.sample_rate_hz = float(sample_rate_hz)
        self.stream = sys.stderr if stream is None else stream
        self.interval_s = interval_s
        self.enabled = enabled
        self.width = width
        self.start = time.perf_counter()
        self._last = -1e9
        isatty = getattr(self.stream, "isatty", None)
        self.live = bool(isatty and isatty())

    def update(self, done: int, force: bool = False) -> None:
        if not self.enabled or not (self.live or force):
            return
        now = time.perf_counter()
        if not force and now - self._last < self.interval_s:
            return
        self._last = now
        frac = min(1.0, max(0.0, done / self.total))
        filled = int(round(frac * self.width))
        wall = now - self.start
        sim = done / self.sample_rate_hz
        speed = sim / wall if wall > 0 else 0.0
        bar = "#" * filled + "-" * (self.width - filled)
        lead = "\r" if self.live else ""  # redrawn over itself on a terminal only
        self.stream.write(
            f"{lead}{self.label:<24} [{bar}] {100 * frac:5.1f} %  {sim:6.2f}/"
            f"{self.total / self.sample_rate_hz:.2f} s sim  {wall:6.1f} s wall  "
            f"x{speed:.2f} real time"
        )
        self.stream.flush()

    def abandon(self) -> None:
        """End the bar's line where it stands (the run was interrupted), so that the next message
        starts on a line of its own."""
        if self.enabled and self._last > -1e9:
            self.stream.write("\n")
            self.stream.flush()

    def close(self, done: int | None = None) -> None:
        if not self.enabled:
            return
        self.update(self.total if done is None else done, force=True)
        self.stream.write("\n")
        self.stream.flush()
