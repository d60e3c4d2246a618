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

What kind of bound it is: the error of the best current trajectory found, not a proven minimum
over all trajectories; the true floor is at or below it. On the nominal plant the oracle tracks
fig14 to about 0.01 % of 15 N: the drive and the board leave fig14 essentially no floor
(crossing the dead zone at a reversal takes the 4 A drive a few ms, during which a 0.5 Hz sine's
peak moves by about a mN). On plants with a strong speed-dependent friction (mu_viscous of order
1 s/m and more) and a breakaway, the greedy choice rings (it pulls hard, the cable's speed raises
the friction, the output collapses and overshoots), so a refinement follows it: iterative
learning control on the exact model (REFINE_ITERATIONS) from the best of its seeds, the oracle's
commands and, with --mode, each mode's own closed-loop current on that plant. The floor's RMS is
the lowest true RMS among the oracle and the refinement's iterates, and its peak the lowest true
peak (each reached by a trajectory within the drive's limits, perhaps not the same one). A row
whose floor still exceeds the mode's error says so (ratio below 1): there no floor was found.

    python -m cosim.studies.tracking_floor --spec SPEC.yaml [--out DIR] [--workers 2]
        [--mode NAME=RESULTS ...] [--limit N] [--only I,J,...] [--horizons S,...] [--refine N]

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
from cosim.project.cliargs import count_refused, unwritable
from cosim.project.datafile import DataFileError, read_json
from cosim.studies.workers import MAX_WORKERS, process_pool, run_interruptible

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

# The refinement: iterative learning control (ILC) of the current set values on the exact,
# noiseless model, from the best of its seeds (the oracle's commands and, with --mode, each mode's
# own closed-loop current): every iteration replays the commands, and the set value at t moves by
# REFINE_GAIN / g times the error at t + d, g the plant's static gain (N of T_out per A) and d its
# delay (samples), both read from the response to short current pulses on the seed; the update is
# smoothed by a centred moving average of REFINE_WINDOW_S (the learning filter, which keeps the
# cable's mode out of the update) and put back on the ESCON's levels and PWM periods. P-type ILC
# with a zero-phase filter: D. A. Bristow, M. Tharayil, A. G. Alleyne, "A survey of iterative
# learning control", IEEE Control Systems Magazine 26(3) (2006) 96-114, "Design" (the P-type and
# the Q-filter). The plant's stick-slip makes the iterations' error rise and fall, so the best
# iterate is kept, not the last. Gain, window and iterations were chosen on the tuning set's
# plants (docs/results.md, "The distance to the limit").
REFINE_ITERATIONS = 40
REFINE_GAIN = 0.1
REFINE_WINDOW_S = 0.016
# The pulses that measure g and d: PULSE_A for PULSE_S at these shares of the run; the response
# is read over PULSE_READ_S.
PULSE_A = 0.2
PULSE_S = 0.001
PULSE_AT = (1 / 12, 5 / 12, 9 / 12)
PULSE_READ_S = 0.08


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


class FloorPlant:
    """One point's plant for the floor: the scenario's inputs, the drive's levels, the exact model
    (the point's plant without its sensor noise, which is not predictable) and the scoring."""

    def __init__(self, run_spec: dict):
        from cosim.config.run import SimConfig  # noqa: PLC0415
        from cosim.config.scenarios import sample_inputs  # noqa: PLC0415
        from cosim.engines.native.engine import scenario_of  # noqa: PLC0415

        self.run_spec = run_spec
        self.cfg = SimConfig.from_dict(run_spec["config"], source="point")
        self.scen = scenario_of(run_spec)
        self.inp = sample_inputs(self.scen, self.cfg, run_spec["duration_s"])
        self.dt = 1.0 / self.cfg.sample_rate_hz
        self.ratio = int(round(self.cfg.sample_rate_hz / self.cfg.board.pwm_hz))
        self.levels = _levels(self.cfg.board.escon_imax_a)
        self.n = len(self.inp.t_s)
        self.pos0 = (self.inp.x_m[0], self.inp.y_m[0], self.inp.z_m[0])
        t_s = self.inp.t_s
        self.settle_s = self.scen.settle_s if t_s[-1] > self.scen.settle_s else 0.0
        self.scored = t_s >= self.settle_s
        self.quiet = SimConfig.from_dict(run_spec["config"], source="point")
        self.quiet.plant = {**self.quiet.plant, "noise_std": 0.0}

    def open_model(self, noisy: bool = False):
        from cosim.engines.harness import open_plant  # noqa: PLC0415

        return open_plant(
            self.cfg if noisy else self.quiet, self.run_spec["loop_routing"], self.pos0
        )

    def project(self, commands: np.ndarray) -> np.ndarray:
        """Commands as the drive takes them: one set value a PWM period (the period's mean), on
        the ESCON's nearest level within its range."""
        c = np.asarray(commands, dtype=float)
        whole = len(c) // self.ratio * self.ratio
        per = [c[:whole].reshape(-1, self.ratio).mean(axis=1)]
        if whole < len(c):
            per.append(np.array([c[whole:].mean()]))
        per = np.concatenate(per)
        lv = self.levels
        idx = np.clip(np.round((per - lv[0]) / (lv[1] - lv[0])), 0, len(lv) - 1).astype(int)
        return np.repeat(lv[idx], self.ratio)[: len(c)]

    def replay(self, commands, outputs=("T_OUT",), noisy: bool = False) -> np.ndarray:
        """The plant's outputs (names of cosim.parts.plant.Plant's indices) for these commands,
        sample by sample along the run's path, one column an output (the record's sample j holds
        the plant after step j); the exact model, or with noisy the plant as the point
        configures it."""
        inp = self.inp
        model = self.open_model(noisy)
        cols = [getattr(model, name) for name in outputs]
        out = np.empty((self.n, len(cols)))
        try:
            u = model.u
            for j in range(self.n):
                u[model.CURRENT_CMD] = commands[j]
                u[model.X], u[model.Y], u[model.Z] = inp.x_m[j], inp.y_m[j], inp.z_m[j]
                y = model.step(self.dt)
                out[j] = [y[c] for c in cols]
        finally:
            model.close()
        return out

    def true_out(self, commands: np.ndarray) -> np.ndarray:
        """The exact model's T_out for these commands."""
        return self.replay(commands)[:, 0]

    def phi_rad(self) -> np.ndarray:
        """The plant's wrap angle along the run's path (the exact model at rest: phi depends on
        the end-effector's position only)."""
        return self.replay(np.zeros(self.n), ("PHI",))[:, 0]

    def true_error_n(self, t_out: np.ndarray) -> tuple[float, float]:
        """The RMS and peak of T_ref - T_out (N), scored as figures() scores."""
        from cosim.results import metrics  # noqa: PLC0415

        err = metrics.tracking_error(self.inp.t_s, self.inp.t_ref_n, t_out, self.settle_s)
        return err["rms_error_n"], err["peak_error_n"]

    def figures(self, commands: np.ndarray) -> dict:
        """The commands replayed on the plant as the point configures it (its sensor noise too),
        scored as the sweep scores a run (cosim.results.metrics.tracking_error after the
        scenario's settle time, in % of max T_ref): on the far-end reading and the true T_out."""
        from cosim.results import metrics  # noqa: PLC0415

        inp = self.inp
        t_out, t_out_true = self.replay(commands, ("T_OUT_MEAS", "T_OUT"), noisy=True).T
        err = metrics.tracking_error(inp.t_s, inp.t_ref_n, t_out, self.settle_s)
        true_err = metrics.tracking_error(inp.t_s, inp.t_ref_n, t_out_true, self.settle_s)
        imax = self.cfg.board.escon_imax_a
        return {
            "rms_error_pct": err["rms_error_pct"],
            "peak_error_pct": err["peak_error_pct"],
            "rms_error_n": err["rms_error_n"],
            "peak_error_n": err["peak_error_n"],
            "true_rms_error_pct": true_err["rms_error_pct"],
            "true_peak_error_pct": true_err["peak_error_pct"],
            "current_saturated_share": float(np.mean(np.abs(commands) >= imax * (1 - 1e-9))),
        }


def breakaway_peak_bound_pct(fp: FloorPlant) -> float | None:
    """A lower bound on the true peak error (% of max T_ref) that a breakaway leaves any
    trajectory, under the sharp law: every strand breaks loose at once (dead_zone_spread 0).

    Derivation (fmu/README.md, "Static friction"): held after a reversal, the output keeps the
    level T_s it had; when the cable breaks loose it jumps to T_s e^(-b phi) (releasing; up by
    e^(+b phi) pulling), b = mu_static_excess. At the reference's maximum R the output is at some
    O, and it cannot fall before its first release jump, from a level T_s >= O; across the jump
    the error changes by c T_s, c = 1 - e^(-b phi), so one side of it is at least c T_s / 2 off.
    Hence peak >= max(R - O, c O / 2) >= R (c / 2) / (1 + c / 2) for every O. phi is the least
    wrap angle of the run (the smallest jump). None without a breakaway. A bound where its
    assumptions hold (`breakaway_bound_holds`); elsewhere an estimate: with a spread the strands
    break loose one after another, and with friction that grows with the cable's speed
    (mu_viscous) the output can also fall while pulling, by pulling faster."""
    b = float(fp.cfg.plant.get("mu_static_excess", 0.0))
    if b <= 0.0:
        return None
    phi = float(np.min(fp.phi_rad()))
    c = 1.0 - math.exp(-b * phi)
    return 100.0 * (c / 2.0) / (1.0 + c / 2.0)


def breakaway_bound_holds(fp: FloorPlant) -> bool:
    """Whether breakaway_peak_bound_pct's assumptions hold on the point's plant: the sharp law
    (dead_zone_spread 0) and no friction with the cable's speed in either form (mu_viscous,
    mu_viscous_tension_rate 0)."""
    p = fp.cfg.plant
    names = ("dead_zone_spread", "mu_viscous", "mu_viscous_tension_rate")
    return all(float(p.get(name, 0.0)) == 0.0 for name in names)


def oracle_commands(fp: FloorPlant, horizon_s: float) -> np.ndarray:
    """The greedy oracle's current set values: every PWM period the level that brings the exact
    model's true T_out to T_ref at the horizon's end (module docstring)."""
    inp, dt, levels, n, ratio = fp.inp, fp.dt, fp.levels, fp.n, fp.ratio
    h_samples = max(1, int(round(horizon_s / dt)))
    pred_samples = max(1, int(round(PREDICTION_STEP_S / dt)))
    step_a = levels[1] - levels[0]
    slew_levels = (
        len(levels) if SLEW_A_PER_S is None else max(1, int(SLEW_A_PER_S * ratio * dt / step_a))
    )
    model = fp.open_model()
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
                # (what is scored is the per-sample replay).
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
    return commands


def plant_response(fp: FloorPlant, commands: np.ndarray, t_out: np.ndarray) -> tuple[float, int]:
    """The static gain g (N of true T_out per A of set value) and delay d (samples) of the plant
    along these commands: the mean response to PULSE_A held for PULSE_S at PULSE_AT of the run,
    g its sum per A-sample, d the sample of its largest magnitude."""
    width = max(fp.ratio, int(round(PULSE_S / fp.dt)))
    read = int(round(PULSE_READ_S / fp.dt))
    responses = []
    for share in PULSE_AT:
        k = int(share * fp.n) // fp.ratio * fp.ratio
        if k + width + read > fp.n:
            continue
        pulsed = commands.copy()
        pulsed[k : k + width] = np.clip(
            pulsed[k : k + width] + PULSE_A, fp.levels[0], fp.levels[-1]
        )
        area = float(np.sum(pulsed[k : k + width] - commands[k : k + width]))
        if area <= 0:
            continue
        responses.append((fp.true_out(pulsed) - t_out)[k : k + read] / area)
    if not responses:
        raise ValueError("the run is too short for the refinement's pulses")
    h = np.mean(responses, axis=0)
    return float(np.sum(h)), int(np.argmax(np.abs(h)))


def refine(
    fp: FloorPlant,
    seed: np.ndarray,
    iterations: int = REFINE_ITERATIONS,
    gain: float = REFINE_GAIN,
    window_s: float = REFINE_WINDOW_S,
) -> dict:
    """P-type ILC of the commands on the exact model from `seed` (see REFINE_ITERATIONS): the
    iterate of the lowest true RMS and the one of the lowest true peak, each with its figures on
    the exact model (N), and the iterations' true RMS (N)."""
    from scipy.ndimage import uniform_filter1d  # noqa: PLC0415

    cmd = fp.project(seed)
    out = fp.true_out(cmd)
    g, d = plant_response(fp, cmd, out)
    if not g > 0:
        raise ValueError(f"the plant's static gain along the seed is {g:.3g} N/A, not positive")
    window = max(1, int(round(window_s / fp.dt)))
    imax = fp.levels[-1]
    ref = fp.inp.t_ref_n

    rms, peak = fp.true_error_n(out)
    best_rms, best_peak = (rms, cmd), (peak, cmd)
    history = [rms]
    cont = cmd.astype(float)
    for _ in range(iterations):
        e = ref - out
        e[~fp.scored] = 0.0
        ahead = np.concatenate([e[d:], np.zeros(d)])
        cont = np.clip(
            uniform_filter1d(cont + (gain / g) * ahead, window, mode="nearest"), -imax, imax
        )
        cmd = fp.project(cont)
        out = fp.true_out(cmd)
        rms, peak = fp.true_error_n(out)
        history.append(rms)
        if rms < best_rms[0]:
            best_rms = (rms, cmd)
        if peak < best_peak[0]:
            best_peak = (peak, cmd)
    return {
        "rms_commands": best_rms[1],
        "peak_commands": best_peak[1],
        "gain_n_per_a": g,
        "delay_samples": d,
        "history_rms_n": history,
    }


def seed_commands(spec_path: str, values: dict) -> np.ndarray:
    """A mode's own closed-loop current on one of its points (the native engine's record, as the
    sweep runs the point): a seed for the refinement."""
    from cosim.studies.sweep.run import run_record  # noqa: PLC0415
    from cosim.studies.sweep.spec import Point, load_spec  # noqa: PLC0415

    _, fixed, _ = run_record(load_spec(spec_path), Point(values))
    return np.asarray(fixed["current_A"], dtype=float)


def floor_point(
    spec_path: str,
    values: dict,
    horizons=HORIZONS_S,
    seeds: dict | None = None,
    iterations: int = REFINE_ITERATIONS,
) -> dict:
    """The floor of one sweep point: the oracle at each horizon (the lowest RMS kept, the others
    listed by horizon), then, with iterations > 0, the refinement from the best seed (the
    oracle's commands, or a mode's own run: seeds maps a mode's name to its values of this
    plant). The floor's RMS is the lowest true RMS of the trajectories tried, and its peak the
    lowest true peak; each figure is reached by a trajectory within the drive's limits."""
    from cosim.config.scenarios import get_scenario  # noqa: PLC0415
    from cosim.studies.sweep.spec import Point, load_spec  # noqa: PLC0415

    spec = load_spec(spec_path)
    run_spec = spec.run_spec(Point(values))
    if run_spec["duration_s"] is None:
        run_spec["duration_s"] = get_scenario(spec.scenario).duration_s
    fp = FloorPlant(run_spec)
    runs = []
    for h in horizons:
        commands = oracle_commands(fp, h)
        runs.append(({"horizon_s": h, **fp.figures(commands)}, commands))
    oracle, oracle_cmd = min(runs, key=lambda r: r[0]["rms_error_pct"])
    by_horizon = {f"{r['horizon_s']:g}": r["rms_error_pct"] for r, _ in runs}
    common = {
        "horizon_s": oracle["horizon_s"],
        "by_horizon": by_horizon,
        "oracle": dict(oracle),
        "breakaway_peak_bound_pct": breakaway_peak_bound_pct(fp),
        "breakaway_bound_holds": breakaway_bound_holds(fp),
    }
    if iterations <= 0:
        return {**oracle, **common, "from": "oracle"}
    # Each candidate's figures on the plant (its sensor noise is on the readings only, so the
    # true T_out is the exact model's): the seed is the one of the lowest true RMS.
    tried = [(oracle, "oracle", oracle_cmd)]
    for name, mode_values in (seeds or {}).items():
        cmd = fp.project(seed_commands(spec_path, mode_values))
        tried.append((fp.figures(cmd), f"mode {name}", cmd))
    _, seed_name, seed = min(tried, key=lambda r: r[0]["true_rms_error_pct"])
    ref = refine(fp, seed, iterations)
    for key in ("rms_commands", "peak_commands"):
        tried.append((fp.figures(ref[key]), f"refined from {seed_name}", None))
    best_rms = min(tried, key=lambda r: r[0]["true_rms_error_pct"])
    best_peak = min(tried, key=lambda r: r[0]["true_peak_error_pct"])
    result = {**best_rms[0], **common, "from": best_rms[1], "peak_from": best_peak[1]}
    for key in ("peak_error_pct", "peak_error_n", "true_peak_error_pct"):
        result[key] = best_peak[0][key]
    result["seeds_true_rms_pct"] = {
        n: f["true_rms_error_pct"] for f, n, c in tried if c is not None
    }
    result["refine"] = {k: ref[k] for k in ("gain_n_per_a", "delay_samples", "history_rms_n")}
    return result


def _mode_points(path: Path) -> list[tuple[dict, dict]]:
    """A mode's (values, row) pairs: a `bowden sweep` --out folder (points/*.json, its points
    that ran) or the JSON of cosim.studies.calibrated_robustness. DataFileError, one line naming
    the file, when it is neither."""

    def pair(values, row, name: str) -> tuple[dict, dict]:
        if not (
            isinstance(values, dict)
            and isinstance(row, dict)
            and all(
                isinstance(row.get(k), (int, float)) for k in ("rms_error_pct", "peak_error_pct")
            )
        ):
            raise DataFileError(f"{name}: a point without its values or its scored row")
        return values, row

    if path.is_dir():
        files = sorted((path / "points").glob("*.json"))
        if not files:
            raise DataFileError(f"{path}: no sweep's points in it (points/*.json)")
        pairs = []
        for f in files:
            data = read_json(f, "a sweep's point")
            if not isinstance(data, dict):
                raise DataFileError(f"{f}: not a sweep's point")
            if isinstance(data.get("row"), dict) and data["row"].get("status", "ok") == "ok":
                pairs.append(pair(data.get("values"), data["row"], str(f)))
        return pairs
    data = read_json(path, "a study's results")
    points = data.get("points") if isinstance(data, dict) else None
    rows = data.get("rows") if isinstance(data, dict) else None
    if not (isinstance(points, list) and isinstance(rows, list) and len(points) == len(rows)):
        raise DataFileError(
            f"{path}: not the results of cosim.studies.calibrated_robustness (its points and "
            "rows, one row per point)"
        )
    return [pair(v, r, str(path)) for v, r in zip(points, rows, strict=True)]


def load_mode(path: Path) -> dict:
    """A mode's rows by plant_key."""
    rows: dict = {}
    for values, row in _mode_points(path):
        rows.setdefault(plant_key(values), []).append(row)
    return rows


def load_mode_values(path: Path) -> dict:
    """A mode's run values by plant_key (its first point of each plant): what the refinement
    re-runs for its seed."""
    values: dict = {}
    for v, _ in _mode_points(path):
        values.setdefault(plant_key(v), v)
    return values


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
        "--only",
        metavar="I,J,...",
        help="only these plants, by their place in the spec's list of plants (0 the first); "
        "after --limit",
    )
    ap.add_argument(
        "--refine",
        type=int,
        default=REFINE_ITERATIONS,
        metavar="N",
        help=f"iterations of the refinement on the exact model (default {REFINE_ITERATIONS}; "
        "0: the oracle alone)",
    )
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
    if not 0 <= args.refine <= 1000:
        print(f"tracking_floor: --refine {args.refine}: iterations in [0, 1000]", file=sys.stderr)
        return 2
    refused = (
        count_refused("--limit", args.limit, 1)
        or count_refused("--workers", args.workers, 1, MAX_WORKERS)
        or (unwritable(Path(args.out), folder=True) if args.out else None)
    )
    if refused is not None:
        print(f"tracking_floor: {refused}", file=sys.stderr)
        return 2
    modes, mode_values = {}, {}
    for item in args.mode:
        name, sep, path = item.partition("=")
        if not sep or not name or not Path(path).exists():
            print(
                f"tracking_floor: --mode {item}: expected NAME=RESULTS with an existing "
                "sweep folder or JSON file",
                file=sys.stderr,
            )
            return 2
        if name in modes:
            print(f"tracking_floor: --mode {item}: a second mode named {name}", file=sys.stderr)
            return 2
        try:
            modes[name] = load_mode(Path(path))
            mode_values[name] = load_mode_values(Path(path))
        except DataFileError as exc:
            print(f"tracking_floor: --mode {name}: {exc}", file=sys.stderr)
            return 2
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
    if args.only:
        try:
            picks = [int(i) for i in args.only.split(",")]
        except ValueError:
            print(f"tracking_floor: --only {args.only}: not whole numbers", file=sys.stderr)
            return 2
        bad = [i for i in picks if not 0 <= i < len(points)]
        if bad:
            print(
                f"tracking_floor: --only: {bad[0]} is not a plant of this spec (0 .. "
                f"{len(points) - 1})",
                file=sys.stderr,
            )
            return 2
        points = [points[i] for i in picks]
    seeds = [
        {name: vals[plant_key(p)] for name, vals in mode_values.items() if plant_key(p) in vals}
        for p in points
    ]
    folder = Path(args.out or tempfile.mkdtemp(prefix="bowden-tracking-floor-"))
    folder.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with process_pool(args.workers) as pool:
        floors = list(
            pool.map(
                floor_point,
                [str(args.spec)] * len(points),
                points,
                [horizons] * len(points),
                seeds,
                [args.refine] * len(points),
            )
        )
    for v, f in zip(points, floors, strict=True):
        plant = ", ".join(f"{k[6:]} {v[k]:.4g}" for k in sorted(v) if k.startswith("plant."))
        print(
            f"  {plant or 'nominal plant'} at {v.get('position_m')}: floor RMS "
            f"{f['rms_error_pct']:.2f} %, peak {f['peak_error_pct']:.2f} % (horizon "
            f"{f['horizon_s'] * 1e3:g} ms; true T_out {f['true_rms_error_pct']:.2f} / "
            f"{f['true_peak_error_pct']:.2f} %; current at the limit "
            f"{100 * f['current_saturated_share']:.1f} % of the time; {f['from']}"
            + (f", peak {f['peak_from']}" if f.get("peak_from") else "")
            + (
                f"; the breakaway's {'bound' if f['breakaway_bound_holds'] else 'estimate'} "
                f"on the peak: {f['breakaway_peak_bound_pct']:.2f} %"
                if f.get("breakaway_peak_bound_pct") is not None
                else ""
            )
            + ")"
        )
    for line in summary(points, floors, modes):
        print(line)
    out = folder / "floor.json"
    out.write_text(json.dumps({"points": points, "floors": floors}, indent=1, default=float))
    print(f"{len(points)} plants, {time.perf_counter() - t0:.0f} s; {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_interruptible(main, PROG))
