"""The Python API (`cosim.bench.api.Bench`) on the emulator: a session as a context manager,
parameters by name in SI units, a run's arrays and trace file, faults, persistence, the device
stopped however a session ends; the README's worked example run as written; the API docs built
by pdoc without a warning."""

import re
import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest

from cosim.bench.api import Bench, Faults, ProtocolError
from cosim.bench.emulate.emulator import Emulator
from cosim.bench.link import messages as msgs
from cosim.bench.link.client import BenchClient, BenchError, BenchUsageError, SerialLink
from cosim.project.paths import REPO_ROOT
from cosim.results import trace as trace_mod


@pytest.fixture(scope="module")
def emulator():
    emu = Emulator(tcp_port=0, pty=False).start()
    yield emu
    emu.stop()


def test_parameters_by_name_in_si_units():
    with Bench(emulate=True) as b:
        info = b.info()
        assert (info.proto_version, info.table_hash) == (msgs.PROTOCOL_VERSION, msgs.TABLE_HASH)
        now = b.set(loop_kp=0.07, comp_mode="smooth", **{"comp.band_n": 1})
        assert now == {"loop.kp": 0.0699462890625, "comp.mode": "smooth", "comp.band_n": 1.0}
        assert b.get("loop.kp", "comp_mode") == {"loop.kp": 0.0699462890625, "comp.mode": "smooth"}
        every = b.get()
        assert list(every) == [p.name for p in msgs.PARAMS] and every["tick_rate_hz"] == 1000
        assert b.info().dirty and b.info().config_source == "defaults"
        # Checked before anything is sent: the first (good) value is not written either.
        with pytest.raises(ProtocolError, match="comp.mode=fast: expected one of"):
            b.set(loop_kp=0.2, comp_mode="fast")
        assert b.get("loop.kp")["loop.kp"] == 0.0699462890625
        with pytest.raises(ProtocolError, match="unknown parameter 'loop.nope'"):
            b.set(loop_nope=1)
        with pytest.raises(ProtocolError, match="tick_rate_hz is read-only"):
            b.set(tick_rate_hz=500)
        assert b.persist() >= 1
        assert b.info().config_source == "flash" and not b.info().dirty
        f = b.faults()
        assert isinstance(f, Faults) and not f and f.fpga == [] and f.device == []


def test_run_returns_arrays_and_the_trace_file(tmp_path):
    with Bench(emulate=True) as b:
        run = b.run("sine", 1.5, out=tmp_path / "s.csv", mean_n=8, amplitude_n=4, freq_hz=1)
        assert (run.samples, run.expected, run.drops, run.complete) == (1500, 1500, 0, True)
        tr = trace_mod.read_trace(run.trace)  # a valid trace file
        for col in ("t_s", "T_ref_N", "T_c_N", "T_in_N", "T_out_N", "current_A"):
            np.testing.assert_array_equal(run[col], tr[col])
        np.testing.assert_array_equal(run["sample"], np.arange(1500))
        assert run["T_ref_N"].max() == pytest.approx(12.0, abs=0.01)
        assert run.faults == []
        ref = 5.0 + 2.0 * np.sin(np.arange(800) / 100.0)
        seen = []
        run = b.run(ref, 0.8, on_telemetry=lambda t: seen.append(t["sample"]))
        # without `out` the trace goes to a folder of its own in the temp folder
        folder = run.trace.parent
        assert folder.parent == Path(tempfile.gettempdir()) and run.trace.exists()
        assert run.complete
        np.testing.assert_allclose(run["T_ref_N"], np.round(ref * 256) / 256, atol=0)
        assert seen == list(range(800))
        shutil.rmtree(folder)
        with pytest.raises(ProtocolError, match="waveform 'square'"):
            b.run("square", 1.0)


def test_the_device_is_stopped_however_the_session_ends(emulator, tmp_path):
    url = emulator.urls["socket"]
    with pytest.raises(RuntimeError, match="script failed"):
        with Bench(url) as b:
            b.client.set("source", "wave")
            b.client.simple("START", duration_ticks=msgs.START_DURATION["CONTINUOUS"])
            assert b.info().running
            raise RuntimeError("script failed")
    probe = BenchClient(SerialLink(url))
    assert not probe.hello().running
    probe.link.close()

    def interrupt(t):
        if t["sample"] == 300:
            raise KeyboardInterrupt

    with Bench(url) as b:
        with pytest.raises(KeyboardInterrupt):
            b.run("sine", 30.0, out=tmp_path / "stopped.csv", on_telemetry=interrupt)
        # the session's own link (the port is locked to it): stopped at once, not after 30 s
        assert not b.info().running


def test_bad_sessions_are_one_line(tmp_path):
    with pytest.raises(BenchError, match="give a port"):
        Bench()
    with pytest.raises(BenchError, match="not both"):
        Bench("x", can="virtual:x")
    with pytest.raises(BenchError, match=f"--port {tmp_path}/nope: cannot open"):
        Bench(str(tmp_path / "nope"))


def _readme_example() -> str:
    text = (REPO_ROOT / "cosim" / "bench" / "README.md").read_text()
    m = re.search(r"## Python API.*?```python\n(.*?)```", text, re.S)
    assert m, "cosim/bench/README.md has a Python API section with a python block"
    return m.group(1)


def test_readme_worked_example_runs_as_written(tmp_path, monkeypatch, capsys):
    """The README's example, on the in-process emulator (its only change: the port)."""
    code = _readme_example()
    assert 'Bench("/dev/ttyUSB0")' in code
    monkeypatch.chdir(tmp_path)
    exec(
        compile(code.replace('Bench("/dev/ttyUSB0")', "Bench(emulate=True)"), "README", "exec"), {}
    )
    out = capsys.readouterr().out
    assert "samples 2000 of 2000" in out and (tmp_path / "sine.csv").exists()


def test_api_docs_build_without_warnings(tmp_path):
    import pdoc

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        pdoc.pdoc("cosim.bench.api", output_directory=tmp_path)
    assert [str(w.message) for w in caught] == []
    page = (tmp_path / "cosim" / "bench" / "api.html").read_text()
    for name in ("Bench", "info", "get", "set", "persist", "run", "faults", "Run", "Faults"):
        assert f'id="{name}"' in page or f'id="Bench.{name}"' in page, name


# --- every failure a BenchError, checked before anything is sent or written ------------------

_CLOSED_SCRIPT = """
from cosim.bench.api import Bench
from cosim.bench.link.client import BenchError

b = Bench(emulate=True)
b.close()
b.close()  # idempotent
calls = {
    "info": lambda: b.info(),
    "get": lambda: b.get("loop.kp"),
    "set": lambda: b.set(loop_kp=0.1),
    "persist": lambda: b.persist(),
    "faults": lambda: b.faults(),
    "run": lambda: b.run("sine", seconds=0.1),
    "client": lambda: b.client.hello(),
}
for name, call in calls.items():
    try:
        call()
    except BenchError as exc:
        print(name, "refused:", exc)
    else:
        print(name, "ANSWERED")
"""


def test_a_closed_session_refuses_every_call():
    """After close() the emulated device's plant is freed: a run stepped it and crashed the
    interpreter (exit 139), info and get still answered. Every call is one BenchError now (in
    a process of its own: the crash would take pytest with it)."""
    r = subprocess.run(
        [sys.executable, "-c", _CLOSED_SCRIPT],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=REPO_ROOT,
    )
    assert r.returncode == 0, (r.returncode, r.stdout, r.stderr)
    lines = r.stdout.splitlines()
    assert len(lines) == 7 and all("refused:" in line for line in lines), r.stdout
    assert all("closed" in line for line in lines), r.stdout


def test_a_bool_is_not_a_parameter_value():
    """set(loop_kp=True) wrote 1.0 A/N: True is not a gain. Refused, naming the parameter, and
    nothing is written (not even the other values of the call)."""
    with Bench(emulate=True) as b:
        before = b.get("loop.kp", "comp.mode", "comp.mu")
        with pytest.raises(ProtocolError, match=r"^loop.kp=True: a bool is not a number") as exc:
            b.set(comp_mu=0.08, loop_kp=True)
        assert isinstance(exc.value, BenchError)
        with pytest.raises(ProtocolError, match=r"^comp.mode=False: a bool is not a number"):
            b.set(comp_mode=False)
        with pytest.raises(ProtocolError, match=r"^comp.mu=True"):
            b.set(comp_mu=np.True_)
        assert b.get("loop.kp", "comp.mode", "comp.mu") == before


@pytest.fixture(scope="module")
def bench():
    with Bench(emulate=True) as b:
        yield b


def _refused(call, cls=BenchError) -> str:
    with pytest.raises(cls) as exc:
        call()
    msg = str(exc.value)
    assert "\n" not in msg and len(msg) < 1000, msg
    return msg


def test_values_that_leaked_other_exceptions_are_bench_errors(bench, tmp_path):
    """Each raised something else (OverflowError, FileNotFoundError, IsADirectoryError after
    writing a stray sidecar, PlantError, KeyError): now a BenchError of one line naming it."""
    msg = _refused(lambda: bench.set(loop_kp=10**400), ProtocolError)
    assert msg.startswith("loop.kp=an integer of 401 digits: outside [0, 3.9")
    msg = _refused(lambda: bench.run("sine", 0.1, out="/proc/x.csv"))
    assert msg.startswith("out=/proc/x.csv: cannot write in /proc")
    folder = tmp_path / "runs"
    folder.mkdir()
    msg = _refused(lambda: bench.run("sine", 0.1, out=folder))
    assert msg == f"out={folder}: is a folder; give a CSV file name (e.g. run.csv)"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runs"]  # no stray runs.meta.json
    assert not any(folder.iterdir())
    msg = _refused(lambda: Bench(emulate=True, plant={"mu": -5}), BenchUsageError)
    assert msg == "plant.mu must be in [0, 1]; got -5"
    msg = _refused(lambda: Bench(emulate=True, plant={"bogus": 1}), BenchUsageError)
    assert msg.startswith("plant: 'bogus' is not a parameter of the FMU; parameters: mu, ")
    assert not bench.info().running


@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda b: b.run("sine", "1"), "seconds='1': expected a finite number > 0"),
        (lambda b: b.run("sine", True), "seconds=True: expected a finite number > 0"),
        (lambda b: b.run("sine", float("nan")), "seconds=nan: expected a finite number > 0"),
        (lambda b: b.run("sine", -1), "seconds=-1: expected a finite number > 0"),
        (lambda b: b.run("sine", 1, mean_n=float("inf")), "mean_n=inf: expected a finite"),
        (lambda b: b.run("sine", 1, freq_hz=True), "freq_hz=True: expected a finite number"),
        (lambda b: b.run("sine", 1, freq_hz=-1), "wave.freq_hz=-1.0: outside [0, 65536] Hz"),
        (lambda b: b.run([], 1), "waveform: no samples"),
        (lambda b: b.run([[1.0, 2.0]], 1), "waveform [[1.0, 2.0]]: expected one of sine"),
        (lambda b: b.run([1.0, float("nan")], 1), "waveform[1]: wave.mean_n=nan: expected"),
        (lambda b: b.run([1.0, 200.0], 1), "waveform[1]=200: outside [-128, 127.996] N"),
        (lambda b: b.run([True, False], 1), "waveform [True, False]: expected one of"),
        (lambda b: b.run(5.0, 1), "waveform 5.0: expected one of sine"),
        (lambda b: b.run("sine", 1, out=3), "out=3: expected a CSV file name"),
        (lambda b: b.run("sine", 1, out=""), "out='': expected a CSV file name"),
        (lambda b: b.run("sine", 1, on_telemetry=5), "on_telemetry=5: expected a function"),
        (lambda b: b.run("sine", 1, position_m=(0, 2, 0)), "position_m=(0.0, 2.0, 0.0): the"),
        (lambda b: b.run("sine", 1, position_m="0,1,0"), "position_m='0,1,0': expected (x, y, z)"),
        (lambda b: b.run("sine", 1, loop_routing=False), "loop_routing=False: the emulated"),
        (lambda b: b.run("sine", 1, sheath_length_m=0), "sheath_length_m=0: outside [0.01, 10] m"),
        (lambda b: b.run("sine", 1, sheath_length_m=2.0), "sheath_length_m=2.0: the emulated"),
        (lambda b: b.set(loop_kp=0.1, **{"loop.kp": 0.2}), "loop.kp given twice"),
        (lambda b: b.set(loop_kp=None), "loop.kp=None: expected a number"),
        (lambda b: b.get(5), "parameter name 5: expected a str"),
        (lambda b: b.faults(clear="no"), "clear='no': expected True or False"),
    ],
)
def test_bad_arguments_are_refused_before_anything_is_sent(bench, call, words, tmp_path):
    """Every argument of the public calls checked first: one BenchError line naming it (a
    value of the wrong type used to leak a TypeError or be taken: seconds=True ran 1 s)."""
    before = bench.get()
    msg = _refused(lambda: call(bench))
    assert msg.startswith(words), msg
    assert bench.get() == before and not bench.info().running


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"emulate": "no"}, "emulate='no': expected True or False"),
        ({"port": 5}, "port=5: expected a pyserial URL or 'auto'"),
        ({"port": "x", "plant": {"mu": 0.1}}, "plant and chain describe the emulated bench"),
        ({"emulate": True, "timeout_s": 0}, "timeout_s=0: expected a finite number > 0"),
        ({"emulate": True, "plant": {"mu": 0.1}, "chain": None}, None),
        ({"emulate": True, "plant": "mu=0.1"}, "plant must be an object of FMU parameter"),
        ({"emulate": True, "plant": {"mu": True}}, "plant.mu must be a number in [0, 1]"),
        (
            {"emulate": True, "chain": "x"},
            "chain='x': expected a cosim.bench.emulate.host_device.ChainConfig",
        ),
        ({"can": "virtual:x", "node": "1"}, "node='1': expected a whole number"),
    ],
)
def test_bad_sessions_are_refused_before_anything_starts(kwargs, words):
    if words is None:  # the good one: numbers of numpy taken as the numbers they are
        with Bench(**{**kwargs, "plant": {"mu": np.float64(0.1), "seed": np.int64(3)}}) as b:
            assert b.info().proto_version == msgs.PROTOCOL_VERSION
        return
    assert _refused(lambda: Bench(**kwargs)).startswith(words)


def test_plant_and_chain_together_are_refused():
    from cosim.bench.emulate.host_device import ChainConfig

    msg = _refused(lambda: Bench(emulate=True, plant={"mu": 0.1}, chain=ChainConfig()))
    assert msg == "give plant or chain (with its plant), not both"
    msg = _refused(lambda: Bench(emulate=True, chain=ChainConfig(position_m=(0, 3, 0))))
    assert msg.startswith("the emulated end-effector at (0, 3, 0) m is outside the workspace")
    msg = _refused(lambda: Bench(emulate=True, plant={"sheath_length": 0.3}))
    assert msg.startswith("the emulated end-effector at (0, 0.5, 0) m is outside the workspace")
    assert "of a 0.3 m sheath" in msg


def test_an_emulated_bench_with_the_boards_interface_runs_on_the_python_engine(tmp_path):
    """ChainConfig(interface="adc") was refused by the stepped link's C chain (ideal only)."""
    from cosim.bench.emulate.host_device import ChainConfig

    with Bench(emulate=True, chain=ChainConfig(interface="adc")) as b:
        assert b.link.chain.engine == "python"
        run = b.run("sine", 0.2, out=tmp_path / "adc.csv")
        assert run.complete and run["T_out_N"].max() > 5.0


def test_set_is_all_or_nothing():
    """A value the device's settings check refuses puts back those written before it (loop.kp
    stayed at 0.2 when comp.mu=2 was refused)."""
    with Bench(emulate=True) as b:
        before = b.get()
        msg = _refused(lambda: b.set(loop_kp=0.2, comp_mu=2), BenchUsageError)
        assert "comp.mu: outside [0, 1]" in msg and "nothing written" in msg
        assert b.get() == before


def test_a_run_that_records_nothing_keeps_an_earlier_recording(tmp_path, monkeypatch):
    """out= is written when the run has recorded (into NAME.partial.csv until then): a run whose
    START fails leaves an earlier recording as it was (it was emptied to its header), and no
    partial file behind."""
    out = tmp_path / "r.csv"
    with Bench(emulate=True) as b:
        first = b.run("sine", 0.2, out=out)
        assert first.complete
        assert sorted(p.name for p in tmp_path.iterdir()) == ["r.csv", "r.meta.json"]
        kept = out.read_bytes(), (tmp_path / "r.meta.json").read_bytes()
        simple = b.client.simple

        def start_fails(name, **fields):
            if name == "START":
                raise BenchError("START: the link went down")
            return simple(name, **fields)

        monkeypatch.setattr(b.client, "simple", start_fails)
        with pytest.raises(BenchError, match="the link went down"):
            b.run("sine", 0.2, out=out)
        assert (out.read_bytes(), (tmp_path / "r.meta.json").read_bytes()) == kept
        assert sorted(p.name for p in tmp_path.iterdir()) == ["r.csv", "r.meta.json"]
        assert not b.info().running
