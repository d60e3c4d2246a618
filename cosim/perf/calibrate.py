"""Does `bowden bench calibrate --apply` bring an off plant back to the nominal plant's tracking?
(`make perf-calibrate`, part of `make perf`)

On the emulated controller (the stepped emulator: the recording `bowden emulate --plant mu=X` gives,
sample for sample, without the wall clock) with the compensator at its default mu 0.075, for each
compensator mode given: the verification waveform's tracking error (cosim.bench.rig.calibrate
VERIFY, measured on T_out from SETTLE_S) on the nominal plant (mu 0.075), then `calibrate --apply`
on plants with mu 0.06 and 0.09, its verification error before and after, the mu it wrote, and the
ratio after / nominal (target <= 1.3). The last column is the floor: the same waveform with the
compensator set to the plant's true mu, what a perfect calibration gives.

    python -m cosim.perf.calibrate [--modes paper,smooth] [--out DIR]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from cosim.bench.link.api import Bench
from cosim.bench.rig import calibrate as cal

NOMINAL_MU = 0.075
OFF_MU = (0.06, 0.09)
TARGET_RATIO = 1.3


def _verify(mode: str, plant_mu: float, comp_mu: float, folder: Path) -> dict:
    with Bench(emulate=True, plant={"mu": plant_mu}) as bench:
        bench.set(comp_mode=mode, comp_mu=comp_mu)
        run = bench.run(
            cal.VERIFY["waveform"],
            cal.VERIFY_SECONDS,
            out=folder / f"verify_{mode}_{plant_mu:g}_{comp_mu:g}.csv",
            mean_n=cal.VERIFY["mean_n"],
            amplitude_n=cal.VERIFY["amplitude_n"],
            freq_hz=cal.VERIFY["freq_hz"],
        )
    return cal.verification_error(run.columns)


def _calibrate(mode: str, plant_mu: float, folder: Path) -> dict:
    with Bench(emulate=True, plant={"mu": plant_mu}) as bench:
        bench.set(comp_mode=mode)
        opts = cal.Options(out_dir=folder / f"cal_{mode}_{plant_mu:g}", apply=True)
        outcome = cal.run_calibration(bench.client, bench.info(), opts, say=lambda _: None)
    return outcome.report


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m cosim.perf.calibrate", description=__doc__)
    ap.add_argument("--modes", default="paper,smooth", help="compensator modes (comp.mode)")
    ap.add_argument("--out", help="keep the calibration folders here (default: a temporary one)")
    args = ap.parse_args(argv)
    folder = Path(args.out or tempfile.mkdtemp(prefix="bowden-perf-calibrate-"))
    folder.mkdir(parents=True, exist_ok=True)
    print(
        f"verification: {cal.VERIFY['waveform']} {cal.VERIFY['mean_n']:g} +- "
        f"{cal.VERIFY['amplitude_n']:g} N at {cal.VERIFY['freq_hz']:g} Hz, "
        f"{cal.VERIFY_SECONDS:g} s, RMS of T_ref - T_out from {cal.SETTLE_S:g} s; compensator "
        f"mu {NOMINAL_MU:g}; stepped emulator"
    )
    print(
        "| mode | plant mu | mu written | kept | RMS before | RMS after | nominal RMS | after / "
        "nominal | floor (comp at the plant's mu) / nominal |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    worst = 0.0
    for mode in args.modes.split(","):
        nominal = _verify(mode, NOMINAL_MU, NOMINAL_MU, folder)["rms_error_n"]
        for mu in OFF_MU:
            t0 = time.perf_counter()
            rep = _calibrate(mode, mu, folder)
            wall = time.perf_counter() - t0
            m = rep.get("measured")
            if m is None:
                print(f"| {mode} | {mu:g} | nothing applied | | | | {nominal:.3f} N | | |")
                worst = float("inf")
                continue
            floor = _verify(mode, mu, mu, folder)["rms_error_n"]
            ratio = m["after"]["rms_error_n"] / nominal
            worst = max(
                worst, ratio if rep["applied_kept"] else m["before"]["rms_error_n"] / nominal
            )
            print(
                f"| {mode} | {mu:g} | {rep['applied'].get('comp.mu', float('nan')):.5f} | "
                f"{'yes' if rep['applied_kept'] else 'no (undone: the error rose)'} | "
                f"{m['before']['rms_error_n']:.3f} N ({m['before']['rms_error_pct']:.2f} %) | "
                f"{m['after']['rms_error_n']:.3f} N ({m['after']['rms_error_pct']:.2f} %) | "
                f"{nominal:.3f} N | {ratio:.2f} | {floor / nominal:.2f} |"
            )
            print(f"  ({mode}, mu {mu:g}: calibrate took {wall:.1f} s)", file=sys.stderr)
    print(f"worst after / nominal: {worst:.2f} (target <= {TARGET_RATIO:g})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
