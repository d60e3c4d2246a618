"""`bowden sim SCENARIO`: one closed-loop co-simulation run and its float reference.

The fixed-point run is the real RTL (cocotb on Verilator or Icarus), the real firmware (host
build through ctypes) and the plant FMU in closed loop (cosim.engines.cocotb). The float reference
runs the same scenario against the same FMU with the compensator's double twin and a double model of
the PI + feedforward loop (cosim.engines.reference). The run writes, in --out DIR:

- ``result.json``: scenario, compensator, loop_routing, samples, sim_seconds, wall_seconds,
  rms_error_n, rms_error_pct, peak_error_n, peak_error_pct (T_ref - T_out of the fixed-point run,
  paper Sec. VI-C), fixed_vs_float {current_rms_lsb, current_max_lsb, t_out_rms_n, t_out_max_n,
  ...}, the float reference's own errors, the friction fit of characterize/positions, and the
  cost split of the wall time;
- ``trace.csv`` + ``trace.meta.json`` (the fixed-point run, cosim.results.trace format) and
  ``reference.csv`` + ``reference.meta.json`` (the float reference);
- ``tracking.png``, ``fixed_vs_float.png`` and, for characterize/positions, ``capstan.png``.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from cosim.config.run import COMPENSATORS, SimConfig
from cosim.config.scenarios import get_scenario
from cosim.parts.interface import INTERFACES
from cosim.results import trace as trace_mod

# Default compensator per scenario: the characterisations measure the plant itself.
DEFAULT_COMPENSATOR = {
    "characterize": "none",
    "positions": "none",
    "fig14": "paper",
    "tune": "preview",
    "sine1hz": "preview",
    "triangle": "preview",
    "multisine": "preview",
    "fig14path2": "preview",
}
SIMULATORS = ("verilator", "icarus")
# AXI4-Lite drivers of the testbench (cosim/engines/cocotb/tb_closed_loop.py): identical results.
BUSES = ("cocotbext-axi", "lean")
# Engines of the fixed-point run: the cocotb harness (the reference: waveforms, Python access) or
# its loop compiled (cosim/native: same bits as cocotb with the lean driver, 20x+ real time).
ENGINES = ("cocotb", "native")
# Full scale of the load cell path (the RTL's default calibration, about +-64 N).
FULL_SCALE_N = 64.0
# Shortest run: ten firmware ticks. The harness reads back the T_c the RTL used (TC_EFF) at every
# tenth tick (tb_closed_loop.SHADOW_REFRESH_TICKS), so a shorter run checks nothing of the loop,
# and the metrics need the reference to have left zero (every scenario starts at T_ref = 0).
MIN_FIRMWARE_TICKS = 10
MAX_DURATION_S = 3600.0


def check_duration(duration_s: float | None, cfg: SimConfig, option: str = "--duration") -> None:
    """ValueError naming `option` unless the run lasts MIN_FIRMWARE_TICKS firmware ticks to
    MAX_DURATION_S (None: the scenario's own duration)."""
    if duration_s is None:
        return
    lo = MIN_FIRMWARE_TICKS / cfg.firmware_rate_hz
    if not (math.isfinite(duration_s) and lo <= duration_s <= MAX_DURATION_S):
        raise ValueError(
            f"{option} must be in [{lo:g}, {MAX_DURATION_S:g}] s (at least {MIN_FIRMWARE_TICKS} "
            f"firmware ticks of 1/{cfg.firmware_rate_hz:g} s); got {duration_s!r}"
        )


def check_reach(scen, cfg: SimConfig, duration_s: float | None) -> None:
    """ValueError when the scenario's end-effector leaves the workspace of the plant's sheath
    (|C| <= L, y >= 0; paper Eq. 13): plant.sheath_length of a params file is too short."""
    from cosim.config.scenarios import SHEATH_LENGTH_M, sample_inputs  # noqa: PLC0415

    length = float(cfg.plant.get("sheath_length", SHEATH_LENGTH_M))
    inp = sample_inputs(scen, cfg, duration_s)
    reach = float(np.max(np.sqrt(inp.x_m**2 + inp.y_m**2 + inp.z_m**2)))
    if reach > length:
        raise ValueError(
            f"plant.sheath_length = {length:g} m is shorter than the reach of scenario "
            f"{scen.name} ({reach:.3f} m from the outlet); allowed: >= {reach:.3f} m"
        )


def check_engine(engine: str, simulator: str) -> None:
    """ValueError for an unknown engine, or the native one with another simulator than
    Verilator (the native loop is the Verilated model)."""
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {', '.join(ENGINES)}; got {engine!r}")
    if engine == "native" and simulator != "verilator":
        raise ValueError(
            f"--engine native runs the Verilated RTL; --simulator {simulator} needs --engine cocotb"
        )


def run(
    scenario: str,
    compensator: str | None = None,
    loop_routing: bool = True,
    simulator: str = "verilator",
    bus: str = "lean",
    cfg: SimConfig | None = None,
    interface: str = "board",
    engine: str = "cocotb",
    duration_s: float | None = None,
    out_dir: Path | None = None,
    reference: bool = True,
    progress: bool = True,
    write_files: bool = True,
) -> dict:
    """Run the fixed-point co-simulation (and the float reference), write the outputs, return
    the result dict (the content of result.json). wall_seconds is the wall time of the
    co-simulation run (simulator start-up included, the up-to-date check of the build not)."""
    from .cocotb import runner  # noqa: PLC0415 (cocotb is only needed for a run)
    from .reference import resolve_phi, run_reference  # noqa: PLC0415

    cfg = cfg or SimConfig()
    cfg.validate()
    if simulator not in SIMULATORS:
        raise ValueError(f"simulator must be one of {', '.join(SIMULATORS)}; got {simulator!r}")
    if bus not in BUSES:
        raise ValueError(f"bus must be one of {', '.join(BUSES)}; got {bus!r}")
    check_engine(engine, simulator)
    if interface not in INTERFACES:
        raise ValueError(f"interface must be one of {', '.join(INTERFACES)}; got {interface!r}")
    scen = get_scenario(scenario)
    compensator = compensator or DEFAULT_COMPENSATOR[scenario]
    if compensator not in COMPENSATORS:
        raise ValueError(
            f"compensator must be one of {', '.join(COMPENSATORS)}; got {compensator!r}"
        )
    check_duration(duration_s, cfg, "duration_s")
    check_reach(scen, cfg, duration_s)
    duration = scen.duration_s if duration_s is None else float(duration_s)
    phi_rad = resolve_phi(scen, cfg, loop_routing)
    # Absolute: the simulator runs in a folder of its own and reads the paths it is given.
    out_dir = Path(out_dir).absolute() if out_dir is not None else None

    run_spec = {
        "scenario": scenario,
        "compensator": compensator,
        "loop_routing": bool(loop_routing),
        "interface": interface,
        "duration_s": duration,
        "phi_rad": phi_rad,
        "config": cfg.to_dict(),
        # The native loop drives the bus as the lean driver does (its bits are that run's).
        "bus": bus if engine == "cocotb" else "native",
        "engine": engine,
    }
    if engine == "native":
        from .native import engine as native  # noqa: PLC0415

        native.load_library()  # built or reused; not part of the run's wall time
        t0 = time.perf_counter()
        fixed, cost = native.run_closed_loop(run_spec, progress=progress)
    else:
        runner.build(simulator)  # reused when up to date; not part of the run's wall time
        t0 = time.perf_counter()
        fixed, cost = runner.run_closed_loop(
            run_spec,
            simulator=simulator,
            work_dir=out_dir / "sim" if out_dir is not None else None,
            progress=progress,
        )
    wall_fixed = time.perf_counter() - t0
    ref = None
    if reference:
        ref = run_reference(
            scen, cfg, compensator, loop_routing, phi_rad, duration, progress, interface
        )

    result = evaluate(scen, cfg, run_spec, fixed, ref, wall_fixed, cost)
    if write_files and out_dir is not None:
        write_outputs(out_dir, scen, cfg, run_spec, fixed, ref, result)
    return result


def evaluate(scen, cfg, run_spec, fixed, ref, wall_s, cost) -> dict:
    """The figures of result.json from the records of the two runs."""
    from cosim.results import metrics  # noqa: PLC0415 (scipy/matplotlib only when a run is evaluated)

    n = len(fixed["t_s"])
    # Runs shorter than the start-up window are evaluated whole.
    settle = scen.settle_s if fixed["t_s"][-1] > scen.settle_s else 0.0
    err = metrics.tracking_error(fixed["t_s"], fixed["T_ref_N"], fixed["T_out_N"], settle)
    result = {
        "scenario": run_spec["scenario"],
        "compensator": run_spec["compensator"],
        "loop_routing": run_spec["loop_routing"],
        "interface": run_spec["interface"],
        "samples": n,
        "sim_seconds": n / cfg.sample_rate_hz,
        "wall_seconds": wall_s,
        "rms_error_n": err["rms_error_n"],
        "rms_error_pct": err["rms_error_pct"],
        "peak_error_n": err["peak_error_n"],
        "peak_error_pct": err["peak_error_pct"],
        "max_ref_n": err["max_ref_n"],
        # Where the error is: after reversals (the jump of T_c, actuator bandwidth) or away from
        # them (the friction model, i.e. phi; what loop routing fixes). metrics.reversal_split.
        "error_split": metrics.reversal_split(
            fixed["t_s"], fixed["T_ref_N"], fixed["T_out_N"], settle
        ),
        "settle_s": settle,
        "sample_rate_hz": cfg.sample_rate_hz,
        "firmware_rate_hz": cfg.firmware_rate_hz,
        "compensator_phi_rad": run_spec["phi_rad"],
        "compensator_mu": cfg.compensator.mu,
        "simulated_per_wall": (n / cfg.sample_rate_hz) / wall_s if wall_s > 0 else None,
        # The closed loop alone (the simulator's start-up excluded), split by component.
        "loop_wall_seconds": cost.get("total_s"),
        "cost_s": {k: cost[k] for k in ("rtl_s", "fmu_s", "firmware_s", "harness_s", "bus_s")},
        "clks_per_sample": cost.get("clks_per_sample"),
        "bus": run_spec["bus"],
        "engine": run_spec.get("engine", "cocotb"),
        "checks": {
            "tc_latency_samples": cost.get("tc_latency_samples"),
            "late_tc_writes": cost.get("late_writes"),
            "tc_eff_mismatches": cost.get("tc_mismatch"),
            "tc_eff_checks": cost.get("tc_checks"),
            "rtl_fault_word_at_end": cost.get("fault_word"),
            "rtl_status_word_at_end": cost.get("status_word"),
        },
    }
    if ref is not None:
        result["fixed_vs_float"] = metrics.fixed_vs_float(
            fixed["current_A"], ref["current_A"], fixed["T_out_N"], ref["T_out_N"], FULL_SCALE_N
        )
        result["fixed_vs_float"]["t_out_rms_pct_max_ref"] = (
            100.0 * result["fixed_vs_float"]["t_out_rms_n"] / err["max_ref_n"]
            if err["max_ref_n"] > 0
            else None
        )
        ref_err = metrics.tracking_error(ref["t_s"], ref["T_ref_N"], ref["T_out_N"], settle)
        result["float_reference"] = {k: ref_err[k] for k in sorted(ref_err)}
    if scen.segments:
        result["friction_fit"] = friction_fits(scen, cfg, fixed)
    return result


def friction_fits(scen, cfg, rec) -> list[dict]:
    """Capstan fit (metrics.fit_capstan) per position segment, on the sensors' T_in and T_out."""
    from cosim.results import metrics  # noqa: PLC0415 (scipy/matplotlib only when a run is evaluated)

    fits = []
    for seg in scen.segments:
        i0 = int(round(seg.t_start_s * cfg.sample_rate_hz))
        i1 = min(len(rec["t_s"]), int(round(seg.t_end_s * cfg.sample_rate_hz)))
        # The first 0.3 s of a segment are the move to the position (scenarios._positions).
        i0 += int(round(0.3 * cfg.sample_rate_hz)) if scen.name == "positions" else 0
        if i1 - i0 < 100:  # too little of the segment was run to fit (a short --duration)
            continue
        phi = float(np.mean(rec["phi_rad"][i0:i1]))
        fit = metrics.fit_capstan(rec["T_in_N"][i0:i1], rec["T_out_N"][i0:i1], phi_rad=phi)
        fits.append({"position_m": list(seg.position_m), "phi_rad": phi, **fit})
    return fits


def write_outputs(out_dir: Path, scen, cfg, run_spec, fixed, ref, result) -> None:
    """Write the run's files into out_dir as one set: they are written in a staging folder
    inside it and moved in place at the end, result.json last, so that an interrupted or failed
    write leaves the files of an earlier run whole (never half a trace)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".writing-", dir=out_dir))
    try:
        _write_files(stage, scen, cfg, run_spec, fixed, ref, result)
        names = sorted(p.name for p in stage.iterdir() if p.name != "result.json")
        for name in [*names, "result.json"]:
            os.replace(stage / name, out_dir / name)
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _write_files(out_dir: Path, scen, cfg, run_spec, fixed, ref, result) -> None:
    from cosim.parts.plant import fmu_variables  # noqa: PLC0415
    from cosim.results import plots  # noqa: PLC0415 (scipy/matplotlib only when a run is evaluated)

    # The plant's own values (the FMU's defaults unless the params file set them), not the
    # compensator's belief: the sidecar describes the plant the trace was recorded on.
    fmu = fmu_variables()
    meta = {
        "sample_rate_hz": cfg.sample_rate_hz,
        "sheath_length_m": float(cfg.plant.get("sheath_length", fmu["sheath_length"].start)),
        "loop_routing": bool(run_spec["loop_routing"]),
        "mu": float(cfg.plant.get("mu", fmu["mu"].start)),
        "source": "cosim",
        "scenario": run_spec["scenario"],
        "compensator": run_spec["compensator"],
        "interface": run_spec["interface"],
    }
    trace_mod.write_trace(out_dir / "trace.csv", trace_columns(fixed), {**meta, "chain": "fixed"})
    if ref is not None:
        trace_mod.write_trace(
            out_dir / "reference.csv", trace_columns(ref), {**meta, "chain": "float"}
        )
    title = (
        f"{run_spec['scenario']}: compensator {run_spec['compensator']}, loop routing "
        f"{'on' if run_spec['loop_routing'] else 'off'} (RMS {_pct(result['rms_error_pct'])} %, "
        f"peak {_pct(result['peak_error_pct'])} % of {result['max_ref_n']:.0f} N)"
    )
    plots.plot_tracking(out_dir / "tracking.png", fixed, ref, title)
    if ref is not None:
        plots.plot_fixed_vs_float(out_dir / "fixed_vs_float.png", fixed, ref, title)
    if scen.segments:
        segs = []
        for seg in scen.segments:
            i0 = int(round(seg.t_start_s * cfg.sample_rate_hz))
            i1 = int(round(seg.t_end_s * cfg.sample_rate_hz))
            if i0 < len(fixed["t_s"]):
                segs.append((f"{tuple(round(v, 2) for v in seg.position_m)} m", slice(i0, i1)))
        plots.plot_capstan(
            out_dir / "capstan.png", fixed["T_in_N"], fixed["T_out_N"], segs, title.split(" (")[0]
        )
    # allow_nan=False: a NaN or an infinity is not JSON (strict readers refuse it); a figure
    # that has no value is null (metrics), anything else is a bug to be seen here.
    (out_dir / "result.json").write_text(json.dumps(result, indent=2, allow_nan=False) + "\n")


def trace_columns(rec) -> dict[str, np.ndarray]:
    """A record's arrays in the trace format (required columns first, then the extras)."""
    cols = {name: np.asarray(rec[name]) for name in trace_mod.COLUMNS}
    for extra in ("T_in_true_N", "T_out_true_N", "phi_rad"):
        if extra in rec:
            cols[extra] = np.asarray(rec[extra])
    return cols


def _pct(value: float | None) -> str:
    """A percentage with one decimal, '-' when it has no value (T_ref zero throughout)."""
    return "-" if value is None else f"{value:.1f}"


def summary_table(results: list[dict], paper: bool = False) -> str:
    """A plain-text table of runs: errors, fixed vs float, speed."""
    from cosim.results import metrics  # noqa: PLC0415 (scipy/matplotlib only when a run is evaluated)

    head = (
        f"{'scenario':<13}{'compensator':<12}{'loop':<6}{'RMS N':>8}{'RMS %':>8}{'peak N':>8}"
        f"{'peak %':>8}{'rev RMS N':>10}{'away RMS N':>11}{'du rms/max LSB':>16}"
        f"{'dT_out rms N':>14}{'sim/wall':>10}  interface"
    )
    lines = [head, "-" * len(head)]
    for r in results:
        fvf = r.get("fixed_vs_float")
        du = f"{fvf['current_rms_lsb']:.2f}/{fvf['current_max_lsb']:.0f}" if fvf else "-"
        dt = f"{fvf['t_out_rms_n']:.4f}" if fvf else "-"
        speed = r.get("simulated_per_wall")
        split = r.get("error_split")
        split_near = f"{split['rms_near_reversal_n']:.3f}" if split else "-"
        split_away = f"{split['rms_away_n']:.3f}" if split else "-"
        lines.append(
            f"{r['scenario']:<13}{r['compensator']:<12}{'on' if r['loop_routing'] else 'off':<6}"
            f"{r['rms_error_n']:>8.3f}{_pct(r['rms_error_pct']):>8}{r['peak_error_n']:>8.3f}"
            f"{_pct(r['peak_error_pct']):>8}{split_near:>10}{split_away:>11}{du:>16}{dt:>14}"
            f"{(f'x{speed:.2f}' if speed else '-'):>10}  {r.get('interface', '-')}"
        )
    if paper:
        lines.append(
            f"{'paper Fig.14':<13}{'paper':<12}{'on':<6}{metrics.PAPER_RMS_N:>8.3f}"
            f"{metrics.PAPER_RMS_PCT:>8.1f}{metrics.PAPER_PEAK_N:>8.3f}"
            f"{metrics.PAPER_PEAK_PCT:>8.1f}{'':>21}{'(measured)':>16}"
        )
    for r in results:
        for fit in r.get("friction_fit", []):
            lines.append(
                f"  friction fit at {tuple(round(v, 2) for v in fit['position_m'])} m: "
                f"mu*phi = {fit['mu_phi']:.3f} (phi {fit['phi_rad']:.2f} rad, mu "
                f"{fit.get('mu', float('nan')):.4f}), efficiency {fit['efficiency']:.3f}"
            )
    return "\n".join(lines)
