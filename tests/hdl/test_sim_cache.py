"""A cocotb run's pass is reused only while everything it depends on is unchanged (sim_cache.py).

The key's parts each move it: the sources' bytes, a parameter, a file a parameter names; the kept
pass lists the Python the simulator imported, and a change to any of them runs it again. End to
end (a run writes that list from inside the simulator, and a second call reuses the pass) in
test_mul_s16.py, on the smallest testbench's own build.
"""

from __future__ import annotations

import json

import numpy as np
import sim_cache

CALL = {
    "toplevel": "mul_s16",
    "test_module": "test_mul_s16",
    "simulator": "verilator",
    "parameters": {},
    "tag": "",
    "extra_env": {},
    "build_args": [],
}


def test_every_input_of_the_call_moves_its_digest(tmp_path):
    src = tmp_path / "top.v"
    src.write_text("module top; endmodule\n")
    image = tmp_path / "image.hex"
    image.write_text("00000013\n")
    call = {**CALL, "parameters": {"ROM_INIT": f'"{image}"', "N": 2}}
    base = sim_cache.call_digest(call, [src])
    assert sim_cache.call_digest(call, [src]) == base  # a pure function of its inputs
    seen = {base}
    src.write_text("module top; wire a; endmodule\n")  # a source's bytes
    seen.add(sim_cache.call_digest(call, [src]))
    image.write_text("00100093\n")  # the file a parameter names
    seen.add(sim_cache.call_digest(call, [src]))
    seen.add(sim_cache.call_digest({**call, "parameters": {**call["parameters"], "N": 4}}, [src]))
    seen.add(sim_cache.call_digest({**call, "extra_env": {"X": "1"}}, [src]))
    seen.add(sim_cache.call_digest({**call, "test_module": "test_other"}, [src]))
    assert len(seen) == 6


def test_a_kept_pass_is_refused_when_a_file_the_run_imported_changed(tmp_path, monkeypatch):
    checkout = tmp_path / "checkout"
    (checkout / "pkg").mkdir(parents=True)
    dep = checkout / "pkg" / "tb.py"
    dep.write_text("X = 1\n")
    monkeypatch.setattr(sim_cache, "REPO_ROOT", checkout)
    listed = tmp_path / "deps.txt"
    # an installed library's file is left to its version (the key's), the checkout's are listed
    listed.write_text(f"{dep}\n{checkout / '.venv' / 'lib.py'}\n/usr/lib/python3/x.py\n")
    entry = sim_cache.Entry(tmp_path / "cache", "mul_s16", "0" * 32)
    assert entry.reused() is None  # nothing kept yet
    entry.keep(3, listed)
    assert list(json.loads(entry.path.read_text())["deps"]) == ["pkg/tb.py"]
    assert entry.reused() == 3
    dep.write_text("X = 2\n")
    assert entry.reused() is None
    dep.unlink()
    assert entry.reused() is None


def test_no_list_from_the_simulator_keeps_nothing(tmp_path):
    entry = sim_cache.Entry(tmp_path, "mul_s16", "1" * 32)
    entry.keep(1, tmp_path / "absent.txt")
    assert not entry.path.exists()


def test_a_closed_loop_is_kept_as_its_record_by_its_spec_and_code(tmp_path, monkeypatch):
    calls = []

    def original(spec, simulator="verilator", work_dir=None, progress=True):
        calls.append(spec["duration_s"])
        return {"t_s": np.arange(3) * spec["duration_s"], "faults": np.zeros(3, np.uint16)}, {
            "sim_s": 1.5
        }

    run = sim_cache.closed_loop_cached(original, tmp_path)
    spec = {"duration_s": 2.0, "config": {"kp": 0.1}}
    first = run(spec, progress=False)
    again = run(dict(spec), progress=False)
    assert calls == [2.0]  # the second is the kept record
    assert again[1] == first[1] == {"sim_s": 1.5}
    assert again[0].keys() == first[0].keys()
    for k, v in first[0].items():
        assert again[0][k].dtype == v.dtype and np.array_equal(again[0][k], v)
    run({**spec, "config": {"kp": 0.2}}, progress=False)  # another spec
    assert len(calls) == 2
    monkeypatch.setattr(sim_cache, "_closed_loop_digest", lambda: b"other code")
    run(spec, progress=False)  # the same spec, other code
    assert len(calls) == 3
    run(spec, work_dir=tmp_path / "w", progress=False)  # a work folder the caller reads
    sim_cache.closed_loop_cached(original, None)(spec)  # BOWDEN_TEST_CACHE=0
    assert len(calls) == 5
