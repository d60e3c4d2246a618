"""The gradual dead zone (fmu/README.md, "Gradual dead zone"): with dead_zone_spread the output
turns gradually after a reversal instead of holding until the sharp corner, and once every
strand slides the slopes are the strands' mean capstan factors."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import norm

from cosim.audit import twin
from cosim.parts.plant import Plant

MU = 0.08
PHI = 2.0 * math.pi  # loop routing in the loop's plane (x = 0)


def _run(spread: float, t_in: np.ndarray) -> np.ndarray:
    params = {"drive_mode": 1, "mu": MU, "dead_zone_spread": spread}
    out = np.empty(len(t_in))
    with Plant(params, inputs={"T_in_cmd": float(t_in[0]), "x": 0.0, "y": 0.5, "z": 0.0}) as p:
        out[0] = p.y[p.T_OUT]
        for k in range(1, len(t_in)):
            p.u[1] = float(t_in[k])
            out[k] = p.step(1e-3)[p.T_OUT]
    return out


def _strand_factors(spread: float, sign: float) -> float:
    n = twin.N_STRAND
    q = norm.ppf((np.arange(n) + 0.5) / n)
    return float(np.mean(np.exp(sign * MU * PHI * np.exp(spread * q))))


def test_the_c_quantile_table_is_the_twins():
    """The FMU's strand count and quantile table (written out in C, which has no normal
    quantile function) are the twin's, computed by scipy: the same thresholds to the last bits."""
    src = Path(__file__).resolve().parents[2] / "fmu" / "src"
    header = (src / "bowden_physics.h").read_text()
    count = int(re.search(r"#define BOWDEN_N_STRAND (\d+)", header).group(1))
    body = re.search(
        r"STRAND_Q\[BOWDEN_N_STRAND\] = \{([^}]*)\}", (src / "bowden_physics.c").read_text()
    )
    table = np.array([float(v) for v in body.group(1).split(",")])
    assert count == twin.N_STRAND == len(table)
    assert np.allclose(table, twin.STRAND_Q, rtol=1e-15, atol=0.0)
    assert np.all(np.diff(table) > 0) and np.allclose(table, -table[::-1], rtol=0, atol=1e-16)


@pytest.mark.parametrize("spread", [0.3, 0.8])
def test_slopes_are_the_strands_mean_and_the_turn_is_gradual(spread):
    up = np.linspace(2.0, 20.0, 1801)
    # the widest strand (q = 2.15) at spread 0.8 slides back below 20 N exp(-2 w) = 0.071 N
    down = np.linspace(20.0, 0.05, 1801)[1:]
    t_in = np.concatenate([up, down])
    sharp = _run(0.0, t_in)
    soft = _run(spread, t_in)
    # loading from rest: every strand slides, T_out = T_in * mean exp(-w_j)
    assert soft[900] == pytest.approx(up[900] * _strand_factors(spread, -1.0), rel=1e-9)
    # far into the unloading every strand slides back: T_out = T_in * mean exp(+w_j)
    assert soft[-1] == pytest.approx(down[-1] * _strand_factors(spread, +1.0), rel=1e-9)
    # the sharp model holds T_out after the reversal until T_in falls to 20 N exp(-2 mu phi)
    # = 7.4 N; the strands with the lowest thresholds slide back before (from 20 N
    # exp(-2 mu phi exp(spread q_0)): 10.6 N at spread 0.3, 16.1 N at 1.0)
    after = len(up) + int(np.argmin(np.abs(down - 9.0)))
    assert sharp[after] == pytest.approx(sharp[len(up) - 1], abs=1e-12)
    assert soft[after] < soft[len(up) - 1] - 1e-3
