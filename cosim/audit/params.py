"""Close the loop: the `--params` file implied by the extended model, and what it changes in the
fig14 experiment.

The file (cosim/config/run.py SimConfig format) has two parts:

- ``plant``: the fitted mu and every finding's FMU parameter, so that `bowden sim --params FILE`
  simulates the rig the data came from (never loop_routing or drive_mode: the command line and the
  scenario own those);
- ``compensator``: what the firmware's compensator can take from the findings (comp.h, "Extensions
  the model audit can emit"): mu, the output sensor's offset (offset_n) and the tension-dependent
  friction (mu_slope_per_n). Effects with no compensator parameter are listed in the notes.

The change in fig14 tracking error is measured with the float reference (cosim.engines.reference,
the same FMU and loop as the co-simulation without the RTL, seconds instead of minutes) on a plant
carrying the found effects, with the default compensator and with the emitted one.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

from cosim.config.run import CompensatorParams, SimConfig

from .effects import BY_PARAM

if TYPE_CHECKING:  # core pulls in scipy and numba: `bowden --help` must not wait for them
    from .core import AuditResult

# fig14 is evaluated after the loop's start-up, as `bowden sim` does (scenarios: settle_s).
FIG14_DEFAULT_DURATION_S = 10.0
# The compensators compared: the paper law (the default of `bowden sim fig14`) and the smooth
# inverse (the project's better one); the paper law's jump at reversals grows with mu*phi, so
# a better friction estimate can make it worse there while the smooth inverse gains.
FIG14_COMPENSATORS = ("paper", "smooth")


def emitted_params(result: AuditResult) -> tuple[dict, list[str]]:
    """The `--params` content of the extended model, and notes on what it leaves out."""
    p = result.extended.params
    d = result.data
    plant: dict[str, float] = {"mu": round(p["mu"], 6)}
    if p.get("dead_zone_spread", 0.0) > 0.0:  # the nominal model's gradual dead zone
        plant["dead_zone_spread"] = round(float(p["dead_zone_spread"]), 6)
    if d.inputs.sheath_length_m != 1.0:
        plant["sheath_length"] = d.inputs.sheath_length_m
    comp: dict[str, float] = {"mu": round(p["mu"], 6)}
    notes = []
    if not d.has_positions:
        notes.append(
            "the data have no positions: mu is the value for the FMU's phi at x = 0, y = L/2, "
            "z = 0 (only mu*phi was observable)"
        )
    taken = {f.fixed.cause: f for f in result.free_forms if f.accepted}
    for f in result.findings:
        e = f.effect
        free = taken.get(e.cause)
        if free is not None:
            # the free form in place of its fixed form: the FMU's table or surface
            for name in free.fmu_params:
                plant[name] = round(float(p.get(name, 0.0)), 9)
            if isinstance(free.knots_at[0], str):
                where = f"terms {', '.join(free.knots_at)}"
            else:
                step = free.knots_at[1] - free.knots_at[0]
                where = (
                    f"{len(free.table)} knots of {free.axis} from {free.knots_at[0]:g}, "
                    f"{step:.4g} apart"
                )
            notes.append(
                f"{e.cause} as its free form, {free.name} ({where}), has no compensator "
                "parameter: the plant carries it, the compensator does not correct it"
            )
            continue
        for name in e.fmu_params:
            plant[name] = round(float(p[name]), 9)
        if e.compensator_key is None:
            notes.append(
                f"{e.cause} ({e.describe_all(p)}) has no compensator parameter: the plant "
                "carries it, the compensator does not correct it"
            )
            continue
        value = float(p[e.fmu_param])
        lo, hi = _compensator_range(e.compensator_key)
        if not lo <= value <= hi:
            notes.append(
                f"{e.cause}: {e.compensator_key} = {value:.4g} is outside the compensator's range "
                f"[{lo:g}, {hi:g}]; left at its default"
            )
            continue
        trial = {**comp, e.compensator_key: round(value, 9)}
        why = _compensator_refuses(trial, result)
        if why:
            notes.append(
                f"{e.cause}: the compensator refuses {e.compensator_key} = {value:.4g} "
                f"({why}); left at its default"
            )
            continue
        comp = trial
    return {"plant": plant, "compensator": comp}, notes


def _compensator_refuses(comp: dict[str, float], result: AuditResult) -> str | None:
    """Why the firmware's compensator would refuse this configuration at fig14's start position
    (its own check, comp_config_check through cosim.parts.firmware), or None."""
    from cosim.config.scenarios import HOME_M  # noqa: PLC0415
    from cosim.parts.firmware import make_compensator_f64  # noqa: PLC0415
    from cosim.parts.geometry import bending_angle  # noqa: PLC0415

    d = result.data
    phi = float(bending_angle(*HOME_M, d.inputs.sheath_length_m, d.inputs.loop_routing))
    try:
        make_compensator_f64("paper", CompensatorParams(**comp), phi)
    except (ValueError, RuntimeError) as exc:
        return str(exc)
    return None


def _compensator_range(key: str) -> tuple[float, float]:
    return {
        "offset_n": (-64.0, 64.0),
        "mu_slope_per_n": (-1 / 128, 1 / 128),
        "breakaway": (0.0, 0.25),
    }[key]


def check_params(path: Path, params: dict) -> None:
    """Check the content the way `bowden sim --params` will (ValueError names the problem)."""
    SimConfig.from_dict(json.loads(json.dumps(params)), source=str(path))


def write_params(path: Path, params: dict) -> None:
    """Write the file after checking it the way `bowden sim --params` will."""
    check_params(path, params)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(params, indent=2) + "\n")


def fig14_change(params: dict, loop_routing: bool, duration_s: float, progress: bool) -> dict:
    """Tracking error of fig14 (float reference) on the plant of `params`, with the default
    compensator configuration and with the emitted one, for each of FIG14_COMPENSATORS."""
    from cosim.config.scenarios import get_scenario  # noqa: PLC0415
    from cosim.engines.reference import resolve_phi, run_reference  # noqa: PLC0415
    from cosim.results.metrics import tracking_error  # noqa: PLC0415

    scen = get_scenario("fig14")
    settle = scen.settle_s if duration_s > 2 * scen.settle_s else 0.0
    out: dict = {"duration_s": duration_s, "settle_s": settle}
    texts = []
    for mode in FIG14_COMPENSATORS:
        runs = {}
        for name, comp in (("default", {}), ("emitted", params["compensator"])):
            cfg = SimConfig.from_dict({"plant": params["plant"], "compensator": comp}, "emitted")
            phi = resolve_phi(scen, cfg, loop_routing)
            rec = run_reference(scen, cfg, mode, loop_routing, phi, duration_s, progress)
            runs[name] = tracking_error(rec["t_s"], rec["T_ref_N"], rec["T_out_N"], settle)
        d, e = runs["default"], runs["emitted"]
        change = e["rms_error_n"] - d["rms_error_n"]
        rel = 100.0 * change / d["rms_error_n"] if d["rms_error_n"] > 0 else math.nan
        out[mode] = {
            "default": {k: float(v) for k, v in d.items()},
            "emitted": {k: float(v) for k, v in e.items()},
            "rms_change_n": float(change),
            "rms_change_pct": None if math.isnan(rel) else float(rel),
        }
        texts.append(
            f"compensator `{mode}`: RMS {d['rms_error_n']:.3f} N ({d['rms_error_pct']:.1f} %) "
            f"-> {e['rms_error_n']:.3f} N ({e['rms_error_pct']:.1f} %), {change:+.3f} N "
            f"({rel:+.0f} %), peak {d['peak_error_n']:.2f} -> {e['peak_error_n']:.2f} N"
        )
    out["text"] = (
        f"fig14 tracking error ({duration_s:g} s, float reference, plant = the extended model), "
        f"default compensator configuration (mu = {CompensatorParams().mu:g}) -> emitted "
        "parameters: " + "; ".join(texts) + "."
    )
    return out


__all__ = ["BY_PARAM", "emitted_params", "fig14_change", "write_params"]
