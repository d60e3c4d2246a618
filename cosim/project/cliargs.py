"""Argument types and the parser class shared by every `bowden` subcommand.

Bad input on the command line gets one line on stderr naming the option and what was expected
(`bowden sim: argument --duration: expected a finite number; got 'nan' (see bowden sim --help)`),
exit status 2, and nothing is run or written.

`harden(parser)` (applied by cosim.cli to the whole command tree, so that a subcommand added
later is covered without edits) makes every option declared with `type=float` refuse NaN and
infinities: no option of this project takes them, and argparse's float() accepts both.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path


class ArgumentParser(argparse.ArgumentParser):
    """argparse with one-line errors (the usage is one `--help` away)."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: {message} (see {self.prog} --help)\n")


def shown(text) -> str:
    """A file name or argument for a one-line message: as it is, or quoted with escapes when it
    holds a line break or another unprintable character."""
    text = str(text)
    return text if text.isprintable() else repr(text)


def finite_float(text: str) -> float:
    """A float that is not NaN or infinite (argparse type)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number; got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number; got {text!r}")
    return value


def count_refused(option: str, value: int | None, lo: int, hi: int | None = None) -> str | None:
    """Why a whole-number option's value is refused, as its one line's text (`--limit 0: at
    least 1`), or None when it is unset or within [lo, hi]."""
    if value is None or (value >= lo and (hi is None or value <= hi)):
        return None
    return f"{option} {value}: " + (f"at least {lo}" if hi is None else f"{lo} to {hi}")


def output_dir(text: str) -> Path:
    """A folder to write into: any non-empty path (created when missing)."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected the name of a folder; got {text!r}")
    return Path(text)


def unwritable(path: Path, folder: bool) -> str | None:
    """Why `path` (a folder to create or fill when `folder`, else a file to create or replace)
    cannot be written, or None: a part of the way that is a file, or the target itself of the
    wrong kind. Checked before a long computation, so that its result is not lost to a path
    that was wrong from the start (permissions are left to the write itself)."""
    if path.exists():
        if folder and not path.is_dir():
            return f"{shown(path)} is a file, not a folder"
        if not folder and path.is_dir():
            return f"{shown(path)} is a folder, not a file"
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                return f"{shown(parent)} is a file, not a folder"
            break
    return None


def subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The subcommand parsers of `parser` by name (empty when it has none)."""
    out: dict[str, argparse.ArgumentParser] = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            out.update(action.choices)
    return out


def harden(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Make every `type=float` option of `parser` and of its subcommands refuse NaN and inf."""
    for action in parser._actions:
        if action.type is float:
            action.type = finite_float
    for sub in subparsers(parser).values():
        harden(sub)
    return parser
