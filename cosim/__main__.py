"""`python -m cosim` and the `bowden` console script (pyproject's project.scripts).

The early SIGINT handler goes in before the command line is imported (cosim._early)."""

import sys

from . import _early


def run() -> int:
    _early.install()
    from .cli import main  # noqa: PLC0415 (after the handler: importing it takes a while)

    return main()


if __name__ == "__main__":
    sys.exit(run())
