"""Co-simulation, float reference, model audit and bench tool for Bowden-cable tension control."""

import sys as _sys

__version__ = "0.1.0"

# `python -m cosim` and the `bowden` console script: a Ctrl-C while the command line is still
# being imported is one line, not a traceback (cosim._early). Only for those two entry points:
# a library user's (or `python -m cosim.X`'s) SIGINT stays Python's. The interpreter's own command
# line (orig_argv) tells them apart from a process that multiprocessing spawns, such as a sweep's
# Dask worker: it inherits the parent's sys.argv and imports its main script (so this package).
_spawned = "--multiprocessing-fork" in _sys.orig_argv
_script = _sys.argv[0].rsplit("/", 1)[-1] == "bowden"
if not _spawned and (_sys.orig_argv[1:3] == ["-m", "cosim"] or _script):
    from . import _early

    _early.install()
elif _spawned and (_script or _sys.argv[0].endswith("/cosim/__main__.py")):
    # A worker of `bowden`: Ctrl-C at the terminal reaches the whole process group, and the parent
    # stops its workers itself (a Dask LocalCluster's close). A worker that took the SIGINT too
    # would print a KeyboardInterrupt traceback from inside Dask's event loop.
    import signal as _signal

    from . import _signals

    _signals.ignore(_signal.SIGINT)
