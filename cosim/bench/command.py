"""`bowden bench` (talk to a controller) and `bowden emulate` (be one), see cosim/bench/README.md.

    bowden emulate                                   # prints its pty and socket:// URL
    bowden bench --port /dev/pts/7 info
    bowden bench --port socket://127.0.0.1:5555 set comp.mode=smooth comp.band_n=1
    bowden bench --port /dev/ttyUSB0 run sine --mean 8 --amplitude 6 --freq 0.5 \\
        --seconds 5 --out x.csv
    bowden bench --can virtual:bench --emulate run triangle --seconds 5 --out y.csv

Every failure is one line on stderr and a non-zero exit: an unknown parameter or value, a port
that does not open, a device that does not answer, a version mismatch, a device error.

The parsers, `bench_main` and the handlers live here, not in cosim/cli, so that
`python -m cosim.bench` starts without the rest of `bowden`; cosim/cli/bench.py adds the two
parsers to `bowden`'s subcommands.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import signal
import sys
from pathlib import Path

from cosim.bench import command_tools as bench_tools
from cosim.bench.emulate.command import emulate_main, plant_assignments
from cosim.bench.emulate.host_device import ChainConfig
from cosim.bench.link import messages as msgs
from cosim.bench.link.api import Bench
from cosim.bench.link.client import (
    BenchClient,
    BenchError,
    BenchUsageError,
    DeviceError,
    fault_names,
    status_names,
)
from cosim.bench.link.paramfiles import ParamFileError
from cosim.bench.link.paramset import backup_doc, write_all, write_atomic
from cosim.bench.link.protocol import ProtocolError, format_value, param, word_from_value
from cosim.bench.link.recorder import WAVE_KINDS, check_geometry
from cosim.bench.rig.run import Signals, cmd_run
from cosim.project.cliargs import finite_float
from cosim.project.interrupt import Interrupted
from cosim.project.pipes import output_reader_gone


def _position(text: str) -> tuple[float, float, float]:
    try:
        parts = [float(p) for p in text.split(",")]
    except ValueError:
        parts = []
    if len(parts) != 3 or not all(math.isfinite(p) for p in parts):
        raise argparse.ArgumentTypeError(f"expected X,Y,Z in metres, e.g. 0,0.5,0; got {text!r}")
    return parts[0], parts[1], parts[2]


def _positive(kind):
    def conv(text: str):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number > 0; got {text!r}") from None
        if not (math.isfinite(v) and v > 0):
            raise argparse.ArgumentTypeError(f"expected a number > 0; got {text!r}")
        return v

    return conv


def _channel(text: str) -> int | str:
    """--channel: a channel number (0, 1, ...: the protocol's, the register banks' and the
    telemetry's numbering) or `all`; the device's count is checked once it says it."""
    if text.strip().lower() == "all":
        return "all"
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a channel number (0, 1, ...) or all; got {text!r}"
        ) from None
    if v < 0:
        raise argparse.ArgumentTypeError(
            f"expected a channel number (0, 1, ...) or all; got {text!r}"
        )
    return v


def _channel_count(text: str) -> int:
    """--channels of `bowden emulate`: how many cables the emulated device drives."""
    from cosim.bench.emulate.host_device import Device  # noqa: PLC0415

    top = Device.channels_max()
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a whole number 1..{top}; got {text!r}"
        ) from None
    if not 1 <= v <= top:
        raise argparse.ArgumentTypeError(f"expected a whole number 1..{top}; got {text!r}")
    return v


# The commands `--channel all` takes (each channel in turn, or a run of them all); the others
# (backup, restore, diff, calibrate, watch) work on one channel's words or run at a time.
_ALL_CHANNELS_COMMANDS = ("info", "get", "set", "faults", "run")


def add_parser(subparsers) -> None:
    _add_bench(subparsers)
    _add_emulate(subparsers)


# --- bowden bench --------------------------------------------------------------------------------


def _add_bench(subparsers) -> None:
    p = subparsers.add_parser(
        "bench",
        help="configure a controller, run waveforms and record them (serial or CAN)",
        description="Talk to a controller (or `bowden emulate`) over any pyserial URL or any "
        "python-can interface: parameters, persistence, faults, and recorded runs in the trace "
        "format.",
    )
    # Neither the link nor the COMMAND is `required` for argparse: it would report a missing one
    # before an unknown option; bench_main names what is missing instead.
    link = p.add_mutually_exclusive_group()
    link.add_argument(
        "--port",
        help="pyserial URL: /dev/ttyUSB0, /dev/pts/N, socket://HOST:PORT; auto: the only "
        "controller found on the ports pyserial lists (see `list`)",
    )
    link.add_argument(
        "--can", help="python-can INTERFACE:CHANNEL, e.g. virtual:bench, socketcan:can0"
    )
    p.add_argument("--baud", type=_positive(int), default=921_600, help="serial baud rate")
    p.add_argument("--node", type=int, default=msgs.CAN_DEFAULT_NODE, help="CAN node id (0..63)")
    p.add_argument("--timeout", type=_positive(float), default=1.0, help="reply timeout in s")
    p.add_argument(
        "--emulate",
        action="store_true",
        help="start the emulator in this process: on the --can bus (python-can's virtual bus "
        "reaches only this process), or without --port/--can stepped as fast as it computes, not "
        "in real time (a run records what `bowden emulate` would give, with no drops on a loaded "
        "machine)",
    )
    p.add_argument(
        "--plant",
        action="append",
        default=[],
        metavar="NAME=VALUE[,...]",
        help="with --emulate: FMU parameters of the emulated plant (as `bowden emulate --plant`)",
    )
    p.add_argument(
        "--channel",
        type=_channel,
        default=0,
        metavar="K|all",
        help="the cable a command addresses, 0 .. n-1 (default 0; `info` and `list` say n), or "
        "all: info, get, set, faults and run on every channel (run: one CSV per channel, "
        "NAME.chK.csv)",
    )
    p.add_argument(
        "--channels",
        type=_channel_count,
        default=1,
        metavar="N",
        help="with --emulate: the emulated device's channels (default 1)",
    )
    sub = p.add_subparsers(dest="bench_command", metavar="COMMAND")
    sub.add_parser("info", help="firmware, protocol, configuration state, faults")
    g = sub.add_parser("get", help="parameter values (all, or the NAMEs given)")
    g.add_argument("names", nargs="*", metavar="NAME")
    s = sub.add_parser("set", help="write parameters: NAME=VALUE (SI units or a mode name)")
    s.add_argument("assignments", nargs="+", metavar="NAME=VALUE")
    sub.add_parser("persist", help="save the parameters in the device's flash")
    sub.add_parser("load", help="reload the parameters saved in flash")
    sub.add_parser("defaults", help="factory defaults (in RAM; persist makes them permanent)")
    b = sub.add_parser("backup", help="save every parameter to a JSON file, stamped")
    b.add_argument("file")
    b.add_argument("--force", action="store_true", help="overwrite an existing backup file")
    r = sub.add_parser(
        "restore",
        help="write the parameters of a backup file, or those a params file sets",
    )
    r.add_argument("file")
    f = sub.add_parser("faults", help="the FPGA's and the device's faults, by name")
    f.add_argument("--clear", action="store_true", help="clear them afterwards")
    sub.add_parser("stats", help="the device's link counters (frames, CRC errors, ...)")
    run = sub.add_parser("run", help="run a waveform and record telemetry in the trace format")
    run.add_argument("waveform", choices=(*WAVE_KINDS, "stream"))
    run.add_argument("--mean", type=finite_float, default=8.5, help="mean T_ref in N (default 8.5)")
    run.add_argument(
        "--amplitude", type=finite_float, default=6.5, help="amplitude in N (default 6.5)"
    )
    run.add_argument("--freq", type=finite_float, default=0.5, help="frequency in Hz (default 0.5)")
    run.add_argument("--ref", help="stream: CSV with T_ref_N (one row per tick), or one column")
    run.add_argument("--seconds", type=_positive(float), required=True)
    run.add_argument("--out", required=True, help="trace CSV (its .meta.json goes beside it)")
    run.add_argument(
        "--position",
        type=_position,
        default=(0.0, 0.5, 0.0),
        metavar="X,Y,Z",
        help="end-effector position in m, held during the run (default 0,0.5,0)",
    )
    run.add_argument("--no-loop-routing", dest="loop_routing", action="store_false")
    run.add_argument("--sheath-length", type=_positive(float), default=1.0, help="m")
    run.add_argument("--quiet", action="store_true", help="no progress line")
    bench_tools.add_live_arguments(run)
    bench_tools.add_parsers(sub)
    p.set_defaults(func=bench_main)


def bench_main(args: argparse.Namespace) -> int:
    if not args.port and not args.can and not args.emulate and args.bench_command != "list":
        print(
            "bowden bench: one of --port URL, --can INTERFACE:CHANNEL or --emulate is required "
            "(see bowden bench --help)",
            file=sys.stderr,
        )
        return 2
    if args.plant and not args.emulate:
        print("bowden bench: --plant sets the emulated plant: it needs --emulate", file=sys.stderr)
        return 2
    if args.channels != 1 and not args.emulate:
        print(
            "bowden bench: --channels sets the emulated device's channels: it needs --emulate "
            "(a device says its own)",
            file=sys.stderr,
        )
        return 2
    if args.channel == "all" and args.bench_command not in (None, "list", *_ALL_CHANNELS_COMMANDS):
        print(
            f"bowden bench: --channel all works with {', '.join(_ALL_CHANNELS_COMMANDS)}; "
            f"{args.bench_command} takes one channel (--channel K)",
            file=sys.stderr,
        )
        return 2
    if args.bench_command is None:
        print(
            f"bowden bench: a COMMAND is required: {', '.join(_COMMANDS)} "
            "(see bowden bench --help)",
            file=sys.stderr,
        )
        return 2
    if (rc := bench_tools.precheck(args)) is not None:
        return rc
    try:
        plant = plant_assignments(args.plant)
    except ValueError as exc:
        print(f"bowden bench: {exc}", file=sys.stderr)
        return 2
    args.signals = Signals()
    args.stop_report = None  # what the device said when a run was stopped
    with args.signals:
        try:
            return _bench_session(args, plant)
        except (Interrupted, KeyboardInterrupt):  # or Ctrl-C before the handlers were in place
            signum = args.signals.signum or int(signal.SIGINT)
            print(
                f"bowden bench: interrupted by {signal.Signals(signum).name}"
                + (f"; {args.stop_report}" if args.stop_report else ""),
                file=sys.stderr,
            )
            return 128 + signum
        except (BenchUsageError, ProtocolError) as exc:  # a value this host or device refuses
            print(f"bowden bench: {exc}", file=sys.stderr)
            return 2
        except DeviceError as exc:
            stop = f"; {args.stop_report}" if args.stop_report else ""
            print(f"bowden bench: {exc}{stop}", file=sys.stderr)
            return 2 if exc.code == "INVALID_VALUE" else 1
        except BenchError as exc:
            stop = f"; {args.stop_report}" if args.stop_report else ""
            print(f"bowden bench: {exc}{stop}", file=sys.stderr)
            return 1
        except OSError as exc:  # a full disk, a folder that cannot be written: say which
            if output_reader_gone(exc):
                raise  # `... | head`: main() ends quietly
            where = f": {exc.filename}" if exc.filename else ""
            stop = f"; {args.stop_report}" if args.stop_report else ""
            print(f"bowden bench: {exc.strerror or exc}{where}{stop}", file=sys.stderr)
            return 1


def _bench_session(args: argparse.Namespace, plant: dict) -> int:
    session = None
    if args.bench_command == "run":
        check_geometry(args.position, args.sheath_length, plant if args.emulate else None)
    try:
        if args.emulate and args.port:
            raise BenchUsageError(
                "--emulate works with --can or alone (use `bowden emulate` for serial)"
            )
        chain = ChainConfig(
            position_m=getattr(args, "position", (0.0, 0.5, 0.0)),
            loop_routing=getattr(args, "loop_routing", True),
            plant=plant or None,
        )
        if args.bench_command == "list":
            return bench_tools.cmd_list(args, chain)
        args.emulated_chain = chain if args.emulate else None
        bench_tools.resolve_port(args)
        session = Bench(
            args.port,
            can=args.can,
            node=args.node,
            baud=args.baud,
            timeout_s=args.timeout,
            emulate=args.emulate,
            chain=chain if args.emulate else None,  # a real device has no emulated bench
            channels=args.channels,
        )
        args.channel_list = _channels_of(args.channel, session.connect_info.n_channels)
        session.client.channel = args.channel_list[0]
        return _COMMANDS[args.bench_command](session.client, args, session.connect_info)
    finally:
        if session is not None:
            with contextlib.suppress(Exception):
                session.close()


def _channels_of(choice: int | str, n_channels: int) -> tuple[int, ...]:
    """The channels --channel names on a device of n_channels; BenchUsageError (exit 2) for one
    the device does not have."""
    if choice == "all":
        return tuple(range(n_channels))
    if not 0 <= choice < n_channels:
        have = "channel 0" if n_channels == 1 else f"channels 0..{n_channels - 1}"
        raise BenchUsageError(
            f"--channel {choice}: the device has {n_channels} channel"
            f"{'' if n_channels == 1 else 's'} ({have})"
        )
    return (choice,)


def _chans(args, client: BenchClient) -> tuple[int, ...]:
    """The channels a command works on: those --channel named, or the client's one."""
    return tuple(getattr(args, "channel_list", None) or (client.channel,))


def _channel_tag(chans: tuple[int, ...], c: int) -> str:
    """A line's channel prefix when several channels are shown, else nothing."""
    return f"[ch {c}] " if len(chans) > 1 else ""


def _cmd_info(client: BenchClient, args, info) -> int:
    print(f"device        {client.link.url}")
    print(f"firmware      {info.firmware} (build {info.build_id:08x})")
    print(f"protocol      {info.proto_version}, table {info.table_hash:08x} (host: same)")
    print(f"channels      {info.n_channels}")
    print(f"parameters    {info.n_params}")
    dirty = "yes: `bowden bench ... persist` keeps them" if info.dirty else "no"
    print(f"configuration {info.config_source}; unsaved changes: {dirty}")
    for c in _chans(args, client):
        f = client.faults(c)
        fpga = fault_names(f["fpga_fault"] & 0x0F) or ["none"]
        dev = ", ".join(fault_names(f["device_faults"])) or "none"
        where = f"channel {c}: " if info.n_channels > 1 else ""
        print(f"faults        {where}FPGA {', '.join(fpga)}; device {dev}")
    if client.stale_telemetry:
        print(f"note          the device was streaming: stopped ({client.stale_telemetry} frames)")
    return 0


def _cmd_get(client: BenchClient, args, info) -> int:
    names = args.names or [p.name for p in msgs.PARAMS]
    for name in names:
        param(name)  # unknown names fail before anything is read
    width = max(len(n) for n in names)
    chans = _chans(args, client)
    if len(chans) > 1:  # a column per channel
        cells = {c: [format_value(param(n), client.get_word(n, c)) for n in names] for c in chans}
        widths = {c: max(len(f"ch {c}"), *(len(v) for v in cells[c])) for c in chans}
        print(f"{'':<{width}}  " + "  ".join(f"{f'ch {c}':<{widths[c]}}" for c in chans).rstrip())
        for i, name in enumerate(names):
            row = "  ".join(f"{cells[c][i]:<{widths[c]}}" for c in chans).rstrip()
            print(f"{name:<{width}}  {row}")
        return 0
    for name in names:
        p = param(name)
        print(f"{name:<{width}}  {format_value(p, client.get_word(name))}")
    return 0


def _cmd_set(client: BenchClient, args, info) -> int:
    todo = []
    for a in args.assignments:
        name, sep, value = a.partition("=")
        if not sep:
            raise ProtocolError(f"{a!r}: expected NAME=VALUE")
        p = param(name.strip())
        if p.read_only:
            raise ProtocolError(f"{p.name} is read-only")
        todo.append((p, word_from_value(p, value.strip())))  # all checked before any is sent
    chans = _chans(args, client)
    for c in chans:
        client.channel = c
        for p, word in write_all(client, todo, "set"):
            print(f"{_channel_tag(chans, c)}{p.name} = {format_value(p, word)}")
    print("(in RAM: `persist` saves them)")
    return 0


def _check_new_file(path: Path, force: bool, what: str) -> None:
    if path.is_dir():
        raise BenchUsageError(f"{what} {path}: is a folder; give a file name")
    if path.exists() or path.is_symlink():
        if not path.is_file() or path.is_symlink():
            raise BenchUsageError(f"{what} {path}: not a regular file")
        if not force:
            raise BenchUsageError(f"{what} {path}: exists; --force overwrites it")


def _write_new_file(path: Path, text: str, force: bool, what: str) -> None:
    """Write `text` to `path` atomically (cosim.bench.link.paramset.write_atomic): only a regular
    file is replaced, and only with `force`."""
    _check_new_file(path, force, what)
    write_atomic(path, text)


def _cmd_simple(name: str, text: str):
    def cmd(client: BenchClient, args, info) -> int:
        value = client.simple(name)
        print(text.format(value=value))
        return 0

    return cmd


def _cmd_backup(client: BenchClient, args, info) -> int:
    path = Path(args.file)
    _check_new_file(path, args.force, "backup")  # before anything is read from the device
    doc = backup_doc(client, info)
    _write_new_file(path, json.dumps(doc, indent=2) + "\n", force=args.force, what="backup")
    print(f"saved {len(doc['params'])} parameters to {path} (table {msgs.TABLE_HASH:08x})")
    return 0


def _cmd_restore(client: BenchClient, args, info) -> int:
    path = Path(args.file)
    # Read and checked before the link opened (bench_tools.precheck), or here when called alone.
    plan = getattr(args, "restore_plan", None)
    if plan is None:
        try:
            plan = bench_tools.restore_plan(path)
        except ParamFileError as exc:  # the file, not the device: a usage error (exit 2)
            raise BenchUsageError(f"restore: {exc}") from None
    todo, note = plan
    if note:
        print(f"note: {note}")
    try:
        done = write_all(client, todo, "restore")
    except BenchUsageError as exc:
        raise BenchError(f"{exc} ({path})") from None
    print(f"restored {len(done)} parameters from {path} (in RAM: `persist` saves them)")
    return 0


def _cmd_faults(client: BenchClient, args, info) -> int:
    chans = _chans(args, client)
    for c in chans:
        tag = _channel_tag(chans, c)
        f = client.faults(c)
        fpga = fault_names(f["fpga_fault"] & 0x0F)
        status = ", ".join(n for n in status_names(f["fpga_status"] << 1)) or "idle"
        print(f"{tag}FPGA faults    {', '.join(fpga) or 'none'}")
        print(f"{tag}FPGA status    {status}")
        print(f"{tag}device faults  {', '.join(fault_names(f['device_faults'])) or 'none'}")
        print(f"{tag}fault ticks    {f['fault_ticks']}")
        for name in fault_names(f["fpga_fault"] & 0x0F) + fault_names(f["device_faults"]):
            doc = _FAULT_DOCS.get(name)
            if doc:
                print(f"  {name}: {doc}")
    if args.clear:
        client.simple("FAULT_CLEAR")
        print("cleared")
    return 0


def _cmd_stats(client: BenchClient, args, info) -> int:
    for k, v in client.stats().items():
        print(f"{k:<18} {v}")
    s = client.link.stats
    print(
        f"host: {s.frames} frames received, {s.rejected} rejected "
        f"({s.crc_errors} CRC, {s.framing_errors} framing, {s.overlong} overlong, "
        f"{s.short_frames} short)"
    )
    return 0


_FAULT_DOCS = {
    "ADC_STALE": "no valid sample from the load-cell ADC: check its wiring and clock",
    "ADC_RANGE": "load-cell code outside [ADC_MIN, ADC_MAX]: overload or a broken bridge",
    "WATCHDOG": "the processor stopped writing T_c: the FPGA ramped the current to zero",
    "OVERCURRENT": "the command stayed at the current limit for OC_TIMEOUT samples",
    "STREAM_UNDERRUN": "the streamed reference ran dry (T_ref was held)",
    "TX_OVERFLOW": "telemetry frames were dropped: raise the baud rate or dev.telemetry_div",
    "CONFIG": "the saved configuration was missing or rejected, or a flash write failed",
    "OVERRUN": "the device could not keep its tick rate",
}

_COMMANDS = {
    "info": _cmd_info,
    "get": _cmd_get,
    "set": _cmd_set,
    "persist": _cmd_simple("PERSIST", "saved to flash (record {value})"),
    "load": _cmd_simple("LOAD", "loaded from flash (record {value})"),
    "defaults": _cmd_simple("DEFAULTS", "factory defaults in force (in RAM: `persist` saves them)"),
    "backup": _cmd_backup,
    "restore": _cmd_restore,
    "faults": _cmd_faults,
    "stats": _cmd_stats,
    "run": cmd_run,
    "diff": bench_tools.cmd_diff,
    "watch": bench_tools.cmd_watch,
    "calibrate": bench_tools.cmd_calibrate,
}


# --- bowden emulate ------------------------------------------------------------------------------


def _add_emulate(subparsers) -> None:
    p = subparsers.add_parser(
        "emulate",
        help="run the controller on this machine (firmware + FPGA loop model + plant FMU)",
        description="The controller in real time: the firmware's host build with the protocol, "
        "the bit-exact model of the FPGA loop and the plant FMU, behind a pseudo-terminal, a TCP "
        "port (pyserial socket://) and optionally a python-can bus. Prints where to connect; runs "
        "until Ctrl-C, SIGTERM or --seconds.",
    )
    p.add_argument(
        "--target",
        choices=("host", "soc"),
        default="host",
        help="host (default): the firmware's host build and the loop's model; soc: the whole "
        "board simulated (bowden_soc executing the RV32 firmware in Verilator, its pins modelled; "
        "a pty only, slower than real time)",
    )
    # --baud, --tcp-port, --interface and --engine default to None so that --target soc can
    # tell one given from one left out (it refuses them); emulate_main fills in the host's.
    p.add_argument(
        "--baud",
        type=_positive(int),
        default=None,
        help="throttle the pty and the socket to this baud rate (default 921600)",
    )
    p.add_argument("--tcp-port", type=int, default=None, help="TCP port (default: any free one)")
    p.add_argument("--no-pty", action="store_true", help="no pseudo-terminal")
    p.add_argument("--no-tcp", action="store_true", help="no TCP port")
    p.add_argument(
        "--can", help="also on a python-can bus, INTERFACE:CHANNEL (e.g. socketcan:vcan0)"
    )
    p.add_argument("--flash", help="keep the emulated flash in this file across runs")
    p.add_argument(
        "--position",
        type=_position,
        default=(0.0, 0.5, 0.0),
        metavar="X,Y,Z",
        help="end-effector position in m (default 0,0.5,0)",
    )
    p.add_argument("--no-loop-routing", dest="loop_routing", action="store_false")
    p.add_argument(
        "--plant",
        action="append",
        default=[],
        metavar="NAME=VALUE[,...]",
        help="FMU parameters of the emulated plant, e.g. --plant sensor_offset=0.5,noise_std=0.03 "
        "(an effect for `bowden audit` to find); repeatable, each parameter once",
    )
    p.add_argument(
        "--interface",
        choices=("ideal", "adc", "board"),
        default=None,
        help="sensing and actuation between plant and loop (cosim.parts.interface): ideal "
        "(default, in C), or the board's ADC / ADC + PWM -> ESCON (on the Python engine)",
    )
    p.add_argument(
        "--engine",
        choices=("native", "python"),
        default=None,
        help="loop model in C (default) or Python (the definition; slower)",
    )
    p.add_argument("--seconds", type=_positive(float), default=None, help="stop after S seconds")
    p.add_argument(
        "--channels",
        type=_channel_count,
        default=None,
        metavar="N",
        help="cables the emulated device drives, each with its own loop and plant (default 1; "
        "the native engine; with --target soc 1, 2 or 4, the SoC and its firmware built for as "
        "many)",
    )
    p.add_argument(
        "--table-hash",
        default=None,
        metavar="HEX",
        help="pose as a firmware of another protocol table (to try the version check)",
    )
    p.add_argument(
        "--garbage-every",
        type=_positive(float),
        default=None,
        metavar="S",
        help="send a burst of garbage bytes every S seconds (to try the resync)",
    )
    p.set_defaults(func=emulate_main)
