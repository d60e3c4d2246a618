"""Finding controllers: `bowden bench list` and `--port auto`.

Every candidate is asked HELLO (answered by a device of any protocol version, PROTOCOL.md) and
nothing else, so probing never changes a device's state, not even a run in progress:

- serial: the ports pyserial lists (`serial.tools.list_ports.comports()`), one after the other,
  each with a short reply timeout. `serial_ports` is the one place the list comes from, so that
  tests (and a script that knows of ports pyserial cannot list, such as an emulator's pty or a
  `socket://` URL) can pass their own `ports`.
- CAN: HELLO to every node id (0..63) of one bus at once; every node that answers within the
  timeout is a controller.

A port that does not open (in use, no permission) or a device that does not answer is not a
controller and is skipped; `Found` describes one that answered.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from . import messages as msgs
from .client import BenchClient, BenchError, BenchUsageError, DeviceInfo, SerialLink
from .protocol import CanReassembler, Frame, ProtocolError, can_encode, pack, unpack

PROBE_TIMEOUT_S = 0.5  # per serial port (a loaded host answers HELLO within it)


class AmbiguousPortError(BenchUsageError):
    """`--port auto` found several controllers: the user must name one (exit 2)."""


@dataclass(frozen=True)
class Found:
    """One controller that answered HELLO: where (port, CAN node) and who it says it is."""

    port: str
    node: int | None
    info: DeviceInfo

    @property
    def compatible(self) -> bool:
        """Same protocol version and table hash as this host (a session may go on)."""
        return (
            self.info.proto_version == msgs.PROTOCOL_VERSION
            and self.info.table_hash == msgs.TABLE_HASH
        )

    @property
    def state(self) -> str:
        i = self.info
        run = "running" if i.running else "idle"
        saved = ", unsaved changes" if i.dirty else ""
        return f"{run}, configuration {i.config_source}{saved}"

    def row(self) -> list[str]:
        i = self.info
        proto = f"{i.proto_version}" + ("" if self.compatible else " (host: other)")
        return [
            self.port,
            "-" if self.node is None else str(self.node),
            f"{i.firmware} ({i.build_id:08x})",
            proto,
            f"{i.table_hash:08x}",
            self.state,
        ]


HEADER = ["port", "node", "firmware (build)", "protocol", "table", "state"]


def table(found: list[Found]) -> str:
    """The controllers found as an aligned text table (header first)."""
    rows = [HEADER] + [f.row() for f in found]
    widths = [max(len(r[c]) for r in rows) for c in range(len(HEADER))]
    return "\n".join(
        "  ".join(cell.ljust(w) for cell, w in zip(r, widths, strict=True)).rstrip() for r in rows
    )


def serial_ports() -> list[str]:
    """The serial ports pyserial lists on this machine (device names, e.g. /dev/ttyUSB0)."""
    from serial.tools import list_ports  # noqa: PLC0415 (pyserial only when probing)

    return sorted(p.device for p in list_ports.comports())


def probe_port(url: str, baud: int = 921_600, timeout_s: float = PROBE_TIMEOUT_S) -> Found | None:
    """HELLO on one serial URL; the controller there, or None (no answer, does not open)."""
    try:
        link = SerialLink(url, baud=baud)
    except BenchError:
        return None
    try:
        client = BenchClient(link, timeout_s=timeout_s)
        try:
            return Found(port=url, node=None, info=client.hello())
        except (BenchError, ProtocolError):
            return None
    finally:
        link.close()


def probe_serial(
    ports: Iterable[str] | None = None,
    baud: int = 921_600,
    timeout_s: float = PROBE_TIMEOUT_S,
    probe: Callable[..., Found | None] = probe_port,
) -> tuple[list[Found], list[str]]:
    """Probe `ports` (default: `serial_ports()`); returns (controllers found, ports probed)."""
    probed = list(serial_ports() if ports is None else ports)
    found = [f for f in (probe(url, baud=baud, timeout_s=timeout_s) for url in probed) if f]
    return found, probed


def probe_can(spec: str, timeout_s: float = 1.0, bus=None) -> list[Found]:
    """HELLO to every node of the python-can bus `spec` (INTERFACE:CHANNEL) at once; the nodes
    that answer, by node id. `bus`: an open python-can bus to use instead of opening `spec`."""
    import can  # noqa: PLC0415 (python-can only when a CAN link is used)

    own = bus is None
    if own:
        interface, sep, channel = spec.partition(":")
        if not sep or not interface:
            raise BenchError(f"--can {spec}: expected INTERFACE:CHANNEL (e.g. virtual:bench)")
        try:
            bus = can.Bus(interface=interface, channel=channel)
        except (can.CanError, ValueError, ImportError, OSError) as exc:
            raise BenchError(f"--can {spec}: cannot open the bus ({exc})") from None
    nodes = range(1 << msgs.CAN_NODE_BITS)
    hello = msgs.MESSAGES["HELLO"].id
    ack = msgs.MESSAGES["HELLO_ACK"].id
    reassemblers = {n: CanReassembler(node=n) for n in nodes}
    answers: dict[int, DeviceInfo] = {}
    try:
        for n in nodes:
            # seq n + 1 (1..64): a reply names the request it answers (0 is the device's own).
            for cid, data in can_encode(n, Frame(msg=hello, seq=n + 1, payload=pack("HELLO"))):
                bus.send(can.Message(arbitration_id=cid, data=data, is_extended_id=False))
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            m = bus.recv(timeout=min(left, 0.02))
            if m is None or m.is_extended_id:
                continue
            node = m.arbitration_id >> msgs.CAN_MESSAGE_BITS
            for f in reassemblers[node].feed(m.arbitration_id, bytes(m.data)):
                if f.msg == ack and f.seq == node + 1:
                    try:
                        answers[node] = DeviceInfo.from_hello(unpack("HELLO_ACK", f.payload))
                    except ProtocolError:
                        continue
    finally:
        if own:
            bus.shutdown()
    return [Found(port=spec, node=n, info=answers[n]) for n in sorted(answers)]


def auto_port(
    ports: Iterable[str] | None = None, baud: int = 921_600, timeout_s: float = PROBE_TIMEOUT_S
) -> str:
    """`--port auto`: the URL of the only controller found; BenchError (one line) when there is
    none or when there are several (listing them: which one is for the user to say)."""
    found, probed = probe_serial(ports, baud=baud, timeout_s=timeout_s)
    if len(found) == 1:
        return found[0].port
    if not found:
        where = f"{len(probed)} serial port(s) probed" if probed else "pyserial lists no ports"
        raise BenchError(f"--port auto: no controller answered HELLO ({where})")
    names = ", ".join(
        f"{f.port} (firmware {f.info.firmware}, {'running' if f.info.running else 'idle'})"
        for f in found
    )
    raise AmbiguousPortError(
        f"--port auto: {len(found)} controllers found, name one with --port: {names}"
    )
