"""Child processes that must not outlive a run: each in its own process group, stopped as one.

A simulator (Verilator's model with cocotb inside, Icarus, make and the compilers of a build)
runs as a child of `bowden`. SIGTERM sent to `bowden` alone, or SIGINT to a terminal's
foreground group while the child ignores it, would leave that child running. So every child
starts a session of its own (its process group, which holds whatever it starts in turn), is
recorded here while it runs, and `stop_all()` (called by `bowden` when it is interrupted, and
by `run` when the waiting thread is) ends each group: SIGTERM, then SIGKILL after a grace time.
"""

from __future__ import annotations

import os
import signal
import subprocess
import threading
from collections.abc import Sequence

# Time a stopped process group has to exit on SIGTERM before it gets SIGKILL.
GRACE_S = 2.0

_lock = threading.Lock()
_running: set[subprocess.Popen] = set()


def run(cmd: Sequence[str], **kwargs) -> int:
    """Run `cmd` to completion in a process group of its own; return its exit status.

    Keyword arguments go to subprocess.Popen. If the waiting thread is interrupted (an exception
    such as KeyboardInterrupt arrives while it waits), the group is stopped before the exception
    goes on."""
    proc = subprocess.Popen(list(cmd), start_new_session=True, **kwargs)
    with _lock:
        _running.add(proc)
    try:
        return proc.wait()
    except BaseException:
        stop(proc)
        raise
    finally:
        with _lock:
            _running.discard(proc)


def stop(proc: subprocess.Popen, grace_s: float = GRACE_S) -> None:
    """End the process group of `proc` (SIGTERM, then SIGKILL after `grace_s`) and reap it."""
    for sig, wait_s in ((signal.SIGTERM, grace_s), (signal.SIGKILL, grace_s)):
        try:
            os.killpg(proc.pid, sig)
        except (ProcessLookupError, PermissionError):
            pass
        try:
            proc.wait(timeout=wait_s)
        except subprocess.TimeoutExpired:
            continue
        # The leader has exited; members of its group may still run (make's children).
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        return


def stop_all() -> int:
    """Stop every process group started through `run` that is still running; return how many."""
    with _lock:
        procs = list(_running)
    for proc in procs:
        stop(proc)
    return len(procs)
