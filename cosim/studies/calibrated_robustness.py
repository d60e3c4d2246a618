"""Sensorless after calibration: `bowden bench calibrate` on each plant of a sweep specification,
then the sweep's runs with what it proposes and the online estimate off (the paper's setting: no
far-end sensor while running). Row (c) of the table in docs/results.md ("With the online
friction estimate"), and the sensorless mode of the random plants.

For every plant of the specification (its `plant.*` axes, over the spec's base `config: plant`;
a grid's plant axes are crossed, a random spec draws one plant per point):

1. `calibrate` (cosim.bench.rig.calibrate, without --apply: its proposal) on the emulated
   controller (the stepped emulator, at the home position) with that plant: the tare of the
   far-end load cell, the identification, the audit, and the compensator values it proposes
   (comp.mu, comp.offset_n, comp.mu_slope_per_n, comp.dead_zone_spread, comp.breakaway,
   comp.slack_tension_n, comp.mu_per_inlet_rate),
   clipped to the compensator's limits where they lie beyond (without calibrate's prediction
   runs, which only print what it expects);
2. the spec's runs of that plant (cosim.studies.sweep.run: fig14 6 s, board interface, the
   native engine; the point's own position and compensator) with the compensator set to them,
   compensator.phi_rad the device's that calibrate scaled them to (run_values), and
   compensator.est_enable 0.

With `--map` (or `--map "X,Y,Z;..."`) calibrate also maps the bending angle over those
positions (cosim.bench.rig.bend_map, the defaults without a value), and each run's compensator
takes the map's angle at the run's position, as the host that places the end-effector would set
it (docs/results.md, "The bending angle's map").

With `--truth KEY` (repeatable, or `all`) a run takes the plant's own value of that compensator
key in place of calibrate's proposal (true_compensator: the FMU's parameters mapped to the
compensator's), which says what calibrate's finding of it costs; with all of them, what the
compensator's law alone can do on the plant.

With `--params FILE` (a `bowden sim --params` file holding `compensator` and `controller`
only) and `--set KEY=VALUE` (a compensator.* or controller.* field of that file, repeatable,
after the file), those settings are laid over the runs' configuration last, over calibrate's
proposals and the estimate's 0: e.g. the far-end mode after calibrate, `--set
compensator.corr_enable=1 --set compensator.corr_rev_enable=1 --set
controller.kv_a_s_per_n=0.001` (docs/results.md, "The far-end mode after calibrate"). They are
checked as a params file is, before anything runs: a bad key or value is one line, exit 2.

Prints each plant's proposal and decisions, and the table: RMS and peak error in % of the 15 N
maximum, median and worst over the runs, scored as the sweep scores a run (T_ref - T_out as the
far-end load cell reads it) and on the true output tension (T_out without the cell's offset,
noise or lag: what the cable delivers). The tare makes the two differ by the cell's offset: the
compensator aims the cable's tension at T_ref, not the cell's reading. The JSON
(calibrated_robustness.json: points, rows, calibrations) joins cosim.studies.tracking_floor
(`--mode sensorless=FILE`).

    python -m cosim.studies.calibrated_robustness [--spec SPEC.yaml] [--workers 2] [--out DIR]
        [--limit N] [--no-tare] [--reuse] [--calibrations DIR] [--leave KEY ...] [--truth KEY ...]
        [--params FILE] [--set KEY=VALUE ...] [--map [X,Y,Z;...]] [--score-from-s S]
        [--breakaway-share K] [--slack-sources S,...] [--viscous-sources S,...]
        [--breakaway-sources S,...]

Without --spec: cosim/studies/sweep/examples/robustness_estimator.yaml (the robustness grid:
plant mu, cable_EA and current_bandwidth at -20 % / nominal / +20 %, 27 plants, five positions).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from cosim.bench.rig import CALIBRATED_PARAMS
from cosim.project.cliargs import count_refused, shown, unwritable
from cosim.project.paths import PACKAGE_DIR
from cosim.studies.workers import MAX_WORKERS, process_pool, run_interruptible

SPEC = PACKAGE_DIR / "studies" / "sweep" / "examples" / "robustness_estimator.yaml"
COMP_KEYS = tuple(f"compensator.{n.removeprefix('comp.')}" for n in CALIBRATED_PARAMS)
# The audit's records a term seen by the audit can be proposed from (calibrate.seen_by_audit).
SOURCES = ("finding", "joint", "candidate", "any_round")


# What --params and --set may lay over the runs: the spec owns the plant, the board and the
# rates (its points and base config), calibrate the plant's own values.
OVERLAY_GROUPS = ("compensator", "controller")


def overlay_of(sets: list[str], params: str | None = None) -> dict:
    """The settings laid over every run, as sweep keys (`compensator.corr_enable`: 1, ...): the
    `compensator` and `controller` of the params file `params`, then each `KEY=VALUE` of `sets`.
    ValueError, one line naming the file or the item and what was expected, when one is not a
    field of those two groups or lies outside its range (cosim.config.run's checks)."""
    from cosim.config.run import SimConfig  # noqa: PLC0415
    from cosim.project.datafile import DataFileError, read_json  # noqa: PLC0415

    nested: dict[str, dict] = {}
    source = []
    if params is not None:
        name = shown(params)
        try:
            data = read_json(params, "a params file (a JSON object)", "valid JSON", name=name)
        except DataFileError as exc:
            raise ValueError(f"--params: {exc}") from None
        if not isinstance(data, dict):
            raise ValueError(f"--params: {name}: expected a JSON object at the top level")
        for key, value in data.items():
            if key not in OVERLAY_GROUPS:
                raise ValueError(
                    f"--params: {name}: {key!r} is not this study's to set (the spec gives the "
                    f"plant, the board and the rates); only {' and '.join(OVERLAY_GROUPS)}"
                )
            if not isinstance(value, dict):
                raise ValueError(f"--params: {name}: {key} must be a JSON object")
            nested[key] = dict(value)
        source.append(f"--params {name}")
    for item in sets:
        key, sep, text = item.partition("=")
        group, dot, field = key.partition(".")
        if not sep or not dot or group not in OVERLAY_GROUPS or not field:
            raise ValueError(
                f"--set: expected compensator.FIELD=VALUE or controller.FIELD=VALUE; got "
                f"{shown(item)}"
            )
        try:
            value = json.loads(text)
        except json.JSONDecodeError:
            value = text  # from_dict names the field and its range
        nested.setdefault(group, {})[field] = value
        source.append("--set")
    if nested:
        SimConfig.from_dict(nested, source=" / ".join(dict.fromkeys(source)))
    return {f"{g}.{k}": v for g, fields in nested.items() for k, v in fields.items()}


def run_values(
    values: dict, comp: dict, leave=(), overlay: dict | None = None, truth: dict | None = None
) -> dict:
    """A run's sweep values: the spec point's, the estimate off, the bending angle calibrate
    scaled its proposals to (`comp["device_phi_rad"]`, the device's comp.phi_rad, when known),
    calibrate's proposals `comp` (but the keys in `leave`), the plant's own values `truth`
    (true_compensator) in place of those proposals, then the overlay (overlay_of), which wins
    over all.

    The angle: only mu*phi is observed, so calibrate proposes mu (and the slope, the breakaway,
    the rate term) for the device's phi; the sweep's own default (resolve_phi: the plant's phi at
    home, with its bending-angle errors) would count the home position's bending error twice,
    once in calibrate's mu*phi and once in the angle. With calibrate's map of the bending angle
    (`comp["bend_map"]`, cosim.bench.rig.bend_map) the angle is the map's at the run's position,
    as the host that places the end-effector would set it."""
    fixed = {n: comp[n] for n in COMP_KEYS if n not in leave}
    phi = comp.get("device_phi_rad")
    if phi is not None and comp.get("bend_map") and values.get("position_m") is not None:
        from cosim.bench.rig.bend_map import BendMap  # noqa: PLC0415

        # the host sets the angle at the run's position from calibrate's map
        phi = BendMap.from_dict(comp["bend_map"]).phi_at(phi, values["position_m"])
    angle = {} if phi is None else {"compensator.phi_rad": phi}
    return {
        **values,
        "compensator.est_enable": 0,
        **angle,
        **fixed,
        **(truth or {}),
        **(overlay or {}),
    }


def true_compensator(
    plant: dict, phi_plant_rad: float, phi_comp_rad: float, keys=COMP_KEYS
) -> dict:
    """The compensator values that stand for the plant's own (FMU parameters `plant`, the FMU's
    defaults where absent), as sweep keys, for `keys` of COMP_KEYS: what calibrate would propose
    if it found the plant exactly. phi_plant_rad is the bending angle the plant's friction sees
    at the run's position (its `phi` output, with the bending-angle errors), phi_comp_rad the
    compensator's (cosim.engines.reference.resolve_phi: the same unless the run sets
    compensator.phi_rad); the terms proportional to phi are scaled by their ratio, since only
    their product with phi acts (fmu/README.md, "Effects"; comp.h).

    - mu, mu_slope_per_n, breakaway: the plant's mu, mu_tension_slope, mu_static_excess, times
      phi_plant / phi_comp; the slope then clipped to the compensator's range (|s| <= 1/128 and
      mu + s * 48 N >= 0: comp.h, COMP_MU_SLOPE_RANGE_N);
    - offset_n: 0 (the tare takes the far-end cell's offset; the plant has no tension offset);
    - dead_zone_spread: the plant's (a log spread: a ratio of widths, the same at any phi);
    - slack_tension_n: the plant's slack_tension (a tension at the inlet);
    - mu_per_inlet_rate: the plant's mu_viscous_tension_rate plus its mu_viscous through the
      cable's compliance in the sheath, the mean of the two branches'
      (cosim.parts.firmware.mu_per_inlet_rate_of_cable_speed at the plant's mu, phi, sheath
      length, cable_EA and load-cell stiffness), times phi_plant / phi_comp, clipped to
      [0, 1/16] s/N.

    The laws the compensator does not share with the FMU stay: one breakaway and one rate term
    for every strand and both branches, the FMU's 32 strands against the compensator's 8 plays."""
    from cosim.parts.firmware import (  # noqa: PLC0415
        MU_SLOPE_RANGE_N,
        mu_per_inlet_rate_of_cable_speed,
    )
    from cosim.parts.plant import fmu_variables  # noqa: PLC0415

    fmu = fmu_variables()

    def get(name: str) -> float:
        return float(plant.get(name, fmu[name].start))

    k = phi_plant_rad / phi_comp_rad
    mu = get("mu") * k
    slope = get("mu_tension_slope") * k
    slope = min(max(slope, -mu / MU_SLOPE_RANGE_N, -1 / 128), 1 / 128)
    up, dn = mu_per_inlet_rate_of_cable_speed(
        get("mu_viscous"),
        get("mu"),
        phi_plant_rad,
        get("sheath_length"),
        get("cable_EA"),
        get("loadcell_stiffness"),
    )
    rate = (get("mu_viscous_tension_rate") + (up + dn) / 2) * k
    every = {
        "compensator.mu": mu,
        "compensator.offset_n": 0.0,
        "compensator.mu_slope_per_n": slope,
        "compensator.dead_zone_spread": get("dead_zone_spread"),
        "compensator.breakaway": get("mu_static_excess") * k,
        "compensator.slack_tension_n": get("slack_tension"),
        "compensator.mu_per_inlet_rate": min(max(rate, 0.0), 1 / 16),
    }
    return {n: every[n] for n in keys}


def phi_of_point(spec_path: str, values: dict) -> tuple[float, float]:
    """The bending angles of a spec point's run: the plant's friction's (its FMU's `phi` output
    at the point's position, else the scenario's start) and the compensator's (resolve_phi: the
    plant's at the scenario's start, where the sweep calibrates it once), in rad."""
    from cosim.config.run import SimConfig  # noqa: PLC0415
    from cosim.config.scenarios import get_scenario  # noqa: PLC0415
    from cosim.engines.harness import open_plant  # noqa: PLC0415
    from cosim.engines.reference import resolve_phi  # noqa: PLC0415
    from cosim.studies.sweep.spec import Point, load_spec  # noqa: PLC0415

    spec = load_spec(spec_path)
    run_spec = spec.run_spec(Point(values))
    cfg = SimConfig.from_dict(run_spec["config"], source="point")
    scen = get_scenario(spec.scenario)
    position = run_spec.get("position_m")
    if position is None:
        x, y, z = scen.trajectory(np.zeros(1))
        position = (x[0], y[0], z[0])
    plant = open_plant(cfg, run_spec["loop_routing"], tuple(position))
    try:
        phi_plant = float(plant.y[plant.PHI])
    finally:
        plant.close()
    return phi_plant, resolve_phi(scen, cfg, run_spec["loop_routing"])


def plant_of(spec, values: dict) -> dict:
    """A point's plant: the spec's base `config: plant` with the point's plant.* axes (FMU
    parameter names)."""
    plant = dict(spec.config.get("plant") or {})
    plant.update({k.split(".", 1)[1]: v for k, v in values.items() if k.startswith("plant.")})
    return plant


def calibrate_plant(
    plant: dict,
    folder: str,
    tare: bool = True,
    reuse: bool = False,
    breakaway_share: float | None = None,
    slack_sources: tuple[str, ...] | None = None,
    viscous_sources: tuple[str, ...] | None = None,
    breakaway_sources: tuple[str, ...] | None = None,
    map_positions: tuple = (),
) -> dict:
    """The compensator values `calibrate` proposes for an emulated plant (FMU parameters), as
    the sweep's config keys (compensator.mu, ...), the decision and reason of each, and the
    tare's reading. reuse: take the calibration.json a run before left in `folder`; when it
    holds no breakaway proposal (a calibration made before calibrate proposed one), or
    `breakaway_share` asks for another share than calibrate's, the breakaway is proposed from
    its findings as calibrate does (cosim.bench.rig.calibrate.breakaway_of_report); the same for
    the slack (slack_of_report, from the report and its audit's record), from `slack_sources`
    rather than calibrate's SLACK_SOURCES when given, the rate term (viscous_of_report) from
    `viscous_sources` rather than VISCOUS_SOURCES, and the breakaway from `breakaway_sources`
    rather than BREAKAWAY_SOURCES. With `map_positions`, calibrate's map of the bending angle
    over them (cosim.bench.rig.bend_map; its bend_map.json reused with `reuse`) as `bend_map`."""
    from cosim.bench.link.api import Bench  # noqa: PLC0415
    from cosim.bench.rig import calibrate as cal  # noqa: PLC0415

    t0 = time.perf_counter()
    done = Path(folder) / "calibration.json"
    if reuse and done.is_file():
        report = json.loads(done.read_text())
    else:
        with Bench(emulate=True, plant=plant) as bench:
            opts = cal.Options(out_dir=Path(folder), audit_plots=False, tare=tare, predict=False)
            report = cal.run_calibration(
                bench.client, bench.info(), opts, say=lambda _: None
            ).report
    names = {c["name"] for c in report["changes"]}
    before: dict = {}

    def folder_before() -> dict:  # the device's values, read once and only when needed
        if not before:
            before.update(_device_before(Path(folder)))
        return before

    # the audit's rounds; a calibration kept without its audit's record gives its findings and
    # joint fit alone
    record = Path(folder) / "audit" / "audit.json"
    audit = json.loads(record.read_text()) if record.is_file() else {}
    if (
        "comp.breakaway" not in names
        or breakaway_share is not None
        or breakaway_sources is not None
    ):
        share = cal.BREAKAWAY_SHARE if breakaway_share is None else breakaway_share
        sources = cal.BREAKAWAY_SOURCES if breakaway_sources is None else breakaway_sources
        b = cal.breakaway_of_report(report, folder_before(), share, audit, sources)
        _replace_change(report, b)
    if "comp.slack_tension_n" not in names or slack_sources is not None:
        sources = cal.SLACK_SOURCES if slack_sources is None else slack_sources
        _replace_change(report, cal.slack_of_report(report, audit, folder_before(), sources))
    if "comp.mu_per_inlet_rate" not in names or viscous_sources is not None:
        sources = cal.VISCOUS_SOURCES if viscous_sources is None else viscous_sources
        _replace_change(report, cal.viscous_of_report(report, audit, folder_before(), sources))
    out = {}
    for c in report["changes"]:
        key = "compensator." + c["name"].split(".", 1)[1]
        applies = c["status"] in ("change", "clipped") and c["proposed"] is not None
        out[key] = c["proposed"] if applies else c["current"]
    out["decisions"] = {c["name"]: c["status"] for c in report["changes"]}
    out["reasons"] = {
        c["name"]: c["reason"] for c in report["changes"] if c["status"] in ("clipped", "refused")
    }
    out["tare_n"] = report["tare"]["offset_n"]
    out["device_phi_rad"] = report.get("device_phi_rad")  # what the proposals are scaled to
    if map_positions:
        out["bend_map"] = _bend_map(plant, Path(folder), report, audit, map_positions, reuse)
    out["wall_s"] = time.perf_counter() - t0
    return out


def _bend_map(plant: dict, folder: Path, report: dict, audit: dict, positions, reuse: bool):
    """calibrate's map of the bending angle (cosim.bench.rig.bend_map) for an emulated plant
    whose calibration is in `folder`, as a dict."""
    from cosim.bench.rig import bend_map  # noqa: PLC0415
    from cosim.bench.rig import calibrate as cal  # noqa: PLC0415
    from cosim.parts.geometry import bending_angle  # noqa: PLC0415

    path = folder / bend_map.FILE
    if reuse and path.is_file():
        m = bend_map.read(path)
        if [tuple(p.position_m) for p in m.points] == [tuple(map(float, p)) for p in positions]:
            return m.to_dict()
    opts = cal.Options(out_dir=folder, audit_plots=False, predict=False)
    phi_home = float(bending_angle(*opts.position_m, opts.sheath_length_m, opts.loop_routing))
    try:
        m = cal.make_bend_map(
            bend_map.emulated_at(plant, opts.loop_routing),
            positions,
            dict(audit["extended"]["params"]),
            phi_home,
            float(report["tare"]["offset_n"]),
            opts,
            say=lambda _: None,
        )
    except bend_map.BendMapError as exc:
        print(f"  {folder.name}: {exc}: the runs keep calibrate's angle", file=sys.stderr)
        return None
    return m.to_dict()


def _replace_change(report: dict, c) -> None:
    """A proposal decided again (a calibrate.Change) in place of the report's own."""
    report["changes"] = [x for x in report["changes"] if x["name"] != c.name]
    report["changes"].append(
        {
            "name": c.name,
            "status": c.status,
            "proposed": c.proposed,
            "current": c.current,
            "reason": c.reason,
        }
    )


def _device_before(folder: Path) -> dict:
    """The device's values a calibration started from, by name: its before.json (written by
    calibrate with --apply), else the emulated controller's defaults, which every calibration of
    this study starts from (a fresh emulator per plant)."""
    from cosim.bench.link.messages import PARAM_BY_NAME  # noqa: PLC0415
    from cosim.bench.link.protocol import value_from_word  # noqa: PLC0415

    before = folder / "before.json"
    if before.is_file():
        words = {n: e["word"] for n, e in json.loads(before.read_text())["params"].items()}
    else:
        from cosim.bench.emulate.emulator import SteppedLink  # noqa: PLC0415
        from cosim.bench.emulate.host_device import ChainConfig  # noqa: PLC0415
        from cosim.bench.link.client import BenchClient  # noqa: PLC0415

        client = BenchClient(SteppedLink(ChainConfig()))
        client.connect()
        try:
            words = client.params()
        finally:
            client.link.close()
    return {n: value_from_word(PARAM_BY_NAME[n], w) for n, w in words.items() if n in PARAM_BY_NAME}


def run_point(spec_path: str, values: dict, score_from_s: float | None = None) -> dict:
    """One run of the sweep (cosim.studies.sweep.run's), scored on the far-end reading as the
    sweep does and on the true output tension; from `score_from_s` rather than the scenario's
    settling time when given (e.g. once every reversal has been met before)."""
    from cosim.config.run import SimConfig  # noqa: PLC0415
    from cosim.config.scenarios import get_scenario  # noqa: PLC0415
    from cosim.engines import experiment as sim  # noqa: PLC0415
    from cosim.engines.native import engine  # noqa: PLC0415
    from cosim.engines.reference import resolve_phi  # noqa: PLC0415
    from cosim.results import metrics  # noqa: PLC0415
    from cosim.studies.sweep.run import FIGURES  # noqa: PLC0415
    from cosim.studies.sweep.spec import Point, load_spec  # noqa: PLC0415

    spec = load_spec(spec_path)
    run_spec = spec.run_spec(Point(values))
    cfg = SimConfig.from_dict(run_spec["config"], source="point")
    scen_base = get_scenario(spec.scenario)
    run_spec["phi_rad"] = resolve_phi(scen_base, cfg, run_spec["loop_routing"])
    run_spec["config"] = cfg.to_dict()
    if run_spec["duration_s"] is None:
        run_spec["duration_s"] = scen_base.duration_s
    run_spec["bus"] = run_spec["engine"] = "native"
    fixed, cost = engine.run_closed_loop(run_spec, progress=False)
    scen = engine.scenario_of(run_spec)
    result = sim.evaluate(scen, cfg, run_spec, fixed, None, cost["total_s"], cost)
    row = {k: result[k] for k in FIGURES}
    settle = scen.settle_s if fixed["t_s"][-1] > scen.settle_s else 0.0
    if score_from_s is not None:
        settle = score_from_s
        far = metrics.tracking_error(fixed["t_s"], fixed["T_ref_N"], fixed["T_out_N"], settle)
        row.update({k: far[k] for k in FIGURES if k in far})
    true = metrics.tracking_error(fixed["t_s"], fixed["T_ref_N"], fixed["T_out_true_N"], settle)
    row["true_rms_error_pct"] = true["rms_error_pct"]
    row["true_peak_error_pct"] = true["peak_error_pct"]
    return row


def _stats(values) -> tuple[float, float]:
    a = np.asarray(values, dtype=float)
    return float(np.median(a)), float(a.max())


def _sources(option: str, text: str | None) -> tuple[str, ...] | None:
    """An option's comma-separated sources of the audit's records (SOURCES; 'none' for none),
    None when the option is not given; ValueError naming the first bad one."""
    if text is None:
        return None
    sources = tuple(s for s in text.split(",") if s and s != "none")
    bad = [s for s in sources if s not in SOURCES]
    if bad:
        raise ValueError(
            f"{option}: expected {', '.join(SOURCES)} or none, comma-separated; got {bad[0]!r}"
        )
    return sources


PROG = "calibrated_robustness"


def main(argv: list[str] | None = None) -> int:
    from cosim.parts.firmware import FirmwareConfigError  # noqa: PLC0415
    from cosim.studies.sweep.spec import SpecError, load_spec  # noqa: PLC0415

    ap = argparse.ArgumentParser(
        prog="python -m cosim.studies.calibrated_robustness",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--spec", default=str(SPEC), help="a `bowden sweep` specification (YAML)")
    ap.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    ap.add_argument("--out", help="keep the calibrations and the table here")
    ap.add_argument("--limit", type=int, help="only the first N plants (a quick look)")
    ap.add_argument(
        "--no-tare",
        action="store_true",
        help="calibrate without the tare (the far-end cell's offset counts as the tension's)",
    )
    ap.add_argument(
        "--leave",
        action="append",
        default=[],
        choices=COMP_KEYS,
        metavar="KEY",
        help="run with the device's value of this compensator key, not calibrate's proposal "
        "(what one of its proposals is worth; repeatable)",
    )
    ap.add_argument(
        "--truth",
        action="append",
        default=[],
        choices=(*COMP_KEYS, "all"),
        metavar="KEY",
        help="run with the plant's own value of this compensator key in place of calibrate's "
        "proposal (true_compensator: what calibrate's finding of it costs; 'all' for every key, "
        "what the compensator's law alone can do; repeatable)",
    )
    ap.add_argument(
        "--map",
        nargs="?",
        const="default",
        metavar="X,Y,Z;...",
        help="calibrate maps the bending angle at these positions (m; without a value its "
        "defaults, cosim.bench.rig.bend_map.DEFAULT_POSITIONS_M) and each run's compensator "
        "takes the map's angle at the run's position (as `bowden bench calibrate --map`)",
    )
    ap.add_argument(
        "--reuse",
        action="store_true",
        help="take each plant's calibration from --out (or --calibrations) where a run before "
        "left it (a resume, or another configuration on the same calibrations)",
    )
    ap.add_argument(
        "--calibrations",
        metavar="DIR",
        help="keep the calibrations (cal_NNN) here rather than in --out: with --reuse, the runs "
        "of another study on the same plants",
    )
    ap.add_argument(
        "--score-from-s",
        type=float,
        metavar="S",
        help="score each run from S seconds (default: the scenario's settling time, 1 s on "
        "fig14), e.g. 2.5 to leave out fig14's first top and bottom reversals",
    )
    ap.add_argument(
        "--breakaway-share",
        type=float,
        metavar="K",
        help="propose comp.breakaway as K times the audit's static friction rather than "
        "calibrate's share (what the share is worth; calibrate.BREAKAWAY_SHARE)",
    )
    ap.add_argument(
        "--slack-sources",
        metavar="S,...",
        help="propose comp.slack_tension_n from these of the audit's records, the first that "
        "holds a slack (finding, joint, candidate, any_round; 'none' for no slack) rather than "
        "calibrate's "
        "(calibrate.SLACK_SOURCES: what each source is worth)",
    )
    ap.add_argument(
        "--viscous-sources",
        metavar="S,...",
        help="propose comp.mu_per_inlet_rate from these of the audit's records, the first "
        "that holds a viscous friction (as --slack-sources; 'none' for no rate term) rather than "
        "calibrate's (calibrate.VISCOUS_SOURCES)",
    )
    ap.add_argument(
        "--breakaway-sources",
        metavar="S,...",
        help="propose comp.breakaway from these of the audit's records, the first that holds a "
        "static friction (as --slack-sources; 'none' for no breakaway) rather than calibrate's "
        "(calibrate.BREAKAWAY_SOURCES)",
    )
    ap.add_argument(
        "--params",
        metavar="FILE",
        help="a params file (compensator and controller only) laid over every run, after "
        "calibrate's proposals",
    )
    ap.add_argument(
        "--set",
        action="append",
        default=[],
        dest="sets",
        metavar="KEY=VALUE",
        help="a compensator.* or controller.* field laid over every run, after --params "
        "(repeatable), e.g. compensator.corr_enable=1",
    )
    args = ap.parse_args(argv)
    try:
        overlay = overlay_of(args.sets, args.params)
        spec = load_spec(args.spec)
    except (SpecError, ValueError) as exc:
        print(f"calibrated_robustness: {exc}", file=sys.stderr)
        return 2
    try:
        slack_sources = _sources("--slack-sources", args.slack_sources)
        viscous_sources = _sources("--viscous-sources", args.viscous_sources)
        breakaway_sources = _sources("--breakaway-sources", args.breakaway_sources)
    except ValueError as exc:
        print(f"calibrated_robustness: {exc}", file=sys.stderr)
        return 2
    from cosim.bench.rig import bend_map  # noqa: PLC0415

    try:
        map_positions = bend_map.positions_of(args.map)
    except bend_map.BendMapError as exc:
        print(f"calibrated_robustness: {exc}", file=sys.stderr)
        return 2
    given = [Path(f) for f in (args.out, args.calibrations) if f]
    refused = (
        count_refused("--workers", args.workers, 1, MAX_WORKERS)
        or count_refused("--limit", args.limit, 1)
        or next(filter(None, (unwritable(f, folder=True) for f in given)), None)
    )
    if refused is None and args.reuse:
        # A resume or another configuration on calibrations made before: a folder that is not
        # there is a wrong path, not an hour of calibrations to start from nothing.
        if not given:
            refused = "--reuse takes the calibrations from --out or --calibrations: give one"
        elif not given[-1].is_dir():
            refused = f"--reuse: {shown(given[-1])} does not exist (no calibrations to take)"
    if refused is not None:
        print(f"calibrated_robustness: {refused}", file=sys.stderr)
        return 2
    start = args.score_from_s
    if start is not None and not 0.0 <= start < (spec.duration_s or np.inf):
        print(
            f"calibrated_robustness: --score-from-s must be in [0, the runs' {spec.duration_s} s); "
            f"got {start}",
            file=sys.stderr,
        )
        return 2
    folder = Path(args.out or tempfile.mkdtemp(prefix="bowden-calibrated-robustness-"))
    cal_folder = Path(args.calibrations) if args.calibrations else folder
    folder.mkdir(parents=True, exist_ok=True)
    # One calibration per plant; the plant's points are the spec's points that carry it.
    plants: dict[str, dict] = {}
    members: dict[str, list[dict]] = {}
    for p in spec.points():
        plant = plant_of(spec, p.values)
        key = json.dumps(plant, sort_keys=True)
        plants.setdefault(key, plant)
        members.setdefault(key, []).append(p.values)
    keys = list(plants)[: args.limit]
    truth_keys = COMP_KEYS if "all" in args.truth else tuple(dict.fromkeys(args.truth))
    t0 = time.perf_counter()
    with process_pool(args.workers) as pool:
        jobs = [
            pool.submit(
                calibrate_plant,
                plants[k],
                str(cal_folder / f"cal_{i:03d}"),
                not args.no_tare,
                args.reuse,
                args.breakaway_share,
                slack_sources,
                viscous_sources,
                breakaway_sources,
                map_positions,
            )
            for i, k in enumerate(keys)
        ]
        calibrated = [j.result() for j in jobs]
        print(f"{len(keys)} calibrations in {time.perf_counter() - t0:.0f} s")
        points, seen = [], set()
        for k, comp in zip(keys, calibrated, strict=True):
            plant = ", ".join(f"{n} {v:.4g}" for n, v in sorted(plants[k].items()))
            print(
                f"  plant {plant or 'nominal'}: tare {comp['tare_n']:+.3f} N; proposes mu "
                f"{comp['compensator.mu']:.5f}, offset {comp['compensator.offset_n']:.3g} N, "
                f"slope {comp['compensator.mu_slope_per_n']:.3g} /N, breakaway "
                f"{comp['compensator.breakaway']:.3g}, slack "
                f"{comp['compensator.slack_tension_n']:.3g} N, rate term "
                f"{comp['compensator.mu_per_inlet_rate']:.3g} s/N, dead-zone spread "
                f"{comp['compensator.dead_zone_spread']:.3g} ({comp['decisions']})"
            )
            for name, why in comp["reasons"].items():
                print(f"    {name}: {why}")
            for values in members[k]:
                truth = None
                if truth_keys:
                    # the compensator's angle is the run's (calibrate's device's, or the overlay's)
                    run = run_values(values, comp, args.leave, overlay)
                    phi_plant, phi_comp = phi_of_point(args.spec, run)
                    truth = true_compensator(plants[k], phi_plant, phi_comp, truth_keys)
                v = run_values(values, comp, args.leave, overlay, truth)
                tag = json.dumps(v, sort_keys=True)
                if tag not in seen:  # a grid's est_enable axis collapses to one run
                    seen.add(tag)
                    points.append(v)
        try:
            rows = list(
                pool.map(run_point, [args.spec] * len(points), points, [start] * len(points))
            )
        except FirmwareConfigError as exc:  # e.g. the online estimate with a friction slope
            print(f"calibrated_robustness: the firmware refused a run: {exc}", file=sys.stderr)
            return 2
    table = {"runs": len(rows), "plants": len(keys), "spec": str(args.spec), "overlay": overlay}
    table["truth"] = list(truth_keys)
    if truth_keys:
        print("the plant's own values in place of calibrate's: " + ", ".join(truth_keys))
    table["score_from_s"] = start
    if overlay:
        print("laid over every run: " + ", ".join(f"{k} {v}" for k, v in overlay.items()))
    for prefix, label in (("", "far-end reading"), ("true_", "true output tension")):
        rm, rw = _stats([r[f"{prefix}rms_error_pct"] for r in rows])
        pm, pw = _stats([r[f"{prefix}peak_error_pct"] for r in rows])
        table[prefix + "scored"] = {
            "rms_median_pct": rm,
            "rms_worst_pct": rw,
            "peak_median_pct": pm,
            "peak_worst_pct": pw,
        }
        print(
            f"| after `bowden bench calibrate`, scored on the {label} | {rm:.2f} % | {rw:.2f} % "
            f"| {pm:.2f} % | {pw:.2f} % |"
        )
    decisions: dict[str, dict[str, int]] = {}
    for comp in calibrated:
        for name, status in comp["decisions"].items():
            decisions.setdefault(name, {}).setdefault(status, 0)
            decisions[name][status] += 1
    table["decisions"] = decisions
    print("decisions: " + "; ".join(f"{n} {d}" for n, d in decisions.items()))
    table["wall_s"] = time.perf_counter() - t0
    worst = int(np.argmax([r["peak_error_pct"] for r in rows]))
    print(f"worst peak at {points[worst]}")
    out = folder / "calibrated_robustness.json"
    out.write_text(
        json.dumps(
            {
                "table": table,
                "points": points,
                "rows": rows,
                "calibrations": [
                    {"plant": plants[k], **c} for k, c in zip(keys, calibrated, strict=True)
                ],
            },
            indent=1,
            default=float,
        )
    )
    print(f"{len(rows)} runs, {table['wall_s']:.0f} s; {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_interruptible(main, PROG))
