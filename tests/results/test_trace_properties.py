"""Property-based tests of the trace surface (CSV + sidecar), issue 9 / issue 13: whatever bytes
a user hands the reader, in either mode, it ends in a Trace whose numbers are all finite and in
range, or in one TraceError of one line that names the file; never another exception.

Examples: the `ci` profile of tests/conftest.py in `make test`, the `fuzz` profile in a long run
(BOWDEN_HYPOTHESIS_PROFILE=fuzz).
"""

from __future__ import annotations

import json
import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from cosim.results import trace as tr

MODES = tr.MODES

# Cells that have broken readers before, or could: non-numbers Python's float() accepts, values
# out of range, separators, quotes, bytes that are not UTF-8 once encoded.
NASTY_CELLS = [
    "nan",
    "NaN",
    "-inf",
    "Infinity",
    "1_000",
    "0x10",
    "1e309",
    "-1e300",
    "1e-400",
    "\u0661\u0662",
    "\u00bd",
    "",
    " ",
    '"1"',
    '"',
    "1,2",
    "1\n2",
    "\x00",
    "1e",
    ".",
    "+.5",
    "-0",
    "9" * 400,
    "0." + "0" * 200 + "1",
]


def _valid_text(n: int, rate_hz: float, with_positions: bool, full: bool) -> str:
    names = list(tr.COLUMNS) if full else ["t_s", "T_in_N", "T_out_N"]
    if with_positions and not full:
        names += ["x_m", "y_m", "z_m"]
    rng = np.random.default_rng(n)
    lines = [",".join(names)]
    for k in range(n):
        row = []
        for name in names:
            if name == "t_s":
                row.append(f"{k / rate_hz:.9g}")
            else:
                lo, hi, _ = tr.COLUMN_RANGES[name]
                row.append(f"{rng.uniform(max(lo, -5), min(hi, 5)):.6g}")
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"


META_OK = {"sample_rate_hz": 1000.0, "sheath_length_m": 1.0, "loop_routing": True, "mu": 0.075}


def _check(path, mode: str) -> tr.Trace | None:
    """The property: a Trace with finite, in-range numbers, or one TraceError naming the file."""
    try:
        trace = tr.read_trace(path, mode)
    except tr.TraceError as exc:
        msg = str(exc)
        assert msg and "\n" not in msg, msg
        assert str(path) in msg or str(tr.meta_path(path)) in msg, msg
        return None
    n = len(trace)
    assert n >= 1
    for name, values in trace.columns.items():
        assert values.dtype == np.float64 and len(values) == n, name
        assert np.all(np.isfinite(values)), name
        if name in tr.COLUMN_RANGES:
            lo, hi, _ = tr.COLUMN_RANGES[name]
            assert np.all((values >= lo) & (values <= hi)), name
    for name, cells in trace.text_columns.items():
        assert len(cells) == n and name not in trace.columns
    assert np.all(np.diff(trace["t_s"]) > 0)
    meta = trace.meta
    assert math.isfinite(meta["sample_rate_hz"]) and 0 < meta["sample_rate_hz"] <= 1e6
    assert 0.01 <= meta["sheath_length_m"] <= 10.0
    assert isinstance(meta["loop_routing"], bool)
    assert meta["mu"] is None or 0.0 <= meta["mu"] <= 1.0
    json.dumps(meta, allow_nan=False)  # the sidecar can be written back as strict JSON
    return trace


@given(csv_bytes=st.binary(max_size=400), meta_bytes=st.one_of(st.none(), st.binary(max_size=80)))
def test_arbitrary_bytes_end_in_a_trace_or_one_trace_error(tmp_path_factory, csv_bytes, meta_bytes):
    folder = tmp_path_factory.mktemp("bytes")
    path = folder / "t.csv"
    path.write_bytes(csv_bytes)
    if meta_bytes is not None:
        tr.meta_path(path).write_bytes(meta_bytes)
    for mode in MODES:
        _check(path, mode)


@given(
    n=st.integers(1, 12),
    full=st.booleans(),
    positions=st.booleans(),
    edits=st.lists(
        st.tuples(
            st.integers(0, 10_000),
            st.one_of(st.sampled_from(NASTY_CELLS), st.text(max_size=6)),
            st.sampled_from(["cell", "insert", "delete"]),
        ),
        min_size=1,
        max_size=4,
    ),
    bom=st.booleans(),
    crlf=st.booleans(),
    drop_meta=st.booleans(),
)
def test_mutated_valid_files_end_in_a_trace_or_one_trace_error(
    tmp_path_factory, n, full, positions, edits, bom, crlf, drop_meta
):
    text = _valid_text(n, 1000.0, positions, full)
    for pos, piece, kind in edits:
        if kind == "cell":  # replace one cell of one row
            lines = text.split("\n")
            i = pos % max(1, len(lines) - 1)
            cells = lines[i].split(",")
            cells[pos % len(cells)] = piece
            lines[i] = ",".join(cells)
            text = "\n".join(lines)
        elif kind == "insert":
            i = pos % (len(text) + 1)
            text = text[:i] + piece + text[i:]
        else:
            i = pos % max(1, len(text))
            text = text[:i] + text[i + 1 + len(piece) :]
    if crlf:
        text = text.replace("\n", "\r\n")
    raw = (b"\xef\xbb\xbf" if bom else b"") + text.encode("utf-8", "surrogatepass")
    folder = tmp_path_factory.mktemp("mutated")
    path = folder / "t.csv"
    path.write_bytes(raw)
    if not drop_meta:
        tr.meta_path(path).write_text(json.dumps(META_OK))
    for mode in MODES:
        _check(path, mode)


JSON_VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(10**20), 10**20)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=8),
    lambda children: (
        st.lists(children, max_size=3) | st.dictionaries(st.text(max_size=6), children, max_size=3)
    ),
    max_leaves=6,
)


@given(
    overrides=st.dictionaries(
        st.sampled_from([*tr.META_REQUIRED, "source", "sample_rate_hz"]), JSON_VALUES, max_size=4
    ),
    drop=st.lists(st.sampled_from(tr.META_REQUIRED), max_size=4, unique=True),
    raw_constant=st.sampled_from([None, "NaN", "Infinity", "-Infinity", "1e400"]),
)
def test_mutated_sidecars_end_in_a_trace_or_one_trace_error(
    tmp_path_factory, overrides, drop, raw_constant
):
    folder = tmp_path_factory.mktemp("sidecar")
    path = folder / "t.csv"
    path.write_text(_valid_text(8, 1000.0, True, True))
    meta = {**META_OK, **overrides}
    for key in drop:
        meta.pop(key, None)
    text = json.dumps(meta)
    if raw_constant is not None:
        text = text.replace("0.075", raw_constant) if "0.075" in text else text
    tr.meta_path(path).write_text(text)
    for mode in MODES:
        _check(path, mode)


@given(
    n=st.integers(1, 30),
    rate_hz=st.sampled_from([100.0, 1000.0, 10_000.0]),
    values=st.lists(st.floats(-1000.0, 1000.0, allow_nan=False, allow_infinity=False), min_size=1),
)
def test_written_traces_read_back_in_both_modes(tmp_path_factory, n, rate_hz, values):
    cols = {}
    for j, name in enumerate(tr.COLUMNS):
        lo, hi, _ = tr.COLUMN_RANGES[name]
        cols[name] = np.clip(np.resize(np.asarray(values[j:] or values), n), lo, hi)
    cols["t_s"] = np.arange(n) / rate_hz
    path = tr.write_trace(
        tmp_path_factory.mktemp("round") / "t.csv", cols, {**META_OK, "sample_rate_hz": rate_hz}
    )
    for mode in MODES:
        back = _check(path, mode)
        assert back is not None
        for name in tr.COLUMNS:
            np.testing.assert_allclose(back[name], cols[name], rtol=1e-8, atol=1e-12)
