"""The sensing study (cosim.studies.sensing): the causes behind its decision hold, on short runs.

The decision in hdl/README.md ("Sensing") rests on three measured causes: the ADS131M02's
sample is younger at every tick than the ADS1220's, that costs less error right after the
reversals, and it leaves the loop more Kp headroom. Each is checked here on a short run."""

from __future__ import annotations

import subprocess
import sys

import pytest

from cosim.studies.sensing import study

CFG = study.study_config()  # the gains the decision was made with


def test_ads131m02_sample_is_younger_than_the_ads1220s():
    """Mean age at a loop step: the ADS131M02's sinc3 delay (1.5 x 31.25 us) plus its reader and
    at most one 10 kHz tick, against the ADS1220's half period (0.25 ms) plus about half of
    its 0.5 ms hold; the DRDY-run loop drops the hold but not the filter's delay."""
    age = {o: study.sample_age_s(o, CFG) for o in study.OPTIONS}
    assert age["ideal"] == 0.0
    m02 = study.ADC_PARTS["ads131m02"].period_s
    assert age["ads131m02"] < 1.5 * m02 + 40e-6 + 1.0 / CFG.sample_rate_hz, age
    assert age["ads1220"] > 0.45e-3, age
    assert age["ads131m02"] < age["ads1220-drdy"] < age["ads1220"], age


@pytest.fixture(scope="module")
def near_reversal_rms_n():
    """RMS error after the reversals of 4 s of fig14 (three reversals past the settling), paper
    compensator, per option."""
    return {
        o: study.run_one(o, "fig14", "paper", CFG, duration_s=4.0).rms_near_reversal_n
        for o in ("ideal", "ads1220", "ads131m02")
    }


def test_ads131m02_costs_less_error_near_reversals(near_reversal_rms_n):
    """Near the reversals, where the compensator's T_c jumps, the older ADS1220 sample costs
    error over the ideal ADC; the ADS131M02 gives back most of it (30 s fig14: 1.64 and
    1.46 N against 1.42 N ideal)."""
    r = near_reversal_rms_n
    assert r["ideal"] < r["ads131m02"] < r["ads1220"], r
    # At least half of the ADS1220's cost over the ideal ADC is recovered.
    assert r["ads131m02"] - r["ideal"] < 0.5 * (r["ads1220"] - r["ideal"]), r


def test_ads131m02_leaves_more_kp_headroom():
    """Between the two margins measured by the study (ADS1220 3.1 x, ADS131M02 5.8 x): at 4.5 x
    Kp the ADS1220 loop keeps a limit cycle, the ADS131M02 one settles; at the default Kp both
    settle."""
    phi = study.resolve_phi(study._probe(), CFG, True)
    assert study.settles("ads1220", CFG, 1.0, phi)
    assert study.settles("ads131m02", CFG, 1.0, phi)
    assert not study.settles("ads1220", CFG, 4.5, phi)
    assert study.settles("ads131m02", CFG, 4.5, phi)


def test_drdy_loop_scales_the_integral_gain_to_the_conversion_period():
    """Run on DRDY, the loop steps once per conversion: Ki*Ts per step is Ki times the ADS1220's
    period, so that Ki in A/(N s) is the one configured."""
    _, loop10k = study.make_option("ads1220", CFG)
    _, drdy = study.make_option("ads1220-drdy", CFG)
    period = study.ADC_PARTS["ads1220"].period_s
    assert drdy.loop.ki_ts_a_per_n == pytest.approx(loop10k.ki_ts_a_per_n * period * 1e4)


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--duration", "1"], "--duration: must be in [2, 3600] s"),
        (["--duration", "nan"], "expected a finite number"),
        (["--scenario", "nope"], "invalid choice: 'nope'"),
    ],
)
def test_cli_bad_input_is_one_line(args, needle):
    """Bad options: one line on stderr, exit status 2, nothing run."""
    r = subprocess.run(
        [sys.executable, "-m", "cosim.studies.sensing", *args],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 2, r.stderr
    assert needle in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert r.stdout == ""
