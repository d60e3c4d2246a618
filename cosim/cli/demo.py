"""`bowden demo` (what `make demo` runs): the paper's Fig. 14 experiment in closed-loop
co-simulation, four ways, on the board's chain and on the ideal interface, next to the paper's
figures; then the held-out scenarios that the tuning never saw, and the antagonistic joint.

The command line only: it parses the arguments and calls cosim.studies.demo.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from cosim.config.scenarios import HELD_OUT_DURATION_S
from cosim.parts.interface import INTERFACES
from cosim.project.cliargs import output_dir
from cosim.project.paths import BUILD_DIR, require_project
from cosim.studies.demo import DEMO_RUNS, held_out, held_out_table, table_from_files


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "demo",
        help="the paper's Fig. 14 in co-simulation: paper/smooth with loop routing, paper without",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument("--out", type=output_dir, default=BUILD_DIR / "demo", help="output folder")
    p.add_argument("--duration", type=float, default=None, help="simulated seconds per fig14 run")
    p.add_argument(
        "--interface",
        choices=INTERFACES,
        default="board",
        help="plant <-> core for the main runs (default board); ideal runs are added beside",
    )
    p.add_argument("--simulator", choices=("verilator", "icarus"), default="verilator")
    p.add_argument(
        "--engine",
        choices=("cocotb", "native"),
        default="cocotb",
        help="fig14 runs on the cocotb harness (default) or compiled (same bits, much faster)",
    )
    p.add_argument(
        "--bus",
        choices=("cocotbext-axi", "lean"),
        default="lean",
        help="AXI4-Lite driver of the testbench: lean (default) or cocotbext-axi (same results)",
    )
    p.add_argument(
        "--held-out-duration",
        type=float,
        default=HELD_OUT_DURATION_S,
        help=f"simulated seconds per held-out run (default {HELD_OUT_DURATION_S:g})",
    )
    p.add_argument(
        "--no-held-out", action="store_true", help="only the fig14 runs (skip the held-out table)"
    )
    p.add_argument(
        "--no-antagonist",
        action="store_true",
        help="skip the antagonistic joint's tables (bowden sim antagonist: about 6 s of CPU)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from cosim.config.run import SimConfig  # noqa: PLC0415
    from cosim.engines import experiment as sim  # noqa: PLC0415

    try:
        sim.check_duration(args.duration, SimConfig())
        sim.check_duration(args.held_out_duration, SimConfig(), "--held-out-duration")
        require_project()
    except ValueError as exc:
        print(f"bowden demo: {exc}", file=sys.stderr)
        return 2
    out = Path(args.out)
    paths = []
    interfaces = [args.interface] + (["ideal"] if args.interface != "ideal" else [])
    runs = [
        (folder if iface == args.interface else f"{folder}_{iface}", comp, loop, iface)
        for iface in interfaces
        for folder, comp, loop in DEMO_RUNS
    ]
    for folder, compensator, loop_routing, interface in runs:
        print(
            f"== fig14, compensator {compensator}, loop routing {'on' if loop_routing else 'off'}"
            f", interface {interface}",
            file=sys.stderr,
        )
        try:
            sim.run(
                scenario="fig14",
                compensator=compensator,
                loop_routing=loop_routing,
                interface=interface,
                simulator=args.simulator,
                bus=args.bus,
                engine=args.engine,
                duration_s=args.duration,
                out_dir=out / folder,
                progress=not args.quiet,
            )
        except (RuntimeError, ValueError, OSError) as exc:
            print(f"bowden demo: {folder}: {exc}", file=sys.stderr)
            return 1
        paths.append(out / folder / "result.json")
    print(table_from_files(paths))
    if not args.no_held_out:
        rows = held_out(args.interface, args.held_out_duration, quiet=args.quiet)
        out.mkdir(parents=True, exist_ok=True)
        (out / "held_out.json").write_text(json.dumps(rows, indent=1) + "\n")
        print()
        print(held_out_table(rows, args.interface))
        print(f"results: {out / 'held_out.json'}")
    if not args.no_antagonist:
        from cosim.config.antagonist import get_antagonist  # noqa: PLC0415
        from cosim.engines import antagonist as pair  # noqa: PLC0415

        print("== antagonist: two cables on one joint, every compensator", file=sys.stderr)
        try:
            rows = pair.run_rows(get_antagonist(), SimConfig(), interface=args.interface)
            faults = pair.run_fault_rows(get_antagonist(), SimConfig(), interface=args.interface)
        except (RuntimeError, ValueError, OSError) as exc:
            print(f"bowden demo: antagonist: {exc}", file=sys.stderr)
            return 1
        out.mkdir(parents=True, exist_ok=True)
        (out / "antagonist.json").write_text(json.dumps(rows, indent=1) + "\n")
        (out / "antagonist_faults.json").write_text(json.dumps(faults, indent=1) + "\n")
        print()
        print(
            "Antagonistic joint (bowden sim antagonist, native engine, "
            f"{args.interface}): torque error tau_ref - r (T_out,1 - T_out,2) in % of max "
            "|tau_ref|; least true tensions, floor T_pre = 2 N"
        )
        print(pair.table(rows))
        print()
        print(pair.FAULT_CAPTION)
        print(pair.fault_table(faults))
        print(f"results: {out / 'antagonist.json'}, {out / 'antagonist_faults.json'}")
    return 0
