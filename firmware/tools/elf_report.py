"""Symbol and size report of the firmware's Cortex-M4 objects, with a libm/soft-float check.

A small reader of ELF32 little-endian relocatable objects and of `ar` archives (standard library
only, so the check needs neither binutils for ARM nor LLVM tools):

    python -m firmware.tools.elf_report LIB.a [--sizes SIZES.o] [--out size.txt]

prints (and writes to --out) the size of each object's code (.text), read-only data, data and bss
and the largest functions, then fails (exit 1) if any object has an undefined reference to a libm
function or to a soft-float helper (__aeabi_f*, __aeabi_d*, and the libgcc names __*sf*/__*df*).
The library is built for a Cortex-M4 without FPU features, so any float or double operation in
the code would appear as such a helper: the check proves that the target code has no floating
point, and no libm.

--sizes names an object whose `const uint32_t` symbols are sizeof() values compiled for the target
(firmware/tools/target_sizes.c); they are read from its data and reported as RAM per instance.
"""

from __future__ import annotations

import argparse
import re
import struct
import sys
from dataclasses import dataclass, field
from pathlib import Path

SHT_NOBITS = 8
SHF_WRITE = 0x1
SHF_ALLOC = 0x2
SHF_EXECINSTR = 0x4
STT_FUNC = 2

LIBM = {
    "exp", "expf", "log", "logf", "pow", "powf", "sqrt", "sqrtf", "sin", "sinf", "cos", "cosf",
    "tan", "atan", "atan2", "floor", "ceil", "round", "lround", "llround", "fabs", "fabsf",
    "fmin", "fmax", "fmod", "ldexp", "frexp", "exp2", "log2", "log10", "tanh", "sinh", "cosh",
}  # fmt: skip
# __aeabi_f*/__aeabi_d* (RTABI float/double helpers), the integer-to-float conversions, and
# the libgcc/compiler-rt names (__addsf3, __muldf3, __fixdfsi, __floatsisf, ...).
SOFT_FLOAT = re.compile(r"^(__aeabi_[fd]|__aeabi_u?[il]2[fd]$|__[a-z]*(sf|df))")


@dataclass
class Symbol:
    name: str
    value: int
    size: int
    kind: int
    defined: bool
    section: int


@dataclass
class ElfObject:
    name: str
    data: bytes
    sections: list[tuple[str, int, int, int, int]] = field(default_factory=list)
    symbols: list[Symbol] = field(default_factory=list)

    def sizes(self) -> dict[str, int]:
        """Bytes of code, read-only data, initialised data and bss (allocated sections only)."""
        out = {"text": 0, "rodata": 0, "data": 0, "bss": 0}
        for _name, stype, flags, _off, size in self.sections:
            if not flags & SHF_ALLOC:
                continue
            if stype == SHT_NOBITS:
                out["bss"] += size
            elif flags & SHF_EXECINSTR:
                out["text"] += size
            elif flags & SHF_WRITE:
                out["data"] += size
            else:
                out["rodata"] += size
        return out

    def read_u32(self, sym: Symbol) -> int:
        _name, _stype, _flags, off, _size = self.sections[sym.section]
        return struct.unpack_from("<I", self.data, off + sym.value)[0]


def parse_elf(name: str, data: bytes) -> ElfObject:
    """Sections and symbols of an ELF32 little-endian object."""
    if data[:4] != b"\x7fELF" or data[4] != 1 or data[5] != 1:
        raise ValueError(f"{name}: not an ELF32 little-endian object")
    (shoff,) = struct.unpack_from("<I", data, 0x20)
    shentsize, shnum, shstrndx = struct.unpack_from("<HHH", data, 0x2E)
    raw = [struct.unpack_from("<IIIIIIIIII", data, shoff + i * shentsize) for i in range(shnum)]
    shstr_off = raw[shstrndx][4]

    def cstr(off: int) -> str:
        return data[off : data.index(b"\0", off)].decode()

    obj = ElfObject(name, data)
    for sh in raw:
        obj.sections.append((cstr(shstr_off + sh[0]), sh[1], sh[2], sh[4], sh[5]))
    for sh in raw:
        if sh[1] != 2:  # SHT_SYMTAB
            continue
        strtab_off = raw[sh[6]][4]
        for i in range(sh[5] // 16):
            st_name, value, size, info, _other, shndx = struct.unpack_from(
                "<IIIBBH", data, sh[4] + i * 16
            )
            if st_name == 0:
                continue
            obj.symbols.append(
                Symbol(cstr(strtab_off + st_name), value, size, info & 0xF, shndx != 0, shndx)
            )
    return obj


def read_objects(path: Path) -> list[ElfObject]:
    """The ELF objects of an `ar` archive, or the single object at `path`."""
    data = path.read_bytes()
    if not data.startswith(b"!<arch>\n"):
        return [parse_elf(path.name, data)]
    objs = []
    pos = 8
    names = b""
    while pos + 60 <= len(data):
        header = data[pos : pos + 60]
        ident = header[:16].decode().strip()
        size = int(header[48:58].decode().strip())
        body = data[pos + 60 : pos + 60 + size]
        if ident == "//":
            names = body
        elif ident not in ("/", "/SYM64/"):
            if ident.startswith("/") and ident[1:].isdigit():
                start = int(ident[1:])
                ident = names[start : names.index(b"\n", start)].decode()
            objs.append(parse_elf(ident.rstrip("/"), body))
        pos += 60 + size + (size & 1)
    return objs


def forbidden(objs: list[ElfObject]) -> list[tuple[str, str]]:
    """(object, symbol) for every undefined reference to libm or to a soft-float helper."""
    bad = []
    for obj in objs:
        for sym in obj.symbols:
            if not sym.defined and (sym.name in LIBM or SOFT_FLOAT.match(sym.name)):
                bad.append((obj.name, sym.name))
    return bad


def report(lib: Path, sizes_obj: Path | None) -> tuple[str, list[tuple[str, str]]]:
    objs = read_objects(lib)
    lines = [f"Cortex-M4 size report of {lib.name} (bytes)", ""]
    lines.append(f"{'object':<12} {'text':>7} {'rodata':>7} {'data':>7} {'bss':>7}")
    total = {"text": 0, "rodata": 0, "data": 0, "bss": 0}
    for obj in objs:
        s = obj.sizes()
        for k in total:
            total[k] += s[k]
        lines.append(f"{obj.name:<12} {s['text']:>7} {s['rodata']:>7} {s['data']:>7} {s['bss']:>7}")
    lines.append(
        f"{'total':<12} {total['text']:>7} {total['rodata']:>7} {total['data']:>7} "
        f"{total['bss']:>7}"
    )
    funcs = sorted(
        (s for o in objs for s in o.symbols if s.defined and s.kind == STT_FUNC),
        key=lambda s: -s.size,
    )
    lines += ["", "functions (code bytes):"]
    lines += [f"  {s.name:<28} {s.size:>6}" for s in funcs]
    if sizes_obj is not None:
        sobj = read_objects(sizes_obj)[0]
        lines += ["", "RAM per instance (sizeof on the target):"]
        for sym in sobj.symbols:
            if sym.defined and sym.name.startswith("sizeof_"):
                lines.append(f"  {sym.name[len('sizeof_') :]:<28} {sobj.read_u32(sym):>6}")
    defined = {s.name for o in objs for s in o.symbols if s.defined}
    external = sorted({s.name for o in objs for s in o.symbols if not s.defined} - defined)
    lines += ["", "external references: " + (", ".join(external) if external else "none")]
    bad = forbidden(objs)
    lines.append(
        "libm / soft-float references: "
        + (", ".join(f"{o}:{s}" for o, s in bad) if bad else "none (no floating point, no libm)")
    )
    return "\n".join(lines) + "\n", bad


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("lib", type=Path)
    ap.add_argument("--sizes", type=Path, default=None)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    text, bad = report(args.lib, args.sizes)
    if args.out is not None:
        args.out.write_text(text)
    print(text, end="")
    if bad:
        print(f"error: {len(bad)} libm or soft-float references", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
