"""The bench protocol on the host: frames, payloads, CAN mapping and parameter words.

The layouts come from the generated tables (`cosim.bench.link.messages`, made by
firmware/proto/gen_proto.py from firmware/proto/bowden_proto.json); the document is
firmware/proto/PROTOCOL.md. COBS is the `cobs` package, CRC-32C the `crc32c` package (both C
extensions); nothing here allocates per byte.

- `encode_frame` / `FrameDecoder`: the serial framing ([version][message][seq][payload][CRC-32C],
  COBS, between two 0x00 delimiters). The decoder takes any chunks of bytes and never raises:
  garbage, truncated, overlong and CRC-failing frames are counted in `FrameDecoder.stats` and it
  resynchronises at the next delimiter.
- `pack` / `unpack`: payload <-> dict of field values (`ProtocolError` for a wrong length).
- `can_encode` / `CanReassembler`: the CAN mapping (one frame, segments, TELEM_A + TELEM_B).
- `word_from_value` / `value_from_word`: a parameter's SI value (or enum name) <-> its 32-bit word.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field

from cobs import cobs
from crc32c import crc32c

from . import messages as msgs

HEADER_LEN = 3
CRC_LEN = 4
MAX_RAW = HEADER_LEN + msgs.MAX_PAYLOAD + CRC_LEN
MAX_COBS = MAX_RAW + MAX_RAW // 254 + 1
CAN_SINGLE_MAX = 7
CAN_SEG_DATA = 6


class ProtocolError(ValueError):
    """A payload that does not match its message's layout, or a value a field cannot hold."""


@dataclass(frozen=True)
class Frame:
    """One message: its id, request id (seq), payload bytes and the frame's version byte."""

    msg: int
    seq: int
    payload: bytes = b""
    version: int = msgs.PROTOCOL_VERSION

    @property
    def name(self) -> str:
        m = msgs.MESSAGE_BY_ID.get(self.msg)
        return m.name if m else f"message {self.msg}"


# --- payloads ------------------------------------------------------------------------------------


def _fixed_format(message: msgs.Message) -> str:
    return "<" + "".join(f.code for f in message.fields if f.count is None)


_FORMATS = {name: struct.Struct(_fixed_format(m)) for name, m in msgs.MESSAGES.items()}


def pack(name: str, **values) -> bytes:
    """The payload of message `name` from its field values (a tail field takes a sequence; the
    ERROR text takes a str). Raises ProtocolError naming the field that does not fit."""
    message = msgs.MESSAGES[name]
    fixed = [values[f.name] for f in message.fields if f.count is None]
    try:
        out = _FORMATS[name].pack(*fixed)
    except struct.error as exc:
        raise ProtocolError(f"{name}: {exc}") from None
    tail = message.fields[-1] if message.fields and message.fields[-1].count else None
    if tail is not None:
        items = values.get(tail.name, ())
        if isinstance(items, str):
            items = items.encode("ascii", "replace")
        lo, hi = tail.count
        if not lo <= len(items) <= hi:
            raise ProtocolError(f"{name}.{tail.name}: {len(items)} elements, allowed {lo}..{hi}")
        if tail.code == "s":
            out += bytes(items)
        else:
            try:
                out += struct.pack("<" + tail.code * len(items), *items)
            except struct.error as exc:
                raise ProtocolError(f"{name}.{tail.name}: {exc}") from None
    return out


def unpack(name: str, payload: bytes) -> dict:
    """Field values of a payload of message `name`; raises ProtocolError for a wrong length."""
    message = msgs.MESSAGES[name]
    fmt = _FORMATS[name]
    n = len(payload)
    tail = message.fields[-1] if message.fields and message.fields[-1].count else None
    if (
        n < message.min_len
        or n > message.max_len
        or (tail is not None and (n - fmt.size) % tail.size)
    ):
        raise ProtocolError(
            f"{name}: payload of {n} bytes, expected {message.min_len}..{message.max_len}"
        )
    values = dict(
        zip(
            (f.name for f in message.fields if f.count is None),
            fmt.unpack_from(payload),
            strict=True,
        )
    )
    if tail is not None:
        rest = payload[fmt.size :]
        if tail.code == "s":
            values[tail.name] = rest.decode("ascii", "replace")
        else:
            values[tail.name] = list(
                struct.unpack("<" + tail.code * (len(rest) // tail.size), rest)
            )
    return values


# --- serial framing ------------------------------------------------------------------------------


def encode_frame(frame: Frame) -> bytes:
    """The frame on the wire: 0x00, COBS(header + payload + CRC-32C), 0x00."""
    if len(frame.payload) > msgs.MAX_PAYLOAD:
        raise ProtocolError(
            f"{frame.name}: payload of {len(frame.payload)} bytes exceeds the limit"
        )
    raw = bytes((frame.version & 0xFF, frame.msg & 0xFF, frame.seq & 0xFF)) + frame.payload
    raw += (crc32c(raw) & 0xFFFFFFFF).to_bytes(4, "little")
    return b"\x00" + cobs.encode(raw) + b"\x00"


@dataclass
class DecoderStats:
    """What a FrameDecoder saw: accepted frames and each kind of rejection."""

    frames: int = 0
    crc_errors: int = 0
    framing_errors: int = 0
    overlong: int = 0
    short_frames: int = 0
    bytes: int = 0

    @property
    def rejected(self) -> int:
        return self.crc_errors + self.framing_errors + self.overlong + self.short_frames


@dataclass
class FrameDecoder:
    """Streaming decoder of the serial framing: feed any chunks, get whole frames back.

    Never raises on input: every byte string ends in frames, counted rejections or bytes held
    for the next chunk. Resynchronises at the next 0x00 after any damage.
    """

    stats: DecoderStats = field(default_factory=DecoderStats)
    _buf: bytearray = field(default_factory=bytearray)
    _discard: bool = False

    def feed(self, data: bytes) -> list[Frame]:
        """Frames completed by `data`, oldest first."""
        out: list[Frame] = []
        self.stats.bytes += len(data)
        parts = bytes(data).split(b"\x00")
        # parts[0] continues the frame in progress; every later part starts after a delimiter.
        for i, part in enumerate(parts):
            if not self._discard:
                self._buf += part
                if len(self._buf) > MAX_COBS:
                    self.stats.overlong += 1
                    self._buf.clear()
                    self._discard = True
            if i == len(parts) - 1:
                break  # no delimiter after the last part: keep it for the next chunk
            if not self._discard and self._buf:
                frame = self._frame(bytes(self._buf))
                if frame is not None:
                    out.append(frame)
            self._buf.clear()
            self._discard = False
        return out

    def _frame(self, body: bytes) -> Frame | None:
        try:
            raw = cobs.decode(body)
        except cobs.DecodeError:
            self.stats.framing_errors += 1
            return None
        if len(raw) < HEADER_LEN + CRC_LEN:
            self.stats.short_frames += 1
            return None
        if crc32c(raw[:-CRC_LEN]) & 0xFFFFFFFF != int.from_bytes(raw[-CRC_LEN:], "little"):
            self.stats.crc_errors += 1
            return None
        self.stats.frames += 1
        return Frame(msg=raw[1], seq=raw[2], payload=raw[HEADER_LEN:-CRC_LEN], version=raw[0])


# --- CAN -----------------------------------------------------------------------------------------


def can_id(node: int, msg: int) -> int:
    """11-bit identifier: node << message_bits | message."""
    return ((node & ((1 << msgs.CAN_NODE_BITS) - 1)) << msgs.CAN_MESSAGE_BITS) | (
        msg & ((1 << msgs.CAN_MESSAGE_BITS) - 1)
    )


def can_encode(node: int, frame: Frame) -> list[tuple[int, bytes]]:
    """The CAN frames (id, data) of a message: one frame, segments, or TELEM_A + TELEM_B."""
    if frame.msg == msgs.MESSAGES["TELEMETRY"].id:
        t = unpack("TELEMETRY", frame.payload)
        a = pack(
            "TELEM_A",
            sample_lo16=t["sample"] & 0xFFFF,
            channel=t["channel"],
            t_ref=t["t_ref"],
            t_c=t["t_c"],
        )
        b = pack(
            "TELEM_B",
            sample_lo=t["sample"] & 0xFF,
            t_in=t["t_in"],
            t_out=t["t_out"],
            current=t["current"],
            faults=t["faults"],
        )
        return [
            (can_id(node, msgs.MESSAGES["TELEM_A"].id), a),
            (can_id(node, msgs.MESSAGES["TELEM_B"].id), b),
        ]
    cid = can_id(node, frame.msg)
    message = msgs.MESSAGE_BY_ID.get(frame.msg)
    if message is None or not message.can_segmented:
        if len(frame.payload) > CAN_SINGLE_MAX:
            raise ProtocolError(f"{frame.name}: {len(frame.payload)} bytes do not fit a CAN frame")
        return [(cid, bytes((frame.seq,)) + frame.payload)]
    data = bytes((len(frame.payload),)) + frame.payload
    return [
        (cid, bytes((frame.seq, i // CAN_SEG_DATA)) + data[i : i + CAN_SEG_DATA])
        for i in range(0, len(data), CAN_SEG_DATA)
    ]


@dataclass
class CanReassembler:
    """Messages from CAN frames of one node: single frames, segments, and telemetry pairs.

    `feed(can_id, data)` returns a list of Frames (TELEMETRY rebuilt from TELEM_A + TELEM_B, with
    the time and overflow fields 0: CAN telemetry does not carry them; the sample index extended
    per channel from TELEM_A's low 16 bits). Frames of other nodes are ignored; out-of-order
    segments and unpaired telemetry halves are counted in `stats`.
    """

    node: int
    stats: DecoderStats = field(default_factory=DecoderStats)
    _seg: dict | None = None
    _telem_a: dict | None = None
    _sample: dict = field(default_factory=dict)  # channel -> the last sample index rebuilt

    def feed(self, cid: int, data: bytes) -> list[Frame]:
        if cid >> msgs.CAN_MESSAGE_BITS != self.node or len(data) > 8:
            return []
        msg = cid & ((1 << msgs.CAN_MESSAGE_BITS) - 1)
        message = msgs.MESSAGE_BY_ID.get(msg)
        if message is not None and message.name in ("TELEM_A", "TELEM_B"):
            return self._telemetry(message.name, data)
        if not data:
            self.stats.short_frames += 1
            return []
        if message is None or not message.can_segmented:
            self.stats.frames += 1
            return [Frame(msg=msg, seq=data[0], payload=bytes(data[1:]))]
        if len(data) < 2:
            self.stats.short_frames += 1
            return []
        seq, index = data[0], data[1]
        if index == 0:
            if self._seg is not None:
                self.stats.framing_errors += 1
            if len(data) < 3 or data[2] > msgs.MAX_PAYLOAD:
                self.stats.framing_errors += 1
                self._seg = None
                return []
            self._seg = {"msg": msg, "seq": seq, "next": 1, "len": data[2], "buf": bytes(data[3:])}
        else:
            s = self._seg
            if s is None or s["msg"] != msg or s["seq"] != seq or s["next"] != index:
                self.stats.framing_errors += 1
                self._seg = None
                return []
            s["buf"] += bytes(data[2:])
            s["next"] += 1
        s = self._seg
        if len(s["buf"]) > s["len"]:
            self.stats.framing_errors += 1
            self._seg = None
            return []
        if len(s["buf"]) < s["len"]:
            return []
        self._seg = None
        self.stats.frames += 1
        return [Frame(msg=s["msg"], seq=s["seq"], payload=s["buf"])]

    def _telemetry(self, name: str, data: bytes) -> list[Frame]:
        try:
            values = unpack(name, bytes(data))
        except ProtocolError:
            self.stats.short_frames += 1
            return []
        if name == "TELEM_A":
            if self._telem_a is not None:
                self.stats.framing_errors += 1  # its B never came
            self._telem_a = values
            return []
        a, self._telem_a = self._telem_a, None
        if a is None or (a["sample_lo16"] & 0xFF) != values["sample_lo"]:
            self.stats.framing_errors += 1
            return []
        self.stats.frames += 1
        # The sample index from its low 16 bits: the channel's last one plus the forward distance
        # when that is short (telemetry_div <= 1000); a long one is a new run, which starts at 0.
        last = self._sample.get(a["channel"])
        step = (a["sample_lo16"] - (last or 0)) & 0xFFFF
        sample = last + step if last is not None and step < 0x8000 else a["sample_lo16"]
        self._sample[a["channel"]] = sample
        payload = pack(
            "TELEMETRY",
            time_us=0,
            sample=sample & 0xFFFFFFFF,
            overflow=0,
            t_ref=a["t_ref"],
            t_c=a["t_c"],
            t_in=values["t_in"],
            t_out=values["t_out"],
            current=values["current"],
            faults=values["faults"],
            status=0,
            # Not carried over CAN (TELEM_A and TELEM_B are full): the recorder leaves them out.
            mu_phi=0,
            est_faults=0,
            channel=a["channel"],
        )
        return [Frame(msg=msgs.MESSAGES["TELEMETRY"].id, seq=0, payload=payload)]


# --- parameters ----------------------------------------------------------------------------------


def param(name: str) -> msgs.Param:
    """The parameter `name`; ProtocolError listing the names when it does not exist."""
    p = msgs.PARAM_BY_NAME.get(name)
    if p is None:
        raise ProtocolError(
            f"unknown parameter {name!r}; parameters: {', '.join(msgs.PARAM_BY_NAME)}"
        )
    return p


def word_from_value(p: msgs.Param, value: str | float | int) -> int:
    """The 32-bit word (as a signed int32 on the wire) for a value in SI units or an enum name.

    Raises ProtocolError naming the parameter and what it accepts when the value is not a finite
    number, not one of the enum's names, or outside the word's range.
    """
    if p.enum is not None and isinstance(value, str) and not _is_number_text(value):
        if value not in p.enum:
            raise ProtocolError(f"{p.name}={value}: expected one of {', '.join(p.enum)}")
        word = p.enum[value]
    else:
        try:
            v = float(value)
        except (TypeError, ValueError):
            what = f"one of {', '.join(p.enum)} or a number" if p.enum else "a number"
            raise ProtocolError(f"{p.name}={value}: expected {what}") from None
        if not math.isfinite(v):
            raise ProtocolError(f"{p.name}={value}: expected a finite number")
        if p.frac == 0 and v != math.floor(v):  # a count (ticks, a node id): not rounded
            raise ProtocolError(f"{p.name}={value}: expected a whole number")
        scaled = v * (1 << p.frac)
        if not math.isfinite(scaled):  # a finite number beyond every word once scaled
            lo_v, hi_v = p.lo / (1 << p.frac), p.hi / (1 << p.frac)
            unit = f" {p.unit}" if p.unit else ""
            raise ProtocolError(f"{p.name}={value}: outside [{lo_v:g}, {hi_v:g}]{unit}")
        word = round(scaled)
        if p.name.endswith("phase0") and p.frac == 32:
            word %= 1 << 32  # a phase in turns wraps
    lo_v, hi_v = p.lo / (1 << p.frac), p.hi / (1 << p.frac)
    if not p.lo <= word <= p.hi:
        unit = f" {p.unit}" if p.unit else ""
        raise ProtocolError(f"{p.name}={value}: outside [{lo_v:g}, {hi_v:g}]{unit}")
    return word - (1 << 32) if word >= 1 << 31 else word


def value_from_word(p: msgs.Param, word: int) -> float | str:
    """The SI value (or enum name) of a parameter's word as the device sent it (int32)."""
    w = word & 0xFFFFFFFF if p.unsigned else word
    if p.enum is not None:
        for name, v in p.enum.items():
            if v == w:
                return name
        return str(w)
    return w / (1 << p.frac) if p.frac else w


def format_value(p: msgs.Param, word: int) -> str:
    """A parameter's value for people: `0.075`, `smooth`, `0.0879 A/N`."""
    v = value_from_word(p, word)
    if isinstance(v, str):
        return v
    text = f"{v:.6g}"
    return f"{text} {p.unit}" if p.unit else text


def _is_number_text(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
