"""`bowden demo` (what `make demo` runs): the paper's Fig. 14 experiment in closed-loop
co-simulation, four ways, on the board's chain and on the ideal interface, next to the paper's
figures; then the held-out scenarios that the tuning never saw.

1. `fig14` (30 s, RTL on Verilator + firmware + plant FMU, and the float reference) for the
   compensators `paper`, `smooth` and `preview` with loop routing, and `paper` without loop
   routing, through the interface stage `--interface` (default `board`: the board's ADC and
   PWM -> ESCON, cosim.parts.interface) and, unless that is already `ideal`, again through the ideal
   interface, so that the cost of the real one shows side by side. Each run is written under
   build/demo/<name>/ (result.json, trace.csv, plots; `_ideal` for the ideal interface), then the
   table is printed from the result.json files just written, so the figures it shows are the
   ones on disk.
2. The held-out scenarios (cosim.config.scenarios.HELD_OUT_SCENARIOS: other frequency and
   amplitude, a triangle, a multi-sine, another path; 10 s each) for `paper`, `smooth` and
   `preview` with loop routing: on the board's chain through the fixed-point chain without a
   simulator (the firmware's host build and the RTL's bit-exact model,
   cosim.engines.reference.run_model_chain, which the RTL co-simulation equals at every sample),
   and on the ideal interface through the float reference; written to build/demo/held_out.json and
   printed as a second table. Gains, band and preview parameters are those `bowden tune` chose on
the `tune` scenario alone.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

# (folder, compensator, loop routing)
DEMO_RUNS = (
    ("fig14_paper_loop", "paper", True),
    ("fig14_smooth_loop", "smooth", True),
    ("fig14_preview_loop", "preview", True),
    ("fig14_paper_noloop", "paper", False),
)
HELD_OUT_COMPENSATORS = ("paper", "smooth", "preview")


def _errors(scen, rec) -> dict:
    from cosim.results import metrics  # noqa: PLC0415

    settle = scen.settle_s if rec["t_s"][-1] > scen.settle_s else 0.0
    e = metrics.tracking_error(rec["t_s"], rec["T_ref_N"], rec["T_out_N"], settle)
    split = metrics.reversal_split(rec["t_s"], rec["T_ref_N"], rec["T_out_N"], settle)
    return {
        "rms_error_pct": e["rms_error_pct"],
        "peak_error_pct": e["peak_error_pct"],
        "rms_near_reversal_n": split["rms_near_reversal_n"],
        "rms_away_n": split["rms_away_n"],
    }


def held_out(interface: str, duration_s: float, quiet: bool = False) -> list[dict]:
    """Each held-out scenario x compensator: the fixed-point chain through `interface` and the
    float reference through the ideal interface (errors in % of the maximum reference)."""
    from cosim.config.run import SimConfig  # noqa: PLC0415
    from cosim.config.scenarios import HELD_OUT_SCENARIOS, get_scenario
    from cosim.engines.reference import resolve_phi, run_model_chain, run_reference  # noqa: PLC0415

    cfg = SimConfig()
    rows = []
    for name in HELD_OUT_SCENARIOS:
        scen = get_scenario(name)
        phi = resolve_phi(scen, cfg, True)
        for comp in HELD_OUT_COMPENSATORS:
            if not quiet:
                print(f"== held out {name}, compensator {comp}", file=sys.stderr, flush=True)
            fixed = run_model_chain(scen, cfg, comp, True, phi, duration_s, interface=interface)
            ideal = run_reference(
                scen, cfg, comp, True, phi, duration_s, progress=False, interface="ideal"
            )
            rows.append(
                {
                    "scenario": name,
                    "compensator": comp,
                    "loop_routing": True,
                    "duration_s": duration_s,
                    interface: {"engine": "fixed-point chain", **_errors(scen, fixed)},
                    "ideal": {"engine": "float reference", **_errors(scen, ideal)},
                }
            )
    return rows


def held_out_table(rows: list[dict], interface: str) -> str:
    """The held-out table: the board's chain beside the ideal interface."""
    head = (
        f"{'scenario':<13}{'compensator':<12}{interface + ' RMS %':>14}{'peak %':>8}"
        f"{'rev RMS N':>10}{'ideal RMS %':>13}{'peak %':>8}{'rev RMS N':>10}"
    )
    lines = [
        "Held-out scenarios (never tuned on), loop routing, error in % of max T_ref; "
        f"{interface}: fixed-point chain (firmware + RTL bit-exact model), ideal: float reference",
        head,
        "-" * len(head),
    ]
    for r in rows:
        b, i = r[interface], r["ideal"]
        lines.append(
            f"{r['scenario']:<13}{r['compensator']:<12}{b['rms_error_pct']:>14.2f}"
            f"{b['peak_error_pct']:>8.2f}{b['rms_near_reversal_n']:>10.3f}"
            f"{i['rms_error_pct']:>13.2f}{i['peak_error_pct']:>8.2f}{i['rms_near_reversal_n']:>10.3f}"
        )
    lines.append(f"{'paper Fig.14':<13}{'paper':<12}{4.3:>14.2f}{13.3:>8.2f}   (measured)")
    return "\n".join(lines)


def table_from_files(paths: list[Path]) -> str:
    """The comparison table, read back from the result.json files (what is printed is on disk)."""
    from cosim.engines.experiment import summary_table  # noqa: PLC0415

    results = [json.loads(Path(p).read_text()) for p in paths]
    lines = [
        "Open-loop output tension control, paper Fig. 14 (error T_ref - T_out in % of max T_ref)",
        summary_table(results, paper=True),
        "",
        "results: " + ", ".join(str(p) for p in paths),
    ]
    return "\n".join(lines)
