"""The trace reader (cosim/results/trace.py): the defects a new user's files found, and the
"measured" mode that reads users' CSVs, bench recordings and `bowden sim` traces with one
validation.

Each defect test below failed on the reader before the fix (a traceback or a silently accepted
value); each now requires one TraceError naming the file, the line, the column and what is
allowed.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from cosim.results import trace as tr

META = {"sample_rate_hz": 1000.0, "sheath_length_m": 1.0, "loop_routing": True, "mu": 0.075}


def _full_text(n: int = 5, tout: str | None = None) -> str:
    """A valid full trace as text; `tout` replaces T_out_N of the third data row."""
    lines = [",".join(tr.COLUMNS)]
    for k in range(n):
        row = [f"{k / 1000:.3f}", "1", "1.2", "1.1", "0.9", "0", "0.5", "0", "0.1", "0"]
        if k == 2 and tout is not None:
            row[4] = tout
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"


def _write(tmp_path, csv_bytes: bytes, meta: dict | bytes | None = META, name="trace.csv"):
    path = tmp_path / name
    path.write_bytes(csv_bytes)
    if meta is not None:
        raw = meta if isinstance(meta, bytes) else json.dumps(meta).encode()
        tr.meta_path(path).write_bytes(raw)
    return path


# --- defects found with users' files ------------------------------------------------------------


def test_non_utf8_byte_in_csv_names_file_line_and_column(tmp_path):
    text = _full_text().encode()
    text = text.replace(b"\n0.002,1,", b"\n0.002,\xff1,")  # data row 3 = line 4
    path = _write(tmp_path, text)
    with pytest.raises(tr.TraceError) as err:
        tr.read_trace(path)
    msg = str(err.value)
    assert f"{path}:4:" in msg and "0xff" in msg and "not UTF-8" in msg and "column 7" in msg


def test_non_utf8_byte_in_sidecar_names_the_sidecar(tmp_path):
    meta = json.dumps(META).encode().replace(b'"mu"', b'"m\xe9u"')
    path = _write(tmp_path, _full_text().encode(), meta)
    with pytest.raises(tr.TraceError) as err:
        tr.read_trace(path)
    msg = str(err.value)
    assert str(tr.meta_path(path)) + ":1:" in msg and "0xe9" in msg and "not UTF-8" in msg


def test_field_over_128_kib_is_rejected_with_its_line(tmp_path):
    text = _full_text().replace("\n0.003,", "\n0.003" + "0" * (129 * 1024) + ",", 1)
    path = _write(tmp_path, text.encode())
    with pytest.raises(tr.TraceError) as err:
        tr.read_trace(path)
    msg = str(err.value)
    assert f"{path}:5:" in msg and "128 KiB" in msg


@pytest.mark.parametrize("value", ["1e300", "-1e300", "1e309", "2000"])
def test_tension_outside_the_physical_range_is_rejected(tmp_path, value):
    path = _write(tmp_path, _full_text(tout=value).encode())
    with pytest.raises(tr.TraceError) as err:
        tr.read_trace(path)
    msg = str(err.value)
    assert f"{path}:4:" in msg and "T_out_N" in msg and "[-1000, 1000] N" in msg


@pytest.mark.parametrize("value", ["1_000", "nan", "inf", "0x10", "\u0661", "1e", "--1", ""])
def test_only_plain_decimal_numbers_are_numbers(tmp_path, value):
    path = _write(tmp_path, _full_text(tout=value).encode())
    with pytest.raises(tr.TraceError) as err:
        tr.read_trace(path)
    msg = str(err.value)
    assert f"{path}:4:" in msg and "column T_out_N" in msg and "decimal number" in msg


@pytest.mark.parametrize(
    ("key", "value", "allowed"),
    [
        ("mu", 50, "[0, 1]"),
        ("mu", -0.1, "[0, 1]"),
        ("sheath_length_m", 1e300, "[0.01, 10] m"),
        ("sheath_length_m", 0.0, "[0.01, 10] m"),
        ("sample_rate_hz", 1e300, "(0, 1e+06] Hz"),
    ],
)
def test_sidecar_values_outside_the_fmu_range_are_rejected(tmp_path, key, value, allowed):
    path = _write(tmp_path, _full_text().encode(), {**META, key: value})
    with pytest.raises(tr.TraceError) as err:
        tr.read_trace(path)
    msg = str(err.value)
    assert str(tr.meta_path(path)) in msg and key in msg and allowed in msg


def test_numbers_in_range_with_spaces_and_exponents_are_read(tmp_path):
    text = _full_text(tout=" 9.5e-1 ").replace("\n0.004,1,", "\n+4E-3,1.,")
    back = tr.read_trace(_write(tmp_path, text.encode()))
    assert back["T_out_N"][2] == 0.95 and back["T_in_N"][4] == 1.1 and back["t_s"][4] == 0.004
    assert back["T_ref_N"][4] == 1.0


def test_trace_ranges_are_the_fmu_ranges():
    """The reader's ranges for mu, the sheath length, tensions and positions are the plant
    FMU's (fmu/gen_model.py), so that every accepted trace can be re-simulated."""
    from fmu import gen_model

    var = {v.name: v for v in gen_model.VARIABLES}
    assert tr.META_RANGES["mu"][:2] == (var["mu"].lo, var["mu"].hi)
    assert tr.META_RANGES["sheath_length_m"][:2] == (
        var["sheath_length"].lo,
        var["sheath_length"].hi,
    )
    for col, fmu_name in (("T_in_N", "T_in_cmd"), ("x_m", "x"), ("y_m", "y"), ("z_m", "z")):
        assert tr.COLUMN_RANGES[col][:2] == (var[fmu_name].lo, var[fmu_name].hi), col


# --- measured mode -----------------------------------------------------------------------------


def _measured_text(n: int = 6, rate: float = 500.0, extra: str = "") -> str:
    head = "t_s,T_in_N,T_out_N" + ("," + extra if extra else "")
    rows = []
    for k in range(n):
        cells = [f"{10 + k / rate:.6f}", f"{2 + k:.3f}", f"{1 + 0.5 * k:.3f}"]
        if extra:
            cells.append("a" if k == 3 else str(k))
        rows.append(",".join(cells))
    return head + "\n" + "\n".join(rows) + "\n"


def test_measured_needs_three_columns_and_no_sidecar(tmp_path):
    path = _write(tmp_path, _measured_text().encode(), meta=None, name="rig.csv")
    back = tr.read_trace(path, mode="measured")
    assert len(back) == 6 and not back.has_positions
    assert back.meta["sample_rate_hz"] == pytest.approx(500.0)
    assert back.meta["sheath_length_m"] == 1.0 and back.meta["loop_routing"] is True
    assert back.meta["mu"] is None
    assert set(back.defaulted) == {"sample_rate_hz", "sheath_length_m", "loop_routing", "mu"}
    np.testing.assert_allclose(back["T_out_N"], 1 + 0.5 * np.arange(6))
    # the same file is not a full trace
    with pytest.raises(tr.TraceError, match="missing"):
        tr.read_trace(path)


def test_measured_sidecar_keys_are_optional_and_checked(tmp_path):
    path = _write(
        tmp_path,
        _measured_text().encode(),
        {"sheath_length_m": 0.8, "mu": None, "note": "rig A"},
        name="rig.csv",
    )
    back = tr.read_trace(path, mode="measured")
    assert back.meta["sheath_length_m"] == 0.8 and back.meta["note"] == "rig A"
    assert set(back.defaulted) == {"sample_rate_hz", "loop_routing", "mu"}
    tr.meta_path(path).write_text(json.dumps({"sample_rate_hz": 1000.0}))
    with pytest.raises(tr.TraceError, match=r"rig.csv:3: t_s step from the previous row is 0.002"):
        tr.read_trace(path, mode="measured")
    tr.meta_path(path).write_text('{"mu": NaN}')
    with pytest.raises(tr.TraceError, match=r"rig.meta.json: not valid JSON \(NaN"):
        tr.read_trace(path, mode="measured")
    tr.meta_path(path).write_text('{"mu": 0.1,}')
    with pytest.raises(tr.TraceError, match=r"rig.meta.json:1: not valid JSON"):
        tr.read_trace(path, mode="measured")


def test_measured_keeps_extra_columns_as_numbers_or_text_never_nan(tmp_path):
    text = _measured_text(extra="label").replace(
        "t_s,T_in_N,T_out_N,label", "t_s,T_in_N,T_out_N,label"
    )
    text = text.replace("\n", ",0\n").replace("label,0", "label,temp_C", 1)
    path = _write(tmp_path, text.encode(), meta=None)
    back = tr.read_trace(path, mode="measured")
    assert back.text_columns["label"][3] == "a"
    np.testing.assert_array_equal(back["temp_C"], np.zeros(6))
    nan_text = text.replace(",0\n", ",nan\n", 1)
    back = tr.read_trace(_write(tmp_path, nan_text.encode(), meta=None), mode="measured")
    assert "temp_C" in back.text_columns and "temp_C" not in back.columns
    assert all(np.all(np.isfinite(v)) for v in back.columns.values())


def test_measured_positions_come_all_three_or_none(tmp_path):
    text = "t_s,T_in_N,T_out_N,x_m,z_m\n0,1,1,0,0\n0.001,1,1,0,0\n"
    with pytest.raises(tr.TraceError, match="has x_m, z_m but not y_m"):
        tr.read_trace(_write(tmp_path, text.encode(), meta=None), mode="measured")
    text = "t_s,T_in_N,T_out_N,x_m,y_m,z_m\n0,1,1,0,0.5,0\n0.001,1,1,0,0.5,11\n"
    with pytest.raises(tr.TraceError, match=r":3: column z_m is 11.0; allowed \[-10, 10\] m"):
        tr.read_trace(_write(tmp_path, text.encode(), meta=None), mode="measured")


def test_measured_reads_a_full_sim_trace_the_same(tmp_path):
    n = 20
    cols = {name: np.full(n, 0.5) for name in tr.COLUMNS}
    cols["t_s"] = np.arange(n) / 1000.0
    cols["T_out_true_N"] = np.linspace(0, 1, n)
    path = tr.write_trace(tmp_path / "trace.csv", cols, META)
    full = tr.read_trace(path)
    measured = tr.read_trace(path, mode="measured")
    assert measured.defaulted == () and measured.meta == full.meta
    for name in full.columns:
        np.testing.assert_array_equal(measured[name], full[name])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("t_s,T_in_N,T_out_N\n0,1,1\n", "the sample rate needs at least two rows"),
        ("t_s,T_in_N,T_out_N\n0,1,1\n0,1,1\n", r":3: t_s must be strictly increasing"),
        ("t_s,T_in_N,T_out_N\n0,1,1\n1e-9,1,1\n", r"sample rate of 1e\+09 Hz; allowed"),
        ("t_s,T_in_N,,T_out_N\n0,1,1,1\n", "header column 3 has no name"),
        ("t_s,T_in_N,T_in_N,T_out_N\n0,1,1,1\n", "duplicate column name 'T_in_N'"),
        ('t_s,T_in_N,T_out_N\n0,"1\n2",1\n', r":3: column T_in_N is '1\\n2', not a number"),
        ("t_s,T_in_N\n0,1\n", "header lacks column.s. T_out_N"),
        ("\n", ":1: blank line where the header row should be"),
    ],
)
def test_measured_rejects_bad_files_with_one_clear_error(tmp_path, text, message):
    with pytest.raises(tr.TraceError, match=message):
        tr.read_trace(_write(tmp_path, text.encode(), meta=None), mode="measured")


@pytest.mark.parametrize(
    "row", [0, tr.COLUMN_CHUNK_CELLS - 1, tr.COLUMN_CHUNK_CELLS, 2 * tr.COLUMN_CHUNK_CELLS + 2999]
)
def test_a_long_column_is_checked_in_every_chunk(tmp_path, row):
    """A column is checked COLUMN_CHUNK_CELLS cells at a time (bounded memory): a bad cell or a
    quoted line break in any chunk, at either side of a chunk's edge, is named with its line,
    and an extra column with such a cell is kept as text."""
    n = 2 * tr.COLUMN_CHUNK_CELLS + 3000
    lines = ["t_s,T_in_N,T_out_N,note"] + [f"{k / 1000},1,1,{k}" for k in range(n)]
    good = _write(tmp_path, ("\n".join(lines) + "\n").encode(), meta=None, name="ok.csv")
    back = tr.read_trace(good, mode="measured")
    assert len(back) == n and back["note"][-1] == n - 1
    # (a row with a quoted line break is named by the line it ends on, as csv counts lines)
    for cell, shown, line in (("1x", "'1x'", row + 2), ('"1\n2"', "'1\\n2'", row + 3)):
        bad = list(lines)
        bad[row + 1] = f"{row / 1000},{cell},1,{row}"
        path = _write(tmp_path, ("\n".join(bad) + "\n").encode(), meta=None, name="bad.csv")
        with pytest.raises(tr.TraceError) as err:
            tr.read_trace(path, mode="measured")
        assert f"bad.csv:{line}: column T_in_N is {shown}, not a number" in str(err.value)
        bad[row + 1] = f"{row / 1000},1,1,{cell}"
        path = _write(tmp_path, ("\n".join(bad) + "\n").encode(), meta=None, name="bad.csv")
        back = tr.read_trace(path, mode="measured")
        assert "note" in back.text_columns and "note" not in back.columns


def test_byte_order_mark_and_crlf_line_ends_are_read(tmp_path):
    text = _measured_text().replace("\n", "\r\n").encode()
    back = tr.read_trace(_write(tmp_path, b"\xef\xbb\xbf" + text, meta=None), mode="measured")
    assert len(back) == 6 and "t_s" in back


def test_command_line_checks_measured_files(tmp_path, capsys):
    path = _write(tmp_path, _measured_text().encode(), meta=None, name="rig.csv")
    assert tr.main([str(path)]) == 1
    assert "its sidecar rig.meta.json is missing" in capsys.readouterr().err
    assert tr.main(["--measured", str(path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"ok: {path}: 6 samples") and "mu unknown" in out
    assert "defaults: " in out
