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
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import InvalidStateError, ProcessPoolExecutor

from cosim import _signals

# The most worker processes a study or a sweep's local cluster starts (a bound against a typo:
# more than the machines this project runs on have cores).
MAX_WORKERS = 256


def _leave_sigint_to_the_parent() -> None:
    _signals.ignore(signal.SIGINT)


@contextlib.contextmanager
def _manager_thread_errors_ignored() -> Iterator[None]:
    """While a broken pool is taken down: Python 3.11's manager thread fails every future left
    with BrokenProcessPool, and one that `Executor.map` cancelled on the interrupt raises
    InvalidStateError in that thread (a traceback after the one line); that error alone is
    dropped, any other goes to the usual hook."""
    previous = threading.excepthook

    def hook(args: threading.ExceptHookArgs) -> None:
        if args.exc_type is not None and issubclass(args.exc_type, InvalidStateError):
            return
        previous(args)

    threading.excepthook = hook
    try:
        yield
    finally:
        threading.excepthook = previous


@contextlib.contextmanager
def process_pool(workers: int) -> Iterator[ProcessPoolExecutor]:
    pool = ProcessPoolExecutor(workers, initializer=_leave_sigint_to_the_parent)
    try:
        yield pool
    except BaseException:
        with _manager_thread_errors_ignored():
            for child in multiprocessing.active_children():
                child.terminate()
            for child in multiprocessing.active_children():
                child.join(5)
            # Its workers gone, the executor's manager thread finds the pool broken and ends;
            # it is waited for here: left running, it raced the interpreter's exit hook for its
            # wake-up pipe ("Exception ignored ... Bad file descriptor" after the one line).
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
