"""Ctrl-C in the first moments of `bowden`: one line, never a KeyboardInterrupt traceback.

Importing the command line (argparse, the subcommands' modules) takes a noticeable time, and
`cosim.cli.main` can catch an interrupt only once it runs. The entry points (`python -m cosim`,
the `bowden` console script: cosim/__main__.py) install `interrupted_before_start` first, with
nothing imported but the standard library's signal and os and cosim._signals (which installs
every handler, and imports only the standard library); `cosim.cli.main` hands SIGINT back to
Python's handler (`release`) when the command starts, after the command line's imports and the
parse (an interrupt raised inside the import machinery can be printed with a traceback before
any handler sees it). Nothing has started before that point, so there is nothing to stop: the
process leaves at once with 128 + SIGINT.

After `release` a Ctrl-C is a KeyboardInterrupt again, and `seen` records that it came: an
interrupt that lands inside an extension module's import can be replaced by an ImportError with
no trace of it (numpy's C code importing datetime does so), and is an interrupt all the same.
"""

from __future__ import annotations

import os
import signal

from cosim import _signals

# True once a SIGINT arrived after release(): see the module's docstring.
seen = False


def interrupted_before_start(signum, _frame) -> None:
    os.write(2, b"bowden: interrupted by SIGINT before the command started\n")
    os._exit(128 + signum)


def install() -> None:
    # A shell that started us with SIGINT ignored (a background job) keeps it ignored.
    _signals.swap(signal.SIGINT, signal.default_int_handler, interrupted_before_start)


def keyboard_interrupt(signum, frame) -> None:
    """Python's default SIGINT handler (KeyboardInterrupt) that also records the signal (`seen`)."""
    global seen
    seen = True
    signal.default_int_handler(signum, frame)


def release() -> None:
    """A KeyboardInterrupt on Ctrl-C again, if install() put our handler in place."""
    _signals.swap(signal.SIGINT, interrupted_before_start, keyboard_interrupt)
