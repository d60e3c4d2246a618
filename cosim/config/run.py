"""The configuration of a run: the controller, compensator and board parameters around a
scenario (SimConfig), their allowed ranges, and the params file (`--params FILE.json`) that
overrides them, validated with one line naming the file, the key and its range."""

from __future__ import annotations

import difflib
import json
import math
import re
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

from cosim.parts.firmware import MODES, CompensatorParams
from cosim.parts.interface import ADC_PARTS
from cosim.project.cliargs import shown
from cosim.project.datafile import DataFileError, HugeInt, read_json

# The firmware's compensator modes (firmware/include/comp.h, mirrored by cosim.parts.firmware).
COMPENSATORS = tuple(MODES)

# The paper's bench: Table I (Maxon RE25 k_t 23.4 mNm/A, 5.4:1 gearhead, efficiency ~0.9
# assumed, spool radius ~10 mm). Kff = r / (N * eta * k_t) in A/N.
SPOOL_RADIUS_M = 0.010
GEAR_RATIO = 5.4
GEAR_EFFICIENCY = 0.9
TORQUE_CONSTANT_NM_PER_A = 0.0234
KFF_A_PER_N = SPOOL_RADIUS_M / (GEAR_RATIO * GEAR_EFFICIENCY * TORQUE_CONSTANT_NM_PER_A)


@dataclass
class ControllerParams:
    """The tension loop's gains and limits in SI units (the RTL holds them in fixed point).

    Kff from the bench (paper Table I, above); Kp and Ki chosen for a loop that tracks T_c within a
    few milliseconds against the FMU's drive, motor and cable (tuned in co-simulation; see README).
    """

    kff_a_per_n: float = KFF_A_PER_N
    kp_a_per_n: float = 0.1
    # Kp and Ki chosen by `bowden tune` on the tune scenario only (board chain, ADS131M02): Kp
    # margin x3.05 before a limit cycle (hold probe, cosim/tune); the register map's reset values.
    ki_a_per_n_s: float = 2.5
    i_limit_a: float = 4.0  # ESCON 36/2 peak current (RTL reset value of I_LIMIT)
    slew_n_per_sample: float = 0.0  # 0 = slew limit off
    # Rate feedforward (fw.h; written to UFF, outside the PI): u += kv * dT_c/dt, bounded by
    # uff_limit_a. The current the drive needs to move the cable at T_c's rate: the motor's
    # viscous damping b, geared to the spool, against the cable's stretch, kv = b N / (r k_t k)
    # (k the cable's stiffness EA / length); 0 = off. The value for the bench is chosen on a
    # tuning set (docs/results.md, "Rate feedforward").
    kv_a_s_per_n: float = 0.0
    uff_limit_a: float = 0.5


# Fields of the run's configuration a params file may not set: the command line owns them.
RUN_OWNED = {"compensator.mode": "is set on the command line (--compensator)"}

# Rates in whole Hz: the firmware takes them as unsigned integers (fw.h), and its checks bound them
# (fw.c: sample rate 1 .. 1e6 Hz, tick rate 1 .. 65535 Hz).
RATE_RANGES_HZ = {"sample_rate_hz": (1, 1_000_000), "firmware_rate_hz": (1, 65_535)}

# FMU parameters a params file may not set, and why: the command line, the scenario or the closed
# loop own them, and result.json and the trace's sidecar report them from there.
PLANT_OWNED = {
    "loop_routing": "is set on the command line (--no-loop-routing) and reported in result.json",
    "drive_mode": "is fixed by the closed loop, which drives the motor by its current command "
    "(drive_mode 0)",
}


def field_ranges(sample_rate_hz: float) -> dict[str, tuple[float, float]]:
    """Allowed range of every controller, compensator and board field, by dotted name.

    Controller: the register words (hdl/regmap/bowden_regs.json): KFF and KP Q2.13, KI_TS
    +-1/32 A/N per sample (so Ki up to sample_rate_hz / 32 A/(N s)), I_LIMIT UQ3.12, SLEW UQ7.8.
    Compensator: the firmware's checks (firmware/include/comp.h)."""
    return {
        "controller.kff_a_per_n": (0.0, 3.9998),
        "controller.kp_a_per_n": (0.0, 3.9998),
        "controller.ki_a_per_n_s": (0.0, sample_rate_hz / 32.0),
        "controller.i_limit_a": (0.0, 7.9997),
        "controller.slew_n_per_sample": (0.0, 127.99),
        "controller.kv_a_s_per_n": (0.0, 1.0 / 16.0),  # fw.h FW_KV_MAX, Q7.24
        "controller.uff_limit_a": (0.0, 7.9997),  # UQ3.12, as UFF's range
        "compensator.mu": (0.0, 1.0),
        "compensator.phi_rad": (0.0, 4.0 * math.pi),
        "compensator.band_n": (1.0 / 256.0, 128.0),
        "compensator.hysteresis_n": (1.0 / 256.0, 32.0),
        "compensator.offset_n": (-64.0, 64.0),
        "compensator.mu_slope_per_n": (-1 / 128, 1 / 128),
        "compensator.tc_min_n": (0.0, 64.0),
        "compensator.preview_ticks": (0, 128),
        "compensator.lead_ticks": (0, 128),
        "compensator.ramp_ticks": (1, 256),
        "compensator.dead_zone_spread": (0.0, 1.0),
        "compensator.breakaway": (0.0, 0.25),
        "compensator.slack_tension_n": (0.0, 64.0),
        "compensator.mu_per_inlet_rate": (0.0, 1.0 / 16.0),
        "compensator.est_enable": (0, 1),
        "compensator.est_tau_ticks": (16, 32768),  # and a power of two (the firmware's check)
        "compensator.est_rate_per_s": (0.0, 1000.0),
        "compensator.est_mu_phi_min": (0.0, 4.0),
        "compensator.est_mu_phi_max": (0.0, 4.0),
        "compensator.est_t_min_n": (0.0, 64.0),
        "compensator.corr_enable": (0, 1),
        "compensator.corr_ki_shift": (4, 16),
        "compensator.corr_hold_ticks": (0, 4096),
        "compensator.corr_limit": (0.0, 1.0),
        "compensator.corr_tare_ticks": (1, 1024),  # and a power of two (the firmware's check)
        "compensator.corr_tare_max_n": (0.0, 8.0),
        "compensator.corr_slide_gate": (0, 1),
        "compensator.corr_offset_term": (0, 1),
        "compensator.corr_rev_enable": (0, 1),
        "compensator.corr_rev_ki_shift": (2, 16),
        "compensator.corr_rev_bin_shift": (0, 7),  # [0, 6] by ticks (the firmware's check)
        "compensator.corr_rev_lead_ticks": (0, 64),
        "compensator.corr_rev_leak_shift": (2, 24),
        "compensator.corr_rev_limit_n": (0.0, 8.0),
        "compensator.corr_rev_index": (0, 1),
        "compensator.corr_kp": (0.0, 4.0),
        # The board's chain (cosim.parts.interface): conversion timing, reader and PWM clocks,
        # ESCON.
        "board.adc_period_s": (1e-6, 0.1),
        "board.adc_phase_s": (0.0, 0.1),
        "board.sclk_half_clks": (1, 1024),
        "board.clk_hz": (1e5, 1e9),
        "board.pwm_hz": (10.0, 5000.0),
        "board.pwm_imax_q12": (1, 32767),
        "board.escon_imax_a": (0.01, 100.0),
        "board.escon_duty_resolution": (0.0, 0.1),
        "board.escon_duty_error": (-0.1, 0.1),
        "board.t_out_stuck_s": (0.0, 1e6),
        "board.t_out_absent_s": (0.0, 1e6),
    }


# Fields that take null (the default: the scenario's phi, the ADC part's own period and reader
# clock) and fields
# that are whole numbers (clock counts, register words).
NULLABLE_FIELDS = {
    "compensator.phi_rad",
    "board.adc_period_s",
    "board.sclk_half_clks",
    "board.t_out_stuck_s",
    "board.t_out_absent_s",
}
WHOLE_FIELDS = {
    "board.sclk_half_clks",
    "board.pwm_imax_q12",
    "compensator.preview_ticks",
    "compensator.lead_ticks",
    "compensator.ramp_ticks",
    "compensator.est_enable",
    "compensator.est_tau_ticks",
    "compensator.corr_enable",
    "compensator.corr_ki_shift",
    "compensator.corr_hold_ticks",
    "compensator.corr_tare_ticks",
    "compensator.corr_slide_gate",
    "compensator.corr_offset_term",
    "compensator.corr_rev_enable",
    "compensator.corr_rev_ki_shift",
    "compensator.corr_rev_bin_shift",
    "compensator.corr_rev_lead_ticks",
    "compensator.corr_rev_leak_shift",
    "compensator.corr_rev_index",
}


@dataclass
class BoardParams:
    """The board's sensing and actuation chain (cosim.parts.interface, `--interface board|adc`): the
    load-cell ADC and the ESCON's PWM set value, with their datasheet defaults."""

    # A part of cosim.parts.interface.ADC_PARTS: the board's ADS131M02 (hdl/README.md, "Sensing"),
    # or the first boards' ADS1220.
    adc: str = "ads131m02"
    adc_period_s: float | None = None  # None: the part's conversion period
    adc_phase_s: float = 0.0  # first conversion window starts at t = phase
    # Reader SCLK half period in board clocks; None: the part's reader default
    # (cosim.parts.interface.AdcPart.sclk_half_clks: ADS1220 8 = 3 MHz, ADS131M02 4 = 6 MHz at 48
    # MHz).
    sclk_half_clks: float | None = None
    clk_hz: float = 48e6  # board clock (iCE40 UP5K top): PWM resolution, reader timing
    pwm_hz: float = 5000.0  # ESCON PWM set value frequency (bowden_core PWM_HZ)
    pwm_imax_q12: float = 16384  # current at 90 % duty, Q3.12 (bowden_core PWM_IMAX_Q12)
    escon_imax_a: float = 4.0  # ESCON set value range: 10 % = -I, 90 % = +I
    escon_duty_resolution: float = 0.001  # the ESCON's duty measurement step (0: continuous)
    escon_duty_error: float = 0.0  # constant duty error of the ESCON's measurement (0..1)
    # The far-end load cell (ADS131M02 CH1, read by the online friction estimate) failing during
    # the run: its code holds from t_out_stuck_s, sits at the rail (an open bridge) from
    # t_out_absent_s; None: healthy. The native engine models it (cosim/engines/native/bn_api.h).
    t_out_stuck_s: float | None = None
    t_out_absent_s: float | None = None


@dataclass
class SimConfig:
    """Everything a run needs besides the scenario: rates, plant, controller, compensator."""

    sample_rate_hz: float = 10_000.0  # FPGA tension loop (hdl/README.md default)
    firmware_rate_hz: float = 1_000.0  # processor's compensator tick (firmware default)
    plant: dict[str, float] = field(default_factory=dict)  # FMU parameter overrides by name
    controller: ControllerParams = field(default_factory=ControllerParams)
    compensator: CompensatorParams = field(default_factory=CompensatorParams)
    board: BoardParams = field(default_factory=BoardParams)

    def to_dict(self) -> dict:
        data = asdict(self)
        del data["compensator"]["mode"]  # the run's --compensator, reported on its own
        return data

    @classmethod
    def from_dict(cls, data: dict, source: str = "params") -> SimConfig:
        """Build a configuration from a (partial) dict; unknown keys and bad values are errors
        (ValueError: one line naming `source`, the key and its allowed range)."""
        if not isinstance(data, dict):
            raise ValueError(f"{source}: expected a JSON object at the top level")
        cfg = cls()
        known = [f.name for f in fields(cls)]
        for key in data:
            if key not in known:
                raise ValueError(f"{source}: unknown key {key!r} (allowed: {', '.join(known)})")
        for key, (lo, hi) in RATE_RANGES_HZ.items():
            if key in data:
                value = _number(data[key], f"{source}: {key}", lo, hi, whole=True)
                setattr(cfg, key, float(value))
        if "plant" in data:
            cfg.plant = plant_overrides(data["plant"], f"{source}: plant")
        ranges = field_ranges(cfg.sample_rate_hz)
        cfg.controller = _sub(
            ControllerParams, data.get("controller", {}), source, "controller", ranges
        )
        cfg.compensator = _sub(
            CompensatorParams, data.get("compensator", {}), source, "compensator", ranges
        )
        cfg.board = _sub(BoardParams, data.get("board", {}), source, "board", ranges)
        cfg.validate(source)
        return cfg

    def validate(self, source: str = "params") -> None:
        """Raise ValueError naming the first variable that is out of its allowed range."""
        for key, (lo, hi) in RATE_RANGES_HZ.items():
            _number(getattr(self, key), f"{source}: {key}", lo, hi, whole=True)
        ratio = self.sample_rate_hz / self.firmware_rate_hz
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(
                f"{source}: sample_rate_hz / firmware_rate_hz must be a whole number >= 1; got "
                f"{self.sample_rate_hz:g} / {self.firmware_rate_hz:g}"
            )
        for name, (lo, hi) in field_ranges(self.sample_rate_hz).items():
            group, key = name.split(".")
            value = getattr(getattr(self, group), key)
            if name in NULLABLE_FIELDS and value is None:
                continue
            _number(value, f"{source}: {name}", lo, hi, whole=name in WHOLE_FIELDS)
        c = self.compensator
        if c.lead_ticks > c.preview_ticks:
            raise ValueError(
                f"{source}: compensator.lead_ticks must be in [0, compensator.preview_ticks = "
                f"{c.preview_ticks:g}]; got {c.lead_ticks!r}"
            )
        b = self.board
        if not isinstance(b.adc, str) or b.adc not in ADC_PARTS:
            raise ValueError(
                f"{source}: board.adc must be one of {', '.join(ADC_PARTS)}; got {b.adc!r}"
            )
        ratio = self.sample_rate_hz / b.pwm_hz
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(
                f"{source}: board.pwm_hz must divide sample_rate_hz ({self.sample_rate_hz:g}); "
                f"got {b.pwm_hz:g}"
            )

    @property
    def decimation(self) -> int:
        """FPGA samples per firmware tick."""
        return int(round(self.sample_rate_hz / self.firmware_rate_hz))


def _show(value, limit: int = 60) -> str:
    """A value from a params file as it was written there (JSON), on one line, shortened."""
    if isinstance(value, HugeInt):
        return repr(value)
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 200:
        return f"an integer of {len(str(abs(value)))} digits"
    try:
        text = json.dumps(value)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _number(value, name: str, lo: float, hi: float, whole: bool = False) -> float:
    kind = "a whole number" if whole else "a number"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name} must be {kind} in [{lo:g}, {hi:g}]; got {_show(value)}")
    try:
        v = float(value)
    except OverflowError:  # a whole number beyond every double: outside any range
        v = math.inf
    if not math.isfinite(v) or v < lo or v > hi:
        raise ValueError(f"{name} must be in [{lo:g}, {hi:g}]; got {_show(value)}")
    if whole and v != math.floor(v):
        raise ValueError(f"{name} must be {kind} in [{lo:g}, {hi:g}]; got {_show(value)}")
    return v


def _name_list(names: list[str]) -> str:
    """Names for an error line, a numbered family in one entry (slack_table_0..7)."""
    out: list[str] = []
    families: dict[str, list[int]] = {}
    for name in names:
        m = re.fullmatch(r"(.*_)(\d+)", name)
        if m is None:
            out.append(name)
        elif m.group(1) not in families:
            families[m.group(1)] = [int(m.group(2))]
            out.append(m.group(1))  # replaced below, in the family's first place
        else:
            families[m.group(1)].append(int(m.group(2)))
    return ", ".join(
        (
            f"{n}{min(families[n])}..{max(families[n])}"
            if len(families[n]) > 1
            else f"{n}{families[n][0]}"
        )
        if n in families
        else n
        for n in out
    )


def plant_overrides(plant, source: str) -> dict[str, float | int]:
    """FMU parameter overrides checked against the FMU's own modelDescription.xml: parameters
    only, not those the command line or the closed loop own (PLANT_OWNED), each of its type and
    within its range; Integer parameters take whole numbers only (nothing is truncated)."""
    from cosim.parts.plant import fmu_variables  # noqa: PLC0415 (reads the built FMU)

    if not isinstance(plant, dict):
        raise ValueError(f"{source} must be an object of FMU parameter values by name")
    variables = fmu_variables()
    settable = [
        v.name
        for v in variables.values()
        if v.causality == "parameter" and v.name not in PLANT_OWNED
    ]
    out: dict[str, float | int] = {}
    for key, value in plant.items():
        var = variables.get(key)
        if key in PLANT_OWNED:
            raise ValueError(f"{source}.{key} {PLANT_OWNED[key]}; a params file cannot set it")
        if var is None or var.causality != "parameter":
            what = (
                f"is an FMU {var.causality} (the scenario and the loop drive it)"
                if var is not None
                else "is not a parameter of the FMU"
            )
            near = difflib.get_close_matches(str(key), settable, n=1)
            hint = f" (did you mean {near[0]!r}?)" if near else ""
            raise ValueError(f"{source}: {key!r} {what}{hint}; parameters: {_name_list(settable)}")
        if var.type == "Boolean":
            if not isinstance(value, bool):
                raise ValueError(f"{source}.{key} must be true or false; got {_show(value)}")
            out[key] = value
            continue
        lo = var.lo if var.lo is not None else -math.inf
        hi = var.hi if var.hi is not None else math.inf
        v = _number(value, f"{source}.{key}", lo, hi, whole=var.type == "Integer")
        out[key] = int(v) if var.type == "Integer" else v
    return out


def _sub(cls, data, source: str, group: str, ranges: dict[str, tuple[float, float]]):
    if not isinstance(data, dict):
        raise ValueError(f"{source}: {group} must be a JSON object")
    obj = cls()
    known = {f.name: f for f in fields(cls) if f"{group}.{f.name}" not in RUN_OWNED}
    for key, value in data.items():
        if f"{group}.{key}" in RUN_OWNED:
            raise ValueError(f"{source}: {group}.{key} {RUN_OWNED[f'{group}.{key}']}")
        if key not in known:
            raise ValueError(
                f"{source}: {group}: unknown key {key!r} (allowed: {', '.join(known)})"
            )
        name = f"{group}.{key}"
        if value is None and name in NULLABLE_FIELDS:
            obj = replace(obj, **{key: None})
            continue
        if name == "board.adc":
            if not isinstance(value, str):
                raise ValueError(
                    f"{source}: board.adc must be the name of an ADC ({', '.join(ADC_PARTS)}); "
                    f"got {_show(value)}"
                )
            obj = replace(obj, adc=value)
            continue
        lo, hi = ranges[name]
        number = _number(value, f"{source}: {name}", lo, hi, whole=name in WHOLE_FIELDS)
        obj = replace(obj, **{key: int(number) if name in WHOLE_FIELDS else number})
    return obj


def load_params(path: str | Path | None) -> SimConfig:
    """The default configuration, overridden by the JSON file `path` when given; ValueError (one
    line naming the file and what is wrong) for a file that cannot be used."""
    if path is None:
        return SimConfig()
    p = Path(path)
    name = shown(p)
    try:
        data = read_json(p, "a params file (a JSON object)", "valid JSON", name=name)
    except DataFileError as exc:
        raise ValueError(f"--params: {exc}") from None
    return SimConfig.from_dict(data, source=name)
