"""`bowden emulate`: the controller on the host, in real time, behind the links a bench has.

The device is the firmware's host build with the protocol's device side
(cosim.bench.emulate.host_device.Device: the same C code as the target), the FPGA loop is its
bit-exact model, the plant is the FMU (cosim.bench.emulate.host_device.LoopChain), stepped at the
tick rate against the wall clock. The device is reachable at once on

- a pseudo-terminal (port 0): raw mode (tty.setraw, or 0x0D, 0x03, 0x11, 0x13 would be mangled
  and input echoed), the slave side kept open (no EIO when a client closes it), throttled to
  `baud` (a pty has no baud rate of its own);
- a TCP socket (port 1), for pyserial's `socket://HOST:PORT` (other processes, other machines),
  throttled the same way;
- a python-can bus (port 2), e.g. `virtual` (in this process only) or `socketcan` (vcan0),
  throttled to the bus's bit rate.

Timing: the loop runs the ticks that are due, then serves the links, then sleeps until the next
tick. When it falls behind (a loaded machine), it catches up tick by tick, so the telemetry's
sample index never skips; a lag beyond `max_lag_s` sets the device's OVERRUN fault, and
telemetry the links cannot carry in time is dropped by the device and counted (the telemetry's
overflow counter and TX_OVERFLOW fault), never silently.
"""

from __future__ import annotations

import errno
import os
import random
import select
import signal
import socket
import threading
import time
import tty
from dataclasses import dataclass, field
from pathlib import Path

from cosim import _signals
from cosim.bench.link.discover import register_emulator, unregister_emulator

from .host_device import PORT_CAN, ChainConfig, Device, LoopChain

PORT_PTY, PORT_TCP, PORT_BUS = 0, 1, 2
DEFAULT_BAUD = 921_600


def _can_frame_bits(n: int) -> int:
    # Base frame: 44 bits + 8 per data byte, worst-case stuffing of the 34 + 8n stuffable bits,
    # 3 bits of interframe space (firmware/proto/PROTOCOL.md, "CAN").
    return 47 + 8 * n + (33 + 8 * n) // 4


@dataclass
class _Bucket:
    """Token bucket: `rate` units per second, at most `burst` saved."""

    rate: float
    burst: float
    tokens: float = 0.0
    last: float = field(default_factory=time.perf_counter)

    def refill(self, now: float) -> float:
        self.tokens = min(self.burst, self.tokens + (now - self.last) * self.rate)
        self.last = now
        return self.tokens


class _ByteLink:
    """A serial-like endpoint of the device: the bytes it sends, throttled to a baud rate."""

    def __init__(self, device: Device, port: int, baud: int) -> None:
        self.device = device
        self.port = port
        # The link may catch up for as long as the emulator may lag (100 ms): a stall of the
        # emulating process is not the device's, so it must not turn into dropped telemetry.
        self.bucket = _Bucket(rate=baud / 10.0, burst=baud / 10.0 * 0.1)
        self.pending = b""
        self.sent = 0
        self.garbage_sent = 0
        self._garbage_due = False

    def inject_garbage(self) -> None:
        """Send a burst of random bytes at the next frame boundary (the device's frames each
        start with a delimiter, so the receiver counts the burst and loses nothing)."""
        self._garbage_due = True

    def pump(self, now: float, write) -> None:
        budget = int(self.bucket.refill(now))
        while budget > 0:
            if not self.pending:
                self.pending = self.device.tx_bytes(self.port, min(budget, 4096))
                if not self.pending:
                    if self._garbage_due:  # between whole frames: nothing is in flight
                        junk = bytes(random.randrange(1, 256) for _ in range(random.randint(5, 40)))
                        self.pending = junk
                        self.garbage_sent += len(junk)
                        self._garbage_due = False
                    else:
                        return
            n = write(self.pending[:budget])
            if n is None or n <= 0:
                return  # the other side is not reading: the device's buffer takes the backlog
            self.pending = self.pending[n:]
            self.bucket.tokens -= n
            self.sent += n
            budget -= n


class Emulator:
    """The emulated bench: a Device and its LoopChain in real time, on a pty, TCP and a CAN bus.

    Call `start()` (a background thread) or `run()` (this thread, until `stop()` or Ctrl-C);
    `urls` says where to connect. `findable`: while it runs, `bowden bench list` and `--port
    auto` find it (cosim.bench.link.discover's registry: pyserial cannot list a pty), however it
    ends (`bowden emulate` is; an emulator a test or a script starts for itself is not, unless
    it asks).
    """

    def __init__(
        self,
        *,
        pty: bool = True,
        tcp_port: int | None = 0,
        can: str | None = None,
        baud: int = DEFAULT_BAUD,
        can_bitrate: int = 1_000_000,
        chain: ChainConfig | None = None,
        engine: str = "native",
        flash_path: str | Path | None = None,
        identity: tuple[int, int] | None = None,
        max_lag_s: float = 0.05,
        findable: bool = False,
        channels: int = 1,
    ) -> None:
        self.findable = findable
        self._registration = None  # the registry file while it is findable
        self.device = Device(channels)
        self.flash_path = Path(flash_path) if flash_path else None
        if self.flash_path is not None and self.flash_path.exists():
            self.device.load_flash_image(self.flash_path.read_bytes())
        if identity is not None:
            self.device.set_identity(*identity)
        self.identity = identity
        self.chain = LoopChain(self.device, chain or ChainConfig(), engine=engine)
        self.tick_period_s = 1.0 / self.chain.cfg.tick_rate_hz
        self.max_lag_s = max_lag_s
        self.baud = baud
        self.urls: dict[str, str] = {}
        self.overruns = 0
        self.max_lag_seen_s = 0.0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: Exception | None = None  # what ended start()'s thread, if anything did
        self._flash_image = self.device.flash_image()
        self.pty_link = self.tcp_link = None
        self._master = self._slave = None
        if pty:
            self._master, self._slave = os.openpty()
            tty.setraw(self._slave)  # raw: no echo, no CR/LF or flow-control translation
            os.set_blocking(self._master, False)
            self.pty_name = os.ttyname(self._slave)
            self.pty_link = _ByteLink(self.device, PORT_PTY, baud)
            self.urls["pty"] = self.pty_name
        self._server = self._client = None
        if tcp_port is not None:
            self._server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            self._server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            self._server.bind(("127.0.0.1", tcp_port))
            self._server.listen(1)
            self._server.setblocking(False)
            self.tcp_link = _ByteLink(self.device, PORT_TCP, baud)
            self.urls["socket"] = f"socket://127.0.0.1:{self._server.getsockname()[1]}"
        self.bus = None
        if can is not None:
            import can as pycan  # noqa: PLC0415 (python-can only when a bus is asked for)

            interface, _, channel = can.partition(":")
            self.bus = pycan.Bus(interface=interface, channel=channel or "bowden")
            self.device.set_port_kind(PORT_BUS, PORT_CAN)
            self._can_bucket = _Bucket(rate=can_bitrate, burst=can_bitrate * 0.1)
            self._can_pending: list[tuple[int, bytes]] = []
            self._pycan = pycan
            self.urls["can"] = f"{interface}:{channel or 'bowden'}"

    # --- run ---------------------------------------------------------------------------------

    def start(self) -> Emulator:
        """Run in a background thread; returns self. An error that ends it (the plant FMU
        failing, a flash file that can no longer be written) is kept in `error`, and `running`
        turns False: the caller reports it (a thread's exception would only be printed)."""
        self._register()  # findable as soon as start returns
        self._thread = threading.Thread(target=self._run_kept, name="bowden-emulator", daemon=True)
        self._thread.start()
        return self

    def _run_kept(self) -> None:
        try:
            self.run()
        except Exception as exc:  # noqa: BLE001 (kept for the caller, see start())
            self.error = exc

    @property
    def running(self) -> bool:
        """start()'s thread is running (False after stop() or an error)."""
        return self._thread is not None and self._thread.is_alive()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=5.0)
        self._close()

    def inject_garbage(self) -> None:
        """Garbage on every byte link at the next frame boundary (device -> host)."""
        for link in (self.pty_link, self.tcp_link):
            if link is not None:
                link.inject_garbage()

    def _register(self) -> None:
        if self.findable and self._registration is None:
            self._registration = register_emulator(self.urls)

    def _unregister(self) -> None:
        registration, self._registration = self._registration, None
        unregister_emulator(registration)

    def run(self) -> None:
        next_t = time.perf_counter()
        last_flash_check = next_t
        self._register()
        try:
            while not self._stop.is_set():
                now = time.perf_counter()
                lag = now - next_t  # how late the oldest due tick is
                due = 0
                while now >= next_t and due < 100:
                    self.chain.step()
                    next_t += self.tick_period_s
                    due += 1
                    if due > 1:  # catching up: the links drain as a device's would meanwhile
                        self._pump(time.perf_counter())
                if lag > self.max_lag_s:
                    # Behind real time: keep every tick (the sample index never skips) and say so.
                    self.overruns += 1
                    self.device.overrun()
                self.max_lag_seen_s = max(self.max_lag_seen_s, lag)
                self._serve(now)
                if self.flash_path is not None and now - last_flash_check > 0.2:
                    self._save_flash()
                    last_flash_check = now
                wait = next_t - time.perf_counter()
                if wait > 0:
                    self._wait_io(min(wait, 0.002))
        finally:
            # However the loop ends (stop(), Ctrl-C, an error): no longer findable.
            self._unregister()
            self._save_flash()

    # --- links -------------------------------------------------------------------------------

    def _wait_io(self, timeout: float) -> None:
        fds = [f for f in (self._master, self._server, self._client) if f is not None]
        if fds:
            select.select(fds, [], [], timeout)
        else:
            time.sleep(timeout)

    def _serve(self, now: float) -> None:
        if self._master is not None:
            try:
                data = os.read(self._master, 4096)
                self.device.rx_bytes(PORT_PTY, data)
            except BlockingIOError:
                pass
            except OSError as exc:  # EIO cannot happen while the slave stays open
                if exc.errno != errno.EIO:
                    raise
            self.pty_link.pump(now, self._pty_write)
        if self._server is not None:
            try:
                client, _ = self._server.accept()
                client.setblocking(False)
                if self._client is not None:
                    self._client.close()  # one client at a time: the newest wins
                self._client = client
            except BlockingIOError:
                pass
            if self._client is not None:
                try:
                    data = self._client.recv(4096)
                    if data:
                        self.device.rx_bytes(PORT_TCP, data)
                    else:
                        self._client.close()
                        self._client = None
                except BlockingIOError:
                    pass
                except OSError:
                    self._client.close()
                    self._client = None
            self.tcp_link.pump(now, self._tcp_write)
        if self.bus is not None:
            self._serve_can(now)

    def _pump(self, now: float) -> None:
        if self.pty_link is not None:
            self.pty_link.pump(now, self._pty_write)
        if self.tcp_link is not None:
            self.tcp_link.pump(now, self._tcp_write)
        if self.bus is not None:
            self._serve_can(now)

    def _pty_write(self, data: bytes) -> int | None:
        try:
            return os.write(self._master, data)
        except BlockingIOError:
            return None

    def _tcp_write(self, data: bytes) -> int | None:
        if self._client is None:
            return len(data)  # nothing attached: the bytes go nowhere, as on an open UART
        try:
            return self._client.send(data)
        except BlockingIOError:
            return None
        except OSError:
            self._client.close()
            self._client = None
            return len(data)

    def _serve_can(self, now: float) -> None:
        while True:
            msg = self.bus.recv(timeout=0)
            if msg is None:
                break
            if not msg.is_extended_id and not msg.is_remote_frame:
                self.device.rx_can(PORT_BUS, msg.arbitration_id, bytes(msg.data))
        budget = self._can_bucket.refill(now)
        while True:
            if not self._can_pending:
                self._can_pending = self.device.tx_can(PORT_BUS, 16)
                if not self._can_pending:
                    return
            cid, data = self._can_pending[0]
            bits = _can_frame_bits(len(data))
            if budget < bits:
                return
            self.bus.send(self._pycan.Message(arbitration_id=cid, data=data, is_extended_id=False))
            self._can_pending.pop(0)
            budget -= bits
            self._can_bucket.tokens -= bits

    def _save_flash(self) -> None:
        if self.flash_path is None:
            return
        image = self.device.flash_image()
        if image != self._flash_image:
            tmp = self.flash_path.with_name(self.flash_path.name + ".tmp")
            tmp.write_bytes(image)
            os.replace(tmp, self.flash_path)  # a killed emulator never leaves half an image
            self._flash_image = image

    def _close(self) -> None:
        self._unregister()  # (stopped before it ran, or its thread did not end in time)
        for fd in (self._master, self._slave):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._master = self._slave = None
        for s in (self._client, self._server):
            if s is not None:
                s.close()
        self._client = self._server = None
        if self.bus is not None:
            self.bus.shutdown()
            self.bus = None
        self.chain.close()


class StopSignals:
    """SIGINT and SIGTERM while `bowden emulate` runs an emulator (either target), from before
    its start until it has stopped: each is only noted (`signum`: the first), never raised, so
    that none lands inside the start or the stop, where the registry file that makes the
    emulator findable (cosim.bench.link.discover) is written and removed; the command's wait loop
    polls `signum` and ends, and the emulator is stopped whole. Outside the main thread (where
    no handler can be set) nothing is noted."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.signum: int | None = None
        self._previous: dict = {}

    def __enter__(self) -> StopSignals:
        self._previous = _signals.install(self._note, self.SIGNALS)
        return self

    def __exit__(self, *exc) -> None:
        previous, self._previous = self._previous, {}
        _signals.restore(previous)

    def _note(self, signum, _frame) -> None:
        if self.signum is None:
            self.signum = signum


class SteppedLink:
    """The emulated bench in this process without the wall clock: a link for BenchClient (as
    SerialLink: send, write_raw, recv, stats, url, close) on port 0 of a Device whose LoopChain
    advances `ticks_per_read` ticks at each read that finds nothing waiting, as fast as the host
    computes them. The device, the loop, the plant and the telemetry frames are the emulator's,
    so a recording is the one `bowden emulate` and `bowden bench run` give, sample for sample,
    in a fraction of real time (tests, reproducible examples)."""

    def __init__(
        self,
        chain: ChainConfig | None = None,
        engine: str = "native",
        ticks_per_read: int = 50,
        channels: int = 1,
    ) -> None:
        from cosim.bench.link.protocol import FrameDecoder  # noqa: PLC0415

        self.device = Device(channels)
        self.chain = LoopChain(self.device, chain or ChainConfig(), engine=engine)
        self.ticks_per_read = ticks_per_read
        self.decoder = FrameDecoder()
        self.url = f"emulator in process ({engine} engine, stepped)"

    @property
    def stats(self):
        return self.decoder.stats

    def clock(self) -> float:
        """The device's time in seconds (the ticks run so far): the host's keep-alive reads it,
        as the wall clock runs much slower than this link."""
        return self.chain.ticks / self.chain.cfg.tick_rate_hz

    def send(self, frame) -> None:
        from cosim.bench.link.protocol import encode_frame  # noqa: PLC0415

        self.device.rx_bytes(PORT_PTY, encode_frame(frame))

    def write_raw(self, data: bytes) -> None:
        self.device.rx_bytes(PORT_PTY, data)

    def recv(self, timeout_s: float) -> list:
        frames = self.decoder.feed(self.device.tx_bytes(PORT_PTY))
        if frames:
            return frames
        for _ in range(self.ticks_per_read):
            self.chain.step()
            # drained every tick, as a link at full speed would: nothing overflows
            frames += self.decoder.feed(self.device.tx_bytes(PORT_PTY))
        return frames

    def close(self) -> None:
        self.chain.close()
