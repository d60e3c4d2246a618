#!/usr/bin/env python3
"""Synthesis figures of the multi-channel loop tension_loop_mc for N channels, on each board's FPGA.

Synthesizes hdl/synth/tension_loop_mc_synth.v (the loop fed from a configuration shift chain,
outputs folded into 8 pins: the harness stands for the register file the board tops have) with
synth.py's yosys and nextpnr steps and the board's device and seeds, for the single-channel
tension_loop (SNAPSHOT 0) as a baseline and for tension_loop_mc at each N. The I/O pins are
left to nextpnr. Writes build/synth/mc/<board>-<design>/summary.json and prints one line per
design: LUT4s, DSPs, Fmax (the board's first seed, or the first of its first K seeds that
meets the board's target, as synth.py does with all of them).
The flip-flop counts include the harness's configuration chain (N * 292 bits), so they are not
the loop's; the LUT counts include the harness's tick counter and output fold (a few dozen). On the
iCE40 the logic cells nextpnr placed (a LUT4 and its flip-flop each, the chain's included) are
printed too; a design that does not place (more cells than the device) prints "no place" and
nextpnr's error, and the others still run.

Usage: python -m hdl.synth.synth_mc [--boards BOARD ...] [--n N ...]
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import time

from hdl.synth import synth

HARNESS = synth.HDL / "synth" / "tension_loop_mc_synth.v"
OUT = synth.BUILD / "mc"


def designs(ns: list[int]) -> list[tuple[str, str]]:
    """(name, chparam arguments) of the baseline and of tension_loop_mc at each N."""
    return [("single", "-set SINGLE 1 -set N 1")] + [(f"n{n}", f"-set N {n}") for n in ns]


def logic_cells(log) -> int | None:
    """Logic cells nextpnr placed (iCE40: ICESTORM_LC, a LUT4 and its flip-flop; the harness's
    chain included), from its log; None where the log does not say (the ECP5's slices)."""
    m = re.search(r"ICESTORM_LC:\s*(\d+)/", log.read_text()) if log.exists() else None
    return int(m.group(1)) if m else None


def run_one(board: synth.Board, name: str, params: str, seeds: tuple[int, ...]) -> dict:
    """Synthesize and place one design for `board`; return its summary (also on disk)."""
    out = OUT / f"{board.name}-{name}"
    out.mkdir(parents=True, exist_ok=True)
    netlist = "tension_loop_mc_synth.json"
    sources = [*synth.sources(board)[:-1], HARNESS]  # the RTL, not the board's top
    before = f"chparam {params} tension_loop_mc_synth; "
    yosys_s = synth.yosys(out, sources, "tension_loop_mc_synth", board.family, netlist, before)
    pcf = out / ("empty.pcf" if board.family == "ice40" else "empty.lpf")
    pcf.write_text("")  # no pin constraints: nextpnr places the 11 pins
    free = "--lpf-allow-unconstrained" if board.family == "ecp5" else "--pcf-allow-unconstrained"
    args = (*board.nextpnr_args, free)
    try:
        pnr = synth.place(out, board.family, args, netlist, pcf, board.target_mhz, seeds=seeds)
    except SystemExit as err:  # nextpnr failed: a design larger than the device does not place
        lines = str(err).splitlines()
        error = next((ln for ln in lines if ln.startswith("ERROR")), lines[0])
        pnr = {"fmax_mhz": None, "seed": None, "fmax_by_seed_mhz": {}, "nextpnr_s": None,
               "error": error}  # fmt: skip
    use = synth.cell_use(out, board.family)
    summary = {
        "board": board.name,
        "design": name,
        "luts": use["luts"],
        "lut_capacity": board.lut_capacity,
        "logic_cells": logic_cells(out / "nextpnr.log"),
        "ffs_with_harness": use["ffs"],
        "dsps": use["dsps"],
        "fmax_mhz": pnr["fmax_mhz"],
        "target_mhz": board.target_mhz,
        "seed": pnr["seed"],
        "fmax_by_seed_mhz": pnr["fmax_by_seed_mhz"],
        "yosys_s": round(yosys_s, 1),
        "nextpnr_s": pnr["nextpnr_s"],
    }
    if "error" in pnr:
        summary["nextpnr_error"] = pnr["error"]
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--boards", nargs="+", default=sorted(synth.BOARDS), metavar="BOARD")
    ap.add_argument("--n", nargs="+", type=int, default=[1, 2, 4], metavar="N")
    ap.add_argument(
        "--seeds", type=int, default=1, metavar="K", help="try the board's first K seeds (1)"
    )
    args = ap.parse_args(argv)
    unknown = [b for b in args.boards if b not in synth.BOARDS]
    if unknown:
        print(f"board {unknown[0]}: expected one of {', '.join(synth.BOARDS)}", file=sys.stderr)
        return 2
    if any(n < 1 for n in args.n):
        print(f"--n {args.n}: expected channel counts >= 1", file=sys.stderr)
        return 2
    t0 = time.monotonic()
    print(f"{'board':<12} {'design':<8} {'LUT4':>6} {'of':>6} {'LCs':>5} {'DSPs':>4} "
          f"{'Fmax MHz':>9} {'target':>6} {'seed':>4}")  # fmt: skip
    for b in args.boards:
        for name, params in designs(args.n):
            board = synth.BOARDS[b]
            s = run_one(board, name, params, board.seeds[: max(1, args.seeds)])
            lcs = "-" if s["logic_cells"] is None else s["logic_cells"]
            fmax = "no place" if s["fmax_mhz"] is None else f"{s['fmax_mhz']:.2f}"
            seed = "-" if s["seed"] is None else s["seed"]
            print(f"{b:<12} {name:<8} {s['luts']:>6} {s['lut_capacity']:>6} {lcs:>5} "
                  f"{s['dsps']:>4} {fmax:>9} {s['target_mhz']:>6.0f} {seed:>4}")  # fmt: skip
            if "nextpnr_error" in s:
                print(f"  nextpnr: {s['nextpnr_error']}")
    print(f"synth_mc: {time.monotonic() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
