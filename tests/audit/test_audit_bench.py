"""The audit on the bench emulator's own recordings: the recording that
`bowden emulate` + `bowden bench run sine` make (the in-process stepped link gives the same
file, sample for sample, in a fraction of real time), of a plant without effects, must give no
finding; with an effect switched on in the emulator's plant, the audit must name it.

The emulator's loop runs the paper's compensator, whose feedforward switches at each reversal:
T_in drops by about 15 N within 10 ms. The audit's input smoothing used to ring across those
drops and the friction model held the ringing's extremes: 0.13 N of residual and four confident
findings on a plant that had none (cosim.audit.core.smooth_input)."""

from __future__ import annotations

import audit_cache
import numpy as np
import pytest
from scipy.signal import savgol_filter

from cosim.audit import core
from cosim.bench.emulate.emulator import SteppedLink
from cosim.bench.emulate.host_device import ChainConfig
from cosim.bench.link.client import BenchClient
from cosim.bench.link.recorder import record_run

# The audit needs 10 s (1 s of warm-up: the loop starts from rest). With 12 s the default
# blocks (0.5 s) would lock to the 0.5 Hz sine (a 2 s fit/selection/fit/report cycle): the
# audit moves them off its period (core.PERIODIC_MIN_R).
SECONDS = 12.0
# Measured on these recordings: 4.9 mN held-out (report blocks) RMS without an effect, 5.6 mN
# unexplained (selection and report blocks), 4.2 mN on the report blocks once the offset is
# taken out (the 1 kHz telemetry samples an input that the plant sees at 10 kHz: driven by the
# 10 kHz T_in the twin matches to 2e-5 N). Budget: the largest, with a margin of 1.6.
RESIDUAL_BUDGET_N = 0.009
OFFSET_N = 0.5
# The plant's mu where the compensator (and the recording's sidecar, "mu_source": "compensator")
# says 0.075: taken as known, it made the audit name four causes the plant does not have.
PLANT_MU = 0.09


def _record(folder, plant: dict | None):
    link = SteppedLink(ChainConfig(plant=plant))
    try:
        client = BenchClient(link)
        client.connect()
        path = folder / "rec.csv"
        result = record_run(
            client,
            path,
            seconds=SECONDS,
            waveform="sine",
            mean_n=8.5,
            amplitude_n=6.5,
            freq_hz=0.5,
        )
    finally:
        link.close()
    assert result.drops == 0 and result.samples == int(SECONDS * 1000)
    return path


@pytest.fixture(scope="module")
def audits(tmp_path_factory, test_cache_dir):
    out = {}
    cases = (("none", None), ("offset", {"sensor_offset": OFFSET_N}), ("mu", {"mu": PLANT_MU}))
    for name, plant in cases:
        path = _record(tmp_path_factory.mktemp(name), plant)
        out[name] = audit_cache.audit(path, test_cache_dir)
    return out


def test_emulator_recording_without_effects_gives_no_finding(audits):
    res = audits["none"]
    found = [(f.effect.cause, f.value, f.evidence) for f in res.findings]
    assert found == []
    assert res.holdout_rms_before_n <= RESIDUAL_BUDGET_N
    assert res.unexplained["rms_n"] <= RESIDUAL_BUDGET_N
    # the sine's harmonics in the residual are the input's, and under one LSB: no line
    # (cosim.audit.lines)
    assert res.data.lines == () and res.unexplained["lines"] == []
    # the compensator's drops at the reversals were kept as recorded, not smoothed over
    d = res.data
    assert np.max(np.abs(np.diff(d.t_in_meas_n))) > 1.0
    kept = d.inputs.t_in_n == d.t_in_meas_n
    assert 0 < d.input_kept <= np.count_nonzero(kept) < 0.5 * len(kept)
    # the blocks see the whole period of the sine, not one phase of it
    assert core.input_period_s(d.t_in_meas_n[1000:], d.rate_hz) == pytest.approx(2.0, abs=2e-3)
    assert d.block_s != 0.5 and "0.50 s would put" in d.split_text()
    assert core.phase_coverage(d.roles, d.rate_hz, 2.0) >= core.COVER_MIN


def test_emulator_recording_with_a_sensor_offset_names_it(audits):
    res = audits["offset"]
    assert [f.effect.cause for f in res.findings] == ["sensor_offset"]
    assert res.findings[0].value == pytest.approx(OFFSET_N, abs=0.01)
    # the baseline shows the offset (mu, fitted, takes a little of it)
    assert res.holdout_rms_before_n == pytest.approx(OFFSET_N, abs=0.03)
    assert res.holdout_rms_after_n <= RESIDUAL_BUDGET_N


def test_smoothing_keeps_a_step_and_removes_noise():
    """smooth_input: white noise is filtered, a 10 N drop within 10 ms is kept without the
    Savitzky-Golay filter's overshoot, and a smooth record stays wholly filtered."""
    rng = np.random.default_rng(5)
    n, rate, sigma = 4000, 1000.0, 0.03
    t = np.arange(n) / rate
    clean = 10.0 + 2.0 * np.sin(2 * np.pi * 0.3 * t)
    clean[2000:] -= 10.0 * np.minimum(1.0, np.arange(n - 2000) / 10.0)
    noisy = clean + rng.normal(0.0, sigma, n)
    win = 41
    out, kept = core.smooth_input(noisy, win, core.noise_std(noisy))
    assert 0 < kept <= 3 * win
    err = out - clean
    far = np.abs(np.arange(n) - 2005) > win
    assert np.std(err[far]) < 0.5 * sigma  # filtered where smooth
    assert np.max(np.abs(err)) < 5 * sigma  # no ringing across the drop
    sg = savgol_filter(noisy, win, core.SMOOTH_ORDER)
    assert np.max(np.abs(sg - clean)) > 0.3  # what the plain filter does there
    smooth_only = clean[:1900] + rng.normal(0.0, sigma, 1900)
    _, kept = core.smooth_input(smooth_only, win, core.noise_std(smooth_only))
    assert kept == 0


def test_blocks_stay_as_they_are_unless_a_periodic_input_locks_them():
    """_roles: a random bench session (cosim.audit.synthetic.session: three incommensurate sines,
    fewer than MIN_PERIODS repeats) keeps the default blocks; a 0.5 Hz sine of 12 s has them moved
    off its period, by the least change that lets the held-out blocks see its phase."""
    from cosim.audit.synthetic import session  # noqa: PLC0415

    rate = 1000.0
    for seed in (101, 105, 900):
        _, t_in, _ = session(seed, 40.0)
        roles, block_s, note = core._roles(len(t_in), rate, t_in)
        assert note == "" and block_s == pytest.approx(39.0 / core.BLOCK_TARGET_COUNT)
    t = np.arange(12_000) / rate
    sine = 8.5 + 6.5 * np.sin(np.pi * t)
    roles, block_s, note = core._roles(len(t), rate, sine)
    assert core.phase_coverage(core._pattern(len(t), rate, 1000, 0.5), rate, 2.0) == 0.25
    assert 0.5 < block_s <= 0.65 and note
    assert core.phase_coverage(roles, rate, 2.0) >= core.COVER_MIN
    assert core.input_period_s(np.random.default_rng(1).normal(size=5000), rate) is None


def test_emulator_recording_of_a_plant_whose_mu_the_compensator_does_not_know(audits):
    """The sidecar's mu is the compensator's setting: the audit fits the plant's own and finds
    nothing else."""
    res = audits["mu"]
    assert res.data.mu_from_compensator and res.data.mu_given is None
    assert res.baseline.params["mu"] == pytest.approx(PLANT_MU, abs=5e-4)
    assert [(f.effect.cause, f.value) for f in res.findings] == []
    assert res.holdout_rms_before_n <= RESIDUAL_BUDGET_N
