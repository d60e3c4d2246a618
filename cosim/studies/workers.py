"""Worker processes of a study, stopped at once by Ctrl-C.

A ProcessPoolExecutor's workers share the terminal's process group: Ctrl-C reaches each of them,
and each would print a KeyboardInterrupt traceback, while the executor's exit waits for the tasks
still running (a calibration takes half a minute). `process_pool` gives workers that leave SIGINT
to the parent and, when the block ends by an exception (Ctrl-C in the parent), ends them at once
instead of waiting.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import signal
import sys
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor

from cosim import _signals


def _leave_sigint_to_the_parent() -> None:
    _signals.ignore(signal.SIGINT)


@contextlib.contextmanager
def process_pool(workers: int) -> Iterator[ProcessPoolExecutor]:
    pool = ProcessPoolExecutor(workers, initializer=_leave_sigint_to_the_parent)
    try:
        yield pool
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        for child in multiprocessing.active_children():
            child.terminate()
        for child in multiprocessing.active_children():
            child.join(5)
        # The executor's manager thread, finding its workers gone, closes its wake-up pipe; left
        # running, it raced the interpreter's exit hook, which writes to that pipe ("Exception
        # ignored ... Bad file descriptor" after the one line). Its end is waited for here.
        pool.shutdown(wait=True)
        raise
    pool.shutdown(wait=True)


def run_interruptible(main: Callable[[], int], prog: str) -> int:
    """`main()`, or after Ctrl-C one line and 130 (the shell's code for SIGINT)."""
    try:
        return main()
    except KeyboardInterrupt:
        print(f"{prog}: interrupted; its workers are stopped", file=sys.stderr)
        return 130
