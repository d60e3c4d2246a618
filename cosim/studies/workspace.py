"""`bowden workspace --out DIR`: the bending angle over the workspace (paper Fig. 8).

Evaluates the sheath's bending angle phi (cosim.parts.geometry, the twin of the FMU's C geometry)
on a grid of the half-sphere workspace |C| <= L, y >= 0 (Eq. 13), without and with loop routing,
draws each as a 3-D map coloured by the bending-angle error of Eq. 14,
error = (phi - phi_ref) / (2*pi) * 100 % with phi_ref = 0 without and 2*pi with the loop,
and prints the spread of phi for each: standard deviation, 5-95 % range, min .. max, and the
mean absolute error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cosim.parts.geometry import bending_angle, hemisphere_grid

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
