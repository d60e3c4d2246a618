"""The host side of a bench session: links, requests with their replies, and recordings.

- `SerialLink(url)`: any pyserial URL (/dev/ttyUSB0, /dev/pts/N, socket://host:port, ...).
- `CanLink(spec, node)`: any python-can interface, `INTERFACE:CHANNEL` (virtual:bench,
  socketcan:can0, ...).
- `BenchClient(link)`: `connect()` stops a stream it finds running, resynchronises and checks the
  device's protocol version and table hash against this host's (`VersionMismatchError`, one line
  naming both); then `get`, `set`, `persist`, `faults`, ... and `record()`. Replies are matched to
  requests by their seq, so telemetry in flight never passes for a reply, nor a stale reply for a
  new one. A device's ERROR comes back as `DeviceError` with its message.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from . import messages as msgs
from .protocol import (
    CanReassembler,
    DecoderStats,
    Frame,
    FrameDecoder,
    ProtocolError,
    can_encode,
    encode_frame,
    format_value,
    pack,
    param,
    unpack,
    value_from_word,
    word_from_value,
)

MSG = {name: m.id for name, m in msgs.MESSAGES.items()}
ERROR_NAMES = {v: k for k, v in msgs.ERRORS.items()}
# A request at least this often while a run records: the device stops a run whose port is silent
# for HOST_WATCHDOG.TIMEOUT_MS (500 ms), so a crashed host never leaves the motor driven; one in
# five may be late or lost before the device stops.
KEEP_ALIVE_S = 0.1
_ERROR_TEXT_MAX = msgs.MESSAGES["ERROR"].fields[-1].count[1]  # characters an ERROR carries


class BenchError(RuntimeError):
    """A bench session failed; the message is one line for the user."""


class BenchUsageError(BenchError):
    """A value given on the command line that the device or the run cannot take (exit 2)."""


class VersionMismatchError(BenchError):
    """The device speaks another protocol version or table than this host."""


class DeviceError(BenchError):
    """The device answered ERROR: `code` (errors table name), `detail`, `text`."""

    def __init__(self, request: str, code: int, detail: int, text: str) -> None:
        self.code = ERROR_NAMES.get(code, str(code))
        self.detail = detail
        self.text = text
        super().__init__(f"{request}: device error {self.code}: {text}")


class LinkTimeoutError(BenchError):
    """No reply in time."""


class PortBusyError(BenchError):
    """Another client holds the port (`PortLock`): `holder` is what its lock file says (its pid
    and command line)."""

    def __init__(self, message: str, holder: str) -> None:
        super().__init__(message)
        self.holder = holder


class LockFolderError(BenchUsageError):
    """The folder for port locks (`runtime_dir()`) cannot be written: no port can be used."""


# --- links ---------------------------------------------------------------------------------------


def runtime_dir() -> str:
    """Where a user's bench tools leave their locks and registrations: $XDG_RUNTIME_DIR (the
    user's own, cleared at logout), else the temporary folder."""
    return os.environ.get("XDG_RUNTIME_DIR") or tempfile.gettempdir()


class PortLock:
    """One client per port: an advisory lock (flock) on a file named after the port, holding
    the holder's pid and command line. The OS drops the lock when its process dies, so a killed
    client never leaves the port locked. (Serial devices are also opened with pyserial's
    `exclusive=True`; a pty or a socket:// URL has only this lock. A CAN node on this machine's
    bus is locked by its INTERFACE:CHANNEL and node number: `option` names it in the refusal.)

    The holder removes the file when it lets go (`close`), so locks do not pile up in the
    runtime folder, one per port ever opened. Removing a lock file is safe only with the check
    that follows every flock: a client that waited on the old file finds, once it holds the
    lock, that the name no longer leads to its file, and starts again on the new one."""

    def __init__(self, url: str, option: str = "--port", key: str | None = None) -> None:
        if key is None:
            key = url if "://" in url else os.path.realpath(url)
        folder = runtime_dir()
        digest = hashlib.sha256(key.encode()).hexdigest()[:16]
        self.path = os.path.join(folder, f"bowden-bench-{digest}.lock")
        self._fd: int | None = None
        while self._fd is None:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as exc:  # every port alike: not a port's problem, the folder's
                raise LockFolderError(
                    f"cannot make a port lock in {folder} ({exc.strerror}): $XDG_RUNTIME_DIR, "
                    "or the temporary folder without it, must be a folder this user can write"
                ) from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.read(fd, 512).decode(errors="replace").strip() or "another process"
                os.close(fd)
                raise PortBusyError(
                    f"{option} {url}: in use by another client ({holder}): one client at a "
                    "time (a second one would stop the first one's run)",
                    holder,
                ) from None
            if _same_file(fd, self.path):
                self._fd = fd
            else:  # its holder removed it between our open and our flock: take the new one
                os.close(fd)
        os.ftruncate(self._fd, 0)
        os.pwrite(self._fd, f"pid {os.getpid()}: {' '.join(sys.argv)[:300]}\n".encode(), 0)

    def close(self) -> None:
        if self._fd is not None:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.path)  # while still held: nobody can hold the name meanwhile
            os.close(self._fd)  # releases the flock
            self._fd = None


def _same_file(fd: int, path: str) -> bool:
    """Whether `path` still names the open file `fd` (not removed, not replaced)."""
    try:
        named = os.stat(path)
    except FileNotFoundError:
        return False
    held = os.fstat(fd)
    return (named.st_dev, named.st_ino) == (held.st_dev, held.st_ino)


class SerialLink:
    """A serial-like link through pyserial's serial_for_url (devices, ptys, socket://)."""

    def __init__(self, url: str, baud: int = 921_600) -> None:
        import serial  # noqa: PLC0415 (pyserial only when a serial link is used)

        self.lock = PortLock(url)
        extra = {} if "://" in url else {"exclusive": True}
        try:
            self.port = serial.serial_for_url(
                url, baudrate=baud, timeout=0, write_timeout=2.0, **extra
            )
        except (serial.SerialException, ValueError) as exc:
            self.lock.close()
            raise BenchError(f"--port {url}: cannot open ({exc})") from None
        self.url = url
        self.decoder = FrameDecoder()

    @property
    def stats(self) -> DecoderStats:
        return self.decoder.stats

    def send(self, frame: Frame) -> None:
        self.write_raw(encode_frame(frame))

    def write_raw(self, data: bytes) -> None:
        """Bytes as they are (garbage injection in tests)."""
        import serial  # noqa: PLC0415

        try:
            self.port.write(data)
        except serial.SerialException as exc:
            raise BenchError(f"{self.url}: write failed ({exc})") from None

    def recv(self, timeout_s: float) -> list[Frame]:
        import serial  # noqa: PLC0415

        deadline = time.monotonic() + timeout_s
        while True:
            try:
                # With timeout 0, read(n) returns what is there, up to n bytes. (in_waiting is no
                # help: pyserial's socket:// reports 1 whenever anything is waiting.)
                data = self.port.read(4096)
            except serial.SerialException as exc:
                raise BenchError(f"{self.url}: read failed ({exc})") from None
            if data:
                frames = self.decoder.feed(data)
                if frames:
                    return frames
            if time.monotonic() >= deadline:
                return []
            time.sleep(0.0005)

    def close(self) -> None:
        try:
            self.port.close()
        finally:
            self.lock.close()


class CanLink:
    """The protocol over a python-can bus, to one node."""

    def __init__(self, spec: str, node: int = msgs.CAN_DEFAULT_NODE, bus=None) -> None:
        import can  # noqa: PLC0415 (python-can only when a CAN link is used)

        interface, sep, channel = spec.partition(":")
        if not sep or not interface:
            raise BenchUsageError(f"--can {spec}: expected INTERFACE:CHANNEL (e.g. virtual:bench)")
        if not 0 <= node < (1 << msgs.CAN_NODE_BITS):
            raise BenchUsageError(f"--node {node}: outside 0..{(1 << msgs.CAN_NODE_BITS) - 1}")
        # One client per node of a bus on this machine (a bus handed in is the caller's).
        self.lock = (
            None
            if bus is not None
            else PortLock(f"{spec} node {node}", "--can", key=f"can {spec} node {node}")
        )
        try:
            self.bus = bus or can.Bus(interface=interface, channel=channel)
        except (can.CanError, ValueError, ImportError, OSError) as exc:
            if self.lock is not None:
                self.lock.close()
            raise BenchError(f"--can {spec}: cannot open the bus ({exc})") from None
        self._can = can
        self.url = spec
        self.node = node
        self.reassembler = CanReassembler(node=node)

    @property
    def stats(self) -> DecoderStats:
        return self.reassembler.stats

    def send(self, frame: Frame) -> None:
        for cid, data in can_encode(self.node, frame):
            self.bus.send(self._can.Message(arbitration_id=cid, data=data, is_extended_id=False))

    def write_raw(self, data: bytes) -> None:
        """Raw CAN frames of garbage for the node (8 bytes each)."""
        for i in range(0, len(data), 8):
            cid = (self.node << msgs.CAN_MESSAGE_BITS) | (data[i] % 32)
            self.bus.send(
                self._can.Message(arbitration_id=cid, data=data[i : i + 8], is_extended_id=False)
            )

    def recv(self, timeout_s: float) -> list[Frame]:
        deadline = time.monotonic() + timeout_s
        out: list[Frame] = []
        while True:
            msg = self.bus.recv(timeout=max(0.0, min(0.01, deadline - time.monotonic())))
            if msg is not None and not msg.is_extended_id:
                out += self.reassembler.feed(msg.arbitration_id, bytes(msg.data))
                # Take what else is already there, then hand it over.
                while True:
                    more = self.bus.recv(timeout=0)
                    if more is None:
                        break
                    if not more.is_extended_id:
                        out += self.reassembler.feed(more.arbitration_id, bytes(more.data))
            if out or time.monotonic() >= deadline:
                return out

    def close(self) -> None:
        try:
            self.bus.shutdown()
        finally:
            if self.lock is not None:
                self.lock.close()


# --- the client ----------------------------------------------------------------------------------


@dataclass
class DeviceInfo:
    """What HELLO says."""

    proto_version: int
    firmware: str
    build_id: int
    table_hash: int
    n_params: int
    running: bool
    config_source: str
    dirty: bool
    n_channels: int = 1  # cables the device drives (protocol 3)

    @classmethod
    def from_hello(cls, v: dict) -> DeviceInfo:
        """From the fields of a HELLO_ACK."""
        sources = {v: k.lower() for k, v in msgs.CONFIG_SOURCE.items()}
        return cls(
            proto_version=v["proto_version"],
            firmware=f"{v['fw_major']}.{v['fw_minor']}.{v['fw_patch']}",
            build_id=v["build_id"],
            table_hash=v["table_hash"],
            n_params=v["n_params"],
            running=bool(v["running"]),
            config_source=sources.get(v["config_source"], str(v["config_source"])),
            dirty=bool(v["dirty"]),
            n_channels=v.get("n_channels", 1),
        )


@dataclass
class BenchClient:
    """One session with a device over a link (see the module docstring)."""

    link: object
    timeout_s: float = 1.0
    telemetry: list[dict] = field(default_factory=list)
    on_telemetry: Callable[[dict], None] | None = None
    stale_telemetry: int = 0  # frames of a stream that was running when we connected
    # The channel a request addresses when it names none (`bowden bench --channel K`): the
    # parameters, faults, stream and run of that channel.
    channel: int = 0
    _seq: int = 0
    _last_send: float = 0.0  # time.monotonic() of the last request sent (keep_alive)
    _backlog: list = field(default_factory=list)  # frames received after a reply, not yet handled

    # --- requests ----------------------------------------------------------------------------

    def _ch(self, channel: int | None) -> int:
        return self.channel if channel is None else channel

    def _next_seq(self) -> int:
        self._seq = self._seq % 255 + 1  # 1..255: 0 is the device's own frames
        return self._seq

    def _dispatch(self, frame: Frame) -> None:
        if frame.msg == MSG["TELEMETRY"]:
            try:
                t = unpack("TELEMETRY", frame.payload)
            except ProtocolError:
                return
            if self.on_telemetry is not None:
                self.on_telemetry(t)
            else:
                self.stale_telemetry += 1

    def request(self, name: str, timeout_s: float | None = None, **fields) -> tuple[str, dict]:
        """Send request `name`, return (reply name, reply fields). Frames that are not its reply
        (telemetry, stale replies) are handled on the way. ERROR raises DeviceError; no reply in
        time raises LinkTimeoutError."""
        seq = self._next_seq()
        self.link.send(Frame(msg=MSG[name], seq=seq, payload=pack(name, **fields)))
        self._last_send = self._clock()
        deadline = time.monotonic() + (self.timeout_s if timeout_s is None else timeout_s)
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise LinkTimeoutError(
                    f"{name}: no reply from {self.link.url} within "
                    f"{self.timeout_s if timeout_s is None else timeout_s:g} s"
                )
            batch = self._take(min(left, 0.05))
            for i, frame in enumerate(batch):
                reply = msgs.MESSAGE_BY_ID.get(frame.msg)
                if frame.seq != seq or reply is None or reply.source != "device":
                    self._dispatch(frame)
                    continue
                self._backlog = batch[i + 1 :] + self._backlog  # what came after it waits
                if reply.name == "HELLO_ACK" or frame.version == msgs.PROTOCOL_VERSION:
                    try:
                        values = unpack(reply.name, frame.payload)
                    except ProtocolError as exc:
                        raise VersionMismatchError(
                            f"{name}: the device's {reply.name} does not match this host's "
                            f"protocol ({exc}): update the host or the firmware"
                        ) from None
                    if reply.name == "ERROR":
                        text = values["text"]
                        if values["detail"] and len(text) >= _ERROR_TEXT_MAX:
                            text = self._full_text(values["detail"], text)
                        raise DeviceError(name, values["code"], values["detail"], text)
                    return reply.name, values
                raise VersionMismatchError(
                    f"{name}: reply in protocol version {frame.version}, this host speaks "
                    f"{msgs.PROTOCOL_VERSION}"
                )

    def _full_text(self, status: int, head: str) -> str:
        """A status code's whole message: ERROR carries its first characters, TEXT_GET the rest
        (what came is kept when the device does not answer)."""
        text = head
        try:
            while True:
                _, v = self.request("TEXT_GET", status=status, offset=len(text))
                if v["offset"] != len(text) or not v["text"]:
                    return text
                text += v["text"]
                if len(text) >= v["total"]:
                    return text
        except BenchError:
            return text

    def _take(self, timeout_s: float) -> list[Frame]:
        if self._backlog:
            batch, self._backlog = self._backlog, []
            return batch
        return self.link.recv(timeout_s)

    def poll(self, timeout_s: float) -> int:
        """Handle the frames that arrive within timeout_s (telemetry to on_telemetry); returns
        how many."""
        batch = self._take(timeout_s)
        for frame in batch:
            self._dispatch(frame)
        return len(batch)

    # --- session -----------------------------------------------------------------------------

    def connect(self) -> DeviceInfo:
        """Stop a stream the device may be sending, resynchronise, and check the versions."""
        last: BenchError | None = None
        for _ in range(3):  # the first STOP may be lost in garbage the device was fed
            try:
                self.request("STOP")
                break
            except (DeviceError, VersionMismatchError):
                break  # a device that answers at all is there: HELLO says who it is
            except LinkTimeoutError as exc:
                last = exc
        else:
            raise BenchError(f"no answer from {self.link.url}: {last}") from None
        info = self.hello()
        host = f"protocol {msgs.PROTOCOL_VERSION}, table {msgs.TABLE_HASH:08x}"
        dev = (
            f"firmware {info.firmware} (build {info.build_id:08x}) speaks protocol "
            f"{info.proto_version}, table {info.table_hash:08x}"
        )
        if info.proto_version != msgs.PROTOCOL_VERSION or info.table_hash != msgs.TABLE_HASH:
            raise VersionMismatchError(
                f"version mismatch: this host speaks {host}; the device's {dev}: update the host "
                "(bowden) or the firmware so that both are built from the same protocol table"
            )
        return info

    def hello(self) -> DeviceInfo:
        _, v = self.request("HELLO")
        return DeviceInfo.from_hello(v)

    # --- parameters ----------------------------------------------------------------------------

    def get_word(self, name: str, channel: int | None = None) -> int:
        _, v = self.request(
            "PARAM_GET", param=param(name).id, channel=_channel_field(self._ch(channel))
        )
        return v["value"]

    def get(self, name: str, channel: int | None = None) -> float | str:
        return value_from_word(param(name), self.get_word(name, self._ch(channel)))

    def set(self, name: str, value, channel: int | None = None) -> int:
        """Write a parameter (SI value or enum name) of one channel (a device-wide one, dev.*,
        of every channel); returns the word now in force."""
        p = param(name)
        if p.read_only:
            raise ProtocolError(f"{name} is read-only")
        _, v = self.request(
            "PARAM_SET",
            param=p.id,
            value=word_from_value(p, value),
            channel=_channel_field(self._ch(channel)),
        )
        return v["value"]

    def set_word(self, name: str, word: int, channel: int | None = None) -> int:
        _, v = self.request(
            "PARAM_SET", param=param(name).id, value=word, channel=_channel_field(self._ch(channel))
        )
        return v["value"]

    def params(self, channel: int | None = None) -> dict[str, int]:
        """Every parameter's word of one channel, by name."""
        return {p.name: self.get_word(p.name, self._ch(channel)) for p in msgs.PARAMS}

    def describe(self, words: dict[str, int]) -> list[tuple[str, str]]:
        return [(name, format_value(param(name), w)) for name, w in words.items()]

    # --- other requests ----------------------------------------------------------------------

    def simple(self, name: str, **fields) -> int:
        """A request answered by ACK; returns the ACK's value."""
        _, v = self.request(name, **fields)
        return v["value"]

    def _clock(self) -> float:
        """Seconds as the device counts them: the wall clock, or a stepped link's own."""
        clock = getattr(self.link, "clock", None)
        return clock() if clock is not None else time.monotonic()

    def keep_alive(self, interval_s: float = KEEP_ALIVE_S) -> bool:
        """Feed the device's host watchdog during a run: send FAULTS_GET (no side effects, a
        short reply) when no request went out for interval_s, without waiting for the reply
        (request() and poll() pass it by as a frame of another seq). True when one was sent."""
        now = self._clock()
        if now - self._last_send < interval_s:
            return False
        self.link.send(
            Frame(msg=MSG["FAULTS_GET"], seq=self._next_seq(), payload=pack("FAULTS_GET"))
        )
        self._last_send = now
        return True

    def faults(self, channel: int | None = None) -> dict:
        _, v = self.request("FAULTS_GET", channel=_channel_field(self._ch(channel)))
        return v

    def stats(self) -> dict:
        _, v = self.request("STATS_GET")
        return v

    def stream(self, samples: Iterable[int], channel: int | None = None) -> int:
        """Append T_ref words (Q7.8) to a channel's stream buffer; returns its free slots."""
        channel = self._ch(channel)
        if channel == 0:
            return self.simple("STREAM", samples=list(samples))
        return self.simple("STREAM_CH", channel=channel, samples=list(samples))


def _channel_field(channel: int) -> list[int]:
    """A request's optional channel field: absent for channel 0, so that a one-channel session
    sends the frames it always sent."""
    return [channel] if channel else []


def channel_mask(channels: Iterable[int]) -> list[int]:
    """START's optional channel_mask field for these channels (bit k: channel k)."""
    mask = 0
    for c in channels:
        mask |= 1 << c
    return [mask]


def fault_names(bits: int) -> list[str]:
    """The names of the fault bits set in the telemetry's fault byte or FAULTS.device_faults."""
    return [name for name, v in msgs.FAULTS.items() if bits & v]


def status_names(bits: int) -> list[str]:
    return [name for name, v in msgs.STATUS.items() if bits & v]
