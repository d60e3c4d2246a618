"""`bowden workspace --out DIR`: both Fig. 8 maps as PNG and the spread of phi printed."""

from __future__ import annotations

import re
import subprocess
import sys

from cosim.cli import main


def test_workspace_command_draws_both_maps_and_prints_spread(tmp_path, capsys):
    assert main(["workspace", "--out", str(tmp_path), "--grid", "15"]) == 0
    printed = capsys.readouterr().out
    for name in ("workspace_free.png", "workspace_loop.png"):
        data = (tmp_path / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    rows = {
        m.group(1): [float(v) for v in m.group(2).split()]
        for m in re.finditer(r"^(free sag|loop routing)\s+(.*)$", printed, re.M)
    }
    free, loop = rows["free sag"], rows["loop routing"]
    # columns: points, std, P5-P95, min, max, mean |err| %
    assert free[0] == loop[0] > 500
    assert loop[1] < 0.5 * free[1]
    assert abs(loop[3] - 6.283) < 1e-3  # phi >= 2*pi with the loop, = 2*pi on its plane
    assert free[3] == 0.0


def test_workspace_command_rejects_bad_length(tmp_path):
    res = subprocess.run(
        [sys.executable, "-m", "cosim", "workspace", "--out", str(tmp_path), "--length", "-1"],
        capture_output=True,
        text=True,
    )
    assert res.returncode == 2
    # Errors go to stderr, one line, with the allowed range.
    assert res.stdout == ""
    assert res.stderr == "bowden workspace: --length must be in [0.01, 10] m; got -1.0\n"


def test_workspace_length_range_is_the_fmus_sheath_length_range(fmu_path):
    from cosim.parts.plant import fmu_variables
    from cosim.studies.workspace import LENGTH_RANGE_M

    var = fmu_variables(fmu_path)["sheath_length"]
    assert LENGTH_RANGE_M == (var.lo, var.hi)
    assert main(["workspace", "--out", "x", "--length", "1e300"]) == 2
