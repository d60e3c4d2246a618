"""`make perf-audit`: wall time of `bowden audit` on 60 s of 1 kHz data (target: at most
30 s on this machine), end to end (reading, fitting, the FMU runs, report and plots), for data
with no effect, one effect and two effects, and a recording of the bench emulator (the
0.5 Hz sine of `bowden bench run sine`); then 20 minutes of 1 kHz data with two effects (target:
at most 2 min and 2 GB of memory, the audit's peak resident set). Prints the machine's load: the
figures move with it. `python -m cosim.perf.audit long` runs the long case only.

Measured on this machine (2 cores shared by four people; CPU seconds are the figure to compare,
wall times follow the load), on a fresh clone (numba's cache empty: the first case also compiles
the twin), before and after the fits' friction on a 2 ms grid (cosim/audit/fit.py,
FIT_FRICTION_STEP_S) and OpenBLAS on one thread (cosim/audit/blas.py):

| case | CPU s before | CPU s after | wall s after (load) |
| --- | --- | --- | --- |
| no effect | 23.6 | 17.9 | 85.5 (9.6) |
| lag 10 ms | 33.9 | 16.5 | 101.8 (8.4) |
| offset 0.5 N + tension slope 1.2e-3/N | 51.2 | 19.6 | 121.1 (9.8); 26.8 (2.2), run alone |
| bench emulator | 21.9 | 11.5 | 64.7 (8.3) |
| 20 min, offset + slope | 121.2 | 98.2 | 141.3 (6.5), peak 1217 MB |

The same findings in every case. The 20-minute record was already fitted on a 12 ms grid
(MAX_FIT_FRICTION_SAMPLES): its gain is the single BLAS thread's. Measured before the fits with
viscous friction went back to the full rate (RATE_PARAMS); after it, the offset + slope case
alone took 18.7 s of CPU (61 s wall at load 4.6).

The 20-minute case again after the time plot drew a long record by buckets (cosim/audit/report.py,
MAX_LINE_BUCKETS) and the free forms of the bending error and the slack (which it does not
reach): 91.5 s of CPU, 450 s wall at load 9.6, peak 1217 MB. Where its CPU goes (a profile of
the same record, numbers of one run without the profiler): reading the CSV 11.8 s, the six plots
3.3 s (6.7 s before the buckets), the two FMU runs about 10 s, the rest the fits (the twin's
friction on the 12 ms grid, 1130 runs; the static friction's breakaway starts the largest single
part of them). The wall target holds only on a machine that gives the audit a core.

Every case again on a quiet machine (load 0.6-0.9, this round's code with the free forms; the
numba cache warm), `python -m cosim.perf.audit`: no effect 10.9 s wall (10.0 s of CPU), lag
15.5 s (15.7), offset + slope 20.1 s (20.2), the bench emulator 10.2 s (10.4); the 20-minute
record 88.5 s wall (88.5 s of CPU), peak 1215 MB: every target met, the same findings.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from cosim.audit.synthetic import fmu_record

TARGET_S = 30.0
LONG_S = 1200.0
LONG_TARGET_S = 120.0
LONG_TARGET_MB = 2048.0
EMULATOR = "bench emulator: 0.5 Hz sine, no effect"
CASES = (
    ("no effect", {}),
    ("lag 10 ms", {"sensor_tau": 0.010}),
    ("offset 0.5 N + tension slope 1.2e-3/N", {"sensor_offset": 0.5, "mu_tension_slope": 0.0012}),
    (EMULATOR, None),
)
LONG = ("offset 0.5 N + tension slope 1.2e-3/N", {"sensor_offset": 0.5, "mu_tension_slope": 0.0012})


def emulator_record(folder: Path, seconds: float) -> Path:
    """A `bowden bench run sine` recording of the emulator (stepped in process, no drops)."""
    from cosim.bench.emulate.emulator import SteppedLink  # noqa: PLC0415
    from cosim.bench.link.client import BenchClient  # noqa: PLC0415
    from cosim.bench.link.recorder import record_run  # noqa: PLC0415

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


def _audit(path: Path) -> tuple[float, float, float, str] | None:
    """Run `bowden audit` on path: wall s, CPU s, peak resident MB, the causes named (None and
    the output printed when it failed)."""
    from cosim.audit.effects import CAUSES  # noqa: PLC0415

    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "cosim", "audit", str(path), "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    out = proc.stdout.read() if proc.stdout else ""
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        print(out)
        return None
    cpu = usage.ru_utime + usage.ru_stime
    found = [
        ln.split()[0]
        for ln in out.splitlines()
        if ln.startswith("  ") and ln.split() and ln.split()[0] in CAUSES
    ]
    return wall, cpu, usage.ru_maxrss / 1024.0, ", ".join(found) or "none"


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    long_only = argv == ["long"]
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_audit_") as tmp:
        for i, (name, effect) in enumerate(() if long_only else CASES):
            folder = Path(tmp) / f"case{i}"
            folder.mkdir()
            if effect is None:
                path = emulator_record(folder, 60.0)
            else:
                path = fmu_record(folder, effect, seed=900 + i, duration_s=60.0)
            load0 = os.getloadavg()[0]
            got = _audit(path)
            if got is None:
                return 1
            wall, cpu, _, found = got
            rows.append((name, wall, cpu, load0, found))
        folder = Path(tmp) / "long"
        folder.mkdir()
        path = fmu_record(folder, LONG[1], seed=950, duration_s=LONG_S)
        load0 = os.getloadavg()[0]
        got = _audit(path)
        if got is None:
            return 1
        long_row = (LONG[0], *got, load0)
    if rows:
        print(
            f"{'60 s of 1 kHz data':<40}{'wall s':>8}{'CPU s':>7}{'load':>7}  target <= "
            f"{TARGET_S:g} s wall  found"
        )
    for name, wall, cpu, load, found in rows:
        verdict = "met" if wall <= TARGET_S else "NOT met"
        print(f"{name:<40}{wall:>8.1f}{cpu:>7.1f}{load:>7.1f}  {verdict:<21}{found}")
    name, wall, cpu, mb, found, load = long_row
    print(
        f"{'20 min of 1 kHz data':<40}{'wall s':>8}{'CPU s':>7}{'load':>7}{'peak MB':>9}  target "
        f"<= {LONG_TARGET_S:g} s wall, <= {LONG_TARGET_MB:g} MB  found"
    )
    verdict = "met" if wall <= LONG_TARGET_S and mb <= LONG_TARGET_MB else "NOT met"
    print(f"{name:<40}{wall:>8.1f}{cpu:>7.1f}{load:>7.1f}{mb:>9.0f}  {verdict:<31}{found}")
    print("(CPU above wall: the numerical libraries use more than one core at times)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
