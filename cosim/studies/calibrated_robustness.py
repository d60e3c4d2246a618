"""The robustness figure after `bowden bench calibrate` on each off plant: row (c) of the table
in docs/results.md ("With the online friction estimate").

For every plant of the robustness grid (cosim/studies/sweep/examples/robustness_estimator.yaml:
plant mu, cable_EA and current_bandwidth at -20 % / nominal / +20 %, 27 plants):

1. `calibrate` (cosim.bench.rig.calibrate, without --apply: its proposal) on the emulated controller
   (the stepped emulator, at the home position) with that plant: the compensator values it
   proposes (comp.mu, and comp.offset_n / comp.mu_slope_per_n where it finds them);
2. the grid's own runs (fig14, 6 s, board interface, preview compensator, the five positions;
   cosim.studies.sweep.run, the runs `bowden sweep` makes) with the compensator set to them.

Prints the mu each calibration proposes and the table's row: RMS and peak error in % of the
15 N maximum, median and worst over the 135 runs, and at the nominal plant.

    python -m cosim.studies.calibrated_robustness [--workers 2] [--out DIR]
"""

from __future__ import annotations

import argparse
import itertools
import json
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from cosim.project.paths import PACKAGE_DIR

SPEC = PACKAGE_DIR / "studies" / "sweep" / "examples" / "robustness_estimator.yaml"
PLANT_AXES = ("plant.mu", "plant.cable_EA", "plant.current_bandwidth")
FMU_NAMES = {
    "plant.mu": "mu",
    "plant.cable_EA": "cable_EA",
    "plant.current_bandwidth": "current_bandwidth",
}


def _spec():
    from cosim.studies.sweep.spec import load_spec  # noqa: PLC0415

    return load_spec(SPEC)


def calibrate_plant(plant: dict, folder: str) -> dict:
    """The compensator values `calibrate` proposes for an emulated plant (FMU parameters), as
    the sweep's config keys (compensator.mu, ...), and the decision for each."""
    from cosim.bench.link.api import Bench  # noqa: PLC0415
    from cosim.bench.rig import calibrate as cal  # noqa: PLC0415

    with Bench(emulate=True, plant=plant) as bench:
        opts = cal.Options(out_dir=Path(folder), audit_plots=False)
        outcome = cal.run_calibration(bench.client, bench.info(), opts, say=lambda _: None)
    out = {}
    for c in outcome.report["changes"]:
        key = "compensator." + c["name"].split(".", 1)[1]
        out[key] = c["proposed"] if c["status"] == "change" else c["current"]
    out["decisions"] = {c["name"]: c["status"] for c in outcome.report["changes"]}
    return out


def run_point(values: dict) -> dict:
    from cosim.studies.sweep.run import _run  # noqa: PLC0415
    from cosim.studies.sweep.spec import Point  # noqa: PLC0415

    return _run(_spec(), Point(values))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m cosim.studies.calibrated_robustness", description=__doc__
    )
    ap.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    ap.add_argument("--out", help="keep the calibrations and the table here")
    args = ap.parse_args(argv)
    folder = Path(args.out or tempfile.mkdtemp(prefix="bowden-calibrated-robustness-"))
    folder.mkdir(parents=True, exist_ok=True)
    spec = _spec()
    plants = list(itertools.product(*(spec.axes[a] for a in PLANT_AXES)))
    t0 = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        jobs = [
            pool.submit(
                calibrate_plant,
                {FMU_NAMES[a]: v for a, v in zip(PLANT_AXES, p, strict=True)},
                str(folder / f"cal_{i:02d}"),
            )
            for i, p in enumerate(plants)
        ]
        calibrated = [j.result() for j in jobs]
        print(f"27 calibrations in {time.perf_counter() - t0:.0f} s")
        points = []
        for p, comp in zip(plants, calibrated, strict=True):
            print(
                f"  plant mu {p[0]:.4g}, EA {p[1]:.5g}, bandwidth {p[2]:.5g}: proposes mu "
                f"{comp['compensator.mu']:.5f}, offset {comp['compensator.offset_n']:.3g} N, "
                f"slope {comp['compensator.mu_slope_per_n']:.3g} /N ({comp['decisions']})"
            )
            fixed = {k: v for k, v in comp.items() if k != "decisions"}
            for pos in spec.axes["position_m"]:
                values = {
                    "compensator": "preview",
                    "compensator.est_enable": 0,
                    "position_m": pos,
                    **dict(zip(PLANT_AXES, p, strict=True)),
                    **fixed,
                }
                points.append(values)
        rows = list(pool.map(run_point, points))
    rms = np.array([r["rms_error_pct"] for r in rows])
    peak = np.array([r["peak_error_pct"] for r in rows])
    nominal = [
        i
        for i, v in enumerate(points)
        if all(np.isclose(v[a], spec.axes[a][len(spec.axes[a]) // 2]) for a in PLANT_AXES)
    ]
    table = {
        "runs": len(rows),
        "rms_median_pct": float(np.median(rms)),
        "rms_worst_pct": float(rms.max()),
        "peak_median_pct": float(np.median(peak)),
        "peak_worst_pct": float(peak.max()),
        "nominal_rms_pct": [float(rms[i]) for i in nominal],
        "nominal_peak_pct": [float(peak[i]) for i in nominal],
        "wall_s": time.perf_counter() - t0,
    }
    (folder / "calibrated_robustness.json").write_text(
        json.dumps({"table": table, "points": points, "rows": rows}, indent=1, default=float)
    )
    print(
        f"| (c) after `bowden bench calibrate` | {table['rms_median_pct']:.2f} % | "
        f"{table['rms_worst_pct']:.2f} % | {table['peak_median_pct']:.2f} % | "
        f"{table['peak_worst_pct']:.2f} % | {min(table['nominal_rms_pct']):.2f}-"
        f"{max(table['nominal_rms_pct']):.2f} / {min(table['nominal_peak_pct']):.1f}-"
        f"{max(table['nominal_peak_pct']):.1f} % |"
    )
    worst = int(np.argmax(peak))
    print(f"worst peak at {points[worst]}")
    print(f"{len(rows)} runs, {table['wall_s']:.0f} s; {folder / 'calibrated_robustness.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
