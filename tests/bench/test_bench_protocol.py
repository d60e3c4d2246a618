"""The host side of the protocol (cosim.bench.link.protocol): the shared vectors, Hypothesis
properties of the decoder (round trip, arbitrary bytes never raise, resynchronisation within one
frame, the C decoder and the Python one agree), the CAN mapping and the parameter words."""

import ctypes
import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from cosim.bench.emulate.host_device import load_library
from cosim.bench.link import messages as msgs
from cosim.bench.link import protocol as proto
from cosim.project.paths import REPO_ROOT

VECTORS = json.loads((REPO_ROOT / "firmware" / "proto" / "vectors.json").read_text())["vectors"]
SERIAL_VECTORS = [v for v in VECTORS if not v.get("can_telemetry")]


@pytest.mark.parametrize("vec", SERIAL_VECTORS, ids=lambda v: f"{v['message']}-{v['seq']}")
def test_shared_vector(vec):
    """Values -> payload -> wire bytes, and back; the C side checks the same vectors."""
    name = vec["message"]
    values = vec["values"]
    if msgs.MESSAGES[name].fields and msgs.MESSAGES[name].fields[-1].code == "s":
        tail = msgs.MESSAGES[name].fields[-1].name
        values = {**values, tail: bytes(values[tail]).decode("ascii")}
    payload = proto.pack(name, **values)
    assert payload.hex() == vec["payload"]
    frame = proto.Frame(msgs.MESSAGES[name].id, vec["seq"], payload)
    assert proto.encode_frame(frame).hex() == vec["wire"]
    (back,) = proto.FrameDecoder().feed(bytes.fromhex(vec["wire"]))
    assert back == frame
    assert proto.unpack(name, back.payload) == values
    if "can" in vec:
        assert [[i, d.hex()] for i, d in proto.can_encode(1, frame)] == vec["can"]
        r = proto.CanReassembler(node=1)
        got = [f for i, d in vec["can"] for f in r.feed(i, bytes.fromhex(d))]
        assert got == [frame]


def test_can_telemetry_vectors():
    for vec in (v for v in VECTORS if v.get("can_telemetry")):
        frame = proto.Frame(
            msgs.MESSAGES["TELEMETRY"].id, 0, proto.pack("TELEMETRY", **vec["values"])
        )
        assert [[i, d.hex()] for i, d in proto.can_encode(1, frame)] == vec["can"]
        r = proto.CanReassembler(node=1)
        (t,) = [f for i, d in vec["can"] for f in r.feed(i, bytes.fromhex(d))]
        got = proto.unpack("TELEMETRY", t.payload)
        # CAN carries the sample's low 16 bits: a reassembler's first sample is those bits.
        assert got["sample"] == vec["values"]["sample"] & 0xFFFF
        for k in ("channel", "t_ref", "t_c", "t_in", "t_out", "current", "faults"):
            assert got[k] == vec["values"][k]


frames = st.builds(
    proto.Frame,
    msg=st.integers(0, 255),
    seq=st.integers(0, 255),
    payload=st.binary(max_size=msgs.MAX_PAYLOAD),
    version=st.integers(0, 255),
)


@given(st.lists(frames, min_size=1, max_size=8), st.data())
def test_round_trip_in_any_chunks(fs, data):
    wire = b"".join(proto.encode_frame(f) for f in fs)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(wire)), max_size=10)))
    dec = proto.FrameDecoder()
    got = []
    for a, b in zip([0, *cuts], [*cuts, len(wire)], strict=True):
        got += dec.feed(wire[a:b])
    assert got == fs
    assert dec.stats.rejected == 0


@given(st.binary(max_size=2000))
def test_arbitrary_bytes_never_raise(data):
    dec = proto.FrameDecoder()
    for f in dec.feed(data):  # whatever is accepted is a real frame: it re-encodes to bytes in data
        assert proto.encode_frame(f)[1:-1] in data


@given(st.binary(max_size=400), frames)
def test_resync_within_one_frame(garbage, frame):
    """After any garbage (even a cut frame), the next frame is received."""
    dec = proto.FrameDecoder()
    got = dec.feed(garbage + proto.encode_frame(frame))
    assert got and got[-1] == frame


class CDecoder:
    """The firmware's decoder (proto_rx_byte) through ctypes."""

    def __init__(self):
        lib = load_library()
        lib.proto_rx_init.argtypes = [ctypes.c_void_p]
        lib.proto_rx_byte.argtypes = [ctypes.c_void_p, ctypes.c_uint8, ctypes.c_void_p]
        lib.proto_rx_byte.restype = ctypes.c_int
        self.lib = lib
        self.rx = ctypes.create_string_buffer(512)  # proto_rx_t is under 100 bytes
        self.out = ctypes.create_string_buffer(64)  # proto_frame_t: 4 + 48 bytes
        lib.proto_rx_init(self.rx)

    def feed(self, data: bytes) -> list[proto.Frame]:
        got = []
        for b in data:
            if self.lib.proto_rx_byte(self.rx, b, self.out):
                raw = self.out.raw
                got.append(proto.Frame(raw[1], raw[2], raw[4 : 4 + raw[3]], version=raw[0]))
        return got

    def stats(self) -> tuple[int, ...]:
        # proto_rx_t starts with its counters: frames, crc, framing, overlong, short (proto.h)
        return tuple(int.from_bytes(self.rx.raw[4 * i : 4 + 4 * i], "little") for i in range(5))


@given(st.lists(st.one_of(frames.map(proto.encode_frame), st.binary(max_size=120)), max_size=12))
def test_c_and_python_decoders_agree(parts):
    """The same bytes (valid frames mixed with garbage) give the same frames and the same
    rejection counts in C and in Python."""
    data = b"".join(parts)
    c, py = CDecoder(), proto.FrameDecoder()
    assert c.feed(data) == py.feed(data)
    s = py.stats
    assert c.stats() == (s.frames, s.crc_errors, s.framing_errors, s.overlong, s.short_frames)


can_frames = st.builds(
    proto.Frame,
    msg=st.integers(1, 20) | st.integers(24, 31),  # not the telemetry ids
    seq=st.integers(0, 255),
    payload=st.binary(max_size=msgs.MAX_PAYLOAD),
)


@given(st.lists(can_frames, max_size=6))
def test_can_round_trip(fs):
    r = proto.CanReassembler(node=5)
    got = []
    for f in fs:
        f = proto.Frame(f.msg, f.seq, f.payload[: proto.CAN_SINGLE_MAX])
        if msgs.MESSAGE_BY_ID.get(f.msg) and msgs.MESSAGE_BY_ID[f.msg].can_segmented:
            f = proto.Frame(f.msg, f.seq, f.payload)
        for cid, d in proto.can_encode(5, f):
            assert len(d) <= 8 and cid >> 5 == 5
            got += r.feed(cid, d)
        assert got[-1] == f


def test_parameter_words():
    mu = proto.param("comp.mu")
    assert proto.word_from_value(mu, "0.075") == round(0.075 * 2**28)
    assert proto.value_from_word(mu, proto.word_from_value(mu, 0.5)) == 0.5
    mode = proto.param("comp.mode")
    assert proto.word_from_value(mode, "smooth") == 2 and proto.value_from_word(mode, 1) == "paper"
    freq = proto.param("wave.freq_hz")
    assert proto.value_from_word(freq, proto.word_from_value(freq, 0.5)) == 0.5
    assert proto.format_value(proto.param("loop.kff"), 721) == "0.0880127 A/N"
    for name, value, words in (
        ("comp.mode", "fast", "expected one of none, paper, smooth"),
        ("comp.mu", "nan", "finite"),
        ("comp.mu", "abc", "expected a number"),
        ("loop.kff", "5", "outside [0, 3.99988] A/N"),
        ("loop.i_limit", "-1", "outside [0, 7.99976] A"),
        ("no.such", "1", "unknown parameter"),
    ):
        with pytest.raises(
            proto.ProtocolError, match=words.replace("[", r"\[").replace("]", r"\]")
        ):
            proto.word_from_value(proto.param(name), value)


def test_unpack_rejects_wrong_lengths():
    with pytest.raises(proto.ProtocolError, match="PARAM_VALUE: payload of 5 bytes, expected 7..7"):
        proto.unpack("PARAM_VALUE", b"12345")
    with pytest.raises(proto.ProtocolError, match="STREAM: payload of 3 bytes"):
        proto.unpack("STREAM", b"123")
    with pytest.raises(proto.ProtocolError, match="25 elements"):
        proto.pack("STREAM", samples=[0] * 25)
