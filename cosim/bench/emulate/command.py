"""`bowden emulate` (and `python -m cosim.bench emulate`): its options checked, the emulator
started, run until Ctrl-C, SIGTERM or --seconds, and stopped (cosim.bench.emulate.emulator), or
the simulated board (--target soc, cosim.bench.emulate.soc.cli). The command line defines the
options and calls emulate_main; `bowden bench --emulate --plant` reads its plant with
plant_assignments.
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import time
from pathlib import Path

from cosim.bench.emulate.host_device import ChainConfig
from cosim.bench.link import messages as msgs
from cosim.bench.link.client import BenchUsageError
from cosim.bench.link.recorder import check_geometry


def plant_assignments(items: list[str]) -> dict:
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
HOST_EMULATOR_DEFAULTS = {
    "baud": 921_600,
    "tcp_port": 0,
    "interface": "ideal",
    "engine": "native",
    "channels": 1,
}


def emulate_main(args: argparse.Namespace) -> int:
    """`bowden emulate` with the options parsed by cosim/bench/command.py: checked (one line and
    exit 2 for a bad one), then the controller runs until its end; 128 + SIGINT when Ctrl-C ends
    it, 0 for --seconds or SIGTERM, 1 when it could not start or stopped by itself."""
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
        plant = plant_assignments(args.plant)
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
    if args.channels > 1 and (engine == "python" or args.interface != "ideal"):
        print(
            f"bowden emulate: --channels {args.channels} runs on the native engine with the ideal "
            "interface (the Python engine is the one-channel definition)",
            file=sys.stderr,
        )
        return 2
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
            channels=args.channels,
        )
    except Exception as exc:  # noqa: BLE001 (the FMU's, the OS's, python-can's: named below)
        print(f"bowden emulate: {_start_problem(exc, args)}", file=sys.stderr)
        return 1
    # From before the start until the emulator has stopped, SIGINT and SIGTERM are noted, not
    # raised (StopSignals): one that comes while it starts, runs or stops ends the wait below,
    # and the stop, never cut short, removes the registry file that makes it findable.
    with StopSignals() as signals:
        try:
            each = f", {args.channels} channels, each" if args.channels > 1 else ""
            print(
                f"bowden emulate: controller running{each} (firmware + FPGA loop model + plant FMU)"
            )
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
