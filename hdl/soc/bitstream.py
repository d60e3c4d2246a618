#!/usr/bin/env python3
"""Bitstreams of bowden_soc for both boards (make bitstream): yosys, nextpnr, icepack / ecppack.

    python -m hdl.soc.bitstream [--all | BOARD ...] [--force] [--bench] [--fit [--channels N]]

Writes build/bitstream/<board>/: the bitstream (ice40-up5k: bowden.bin; ecp5-25f: bowden.bit,
the firmware image inside it), summary.json (LUTs, flip-flops, DSPs, block and single-port RAMs,
Fmax, the target clock, the clock the top runs at and Fmax's margin above it, every seed's Fmax,
the cables, the image size) and, for the UP5K, the netlist as
Verilog (netlist.v) for the gate-level simulation and the flash image to program beside the
bitstream. Exits non-zero when timing is not met or a tool fails. Placement tries the seeds of
hdl/synth/synth.py in order and stops at the first that meets the target, as `make synth`
does. A board whose inputs (sources, constraints, this script, for the ECP5 the image) are
unchanged since its last run is not built again. --bench prints the figures beside the
previous run's. --fit stops after nextpnr's packer: the logic cells against the device's, in
seconds (make test checks the UP5K so; its place and route take minutes); with --channels, for
that many cables rather than the board table's count.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

import pythondata_cpu_picorv32

from hdl.boards import table
from hdl.synth import synth
from hdl.synth.synth import place, pnr_command, run, tool, yosys

ROOT = Path(__file__).resolve().parents[2]

HDL = ROOT / "hdl"
SOC = HDL / "soc"
BUILD = ROOT / "build" / "bitstream"
FW = ROOT / "build" / "firmware" / "soc"
PICORV32 = Path(pythondata_cpu_picorv32.data_location) / "picorv32.v"
CPU = "picorv32 RV32I + Zmmul (DSP multiplier, no divider, no C, no interrupt, no traps)"


def image_dir(channels: int) -> Path:
    """The firmware image of `channels` cables (mk/soc.mk: the one-cable image in FW, the others
    in FW/chN, each holding as many cables as its RAM allows; firmware/soc/main.c)."""
    return FW if channels == 1 else FW / f"ch{channels}"


@dataclass(frozen=True)
class Board(synth.Target):
    """The SoC's top of a board: where its image lives and how many cables it drives."""

    image_in_bitstream: bool = True
    channels: int = 1  # cables (the top's CHANNELS, set by synthesize())
    clock_mhz: float = 0.0  # the clock the top runs at (its CLK_HZ); target_mhz may be above it


# Where each board's firmware image lives: in the ECP5's bitstream (block RAM it initialises), or
# for the UP5K in SPRAM, booted from the flash (firmware/soc/boot.S).
IMAGE_IN_BITSTREAM = {"ecp5-25f": True, "ice40-up5k": False}


def board_of(b: table.Board) -> Board:
    """The SoC's top of board `b` (its `soc` design)."""
    return Board(
        **synth.Target.fields(b, b.soc),
        image_in_bitstream=IMAGE_IN_BITSTREAM[b.name],
        channels=b.soc.channels,
        clock_mhz=b.soc.runs_mhz,
    )


# In the order `--all` builds them.
BOARDS = {name: board_of(table.BOARDS[name]) for name in ("ecp5-25f", "ice40-up5k")}


def cell_use(log: Path) -> tuple[int, int] | None:
    """(used, available) packed logic cells from a nextpnr log: iCE40 LCs (a LUT4, its carry and
    its flip-flop; a flip-flop or a carry without its own LUT takes a cell too, so this, not the
    LUT4 count, is what must fit the device) or ECP5 TRELLIS_COMB (LUT4 halves of slices)."""
    if not log.exists():
        return None
    for line in log.read_text().splitlines():
        if "ICESTORM_LC:" in line or "TRELLIS_COMB:" in line:
            used, avail = line.split(":")[-1].split("/")
            return int(used), int(avail.split()[0])
    return None


def logic_cells(out: Path) -> int | None:
    use = cell_use(out / "nextpnr.log")
    return use[0] if use else None


def failure(name: str, exc: SystemExit, out: Path) -> str:
    """One line for a board whose build failed: the cells over the device when that was why."""
    use = cell_use(out / "nextpnr.log")
    if use is not None and use[0] > use[1]:
        return (
            f"{name}: does not fit: {use[0]} of {use[1]} logic cells "
            f"({100 * use[0] / use[1]:.1f} %; log {out / 'nextpnr.log'})"
        )
    return f"{name}: {str(exc).splitlines()[0]}"


def sources(board: Board) -> list[Path]:
    rtl = [p for p in sorted((HDL / "rtl").glob("*.v")) if p.stem != "bowden_system"]
    return [PICORV32, *rtl, *sorted(SOC.glob("*.v")), SOC / "boards" / f"{board.top}.v"]


def input_hash(board: Board) -> str:
    h = hashlib.sha256()
    extra = [image_dir(board.channels) / "bowden_fw.hex" if board.image_in_bitstream
             else FW / "boot.hex"]  # fmt: skip
    for path in [*sources(board), board.constraints, Path(__file__), Path(table.__file__), *extra]:
        h.update(path.name.encode())
        h.update(path.read_bytes())
    h.update(f"CHANNELS={board.channels}".encode())  # --channels changes the design, not a file
    return h.hexdigest()[:16]


def synthesize(board: Board, out: Path) -> float:
    """yosys alone for `board` into out/: netlist.json (for nextpnr) and, for the iCE40,
    netlist.v (the gate-level simulation's). Returns the seconds yosys took."""
    out.mkdir(parents=True, exist_ok=True)
    before = f"chparam -set CHANNELS {board.channels} {board.top}; "
    after = ""
    if board.image_in_bitstream:
        shutil.copyfile(image_dir(board.channels) / "bowden_fw.hex", out / "bowden_fw.hex")
        before += f'chparam -set ROM_INIT "bowden_fw.hex" {board.top}; '
    else:  # the boot loader, in a block RAM the bitstream initialises
        shutil.copyfile(FW / "boot.hex", out / "boot.hex")
        before += f'chparam -set BOOT_INIT "boot.hex" {board.top}; '
    if board.family == "ice40":
        after = "write_verilog -noattr netlist.v; "  # the gate-level simulation's netlist
    return yosys(out, sources(board), board.top, board.family, "netlist.json", before, after)


def netlist(board: Board, out: Path) -> Path:
    """out/netlist.v of `board`, synthesized again only when its inputs changed (the gate-level
    simulation's netlist: no place and route; out/netlist.json beside it)."""
    stamp = out / "netlist.hash"
    key = input_hash(board)
    made = (out / "netlist.json").exists() and (
        board.family != "ice40" or (out / "netlist.v").exists()
    )
    if not made or not stamp.exists() or stamp.read_text() != key:
        synthesize(board, out)
        tmp = stamp.with_suffix(".tmp")
        tmp.write_text(key)
        tmp.replace(stamp)
    return out / "netlist.v"


def fit(board: Board, out: Path) -> tuple[int, int]:
    """(used, available) logic cells of `board` from its synthesis (netlist(), cached) and
    nextpnr's packer alone: whether the design still fits the device, in seconds where place and
    route take minutes (make test's check of the UP5K; SystemExit when a tool fails)."""
    netlist(board, out)
    log = out / "pack-only.log"
    cmd = pnr_command(board.family, board.nextpnr_args, "netlist.json", board.constraints, out)
    run([*cmd, "--pack-only"], log)
    use = cell_use(log)
    if use is None:
        raise SystemExit(f"{board.name}: no logic-cell count in {log}")
    return use


def stage_flash_image(board: Board, out: Path, summary: dict, fw: Path | None = None) -> dict:
    """For a board that boots its firmware from the flash: the image to program beside the
    bitstream, copied from the firmware build on every run (the bitstream does not depend on
    the image, so it is not rebuilt when only the firmware changed), and its size in the
    summary. Returns the summary."""
    if board.image_in_bitstream:
        return summary
    fw = image_dir(board.channels) if fw is None else fw
    shutil.copyfile(fw / "bowden_fw_flash.bin", out / "bowden_fw_flash.bin")
    image = (fw / "bowden_fw.bin").stat().st_size
    if summary.get("image_bytes") != image:
        summary = {**summary, "image_bytes": image}
        synth.write_json(out / "summary.json", summary)
    return summary


def build(board: Board) -> dict:
    """hdl/synth/synth.py's synthesis and placement steps, then the packer, for `board`."""
    out = BUILD / board.name
    yosys_s = synthesize(board, out)
    packed = "bowden.asc" if board.family == "ice40" else "bowden.config"
    pnr = place(
        out, board.family, board.nextpnr_args, "netlist.json", board.constraints,
        board.target_mhz, ("--asc" if board.family == "ice40" else "--textcfg", packed),
    )  # fmt: skip
    if board.family == "ice40":
        run([tool("yowasp-icepack"), packed, "bowden.bin"], out / "pack.log")
        bitstream = out / "bowden.bin"
    else:
        run([tool("yowasp-ecppack"), packed, "bowden.bit"], out / "pack.log")
        bitstream = out / "bowden.bit"
    use = synth.cell_use(out, board.family)
    summary = synth.summary_of(board, use, pnr, yosys_s, input_hash(board))
    summary.update(
        channels=board.channels,
        clock_mhz=board.clock_mhz,
        clock_margin=round(pnr["fmax_mhz"] / board.clock_mhz - 1, 4),
        cpu=CPU,
        logic_cells=logic_cells(out),
        sprams=use["cells"].get("SB_SPRAM256KA", 0),
        image_bytes=(image_dir(board.channels) / "bowden_fw.bin").stat().st_size,
        image_in_bitstream=board.image_in_bitstream,
        bitstream=bitstream.name,
        bitstream_bytes=bitstream.stat().st_size,
    )
    synth.save_summary(out, summary)
    return summary


def check_fit(names: list[str], channels: int | None = None) -> int:
    """--fit: each board's logic cells against its device; 1 when one does not fit. `channels`
    (--channels) sizes the design for that many cables instead of the board table's count."""
    status = 0
    for name in names:
        board = BOARDS[name]
        out = BUILD / name / "fit"
        if channels is not None and channels != board.channels:
            board = dataclasses.replace(board, channels=channels)
            out = BUILD / name / f"fit-{channels}ch"
        out.mkdir(parents=True, exist_ok=True)
        try:
            used, avail = fit(board, out)
        except SystemExit as exc:
            print(f"bitstream: FAILED: {name}: {str(exc).splitlines()[0]}", file=sys.stderr)
            status = 1
            continue
        verdict = "fits" if used <= avail else "does not fit"
        print(
            f"{name}: {verdict}: {used} of {avail} logic cells ({100 * used / avail:.1f} %), "
            f"{board.channels} cable{'s' if board.channels > 1 else ''}"
        )
        status |= used > avail
    return status


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("boards", nargs="*", help=f"any of {', '.join(BOARDS)}")
    ap.add_argument("--all", action="store_true")
    ap.add_argument("--force", action="store_true")
    ap.add_argument("--bench", action="store_true")
    ap.add_argument(
        "--fit",
        action="store_true",
        help="synthesis and nextpnr's packer only (build/bitstream/<board>/fit/): the logic cells "
        "used, whether the board fits; no bitstream",
    )
    ap.add_argument(
        "--channels",
        type=int,
        choices=(1, 2, 4),
        help="with --fit: the cables to size the design for, instead of the board table's "
        "(build/bitstream/<board>/fit-<n>ch/; at most the pins the board's top has)",
    )
    args = ap.parse_args(argv)
    if args.channels is not None and not args.fit:
        ap.error("--channels goes with --fit (a bitstream is built for the board table's count)")
    names = list(BOARDS) if args.all or not args.boards else args.boards
    for name in names:
        if name not in BOARDS:
            ap.error(f"board {name!r} unknown; allowed: {', '.join(BOARDS)}")
    for name in names:
        hexfile = image_dir(BOARDS[name].channels) / "bowden_fw.hex"
        if not hexfile.exists():
            print(
                f"bitstream: {hexfile.relative_to(ROOT)} missing: make firmware-soc",
                file=sys.stderr,
            )
            return 2
    if args.fit:
        return check_fit(names, args.channels)
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
                failed.append(failure(name, exc, BUILD / name))
                continue
        summary = stage_flash_image(board, BUILD / name, summary)
        prev = BUILD / name / "summary.prev.json"
        line = (
            f"{name}: {summary['luts']} LUTs ({100 * summary['lut_fraction']:.1f} %), "
            f"{summary['ffs']} FFs, {summary['dsps']} DSPs, {summary['brams']} BRAMs, "
            f"{summary['sprams']} SPRAMs, Fmax {summary['fmax_mhz']} MHz "
            f"(target {summary['target_mhz']}, runs at {summary['clock_mhz']}, "
            f"seed {summary['seed']}), {summary['channels']} cable"
            f"{'s' if summary['channels'] > 1 else ''}"
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
    try:
        sys.exit(main())
    except KeyboardInterrupt:  # the tools stop with it; a summary is only ever replaced whole
        print("bitstream: interrupted; the boards' earlier summaries are kept", file=sys.stderr)
        sys.exit(130)
