"""`bowden bench diff` against the emulator: a backup, a bench params file, a co-simulation
params file and the factory defaults, parameter by parameter in SI units; bad files (another
protocol version, not JSON, a value out of range, neither kind) in one line, before anything is
sent."""

import json
import os

import pytest

from cosim.bench.__main__ import main as bench_cli
from cosim.bench.emulate.emulator import Emulator
from cosim.bench.link import messages as msgs
from cosim.project.paths import PACKAGE_DIR

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


def test_a_phase_in_turns_wraps_as_set_wraps_it(url, tmp_path, capsys):
    _run(capsys, "--port", url, "defaults")
    f = tmp_path / "f.json"
    f.write_text(json.dumps({"wave.phase0": 1.25}))
    rc, out, err = _run(capsys, "--port", url, "diff", str(f))
    assert rc == 0 and _rows(out)["wave.phase0"][1:4] == ["0", "0.25", "-0.25"], out + err


def test_an_empty_file_name_or_a_device_file_is_one_line(capsys, tmp_path):
    for command in ("diff", "restore"):
        got, _, err = _run(capsys, "--port", str(tmp_path / "no-port"), command, "")
        assert (got, len(err.splitlines())) == (2, 1) and "an empty file name" in err, err
        got, _, err = _run(capsys, "--port", str(tmp_path / "no-port"), command, "/dev/zero")
        # A device (or a FIFO) is refused before it is opened: reading it could block or never end.
        assert got == 2 and "/dev/zero is not a regular file" in err, err


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


# --- co-simulation params files: every key compared or said not to be ---------------------------


def test_a_sim_file_compares_the_rate_feedforward_and_the_estimate(url, tmp_path, capsys):
    """kv, its bound and the online estimate's settings are device parameters (loop.kv,
    loop.uff_limit, est.*): each key the file sets is a row, none left out silently."""
    _run(capsys, "--port", url, "defaults")
    sim = tmp_path / "tuned_params.json"
    sim.write_text(
        json.dumps(
            {
                "controller": {"kp_a_per_n": 0.1, "kv_a_s_per_n": 0.01, "uff_limit_a": 1.0},
                "compensator": {
                    "mu": 0.075,
                    "est_enable": 1,
                    "est_tau_ticks": 256,
                    "est_rate_per_s": 1.0,
                    "est_mu_phi_min": 0.1,
                    "est_mu_phi_max": 1.5,
                    "est_t_min_n": 1.0,
                },
            }
        )
    )
    rc, out, err = _run(capsys, "--port", url, "diff", str(sim))
    lines = out.splitlines()
    rows = _rows("\n".join(lines[:-1]))
    assert rc == 0 and err == "", err
    assert set(rows) == {
        "loop.kv",
        "loop.uff_limit",
        "est.enable",
        "est.tau_ticks",
        "est.rate",
        "est.mu_phi_min",
        "est.mu_phi_max",
        "est.t_min_n",
    }, out
    assert lines[-1] == "8 of 10 parameters differ"  # kp and mu as the device holds them
    # The estimate's rate is per firmware tick on the device: 1 per s at the file's 1 kHz is
    # 0.001 per tick, in Q3.28; kv 0.01 A s/N in Q7.24.
    assert rows["est.rate"][1:5] == ["0.002", "per", "tick", "0.000999998"]
    assert rows["loop.kv"][1:5] == ["0", "A", "s/N", "0.00999999"]


def test_a_null_bending_angle_is_listed_as_not_compared(url, tmp_path, capsys):
    _run(capsys, "--port", url, "defaults")
    sim = tmp_path / "sim.json"
    sim.write_text(json.dumps({"compensator": {"phi_rad": None, "mu": 0.075}}))
    rc, out, _ = _run(capsys, "--port", url, "diff", str(sim))
    lines = out.splitlines()
    assert rc == 0 and lines[0] == "no differences in 1 parameters", out
    assert lines[1].startswith("not compared: compensator.phi_rad (null: "), out


def test_every_sim_key_is_mapped_or_said_to_have_no_device_counterpart():
    """The co-simulation's controller and compensator fields (and the file's top level) each map
    to a device parameter or are listed with the reason they have none; a field added to the
    co-simulation without either is found."""
    import dataclasses

    from cosim.bench.rig import diff
    from cosim.config.run import ControllerParams

    assert diff.unmapped_sim_keys() == []
    for key, name in diff.SIM_TO_DEVICE.items():
        assert name in msgs.PARAM_BY_NAME, key
    assert not set(diff.SIM_TO_DEVICE) & set(diff.SIM_NOT_ON_DEVICE)

    @dataclasses.dataclass
    class Grown(ControllerParams):
        kd_a_s_per_n: float = 0.0

    assert diff.unmapped_sim_keys(controller=Grown) == ["controller.kd_a_s_per_n"]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"loop.nope": "controller.x"}, r"params.cosim names unknown parameters \['loop.nope'\]"),
        ({"loop.kff": "controller.kp_a_per_n"}, r"gives \['controller.kp_a_per_n'\] to more than"),
    ],
)
def test_the_protocol_table_refuses_a_bad_co_simulation_name(change, message, tmp_path):
    """The co-simulation <-> device table is generated from the protocol's table (params.cosim in
    firmware/proto/bowden_proto.json); the generator refuses an unknown parameter or a key given
    to two, and the table does not enter the hash the device reports."""
    from firmware.proto import gen_proto

    raw = json.loads(gen_proto.SOURCE.read_text())
    spec = gen_proto.load()
    assert dict(msgs.SIM_TO_DEVICE) == {k: v for v, k in raw["params"]["cosim"].items()}
    raw["params"]["cosim"].update(change)
    bad = tmp_path / "proto.json"
    bad.write_text(json.dumps(raw))
    with pytest.raises(ValueError, match=message):
        gen_proto.load(bad)
    del raw["params"]["cosim"]
    bare = tmp_path / "bare.json"
    bare.write_text(json.dumps(raw))
    assert gen_proto.load(bare).table_hash == spec.table_hash == msgs.TABLE_HASH


def test_sim_words_are_the_words_the_cosimulation_gives_the_firmware():
    """Units and scaling: for a params file that sets every mapped key away from its default,
    the device words diff compares with are the firmware configuration the co-simulation builds
    from that file (cosim.engines.fwbridge), word for word."""
    from cosim.bench.rig import diff
    from cosim.config.run import SimConfig
    from cosim.engines.fwbridge import FirmwareBridge
    from cosim.parts import firmware

    doc = {
        "sample_rate_hz": 20000,
        "firmware_rate_hz": 2000,
        "controller": {
            "kff_a_per_n": 0.09,
            "kp_a_per_n": 0.12,
            "ki_a_per_n_s": 3.0,
            "i_limit_a": 3.5,
            "slew_n_per_sample": 0.25,
            "kv_a_s_per_n": 0.02,
            "uff_limit_a": 1.25,
        },
        "compensator": {
            "mu": 0.1,
            "phi_rad": 3.0,
            "band_n": 0.75,
            "hysteresis_n": 0.05,
            "offset_n": 0.2,
            "mu_slope_per_n": 0.0,
            "tc_min_n": 0.3,
            "preview_ticks": 40,
            "lead_ticks": 5,
            "ramp_ticks": 100,
            "est_enable": 1,
            "est_tau_ticks": 512,
            "est_rate_per_s": 3.0,
            "est_mu_phi_min": 0.1,
            "est_mu_phi_max": 1.5,
            "est_t_min_n": 0.75,
            "corr_enable": 1,
            "corr_ki_shift": 7,
            "corr_hold_ticks": 45,
            "corr_limit": 0.25,
            "corr_tare_ticks": 128,
            "corr_tare_max_n": 0.75,
            "corr_slide_gate": 1,
            "corr_offset_term": 1,
            "corr_rev_enable": 1,
            "corr_rev_ki_shift": 5,
            "corr_rev_bin_shift": 4,
            "corr_rev_lead_ticks": 0,  # by travel (corr_rev_index 1) the lead must be 0
            "corr_rev_leak_shift": 10,
            "corr_rev_limit_n": 1.5,
            "corr_rev_index": 1,
            "dead_zone_spread": 0.35,
            "breakaway": 0.02,
            "slack_tension_n": 3.4,
            "mu_per_inlet_rate": 0.0027,
            "corr_kp": 0.75,
        },
    }
    mapped = {k for k in diff.SIM_TO_DEVICE if "." in k} | {"sample_rate_hz", "firmware_rate_hz"}
    given = {f"{g}.{k}" for g in ("controller", "compensator") for k in doc[g]}
    assert mapped <= given | {"sample_rate_hz", "firmware_rate_hz"}
    words = diff.sim_words(doc, SimConfig.from_dict(doc))[0]
    cfg = SimConfig.from_dict(doc)
    bridge = FirmwareBridge(cfg, "paper", cfg.compensator.phi_rad)
    c = bridge.fw.config.to_c(firmware.load_library())
    for name, word in words.items():
        node = c
        for part in msgs.PARAM_BY_NAME[name].cpath.removeprefix("fw.").split("."):
            node = getattr(node, part)
        assert word == node, name
    assert {"loop.slew_en", "loop.slew", "est.rate", "loop.ki_ts"} <= set(words)


def test_a_sim_file_with_its_rates_is_read_as_a_sim_file(url, tmp_path, capsys):
    _run(capsys, "--port", url, "defaults")
    sim = tmp_path / "sim.json"
    sim.write_text(
        json.dumps(
            {
                "sample_rate_hz": 10000,
                "controller": {"kp_a_per_n": 0.2},
                "compensator": {"mu": 0.075},
                "plant": {"mu": 0.2},
            }
        )
    )
    rc, out, _ = _run(capsys, "--port", url, "diff", str(sim))
    lines = out.splitlines()
    assert rc == 0 and set(_rows("\n".join(lines[:-2]))) == {"loop.kp"}, out
    assert lines[-2:] == [
        "1 of 3 parameters differ",
        "not device parameters (the co-simulation's model), skipped: plant",
    ]


# --- a setting that is off on both sides ---------------------------------------------------------


def test_a_value_whose_switch_is_off_on_both_sides_is_not_a_difference(url, tmp_path, capsys):
    """The device's slew limit is off (loop.slew_en 0, loop.slew 0.5 N): a file whose slew is off
    too (the co-simulation's 0, or a slew value without the switch) differs in nothing that
    acts; with the switch on in the file, both rows differ."""
    _run(capsys, "--port", url, "defaults")
    f = tmp_path / "f.json"
    f.write_text(json.dumps({"controller": {"slew_n_per_sample": 0}}))
    rc, out, _ = _run(capsys, "--port", url, "diff", str(f))
    assert rc == 0 and out.strip() == "no differences in 1 parameters", out
    f.write_text(json.dumps({"loop.slew": 0}))
    rc, out, _ = _run(capsys, "--port", url, "diff", str(f))
    lines = out.splitlines()
    assert rc == 0 and lines[0] == "no differences in 1 parameters", out
    assert lines[1] == "off on both sides, not a difference: loop.slew (loop.slew_en 0)", out
    f.write_text(json.dumps({"loop.slew": 0, "loop.slew_en": 1}))
    rc, out, _ = _run(capsys, "--port", url, "diff", str(f))
    assert out.splitlines()[-1] == "2 of 2 parameters differ", out
    f.write_text(json.dumps({"controller": {"slew_n_per_sample": 1.0}}))
    rc, out, _ = _run(capsys, "--port", url, "diff", str(f))
    assert set(_rows("\n".join(out.splitlines()[:-1]))) == {"loop.slew", "loop.slew_en"}, out
    # A backup: the slew changed while off, and the estimate's rate while it is off.
    backup = tmp_path / "b.json"
    _run(capsys, "--port", url, "backup", str(backup))
    _run(capsys, "--port", url, "set", "loop.slew=2", "est.rate=0.01")
    rc, out, _ = _run(capsys, "--port", url, "diff", str(backup), "--all")
    lines = out.splitlines()
    assert lines[-2] == f"no differences in {len(msgs.PARAMS)} parameters", out
    assert lines[-1] == (
        "off on both sides, not a difference: loop.slew (loop.slew_en 0), est.rate (est.enable 0)"
    )
    slew = next(line for line in lines if line.startswith("loop.slew "))
    assert slew.split()[1:] == ["2", "N", "per", "sample", "0.5", "N", "per", "sample", "off"]
    _run(capsys, "--port", url, "defaults")


# --- files refused in one line, exit 2, before the link -----------------------------------------


def _backup_doc(**params):
    doc = {
        "bowden_bench_backup": 1,
        "protocol_version": msgs.PROTOCOL_VERSION,
        "table_hash": f"{msgs.TABLE_HASH:08x}",
        "params": {"loop.kp": {"word": 819, "value": "0.0999756 A/N"}},
    }
    doc["params"].update(params)
    return doc


@pytest.mark.parametrize(
    ("content", "words"),
    [
        ({"comp.mu": 2.0}, "comp.mu=2: outside [0, 1]"),
        ({"comp.mu": -0.1}, "comp.mu=-0.1: outside [0, 1]"),
        ({"comp.mode": 7}, "comp.mode=7: expected one of none, paper, smooth, preview"),
        ({"est.tau_ticks": 8}, "est.tau_ticks=8: outside [16, 32768]"),
        ({"controller": {"kv_a_s_per_n": 1.0}}, "controller.kv_a_s_per_n must be in [0, 0.0625]"),
        (_backup_doc(**{"loop.kv": {"word": 2**31 - 1}}), "loop.kv: word 2147483647 outside"),
        (_backup_doc(**{"comp.mode": {"word": 99}}), "comp.mode: word 99 is none of none=0"),
        (_backup_doc(**{"comp.mu": {"value": "1.5"}}), "comp.mu=1.5: outside [0, 1]"),
        ('{"loop.kp": 0.1, "loop.kp": 0.5}', "key 'loop.kp' appears twice"),
        (
            '{"controller": {"kp_a_per_n": 0.1, "kp_a_per_n": 0.5}}',
            "key 'kp_a_per_n' appears twice",
        ),
        (
            json.dumps(_backup_doc()).replace('"params": {', '"params": {"loop.kp": {"word": 1}, '),
            "key 'loop.kp' appears twice",
        ),
        ('{"loop.kp": ' + "9" * 5000 + "}", "loop.kp: an integer of 5000 digits"),
        ('{"controller": {"kp_a_per_n": ' + "9" * 5000 + "}}", "an integer of 5000 digits"),
        ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
        ('{"a": ' * 100_000 + "1" + "}" * 100_000, "nested too deeply"),
        # Found by trying again as a new user:
        ({"est.tau_ticks": 100}, "est.tau_ticks=100: not a power of two in [16, 32768]"),
        ({"compensator": {"est_tau_ticks": 100}}, "compensator.est_tau_ticks: est.tau_ticks=100"),
        (_backup_doc(**{"est.tau_ticks": {"word": 48}}), "word 48 is not a power of two"),
        (_backup_doc(**{"loop.kp": {"word": 819.0}}), "must be a 32-bit integer; got 819.0"),
        (" \n", "f.json is empty: expected a backup or params file"),
        ({}, "f.json is an empty object: nothing to compare"),
        ({"comp.mu": 1e9}, "comp.mu=1e+09: outside [0, 1]"),  # beyond the word: the device's range
    ],
)
def test_out_of_range_duplicate_huge_and_deep_files_are_one_line(content, words, tmp_path, capsys):
    f = tmp_path / "f.json"
    f.write_text(content if isinstance(content, str) else json.dumps(content))
    rc, out, err = _run(capsys, "--port", str(tmp_path / "no-port"), "diff", str(f))
    assert rc == 2 and len(err.strip().splitlines()) == 1 and words in err, err
    assert err.startswith("bowden bench diff: ") and out == ""


# --- restore reads a backup with the same reader ------------------------------------------------


@pytest.mark.parametrize(
    ("content", "words"),
    [
        (_backup_doc(**{"loop.kv": {"word": 2**31 - 1}}), "loop.kv: word 2147483647 outside"),
        (_backup_doc(**{"comp.mode": {"word": 99}}), "comp.mode: word 99 is none of none=0"),
        (_backup_doc(**{"comp.mu": {"value": 2}}), "comp.mu=2: outside [0, 1]"),
        ({**_backup_doc(), "protocol_version": OLD}, f"is a backup of protocol version {OLD}"),
        (
            json.dumps(_backup_doc()).replace('"params": {', '"params": {"loop.kp": {"word": 1}, '),
            "key 'loop.kp' appears twice",
        ),
        (
            json.dumps(_backup_doc()).replace('"word": 819', '"word": ' + "9" * 5000),
            "loop.kp.word must be a 32-bit integer; got an integer of 5000 digits",
        ),
        ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ],
)
def test_restore_refuses_what_diff_refuses_before_the_link(content, words, tmp_path, capsys):
    f = tmp_path / "b.json"
    f.write_text(content if isinstance(content, str) else json.dumps(content))
    rc, out, err = _run(capsys, "--port", str(tmp_path / "no-port"), "restore", str(f))
    assert rc == 2 and len(err.strip().splitlines()) == 1 and words in err, err
    assert err.startswith("bowden bench: restore: ") and out == ""


# --- restore writes what a params file sets -----------------------------------------------------


def test_restore_of_a_params_file_writes_what_it_sets_and_keeps_the_rest(url, tmp_path, capsys):
    """The recommended params files (cosim/config/params/) go onto a device as they go into
    `bowden sim --params`: restore writes the parameters the file sets and nothing else; diff
    against the same file then finds nothing to report."""
    assert _run(capsys, "--port", url, "defaults")[0] == 0
    assert _run(capsys, "--port", url, "set", "loop.kp=0.07")[0] == 0
    far = PACKAGE_DIR / "config" / "params" / "far_end_after_calibrate.json"
    rc, out, err = _run(capsys, "--port", url, "restore", str(far))
    assert rc == 0, err
    assert "a params file: the 15 parameters it sets" in out and "restored 15 parameters" in out
    rc, out, _ = _run(capsys, "--port", url, "diff", str(far))
    assert rc == 0 and out.strip().endswith("no differences in 15 parameters"), out
    rc, out, _ = _run(capsys, "--port", url, "get", "loop.kp", "loop.kv", "corr.rev_enable")
    rows = _rows("\n" + out)
    assert rows["loop.kp"][1] == "0.0699463" and rows["corr.rev_enable"][1] == "1", out
    assert float(rows["loop.kv"][1]) == pytest.approx(0.001, abs=2e-8), out  # one word of it


@pytest.mark.parametrize(
    ("content", "words"),
    [
        ({"plant": {"mu": 0.1}}, "sets no parameter the device has"),
        ({"loop.kp": 0.1, "loop.nope": 1}, "parameters this device does not know: loop.nope"),
        ({"controller": {"kv_a_s_per_n": -1}}, "kv_a_s_per_n"),
        ({"hello": 1}, "is neither a bowden bench backup, nor a params file"),
    ],
)
def test_restore_refuses_a_params_file_it_cannot_write_before_the_link(
    content, words, tmp_path, capsys
):
    f = tmp_path / "p.json"
    f.write_text(json.dumps(content))
    rc, out, err = _run(capsys, "--port", str(tmp_path / "no-port"), "restore", str(f))
    assert rc == 2 and len(err.strip().splitlines()) == 1 and words in err, err
    assert err.startswith("bowden bench: restore: ") and out == ""
