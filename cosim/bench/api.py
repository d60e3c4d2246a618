"""The Python API for scripts, under its documented name: `from cosim.bench.api import Bench`
(cosim/bench/README.md, "Python API"). It lives with the link it drives, in
cosim.bench.link.api; this module names the stable surface."""

from cosim.bench.link.api import (
    WAVE_KINDS,
    Bench,
    BenchError,
    BenchUsageError,
    DeviceInfo,
    Faults,
    ProtocolError,
    Run,
)

__all__ = [
    "Bench",
    "BenchError",
    "BenchUsageError",
    "DeviceInfo",
    "Faults",
    "ProtocolError",
    "Run",
    "WAVE_KINDS",
]
