"""`bowden bench` (talk to a controller) and `bowden emulate` (be one), see cosim/bench/README.md.

The two parsers, `bench_main` and the handlers are in cosim/bench/command.py (and its
command_tools.py), which `python -m cosim.bench` runs without the rest of `bowden`; this module
adds them to `bowden`'s subcommands.
"""

from __future__ import annotations

from cosim.bench import command


def add_parser(subparsers) -> None:
    command.add_parser(subparsers)
