"""Co-simulation, float reference, model audit and bench tool for Bowden-cable tension control."""

import sys as _sys

__version__ = "0.1.0"

# `python -m cosim` and the `bowden` console script: a Ctrl-C while the command line is still
# being imported is one line, not a traceback (cosim._early). Only for those two entry points:
# a library user's (or `python -m cosim.X`'s) SIGINT stays Python's.
if _sys.orig_argv[1:3] == ["-m", "cosim"] or _sys.argv[0].rsplit("/", 1)[-1] == "bowden":
    from . import _early

    _early.install()
