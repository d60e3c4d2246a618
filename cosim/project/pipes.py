"""Standard output piped into a reader that stops (`bowden bench ... faults | head -2`, a study's
table into `head`): told apart from other broken pipes, and ended as a shell ends it."""

from __future__ import annotations

import os
import select
import signal
import sys


def end_for_gone_reader() -> int:
    """Whatever read standard output went away (`bowden bench ... faults | head -2`): nothing
    more goes to it (not even the interpreter's flush at exit), no message, and the exit status
    a shell gives for it, 128 + SIGPIPE, returned."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 128 + int(signal.SIGPIPE)


def output_reader_gone(exc: OSError) -> bool:
    """Whether `exc` is standard output's reader having closed the pipe (poll reports an error on
    its write end), as opposed to a broken pipe elsewhere (a device's TCP link), which is said.
    A subcommand that catches OSError itself re-raises this one for cosim.cli's main() to end
    quietly."""
    if not isinstance(exc, BrokenPipeError):
        return False
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):
        return False
    poller = select.poll()
    poller.register(fd, select.POLLOUT)
    return any(events & select.POLLERR for _, events in poller.poll(0))
