"""`python -m cosim.bench bench|emulate ...`: the two commands without the rest of `bowden`'s
(quicker to start, for scripts and tests); the same as `bowden bench` and `bowden emulate`."""

import argparse
import sys

from cosim.bench import command as cli


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m cosim.bench")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    cli.add_parser(sub)
    args = parser.parse_args(argv)
    return int(args.func(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
