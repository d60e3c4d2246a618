"""Finding controllers: `bowden bench list` and `--port auto`.

Every candidate is asked HELLO (answered by a device of any protocol version, PROTOCOL.md) and
nothing else, so probing never changes a device's state, not even a run in progress:

- serial: the ports pyserial lists (`serial.tools.list_ports.comports()`), one after the other,
  each with a short reply timeout, then the emulators that registered themselves (below).
  `serial_ports` is the one place pyserial's list comes from, so that tests (and a script that
  knows of other ports, such as a `socket://` URL) can pass their own `ports`.
- CAN: HELLO to every node id (0..63) of one bus at once; every node that answers within the
  timeout is a controller.

A port that another bench client holds (its advisory lock, `client.PortLock`) is listed as
busy, with the holder its lock names; a port that does not open for another reason (no
permission, no device) or a device that does not answer is not a controller and is skipped.
`Found` describes one that answered or is busy.

pyserial cannot list a pseudo-terminal, so `bowden emulate` makes itself findable, either
target: while it runs, a registry file in the user's runtime folder (`client.runtime_dir()`:
$XDG_RUNTIME_DIR, else the temporary folder, where the port locks are) names its process and its
URLs (`register_emulator`, from the start and stop of the host emulator, `Emulator`, or of the
simulated board, `soc.harness.SocBoard`). A file whose process is gone (an
emulator killed outright) is stale: it is ignored, and removed.
"""

from __future__ import annotations

import itertools
import json
import os
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

from . import messages as msgs
from .client import (
    BenchClient,
    BenchError,
    BenchUsageError,
    DeviceInfo,
    LockFolderError,
    PortBusyError,
    SerialLink,
    runtime_dir,
)
from .protocol import CanReassembler, Frame, ProtocolError, can_encode, pack, unpack

PROBE_TIMEOUT_S = 0.5  # per serial port (a loaded host answers HELLO within it)


class AmbiguousPortError(BenchUsageError):
    """`--port auto` found several controllers: the user must name one (exit 2)."""


@dataclass(frozen=True)
class Found:
    """One controller that answered HELLO: where (port, CAN node) and who it says it is; or a
    port another client holds (`info` None, `holder`: its pid and command line, as its lock
    says), which was not asked anything."""

    port: str
    node: int | None
    info: DeviceInfo | None
    holder: str | None = None

    @property
    def busy(self) -> bool:
        """Another client holds the port: who is behind it is not known."""
        return self.info is None

    @property
    def compatible(self) -> bool:
        """Same protocol version and table hash as this host (a session may go on); False for a
        busy port (not known)."""
        return (
            self.info is not None
            and self.info.proto_version == msgs.PROTOCOL_VERSION
            and self.info.table_hash == msgs.TABLE_HASH
        )

    @property
    def state(self) -> str:
        if self.info is None:
            return f"busy: in use by another client ({self.holder})"
        i = self.info
        run = "running" if i.running else "idle"
        saved = ", unsaved changes" if i.dirty else ""
        return f"{run}, configuration {i.config_source}{saved}"

    def brief(self) -> str:
        """The port and its state in a few words (the refusals of `--port auto`)."""
        if self.info is None:
            return f"{self.port} (busy: {self.holder})"
        run = "running" if self.info.running else "idle"
        return f"{self.port} (firmware {self.info.firmware}, {run})"

    def row(self) -> list[str]:
        i = self.info
        if i is None:
            return [
                self.port,
                "-" if self.node is None else str(self.node),
                "-",
                "-",
                "-",
                "-",
                self.state,
            ]
        proto = f"{i.proto_version}" + ("" if self.compatible else " (host: other)")
        return [
            self.port,
            "-" if self.node is None else str(self.node),
            f"{i.firmware} ({i.build_id:08x})",
            proto,
            f"{i.table_hash:08x}",
            str(i.n_channels),
            self.state,
        ]


HEADER = ["port", "node", "firmware (build)", "protocol", "table", "channels", "state"]


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


def probe_port(
    url: str,
    baud: int = 921_600,
    timeout_s: float = PROBE_TIMEOUT_S,
    why_not: dict[str, str] | None = None,
) -> Found | None:
    """HELLO on one serial URL; the controller there, a busy Found when another client holds
    the port (nothing is sent: its requests would meet ours), or None (no answer, does not
    open: `why_not[url]` says which, for a port the user named)."""
    why_not = {} if why_not is None else why_not
    try:
        link = SerialLink(url, baud=baud)
    except PortBusyError as exc:
        return Found(port=url, node=None, info=None, holder=exc.holder)
    except LockFolderError:
        raise  # no port can be probed: the user must hear why
    except BenchError as exc:
        why_not[url] = str(exc).removeprefix(f"--port {url}: ")
        return None
    try:
        client = BenchClient(link, timeout_s=timeout_s)
        try:
            return Found(port=url, node=None, info=client.hello())
        except (BenchError, ProtocolError):
            why_not[url] = f"no answer to HELLO within {timeout_s:g} s"
            return None
    finally:
        link.close()


def probe_serial(
    ports: Iterable[str] | None = None,
    baud: int = 921_600,
    timeout_s: float = PROBE_TIMEOUT_S,
    probe: Callable[..., Found | None] = probe_port,
    why_not: dict[str, str] | None = None,
) -> tuple[list[Found], list[str]]:
    """Probe `ports` (default: `serial_ports()`, then the registered emulators'); returns
    (controllers found, ports probed). `why_not`: filled with why each port that is not listed
    is not (see `probe_port`)."""
    if ports is None:
        listed = serial_ports()
        ports = listed + [p for p in registered_ports() if p not in listed]
    probed = list(ports)
    kw = {} if why_not is None else {"why_not": why_not}
    found = [f for f in (probe(url, baud=baud, timeout_s=timeout_s, **kw) for url in probed) if f]
    return found, probed


def probe_can(spec: str, timeout_s: float = 1.0, bus=None) -> list[Found]:
    """HELLO to every node of the python-can bus `spec` (INTERFACE:CHANNEL) at once; the nodes
    that answer, by node id. `bus`: an open python-can bus to use instead of opening `spec`."""
    import can  # noqa: PLC0415 (python-can only when a CAN link is used)

    own = bus is None
    if own:
        interface, sep, channel = spec.partition(":")
        if not sep or not interface:
            raise BenchUsageError(f"--can {spec}: expected INTERFACE:CHANNEL (e.g. virtual:bench)")
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
    if len(found) == 1 and not found[0].busy:
        return found[0].port
    if not found:
        where = f"{len(probed)} serial port(s) probed" if probed else "pyserial lists no ports"
        raise BenchError(f"--port auto: no controller answered HELLO ({where})")
    if len(found) == 1:  # what a session there would meet: the holder's refusal
        f = found[0]
        raise PortBusyError(
            f"--port auto: the only controller found, {f.port}, is in use by another client "
            f"({f.holder}): one client at a time",
            f.holder or "",
        )
    # A busy port counts: which of them the user means is theirs to say.
    names = ", ".join(f.brief() for f in found)
    raise AmbiguousPortError(
        f"--port auto: {len(found)} controllers found, name one with --port: {names}"
    )


# --- emulators' registry -------------------------------------------------------------------------

REGISTRY_PREFIX = "bowden-emulator-"
_registrations = itertools.count()  # several emulators in one process (tests, scripts)


def _process_start(pid: int) -> str | None:
    """When process `pid` started (clock ticks since boot, /proc/PID/stat's 22nd field): a pid
    the system gave to a new process since is not the emulator's. None without /proc."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[19]
    except (OSError, IndexError):
        return None


def _alive(pid: int, start: str | None) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # alive, another user's (their files are skipped before this)
    now = _process_start(pid)
    return start is None or now is None or now == start


def register_emulator(urls: dict[str, str]) -> Path | None:
    """Make an emulator on this process findable by `list` and `--port auto`: its pty and its
    `socket://` URL (`urls`, as `Emulator.urls` names them; a simulated board has a pty only)
    in a registry file. Returns the
    file, for `unregister_emulator`; None when there is nothing serial to name or the runtime
    folder cannot be written (the emulator works all the same, named with --port)."""
    serial = {k: urls[k] for k in ("pty", "socket") if k in urls}
    if not serial:
        return None
    pid = os.getpid()
    doc = {"pid": pid, "start": _process_start(pid), "urls": serial}
    path = Path(runtime_dir()) / f"{REGISTRY_PREFIX}{pid}-{next(_registrations)}.json"
    tmp = path.with_name(path.name + ".tmp")
    try:
        tmp.write_text(json.dumps(doc) + "\n")
        os.replace(tmp, path)  # `list` never reads half a file
    except OSError:
        tmp.unlink(missing_ok=True)
        return None
    return path


def unregister_emulator(path: Path | None) -> None:
    """The emulator ended: `list` no longer finds it."""
    if path is not None:
        path.unlink(missing_ok=True)


def registered_emulators() -> list[dict]:
    """The registry's emulators whose process still runs, this user's only, oldest first: each
    `{"pid", "start", "urls"}`. A stale file (its process gone) is removed."""
    folder = Path(runtime_dir())
    entries = []
    try:
        paths = sorted(folder.glob(f"{REGISTRY_PREFIX}*.json"))
    except OSError:
        return []
    for path in paths:
        try:
            st = path.stat()
            if st.st_uid != os.getuid():
                continue
            doc = json.loads(path.read_text())
            pid, urls = int(doc["pid"]), dict(doc["urls"])
        except (OSError, ValueError, KeyError, TypeError):
            continue  # gone meanwhile, or not a registry file
        if not _alive(pid, doc.get("start")):
            path.unlink(missing_ok=True)
            continue
        entries.append((st.st_mtime, {"pid": pid, "start": doc.get("start"), "urls": urls}))
    return [e for _, e in sorted(entries, key=lambda m: m[0])]


def registered_ports() -> list[str]:
    """One URL per registered emulator: its pty, else its `socket://` URL (both lead to the
    same device: probing both would list it twice)."""
    ports = []
    for e in registered_emulators():
        url = e["urls"].get("pty") or e["urls"].get("socket")
        if isinstance(url, str) and url not in ports:
            ports.append(url)
    return ports
