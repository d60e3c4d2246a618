"""The `bowden bench` commands beyond the protocol's own: `list` and `--port auto` (finding
controllers), `diff` (what changed in a configuration), `watch` and `run --live` (the live view).
cosim/bench/command.py calls `add_parsers` and `add_live_arguments`, `precheck` before anything is
sent, and dispatches to the handlers; the work is done in cosim.bench (discover, diff, live, and
the run with its stop in rig/run.py).
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

from cosim.bench.link import discover, paramfiles
from cosim.bench.link import messages as msgs
from cosim.bench.link.client import BenchError
from cosim.bench.link.protocol import param
from cosim.bench.link.recorder import run_ticks
from cosim.bench.live import view as live
from cosim.bench.rig import CALIBRATED_PARAMS, diff
from cosim.bench.rig.run import cmd_run, stop_and_confirm


def add_parsers(sub) -> None:
    """Add `list`, `diff` and `watch` to the `bowden bench` COMMAND subparsers."""
    sub.add_parser(
        "list",
        help="find controllers: HELLO on every serial port pyserial lists and every running "
        "`bowden emulate` (or the --port given), or every node of the --can bus",
        description="Print every controller that answers HELLO: port, CAN node, firmware, "
        "protocol version, table hash and state. Nothing but HELLO is sent: a run in progress "
        "goes on. A port another client holds is listed as busy, with the holder's pid.",
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
        "faults live, and record every sample (as `run`: every way out stops the device).",
    )
    w.add_argument("--seconds", type=float, default=600.0, help="run length (default 600 s)")
    w.add_argument("--out", help="trace CSV (default: a new file in a temporary folder)")
    add_live_arguments(w, required_live=True)
    c = sub.add_parser(
        "calibrate",
        help="identify the plant, audit it and propose (--apply: write and verify) the "
        "compensator's friction values",
        description="Run an identification sequence (the tension range, both directions, "
        "several rates) recorded with T_out, audit it (`bowden audit`), and print the changes "
        f"to {', '.join(CALIBRATED_PARAMS)} that the audit's findings support (cosim/bench/"
        'README.md, "Calibration", says which rule decides each) with '
        "the tracking error they predict. --apply saves the configuration to DIR/before.json, "
        "writes the changes as one set and measures a different (verification) waveform on "
        "the device's T_out before and after. Loop gains are never changed.",
    )
    c.add_argument("--out", required=True, metavar="DIR", help="folder for every file written")
    c.add_argument("--apply", action="store_true", help="write the changes and verify them")
    c.add_argument("--persist", action="store_true", help="with --apply: save them in flash")
    c.add_argument("--force", action="store_true", help="write into a non-empty --out")
    c.add_argument("--quiet", action="store_true", help="no progress line")
    c.add_argument(
        "--map",
        nargs="?",
        const="default",
        metavar="X,Y,Z;...",
        help="after the audit, map the bending angle over the workspace: a short sequence at "
        "home and at each of these positions (m; without a value 0.2 m from home along x, y and "
        "z). On a device you move the end-effector to each when asked, with the output off; "
        "the map (bend_map.json) is the host's, for comp.phi_rad at each position",
    )


def add_live_arguments(p, required_live: bool = False) -> None:
    """The live view's options on a `bowden bench` subparser (`run`, `watch`)."""
    if required_live:
        p.add_argument(
            "--live",
            choices=("term", "web"),
            default="term",
            help="where to show it: the terminal (default) or a page on 127.0.0.1",
        )
    else:
        p.add_argument(
            "--live",
            nargs="?",
            const="term",
            choices=("term", "web"),
            default=None,
            help="show the run as it goes: in the terminal (--live, --live term) or on a page "
            "on 127.0.0.1 (--live web); the recording loses nothing to it",
        )
    # The view's options default to None, so that one given without a view to take it is
    # refused (`precheck`) rather than ignored; `precheck` fills in the defaults.
    p.add_argument(
        "--signals",
        default=None,
        help=f"what the live view shows, comma-separated (default {_LIVE_DEFAULTS['signals']})",
    )
    lo, hi = live.WINDOW_RANGE_S
    p.add_argument(
        "--window",
        type=float,
        default=None,
        metavar="S",
        help=f"the live view's rolling window in s (default {live.DEFAULT_WINDOW_S:g}, "
        f"{lo:g}..{hi:g})",
    )
    p.add_argument(
        "--http-port",
        type=int,
        default=None,
        help="--live web: the page's port (default: a free one)",
    )


_LIVE_DEFAULTS = {
    "signals": ",".join(live.SIGNALS),
    "window": live.DEFAULT_WINDOW_S,
    "http_port": 0,
}
_LIVE_OPTIONS = {"signals": "--signals", "window": "--window", "http_port": "--http-port"}


def _live_options_problem(args) -> str | None:
    """A view's option with no view to take it (no --live; --http-port with the terminal's):
    refused, not ignored. Fills in the defaults of those not given."""
    given = [opt for dest, opt in _LIVE_OPTIONS.items() if getattr(args, dest, None) is not None]
    if not getattr(args, "live", None):
        if given:
            return f"{', '.join(given)}: for the live view, which needs --live"
        return None
    if args.live == "term" and args.http_port is not None:
        return "--http-port: for the page (--live web); the terminal's view has no port"
    for dest, default in _LIVE_DEFAULTS.items():
        if getattr(args, dest) is None:
            setattr(args, dest, default)
    return None


def precheck(args) -> int | None:
    """Checks of a command's files and options before anything is sent: one line and exit 2 on
    bad input."""
    if problem := _live_options_problem(args):
        print(f"bowden bench: {problem}", file=sys.stderr)
        return 2
    if getattr(args, "live", None):
        lo, hi = live.WINDOW_RANGE_S
        problem = None
        if not lo <= args.window <= hi:
            problem = f"--window {args.window:g}: outside {lo:g}..{hi:g} s"
        elif not 0 <= args.http_port <= 65535:
            problem = f"--http-port {args.http_port}: outside 0..65535"
        else:
            try:
                args.signal_list = live.parse_signals(args.signals)
            except ValueError as exc:
                problem = str(exc)
        problem = problem or _live_place_problem(args)
        if problem:
            print(f"bowden bench: {problem}", file=sys.stderr)
            return 2
    if args.bench_command == "watch" and not (math.isfinite(args.seconds) and args.seconds > 0):
        print(
            f"bowden bench watch: --seconds {args.seconds:g}: expected a duration > 0 s",
            file=sys.stderr,
        )
        return 2
    if args.bench_command == "calibrate":
        return _precheck_calibrate(args)
    if args.bench_command == "restore":  # the file read and checked as diff reads it
        try:
            args.restore_plan = restore_plan(args.file)
        except paramfiles.ParamFileError as exc:
            print(f"bowden bench: restore: {exc}", file=sys.stderr)
            return 2  # a missing, unreadable or bad backup is a usage error, as for diff
        return None
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


def _live_place_problem(args) -> str | None:
    """Where the view would go, checked before the run: a terminal for `term` (drawn into a
    file or a pipe it would be escape codes, tens of kB a second), a port free for `web`."""
    if args.live == "term" and not sys.stdout.isatty():
        other = "--live web" if args.bench_command == "watch" else "--live web, or no --live"
        return (
            f"--live term draws in a terminal and the output is not one: use {other} (a page on "
            "127.0.0.1)"
        )
    if args.live == "web" and (why := live.check_http_port(args.http_port)):
        return f"--http-port {args.http_port}: {why} (choose another, or 0 for a free one)"
    return None


def _precheck_calibrate(args) -> int | None:
    from cosim.bench.link.client import BenchUsageError  # noqa: PLC0415
    from cosim.bench.rig.calibrate import check_out_dir  # noqa: PLC0415

    if args.persist and not args.apply:
        print(
            "bowden bench calibrate: --persist saves what --apply writes: give --apply too",
            file=sys.stderr,
        )
        return 2
    try:
        check_out_dir(Path(args.out), args.force)
    except BenchUsageError as exc:
        print(f"bowden bench {exc}", file=sys.stderr)
        return 2
    from cosim.bench.rig import bend_map  # noqa: PLC0415

    try:
        args.map_positions = bend_map.positions_of(args.map)
    except bend_map.BendMapError as exc:
        print(f"bowden bench calibrate: {exc}", file=sys.stderr)
        return 2
    return None


def restore_plan(path: str | Path) -> tuple[list[tuple[msgs.Param, int]], str]:
    """What `restore` writes from `path`: a backup's every writable parameter
    (paramfiles.restore_plan), or the parameters a params file sets (a co-simulation params
    file's controller and compensator, or device parameters by name, read as `diff` reads them),
    the device keeping its other values. ParamFileError, one line, for a file that is neither or
    names a parameter this device does not know."""
    if not str(path).strip():
        raise paramfiles.ParamFileError("an empty file name: expected a backup or params file")
    path = Path(path)
    doc = paramfiles.read_json(path, "a backup or params file", "a JSON backup or params file")
    if not isinstance(doc, dict) or paramfiles.is_backup(doc):
        return paramfiles.restore_plan(path)
    ref = diff.read_params_file(path, doc)
    if ref is None:
        raise paramfiles.ParamFileError(
            f"{path} is neither a bowden bench backup, nor a params file of device parameters "
            '(e.g. {"loop.kp": 0.1}), nor a co-simulation params file (controller, compensator)'
        )
    if ref.unknown:
        raise paramfiles.ParamFileError(
            f"{path} has parameters this device does not know: {', '.join(ref.unknown)}"
        )
    todo = [(param(n), w) for n, w in ref.words.items() if not param(n).read_only]
    if not todo:
        raise paramfiles.ParamFileError(f"{path} sets no parameter the device has")
    left = [*ref.skipped, *ref.not_compared]
    note = f"a params file: the {len(todo)} parameters it sets, the others as the device has them"
    return todo, note + (f"; not device parameters: {', '.join(left)}" if left else "")


def restore_command(args) -> str | None:
    """The `bowden bench ... restore` command line for this session's link; None for an
    emulated device (--emulate): it lives in this process and ends with it, and a restore
    would start a new one, on its defaults."""
    if args.emulate:
        return None
    link = f"--can {args.can} --node {args.node}" if args.can else f"--port {args.port}"
    return f"bowden bench {link} restore"


def cmd_calibrate(client, args, info) -> int:
    """`bowden bench calibrate` (cosim.bench.rig.calibrate): every run ends with `stop_and_confirm`
    (cosim.bench.rig.run: the device stopped, its output disabled, confirmed by the device)."""
    from cosim.bench.link.recorder import stderr_progress  # noqa: PLC0415
    from cosim.bench.rig import calibrate  # noqa: PLC0415

    def after_run() -> None:
        with args.signals.hold():
            why_not = stop_and_confirm(client)
        if why_not is None:
            args.stop_report = "device stopped, output disabled (confirmed by the device)"
            return
        args.stop_report = (
            f"the device did NOT confirm that it stopped ({why_not}): it ends the run by "
            "itself; switch the drive off"
        )
        raise BenchError("a run could not be stopped")

    opts = calibrate.Options(
        out_dir=Path(args.out),
        apply=args.apply,
        persist=args.persist,
        restore_hint=restore_command(args),
        map_positions=tuple(getattr(args, "map_positions", ())),
    )
    outcome = calibrate.run_calibration(
        client,
        info,
        opts,
        after_run=after_run,
        hold=args.signals.hold,
        say=lambda line: print(line, flush=True),
        progress=None if args.quiet else stderr_progress,
        bench_at=_bench_at(client, args, after_run),
    )
    return outcome.exit_code


def _bench_at(client, args, after_run):
    """calibrate's bench_at for its map of the bending angle: with --emulate a stepped
    emulated bench with the session's plant started at each position; on a device, the user
    moves the end-effector there while the output is off (every run ended with it disabled,
    confirmed) and presses Enter (Ctrl-C stops the calibration and puts everything back)."""
    import contextlib  # noqa: PLC0415

    from cosim.bench.rig import bend_map  # noqa: PLC0415

    if args.emulate:
        chain = getattr(args, "emulated_chain", None)
        return bend_map.emulated_at(
            None if chain is None else chain.plant, True if chain is None else chain.loop_routing
        )

    @contextlib.contextmanager
    def at(p):
        print(
            f"move the end-effector to {bend_map.show_position(p)} m (the output is disabled), "
            "then press Enter; Ctrl-C stops the calibration",
            flush=True,
        )
        try:
            input()
        except EOFError:
            raise BenchError(
                "calibrate --map: no answer on the standard input (it asks you to move the "
                "end-effector to each position)"
            ) from None
        yield client, after_run

    return at


def resolve_port(args) -> None:
    """`--port auto`: the only controller pyserial's ports lead to (several: AmbiguousPortError,
    a usage error naming them; none: BenchError)."""
    if args.port == "auto":
        args.port = discover.auto_port(
            baud=args.baud, timeout_s=min(args.timeout, discover.PROBE_TIMEOUT_S)
        )


def cmd_list(args, chain=None) -> int:
    """`bowden bench list`: one row per controller found; exit 1 when there is none. With
    `--emulate --can BUS` the emulator joins the bus first (python-can's virtual bus)."""
    timeout_s = min(args.timeout, discover.PROBE_TIMEOUT_S)
    if args.port == "":
        print(
            "bowden bench list: --port is empty: give a port, or leave --port out", file=sys.stderr
        )
        return 2
    if args.emulate and not args.can:
        print(
            "bowden bench list: --emulate lists an emulator on the --can bus given (a stepped "
            "one in this process has no port to list): add --can, or start `bowden emulate`",
            file=sys.stderr,
        )
        return 2
    if args.can:  # one wait for every node at once: the whole reply timeout
        emulator = None
        if args.emulate:
            from cosim.bench.emulate.emulator import Emulator  # noqa: PLC0415

            emulator = Emulator(pty=False, tcp_port=None, can=args.can, chain=chain).start()
        try:
            found = discover.probe_can(args.can, timeout_s=args.timeout)
        finally:
            if emulator is not None:
                emulator.stop()
        where = f"on {args.can} (nodes 0..{(1 << msgs.CAN_NODE_BITS) - 1})"
    else:
        ports = [args.port] if args.port and args.port != "auto" else None
        why_not: dict[str, str] = {}
        # A port the user named is given the whole reply timeout; each of a list, a short one.
        found, probed = discover.probe_serial(
            ports, baud=args.baud, timeout_s=args.timeout if ports else timeout_s, why_not=why_not
        )
        where = f"on {len(probed)} serial port(s) probed" if probed else "(pyserial lists no ports)"
        if ports:  # the port the user named: why it is not listed
            where = f"on {args.port} ({why_not.get(args.port, 'no answer')})"
    if not found:
        print(f"bowden bench list: no controller answered HELLO {where}", file=sys.stderr)
        return 1
    print(discover.table(found))
    if any(not f.busy and not f.compatible for f in found):
        print(
            "note: a controller marked 'host: other' speaks another protocol version or table "
            "than this host: update the host or its firmware before a session"
        )
    return 0


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


def cmd_watch(client, args, info) -> int:
    """`bowden bench watch`: `run` (cosim.bench.rig.run.cmd_run, with every exit path of a run)
    of the waveform the device is set to, with the live view; recorded to --out or a new
    temporary file."""
    run_ticks(args.seconds, float(client.get("tick_rate_hz")))  # before any file or view
    folder = None
    if args.out is None:
        folder = Path(tempfile.mkdtemp(prefix="bowden-watch-"))
        args.out = str(folder / "watch.csv")
    args.waveform = str(client.get("wave.kind"))
    args.mean = float(client.get("wave.mean_n"))
    args.amplitude = float(client.get("wave.amplitude_n"))
    args.freq = float(client.get("wave.freq_hz"))
    args.ref = None
    args.position, args.loop_routing, args.sheath_length = (0.0, 0.5, 0.0), True, 1.0
    args.quiet = False
    try:
        return cmd_run(client, args, info)
    finally:
        if folder is not None and not any(folder.iterdir()):
            folder.rmdir()  # the run recorded nothing: no empty folder left behind
