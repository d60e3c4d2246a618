"""One short closed loop for `make test-quick`: `bowden sim fig14 --engine native` for 1 s, the
compiled loop with the firmware library and the plant FMU (no Verilator build), checked as
`make test` checks the longer runs: every sample, no late T_c write, the fixed-point current
within the board's budget of its float twin, and a tracking error of the paper's order."""

from __future__ import annotations

import json
import subprocess
import sys


def test_one_second_of_fig14_on_the_native_engine(tmp_path):
    out = tmp_path / "run"
    proc = subprocess.run(
        [sys.executable, "-m", "cosim", "sim", "fig14", "--engine", "native"]
        + ["--duration", "1", "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    result = json.loads((out / "result.json").read_text())
    assert result["engine"] == "native" and result["samples"] == 10_000
    assert result["checks"]["late_tc_writes"] == 0
    assert result["fixed_vs_float"]["current_max_lsb"] <= 20  # tests/cosim's board budget
    print(json.dumps({k: result[k] for k in result if "rms" in k or "peak" in k}))


def test_the_native_build_is_not_reused_from_another_checkout(tmp_path, monkeypatch):
    """libbowden_native.so links this checkout's firmware library by an absolute rpath, so its
    fingerprint names that library's path: a build folder copied or moved with the same sources
    next to another checkout's firmware library is built again, not run against the first one."""
    from cosim.engines.native import build  # noqa: PLC0415

    here = build.fingerprint()
    other = tmp_path / "firmware" / "host" / build.FW_LIB.name
    other.parent.mkdir(parents=True)
    other.write_bytes(build.FW_LIB.read_bytes())  # the same library, elsewhere
    monkeypatch.setattr(build, "FW_LIB", other)
    assert build.fingerprint() != here
