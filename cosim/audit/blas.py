"""One BLAS thread while the audit fits.

The fits' linear algebra is small: a Jacobian of at most MAX_FIT_RESIDUALS rows and a few
columns, dot products of that length (cosim.audit.fit). OpenBLAS, which numpy and scipy bundle,
splits such a product over every core, and its threads wait for each other by spinning: measured
on 60 s of 1 kHz data on this machine (2 cores, shared), the audit took 28 s of CPU with the
default threads and 14 s with one, in less wall time. One thread also makes the sums of the
products independent of the machine's core count (OpenBLAS splits a dot product by its threads),
so an audit's numbers are the same on every machine with the same libraries.

`one_thread()` limits every BLAS library the process has loaded (numpy's and scipy's OpenBLAS are
separate copies) to one thread, and gives each its count back on leaving (threadpoolctl).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator


@contextlib.contextmanager
def one_thread() -> Iterator[None]:
    """BLAS on one thread inside the block (the module's docstring)."""
    import numpy  # noqa: F401, PLC0415 (both libraries loaded, so both are limited)
    import scipy.linalg  # noqa: F401, PLC0415
    from threadpoolctl import threadpool_limits  # noqa: PLC0415

    with threadpool_limits(limits=1, user_api="blas"):
        yield
