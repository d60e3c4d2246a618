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
