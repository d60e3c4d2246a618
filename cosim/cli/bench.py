"""`bowden bench` (talk to a controller) and `bowden emulate` (be one), see cosim/bench/README.md.

    bowden emulate                                   # prints its pty and socket:// URL
    bowden bench --port /dev/pts/7 info
    bowden bench --port socket://127.0.0.1:5555 set comp.mode=smooth comp.band_n=1
    bowden bench --port /dev/ttyUSB0 run sine --mean 8 --amplitude 6 --freq 0.5 \\
        --seconds 5 --out x.csv
    bowden bench --can virtual:bench --emulate run triangle --seconds 5 --out y.csv

Every failure is one line on stderr and a non-zero exit: an unknown parameter or value, a port
that does not open, a device that does not answer, a version mismatch, a device error.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import json
import math
import os
import signal
import sys
import threading
import time
from pathlib import Path

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
from cosim.bench.link.paramfiles import ParamFileError, restore_plan
from cosim.bench.link.paramset import backup_doc, write_all, write_atomic
from cosim.bench.link.protocol import ProtocolError, format_value, param, word_from_value
from cosim.bench.link.recorder import WAVE_KINDS, stderr_progress
from cosim.parts import regmap
from cosim.parts.geometry import in_workspace
from cosim.results import trace as trace_mod

from . import bench_tools, output_reader_gone

# The FPGA's drive enable in the STATUS register (FAULTS.fpga_status).
STATUS_OUT_EN = 1 << next(f.lsb for f in regmap.REGISTERS["STATUS"].fields if f.name == "OUT_EN")


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM during a bench command (unwinds like Ctrl-C; exit 128 + signum)."""

    def __init__(self, signum: int) -> None:
        self.signum = signum
        super().__init__(signal.Signals(signum).name)


class Signals:
    """SIGINT and SIGTERM raise Interrupted in the main thread, once: a later signal is noted,
    not raised, so that it cannot cut short the STOP that follows. Inside `hold()` (stopping the
    device) a signal is noted and raised when the hold ends."""

    def __init__(self) -> None:
        self.signum: int | None = None
        self._raised = False
        self._holding = False
        self._previous: dict = {}

    def __enter__(self) -> Signals:
        if threading.current_thread() is threading.main_thread():
            self._previous = {
                sig: signal.signal(sig, self._handler) for sig in (signal.SIGINT, signal.SIGTERM)
            }
        return self

    def __exit__(self, *exc) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)

    def _handler(self, signum, _frame) -> None:
        if self.signum is None:
            self.signum = signum
        if not self._raised and not self._holding:
            self._raised = True
            raise Interrupted(signum)

    @contextlib.contextmanager
    def hold(self):
        self._holding = True
        try:
            yield
        finally:
            self._holding = False
        if self.signum is not None and not self._raised:
            self._raised = True
            raise Interrupted(self.signum)


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


def _finite(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number; got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"expected a finite number; got {text!r}")
    return v


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
    r = sub.add_parser("restore", help="write the parameters of a backup file")
    r.add_argument("file")
    f = sub.add_parser("faults", help="the FPGA's and the device's faults, by name")
    f.add_argument("--clear", action="store_true", help="clear them afterwards")
    sub.add_parser("stats", help="the device's link counters (frames, CRC errors, ...)")
    run = sub.add_parser("run", help="run a waveform and record telemetry in the trace format")
    run.add_argument("waveform", choices=(*WAVE_KINDS, "stream"))
    run.add_argument("--mean", type=_finite, default=8.5, help="mean T_ref in N (default 8.5)")
    run.add_argument("--amplitude", type=_finite, default=6.5, help="amplitude in N (default 6.5)")
    run.add_argument("--freq", type=_finite, default=0.5, help="frequency in Hz (default 0.5)")
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
        plant = _plant_assignments(args.plant)
    except ValueError as exc:
        print(f"bowden bench: {exc}", file=sys.stderr)
        return 2
    args.signals = Signals()
    args.stop_report = None  # what the device said when a run was stopped
    with args.signals:
        try:
            return _bench_session(args, plant)
        except KeyboardInterrupt:  # Interrupted, or Ctrl-C before the handlers were in place
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


def check_geometry(position_m, sheath_length_m: float, plant: dict | None = None) -> None:
    """--position inside the workspace of the sheath (Eq. 13 of the paper: within the sheath's
    length of the outlet, y >= 0) and --sheath-length in the trace format's range, before
    anything is sent or written. `plant`: the emulated plant's overrides (its sheath_length,
    when given, is the one the position must fit)."""
    lo, hi, unit, _ = trace_mod.META_RANGES["sheath_length_m"]
    if not lo <= sheath_length_m <= hi:
        raise BenchUsageError(
            f"--sheath-length {sheath_length_m:g}: outside [{lo:g}, {hi:g}] {unit}"
        )
    length = float((plant or {}).get("sheath_length", sheath_length_m))
    x, y, z = position_m
    if not bool(in_workspace(x, y, z, length)):
        raise BenchUsageError(
            f"--position {x:g},{y:g},{z:g}: outside the workspace of a {length:g} m sheath "
            f"(sqrt(x^2 + y^2 + z^2) <= {length:g} m and y >= 0)"
        )


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
        bench_tools.resolve_port(args)
        session = Bench(
            args.port,
            can=args.can,
            node=args.node,
            baud=args.baud,
            timeout_s=args.timeout,
            emulate=args.emulate,
            chain=chain if args.emulate else None,  # a real device has no emulated bench
        )
        return _COMMANDS[args.bench_command](session.client, args, session.connect_info)
    finally:
        if session is not None:
            with contextlib.suppress(Exception):
                session.close()


def _cmd_info(client: BenchClient, args, info) -> int:
    print(f"device        {client.link.url}")
    print(f"firmware      {info.firmware} (build {info.build_id:08x})")
    print(f"protocol      {info.proto_version}, table {info.table_hash:08x} (host: same)")
    print(f"parameters    {info.n_params}")
    dirty = "yes: `bowden bench ... persist` keeps them" if info.dirty else "no"
    print(f"configuration {info.config_source}; unsaved changes: {dirty}")
    f = client.faults()
    fpga = fault_names(f["fpga_fault"] & 0x0F) or ["none"]
    dev = ", ".join(fault_names(f["device_faults"])) or "none"
    print(f"faults        FPGA {', '.join(fpga)}; device {dev}")
    if client.stale_telemetry:
        print(f"note          the device was streaming: stopped ({client.stale_telemetry} frames)")
    return 0


def _cmd_get(client: BenchClient, args, info) -> int:
    names = args.names or [p.name for p in msgs.PARAMS]
    for name in names:
        param(name)  # unknown names fail before anything is read
    width = max(len(n) for n in names)
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
    for p, word in write_all(client, todo, "set"):
        print(f"{p.name} = {format_value(p, word)}")
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
            plan = restore_plan(path)
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
    f = client.faults()
    fpga = fault_names(f["fpga_fault"] & 0x0F)
    print(f"FPGA faults    {', '.join(fpga) or 'none'}")
    print(f"FPGA status    {', '.join(n for n in status_names(f['fpga_status'] << 1)) or 'idle'}")
    print(f"device faults  {', '.join(fault_names(f['device_faults'])) or 'none'}")
    print(f"fault ticks    {f['fault_ticks']}")
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


def _read_ref(path: str) -> list[int]:
    p = Path(path)
    try:
        text = p.read_text()
    except FileNotFoundError:
        raise BenchError(f"--ref {p}: no such file") from None
    except UnicodeDecodeError:
        raise BenchError(f"--ref {p}: not a text CSV") from None
    rows = list(csv.reader(text.splitlines()))
    if not rows:
        raise BenchError(f"--ref {p}: empty")
    header = [h.strip() for h in rows[0]]
    col = header.index("T_ref_N") if "T_ref_N" in header else 0
    start = 1 if not _is_number(rows[0][col] if col < len(rows[0]) else "") else 0
    words = []
    for i, row in enumerate(rows[start:], start=start + 1):
        if not row:
            continue
        cell = row[col] if col < len(row) else ""
        if not _is_number(cell):
            raise BenchError(f"--ref {p}:{i}: T_ref {cell!r} is not a finite number")
        v = float(cell)
        if not -128.0 <= v <= 127.99:
            raise BenchError(f"--ref {p}:{i}: T_ref {v:g} N outside [-128, 127.99] N")
        words.append(round(v * 256.0))
    if not words:
        raise BenchError(f"--ref {p}: no samples")
    return words


def _is_number(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def _cmd_run(client: BenchClient, args, info) -> int:
    words = None
    if args.waveform == "stream":
        if not args.ref:
            raise BenchUsageError("run stream needs --ref FILE.csv (T_ref_N, one row per tick)")
        words = _read_ref(args.ref)
    elif args.ref:
        raise BenchUsageError("--ref is for `run stream` only")
    out = _run_target(args.out)
    if client.stale_telemetry:
        print(
            f"note: the device was streaming when we connected: stopped it "
            f"({client.stale_telemetry} stale frames skipped)",
            file=sys.stderr,
        )
    # The run's rows go to NAME.partial.csv, moved onto --out when the run ends (a failed run
    # never wipes an earlier recording; a run killed with SIGKILL leaves the partial file).
    partial = out.with_name(f"{out.stem}.partial{out.suffix}")
    result = None
    try:
        result = bench_tools.record_with_view(
            client,
            args,
            partial,
            f"{args.waveform} -> {out}",
            seconds=args.seconds,
            waveform=args.waveform,
            mean_n=args.mean,
            amplitude_n=args.amplitude,
            freq_hz=args.freq,
            stream_words=words,
            position_m=args.position,
            loop_routing=args.loop_routing,
            sheath_length_m=args.sheath_length,
            progress=None if args.quiet else stderr_progress,
        )
    finally:
        # Every way out of a run (the end, a signal, a link error, an exception, a full disk)
        # passes here: STOP, then the device's own word that it stopped and the output is off.
        with args.signals.hold():
            why_not = stop_and_confirm(client)
            args.stop_report = (
                "device stopped, output disabled (confirmed by the device)"
                if why_not is None
                else f"the device did NOT confirm that it stopped ({why_not}): it ends the run "
                "by itself after --seconds; switch the drive off"
            )
            kept = _keep_recording(partial, out)
            if result is None and kept:
                args.stop_report = f"{out} holds the samples up to now; {args.stop_report}"
    if why_not is not None:
        raise BenchError(f"{out}: {result.summary()}")
    print(f"{out}: {result.summary()} ({result.wall_s:.1f} s)")
    for first, count in result.gaps[:5]:
        print(f"  gap: {count} sample(s) missing from sample {first}")
    if result.drops or result.stopped_early:
        print(
            f"bowden bench: the recording is incomplete ({result.drops} dropped, device stopped "
            f"early: {result.stopped_early}); python -m cosim.results.trace will name the first "
            "gap",
            file=sys.stderr,
        )
        return 1
    return 0


def stop_and_confirm(client: BenchClient, tries: int = 3, settle_s: float = 0.5) -> str | None:
    """Send STOP, then ask the device: None when HELLO says no run is active and the FPGA's
    STATUS shows the drive output disabled; otherwise why that could not be confirmed. The FPGA
    takes STOP's CTRL write at its next sample: STATUS is read again for up to `settle_s`."""
    client.on_telemetry = None
    why = "no answer"
    for _ in range(tries):
        try:
            client.request("STOP")
            deadline = time.monotonic() + settle_s
            while True:
                running = client.hello().running
                out_en = client.faults()["fpga_status"] & STATUS_OUT_EN
                if (not running and not out_en) or time.monotonic() >= deadline:
                    break
                client.poll(0.02)  # (the stepped emulator advances its loop here)
        except (BenchError, ProtocolError, OSError) as exc:
            why = str(exc)
            continue
        if not running and not out_en:
            return None
        why = "a run is still active" if running else "the FPGA's output is still enabled"
    return why


def _run_target(text: str) -> Path:
    """--out checked before anything is sent or written: a CSV file name, not a folder."""
    out = Path(text)
    if out.is_dir() or text.endswith(os.sep):
        raise BenchUsageError(f"--out {text}: is a folder; give a CSV file name (e.g. run.csv)")
    if out.exists() and not out.is_file():
        raise BenchUsageError(f"--out {text}: not a regular file")
    return out


def _keep_recording(partial: Path, out: Path) -> bool:
    """Move a run's rows (and sidecar) onto `out` when it recorded any; otherwise remove the
    partial files and leave `out` as it was. True when `out` now holds the run."""
    meta = trace_mod.meta_path(partial)
    rows = 0
    if partial.exists():
        with partial.open("rb") as f:
            rows = sum(1 for _ in f) - 1
    if rows <= 0:
        for p in (partial, meta):
            p.unlink(missing_ok=True)
        return False
    if meta.exists():
        meta.replace(trace_mod.meta_path(out))
    partial.replace(out)
    return True


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
    "run": _cmd_run,
    "diff": bench_tools.cmd_diff,
    "watch": lambda client, args, info: bench_tools.cmd_watch(client, args, info, _cmd_run),
    "calibrate": lambda client, args, info: bench_tools.cmd_calibrate(
        client, args, info, stop_and_confirm
    ),
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


def _plant_assignments(items: list[str]) -> dict:
    """--plant NAME=VALUE[,NAME=VALUE...] (repeatable) as FMU parameter overrides, checked as a
    params file's plant section is (cosim.config.scenarios.plant_overrides: an FMU parameter, in its
    range)."""
    from cosim.config.run import plant_overrides  # noqa: PLC0415 (reads the built FMU)

    raw: dict[str, float | bool] = {}
    given: dict[str, str] = {}  # name -> the value's text (a second value is refused, not taken)
    for option, item in ((arg, part) for arg in items for part in arg.split(",")):
        name, sep, text = item.partition("=")
        name, text = name.strip(), text.strip()
        if not item.strip():
            raise ValueError(f"--plant {option!r}: an empty item; expected NAME=VALUE[,...]")
        if not sep or not name:
            raise ValueError(f"--plant {item!r}: expected NAME=VALUE (e.g. sensor_offset=0.5)")
        if name in given:
            raise ValueError(
                f"--plant {name}={given[name]} and {name}={text}: {name} given twice; "
                "give each parameter once"
            )
        given[name] = text
        if text.lower() in ("true", "false"):
            raw[name] = text.lower() == "true"
            continue
        if text.strip().lstrip("+-").isdigit():
            if len(text.strip()) > 30:  # beyond every parameter's range (and int()'s limit)
                raise ValueError(
                    f"--plant {name}: a whole number of {len(text.strip())} digits is outside "
                    "every parameter's range"
                )
            raw[name] = int(text)  # Integer parameters (seed) take whole numbers
            continue
        try:
            raw[name] = float(text)
        except ValueError:
            raise ValueError(f"--plant {item!r}: {text!r} is not a number") from None
    return plant_overrides(raw, "--plant")


def _flash_problem(text: str, target: str) -> str | None:
    """--flash checked before anything starts: a flash image of the target's size that can be
    read, or no file yet, in a folder that can be written (the emulator saves the flash there
    while it runs; a save that failed then would stop it). None when it will do."""
    from cosim.bench.emulate.soc.harness import FLASH_BYTES, check_flash_file  # noqa: PLC0415

    if not text.strip():
        return f"--flash {text!r}: expected a file name (a flash image, or none yet)"
    if target == "soc":
        size_bytes = FLASH_BYTES
    else:
        from cosim.bench.emulate.host_device import load_library  # noqa: PLC0415

        size_bytes = 4 * load_library().dev_host_flash_n_words()
    try:
        check_flash_file(Path(text), size_bytes)
    except ValueError as exc:
        return str(exc)
    return None


def _start_problem(exc: Exception, args: argparse.Namespace) -> str:
    """Why the host emulator did not start, naming the option it comes from: the TCP port
    (the only socket it binds) or the --can bus (an error raised inside python-can)."""
    import errno  # noqa: PLC0415
    import traceback  # noqa: PLC0415

    text = " ".join(str(exc).split()) or type(exc).__name__
    if isinstance(exc, OSError) and exc.errno in (errno.EADDRINUSE, errno.EACCES):
        return f"--tcp-port {args.tcp_port}: {exc.strerror} (0, the default, takes a free port)"
    if args.can:
        import can  # noqa: PLC0415 (imported by the emulator already)

        where = os.path.dirname(can.__file__)
        frames = traceback.extract_tb(exc.__traceback__)
        if isinstance(exc, can.CanError) or any(f.filename.startswith(where) for f in frames):
            return f"--can {args.can}: cannot open the bus ({text})"
    return text


# The host emulator's values of the options --target soc refuses (default None in the parser).
HOST_EMULATOR_DEFAULTS = {"baud": 921_600, "tcp_port": 0, "interface": "ideal", "engine": "native"}


def emulate_main(args: argparse.Namespace) -> int:
    from cosim.bench.emulate.emulator import Emulator, StopSignals  # noqa: PLC0415

    if args.target == "soc":
        from cosim.bench.emulate.soc.cli import refused_option  # noqa: PLC0415

        flag = refused_option(args)
        if flag is not None:
            print(f"bowden emulate: {flag} is not available with --target soc", file=sys.stderr)
            return 2
    else:
        if args.engine == "native" and args.interface not in (None, "ideal"):
            print(
                f"bowden emulate: --engine native has the ideal interface only: --interface "
                f"{args.interface} runs on the Python engine (leave --engine out)",
                file=sys.stderr,
            )
            return 2
        for dest, value in HOST_EMULATOR_DEFAULTS.items():
            if getattr(args, dest) is None:
                setattr(args, dest, value)
    identity = None
    if args.table_hash is not None:
        try:
            identity = (msgs.PROTOCOL_VERSION, int(args.table_hash, 16) & 0xFFFFFFFF)
        except ValueError:
            print(
                f"bowden emulate: --table-hash {args.table_hash!r}: expected hex digits",
                file=sys.stderr,
            )
            return 2
    if args.tcp_port is not None and not 0 <= args.tcp_port <= 65535:
        print(f"bowden emulate: --tcp-port {args.tcp_port}: outside 0..65535", file=sys.stderr)
        return 2
    if args.flash is not None and (problem := _flash_problem(args.flash, args.target)):
        print(f"bowden emulate: {problem}", file=sys.stderr)
        return 2
    try:
        plant = _plant_assignments(args.plant)
    except ValueError as exc:
        print(f"bowden emulate: {exc}", file=sys.stderr)
        return 2
    try:
        check_geometry(args.position, 1.0, plant)
    except BenchUsageError as exc:
        print(f"bowden emulate: {exc}", file=sys.stderr)
        return 2
    if args.target == "soc":
        from cosim.bench.emulate.soc.cli import emulate_soc  # noqa: PLC0415

        return emulate_soc(args, plant)
    engine = args.engine
    if args.interface != "ideal" and engine == "native":
        engine = "python"
        print(
            f"bowden emulate: --interface {args.interface} runs on the Python engine (the C chain "
            "has the ideal interface only): real time is not guaranteed on a loaded machine; a "
            "late tick sets the device's OVERRUN fault"
        )
    try:
        emu = Emulator(
            pty=not args.no_pty,
            tcp_port=None if args.no_tcp else args.tcp_port,
            can=args.can,
            baud=args.baud,
            chain=ChainConfig(
                position_m=args.position,
                loop_routing=args.loop_routing,
                plant=plant or None,
                interface=args.interface,
            ),
            engine=engine,
            flash_path=args.flash,
            identity=identity,
            findable=True,  # `bowden bench list` and --port auto find its pty
        )
    except Exception as exc:  # noqa: BLE001 (the FMU's, the OS's, python-can's: named below)
        print(f"bowden emulate: {_start_problem(exc, args)}", file=sys.stderr)
        return 1
    # From before the start until the emulator has stopped, SIGINT and SIGTERM are noted, not
    # raised (StopSignals): one that comes while it starts, runs or stops ends the wait below,
    # and the stop, never cut short, removes the registry file that makes it findable.
    with StopSignals() as signals:
        try:
            print("bowden emulate: controller running (firmware + FPGA loop model + plant FMU)")
            for kind, url in emu.urls.items():
                print(
                    f"  {kind:<7} bowden bench {'--can' if kind == 'can' else '--port'} {url} info"
                )
            if plant:  # as the FMU holds them (read back)
                held = " ".join(f"{k}={emu.chain.plant.get(k):g}" for k in plant)
                print(f"  plant FMU parameters set: {held}")
            print(f"  serial links throttled to {args.baud} baud; Ctrl-C stops", flush=True)
            emu.start()
            t0 = time.monotonic()
            next_garbage = t0 + (args.garbage_every or math.inf)
            while (
                emu.running
                and signals.signum is None
                and (args.seconds is None or time.monotonic() - t0 < args.seconds)
            ):
                time.sleep(0.05)
                if time.monotonic() >= next_garbage:
                    emu.inject_garbage()
                    next_garbage += args.garbage_every
        finally:
            emu.stop()
    if emu.error is not None:  # the emulated controller is gone: say why, once
        exc = emu.error
        why = f"{exc.strerror}: {exc.filename}" if isinstance(exc, OSError) else str(exc)
        print(
            f"bowden emulate: the emulated controller stopped after {emu.chain.ticks} ticks: "
            f"{' '.join(why.split())}",
            file=sys.stderr,
        )
        return 1
    if signals.signum == signal.SIGINT:
        print(
            f"bowden emulate: interrupted by SIGINT: stopped after {emu.chain.ticks} ticks",
            file=sys.stderr,
        )
        return 128 + signal.SIGINT
    # --seconds, or SIGTERM (its usual end: a service manager's, a script's)
    print(
        f"bowden emulate: stopped after {emu.chain.ticks} ticks; lag behind real time at most "
        f"{emu.max_lag_seen_s * 1e3:.1f} ms, {emu.overruns} overrun(s)"
    )
    return 0
