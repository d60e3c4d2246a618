"""The emulator without the wall clock (cosim.bench.emulate.emulator.SteppedLink) records what the
real-time emulator records over its pty, sample for sample; `bowden emulate --plant` sets the
emulated plant's FMU parameters, each checked, a bad one refused in one line."""

import numpy as np
import pytest

from cosim.bench.__main__ import main as bench_cli
from cosim.bench.emulate.emulator import Emulator, SteppedLink
from cosim.bench.emulate.host_device import ChainConfig
from cosim.bench.link.client import BenchClient, SerialLink
from cosim.bench.link.recorder import record_run
from cosim.results import trace as trace_mod

SECONDS = 1.5
RUN = {"waveform": "sine", "mean_n": 8.5, "amplitude_n": 6.5, "freq_hz": 2.0}
# The faults column is compared where no clock is involved: a loaded machine may make the
# real-time emulator late (OVERRUN) or its link full (TX_OVERFLOW).
COMPARED = ("t_s", "T_ref_N", "T_c_N", "T_in_N", "T_out_N", "current_A", "sample")


def _record(link, path, real_time: bool = False):
    client = BenchClient(link)
    client.connect()
    result = record_run(client, path, seconds=SECONDS, **RUN)
    if real_time:  # a loaded machine may drop frames of the real-time link: counted, not filled
        assert result.samples >= 0.9 * SECONDS * 1000, result.summary()
        return np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2), path.read_text()
    assert result.drops == 0 and result.samples == int(SECONDS * 1000), result.summary()
    return trace_mod.read_trace(path)


@pytest.mark.parametrize("plant", [None, {"sensor_offset": 0.5}])
def test_stepped_link_records_what_the_real_time_emulator_records(plant, tmp_path):
    emu = Emulator(tcp_port=None, chain=ChainConfig(plant=plant)).start()
    link = SerialLink(emu.urls["pty"])
    try:
        rows, text = _record(link, tmp_path / "real.csv", real_time=True)
    finally:
        link.close()
        emu.stop()
    stepped_link = SteppedLink(ChainConfig(plant=plant))
    try:
        stepped = _record(stepped_link, tmp_path / "stepped.csv")
    finally:
        stepped_link.close()
    header = text.splitlines()[0].split(",")
    real = {name: rows[:, i] for i, name in enumerate(header)}
    idx = real["sample"].astype(int)  # the samples the real-time link delivered
    assert real["T_out_N"].max() > 5.0  # the plant did pull
    for col in COMPARED:
        np.testing.assert_array_equal(stepped[col][idx], real[col], err_msg=col)
    assert not np.any(stepped["faults"])


@pytest.mark.parametrize("engine", ["native", "python"])
def test_the_online_estimate_is_recorded_and_finds_the_plants_friction(engine, tmp_path):
    """With `est.enable` on, the recording's mu_phi column is the estimate the compensator
    applies: on a plant whose mu (0.09) is 20 % above the configured 0.075 it leaves the
    configured 0.471 and settles at the plant's mu*phi, 0.565 (loop routing: phi = 2 pi), within
    3 % after 3 s of a 2 Hz sine, with no fault bit."""
    link = SteppedLink(ChainConfig(plant={"mu": 0.09}), engine=engine)
    try:
        client = BenchClient(link)
        client.connect()
        client.set("est.enable", 1)
        result = record_run(client, tmp_path / "est.csv", seconds=4.0, **RUN)
    finally:
        link.close()
    assert result.drops == 0, result.summary()
    tr = trace_mod.read_trace(tmp_path / "est.csv")
    assert abs(tr["mu_phi"][0] - 0.075 * 2 * np.pi) <= 2.0**-14
    late = tr["mu_phi"][tr["t_s"] >= 3.0]
    np.testing.assert_allclose(late, 0.09 * 2 * np.pi, rtol=0.03)
    assert not np.any(tr["est_faults"])


@pytest.mark.parametrize(
    ("args", "words"),
    [
        ("sensor_offset=x", "--plant 'sensor_offset=x': 'x' is not a number"),
        ("=3", "expected NAME=VALUE"),
        ("foo=1", "'foo' is not a parameter of the FMU"),
        ("drive_mode=1", "fixed by the closed loop"),
        ("seed=1.5", "--plant.seed must be a whole number"),
        ("sensor_offset=nan", "--plant.sensor_offset must be in [-100, 100]; got NaN"),
        # a second value used to win silently
        ("mu=0.09,mu=0.12", "--plant mu=0.09 and mu=0.12: mu given twice"),
        ("mu=0.09, mu =0.12", "--plant mu=0.09 and mu=0.12: mu given twice"),
        ("mu=0.09,", "--plant 'mu=0.09,': an empty item; expected NAME=VALUE[,...]"),
    ],
)
def test_emulate_plant_option_refuses_a_bad_value_in_one_line(args, words, capsys):
    rc = bench_cli(["emulate", "--no-pty", "--no-tcp", "--seconds", "0.1", "--plant", args])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and words in err, err


def test_emulate_plant_option_sets_the_plant(capsys):
    rc = bench_cli(
        [
            "emulate",
            "--no-pty",
            "--no-tcp",
            "--seconds",
            "0.1",
            "--plant",
            "sensor_offset=0.25,noise_std=0.01",
            "--plant",
            "seed=7",
        ]
    )
    out = capsys.readouterr().out
    assert rc == 0 and "set: sensor_offset=0.25 noise_std=0.01 seed=7" in out, out


def test_bench_emulate_without_a_link_records_the_stepped_emulator(tmp_path, capsys):
    """`bowden bench --emulate` alone: the stepped emulator with the run's --position and the
    --plant given, the same recording as SteppedLink's."""
    out = tmp_path / "cli.csv"
    args = ["bench", "--emulate", "--plant", "sensor_offset=0.5", "run", "sine", "--freq", "2"]
    rc = bench_cli([*args, "--seconds", str(SECONDS), "--out", str(out), "--quiet"])
    text = capsys.readouterr()
    assert rc == 0, text.err
    assert f"{int(SECONDS * 1000)} samples of {int(SECONDS * 1000)}, drops 0" in text.out
    link = SteppedLink(ChainConfig(plant={"sensor_offset": 0.5}))
    try:
        want = _record(link, tmp_path / "stepped.csv")
    finally:
        link.close()
    got = trace_mod.read_trace(out)
    for col in (*COMPARED, "faults"):
        np.testing.assert_array_equal(got[col], want[col], err_msg=col)


@pytest.mark.parametrize(
    ("args", "rc", "words"),
    [
        (["--port", "x", "--plant", "sensor_offset=0.5", "info"], 2, "it needs --emulate"),
        (["--emulate", "--port", "x", "info"], 2, "--emulate works with --can or alone"),
        (["--emulate", "--plant", "nope=1", "info"], 2, "'nope' is not a parameter of the FMU"),
        # one parameter given twice, in one --plant or in two: refused, not the last one taken
        (["--emulate", "--plant", "mu=0.09,mu=0.12", "get"], 2, "mu given twice"),
        (
            ["--emulate", "--plant", "mu=0.09", "--plant", "mu=0.12", "calibrate", "--out", "c"],
            2,
            "--plant mu=0.09 and mu=0.12: mu given twice; give each parameter once",
        ),
    ],
)
def test_bench_emulate_options_refuse_in_one_line(args, rc, words, capsys):
    got = bench_cli(["bench", *args])
    err = capsys.readouterr().err.strip()
    assert got == rc and len(err.splitlines()) == 1 and words in err, err
