"""The native ADC's sum (closed_loop.cpp, fsum_fast: TwoSum with an error bound, CPython's
algorithm when the bound cannot decide) against math.fsum, bit for bit: on sums like the ADC's
(24 positive weights times tensions), on ties and near-ties of round-half-even, on cancellation,
mixed signs and exponents, subnormals and zeros. Both paths are exercised and counted."""

from __future__ import annotations

import ctypes
import math

import numpy as np
import pytest

from cosim.engines.native import engine


@pytest.fixture(scope="module")
def lib():
    return engine.load_library()


def _check(lib, arrays) -> tuple[int, int]:
    """Compare every array's sum with math.fsum (same bits, sign of zero included); return how
    many the fast path decided and how many the fallback did."""
    fast = slow = 0
    flag = ctypes.c_int32()
    for x in arrays:
        x = np.ascontiguousarray(x, dtype=np.float64)
        got = lib.bn_fsum(x.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), len(x), flag)
        want = math.fsum(x.tolist())
        assert got.hex() == want.hex() and math.copysign(1, got) == math.copysign(1, want), (
            f"{x.tolist()!r}: native {got!r}, math.fsum {want!r}"
        )
        fast += bool(flag.value)
        slow += not flag.value
    return fast, slow


def test_adc_like_sums_take_the_fast_path(lib):
    rng = np.random.default_rng(1414)
    arrays = []
    for _ in range(20_000):
        w = rng.uniform(0.0, 1.0, 24)
        w /= w.sum()
        arrays.append(w * rng.uniform(-1.0, 40.0, 24))
    fast, slow = _check(lib, arrays)
    assert fast >= 0.99 * len(arrays), (fast, slow)


def test_ties_cancellation_and_extremes_equal_math_fsum(lib):
    u = 2.0**-53
    ties = [
        [1.0, u],  # exact tie: half to even keeps 1.0
        [1.0, u, u * 2.0**-60],  # just above the tie: rounds up
        [1.0, u, -(u * 2.0**-60)],  # just below: stays
        [1.0 + 2 * u, u],  # tie with an odd neighbour: rounds up to even
        [-1.0, -u],
        [2.0, -u / 2],  # below a power of two, where the gap halves
        [1e16, 1.0, -1e16],
        [1e308, 1e308 * 0.5, -1e308],
        [5e-324, 5e-324, -5e-324],
        [0.0, -0.0],
        [-0.0, -0.0],
        [],
        [3.0],
    ]
    rng = np.random.default_rng(14)
    mixed = [
        rng.choice([-1.0, 1.0], n) * 2.0 ** rng.uniform(-60, 60, n)
        for n in rng.integers(1, 40, 5_000)
    ]
    # Sums that cancel to a few ulps of their terms, and near-ties built from a rounded sum.
    cancel = []
    for _ in range(5_000):
        a = rng.uniform(-1.0, 1.0, 12)
        cancel.append(np.concatenate([a, -a[::-1] * (1 + rng.integers(-3, 4, 12) * u)]))
    near = []
    for _ in range(5_000):
        a = rng.uniform(0.5, 1.0, 23)
        s = math.fsum(a.tolist())
        ulp = math.ulp(s)
        near.append(np.append(a, -math.fsum([*a.tolist(), -s]) + ulp * rng.choice([0.5, -0.5])))
    fast, slow = _check(lib, [np.array(t) for t in ties] + mixed + cancel + near)
    assert fast > 0 and slow > 100, (fast, slow)  # both paths taken
