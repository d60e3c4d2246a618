"""`bowden emulate --target soc`: the simulated board (cosim.bench.emulate.soc.harness) behind a
pty.

Prints the pty as the host emulator does and is findable as it is (`bowden bench list`, `--port
auto`: cosim.bench.link.discover's registry), runs until Ctrl-C, SIGTERM or --seconds of wall time
(signals noted, as the host emulator's, by cosim.bench.emulate.emulator.StopSignals): the board's
run ends, the flash file is written, the registry file removed; Ctrl-C's line is the only one
printed (exit 130), SIGTERM and --seconds print the run's figures (exit 0). --channels N runs
the SoC built for N cables (1, 2 or 4: bowden_soc's CHANNELS, the firmware image of as many),
each cable with its own plant FMU; a count it is not built for is refused in one line (exit 2).
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from pathlib import Path

# What the host emulator offers that the simulated board has not (a TCP port, a CAN bus, the
# host emulator's own link and engine options): named in one line, exit 2. The flags first, then
# the options whose presence counts (default None), whatever their value: the board's UART runs
# at its own 921600 baud (soc_uart.v's bit time, fixed in the RTL), its pins are the interface
# and Verilator the engine.
HOST_ONLY = {
    "no_pty": "--no-pty",
    "can": "--can",
    "table_hash": "--table-hash",
    "garbage_every": "--garbage-every",
}
HOST_ONLY_GIVEN = {
    "baud": "--baud",
    "tcp_port": "--tcp-port",
    "interface": "--interface",
    "engine": "--engine",
}


def refused_option(args: argparse.Namespace) -> str | None:
    """The first host-emulator option given with --target soc, or None."""
    for dest, flag in HOST_ONLY.items():
        if getattr(args, dest, None):
            return flag
    for dest, flag in HOST_ONLY_GIVEN.items():
        if getattr(args, dest, None) is not None:
            return flag
    return None


def emulate_soc(args: argparse.Namespace, plant: dict) -> int:
    """`args` as `bowden emulate` parsed them; `plant` its --plant overrides, checked (with the
    position) by cosim.bench.emulate.command."""
    flag = refused_option(args)
    if flag is not None:
        print(f"bowden emulate: {flag} is not available with --target soc", file=sys.stderr)
        return 2
    from cosim.bench.emulate.emulator import StopSignals  # noqa: PLC0415
    from cosim.bench.emulate.host_device import ChainConfig  # noqa: PLC0415
    from cosim.bench.emulate.host_device import _open_plant as open_plant  # noqa: PLC0415
    from cosim.config.run import BoardParams  # noqa: PLC0415

    from .build import CHANNELS  # noqa: PLC0415
    from .harness import SocBoard, check_flash_file  # noqa: PLC0415

    channels = 1 if args.channels is None else args.channels
    if channels not in CHANNELS:
        print(
            f"bowden emulate: --channels {channels}: the simulated SoC is built for "
            f"{', '.join(map(str, CHANNELS[:-1]))} or {CHANNELS[-1]} cables",
            file=sys.stderr,
        )
        return 2

    flash = Path(args.flash) if args.flash else None
    if flash is not None:
        try:
            check_flash_file(flash)
        except ValueError as exc:
            print(f"bowden emulate: {exc}", file=sys.stderr)
            return 2
    chain = ChainConfig(
        position_m=args.position, loop_routing=args.loop_routing, plant=plant or None
    )
    try:
        fmus = [open_plant(chain) for _ in range(channels)]  # a plant of its own a cable
        board = SocBoard(
            flash_path=flash,
            plant=fmus,
            escon_imax_a=BoardParams().escon_imax_a,
            findable=True,  # `bowden bench list` and --port auto find its pty
            channels=channels,
        )
    except ValueError as exc:
        print(f"bowden emulate: {exc}", file=sys.stderr)
        return 2
    except (OSError, RuntimeError) as exc:
        print(f"bowden emulate: {exc}", file=sys.stderr)
        return 1
    # As the host emulator's (cosim.bench.emulate.command.emulate_main): signals noted from
    # before the start until the board has stopped, so that none cuts the start or the stop (and
    # the removal of the registry file) short.
    with StopSignals() as signals:
        try:
            adc = {1: "ADS131M02", 2: "ADS131M04", 4: "ADS131M08"}[channels]
            cables = (
                "; the plant FMU" if channels == 1 else f"; {channels} cables, a plant FMU each"
            )
            print(
                "bowden emulate: simulated board running (bowden_soc executing the RV32 firmware "
                f"in Verilator; {adc}, ESCON and SPI flash at pin level{cables})"
            )
            print(f"  pty     bowden bench --port {board.pty_name} info")
            if flash is not None:
                print(f"  flash   {flash}")
            print("  Ctrl-C stops", flush=True)
            board.start()
            t0 = time.monotonic()
            while (
                board.running
                and signals.signum is None
                and (args.seconds is None or time.monotonic() - t0 < args.seconds)
            ):
                time.sleep(0.05)
        finally:
            stats = board.stop()
    if board.status:
        print(f"bowden emulate: the simulated board stopped: {board.error}", file=sys.stderr)
        return 1
    if signals.signum == signal.SIGINT:
        print(
            f"bowden emulate: interrupted by SIGINT: stopped after {stats.sim_s:.3f} s of "
            "simulated time",
            file=sys.stderr,
        )
        return 128 + signal.SIGINT
    print(  # --seconds, or SIGTERM (its usual end)
        f"bowden emulate: stopped after {stats.sim_s:.3f} s of simulated time "
        f"({stats.speed:.2f}x real time), {stats.ticks} firmware ticks"
    )
    return 0
