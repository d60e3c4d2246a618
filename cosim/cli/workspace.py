"""`bowden workspace --out DIR`: the bending angle over the workspace (paper Fig. 8).

The command line only: it parses the arguments and calls cosim.studies.workspace.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from cosim.project.cliargs import output_dir
from cosim.studies.workspace import GRID_RANGE, LENGTH_RANGE_M, run


def main(args: argparse.Namespace) -> int:
    lo, hi = LENGTH_RANGE_M
    if not (math.isfinite(args.length) and lo <= args.length <= hi):
        print(
            f"bowden workspace: --length must be in [{lo:g}, {hi:g}] m; got {args.length!r}",
            file=sys.stderr,
        )
        return 2
    if not GRID_RANGE[0] <= args.grid <= GRID_RANGE[1]:
        print(
            f"bowden workspace: --grid must be in [{GRID_RANGE[0]}, {GRID_RANGE[1]}]; "
            f"got {args.grid}",
            file=sys.stderr,
        )
        return 2
    out = Path(args.out)
    results = run(out, args.length, args.grid)
    print(f"bending angle phi over the half-sphere workspace, L = {args.length:g} m")
    print(
        f"{'routing':<14}{'points':>8}{'std [rad]':>11}{'P5-P95':>9}"
        f"{'min':>8}{'max':>8}{'mean |err| %':>14}"
    )
    for s in results:
        print(
            f"{s.routing:<14}{s.points:>8}{s.std_rad:>11.3f}{s.p5_p95_rad:>9.3f}"
            f"{s.min_rad:>8.3f}{s.max_rad:>8.3f}{s.mean_abs_error_pct:>14.1f}"
        )
    print(f"wrote {out / 'workspace_free.png'} and {out / 'workspace_loop.png'}")
    return 0


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "workspace",
        help="bending angle over the workspace with and without loop routing (paper Fig. 8)",
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument(
        "--out", required=True, type=output_dir, help="output folder for the two PNG maps"
    )
    p.add_argument("--length", type=float, default=1.0, help="sheath length L in m (default 1)")
    p.add_argument("--grid", type=int, default=31, help="grid points along x (default 31)")
    p.set_defaults(func=main)
