"""cosim.parts.firmware.tension_words (the native engine's set-up) against the scalar tension_word
it vectorises: the same Q7.8 word at every word, every tie between two words, their neighbours
one ulp away, full scale and beyond, and the same error for a NaN."""

from __future__ import annotations

import numpy as np
import pytest

from cosim.parts.firmware import FULL_SCALE_N, Q7_8_MAX, Q7_8_MIN, tension_word, tension_words


def _values() -> np.ndarray:
    # Every multiple of half an LSB from 2 LSB below -full scale to 2 LSB above +full scale:
    # each word (k / 256) and each tie between two words ((k + 0.5) / 256).
    halves = np.arange(2 * Q7_8_MIN - 4, 2 * (Q7_8_MAX + 1) + 5, dtype=np.float64) / 512.0
    near = np.concatenate([np.nextafter(halves, -np.inf), np.nextafter(halves, np.inf)])
    edges = np.array(
        [
            FULL_SCALE_N,
            -FULL_SCALE_N,
            (Q7_8_MAX + 0.5) / 256.0,
            (Q7_8_MIN - 0.5) / 256.0,
            -0.0,
            1e308,
            -1e308,
            np.inf,
            -np.inf,
            5e-324,
        ]
    )
    rng = np.random.default_rng(14)
    return np.concatenate([halves, near, edges, rng.uniform(-200.0, 200.0, 20_000)])


def test_vector_form_equals_scalar_form_everywhere():
    values = _values()
    words = tension_words(values)
    assert words.dtype == np.int16 and words.shape == values.shape
    scalar = np.array([tension_word(float(v)) for v in values], dtype=np.int64)
    bad = np.flatnonzero(words.astype(np.int64) != scalar)
    assert bad.size == 0, (
        f"{bad.size} values differ, first {values[bad[0]]!r}: "
        f"vector {words[bad[0]]}, scalar {scalar[bad[0]]}"
    )
    # The set covers both saturations and the round-half-even ties on both sides of zero.
    assert {Q7_8_MIN, Q7_8_MAX} <= set(words.tolist())
    assert tension_words([0.5 / 256.0, 1.5 / 256.0, -0.5 / 256.0]).tolist() == [0, 2, 0]


def test_nan_is_refused_as_by_the_scalar_form():
    with pytest.raises(ValueError, match="NaN"):
        tension_word(float("nan"))
    with pytest.raises(ValueError, match="NaN"):
        tension_words(np.array([1.0, np.nan]))
