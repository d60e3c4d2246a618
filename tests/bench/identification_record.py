"""calibrate's identification run recorded on an emulated plant, for the calibrate tests that stand
in for the audit's rounds themselves (test_bench_calibrate_joint_mu.py,
test_bench_calibrate_spread_slope.py): the sequence streamed to the stepped emulator as calibrate
streams it, the record prepared for the audit, and the device's comp.* values read back."""

from __future__ import annotations

from pathlib import Path

from cosim.audit import core
from cosim.bench.api import Bench
from cosim.bench.link.protocol import param, value_from_word, word_from_value
from cosim.bench.rig import calibrate as cal
from cosim.results import trace as trace_mod


def identification_record(plant: dict, folder: Path) -> tuple[core.AuditData, dict[str, float]]:
    """The prepared identification record of `plant` (written to folder/identification.csv) and
    the device's comp.* values."""
    seq, _ = cal.identification_sequence(1000.0)
    path = folder / "identification.csv"
    with Bench(emulate=True, plant=plant) as bench:
        client = bench.client
        opts = cal.Options(out_dir=folder, audit_plots=False, predict=False)
        cal._record(
            client,
            path,
            lambda: client.request("STOP"),
            opts,
            None,
            seconds=len(seq) / 1000.0,
            waveform="stream",
            mean_n=0.0,
            amplitude_n=0.0,
            freq_hz=0.0,
            stream_words=[word_from_value(param("wave.mean_n"), v) for v in seq],
        )
        device = {
            n: value_from_word(param(n), w)
            for n, w in client.params().items()
            if n.startswith("comp.")
        }
    return core.prepare(trace_mod.read_trace(path, mode="measured"), str(path)), device
