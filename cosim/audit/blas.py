"""One BLAS thread while the audit fits.

The fits' linear algebra is small: a Jacobian of at most MAX_FIT_RESIDUALS rows and a few
columns, dot products of that length (cosim.audit.fit). OpenBLAS, which numpy and scipy bundle,
splits such a product over every core, and its threads wait for each other by spinning: measured
on 60 s of 1 kHz data on this machine (2 cores, shared), the audit took 28 s of CPU with the
default threads and 14 s with one, in less wall time. One thread also makes the sums of the
products independent of the machine's core count (OpenBLAS splits a dot product by its threads),
so an audit's numbers are the same on every machine with the same libraries.

`one_thread()` sets the thread count of every OpenBLAS library the process has loaded (numpy's
and scipy's are separate copies, with their own symbol names) to one, and back on leaving. Where
the libraries cannot be found (no /proc/self/maps, another BLAS) it does nothing.
"""

from __future__ import annotations

import contextlib
import ctypes
from collections.abc import Iterator

# (set, get) of OpenBLAS's thread count under the names the builds export: plain OpenBLAS,
# scipy-openblas (32-bit integers, scipy's), and scipy-openblas64 (numpy's)
_SYMBOLS = (
    ("openblas_set_num_threads", "openblas_get_num_threads"),
    ("scipy_openblas_set_num_threads", "scipy_openblas_get_num_threads"),
    ("scipy_openblas_set_num_threads64_", "scipy_openblas_get_num_threads64_"),
)


def _loaded_openblas() -> list[tuple[object, object]]:
    """(set, get) of each OpenBLAS the process has mapped."""
    try:
        with open("/proc/self/maps") as f:
            paths = sorted({ln.split()[-1] for ln in f if "openblas" in ln.rsplit("/", 1)[-1]})
    except OSError:
        return []
    out = []
    for path in paths:
        try:
            lib = ctypes.CDLL(path)  # the library already loaded: the same handle
        except OSError:
            continue
        for set_name, get_name in _SYMBOLS:
            if hasattr(lib, set_name) and hasattr(lib, get_name):
                setter, getter = getattr(lib, set_name), getattr(lib, get_name)
                setter.argtypes, getter.restype = [ctypes.c_int], ctypes.c_int
                out.append((setter, getter))
                break
    return out


@contextlib.contextmanager
def one_thread() -> Iterator[None]:
    """OpenBLAS on one thread inside the block (the module's docstring)."""
    import numpy  # noqa: F401, PLC0415 (both libraries loaded, so both are found)
    import scipy.linalg  # noqa: F401, PLC0415

    libs = _loaded_openblas()
    before = [get() for _, get in libs]
    for setter, _ in libs:
        setter(1)
    try:
        yield
    finally:
        for (setter, _), n in zip(libs, before, strict=True):
            setter(n)
