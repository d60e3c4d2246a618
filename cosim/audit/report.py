"""How an audit result is shown: `audit.json`, a short summary (like statsmodels' summary()),
`report.md` that reads on its own, and the PNG plots it links (matplotlib, Agg backend).

Plots are for a person: labelled axes with units, the residual beside the signal it
follows, the held-out report blocks shaded.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402 (backend first)
import numpy as np  # noqa: E402
from scipy.signal import welch  # noqa: E402

from . import core  # noqa: E402
from .core import FIT, REPORT, SELECT, WARMUP, AuditResult  # noqa: E402
from .free_forms import FreeForm  # noqa: E402

# Scatter plots show at most this many points.
MAX_SCATTER = 4000
# The time plot draws a signal of more samples than this as each bucket's lowest and highest
# sample in their order (_envelope): a 10-inch figure at 100 dpi is 1000 pixels wide, so 4000
# buckets keep every spike and the band's edges; the 20-minute record's 1.2 million samples a
# line took half the plots' time (6.7 s of CPU for the six plots, 3.3 s with the buckets).
MAX_LINE_BUCKETS = 4000


def _num(x: float | None, digits: int = 6) -> float | None:
    """A JSON-safe number: None for NaN or infinity (audit.json is strict JSON)."""
    if x is None or not math.isfinite(float(x)):
        return None
    return float(f"{float(x):.{digits}g}")


def _params(p: dict[str, float]) -> dict[str, float | None]:
    return {k: _num(v, 8) for k, v in sorted(p.items())}


def _scored(result: AuditResult) -> np.ndarray:
    return result.data.roles != WARMUP


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x * x))) if len(x) else 0.0


def to_dict(result: AuditResult) -> dict:
    """The content of audit.json."""
    d = result.data
    scored = _scored(result)
    base_res = d.t_out_n - result.fmu_baseline
    ext_res = d.t_out_n - result.fmu_extended
    phi, phi_note = core.phi_text(d, result.baseline.params["mu"])
    findings = []
    for f in result.findings:
        findings.append(
            {
                "cause": f.effect.cause,
                "form": f.effect.form or None,
                "forms_selection_explains_pct": {k: _num(v, 4) for k, v in f.forms.items()},
                "params": {
                    n: _num(f.value if n == f.effect.fmu_param else result.extended.params[n], 8)
                    for n in f.effect.fmu_params
                },
                "unit": f.effect.unit,
                "explains_pct": _num(f.explains_pct, 4),
                "evidence": f.evidence,
                "selection_explains_pct": _num(f.selection_pct, 4),
                "block_t": _num(f.t, 4),
                "improved_share": _num(f.improved_share, 4),
                "runner_up": f.runner_up,
                "separation_block_t": _num(f.separation_t, 4),
                "ambiguous_with": f.ambiguous_with,
                "equation": f.effect.equation,
            }
        )
    rounds = []
    for i, rnd in enumerate(result.rounds):
        rounds.append(
            {
                "round": i + 1,
                "chosen": rnd.chosen.effect.cause if rnd.chosen else None,
                "candidates": [
                    {
                        "cause": c.effect.cause,
                        "form": c.effect.form or None,
                        "params": {n: _num(c.model.params[n]) for n in c.effect.fmu_params},
                        "selection_explains_pct": _num(c.explained_pct, 4),
                        "block_t": _num(c.t, 4),
                        "improved_share": _num(c.stats.improved_share, 4),
                        "worst_block_z": _num(c.stats.worst_z, 4),
                        "significant": c.significant,
                        "at_bound": c.at_bound,
                    }
                    for c in sorted(rnd.candidates, key=lambda c: -c.explained_pct)
                ],
            }
        )
    unexpl = {k: (_num(v) if isinstance(v, float) else v) for k, v in result.unexplained.items()}
    out = {
        "source": d.source,
        "samples": len(d.t_s),
        "duration_s": _num(d.t_s[-1] - d.t_s[0]),
        "sample_rate_hz": _num(d.rate_hz),
        "decimation": d.decimation,
        "data": {
            "positions": d.has_positions,
            "sheath_length_m": d.inputs.sheath_length_m,
            "loop_routing": d.inputs.loop_routing,
            "mu_given": d.mu_given,
            "mu_from_compensator": d.mu_from_compensator,
            "sidecar_defaults": list(d.defaulted),
            "noise_floor_n": _num(d.noise_floor_n),
            "input_noise_n": _num(d.input_noise_n),
            "input_smoothing_s": core.SMOOTH_S,
            "input_kept_as_measured_s": _num(d.input_kept / d.rate_hz),
        },
        "split": {
            "text": d.split_text(),
            "block_s": _num(d.block_s),
            "block_note": d.block_note,
            "warmup_s": core.WARMUP_S,
            "fit_s": _num(np.sum(d.roles == FIT) / d.rate_hz),
            "selection_s": _num(np.sum(d.roles == SELECT) / d.rate_hz),
            "report_s": _num(np.sum(d.roles == REPORT) / d.rate_hz),
            "report_blocks_s": [[_num(a), _num(b)] for a, b in d.blocks(REPORT)],
        },
        "rule": {
            "text": result.rule.text(),
            "min_explained_pct": result.rule.min_explained_pct,
            "min_effect_rms_n": result.rule.min_effect_rms_n,
            "min_effect_noise_ratio": result.rule.min_effect_noise_ratio,
            "min_effect_rms_here_n": _num(
                result.rule.min_rms_n(d.noise_floor_n, d.input_noise_n, d.sampling_error_n)
            ),
            "min_block_t": result.rule.min_block_t,
            "min_improved_share": result.rule.min_improved_share,
            "separation_block_t": result.rule.separation_t,
        },
        "baseline": {
            "params": _params(result.baseline.params),
            "rms_n": _num(_rms(base_res[scored])),
            "holdout_rms_n": _num(result.holdout_rms_before_n),
            "phi_rad": _num(phi),
            "phi": phi_note,
            "source": "plant FMU, drive mode 1, driven by the measured T_in and positions",
        },
        "findings": findings,
        "free_forms": [f.to_dict() for f in result.free_forms],
        "rounds": rounds,
        "not_tried": result.rounds[0].skipped if result.rounds else {},
        "extended": {
            "params": _params(result.extended.params),
            "rms_n": _num(_rms(ext_res[scored])),
            "holdout_rms_n": _num(result.holdout_rms_after_n),
            "twin_rms_n": _num(_rms((d.t_out_n - result.extended.prediction)[scored])),
            "twin_fmu_max_diff_n": _num(result.twin_fmu_max_diff_n),
            "source": "plant FMU, drive mode 1, with the findings' parameters",
        },
        "gain": {
            "holdout_rms_before_n": _num(result.holdout_rms_before_n),
            "holdout_rms_after_n": _num(result.holdout_rms_after_n),
            "gain_pct": _num(result.gain_pct, 4),
            "holdout": "the report blocks (split.report_blocks_s): no fit and no decision saw them",
            "noise_floor_n": _num(d.noise_floor_n),
            "output": "T_out less lines_removed_before_fits" if d.lines else "T_out as measured",
        },
        "lines_removed_before_fits": [
            {
                "freq_hz": _num(ln.freq_hz),
                "amplitude_n": _num(ln.amplitude_n),
                "mains_hz": ln.mains_hz,
            }
            for ln in d.lines
        ],
        "unexplained": unexpl,
        "warnings": list(result.warnings),
        "wall_s": _num(result.wall_s, 4),
    }
    out.update(result.extras)
    return out


def write_json(path: Path, result: AuditResult) -> dict:
    data = to_dict(result)
    path.write_text(json.dumps(data, indent=2, allow_nan=False) + "\n")
    return data


def summary(result: AuditResult) -> str:
    """A short readable summary: data, split, baseline, findings, gain, what is left."""
    d = result.data
    scored = _scored(result)
    base_rms = _rms((d.t_out_n - result.fmu_baseline)[scored])
    ext_rms = _rms((d.t_out_n - result.fmu_extended)[scored])
    mu_src = (
        "mu from the sidecar"
        if d.mu_fixed
        else "mu fitted"
        + ("" if d.has_positions else " (mu*phi)")
        + (" (the sidecar's mu is the compensator's setting)" if d.mu_from_compensator else "")
    )
    lines = [
        f"bowden audit: {d.source}",
        f"  data     {d.t_s[-1] - d.t_s[0]:.1f} s at {d.rate_hz:g} Hz"
        + (f" (decimated by {d.decimation})" if d.decimation > 1 else "")
        + f", {'positions' if d.has_positions else 'no positions'}, "
        f"{'loop routing' if d.inputs.loop_routing else 'no loop'}, "
        f"L = {d.inputs.sheath_length_m:g} m, {mu_src}"
        + (f"; sidecar defaults: {', '.join(d.defaulted)}" if d.defaulted else ""),
        f"  split    {d.split_text()}",
        f"  noise    output sensor {d.noise_floor_n:.4f} N, input sensor {d.input_noise_n:.4f} N"
        f" (white part, from second differences); sampling {d.sampling_error_n:.4f} N",
        f"  baseline nominal FMU, mu = {result.baseline.params['mu']:.5f}: RMS {base_rms:.4f} N, "
        f"held-out {result.holdout_rms_before_n:.4f} N",
        f"  rule     {result.rule.text()}",
    ]
    if result.findings:
        w = max(28, *(len(f.effect.label) + 2 for f in result.findings))
        lines.append(f"  {'finding':<{w}}{'FMU parameter':<32}{'explains':>9}{'block t':>9}")
        for f in result.findings:
            flag = f"  (or {f.ambiguous_with})" if f.ambiguous_with else ""
            lines.append(
                f"  {f.effect.label:<{w}}{f.effect.describe(f.value):<32}"
                f"{f.explains_pct:>8.1f}%{f.t:>9.1f}{flag}"
            )
            lines.append(f"      why: {f.evidence}")
    else:
        lines.append("  findings none: no cause of the vocabulary passes the rule")
    lines += free_form_lines(result)
    # what the last round (against the model with the findings) would have named but for a
    # shape at a bound (decision.Candidate.at_bound): a hint at what is left, not a finding
    for c in result.rounds[-1].candidates if result.rounds else ():
        if c.at_bound and result.rule.passes(c.stats, d):
            lines.append(
                f"  not named {c.effect.label}: removes {c.explained_pct:.1f} % of the "
                f"selection blocks' residual, but {c.at_bound}: not an estimate of that form"
            )
    lines += [
        f"  extended FMU with the findings: RMS {ext_rms:.4f} N, held-out "
        f"{result.holdout_rms_after_n:.4f} N (twin within {result.twin_fmu_max_diff_n:.1e} N)",
        f"  gain     held-out (report blocks) {result.holdout_rms_before_n:.4f} -> "
        f"{result.holdout_rms_after_n:.4f} N: {result.gain_pct:.1f} % of the residual variance; "
        f"noise floor {d.noise_floor_n:.4f} N" + _less_lines(d),
        "  left     " + unexplained_text(result.unexplained),
    ]
    lines += [f"  warning  {w}" for w in result.warnings]
    return "\n".join(lines)


def free_form_lines(result: AuditResult) -> list[str]:
    """Each free form tried (cosim.audit.drift_table, cosim.audit.free_forms): the verdict with
    its figures, then the learned table beside the fixed form's, knot by knot (or term by
    term)."""
    lines = []
    for free in result.free_forms:
        head = f"  free form of {free.fixed.cause}: {free.why}"
        tail = (
            f"      report blocks (twin): form {free.fixed.form or free.fixed.fmu_param} "
            f"{free.report_rms_fixed_n:.4f} N, free form {free.report_rms_free_n:.4f} N "
            "(measured only, never decided on)"
        )
        lines += [head, f"      {free.quantity}:", *(f"      {r}" for r in free.table_text()), tail]
    return lines


def _less_lines(d) -> str:
    """The note that the fits and their figures saw the output less its lines."""
    if not d.lines:
        return ""
    freqs = ", ".join(f"{ln.freq_hz:.2f}" for ln in d.lines)
    return f" (T_out less its line{'s' if len(d.lines) > 1 else ''} at {freqs} Hz)"


def unexplained_text(u: dict) -> str:
    follows = ", ".join(f"{n} (r = {u['correlations'][n]:+.2f})" for n in u["correlates"])
    return (
        f"{u['rms_n']:.4f} N RMS (noise floor {u['noise_floor_n']:.4f} N), "
        f"{'white' if u['white'] else 'not white'} (largest autocorrelation "
        f"{u['max_autocorrelation']:.2f}), spectral peak at {u['peak_hz']:.2f} Hz "
        f"({u['peak_to_median_psd']:.0f}x the median), follows {follows or 'no signal'}; "
        f"sits {'; '.join(u.get('where') or []) or 'nowhere in particular'}; "
        + lines_text(u.get("lines", []))
    )


def lines_text(lines: list[dict]) -> str:
    """The residual's lines (cosim.audit.lines) in words."""
    if not lines:
        return "no line the input does not explain"
    parts = []
    for ln in lines:
        mains = " or ".join(f"{m:g}" for m in ln["mains_hz"])
        parts.append(
            f"{ln['freq_hz']:.2f} Hz of {ln['amplitude_n']:.4f} N amplitude "
            f"({ln['share_pct']:.0f} % of its variance"
            + (f", a multiple of the {mains} Hz mains" if mains else "")
            + (", taken out of the output before the fits" if ln["removed_before_fits"] else "")
            + ")"
        )
    return (
        f"{'a line' if len(lines) == 1 else f'{len(lines)} lines'} the input does not explain, "
        "which no cause of the vocabulary makes: " + "; ".join(parts)
    )


# --- plots -----------------------------------------------------------------------------------


def _shade_report(ax, result: AuditResult) -> None:
    for i, (a, b) in enumerate(result.data.blocks(REPORT)):
        ax.axvspan(
            a, b, color="tab:green", alpha=0.08, lw=0, label="report blocks" if i == 0 else None
        )


def _pick(n: int, mask: np.ndarray) -> np.ndarray:
    idx = np.flatnonzero(mask)
    step = max(1, len(idx) // MAX_SCATTER)
    return idx[::step]


def _envelope(n: int) -> np.ndarray | None:
    """The samples the time plot draws of a signal of n samples: None (all) up to
    2 MAX_LINE_BUCKETS, else the bucket edges for _envelope_of."""
    if n <= 2 * MAX_LINE_BUCKETS:
        return None
    return np.linspace(0, n, MAX_LINE_BUCKETS + 1).astype(np.int64)


def _envelope_of(edges: np.ndarray | None, t: np.ndarray, y: np.ndarray):
    """t and y at each bucket's lowest and highest sample of y, in time order (edges None: t
    and y as they are)."""
    if edges is None:
        return t, y
    lo = np.minimum.reduceat(y, edges[:-1])
    hi = np.maximum.reduceat(y, edges[:-1])
    first = y[edges[:-1]] <= y[edges[1:] - 1]  # a rising bucket: its low comes first
    a = np.where(first, lo, hi)
    b = np.where(first, hi, lo)
    start_t = t[edges[:-1]]
    end_t = t[edges[1:] - 1]
    return np.column_stack([start_t, end_t]).ravel(), np.column_stack([a, b]).ravel()


def plots(out_dir: Path, result: AuditResult) -> list[str]:
    """Write the PNGs; return their file names."""
    d = result.data
    t = d.t_s
    # as measured, lines and all: the spectrum shows what was taken out (unexplained["lines"])
    base_r = d.t_out_meas_n - result.fmu_baseline
    ext_r = d.t_out_meas_n - result.fmu_extended
    held = (d.roles == SELECT) | (d.roles == REPORT)
    names = []

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True, height_ratios=[2, 1.3])
    edges = _envelope(len(t))

    def line(ax, y, **style):
        ax.plot(*_envelope_of(edges, t, y), **style)

    line(ax1, d.t_in_meas_n, color="tab:blue", lw=0.6, label="T_in measured")
    line(ax1, d.t_out_meas_n, color="k", lw=0.6, label="T_out measured")
    line(ax1, result.fmu_baseline, color="tab:orange", lw=0.7, label="T_out nominal model")
    if result.findings:
        line(ax1, result.fmu_extended, color="tab:red", lw=0.7, ls="--", label="T_out extended")
    ax1.set_ylabel("tension [N]")
    ax1.legend(loc="upper right", fontsize=8, ncol=2)
    ax1.grid(alpha=0.3)
    ax1.set_title("measured output tension against the models (FMU, drive mode 1)")
    line(ax2, base_r, color="tab:orange", lw=0.5, label="residual, nominal")
    if result.findings:
        line(ax2, ext_r, color="tab:red", lw=0.5, label="residual, extended")
    _shade_report(ax2, result)
    ax2.set_ylabel("T_out measured - model [N]")
    ax2.set_xlabel("time [s]")
    ax2.legend(loc="upper right", fontsize=8)
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out_dir / "residual_time.png", dpi=100)
    plt.close(fig)
    names.append("residual_time.png")

    idx = _pick(len(t), held)
    scatter = [("T_in_N", d.inputs.t_in_n, "input tension T_in [N]", "residual_vs_tin.png")]
    scatter.append(
        ("dT_in/dt", d.rate_n_s, "input tension rate dT_in/dt [N/s]", "residual_vs_rate.png")
    )
    for _, x, xlabel, fname in scatter:
        fig, ax = plt.subplots(figsize=(7, 4.5))
        colour = d.positions_m[idx, 2] if d.has_positions else None
        # Coloured by z only when positions were recorded: a cmap without values to map makes
        # matplotlib warn that it is ignored, on every audit of a file without positions.
        shade = {"c": colour, "cmap": "viridis"} if colour is not None else {"color": "tab:blue"}
        sc = ax.scatter(x[idx], base_r[idx], s=3, label="nominal", **shade)
        if result.findings:
            ax.scatter(x[idx], ext_r[idx], s=3, color="tab:red", alpha=0.4, label="extended")
        if colour is not None:
            fig.colorbar(sc, ax=ax, label="z of the end-effector [m]")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("T_out measured - model [N]")
        ax.set_title(f"residual against {xlabel.split(' [')[0]} (held-out blocks)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
        fig.tight_layout()
        fig.savefig(out_dir / fname, dpi=100)
        plt.close(fig)
        names.append(fname)

    if d.has_positions:
        fig, axes = plt.subplots(1, 3, figsize=(11, 3.8), sharey=True)
        for j, (ax, name) in enumerate(zip(axes, ("x", "y", "z"), strict=True)):
            ax.scatter(d.positions_m[idx, j], base_r[idx], s=3, color="tab:orange", label="nominal")
            if result.findings:
                ax.scatter(
                    d.positions_m[idx, j],
                    ext_r[idx],
                    s=3,
                    color="tab:red",
                    alpha=0.4,
                    label="extended",
                )
            ax.set_xlabel(f"{name} of the end-effector [m]")
            ax.grid(alpha=0.3)
        axes[0].set_ylabel("T_out measured - model [N]")
        axes[0].legend(fontsize=8)
        fig.suptitle("residual against the end-effector position (held-out blocks)")
        fig.tight_layout()
        fig.savefig(out_dir / "residual_vs_position.png", dpi=100)
        plt.close(fig)
        names.append("residual_vs_position.png")

    scored = _scored(result)
    nper = int(min(np.sum(scored), round(4.0 * d.rate_hz)))
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for r, label, colour in ((base_r, "nominal", "tab:orange"), (ext_r, "extended", "tab:red")):
        if label == "extended" and not result.findings:
            continue
        f, p = welch(r[scored] - np.mean(r[scored]), fs=d.rate_hz, nperseg=nper)
        ax.semilogy(f[1:], p[1:], color=colour, lw=0.8, label=f"residual, {label}")
    white = 2.0 * d.noise_floor_n**2 / d.rate_hz
    ax.axhline(white, color="k", lw=0.8, ls=":", label="white noise at the noise floor")
    ax.set_xscale("log")
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("power spectral density [N^2/Hz]")
    ax.set_title("spectrum of the residual")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / "residual_spectrum.png", dpi=100)
    plt.close(fig)
    names.append("residual_spectrum.png")

    idx = _pick(len(t), scored)
    fig, ax = plt.subplots(figsize=(6, 5))
    ax.scatter(d.t_in_meas_n[idx], d.t_out_meas_n[idx], s=2, color="k", label="measured")
    ax.scatter(
        d.t_in_meas_n[idx],
        result.fmu_baseline[idx],
        s=2,
        color="tab:orange",
        alpha=0.5,
        label="nominal",
    )
    if result.findings:
        ax.scatter(
            d.t_in_meas_n[idx],
            result.fmu_extended[idx],
            s=2,
            color="tab:red",
            alpha=0.5,
            label="extended",
        )
    ax.set_xlabel("input tension T_in [N]")
    ax.set_ylabel("output tension T_out [N]")
    ax.set_title("capstan relation (paper Fig. 2, 11)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / "capstan.png", dpi=100)
    plt.close(fig)
    names.append("capstan.png")
    if result.free_forms:
        names.append(free_form_plot(out_dir, result.free_forms))
    return names


def free_form_plot(out_dir: Path, tried: list[FreeForm] | FreeForm) -> str:
    """Each free form tried against its best fixed form, a panel each: a table (the drift's over
    time, the slack's over the input tension: the FMU's, linear between its knots) through its
    knots, a surface's coefficients as bars beside the fixed form's; returns the file name."""
    tried = [tried] if isinstance(tried, FreeForm) else list(tried)
    fig, axes = plt.subplots(len(tried), 1, figsize=(7, 4.5 * len(tried)), squeeze=False)
    for ax, free in zip(axes[:, 0], tried, strict=True):
        verdict = "taken" if free.accepted else "not taken"
        fixed = f"fixed form: {free.fixed.form or free.fixed.fmu_param}"
        if isinstance(free.knots_at[0], str):
            at = np.arange(len(free.knots_at))
            ax.bar(at - 0.2, free.table, 0.4, color="tab:red", label=f"free form, {verdict}")
            ax.bar(at + 0.2, free.fixed_at_knots, 0.4, color="tab:orange", label=fixed)
            ax.set_xticks(at, [f"phi_offset_per_{a}" for a in free.knots_at], rotation=30)
            ax.set_xlabel("term of the surface (linear rad/m, quadratic rad/m^2)")
        else:
            ax.plot(
                free.knots_at,
                free.table,
                "o-",
                color="tab:red",
                lw=1.0,
                ms=4,
                label=f"free form ({free.name}), {verdict}",
            )
            ax.plot(
                free.knots_at,
                free.fixed_at_knots,
                "s--",
                color="tab:orange",
                lw=1.0,
                ms=4,
                label=fixed,
            )
            ax.set_xlabel(free.axis.replace(" (", " [").replace(")", "]"))
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel(free.quantity)
        ax.set_title(f"{free.fixed.cause}: the learned shape against the fixed form")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / FREE_FORM_PNG, dpi=100)
    plt.close(fig)
    return FREE_FORM_PNG


FREE_FORM_PNG = "free_form.png"


PLOT_CAPTIONS = {
    "residual_time.png": "measured T_out against the nominal and extended models, and the "
    "residuals over time (report blocks shaded)",
    "residual_vs_tin.png": "residual against the input tension (a gain or a tension-dependent "
    "friction grows with it)",
    "residual_vs_rate.png": "residual against the tension rate (lag, delay and viscous friction "
    "follow it)",
    "residual_vs_position.png": "residual against the end-effector position (a wrong bending "
    "angle follows z)",
    "residual_spectrum.png": "spectrum of the residuals, with the level of white noise at the "
    "noise floor",
    "capstan.png": "T_out against T_in: the capstan loops of the data and the models",
    FREE_FORM_PNG: "each free form tried (the FMU's drift or slack table, the bending error's "
    "surface) against its best fixed form, at the table's knots or term by term",
}


def markdown(result: AuditResult, data: dict, plot_names: list[str]) -> str:
    """report.md: readable on its own."""
    d = result.data
    b, e, g = data["baseline"], data["extended"], data["gain"]
    lines = [
        f"# Model audit of `{d.source}`",
        "",
        "What the plant model (the FMU's physics: capstan friction with a dead zone at reversals, "
        "the bending angle from the geometry) gets wrong on these data, the cause named from the "
        "vocabulary of the FMU's effects, and what fixing it gains on data no fit saw.",
        "",
        "## Data",
        "",
        f"- {data['samples']} samples, {data['duration_s']:.1f} s at {data['sample_rate_hz']:g} Hz"
        + (f" (decimated by {d.decimation})" if d.decimation > 1 else ""),
        f"- positions: {'yes' if d.has_positions else 'no'}; loop routing: "
        f"{d.inputs.loop_routing}; sheath length {d.inputs.sheath_length_m:g} m; mu "
        + ("from the sidecar" if d.mu_fixed else "fitted"),
        f"- sidecar values taken by default: {', '.join(d.defaulted) or 'none'}",
        f"- noise floor (white noise of the output sensor): {d.noise_floor_n:.4f} N; input "
        f"sensor {d.input_noise_n:.4f} N (the input is smoothed over {core.SMOOTH_S * 1000:.0f} ms "
        "before it drives the model, except across fast changes, where the filter would ring: "
        f"{d.input_kept / d.rate_hz:.2f} s of the record kept as measured)",
        f"- split: {d.split_text()}. The report blocks are {len(data['split']['report_blocks_s'])} "
        "blocks spread over the record; every held-out figure below comes from them.",
        "",
        "## Nominal model",
        "",
        f"mu = {b['params']['mu']:.5f}; phi {b['phi']}; dead_zone_spread = "
        f"{b['params'].get('dead_zone_spread') or 0.0:.3f} (the gradual turn through the dead "
        f"zone). Residual of T_out (FMU): RMS {b['rms_n']:.4f} N, held-out "
        f"{b['holdout_rms_n']:.4f} N.",
        "",
        *(["## Warnings", "", *(f"- {w}" for w in result.warnings), ""] if result.warnings else []),
        "## Findings",
        "",
        f"Rule: {result.rule.text()}.",
        "",
    ]
    if result.findings:
        lines += [
            "| cause | FMU parameter | explains (held-out) | block t | why |",
            "| --- | --- | --- | --- | --- |",
        ]
        for f in result.findings:
            lines.append(
                f"| {f.effect.label}{' (or ' + f.ambiguous_with + ')' if f.ambiguous_with else ''} "
                f"| {f.effect.describe_all(core.finding_params(result, f))} "
                f"| {f.explains_pct:.1f} % | {f.t:.1f} "
                f"| {f.evidence} |"
            )
    else:
        lines.append("No cause of the vocabulary passes the rule: the nominal model stands.")
    for free in result.free_forms:
        form = free.fixed.form or free.fixed.fmu_param
        lines += [
            "",
            f"Free form of {free.fixed.cause} ({free.name} of the FMU, fmu/README.md): "
            f"{free.why}. The report blocks, measured only: form {form} "
            f"{free.report_rms_fixed_n:.4f} N, free form {free.report_rms_free_n:.4f} N (twin).",
            "",
            f"| {free.axis} | free form | {form} |",
            "| --- | --- | --- |",
            *(
                f"| {a if isinstance(a, str) else f'{a:.2f}'} | {d:+.5f} | {f:+.5f} |"
                for a, d, f in zip(free.knots_at, free.table, free.fixed_at_knots, strict=True)
            ),
        ]
    lines += [
        "",
        "Candidates per round (share of the selection blocks' residual removed, block t):",
        "",
    ]
    for rnd in data["rounds"]:
        cells = ", ".join(
            f"{c['cause']} {c['selection_explains_pct']:.1f} % ({c['block_t']})"
            for c in rnd["candidates"]
        )
        lines.append(f"- round {rnd['round']}: {cells}; chosen: {rnd['chosen'] or 'none'}")
    for cause, why in data["not_tried"].items():
        lines.append(f"- not tried: {cause}: {why}")
    js = data.get("joint_search")
    if js:
        lines.append(
            "- joint search (every cause that removed a share in some round, together, then "
            f"taken out while the rule allows: cosim.audit.joint): from "
            f"{', '.join(js['started'])}; out with the rest held: "
            f"{', '.join(js['dropped_with_the_rest_held']) or 'none'}; out with the rest "
            f"refitted: {', '.join(js['dropped_with_the_rest_refitted']) or 'none'}; kept: "
            f"{', '.join(js['kept']) or 'none'}; "
            + ("taken" if js["taken"] else "not taken")
            + f": {js['why']}"
        )
    lines += [
        "",
        "## Extended model",
        "",
        f"Parameters: {', '.join(f'{k} = {v:g}' for k, v in e['params'].items())}. Run through "
        f"the FMU: RMS {e['rms_n']:.4f} N, held-out {e['holdout_rms_n']:.4f} N (the twin used "
        f"for fitting agrees within {e['twin_fmu_max_diff_n']:.1e} N).",
        "",
        "## Gain on held-out data",
        "",
        f"On the report blocks: {g['holdout_rms_before_n']:.4f} N -> "
        f"{g['holdout_rms_after_n']:.4f} N RMS, {g['gain_pct']:.1f} % of the residual variance "
        f"removed; noise floor {g['noise_floor_n']:.4f} N{_less_lines(d)}.",
        "",
        "## What is left",
        "",
        unexplained_text(result.unexplained) + ".",
        "",
    ]
    if "emitted_params" in data:
        lines += ["## Parameters for `bowden sim --params`", ""]
        lines.append(f"Written to `{data['emitted_params']['file']}`:")
        lines += ["", "```json", json.dumps(data["emitted_params"]["params"], indent=2), "```", ""]
        for note in data["emitted_params"].get("notes", []):
            lines.append(f"- {note}")
        fig = data.get("fig14")
        if fig:
            lines += ["", fig["text"], ""]
    lines += ["## Plots", ""]
    for name in plot_names:
        lines += [f"![{PLOT_CAPTIONS[name]}]({name})", "", f"*{PLOT_CAPTIONS[name]}*", ""]
    return "\n".join(lines)
