"""WAVES=1 makes an RTL test dump its waveform (hdl_sim.run_cocotb): a VCD from Verilator, an
FST from Icarus, holding the toplevel's signals; without it nothing is dumped."""

from __future__ import annotations

import pytest
from hdl_sim import MAKE_TEST_SIMULATOR, SIMULATOR_PARAMS, rtl, run_cocotb, waves_file

from cosim.project.paths import BUILD_DIR


@pytest.mark.slow
@pytest.mark.parametrize("simulator", SIMULATOR_PARAMS)
def test_waves_dumps_a_waveform_of_the_toplevel(simulator, monkeypatch):
    build_dir = BUILD_DIR / "sim" / "mul_s16-waves" / simulator
    dump = waves_file(build_dir, "mul_s16", simulator)
    dump.unlink(missing_ok=True)
    monkeypatch.setenv("WAVES", "1")
    assert run_cocotb("mul_s16", "test_mul_s16", rtl("mul_s16"), simulator) > 0
    assert dump.is_file() and dump.stat().st_size > 0
    if simulator == "verilator":  # VCD is text: the toplevel's ports are declared in it
        text = dump.read_text(errors="replace")
        assert "$var" in text and "mul_s16" in text


def test_without_waves_nothing_is_dumped(monkeypatch):
    monkeypatch.delenv("WAVES", raising=False)
    simulator = MAKE_TEST_SIMULATOR
    run_cocotb("mul_s16", "test_mul_s16", rtl("mul_s16"), simulator)
    assert not waves_file(BUILD_DIR / "sim" / "mul_s16" / simulator, "mul_s16", simulator).exists()
