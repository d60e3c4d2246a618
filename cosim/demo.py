"""`bowden demo` (what `make demo` runs): the paper's Fig. 14 experiment in closed-loop
co-simulation, three ways, on the board's chain and on the ideal interface, next to the paper's
figures.

Runs `fig14` (30 s, RTL on Verilator + firmware + plant FMU, and the float reference) for the
compensator `paper` and `smooth` with loop routing, and `paper` without loop routing, through the
interface stage `--interface` (default `board`: the board's ADC and PWM -> ESCON, cosim.interface)
and, unless that is already `ideal`, again through the ideal interface, so that the cost of the
real one shows side by side. Each run is written under build/demo/<name>/ (result.json,
trace.csv, plots; `_ideal` for the ideal interface), then the comparison table is printed from
the result.json files just written, so the figures it shows are the ones on disk.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .cliargs import output_dir
from .interface import INTERFACES
from .paths import BUILD_DIR, require_project

# (folder, compensator, loop routing)
DEMO_RUNS = (
    ("fig14_paper_loop", "paper", True),
    ("fig14_smooth_loop", "smooth", True),
    ("fig14_paper_noloop", "paper", False),
)


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "demo",
        help="the paper's Fig. 14 in co-simulation: paper/smooth with loop routing, paper without",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument("--out", type=output_dir, default=BUILD_DIR / "demo", help="output folder")
    p.add_argument("--duration", type=float, default=None, help="simulated seconds per run")
    p.add_argument(
        "--interface",
        choices=INTERFACES,
        default="board",
        help="plant <-> core for the main runs (default board); ideal runs are added beside",
    )
    p.add_argument("--simulator", choices=("verilator", "icarus"), default="verilator")
    p.add_argument(
        "--bus",
        choices=("cocotbext-axi", "lean"),
        default="cocotbext-axi",
        help="AXI4-Lite driver of the testbench (same results; lean is faster)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from . import sim  # noqa: PLC0415
    from .scenarios import SimConfig  # noqa: PLC0415

    try:
        sim.check_duration(args.duration, SimConfig())
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
                duration_s=args.duration,
                out_dir=out / folder,
                progress=not args.quiet,
            )
        except (RuntimeError, ValueError, OSError) as exc:
            print(f"bowden demo: {folder}: {exc}", file=sys.stderr)
            return 1
        paths.append(out / folder / "result.json")
    print(table_from_files(paths))
    return 0


def table_from_files(paths: list[Path]) -> str:
    """The comparison table, read back from the result.json files (what is printed is on disk)."""
    from .sim import summary_table  # noqa: PLC0415

    results = [json.loads(Path(p).read_text()) for p in paths]
    lines = [
        "Open-loop output tension control, paper Fig. 14 (error T_ref - T_out in % of max T_ref)",
        summary_table(results, paper=True),
        "",
        "results: " + ", ".join(str(p) for p in paths),
    ]
    return "\n".join(lines)
