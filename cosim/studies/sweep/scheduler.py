"""Is `--scheduler ADDRESS` a Dask scheduler? Asked before the sweep writes anything, within a
stated time, with one line for the answer.

Dask's own client reads whatever the far end sends as a frame length (a service that answers
with text asks it for exabytes), waits its connect timeout on a port that accepts and says
nothing, and retries a refused or unknown host for seconds. The probe therefore:

1. resolves the host and opens a plain TCP connection, each within PROBE_TIMEOUT_S;
2. reads the greeting a Dask scheduler sends first on every new connection (its handshake, in
   distributed's TCP framing: a u64 little-endian total length, a u64 frame count, one u64
   length per frame, the frames) and checks that the lengths add up and stay small;
3. only then is Dask's Client connected, with the same timeout (`client_timeout`).

Only `tcp://` addresses are probed at the byte level (a `tls://` greeting is encrypted); `tls://`,
`ws://` and `wss://` go straight to step 3, and an address of another kind (Dask's `inproc://`
and `ucx://`, or no Dask address at all) is refused, as is a `tls://` or `wss://` address without
Dask's TLS configuration (its client would fail on it with a traceback).
"""

from __future__ import annotations

import socket
import struct
import threading
import time
from urllib.parse import urlsplit

PROBE_TIMEOUT_S = 5.0  # each of: name lookup, connection, greeting
MAX_GREETING_BYTES = 1 << 20  # a handshake is a few hundred bytes
MAX_FRAMES = 64
# The schemes of a Dask scheduler on another host that its client can reach without extra packages.
SCHEMES = ("tcp", "tls", "ws", "wss")
TLS_SCHEMES = ("tls", "wss")


class SchedulerError(ValueError):
    """`--scheduler` does not lead to a Dask scheduler (one line, naming the address)."""


def _resolve(host: str, port: int, timeout_s: float) -> list:
    """getaddrinfo within timeout_s (it has no timeout of its own): a daemon thread asks."""
    box: dict = {}

    def ask() -> None:
        try:
            box["infos"] = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
        except OSError as exc:
            box["error"] = exc

    t = threading.Thread(target=ask, daemon=True)
    t.start()
    t.join(timeout_s)
    if t.is_alive():
        raise TimeoutError(f"no answer for the name {host!r} within {timeout_s:g} s")
    if "error" in box:
        raise box["error"]
    return box["infos"]


def _read_exact(sock: socket.socket, n: int, deadline: float) -> bytes:
    buf = b""
    while len(buf) < n:
        left = deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError
        sock.settimeout(left)
        chunk = sock.recv(n - len(buf))
        if not chunk:
            raise ConnectionError("closed the connection")
        buf += chunk
    return buf


def _check_greeting(sock: socket.socket, timeout_s: float) -> None:
    """Raise SchedulerError unless the first bytes are a well-formed distributed TCP message."""
    deadline = time.monotonic() + timeout_s
    (total,) = struct.unpack("<Q", _read_exact(sock, 8, deadline))
    if not 16 <= total <= MAX_GREETING_BYTES:
        raise SchedulerError(f"answers, but not as a Dask scheduler (message length {total})")
    body = _read_exact(sock, total, deadline)
    (n_frames,) = struct.unpack_from("<Q", body)
    if not 1 <= n_frames <= MAX_FRAMES or 8 + 8 * n_frames > total:
        raise SchedulerError(f"answers, but not as a Dask scheduler ({n_frames} frames)")
    lengths = struct.unpack_from(f"<{n_frames}Q", body, 8)
    if 8 + 8 * n_frames + sum(lengths) != total:
        raise SchedulerError("answers, but not as a Dask scheduler (frame lengths disagree)")


def _tls_configured() -> bool:
    """Whether Dask's configuration gives its client a TLS context (distributed.comm.tls)."""
    from distributed.security import Security  # noqa: PLC0415

    try:
        return Security().get_connection_args("client").get("ssl_context") is not None
    except (OSError, ValueError):  # configured, but a file that cannot be read: Dask says so
        return True


def probe(address: str, timeout_s: float | None = None) -> None:
    """Raise SchedulerError (one line naming `address`) unless a Dask scheduler greets there
    within about 3 x timeout_s (default PROBE_TIMEOUT_S)."""
    timeout_s = PROBE_TIMEOUT_S if timeout_s is None else timeout_s
    parts = urlsplit(address)
    try:
        host, port = parts.hostname, parts.port
    except ValueError:  # a port that is not a number in [0, 65535]
        host = port = None
    if not host or port is None or parts.path or parts.query or parts.fragment:
        raise SchedulerError(f"--scheduler {address}: expected an address like tcp://HOST:PORT")
    if parts.scheme not in SCHEMES:
        raise SchedulerError(
            f"--scheduler {address}: expected a {', '.join(s + '://' for s in SCHEMES)} address "
            "of a Dask scheduler"
        )
    if parts.scheme in TLS_SCHEMES and not _tls_configured():
        raise SchedulerError(
            f"--scheduler {address}: a TLS address needs Dask's TLS configuration (its "
            "distributed.comm.tls settings: the CA file, the client's certificate and key); none "
            "is set"
        )
    if parts.scheme != "tcp":
        return  # the greeting of tls:// and others is not readable here: Dask's timeout holds
    try:
        infos = _resolve(host, port, timeout_s)
        family, kind, proto, _, sockaddr = infos[0]
        with socket.socket(family, kind, proto) as sock:
            sock.settimeout(timeout_s)
            sock.connect(sockaddr)
            _check_greeting(sock, timeout_s)
    except SchedulerError as exc:
        raise SchedulerError(f"--scheduler {address}: {exc}") from None
    except socket.gaierror as exc:
        raise SchedulerError(
            f"--scheduler {address}: unknown host {host!r} ({exc.strerror})"
        ) from None
    except ConnectionRefusedError:
        raise SchedulerError(
            f"--scheduler {address}: connection refused (nothing listens)"
        ) from None
    except TimeoutError:
        raise SchedulerError(
            f"--scheduler {address}: no Dask greeting within {timeout_s:g} s "
            "(a silent service, or a firewall dropping packets)"
        ) from None
    except OSError as exc:
        reason = exc.strerror or str(exc) or type(exc).__name__
        raise SchedulerError(f"--scheduler {address}: {reason}") from None
