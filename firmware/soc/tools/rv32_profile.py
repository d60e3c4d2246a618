"""Where the firmware's clocks go: a profile of the RV32 image by function (make soc-profile).

    python -m firmware.soc.tools.rv32_profile build/firmware/soc/bowden_fw.elf profile.json

profile.json is written by the simulation (tests/soc/tb_soc_profile.py): for each phase the
firmware marks (the tick, a received frame's handling), the program counter sampled at every
clock of every span of that phase. The table gives, for the median and the worst span of each
phase, the clocks spent in each function of the image (its symbol table: a function's address
and size); a clock whose PC lies in no function is counted under "?".
"""

from __future__ import annotations

import argparse
import bisect
import json
import statistics
import sys
from collections import Counter
from pathlib import Path

from elftools.common.exceptions import ELFError

from firmware.soc.tools.rv32_report import load


class Functions:
    """The image's functions by address: name_at(pc) is the function holding pc, or "?"."""

    def __init__(self, funcs: dict[int, tuple[str, int]]):
        spans = sorted((addr, addr + size, name) for addr, (name, size) in funcs.items() if size)
        self._starts = [s for s, _, _ in spans]
        self._spans = spans

    @classmethod
    def of_elf(cls, elf: Path) -> Functions:
        return cls(load(elf)[2])

    def name_at(self, pc: int) -> str:
        i = bisect.bisect_right(self._starts, pc) - 1
        if i >= 0 and pc < self._spans[i][1]:
            return self._spans[i][2]
        return "?"

    def attribute(self, hist: dict[int, int]) -> Counter:
        """Clocks by function from clocks by PC."""
        out: Counter = Counter()
        for pc, n in hist.items():
            out[self.name_at(pc)] += n
        return out


def spans_of(profile: dict, phase: str) -> list[dict[int, int]]:
    """The spans of one phase, each a histogram {pc: clocks}."""
    return [{int(pc, 16): n for pc, n in span.items()} for span in profile[phase]]


def table(funcs: Functions, spans: list[dict[int, int]], rows: int = 12) -> list[str]:
    """The median and the worst span of a phase, by function, largest first."""
    sizes = [sum(s.values()) for s in spans]
    worst_i = max(range(len(spans)), key=sizes.__getitem__)
    med = statistics.median_low(sizes)
    med_i = sizes.index(med)
    worst, median = funcs.attribute(spans[worst_i]), funcs.attribute(spans[med_i])
    names = sorted(set(worst) | set(median), key=lambda k: -worst[k])
    lines = [
        f"  {len(spans)} spans, median {med} clocks, worst {sizes[worst_i]}",
        f"  {'function':<28}{'median':>8}{'worst':>8}{'of worst':>10}",
    ]
    for name in names[:rows]:
        share = 100 * worst[name] / sizes[worst_i]
        lines.append(f"  {name:<28}{median[name]:>8}{worst[name]:>8}{share:>9.1f}%")
    rest = names[rows:]
    if rest:
        lines.append(
            f"  {f'({len(rest)} more)':<28}{sum(median[k] for k in rest):>8}"
            f"{sum(worst[k] for k in rest):>8}"
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("elf", type=Path)
    ap.add_argument("profile", type=Path, help="the simulation's profile (JSON)")
    args = ap.parse_args(argv)
    for path in (args.elf, args.profile):
        if not path.is_file():
            print(f"rv32_profile: {path}: no such file", file=sys.stderr)
            return 2
    try:
        funcs = Functions.of_elf(args.elf)
    except (ELFError, KeyError) as exc:
        print(f"rv32_profile: {args.elf}: not an RV32 image with symbols ({exc})", file=sys.stderr)
        return 2
    try:
        profile = json.loads(args.profile.read_text())
        tables = {
            phase: table(funcs, spans_of(profile, phase)) for phase in profile if profile[phase]
        }
    except (ValueError, TypeError, AttributeError) as exc:
        print(
            f"rv32_profile: {args.profile}: not a profile of tb_soc_profile.py "
            f'({{phase: [{{"0x<pc>": clocks}}, ...]}}): {exc}',
            file=sys.stderr,
        )
        return 2
    for phase, lines in tables.items():
        print(f"{phase}:")
        print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
