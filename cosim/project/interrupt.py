"""The one exception a signal handler raises to stop a command: SIGINT or SIGTERM arrived.

The `bowden` dispatcher (cosim.cli) and a bench run's handlers (cosim.bench.rig.run.Signals)
raise it; whoever catches it exits with 128 + `signum`.
"""

from __future__ import annotations

import signal


class Interrupted(BaseException):
    """SIGINT or SIGTERM arrived: unwinds the run like KeyboardInterrupt (no `except Exception`
    catches it); `signum` is the signal. Not a KeyboardInterrupt: code that catches one of those
    (Ctrl-C without our handlers) names Interrupted beside it."""

    def __init__(self, signum: int):
        self.signum = signum
        super().__init__(signal.Signals(signum).name)
