"""Data a real user has, and data that make no sense: the audit reads the files people have
(semicolon- or tab-separated with decimal commas, a separator at the end of every row, Unix
times, jittered PC timestamps on request, a params file with a byte-order mark), refuses a
sensor that does not move in one line, warns when the output is above the input while the
input rises, never writes inf or nan, writes its set of files as one, and ends on SIGTERM even
when the signal's exception is lost in a __del__."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from cosim import cli
from cosim.audit import core
from cosim.config.run import load_params
from cosim.results import trace

RATE_HZ = 1000.0
ENV = {**os.environ, "PYTHONUNBUFFERED": "1", "MPLBACKEND": "Agg"}


def _bowden(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "cosim", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=900,
        env=ENV,
    )


def _signals(n: int = 3000, seed: int = 3):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / RATE_HZ
    t_in = 10.0 + 6.0 * np.sin(2 * np.pi * 0.5 * t) + rng.normal(0, 0.02, n)
    t_out = 0.6 * (10.0 + 6.0 * np.sin(2 * np.pi * 0.5 * t)) + rng.normal(0, 0.02, n)
    return t, t_in, t_out


def _write(path: Path, rows: list[str]) -> Path:
    path.write_text("\n".join(rows) + "\n")
    return path


# --- files people have ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("sep", "decimal"), [(";", ","), ("\t", ","), ("\t", "."), (";", ".")], ids=str
)
def test_semicolon_or_tab_separated_with_decimal_commas_reads_as_the_comma_file(
    tmp_path, sep, decimal
):
    t, a, b = _signals(200)
    plain = _write(
        tmp_path / "plain.csv",
        ["t_s,T_in_N,T_out_N"]
        + [f"{x:.4f},{y:.5f},{z:.5f}" for x, y, z in zip(t, a, b, strict=True)],
    )

    def cell(v: float, digits: int) -> str:
        return f"{v:.{digits}f}".replace(".", decimal)

    local = _write(
        tmp_path / "local.csv",
        [sep.join(["t_s", "T_in_N", "T_out_N"])]
        + [sep.join([cell(x, 4), cell(y, 5), cell(z, 5)]) for x, y, z in zip(t, a, b, strict=True)],
    )
    ref = trace.read_trace(plain, "measured")
    got = trace.read_trace(local, "measured")
    for name in ("t_s", "T_in_N", "T_out_N"):
        assert np.array_equal(ref[name], got[name]), name


@pytest.mark.parametrize("header_comma", [True, False])
def test_a_trailing_comma_on_every_row_is_an_empty_column_dropped(tmp_path, header_comma):
    t, a, b = _signals(100)
    head = "t_s,T_in_N,T_out_N" + ("," if header_comma else "")
    path = _write(
        tmp_path / "trail.csv",
        [head] + [f"{x:.4f},{y:.5f},{z:.5f}," for x, y, z in zip(t, a, b, strict=True)],
    )
    tr = trace.read_trace(path, "measured")
    assert np.allclose(tr["T_in_N"], np.round(a, 5))
    assert set(tr.columns) == {"t_s", "T_in_N", "T_out_N"}


def test_unix_epoch_times_start_at_zero_with_the_offset_kept(tmp_path):
    t, a, b = _signals(100)
    epoch = 1_732_000_000
    path = _write(
        tmp_path / "epoch.csv",
        ["t_s,T_in_N,T_out_N"]
        + [f"{epoch + x:.4f},{y:.5f},{z:.5f}" for x, y, z in zip(t, a, b, strict=True)],
    )
    tr = trace.read_trace(path, "measured")
    assert tr["t_s"][0] == 0.0
    assert np.allclose(tr["t_s"], t, atol=1e-9)
    assert tr.meta["t_s_epoch_offset_s"] == float(epoch)
    assert tr.meta["sample_rate_hz"] == pytest.approx(RATE_HZ, rel=1e-6)


def test_jittered_timestamps_are_refused_naming_resample_and_resampled_on_request(tmp_path):
    rng = np.random.default_rng(5)
    n = 2000
    t = np.cumsum(np.full(n, 1e-3) * (1.0 + 0.1 * rng.uniform(-1, 1, n)))
    t -= t[0]
    a = 10 + 6 * np.sin(2 * np.pi * 0.5 * t)
    path = _write(
        tmp_path / "pc.csv",
        ["t_s,T_in_N,T_out_N"]
        + [f"{x:.6f},{y:.5f},{0.6 * y:.5f}" for x, y in zip(t, a, strict=True)],
    )
    with pytest.raises(trace.TraceError, match="--resample"):
        trace.read_trace(path, "measured")
    tr = trace.read_trace(path, "measured", resample=True)
    assert "resampled" in tr.meta
    step = np.diff(tr["t_s"])
    assert np.allclose(step, step[0], rtol=1e-9)
    assert np.allclose(
        tr["T_out_N"], 0.6 * (10 + 6 * np.sin(2 * np.pi * 0.5 * tr["t_s"])), atol=2e-3
    )


def test_a_params_file_with_a_byte_order_mark_loads(tmp_path):
    path = tmp_path / "p.json"
    path.write_bytes(b"\xef\xbb\xbf" + json.dumps({"plant": {"mu": 0.09}}).encode())
    assert load_params(path).plant["mu"] == 0.09


# --- data that make no sense ----------------------------------------------------------------


def _record(folder: Path, t_in: np.ndarray, t_out: np.ndarray) -> Path:
    t = np.arange(len(t_in)) / RATE_HZ
    path = folder / "odd.csv"
    np.savetxt(
        path,
        np.column_stack([t, t_in, t_out]),
        fmt="%.6f",
        delimiter=",",
        header="t_s,T_in_N,T_out_N",
        comments="",
    )
    return path


@pytest.mark.parametrize("which", ["T_out_N", "T_in_N"])
@pytest.mark.parametrize("level", [0.0, 3.5])
def test_a_tension_that_does_not_move_is_refused_in_one_line(tmp_path, which, level):
    n = 12_000
    _, a, b = _signals(n)
    const = np.full(n, level)
    path = _record(tmp_path, const if which == "T_in_N" else a, const if which == "T_out_N" else b)
    with pytest.raises(core.AuditError, match=f"column {which} does not move"):
        core.prepare(trace.read_trace(path, "measured"), str(path))
    out = _bowden("audit", path.name, "--quiet", cwd=tmp_path)
    assert out.returncode == 2
    assert out.stderr.count("\n") == 1 and "does not move" in out.stderr, out.stderr
    assert not (tmp_path / "odd_audit").exists()


@pytest.mark.slow
def test_swapped_columns_are_warned_and_no_output_holds_inf_or_nan(tmp_path):
    n = 12_000
    _, a, b = _signals(n)
    path = _record(tmp_path, b, a)  # T_in and T_out swapped
    out = _bowden("audit", path.name, "--quiet", "--out", "rep", cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "are the columns swapped" in out.stdout
    for text in (out.stdout, (tmp_path / "rep" / "report.md").read_text()):
        words = text.replace("(", " ").replace(")", " ").replace(",", " ").split()
        assert not {"inf", "-inf", "nan", "NaN", "Infinity"} & set(words)
    data = json.loads(
        (tmp_path / "rep" / "audit.json").read_text(),
        parse_constant=lambda c: pytest.fail(f"{c} in audit.json"),
    )
    assert any("swapped" in w for w in data["warnings"])


def test_a_fitted_value_at_its_bound_is_a_warning():
    assert "at the lower bound" in plausible_at_bound("mu", 1e-4, 1e-4, 1.0)
    assert plausible_at_bound("mu", 0.08, 1e-4, 1.0) is None


def plausible_at_bound(*args):
    from cosim.audit import plausible  # noqa: PLC0415

    return plausible.at_bound(*args)


# --- signals and the output set -------------------------------------------------------------


class _Swallows:
    """An object whose __del__ receives the signal: Python prints its exception as ignored."""

    def __del__(self):
        os.kill(os.getpid(), signal.SIGTERM)


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")  # on purpose
def test_a_signal_whose_exception_a_del_swallowed_still_ends_the_command():
    cli._pending = None
    with pytest.raises(cli.Interrupted) as info:
        with cli._signals_interrupt():
            obj = _Swallows()
            del obj  # the handler raises inside __del__: "Exception ignored in ..."
            time.sleep(0.01)
            cli.check_interrupted()
    assert info.value.signum == signal.SIGTERM
    cli._pending = None


def test_ctrl_c_before_the_command_starts_is_one_line(monkeypatch, capsys):
    def interrupted():
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)
    assert cli.main(["audit", "x.csv"]) == 128 + signal.SIGINT
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "interrupted by SIGINT" in err


@pytest.mark.slow
def test_sigterm_during_the_audit_exits_143_and_leaves_no_half_set(tmp_path):
    from cosim.audit.synthetic import fmu_record  # noqa: PLC0415

    path = fmu_record(tmp_path, {"sensor_offset": 0.4}, seed=11, duration_s=30.0)
    proc = subprocess.Popen(
        [sys.executable, "-m", "cosim", "audit", path.name, "--out", "rep", "--quiet"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
    )
    time.sleep(4.0)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 128 + signal.SIGTERM, err[-2000:]
    assert "Traceback" not in err
    rep = tmp_path / "rep"
    # nothing of the set, or all of it: never report.md or plots without audit.json
    assert not rep.exists() or not any(p for p in rep.iterdir() if not p.name.startswith("."))
