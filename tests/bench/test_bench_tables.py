"""The protocol table and its generated outputs: up to date, consistent between C and Python, the
parameters taken from the firmware's configuration, the DBC readable by cantools."""

import json
import subprocess
import sys

import cantools
import pytest

from cosim.bench.emulate.host_device import Device
from cosim.bench.link import messages as msgs
from cosim.bench.link import protocol
from cosim.project.paths import REPO_ROOT

PROTO = REPO_ROOT / "firmware" / "proto"
VECTORS = REPO_ROOT / "firmware" / "proto" / "vectors.json"


def test_generated_files_are_up_to_date():
    run = subprocess.run(
        [sys.executable, "-m", "firmware.proto.gen_proto", "--check"],
        cwd=REPO_ROOT,
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stdout + run.stderr


def test_table_hash_is_the_same_in_c_and_python():
    header = (REPO_ROOT / "firmware" / "include" / "proto_msgs.h").read_text()
    assert f"#define PROTO_TABLE_HASH 0x{msgs.TABLE_HASH:08X}u" in header
    assert json.loads(VECTORS.read_text())["table_hash"] == f"0x{msgs.TABLE_HASH:08X}"


def test_parameters_come_from_the_firmware_configuration():
    """Every word of the firmware's configuration is a parameter, in C and Python alike: the
    device's PARAM_INFO keys are the CRC-32C of the Python names, the loop's words carry the
    register map's formats, and the compensator's modes come from comp.h."""
    names = [p.name for p in msgs.PARAMS]
    for expected in (
        "comp.mode", "comp.mu", "comp.phi_rad", "comp.band_n", "comp.hysteresis_n",
        "wave.kind", "wave.freq_hz", "loop.kff", "loop.kp", "loop.ki_ts", "loop.i_limit",
        "loop.slew", "loop.wdt_timeout", "dev.telemetry_div", "source", "tick_rate_hz",
    ):  # fmt: skip
        assert expected in names
    p = msgs.PARAM_BY_NAME
    assert p["comp.mode"].enum == {"none": 0, "paper": 1, "smooth": 2, "preview": 3}
    assert p["wave.kind"].enum == {"constant": 0, "sine": 1, "triangle": 2, "ramp": 3, "step": 4}
    # lo: the register map's documented limit (a gain of the wrong sign is refused)
    assert (p["loop.kff"].frac, p["loop.kff"].unit, p["loop.kff"].lo) == (13, "A/N", 0)
    assert (p["loop.i_limit"].lo, p["loop.i_limit"].hi) == (0, 32767)
    assert (p["comp.mu"].frac, p["comp.phi_rad"].unit) == (28, "rad")
    assert p["tick_rate_hz"].read_only and not p["comp.mu"].read_only
    dev = Device()
    for q in msgs.PARAMS:
        reply = _request(dev, "PARAM_INFO", param=q.id)
        assert reply["key"] == q.key == protocol.crc32c(q.name.encode()), q.name


def test_no_parameter_id_moves_when_the_configuration_grows():
    """A parameter added later (params.appended) takes an id after every other one, so that a
    host script or a backup that uses ids keeps working: the last ids of the first table stay
    where they were, and the appended ones follow in the order the table lists them."""
    p = msgs.PARAM_BY_NAME
    assert [p[n].id for n in ("comp.mode", "est.t_min_n", "dev.telemetry_div", "dev.can_node")] == [
        3, 39, 40, 41,
    ]  # fmt: skip
    raw = json.loads((PROTO / "bowden_proto.json").read_text())
    appended = raw["params"]["appended"]
    n = len(msgs.PARAMS)
    assert [q.name for q in msgs.PARAMS[n - len(appended) :]] == appended
    assert [q.id for q in msgs.PARAMS] == list(range(n))


def _request(dev, name, **fields):
    dev.rx_bytes(
        0,
        protocol.encode_frame(
            protocol.Frame(msgs.MESSAGES[name].id, 7, protocol.pack(name, **fields))
        ),
    )
    frames = protocol.FrameDecoder().feed(dev.tx_bytes(0))
    (f,) = frames
    return protocol.unpack(msgs.MESSAGE_BY_ID[f.msg].name, f.payload)


def test_dbc_describes_the_can_frames():
    db = cantools.database.load_file(str(REPO_ROOT / "firmware" / "proto" / "bowden_bench.dbc"))
    node = msgs.CAN_DEFAULT_NODE
    a = db.get_message_by_name("TELEM_A")
    assert a.frame_id == node << 5 | msgs.MESSAGES["TELEM_A"].id
    vec = next(v for v in json.loads(VECTORS.read_text())["vectors"] if v.get("can_telemetry"))
    decoded = a.decode(bytes.fromhex(vec["can"][0][1]))
    assert decoded["sample_lo16"] == vec["values"]["sample"] & 0xFFFF
    assert decoded["channel"] == vec["values"]["channel"]
    assert decoded["t_ref"] == pytest.approx(vec["values"]["t_ref"] / 256.0)
    b = db.get_message_by_name("TELEM_B").decode(bytes.fromhex(vec["can"][1][1]))
    assert b["current"] == pytest.approx(vec["values"]["current"] / 4096.0)
    ps = db.get_message_by_name("PARAM_SET")
    # the optional channel, a repeated field of at most one, is the DBC's channel_0
    assert ps.encode({"seq": 3, "param": 4, "value": -5, "channel_0": 2}) == bytes([3, 4, 0]) + (
        -5
    ).to_bytes(4, "little", signed=True) + bytes([2])
    # Bandwidth stated in the document: 2 frames per sample fit 500 kbit/s.
    doc = (REPO_ROOT / "firmware" / "proto" / "PROTOCOL.md").read_text()
    assert "of 500 kbit/s" in doc and "latency timer" in doc


def test_generator_refuses_a_bad_table(tmp_path):
    """A duplicate id, an id beyond 5 bits and an oversized message are named."""
    from firmware.proto import gen_proto

    raw = json.loads((PROTO / "bowden_proto.json").read_text())
    for change, words in (
        (lambda r: r["messages"][1].update(id=1), "already used"),
        (lambda r: r["messages"][1].update(id=32), "outside 1..31"),
        (lambda r: r["messages"][1]["fields"].append(
            {"name": "x", "type": "u32", "count": [0, 20]}), "max_payload"),
        (lambda r: r["params"]["read_only"].append("no.such"), "unknown parameters"),
        (lambda r: r["params"]["appended"].append("no.such"), "appended names unknown"),
    ):  # fmt: skip
        bad = json.loads(json.dumps(raw))
        change(bad)
        path = tmp_path / "t.json"
        path.write_text(json.dumps(bad))
        with pytest.raises(ValueError, match=words):
            gen_proto.load(path)
