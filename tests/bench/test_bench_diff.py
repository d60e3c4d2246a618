"""`bowden bench diff` against the emulator: a backup, a bench params file, a co-simulation
params file and the factory defaults, parameter by parameter in SI units; bad files (another
protocol version, not JSON, a value out of range, neither kind) in one line, before anything is
sent."""

import json
import os

import pytest

from cosim.bench import messages as msgs
from cosim.bench.__main__ import main as bench_cli
from cosim.bench.emulator import Emulator

OLD = msgs.PROTOCOL_VERSION - 1  # a backup made by the previous protocol


@pytest.fixture(scope="module")
def url():
    emu = Emulator(tcp_port=0, pty=False).start()
    yield emu.urls["socket"]
    emu.stop()


def _run(capsys, *args):
    rc = bench_cli(["bench", *args])
    out = capsys.readouterr()
    return rc, out.out, out.err


def _rows(out):
    return {line.split()[0]: line.split() for line in out.splitlines()[1:] if line.strip()}


def test_diff_against_a_backup_and_the_defaults(url, tmp_path, capsys):
    assert _run(capsys, "--port", url, "defaults")[0] == 0
    backup = tmp_path / "b.json"
    assert _run(capsys, "--port", url, "backup", str(backup))[0] == 0
    rc, out, _ = _run(capsys, "--port", url, "diff", str(backup))
    assert rc == 0 and out.strip() == f"no differences in {len(msgs.PARAMS)} parameters"
    _run(capsys, "--port", url, "set", "loop.kp=0.07", "comp.mode=smooth", "comp.band_n=1")
    rc, out, _ = _run(capsys, "--port", url, "diff", str(backup))
    assert rc == 0
    lines = out.splitlines()
    assert lines[0].split() == ["parameter", "device", "b.json", "device", "-", "file"]
    rows = _rows("\n".join(lines[:-1]))
    assert set(rows) == {"comp.mode", "comp.band_n", "loop.kp"}
    assert rows["loop.kp"] == [
        "loop.kp",
        "0.0699463",
        "A/N",
        "0.0999756",
        "A/N",
        "-0.0300293",
        "A/N",
    ]
    assert rows["comp.mode"] == ["comp.mode", "smooth", "paper"]
    assert rows["comp.band_n"] == ["comp.band_n", "1", "N", "0.5", "N", "+0.5", "N"]
    assert lines[-1] == f"3 of {len(msgs.PARAMS)} parameters differ"
    rc, out, _ = _run(capsys, "--port", url, "diff", "--defaults")
    assert rc == 0 and out.splitlines()[0].split()[2:4] == ["factory", "default"]
    assert set(_rows("\n".join(out.splitlines()[:-1]))) == {"comp.mode", "comp.band_n", "loop.kp"}
    rc, out, _ = _run(capsys, "--port", url, "diff", "--defaults", "--all")
    assert len(out.splitlines()) == 1 + len(msgs.PARAMS) + 1


def test_diff_against_params_files(url, tmp_path, capsys):
    _run(capsys, "--port", url, "defaults")
    _run(capsys, "--port", url, "set", "loop.kp=0.07", "comp.mode=smooth")
    bench = tmp_path / "bench.json"
    bench.write_text(json.dumps({"loop.kp": 0.07, "comp.mode": "smooth", "comp.mu": 0.3}))
    rc, out, _ = _run(capsys, "--port", url, "diff", str(bench))
    rows = _rows("\n".join(out.splitlines()[:-1]))
    assert rc == 0 and set(rows) == {"comp.mu"}  # kp and mode as the file says
    assert out.splitlines()[-1] == "1 of 3 parameters differ"
    sim = tmp_path / "tuned_params.json"
    sim.write_text(
        json.dumps(
            {
                "controller": {"kp_a_per_n": 0.1, "ki_a_per_n_s": 2.5},
                "compensator": {"band_n": 0.5},
                "plant": {"mu": 0.2},
            }
        )
    )
    rc, out, _ = _run(capsys, "--port", url, "diff", str(sim))
    lines = out.splitlines()
    rows = _rows("\n".join(lines[:-2]))
    # Ki 2.5 A/(N s) at the file's 10 kHz is the device's ki_ts 2.5e-4: equal; kp was changed.
    assert rc == 0 and set(rows) == {"loop.kp"}
    assert lines[-2] == "1 of 3 parameters differ"
    assert lines[-1] == "not device parameters (the co-simulation's model), skipped: plant"


def test_diff_of_another_table_compares_by_name(url, tmp_path, capsys):
    backup = tmp_path / "b.json"
    _run(capsys, "--port", url, "defaults")
    _run(capsys, "--port", url, "backup", str(backup))
    doc = json.loads(backup.read_text())
    doc["table_hash"] = "12345678"
    doc["params"]["comp.future"] = {"word": 1, "value": "1"}
    backup.write_text(json.dumps(doc))
    rc, out, _ = _run(capsys, "--port", url, "diff", str(backup))
    lines = out.splitlines()
    assert rc == 0 and lines[0].startswith("note: backup of table 12345678")
    assert lines[-1] == "in b.json but unknown to this device: comp.future"


@pytest.mark.parametrize(
    ("content", "words"),
    [
        (
            {"bowden_bench_backup": 1, "protocol_version": OLD, "params": {}},
            f"is a backup of protocol version {OLD}, this host speaks {msgs.PROTOCOL_VERSION}",
        ),
        ("{not json", "is not JSON"),
        ({"loop.kp": 0.1, "comp.mode": "fast"}, "comp.mode=fast: expected one of none, paper"),
        ({"controller": {"kp_a_per_n": -1}}, "controller.kp_a_per_n"),
        ({"hello": 1}, "is neither a bowden bench backup"),
        ([1, 2], "expected a JSON object at the top level"),
    ],
)
def test_bad_diff_files_are_one_line_before_any_link(content, words, tmp_path, capsys):
    f = tmp_path / "f.json"
    f.write_text(content if isinstance(content, str) else json.dumps(content))
    # The port does not exist: the file is refused before the link is opened.
    rc, out, err = _run(capsys, "--port", str(tmp_path / "no-port"), "diff", str(f))
    assert rc == 2 and len(err.strip().splitlines()) == 1 and words in err, err
    assert err.startswith("bowden bench diff: ") and out == ""


def test_diff_needs_a_file_or_defaults(capsys, tmp_path):
    for args in (["diff"], ["diff", "x.json", "--defaults"]):
        rc, _, err = _run(capsys, "--port", "x", *args)
        assert (rc, err.strip()) == (2, "bowden bench diff: give FILE or --defaults (one of them)")
    rc, _, err = _run(capsys, "--port", "x", "diff", str(tmp_path / "missing.json"))
    assert rc == 2 and "missing.json does not exist" in err


def test_diff_over_can(capsys):
    rc, out, _ = _run(
        capsys, "--can", f"virtual:diff_{os.getpid()}", "--emulate", "diff", "--defaults"
    )
    assert rc == 0 and out.strip() == f"no differences in {len(msgs.PARAMS)} parameters"
