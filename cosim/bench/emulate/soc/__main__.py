"""python -m cosim.bench.emulate.soc build: build (or reuse) build/soc_sim/libbowden_soc_sim.so."""

import sys

from .build import build


def main(argv: list[str]) -> int:
    if argv != ["build"]:
        print("usage: python -m cosim.bench.emulate.soc build", file=sys.stderr)
        return 2
    try:
        print(f"built {build()}")
    except RuntimeError as exc:
        print(f"soc build: {exc}", file=sys.stderr)
        return 1
    return 0


sys.exit(main(sys.argv[1:]))
