"""The four effects appended to the FMU (fmu/README.md "Static friction", "Slack", "Sensor
saturation", "Load-cell creep"), each against its written law in drive mode 1 at a fixed
position in the loop's plane (phi = 2 pi), without noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.parts.plant import Plant

MU = 0.08
PHI = 2.0 * math.pi


def _run(params: dict, t_in: np.ndarray, output: str = "T_out") -> np.ndarray:
    out = np.empty(len(t_in))
    full = {"drive_mode": 1, "mu": MU, **params}
    with Plant(full, inputs={"T_in_cmd": float(t_in[0]), "x": 0.0, "y": 0.5, "z": 0.0}) as p:
        idx = p.T_OUT if output == "T_out" else p.T_OUT_MEAS
        out[0] = p.y[idx]
        for k in range(1, len(t_in)):
            p.u[1] = float(t_in[k])
            out[k] = p.step(1e-3)[idx]
    return out


def test_static_friction_holds_longer_after_a_reversal_then_jumps_to_the_kinetic_bound():
    excess = 0.02
    up = np.linspace(5.0, 20.0, 1501)
    down = np.linspace(20.0, 5.0, 1501)[1:]
    t_in = np.concatenate([up, down])
    kinetic = _run({}, t_in)
    stick = _run({"mu_static_excess": excess}, t_in)
    # loading from rest and sliding on: the kinetic law, untouched
    assert np.allclose(stick[:1501], kinetic[:1501], rtol=1e-12)
    # after the reversal at 20 N the sharp model slides back once T_in < T_out exp(-mu phi);
    # with static friction it holds until T_in < T_out exp(-(mu + excess) phi)
    held = kinetic[1500]
    k_kin = 1501 + int(np.argmax(down < held * math.exp(-MU * PHI)))
    k_st = 1501 + int(np.argmax(down < held * math.exp(-(MU + excess) * PHI)))
    assert k_st > k_kin + 50
    assert np.all(stick[1500:k_st] == pytest.approx(held, rel=1e-12))
    # the jump: from the held value down to the release bound T_in exp(+mu phi)
    assert stick[k_st] == pytest.approx(t_in[k_st] * math.exp(MU * PHI), rel=1e-9)
    assert held - stick[k_st] > 0.05 * held


@pytest.mark.parametrize(
    "effects",
    [
        {"mu_static_excess": 0.037, "mu_tension_slope": 1.1e-3},
        {"mu_static_excess": 0.037, "mu_tension_slope": -1.1e-3},
        {"mu_static_excess": 0.03, "dead_zone_spread": 0.3, "mu_tension_slope": 1.2e-3},
    ],
)
def test_a_breakaway_with_a_tension_slope_never_moves_the_output_against_the_input(effects):
    """A released cable cannot raise the tension at a fixed far end, nor a pulled one lower it
    (friction only takes tension away from the motion). The strands turn the output through the
    dead zone as a ratio to the reference strand, so their widths must follow the tension as the
    sheath's segments do: at the slope-free widths the output rose 23 % above its level at the
    reversal while the input fell. Up to 24 N, down to 3 N and up again, 1 kHz."""
    up = np.linspace(5.0, 24.0, 1001)
    down = np.linspace(24.0, 3.0, 1001)[1:]
    again = np.linspace(3.0, 24.0, 1001)[1:]
    t_in = np.concatenate([up, down, again])
    out = _run(effects, t_in)
    top, bottom = out[1000], out[2000]
    # 0.1 %: the strands take the whole bend's sloped capstan where the segments step it (the
    # discretisation's difference, about 0.05 % here)
    assert out[1000:2001].max() <= top * 1.001, out[1000:2001].max() / top
    assert out[2000:].min() >= bottom * 0.999, out[2000:].min() / bottom
    # and the output does go through the breakaway's jump on both branches
    assert out[2000] < 0.6 * top and out[-1] > 1.5 * bottom


def test_slack_scales_the_output_below_its_input_tension():
    t_in = np.linspace(1.0, 12.0, 1101)
    plain = _run({}, t_in)
    slack = _run({"slack_tension": 6.0}, t_in)
    expected = plain * np.minimum(1.0, t_in / 6.0)
    assert np.allclose(slack, expected, rtol=1e-12)
    assert slack[0] == pytest.approx(plain[0] / 6.0)


@pytest.mark.parametrize("knee", [0.0, 1.5])
def test_the_output_sensor_saturates_at_its_full_scale(knee):
    t_in = np.linspace(1.0, 24.0, 2301)
    true = _run({}, t_in)
    fs = 10.0
    meas = _run({"sensor_full_scale": fs, "sensor_saturation_knee": knee}, t_in, "T_out_meas")
    if knee == 0.0:
        assert np.allclose(meas, np.minimum(true, fs), rtol=1e-12)
        assert meas.max() == fs
    else:
        shift = 0.5 * (math.sqrt(fs * fs + knee * knee) - fs)
        sat = 0.5 * (true + fs - np.sqrt((true - fs) ** 2 + knee * knee)) + shift
        assert np.allclose(meas, sat, rtol=1e-12)
        assert meas.max() < fs + shift  # the asymptote
        assert meas[0] == pytest.approx(true[0], abs=0.02)  # far below: nearly linear


@pytest.mark.parametrize("creep", [0.05, -0.04])
def test_a_creeping_load_cell_reads_a_step_short_then_approaches_it(creep):
    tau = 0.5
    t_in = np.concatenate([np.full(100, 5.0), np.full(3000, 15.0)])
    true = _run({}, t_in)
    meas = _run({"sensor_creep": creep, "sensor_creep_tau": tau}, t_in, "T_out_meas")
    step = true[150] - true[50]
    assert meas[50] == pytest.approx(true[50], rel=1e-12)  # settled before the step
    # right after the step it reads (1 - creep) of it, then creeps with tau
    t = (np.arange(100, 3100) - 99) * 1e-3
    expected = true[100:] - creep * step * np.exp(-t / tau)
    assert np.allclose(meas[100:], expected, atol=1e-9 * step)
    assert meas[-1] == pytest.approx(true[-1], abs=1e-3 * step)
