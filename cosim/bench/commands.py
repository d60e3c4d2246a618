"""The `bowden bench` commands beyond the protocol's own: `list` and `--port auto` (finding
controllers), `diff` (what changed in a configuration).
cli.py calls `add_parsers`, `precheck` before anything is sent, and dispatches to them.
"""

from __future__ import annotations

import sys

from . import diff, discover
from . import messages as msgs
from .protocol import param


def add_parsers(sub) -> None:
    """Add `list` and `diff` to the `bowden bench` COMMAND subparsers."""
    sub.add_parser(
        "list",
        help="find controllers: HELLO on every serial port pyserial lists (or the --port "
        "given), or every node of the --can bus",
        description="Print every controller that answers HELLO: port, CAN node, firmware, "
        "protocol version, table hash and state. Nothing but HELLO is sent: a run in progress "
        "goes on.",
    )
    d = sub.add_parser(
        "diff",
        help="how the device's parameters differ from a backup or params file, or the factory "
        "defaults (--defaults), in SI units",
        description="Parameter by parameter, in SI units: the device against a backup "
        '(`bowden bench backup`), a params file of device parameters ({"loop.kp": 0.1}) or '
        "a co-simulation params file (`bowden sim --params`), or the factory defaults. Values "
        "are compared as the device's words.",
    )
    d.add_argument("file", nargs="?", metavar="FILE", help="backup or params file (JSON)")
    d.add_argument("--defaults", action="store_true", help="compare with the factory defaults")
    d.add_argument("--all", action="store_true", help="show equal parameters too")


def precheck(args) -> int | None:
    """Checks of a command's files before anything is sent: one line and exit 2 on bad input."""
    if args.bench_command != "diff":
        return None
    if (args.file is None) == (not args.defaults):
        print("bowden bench diff: give FILE or --defaults (one of them)", file=sys.stderr)
        return 2
    if args.file is not None:
        try:
            args.reference = diff.load_file(args.file)
        except diff.DiffFileError as exc:
            print(f"bowden bench {exc}", file=sys.stderr)
            return 2
    return None


def cmd_diff(client, args, info) -> int:
    """`bowden bench diff`: the device's words against the file's (or the defaults)."""
    device = client.params()
    if args.defaults:
        words = {}
        for p in msgs.PARAMS:
            _, v = client.request("PARAM_INFO", param=param(p.name).id)
            words[p.name] = v["default_word"]
        ref = diff.Reference(label="factory default", words=words)
    else:
        ref = args.reference
    print(diff.render(diff.compare(device, ref), ref, show_all=args.all))
    return 0


COMMANDS = {"diff": cmd_diff}


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
