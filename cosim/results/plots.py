"""Plots of a run (matplotlib, Agg backend: no display needed).

- ``tracking.png``: as the paper's Fig. 14, reference, input and output tension, and the error
  T_ref - T_out, for the fixed-point co-simulation and the float reference.
- ``fixed_vs_float.png``: the sample-by-sample differences of current command (LSB) and T_out.
- ``capstan.png``: T_out against T_in (paper Fig. 11 and 13), one colour per position.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402 (backend first)
import numpy as np  # noqa: E402

from .metrics import CURRENT_LSB_A  # noqa: E402

# Plot at most this many points per curve (a 30 s run at 10 kHz has 300 000).
MAX_POINTS = 20_000


def _thin(*arrays: np.ndarray) -> list[np.ndarray]:
    n = len(arrays[0])
    step = max(1, n // MAX_POINTS)
    return [np.asarray(a)[::step] for a in arrays]


def plot_tracking(path: Path, fixed: dict, ref: dict | None, title: str) -> Path:
    """Fig. 14 style: tensions (top) and error T_ref - T_out (bottom); fixed solid, float dashed.

    `fixed` and `ref` hold arrays t_s, T_ref_N, T_c_N, T_in_N, T_out_N (trace columns).
    """
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True, height_ratios=[2, 1])
    t, tr, tc, ti, to = _thin(
        fixed["t_s"], fixed["T_ref_N"], fixed["T_c_N"], fixed["T_in_N"], fixed["T_out_N"]
    )
    ax1.plot(t, tr, color="k", lw=1.2, label="T_ref")
    ax1.plot(t, tc, color="tab:gray", lw=0.7, alpha=0.8, label="T_c (compensator)")
    ax1.plot(t, ti, color="tab:blue", lw=0.8, label="T_in (fixed point)")
    ax1.plot(t, to, color="tab:red", lw=0.9, label="T_out (fixed point)")
    ax2.plot(t, tr - to, color="tab:red", lw=0.8, label="fixed point")
    if ref is not None:
        rt, rr, ro = _thin(ref["t_s"], ref["T_ref_N"], ref["T_out_N"])
        ax1.plot(rt, ro, color="tab:orange", lw=0.8, ls="--", label="T_out (float reference)")
        ax2.plot(rt, rr - ro, color="tab:orange", lw=0.8, ls="--", label="float reference")
    ax1.set_ylabel("tension [N]")
    ax1.set_title(title)
    ax1.grid(alpha=0.3)
    ax1.legend(loc="upper right", fontsize=8, ncol=2)
    ax2.axhline(0.0, color="k", lw=0.5)
    ax2.set_ylabel("T_ref - T_out [N]")
    ax2.set_xlabel("time [s]")
    ax2.grid(alpha=0.3)
    ax2.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_fixed_vs_float(path: Path, fixed: dict, ref: dict, title: str) -> Path:
    """Differences fixed - float: current command in LSB (top), T_out in N (bottom)."""
    n = min(len(fixed["t_s"]), len(ref["t_s"]))
    du = (np.asarray(fixed["current_A"][:n]) - np.asarray(ref["current_A"][:n])) / CURRENT_LSB_A
    dt = np.asarray(fixed["T_out_N"][:n]) - np.asarray(ref["T_out_N"][:n])
    t, du, dt = _thin(np.asarray(fixed["t_s"][:n]), du, dt)
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 5), sharex=True)
    ax1.plot(t, du, lw=0.6)
    ax1.set_ylabel("current: fixed - float [LSB]")
    ax1.set_title(title)
    ax1.grid(alpha=0.3)
    ax2.plot(t, dt, lw=0.6, color="tab:red")
    ax2.set_ylabel("T_out: fixed - float [N]")
    ax2.set_xlabel("time [s]")
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_capstan(path: Path, t_in_n, t_out_n, segments: list[tuple[str, slice]], title: str):
    """T_out against T_in, one colour per segment (label, slice of samples)."""
    fig, ax = plt.subplots(figsize=(6.5, 5.5))
    for label, sl in segments:
        x, y = _thin(np.asarray(t_in_n)[sl], np.asarray(t_out_n)[sl])
        ax.plot(x, y, lw=0.8, label=label)
    top = float(np.max(t_in_n)) if len(t_in_n) else 1.0
    ax.plot([0, top], [0, top], color="k", lw=0.5, ls=":", label="T_out = T_in")
    ax.set_xlabel("input tension T_in [N]")
    ax.set_ylabel("output tension T_out [N]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
