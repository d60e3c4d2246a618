"""`bowden workspace --out DIR`: the bending angle over the workspace (paper Fig. 8).

Evaluates the sheath's bending angle phi (cosim.parts.geometry, the twin of the FMU's C geometry)
on a grid of the half-sphere workspace |C| <= L, y >= 0 (Eq. 13), without and with loop routing,
draws each as a 3-D map coloured by the bending-angle error of Eq. 14,
error = (phi - phi_ref) / (2*pi) * 100 % with phi_ref = 0 without and 2*pi with the loop,
and prints the spread of phi for each: standard deviation, 5-95 % range, min .. max, and the
mean absolute error.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cosim.parts.geometry import bending_angle, hemisphere_grid
from cosim.project.cliargs import output_dir

# The plant FMU's range of sheath_length (fmu/gen_model.py; a test holds the two equal): beyond
# it the maps would describe a sheath the plant refuses, and squares of lengths far beyond it
# overflow.
LENGTH_RANGE_M = (0.01, 10.0)
GRID_RANGE = (5, 201)


@dataclass(frozen=True)
class Spread:
    """How much phi varies over the workspace for one routing."""

    routing: str
    points: int
    std_rad: float
    p5_p95_rad: float
    min_rad: float
    max_rad: float
    mean_abs_error_pct: float  # Eq. 14, against phi_ref


def spread(phi: np.ndarray, routing: str, phi_ref: float) -> Spread:
    """Spread statistics of the bending angles phi (rad) of one routing."""
    return Spread(
        routing=routing,
        points=int(phi.size),
        std_rad=float(np.std(phi)),
        p5_p95_rad=float(np.percentile(phi, 95) - np.percentile(phi, 5)),
        min_rad=float(np.min(phi)),
        max_rad=float(np.max(phi)),
        mean_abs_error_pct=float(np.mean(np.abs(phi - phi_ref)) / (2 * math.pi) * 100),
    )


def draw_map(path: Path, x, y, z, error_pct, title: str) -> None:
    """3-D scatter of the workspace coloured by the bending-angle error (Fig. 8 style)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(7, 5.5))
    ax = fig.add_subplot(projection="3d")
    sc = ax.scatter(x, y, z, c=error_pct, cmap="jet", s=6, vmin=0, vmax=100)
    ax.scatter([0], [0], [0], c="k", marker="s", s=40)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(title)
    fig.colorbar(sc, ax=ax, shrink=0.7, label="bending angle error (Eq. 14) [%]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(out_dir: Path, length_m: float = 1.0, grid: int = 31) -> list[Spread]:
    """Compute both maps, write DIR/workspace_free.png and DIR/workspace_loop.png."""
    out_dir.mkdir(parents=True, exist_ok=True)
    x, y, z = hemisphere_grid(length_m, grid)
    results = []
    for routing, loop, phi_ref in (("free sag", False, 0.0), ("loop routing", True, 2 * math.pi)):
        phi = bending_angle(x, y, z, length_m, loop)
        error_pct = np.abs(phi - phi_ref) / (2 * math.pi) * 100
        name = "workspace_loop.png" if loop else "workspace_free.png"
        draw_map(
            out_dir / name,
            x,
            y,
            z,
            error_pct,
            f"{routing}: bending-angle error, L = {length_m:g} m (Fig. 8 {'b' if loop else 'a'})",
        )
        results.append(spread(phi, routing, phi_ref))
    return results


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
