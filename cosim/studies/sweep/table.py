"""The sweep's table (Parquet, pyarrow) and its plots: the error over the workspace (the paper's
Fig. 8 / 13 as maps), and the error against each numeric axis (median and worst case)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .atomic import replacing

# Columns first in the table, when present; the rest follow in name order.
LEAD = ("point_id", "status", "compensator", "loop_routing", "x_m", "y_m", "z_m")


def write_table(rows: list[dict], path: Path) -> None:
    """One row per point, written atomically."""
    import pyarrow as pa  # noqa: PLC0415
    import pyarrow.parquet as pq  # noqa: PLC0415

    names = sorted({k for r in rows for k in r})
    order = [c for c in LEAD if c in names] + [c for c in names if c not in LEAD]
    cols = {c: [r.get(c) for r in rows] for c in order}
    table = pa.table(cols)
    with replacing(path) as tmp:  # a name of this process's own: two sweeps never share it
        pq.write_table(table, tmp)


def read_table(path: Path) -> list[dict]:
    import pyarrow.parquet as pq  # noqa: PLC0415

    return pq.read_table(path).to_pylist()


def _groups(rows: list[dict]) -> dict[str, list[dict]]:
    """Rows by compensator, loop routing and, when swept, the online friction estimate (the
    curves of a plot)."""
    out: dict[str, list[dict]] = {}
    for r in rows:
        label = f"{r.get('compensator', '-')}"
        if "loop_routing" in r:
            label += ", loop" if r["loop_routing"] else ", no loop"
        if "compensator.est_enable" in r:
            label += ", estimate" if r["compensator.est_enable"] else ", calibrated"
        out.setdefault(label, []).append(r)
    return dict(sorted(out.items()))


def numeric_axes(rows: list[dict], axes: list[str]) -> list[str]:
    """The axes whose values are numbers and take more than one value."""
    out = []
    for a in axes:
        vals = {r.get(a) for r in rows}
        if len(vals) > 1 and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals
        ):
            out.append(a)
    return out


def plot_sweep(rows: list[dict], axes: list[str], out_dir: Path, metric="rms_error_pct") -> list:
    """Write error_map.png (when the sweep has positions) and error_vs_<axis>.png per numeric
    axis; return the paths written."""
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    ok = [r for r in rows if r.get("status") == "ok" and r.get(metric) is not None]
    written = []
    if not ok:
        return written
    groups = _groups(ok)
    label = {"rms_error_pct": "RMS error (% of max T_ref)"}.get(metric, metric)
    if "position_m" in axes:
        n = len(groups)
        fig, axs = plt.subplots(1, n, figsize=(4.2 * n, 3.8), squeeze=False, sharey=True)
        vmax = max(r[metric] for r in ok)
        for ax, (name, rs) in zip(axs[0], groups.items(), strict=True):
            # The error at each (y, z) of the loop's plane; points out of it (x != 0) and the
            # plant's variations at one position are summarised by their worst case.
            cells: dict[tuple[float, float], float] = {}
            for r in rs:
                key = (round(r["y_m"], 4), round(r["z_m"], 4))
                cells[key] = max(cells.get(key, 0.0), r[metric])
            ys = np.array([k[0] for k in cells])
            zs = np.array([k[1] for k in cells])
            vs = np.array(list(cells.values()))
            sc = ax.scatter(ys, zs, c=vs, s=260, marker="s", cmap="viridis", vmin=0, vmax=vmax)
            for y, z, v in zip(ys, zs, vs, strict=True):
                ax.annotate(f"{v:.1f}", (y, z), ha="center", va="center", fontsize=7, color="w")
            ax.set_title(name, fontsize=9)
            ax.margins(0.2)
            ax.set_xlabel("end-effector y (m)")
        axs[0][0].set_ylabel("end-effector z (m)")
        fig.colorbar(sc, ax=axs[0].tolist(), label=f"worst {label}")
        fig.suptitle("tracking error over the workspace (worst case per position)", fontsize=10)
        path = out_dir / "error_map.png"
        _save(fig, path)
        plt.close(fig)
        written.append(path)
    for a in numeric_axes(ok, axes):
        fig, ax = plt.subplots(figsize=(5.5, 3.6))
        for name, rs in groups.items():
            xs = sorted({r[a] for r in rs})
            med = [float(np.median([r[metric] for r in rs if r[a] == x])) for x in xs]
            worst = [max(r[metric] for r in rs if r[a] == x) for x in xs]
            (line,) = ax.plot(xs, med, "o-", label=f"{name} (median)")
            ax.plot(xs, worst, "^--", color=line.get_color(), label=f"{name} (worst)")
        ax.set_xlabel(a)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        path = out_dir / f"error_vs_{a.replace('.', '_')}.png"
        _save(fig, path)
        plt.close(fig)
        written.append(path)
    return written


def _save(fig, path: Path) -> None:
    """Write a figure as PNG atomically (a failed write keeps the plot already there)."""
    with replacing(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")


def summary(rows: list[dict], metric: str = "rms_error_pct") -> str:
    """Median and worst case of the metric (and of the peak error) per group, as a text table."""
    head = f"{'group':<32}{'points':>7}{'failed':>7}{'median %':>10}{'worst %':>9}"
    lines = [head + f"{'peak med %':>12}{'peak worst %':>14}"]
    for name, rs in _groups(rows).items():
        fail = sum(r.get("status") != "ok" for r in rs)
        cells = []
        for key in (metric, "peak_error_pct"):
            vals = [r[key] for r in rs if r.get("status") == "ok" and r.get(key) is not None]
            cells.append(f"{np.median(vals):.2f}" if vals else "-")
            cells.append(f"{max(vals):.2f}" if vals else "-")
        lines.append(
            f"{name:<32}{len(rs):>7}{fail:>7}{cells[0]:>10}{cells[1]:>9}{cells[2]:>12}{cells[3]:>14}"
        )
    return "\n".join(lines)
