"""The `bowden` command line.

Each subcommand lives in its own module, which provides `add_parser(subparsers)`; the parser
it adds sets `func(args) -> int`. A module is listed in SUBCOMMANDS only once it works.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from . import __version__

# Modules that provide subcommands, in the order `bowden --help` lists them.
SUBCOMMANDS: list[str] = ["workspace", "sim", "demo"]


def _doctor(args: argparse.Namespace) -> int:
    from .doctor import main as doctor_main

    return doctor_main()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="bowden",
        description="Bowden-cable tension control: co-simulation, model audit and bench tool.",
    )
    parser.add_argument("--version", action="version", version=f"bowden {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    doctor = sub.add_parser(
        "doctor", help="print the versions of every tool; fail if one is missing"
    )
    doctor.set_defaults(func=_doctor)
    for name in SUBCOMMANDS:
        importlib.import_module(f"cosim.{name}").add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except OSError as exc:
        # A folder that cannot be created, a file that cannot be read or written: say which.
        where = f": {exc.filename}" if exc.filename else ""
        print(f"bowden {args.command}: {exc.strerror or exc}{where}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
