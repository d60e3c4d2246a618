"""Size and worst-case stack of the RV32 firmware image (make firmware-soc).

    python -m firmware.soc.tools.rv32_report build/firmware/soc/bowden_fw.elf [--out size.txt]
        [--stack-max BYTES] [--isr-frame BYTES]

Sizes: code and read-only data (the image in ROM), .data, .bss (RAM), from the ELF's sections.

Worst-case stack: a static bound from the machine code (capstone disassembles each function):
every function's frame is what its prologue subtracts from sp; the call graph has its direct
calls (jal, and auipc + jalr pairs) and, for each indirect call (jalr through a register), an
edge to every function whose address the image takes (a lui/addi pair or a data word holding a
function's entry), so a call through the HAL's or the flash's function pointers is covered. The
bound is the deepest path from `_start` plus the interrupt handler's frame (an interrupt can
arrive anywhere). A recursive cycle makes the bound infinite: the report then fails. Tail calls
(a jump to another function) are counted as calls, which can only over-estimate.

Exit 1 when the image has a soft-float or libm symbol (the same names as elf_report.py's check),
when the stack bound exceeds --stack-max, or on recursion.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import capstone
from elftools.elf.elffile import ELFFile

from firmware.tools.elf_report import LIBM, SOFT_FLOAT

# RISC-V relocation types that call, jump, branch or only pair another relocation (RISC-V ELF
# psABI, "Relocations"): BRANCH 16, JAL 17, CALL 18, CALL_PLT 19, PCREL_LO12_I/S 24/25, ALIGN 43,
# RVC_BRANCH 44, RVC_JUMP 45, RELAX 51.
NOT_ADDRESS_RELOCS = {16, 17, 18, 19, 24, 25, 43, 44, 45, 51}


def load(path: Path):
    with path.open("rb") as fh:
        elf = ELFFile(fh)
        secs = {s.name: s for s in elf.iter_sections()}
        text = secs[".text"]
        code = text.data()
        base = text["sh_addr"]
        funcs = {}
        names = set()
        for sym in secs[".symtab"].iter_symbols():
            names.add(sym.name)
            if sym["st_info"]["type"] == "STT_FUNC" and sym["st_size"] > 0:
                funcs[sym["st_value"]] = (sym.name, sym["st_size"])
            elif sym.name in ("_start", "irq_entry", "reset") and sym["st_shndx"] != "SHN_UNDEF":
                funcs.setdefault(sym["st_value"], (sym.name, 0))
        sizes = {
            name: s["sh_size"] for name, s in secs.items() if name in (".text", ".data", ".bss")
        }
        # Words of the data (initialised .data and the read-only objects, which link.ld puts in
        # .text) that may hold function pointers: the objects' own bytes, not the code's.
        data_words = set()
        objects = [
            (sym["st_value"], sym["st_size"])
            for sym in secs[".symtab"].iter_symbols()
            if sym["st_info"]["type"] == "STT_OBJECT" and sym["st_size"] >= 4
        ]
        blobs = [(base, code)]
        if ".data" in secs and secs[".data"]["sh_type"] != "SHT_NOBITS":
            blobs.append((secs[".data"]["sh_addr"], secs[".data"].data()))
        for addr, size in objects:
            for start, blob in blobs:
                off = addr - start
                if 0 <= off < len(blob):
                    d = blob[off : off + size]
                    data_words |= {
                        int.from_bytes(d[i : i + 4], "little") for i in range(0, len(d) - 3, 4)
                    }
        # Linked with --emit-relocs, the image keeps its relocations: a function whose address is
        # materialised (lui/addi, auipc/addi, a data word) rather than called is address-taken.
        taken = None
        symtab = secs[".symtab"]
        for sec in elf.iter_sections():
            if sec["sh_type"] != "SHT_RELA":
                continue
            taken = taken or set()
            for rel in sec.iter_relocations():
                if rel["r_info_type"] in NOT_ADDRESS_RELOCS:
                    continue
                sym = symtab.get_symbol(rel["r_info_sym"])
                taken.add((sym["st_value"] + rel["r_addend"]) & 0xFFFFFFFF)
    exact = taken is not None
    return code, base, funcs, names, sizes, (taken if exact else data_words), exact


def _is_int(s: str) -> bool:
    try:
        int(s, 0)
    except ValueError:
        return False
    return True


def _jalr_operands(op_str: str) -> tuple[str, int]:
    """The base register and offset of a jalr in capstone's forms: `rs1`, `rd, rs1`,
    `rd, rs1, imm`, `imm(rs1)`, `rd, imm(rs1)`."""
    if "(" in op_str:
        head, reg = op_str.rstrip(")").split("(")
        imm = head.split(",")[-1].strip() or "0"
        return reg.strip(), int(imm, 0)
    ops = [o.strip() for o in op_str.split(",")]
    if len(ops) == 3:
        return ops[1], int(ops[2], 0)
    return ops[-1] if len(ops) == 1 else ops[1], 0


def analyse(
    code: bytes,
    base: int,
    funcs: dict[int, tuple[str, int]],
    data_words: set[int],
    exact: bool = False,
):
    md = capstone.Cs(capstone.CS_ARCH_RISCV, capstone.CS_MODE_RISCV32 | capstone.CS_MODE_RISCVC)
    md.detail = False
    starts = sorted(funcs)
    # Extent of each function: its size, or up to the next symbol for the assembly labels.
    extent = {}
    for i, a in enumerate(starts):
        name, size = funcs[a]
        end = a + size if size else (starts[i + 1] if i + 1 < len(starts) else base + len(code))
        extent[a] = end
    frame, direct, indirect, taken = {}, {}, {}, set()
    for a in starts:
        f, calls, ind = 0, set(), False
        last_auipc = {}
        last_lui = {}
        for ins in md.disasm(code[a - base : extent[a] - base], a):
            m, ops = ins.mnemonic, [o.strip() for o in ins.op_str.split(",")]
            if m in ("addi", "c.addi", "c.addi16sp") and ops[0] == "sp" and _is_int(ops[-1]):
                imm = int(ops[-1], 0)
                if imm < 0:
                    f += -imm
            elif m in ("jal", "c.jal", "j", "c.j") and _is_int(ops[-1]):
                # capstone prints the jump's offset, not its target
                t = (ins.address + int(ops[-1], 0)) & 0xFFFFFFFF
                if t in funcs and t != a:
                    calls.add(t)
            elif m in ("jalr", "c.jalr", "c.jr", "jr"):
                reg, off = _jalr_operands(ins.op_str)
                if m in ("c.jr", "jr") and reg == "ra":
                    pass  # return
                elif reg in last_auipc:
                    t = (last_auipc[reg] + off) & 0xFFFFFFFF
                    if t in funcs:
                        calls.add(t)
                else:
                    ind = True
            if m == "auipc":
                last_auipc[ops[0]] = ins.address + (int(ops[1], 0) << 12)
            if m in ("lui", "c.lui"):
                last_lui[ops[0]] = int(ops[1], 0) << 12
            if m in ("addi", "c.addi") and len(ops) == 3 and ops[1] in last_lui:
                v = (last_lui[ops[1]] + int(ops[2], 0)) & 0xFFFFFFFF
                if v in funcs and not exact:
                    taken.add(v)
        frame[a], direct[a], indirect[a] = f, calls, ind
    taken |= {w for w in data_words if w in funcs}
    taken -= {a for a in funcs if funcs[a][0] in ("_start", "reset", "main", "irq_entry")}
    return frame, direct, indirect, taken


def worst_stack(root: int, frame, direct, indirect, taken, funcs):
    memo: dict[int, tuple[int, list[str]]] = {}
    active: set[int] = set()

    def depth(a: int) -> tuple[int, list[str]]:
        if a in memo:
            return memo[a]
        if a in active:
            raise RecursionError(funcs[a][0])
        active.add(a)
        callees = set(direct[a]) | (taken if indirect[a] else set())
        best, path = 0, []
        for c in callees:
            d, p = depth(c)
            if d > best:
                best, path = d, p
        active.discard(a)
        memo[a] = (frame[a] + best, [funcs[a][0]] + path)
        return memo[a]

    return depth(root)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("elf", type=Path)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--stack-max", type=int, default=None, help="fail above this many bytes")
    args = ap.parse_args(argv)
    code, base, funcs, names, sizes, data_words, exact = load(args.elf)
    bad = sorted(n for n in names if n in LIBM or SOFT_FLOAT.match(n))
    by_name = {v[0]: k for k, v in funcs.items()}
    frame, direct, indirect, taken = analyse(code, base, funcs, data_words, exact)
    lines = [
        "image (ROM: code + read-only data + .data init): "
        f"{sizes['.text'] + sizes.get('.data', 0)} bytes",
        f"  .text (code + read-only data) {sizes['.text']}, .data {sizes.get('.data', 0)}, "
        f".bss {sizes.get('.bss', 0)} bytes",
    ]
    status = 0
    try:
        main_d, main_p = worst_stack(by_name["main"], frame, direct, indirect, taken, funcs)
        isr = frame.get(by_name.get("irq_entry", -1), 0)
        stack = main_d + isr
        lines.append(
            f"worst-case stack (static bound): {stack} bytes = main's deepest path {main_d}"
            + (f" + interrupt {isr}" if "irq_entry" in by_name else " (no interrupt)")
        )
        lines.append("  path: " + " -> ".join(main_p))
        if args.stack_max is not None and stack > args.stack_max:
            lines.append(f"FAIL: stack bound {stack} exceeds --stack-max {args.stack_max}")
            status = 1
    except RecursionError as exc:
        lines.append(f"FAIL: recursion through {exc}: no static stack bound")
        status = 1
    lines.append(f"functions {len(funcs)}, address-taken (indirect call targets) {len(taken)}")
    if bad:
        lines.append("FAIL: soft-float or libm symbols in the image: " + ", ".join(bad))
        status = 1
    else:
        lines.append("no soft-float helper and no libm symbol in the image")
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    if args.out:
        args.out.write_text(text)
    return status


if __name__ == "__main__":
    sys.exit(main())
