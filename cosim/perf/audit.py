"""`make perf-audit`: wall time of `bowden audit` on 60 s of 1 kHz data (target: at most
30 s on this machine), end to end (reading, fitting, the FMU runs, report and plots), for data
with no effect, one effect and two effects, and a recording of the bench emulator (the
0.5 Hz sine of `bowden bench run sine`). Prints the machine's load: the figures move with it.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from cosim.audit.synthetic import fmu_record

TARGET_S = 30.0
EMULATOR = "bench emulator: 0.5 Hz sine, no effect"
CASES = (
    ("no effect", {}),
    ("lag 10 ms", {"sensor_tau": 0.010}),
    ("offset 0.5 N + tension slope 1.2e-3/N", {"sensor_offset": 0.5, "mu_tension_slope": 0.0012}),
    (EMULATOR, None),
)


def emulator_record(folder: Path, seconds: float) -> Path:
    """A `bowden bench run sine` recording of the emulator (stepped in process, no drops)."""
    from cosim.bench.client import BenchClient  # noqa: PLC0415
    from cosim.bench.emulator import SteppedLink  # noqa: PLC0415
    from cosim.bench.recorder import record_run  # noqa: PLC0415

    link = SteppedLink()
    try:
        client = BenchClient(link)
        client.connect()
        path = folder / "rec.csv"
        record_run(
            client, path, seconds=seconds, waveform="sine", mean_n=8.5, amplitude_n=6.5, freq_hz=0.5
        )
    finally:
        link.close()
    return path


def main() -> int:
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_audit_") as tmp:
        for i, (name, effect) in enumerate(CASES):
            folder = Path(tmp) / f"case{i}"
            folder.mkdir()
            if effect is None:
                path = emulator_record(folder, 60.0)
            else:
                path = fmu_record(folder, effect, seed=900 + i, duration_s=60.0)
            load0 = os.getloadavg()[0]
            cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            out = subprocess.run(
                [sys.executable, "-m", "cosim", "audit", str(path), "--quiet"],
                capture_output=True,
                text=True,
                check=False,
            )
            wall = time.perf_counter() - t0
            cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
            if out.returncode != 0:
                print(out.stdout + out.stderr)
                return 1
            found = [
                ln.split()[0]
                for ln in out.stdout.splitlines()
                if ln.startswith("  ")
                and ln.split()
                and ln.split()[0]
                in {
                    "sensor_offset",
                    "sensor_gain",
                    "lag",
                    "time_delay",
                    "viscous_friction",
                    "tension_dependent_friction",
                    "bending_angle_error",
                    "friction_drift",
                }
            ]
            rows.append((name, wall, cpu, load0, ", ".join(found) or "none"))
    print(
        f"{'60 s of 1 kHz data':<40}{'wall s':>8}{'CPU s':>7}{'load':>7}  target <= "
        f"{TARGET_S:g} s wall  found"
    )
    for name, wall, cpu, load, found in rows:
        verdict = "met" if wall <= TARGET_S else "NOT met"
        print(f"{name:<40}{wall:>8.1f}{cpu:>7.1f}{load:>7.1f}  {verdict:<21}{found}")
    print("(single-threaded: on a quiet machine the wall time is about the CPU time)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
