"""The `bowden bench` commands beyond the protocol's own: `list` and `--port auto` (finding
controllers).
cli.py calls `add_parsers` and dispatches to them.
"""

from __future__ import annotations

import sys

from . import discover
from . import messages as msgs


def add_parsers(sub) -> None:
    """Add `list` to the `bowden bench` COMMAND subparsers."""
    sub.add_parser(
        "list",
        help="find controllers: HELLO on every serial port pyserial lists (or the --port "
        "given), or every node of the --can bus",
        description="Print every controller that answers HELLO: port, CAN node, firmware, "
        "protocol version, table hash and state. Nothing but HELLO is sent: a run in progress "
        "goes on.",
    )


def resolve_port(args) -> int | None:
    """`--port auto`: the only controller pyserial's ports lead to. Several: one line listing
    them and exit 2 (the user names one); none: BenchError."""
    if args.port == "auto":
        try:
            args.port = discover.auto_port(
                baud=args.baud, timeout_s=min(args.timeout, discover.PROBE_TIMEOUT_S)
            )
        except discover.AmbiguousPortError as exc:
            print(f"bowden bench: {exc}", file=sys.stderr)
            return 2
    return None


def cmd_list(args, chain=None) -> int:
    """`bowden bench list`: one row per controller found; exit 1 when there is none. With
    `--emulate --can BUS` the emulator joins the bus first (python-can's virtual bus)."""
    timeout_s = min(args.timeout, discover.PROBE_TIMEOUT_S)
    if args.can:
        emulator = None
        if args.emulate:
            from .emulator import Emulator  # noqa: PLC0415

            emulator = Emulator(pty=False, tcp_port=None, can=args.can, chain=chain).start()
        try:
            found = discover.probe_can(args.can, timeout_s=timeout_s)
        finally:
            if emulator is not None:
                emulator.stop()
        where = f"on {args.can} (nodes 0..{(1 << msgs.CAN_NODE_BITS) - 1})"
    else:
        ports = [args.port] if args.port and args.port != "auto" else None
        found, probed = discover.probe_serial(ports, baud=args.baud, timeout_s=timeout_s)
        where = f"on {len(probed)} serial port(s) probed" if probed else "(pyserial lists no ports)"
    if not found:
        print(f"bowden bench list: no controller answered HELLO {where}", file=sys.stderr)
        return 1
    print(discover.table(found))
    if any(not f.compatible for f in found):
        print(
            "note: a controller marked 'host: other' speaks another protocol version or table "
            "than this host: update the host or its firmware before a session"
        )
    return 0
