"""The Python API (`cosim.bench.api.Bench`) on the emulator: a session as a context manager,
parameters by name in SI units, a run's arrays and trace file, faults, persistence, the device
stopped however a session ends; the README's worked example run as written; the API docs built
by pdoc without a warning."""

import re
import warnings

import numpy as np
import pytest

from cosim.bench import messages as msgs
from cosim.bench.api import Bench, Faults, ProtocolError
from cosim.bench.client import BenchClient, BenchError, SerialLink
from cosim.bench.emulator import Emulator
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
        assert run.trace.exists() and run.complete
        np.testing.assert_allclose(run["T_ref_N"], np.round(ref * 256) / 256, atol=0)
        assert seen == list(range(800))
        with pytest.raises(ProtocolError, match="waveform 'square'"):
            b.run("square", 1.0)


def test_the_device_is_stopped_however_the_session_ends(emulator):
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
            b.run("sine", 30.0, on_telemetry=interrupt)
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
