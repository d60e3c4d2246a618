"""The trace format (cosim/results/trace.py): round trip, and clear errors for bad files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cosim.results import trace as tr


def _columns(n: int = 50, rate: float = 1000.0) -> dict[str, np.ndarray]:
    t = np.arange(n) / rate
    rng = np.random.default_rng(1)
    cols = {name: rng.normal(size=n) for name in tr.COLUMNS}
    cols["t_s"] = t
    return cols


META = {"sample_rate_hz": 1000.0, "sheath_length_m": 1.0, "loop_routing": True, "mu": 0.075}


def test_cosim_trace_round_trip_keeps_values_columns_and_meta(tmp_path):
    cols = _columns()
    cols["extra_N"] = np.linspace(0, 1, 50)
    path = tr.write_trace(tmp_path / "trace.csv", cols, {**META, "source": "test"})
    assert tr.meta_path(path).name == "trace.meta.json"
    header = path.read_text().splitlines()[0].split(",")
    assert header == [*tr.COLUMNS, "extra_N"]
    back = tr.read_trace(path)
    assert back.meta["source"] == "test" and back.meta["loop_routing"] is True
    for name, values in cols.items():
        np.testing.assert_allclose(back[name], values, rtol=1e-8, atol=1e-12, err_msg=name)
    assert len(back) == 50


@pytest.mark.parametrize(
    ("meta_change", "message"),
    [
        (
            {"sample_rate_hz": 0},
            r"sample_rate_hz = 0 is outside the allowed range \(0, 1e\+06\] Hz",
        ),
        (
            {"sheath_length_m": -1.0},
            r"sheath_length_m = -1.0 is outside the allowed range \[0.01, 10\] m",
        ),
        ({"loop_routing": 1}, "loop_routing must be true or false"),
        ({"mu": -0.1}, r"mu = -0.1 is outside the allowed range \[0, 1\]"),
        ({"mu": None}, r"mu must be a number in \[0, 1\]; got None"),
    ],
)
def test_cosim_trace_rejects_bad_meta_values(tmp_path, meta_change, message):
    with pytest.raises(tr.TraceError, match=message):
        tr.write_trace(tmp_path / "trace.csv", _columns(), {**META, **meta_change})


def test_cosim_trace_rejects_missing_sidecar_key_and_file(tmp_path):
    path = tr.write_trace(tmp_path / "trace.csv", _columns(), META)
    meta = dict(META)
    del meta["mu"]
    tr.meta_path(path).write_text(json.dumps(meta))
    with pytest.raises(tr.TraceError, match="missing key 'mu'"):
        tr.read_trace(path)
    tr.meta_path(path).unlink()
    with pytest.raises(tr.TraceError, match="sidecar trace.meta.json is missing"):
        tr.read_trace(path)
    with pytest.raises(tr.TraceError, match="no such file"):
        tr.read_trace(tmp_path / "nothing.csv")


def _write_raw(tmp_path, text: str):
    path = tmp_path / "trace.csv"
    path.write_text(text)
    tr.meta_path(path).write_text(json.dumps(META))
    return path


def test_cosim_trace_rejects_bad_csv_contents(tmp_path):
    header = ",".join(tr.COLUMNS)
    good = ",".join(["0"] * len(tr.COLUMNS))
    row2 = ",".join(["0.001"] + ["0"] * (len(tr.COLUMNS) - 1))
    with pytest.raises(tr.TraceError, match="header lacks column.*motor_angle_rad"):
        tr.read_trace(_write_raw(tmp_path, ",".join(tr.COLUMNS[:-1]) + "\n"))
    with pytest.raises(tr.TraceError, match="no data rows"):
        tr.read_trace(_write_raw(tmp_path, header + "\n"))
    with pytest.raises(tr.TraceError, match=r":3: column T_in_N is 'abc', not a number"):
        bad = row2.split(",")
        bad[3] = "abc"
        tr.read_trace(_write_raw(tmp_path, f"{header}\n{good}\n{','.join(bad)}\n"))
    with pytest.raises(tr.TraceError, match=r":2: 9 fields, the header has 10"):
        tr.read_trace(_write_raw(tmp_path, f"{header}\n{good[:-2]}\n"))
    with pytest.raises(tr.TraceError, match="t_s must be strictly increasing"):
        tr.read_trace(_write_raw(tmp_path, f"{header}\n{row2}\n{good}\n"))
    with pytest.raises(tr.TraceError, match=r":3: column T_out_N is 'nan', not a number"):
        bad = row2.split(",")
        bad[4] = "nan"
        tr.read_trace(_write_raw(tmp_path, f"{header}\n{good}\n{','.join(bad)}\n"))
    with pytest.raises(tr.TraceError, match=r":3: t_s step from the previous row is 0.002 s"):
        row_late = ",".join(["0.002"] + ["0"] * (len(tr.COLUMNS) - 1))
        tr.read_trace(_write_raw(tmp_path, f"{header}\n{good}\n{row_late}\n"))
    with pytest.raises(tr.TraceError, match="empty file"):
        tr.read_trace(_write_raw(tmp_path, ""))


def test_cosim_trace_command_line_validates_files(tmp_path, capsys):
    good = tr.write_trace(tmp_path / "good.csv", _columns(), META)
    bad = tmp_path / "bad.csv"
    bad.write_text(",".join(tr.COLUMNS[:3]) + "\n")
    tr.meta_path(bad).write_text(json.dumps(META))
    assert tr.main([str(good)]) == 0
    assert "ok: " in capsys.readouterr().out
    assert tr.main([str(good), str(bad)]) == 1
    out = capsys.readouterr()
    assert out.out.startswith("ok: ") and "invalid: " in out.err
    assert "header lacks column(s) T_in_N" in out.err
    assert tr.main([]) == 2
