"""Figures of the full-system co-simulation (`make perf-soc`, part of `make perf`): the simulated
board of `bowden emulate --target soc` (bowden_soc executing the RV32 firmware in Verilator, its
pins modelled, the plant FMU in the loop), driven over its pty by the scripting API:

- speed: simulated seconds per wall second of the whole board, as fast as it computes (not held
  to real time), over a recorded run of the firmware's sine with telemetry every tick; target
  >= 0.2x real time on the project's 2-core machine; and the FMU's share of the wall time;
- the firmware's tick in CPU cycles (clocks of the SoC from the tick's start to the main loop's
  next idle phase: reference, compensator, T_c write, telemetry frame), worst and median over
  the run, against its budget (the SoC's clock / tick rate: 24000 at 24 MHz and 1 kHz);
- the longest handling of received bytes (the firmware's RX phase: a frame decoded, dispatched
  and its reply queued; firmware/soc/main.c serves one only when it fits before the next tick)
  and the longest time between two ticks' starts (over 2 budgets: the device's OVERRUN fault).

    python -m cosim.perf.soc [--seconds 1.0]
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
from pathlib import Path

from cosim.bench.emulate.host_device import ChainConfig
from cosim.bench.emulate.host_device import _open_plant as open_plant
from cosim.bench.emulate.soc import build as soc_build
from cosim.bench.emulate.soc.harness import SocBoard
from cosim.bench.link.api import Bench
from cosim.config.run import BoardParams

TICK_HZ = 1000  # the firmware's default tick rate (tick_rate_hz)


def _cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0, help="simulated seconds recorded")
    args = ap.parse_args(argv)
    soc_build.build()
    plant = open_plant(ChainConfig())
    board = SocBoard(realtime=False, plant=plant, escon_imax_a=BoardParams().escon_imax_a)
    board.start()
    with tempfile.TemporaryDirectory() as tmp, Bench(board.pty_name) as bench:
        start, cpu0 = board.stats(), _cpu_s()
        board.clear_stats()
        run = bench.run("sine", seconds=args.seconds, out=str(Path(tmp) / "run.csv"))
        end, cpu1 = board.stats(), _cpu_s()
    ticks = board.stop()  # the tick figures are taken when the board stops (a few idle ticks
    # after the run are among them; the run's ticks are most)
    sim_s = end.sim_s - start.sim_s
    wall_s = end.wall_s - start.wall_s
    budget = soc_build.CLK_HZ // TICK_HZ
    print(f"soc co-simulation ({soc_build.CLK_HZ / 1e6:g} MHz SoC, plant FMU every loop sample)")
    print(
        f"  speed    {sim_s / wall_s:.3f}x real time ({sim_s:.2f} simulated s in {wall_s:.1f} "
        f"wall s; target >= 0.2x); FMU {100 * (end.fmu_s - start.fmu_s) / wall_s:.1f} % of it"
    )
    print(
        f"           {sim_s / (cpu1 - cpu0):.3f} simulated s per CPU s of this process (the wall "
        f"figure on an idle core; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs)"
    )
    print(
        f"  tick     worst {ticks.tick_worst_clks} cycles, median {ticks.tick_median_clks} "
        f"({100 * ticks.tick_worst_clks / budget:.1f} % / "
        f"{100 * ticks.tick_median_clks / budget:.1f} % of the {budget}-cycle budget) over "
        f"{ticks.ticks} ticks"
    )
    print(
        f"  requests longest handling of received bytes {end.rx_worst_clks} cycles "
        f"({end.rx_worst_clks / soc_build.CLK_HZ * 1e3:.2f} ms); longest tick-to-tick "
        f"{end.tick_gap_worst_clks} cycles"
    )
    print(f"  run      {run.samples} samples of {run.expected}, drops {run.drops}, faults "
          f"{', '.join(run.faults) or 'none'}")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
