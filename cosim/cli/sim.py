"""`bowden sim SCENARIO`: one closed-loop co-simulation run and its float reference.

The command line only: it parses the arguments and calls cosim.engines.experiment (or, for the
antagonistic joint `antagonist`, cosim.engines.antagonist).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from cosim.config.antagonist import ANTAGONIST
from cosim.config.run import COMPENSATORS, load_params
from cosim.config.scenarios import SCENARIO_NAMES, get_scenario
from cosim.engines.experiment import (
    BUSES,
    ENGINES,
    SIMULATORS,
    check_duration,
    check_engine,
    check_reach,
    run,
    summary_table,
)
from cosim.parts.interface import INTERFACES
from cosim.project.cliargs import output_dir, unwritable
from cosim.project.paths import require_project


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "sim",
        help="closed-loop co-simulation of RTL + firmware + plant FMU (a paper experiment)",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument(
        "scenario",
        choices=(*SCENARIO_NAMES, ANTAGONIST),
        help="the experiment to run (antagonist: two cables on one joint, every compensator)",
    )
    p.add_argument(
        "--compensator",
        choices=COMPENSATORS,
        default=None,
        help="friction compensator (default: none for characterize/positions, paper for fig14, "
        "preview for tune and the held-out scenarios)",
    )
    p.add_argument(
        "--no-loop-routing",
        dest="loop_routing",
        action="store_false",
        help="route the sheath without the loop (phi follows the end-effector)",
    )
    p.add_argument(
        "--interface",
        choices=INTERFACES,
        default="board",
        help="plant <-> core: the board's ADC and PWM -> ESCON (default), its ADC only, or ideal",
    )
    p.add_argument("--simulator", choices=SIMULATORS, default="verilator")
    p.add_argument(
        "--bus",
        choices=BUSES,
        default="lean",
        help="AXI4-Lite driver: the lean one (default) or cocotbext-axi's AxiLiteMaster (same "
        "results at every sample, about 1.4x the run time)",
    )
    p.add_argument(
        "--engine",
        choices=ENGINES,
        default=None,
        help="cocotb harness (default) or the compiled loop (same results, 20x+ real time); "
        "antagonist runs on the native engine only",
    )
    p.add_argument("--params", default=None, help="JSON file of parameter overrides")
    p.add_argument("--duration", type=float, default=None, help="simulated seconds (default: all)")
    p.add_argument("--out", required=True, type=output_dir, help="output folder")
    p.add_argument("--no-reference", action="store_true", help="skip the float reference")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=main)


def check_out(out: Path) -> None:
    """An --out that cannot be a folder is said before the run, not after it."""
    problem = unwritable(Path(out), folder=True)
    if problem:
        raise ValueError(f"--out: {problem}")


def main(args: argparse.Namespace) -> int:
    if args.scenario == ANTAGONIST:
        return _antagonist(args)
    args.engine = args.engine or "cocotb"
    try:
        cfg = load_params(args.params)
        check_duration(args.duration, cfg)
        check_reach(get_scenario(args.scenario), cfg, args.duration)
        check_engine(args.engine, args.simulator)
        check_out(args.out)
        require_project()
    except (ValueError, FileNotFoundError) as exc:
        print(f"bowden sim: {exc}", file=sys.stderr)
        return 2
    try:
        result = run(
            scenario=args.scenario,
            compensator=args.compensator,
            loop_routing=args.loop_routing,
            interface=args.interface,
            simulator=args.simulator,
            bus=args.bus,
            engine=args.engine,
            cfg=cfg,
            duration_s=args.duration,
            out_dir=Path(args.out),
            reference=not args.no_reference,
            progress=not args.quiet,
        )
    except (RuntimeError, ValueError, OSError) as exc:
        print(f"bowden sim: {exc}", file=sys.stderr)
        return 1
    print(summary_table([result]))
    print(f"wrote {Path(args.out) / 'result.json'}")
    return 0


def _antagonist(args: argparse.Namespace) -> int:
    """`bowden sim antagonist`: the pair on the native engine (its Verilated two-channel
    tension_loop_mc, both cables' firmware and FMUs, the joint), every compensator row or the one
    --compensator names; with every row also the load-cell faults on cable 1 (pair.FAULT_ROWS)."""
    from cosim.config.antagonist import get_antagonist  # noqa: PLC0415
    from cosim.engines import antagonist as pair  # noqa: PLC0415

    try:
        if args.engine not in (None, "native"):
            raise ValueError("antagonist runs on the native engine only")
        if args.compensator == "none":
            raise ValueError("antagonist: --compensator must be paper, smooth or preview")
        if not args.loop_routing:
            raise ValueError("antagonist: each cable's routing is the scenario's")
        cfg = load_params(args.params)
        check_duration(args.duration, cfg)
        scen = get_antagonist()
        for i in range(2):
            check_reach(scen.cable_scenario(i), scen.cable_config(cfg, i), args.duration)
        check_out(args.out)
        require_project()
    except (ValueError, FileNotFoundError) as exc:
        print(f"bowden sim: {exc}", file=sys.stderr)
        return 2
    if args.compensator is None:
        rows = pair.ROWS
    else:
        rows = ((args.compensator, bool(cfg.compensator.est_enable)),)
    try:
        result = {
            "scenario": ANTAGONIST,
            "engine": "native",
            "rows": pair.run_rows(
                scen, cfg, rows, args.duration, args.interface, progress=not args.quiet
            ),
        }
        if args.compensator is None:  # the whole table: also a load-cell fault on cable 1
            result["faults"] = pair.run_fault_rows(scen, cfg, interface=args.interface)
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        tmp = out / f".result.json.{os.getpid()}"
        tmp.write_text(json.dumps(result, indent=2, allow_nan=False) + "\n")
        os.replace(tmp, out / "result.json")
    except (RuntimeError, ValueError, OSError) as exc:
        print(f"bowden sim: {exc}", file=sys.stderr)
        return 1
    print(pair.table(result["rows"]))
    if "faults" in result:
        print()
        print(pair.FAULT_CAPTION)
        print(pair.fault_table(result["faults"], cfg.sample_rate_hz))
    print(f"wrote {Path(args.out) / 'result.json'}")
    return 0
