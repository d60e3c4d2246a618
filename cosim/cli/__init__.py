"""The `bowden` command line.

Each subcommand lives in its own module, which provides `add_parser(subparsers)`; the parser
it adds sets `func(args) -> int`. A module is listed in SUBCOMMANDS only once it works.

For every subcommand: a bad argument is one line on stderr and exit status 2
(cosim.project.cliargs); SIGINT (Ctrl-C) or SIGTERM stops the run and every process it started
(cosim.project.procs), prints one line and exits with 128 + the signal number, keeping the files
already written.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import signal
import sys

from cosim import __version__, _early, _signals
from cosim.project import procs
from cosim.project.cliargs import ArgumentParser, harden, subparsers
from cosim.project.interrupt import Interrupted
from cosim.project.pipes import end_for_gone_reader, output_reader_gone

# The subcommands, in the order `bowden --help` lists them: cosim/cli/NAME.py for each; `bench`
# adds `bowden bench` and `bowden emulate`.
SUBCOMMANDS: list[str] = ["doctor", "workspace", "sim", "demo", "tune", "audit", "bench", "sweep"]


# The signal that arrived, kept in case its exception is lost: raised where Python cannot
# propagate it (a __del__ run by the garbage collector, a callback from C), Interrupted is
# printed as "ignored" and the run would go on to exit 0 (an audit did, 2 times in 7 on
# SIGTERM). main() and check_interrupted() read it.
_pending: int | None = None


def _raise_interrupted(signum, _frame):
    global _pending
    _pending = signum
    # A second Ctrl-C while the run is being stopped would only interrupt the stopping.
    _signals.ignore(*_signals.STOP)
    raise Interrupted(signum)


def check_interrupted() -> None:
    """Raise Interrupted again when a signal arrived whose exception was lost (see _pending):
    long commands call it between their steps."""
    if _pending is not None:
        raise Interrupted(_pending)


@contextlib.contextmanager
def _signals_interrupt():
    """SIGINT and SIGTERM raise Interrupted in the main thread while the command runs."""
    previous = _signals.install(_raise_interrupted)
    try:
        yield
    finally:
        _signals.restore(previous)


def build_parser() -> argparse.ArgumentParser:
    parser = ArgumentParser(
        prog="bowden",
        description="Bowden-cable tension control: co-simulation, model audit and bench tool.",
    )
    parser.add_argument("--version", action="version", version=f"bowden {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in SUBCOMMANDS:
        importlib.import_module(f"cosim.cli.{name}").add_parser(sub)
    return harden(parser)


def _interruption(exc: BaseException) -> BaseException | None:
    """The Interrupted or KeyboardInterrupt behind `exc`, if any. A signal that lands inside an
    extension module's import (numpy importing datetime, say) reaches us as an ImportError whose
    context is the interrupt: it is the interrupt all the same."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, (Interrupted, KeyboardInterrupt)):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def main(argv: list[str] | None = None) -> int:
    global _pending
    _pending = None
    try:
        # The early handler (one line, exit) stays through the command line's imports and the
        # parse: nothing has started, and a KeyboardInterrupt raised inside the import machinery
        # can be printed with a traceback by the interpreter before it reaches any handler
        # (seen once in importlib's module locks). _main releases it when the command starts.
        return _main(argv)
    except (KeyboardInterrupt, ImportError) as exc:  # Ctrl-C before the command's handlers
        if _interruption(exc) is None and not _early.seen:
            raise
        print("bowden: interrupted by SIGINT before the command started", file=sys.stderr)
        return 128 + int(signal.SIGINT)


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    try:
        args, extra = parser.parse_known_args(argv)
        if extra:  # named by the subcommand's parser: `bowden sim: unrecognized arguments: ...`
            command = subparsers(parser).get(getattr(args, "command", None) or "", parser)
            command.error(f"unrecognized arguments: {' '.join(extra)}")
    except SystemExit as exc:  # --help, --version, or a bad argument (one line printed)
        return exc.code if isinstance(exc.code, int) else 2
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 2
    _early.release()  # from here on a Ctrl-C is a KeyboardInterrupt caught below
    try:
        with _signals_interrupt():
            code = int(args.func(args) or 0)
            check_interrupted()  # a signal whose exception was lost on the way
            return code
    except (Interrupted, KeyboardInterrupt, ImportError, SystemError) as exc:
        # SystemError: a handler's Interrupted raised as a compiled function (numba's dispatcher)
        # returns reaches us as "returned a result with an exception set", caused by it.
        interrupt = _interruption(exc)
        if interrupt is None and _pending is None:
            raise
        if isinstance(interrupt, Interrupted):
            signum = interrupt.signum
        else:  # a KeyboardInterrupt, or an ImportError that replaced the signal's exception
            signum = _pending or int(signal.SIGINT)
        procs.stop_all()  # whatever the command's own handler has not stopped yet
        print(
            f"bowden {args.command}: interrupted by {signal.Signals(signum).name}: stopped the run "
            "and every process it started; files already written are kept",
            file=sys.stderr,
        )
        return 128 + signum
    except OSError as exc:
        if output_reader_gone(exc):
            # The command's own clean-up (a run's output disabled) ran while the error came up.
            return end_for_gone_reader()
        # A folder that cannot be created, a file that cannot be read or written: say which.
        where = f": {exc.filename}" if exc.filename else ""
        print(f"bowden {args.command}: {exc.strerror or exc}{where}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
