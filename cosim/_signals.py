"""The one place that installs signal handlers (tests/test_layers.py fails on a `signal.signal`
call anywhere else), so that who handles SIGINT and SIGTERM, and when, is read here.

It sits at the bottom of the package, beside cosim._early, and imports nothing but the standard
library: the package's own __init__ (a Dask worker of `bowden` ignores SIGINT) and the early
Ctrl-C handler use it before anything else is imported. The policies its callers apply:

- `ignore`: SIGINT ignored by a process its parent stops (a sweep's Dask worker, the live view),
  and both stop signals ignored while the dispatcher's command is being stopped (cosim.cli);
- `swap`: the early Ctrl-C handler put in place, and handed back, only over the one it expects
  (cosim._early);
- `install` and `restore`: a handler for SIGINT and SIGTERM while something runs, put back as it
  was after (the dispatcher's Interrupted, a bench run's Signals, the emulator's StopSignals);
  outside the main thread, where Python sets no handler, nothing is installed;
- `handle` and `default`: the live view's SIGTERM, handled, then back to the default to end by it.
"""

from __future__ import annotations

import signal
import threading

# The two signals that stop a command: Ctrl-C and kill's default.
STOP = (signal.SIGINT, signal.SIGTERM)


def in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def ignore(*signums: int) -> None:
    for signum in signums:
        signal.signal(signum, signal.SIG_IGN)


def default(*signums: int) -> None:
    for signum in signums:
        signal.signal(signum, signal.SIG_DFL)


def handle(signum: int, handler) -> None:
    signal.signal(signum, handler)


def swap(signum: int, expected, handler) -> None:
    """`handler` for `signum` if the one in place is `expected` (in the main thread only)."""
    if in_main_thread() and signal.getsignal(signum) is expected:
        signal.signal(signum, handler)


def install(handler, signums: tuple[int, ...] = STOP) -> dict:
    """`handler` for each of `signums` in the main thread; the handlers it replaced, for
    `restore` (none outside the main thread, where nothing is installed)."""
    if not in_main_thread():
        return {}
    return {signum: signal.signal(signum, handler) for signum in signums}


def restore(previous: dict) -> None:
    """The handlers `install` replaced, back in place."""
    for signum, handler in previous.items():
        signal.signal(signum, handler)
