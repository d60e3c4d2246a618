"""The `bowden bench` commands beyond the protocol's own: `list` and `--port auto` (finding
controllers), `diff` (what changed in a configuration), `watch` and `run --live` (the live view).
cli.py calls `add_parsers`, `precheck` before anything is sent, and dispatches to them.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from . import diff, discover, live
from . import messages as msgs
from .client import BenchError
from .protocol import param
from .recorder import RunResult, record_run


def add_parsers(sub) -> None:
    """Add `list`, `diff` and `watch` to the `bowden bench` COMMAND subparsers."""
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
    w = sub.add_parser(
        "watch",
        help="run the device's configured waveform and show it live (terminal or local page)",
        description="Start the waveform the device is set to (wave.kind, wave.mean_n, ...: "
        "`set` them first) for --seconds, show T_ref, T_c, T_in, T_out, the current and the "
        "faults live, and record every sample. Ctrl-C stops the device at once.",
    )
    w.add_argument("--seconds", type=float, default=600.0, help="run length (default 600 s)")
    w.add_argument("--out", help="trace CSV (default: a new file in a temporary folder)")
    live.add_arguments(w, required_live=True)


def precheck(args) -> int | None:
    """Checks of a command's files and options before anything is sent: one line and exit 2 on
    bad input."""
    if getattr(args, "live", None):
        try:
            live.check_options(args)
        except ValueError as exc:
            print(f"bowden bench: {exc}", file=sys.stderr)
            return 2
    if args.bench_command == "watch" and not 0 < args.seconds <= 86_400:
        print(f"bowden bench: --seconds {args.seconds:g}: outside (0, 86400]", file=sys.stderr)
        return 2
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


def record_with_view(client, args, label: str, **kw) -> RunResult:
    """record_run, with the live view `args.live` asks for when it asks for one (the progress
    line gives way to a terminal view)."""
    if not getattr(args, "live", None):
        return record_run(client, args.out, **kw)
    rate_hz = float(client.get("tick_rate_hz")) / int(client.get("dev.telemetry_div"))
    view = live.open_live(args, label, rate_hz)
    if view.owns_terminal:
        kw["progress"] = None
    result = None
    try:
        result = record_run(client, args.out, tap=view.tap, **kw)
    finally:
        view.close(
            f"run ended: {result.summary()}" if result else "run interrupted: the device is stopped"
        )
    return result


def cmd_watch(client, args, info) -> int:
    """`bowden bench watch`: the device's configured waveform, live, recorded."""
    if args.out is None:
        args.out = str(Path(tempfile.mkdtemp(prefix="bowden-watch-")) / "watch.csv")
    kind = client.get("wave.kind")
    wave = {k: float(client.get(f"wave.{k}")) for k in ("mean_n", "amplitude_n", "freq_hz")}
    label = f"{kind} {wave['mean_n']:g} +- {wave['amplitude_n']:g} N at {wave['freq_hz']:g} Hz"
    try:
        result = record_with_view(
            client,
            args,
            f"{label} -> {args.out}",
            seconds=args.seconds,
            waveform=kind,
            mean_n=wave["mean_n"],
            amplitude_n=wave["amplitude_n"],
            freq_hz=wave["freq_hz"],
        )
    except KeyboardInterrupt:
        try:
            client.request("STOP")
        except BenchError:
            pass
        print(f"bowden bench: stopped; {args.out} holds the samples up to now", file=sys.stderr)
        return 130
    print(f"{args.out}: {result.summary()} ({result.wall_s:.1f} s)")
    return 0 if not (result.drops or result.stopped_early) else 1


COMMANDS = {"diff": cmd_diff, "watch": cmd_watch}


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
