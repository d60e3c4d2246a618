"""The distance to the limit: the tracking error a controller that knows the plant exactly would
leave on fig14, per plant of a sweep specification, and each mode's error as a ratio to it.

The floor's controller is an oracle on the float model: it holds the plant FMU itself (every
parameter and effect of the point: mu, stiffness, drive bandwidth, dead zone, breakaway, slack,
sensor offset and lag, ...) and the reference ahead, and drives the plant through the drive's
limits only. Every PWM period of the board (board.pwm_hz, 5 kHz) it chooses the ESCON's current
set value among the levels the ESCON resolves (duty 10 .. 90 % in steps of
ESCON_DUTY_RESOLUTION: +-escon_imax_a in steps of 10 mA), by bisection on the plant's own
response: the set value that, held for `horizon_s` (HORIZONS_S), brings the true output tension
T_out to T_ref at the horizon's end. Saved and restored FMU states make each trial start from the
plant's exact state. The chosen commands are then replayed sample by sample on the plant as the
point configures it (its sensor noise included) and scored as the sweep scores a run
(cosim.results.metrics.tracking_error after the scenario's settle time, in % of max T_ref): on the
far-end reading (T_out_meas, the sweep's figure) and on the true T_out.

What the floor includes: the drive's current limit (the ESCON's set value range and the plant's
current_limit), its bandwidth (the plant's current loop), the PWM set value's period and
resolution, the plant's mechanics (motor inertia, cable and sheath elasticity, the dead zone and
every effect). What it leaves out, all of which can only raise a real controller's error: model
error (the oracle knows the plant exactly), the inlet sensor and its ADC (a controller that knows
the plant and its state needs no measurement: the plant is deterministic but for its sensors'
noise), the ADC's and the PWM's latency (with the reference known ahead, a known delay costs an
exact model nothing), the loop's fixed point and the reference's Q7.8 words. Its far-end figure
also carries the far-end cell's own offset, gain, lag and noise, since the oracle aims the cable's
tension, not the reading.

What kind of bound it is: the error of one controller, a greedy model-predictive one, not a
proven minimum over all current trajectories; the true floor is at or below it where it tracks.
On the nominal plant it tracks fig14 to about 0.01 % of 15 N: the drive and the board leave fig14
essentially no floor (crossing the dead zone at a reversal takes the 4 A drive a few ms, during
which a 0.5 Hz sine's peak moves by about a mN). On plants with a strong speed-dependent
friction (mu_viscous of order 1 s/m and more) and a breakaway, the greedy choice rings (it pulls
hard, the cable's speed raises the friction, the output collapses and overshoots): there its
figure is no floor, and a row whose floor exceeds the mode's error says so (ratio below 1).

    python -m cosim.studies.tracking_floor --spec SPEC.yaml [--out DIR] [--workers 2]
        [--mode NAME=RESULTS ...] [--limit N] [--horizons S,...]

--mode joins a mode's results: the --out folder of `bowden sweep` on the same spec (its points/
files), or the JSON of cosim.studies.calibrated_robustness; rows are matched by the plant and
position of each point, and the table prints each mode's RMS and peak beside the floor's and
their ratios (median and worst over the plants).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from cosim.parts.interface import ESCON_DUTY_MAX, ESCON_DUTY_MIN, ESCON_DUTY_RESOLUTION
from cosim.studies.workers import process_pool, run_interruptible

# Horizons of the oracle's prediction (s): the set value is held over the horizon, and T_out at
# its end is brought to T_ref there. 1 ms excites the cable's mode (about 28 Hz, fmu/README.md A5)
# on the nominal plant; 2 ms tracks it to 0.01 %. With several, each point takes the best.
HORIZONS_S = (0.002,)
# The FMU's communication step in the oracle's predictions: one step over the horizon (the FMU
# integrates inside it at its own max_step; its rate filters see one averaged step).
PREDICTION_STEP_S = 0.002
# An optional bound of the oracle's own on the set value's rate (A/s; None: none, as the drive
# has none). Tried against the ringing on plants with a speed-dependent friction and a breakaway
# (see the module's docstring): 250 A/s made it worse, so the default is no bound.
SLEW_A_PER_S = None


def plant_key(values: dict) -> tuple:
    """The plant and position of a sweep point: what a floor depends on (the controller's
    fields do not enter)."""
    key = [("position_m", tuple(round(float(v), 9) for v in values.get("position_m") or ()))]
    for name in sorted(values):
        if name.startswith("plant."):
            key.append((name, round(float(values[name]), 12)))
    return tuple(key)


def _levels(escon_imax_a: float) -> np.ndarray:
    """The ESCON's current set values (A) for the duty cycles it resolves."""
    steps = int(round((ESCON_DUTY_MAX - ESCON_DUTY_MIN) / ESCON_DUTY_RESOLUTION))
    duty = ESCON_DUTY_MIN + ESCON_DUTY_RESOLUTION * np.arange(steps + 1)
    return (duty - 0.5) / 0.4 * escon_imax_a


def floor_run(
    run_spec: dict, horizon_s: float, trace: dict | None = None, slew_a_per_s: float | None = None
) -> dict:
    """The oracle's run of one point (run_spec as cosim.studies.sweep.spec.SweepSpec.run_spec
    makes it, duration_s set): its error figures and its current set values."""
    from cosim.config.run import SimConfig  # noqa: PLC0415
    from cosim.config.scenarios import sample_inputs  # noqa: PLC0415
    from cosim.engines.harness import open_plant  # noqa: PLC0415
    from cosim.engines.native.engine import scenario_of  # noqa: PLC0415
    from cosim.results import metrics  # noqa: PLC0415

    cfg = SimConfig.from_dict(run_spec["config"], source="point")
    scen = scenario_of(run_spec)
    inp = sample_inputs(scen, cfg, run_spec["duration_s"])
    dt = 1.0 / cfg.sample_rate_hz
    ratio = int(round(cfg.sample_rate_hz / cfg.board.pwm_hz))
    levels = _levels(cfg.board.escon_imax_a)
    n = len(inp.t_s)
    h_samples = max(1, int(round(horizon_s / dt)))
    pred_samples = max(1, int(round(PREDICTION_STEP_S / dt)))
    slew = SLEW_A_PER_S if slew_a_per_s is None else slew_a_per_s
    step_a = levels[1] - levels[0]
    slew_levels = len(levels) if slew is None else max(1, int(slew * ratio * dt / step_a))
    pos0 = (inp.x_m[0], inp.y_m[0], inp.z_m[0])
    routing = run_spec["loop_routing"]

    # The oracle's model: the point's plant without its sensor noise (noise is not predictable).
    quiet = SimConfig.from_dict(run_spec["config"], source="point")
    quiet.plant = {**quiet.plant, "noise_std": 0.0}
    model = open_plant(quiet, routing, pos0)
    t_ref = inp.t_ref_n
    T_OUT, X, Y, Z, CMD = model.T_OUT, model.X, model.Y, model.Z, model.CURRENT_CMD
    u = model.u
    commands = np.empty(n)
    lo_prev = len(levels) // 2
    try:
        k = 0
        while k < n:
            block = min(ratio, n - k)
            target_k = min(n - 1, k + h_samples)
            state = model.get_state()

            def reading(level: int, k=k, target_k=target_k, state=state) -> float:
                # The prediction steps the FMU in pieces of up to PREDICTION_STEP_S with the
                # position at each piece's end (the path moves slowly): a prediction a little
                # off the per-sample run costs the oracle a little, never the figure's honesty
                # (what is scored is the per-sample replay below).
                model.set_state(state)
                t0 = model.time_s
                u[CMD] = levels[level]
                j = k
                while j <= target_k:
                    m = min(target_k + 1 - j, pred_samples)
                    e = j + m - 1
                    u[X], u[Y], u[Z] = inp.x_m[e], inp.y_m[e], inp.z_m[e]
                    y = model.step(m * dt)
                    j += m
                model.time_s = t0
                return y[T_OUT]

            # The reading rises with the set value: bisect for the lowest level within the slew
            # bound of the last choice that reaches the target, then keep whichever neighbour
            # lands closer.
            want = t_ref[target_k]
            a = max(0, lo_prev - slew_levels)
            b = min(len(levels) - 1, lo_prev + slew_levels)
            if reading(a) >= want:
                b = a
            elif reading(b) < want:
                a = b
            while b - a > 1:
                mid = (a + b) // 2
                if reading(mid) >= want:
                    b = mid
                else:
                    a = mid
            ea, eb = abs(reading(a) - want), abs(reading(b) - want)
            best = a if ea <= eb else b
            lo_prev = best
            model.set_state(state)
            model.free_state(state)
            u[CMD] = levels[best]
            for j in range(k, k + block):
                u[X], u[Y], u[Z] = inp.x_m[j], inp.y_m[j], inp.z_m[j]
                model.step(dt)
                commands[j] = levels[best]
            k += block
    finally:
        model.close()

    # The commands replayed on the plant as the point configures it (its sensor noise too).
    plant = open_plant(cfg, routing, pos0)
    t_out = np.empty(n)
    t_out_true = np.empty(n)
    try:
        pu = plant.u
        for j in range(n):
            pu[CMD] = commands[j]
            pu[X], pu[Y], pu[Z] = inp.x_m[j], inp.y_m[j], inp.z_m[j]
            y = plant.step(dt)
            t_out[j] = y[plant.T_OUT_MEAS]
            t_out_true[j] = y[plant.T_OUT]
    finally:
        plant.close()
    if trace is not None:  # the run's series, for a look at where the error comes from
        trace.update(t_s=inp.t_s, t_ref_n=t_ref, t_out_n=t_out, t_out_true_n=t_out_true)
        trace.update(current_a=commands)
    # The record's sample j holds the plant after step j, as the closed loop's does.
    t_s = inp.t_s
    settle = scen.settle_s if t_s[-1] > scen.settle_s else 0.0
    err = metrics.tracking_error(t_s, t_ref, t_out, settle)
    true_err = metrics.tracking_error(t_s, t_ref, t_out_true, settle)
    return {
        "horizon_s": horizon_s,
        "rms_error_pct": err["rms_error_pct"],
        "peak_error_pct": err["peak_error_pct"],
        "rms_error_n": err["rms_error_n"],
        "peak_error_n": err["peak_error_n"],
        "true_rms_error_pct": true_err["rms_error_pct"],
        "true_peak_error_pct": true_err["peak_error_pct"],
        "current_saturated_share": float(
            np.mean(np.abs(commands) >= cfg.board.escon_imax_a * (1 - 1e-9))
        ),
    }


def floor_point(spec_path: str, values: dict, horizons=HORIZONS_S) -> dict:
    """The floor of one sweep point: floor_run at each horizon, the lowest RMS kept (the others
    listed by horizon)."""
    from cosim.config.scenarios import get_scenario  # noqa: PLC0415
    from cosim.studies.sweep.spec import Point, load_spec  # noqa: PLC0415

    spec = load_spec(spec_path)
    run_spec = spec.run_spec(Point(values))
    if run_spec["duration_s"] is None:
        run_spec["duration_s"] = get_scenario(spec.scenario).duration_s
    runs = [floor_run(run_spec, h) for h in horizons]
    best = min(runs, key=lambda r: r["rms_error_pct"])
    return {**best, "by_horizon": {f"{r['horizon_s']:g}": r["rms_error_pct"] for r in runs}}


def load_mode(path: Path) -> dict:
    """A mode's rows by plant_key: a `bowden sweep` --out folder (points/*.json) or the JSON of
    cosim.studies.calibrated_robustness."""
    rows = {}
    if path.is_dir():
        for f in sorted((path / "points").glob("*.json")):
            data = json.loads(f.read_text())
            if data["row"].get("status", "ok") == "ok":
                rows.setdefault(plant_key(data["values"]), []).append(data["row"])
    else:
        data = json.loads(path.read_text())
        for values, row in zip(data["points"], data["rows"], strict=True):
            rows.setdefault(plant_key(values), []).append(row)
    return rows


def summary(points: list[dict], floors: list[dict], modes: dict[str, dict]) -> list[str]:
    """The printed table: the floor's median and worst (on the far-end reading, as the sweep
    scores, and on the true output tension), then each mode beside it with its ratios per plant
    (on the true tension where the mode's rows carry it, else on the reading), and how many
    plants' floors are above the mode's error: there the oracle rang and gives no floor."""
    lines = [
        "| figure | RMS median | RMS worst | peak median | peak worst | ratio to the floor "
        "(median / worst over the plants) |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for prefix, label in (("", "far-end reading"), ("true_", "true output tension")):
        rms = np.array([f[prefix + "rms_error_pct"] for f in floors])
        peak = np.array([f[prefix + "peak_error_pct"] for f in floors])
        lines.append(
            f"| floor (exact model, drive limits), {label} | {np.median(rms):.2f} % | "
            f"{rms.max():.2f} % | {np.median(peak):.2f} % | {peak.max():.2f} % | 1 |"
        )
    for name, rows in modes.items():
        pairs = [(rows.get(plant_key(v)), f) for v, f in zip(points, floors, strict=True)]
        pairs = [(got[0], f) for got, f in pairs if got]
        if not pairs:
            lines.append(f"| {name} | (no point of this spec in its results) | | | | |")
            continue
        prefix = "true_" if all("true_rms_error_pct" in r for r, _ in pairs) else ""
        label = "true output tension" if prefix else "far-end reading"
        mr = np.array([r[prefix + "rms_error_pct"] for r, _ in pairs])
        mp = np.array([r[prefix + "peak_error_pct"] for r, _ in pairs])
        fr = np.array([f[prefix + "rms_error_pct"] for _, f in pairs])
        fp = np.array([f[prefix + "peak_error_pct"] for _, f in pairs])
        ratio_r, ratio_p = mr / fr, mp / fp
        rang = int(np.sum(fr > mr))
        lines.append(
            f"| {name}, {label} ({len(mr)} of {len(points)}) | {np.median(mr):.2f} % | "
            f"{mr.max():.2f} % | {np.median(mp):.2f} % | {mp.max():.2f} % | RMS "
            f"{np.median(ratio_r):.1f}x / {ratio_r.max():.1f}x, peak {np.median(ratio_p):.1f}x / "
            f"{ratio_p.max():.1f}x; the oracle above the mode (no floor) on {rang} |"
        )
    return lines


PROG = "tracking_floor"


def main(argv: list[str] | None = None) -> int:
    from cosim.studies.sweep.spec import SpecError, load_spec  # noqa: PLC0415

    ap = argparse.ArgumentParser(
        prog="python -m cosim.studies.tracking_floor",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--spec", required=True, help="a `bowden sweep` specification (YAML)")
    ap.add_argument("--out", help="keep the floors here (floor.json); default a temporary folder")
    ap.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    ap.add_argument(
        "--mode",
        action="append",
        default=[],
        metavar="NAME=RESULTS",
        help="a mode's results to compare: a `bowden sweep` --out folder or the JSON of "
        "cosim.studies.calibrated_robustness (repeatable)",
    )
    ap.add_argument("--limit", type=int, help="only the first N plants (a quick look)")
    ap.add_argument(
        "--horizons",
        help=f"comma-separated horizons in s (default {','.join(map(str, HORIZONS_S))})",
    )
    args = ap.parse_args(argv)
    try:
        spec = load_spec(args.spec)
    except SpecError as exc:
        print(f"tracking_floor: {exc}", file=sys.stderr)
        return 2
    modes = {}
    for item in args.mode:
        name, sep, path = item.partition("=")
        if not sep or not Path(path).exists():
            print(
                f"tracking_floor: --mode {item}: expected NAME=RESULTS with an existing "
                "sweep folder or JSON file",
                file=sys.stderr,
            )
            return 2
        modes[name] = load_mode(Path(path))
    horizons = HORIZONS_S
    if args.horizons:
        try:
            horizons = tuple(float(h) for h in args.horizons.split(","))
        except ValueError:
            print(f"tracking_floor: --horizons {args.horizons}: not numbers", file=sys.stderr)
            return 2
        if not all(math.isfinite(h) and 0 < h <= 0.2 for h in horizons):
            print("tracking_floor: --horizons: each in (0, 0.2] s", file=sys.stderr)
            return 2
    # One floor per plant and position: the controller's axes (compensator, estimate, gains)
    # do not change it.
    unique: dict[tuple, dict] = {}
    for p in spec.points():
        unique.setdefault(plant_key(p.values), p.values)
    points = list(unique.values())[: args.limit]
    folder = Path(args.out or tempfile.mkdtemp(prefix="bowden-tracking-floor-"))
    folder.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with process_pool(args.workers) as pool:
        floors = list(
            pool.map(floor_point, [str(args.spec)] * len(points), points, [horizons] * len(points))
        )
    for v, f in zip(points, floors, strict=True):
        plant = ", ".join(f"{k[6:]} {v[k]:.4g}" for k in sorted(v) if k.startswith("plant."))
        print(
            f"  {plant or 'nominal plant'} at {v.get('position_m')}: floor RMS "
            f"{f['rms_error_pct']:.2f} %, peak {f['peak_error_pct']:.2f} % (horizon "
            f"{f['horizon_s'] * 1e3:g} ms; true T_out {f['true_rms_error_pct']:.2f} / "
            f"{f['true_peak_error_pct']:.2f} %; current at the limit "
            f"{100 * f['current_saturated_share']:.1f} % of the time)"
        )
    for line in summary(points, floors, modes):
        print(line)
    out = folder / "floor.json"
    out.write_text(json.dumps({"points": points, "floors": floors}, indent=1, default=float))
    print(f"{len(points)} plants, {time.perf_counter() - t0:.0f} s; {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_interruptible(main, PROG))
