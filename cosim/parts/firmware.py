"""The firmware's host build (build/firmware/host/libbowden_fw.so) through ctypes.

Three things, as the co-simulation needs them (firmware/README.md, host build):

- `Compensator`: the fixed-point friction compensator (firmware/include/comp.h), stepped one
  Q7.8 reference at a time or over an array;
- `CompensatorF64`: its double twin (comp_f64.h), the oracle of the fixed-point one and the
  compensator of the co-simulation's float reference (`make_compensator_f64`);
- `Firmware`: the whole processor side (fw.h) on a register shadow: the host writes what it read
  from the RTL into the shadow (`shadow_write`), calls `tick`, then drains the firmware's register
  writes (`drain_writes`) and performs them on the RTL over AXI4-Lite. No C -> Python callbacks.

Configuration is checked by the C code, which returns an error code; it is raised here as
`FirmwareConfigError` naming the field and its allowed range, and the previous configuration stays
in force. Tension words are Q7.8 newtons (LSB 1/256 N), as on the bus.

Build the library first with `make firmware`.
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from cosim.project.paths import BUILD_DIR

LIB_PATH = BUILD_DIR / "firmware" / "host" / "libbowden_fw.so"

Q7_8_LSB_N = 1.0 / 256.0
Q7_8_MIN, Q7_8_MAX = -32768, 32767
MODES = {"none": 0, "paper": 1, "smooth": 2, "preview": 3}
SOURCES = {"host": 0, "wave": 1}
WAVE_KINDS = {"constant": 0, "sine": 1, "triangle": 2, "ramp": 3, "step": 4}  # WAVE_* of wave.h
FW_KV_MAX = 1 << 20  # fw.h: the rate feedforward gain loop.kv at most 1/16 A s/N (Q7.24)

# Bound of |fixed - double twin| in Q7.8 LSB without a friction slope (COMP_ERR_BOUND_LSB).
ERR_BOUND_LSB = 1.0
# Gain table spacing of the fixed-point compensator (COMP_TAB_SHIFT = 9: 512 LSB = 2 N).
TABLE_STEP_N = 2.0
FULL_SCALE_N = 128.0
# comp.h COMP_MU_SLOPE_RANGE_N: the tension up to which the friction slope's law holds (mu + s*T
# >= 0 is checked there) and above which the gain tables stay constant.
MU_SLOPE_RANGE_N = 48.0
# comp.h COMP_DZ_PLAYS: the strands of the compensator's dead-zone inverse.
COMP_DZ_PLAYS = 8
# comp.h COMP_VISC_X_MAX_Q28: the viscous term's largest growth of the friction exponent.
VISC_X_MAX = 1.0


class FirmwareConfigError(ValueError):
    """A configuration the firmware rejected; `field` names the offending field."""

    def __init__(self, code: int, message: str):
        self.code = code
        self.message = message
        self.field = message.split(":", 1)[0]
        super().__init__(f"{message} (firmware status {code})")

    def __reduce__(self):
        # A study's worker process sends it back pickled; the default would call __init__ with
        # the formatted text alone and break the worker pool instead of raising it.
        return type(self), (self.code, self.message)


# --- mirrors of the C structures (all fields 32 bits; sizes checked against the library) ----


class CompConfig(ctypes.Structure):
    """comp_config_t (comp.h)."""

    _fields_ = [
        ("mode", ctypes.c_int32),
        ("mu_q28", ctypes.c_int32),
        ("phi_rad_q24", ctypes.c_int32),
        ("mu_slope_per_n_q28", ctypes.c_int32),
        ("offset_n_q8", ctypes.c_int32),
        ("hysteresis_n_q8", ctypes.c_int32),
        ("band_n_q8", ctypes.c_int32),
        ("tc_min_n_q8", ctypes.c_int32),
        ("preview_ticks", ctypes.c_int32),
        ("lead_ticks", ctypes.c_int32),
        ("ramp_ticks", ctypes.c_int32),
        ("dead_zone_spread_q28", ctypes.c_int32),
        ("breakaway_q28", ctypes.c_int32),
        ("slack_tension_n_q8", ctypes.c_int32),
        ("mu_per_inlet_rate_q28", ctypes.c_int32),
    ]


class CompF64Config(ctypes.Structure):
    """comp_f64_config_t (comp_f64.h)."""

    _fields_ = [
        ("mode", ctypes.c_int32),
        ("mu", ctypes.c_double),
        ("phi_rad", ctypes.c_double),
        ("mu_slope_per_n", ctypes.c_double),
        ("offset_n", ctypes.c_double),
        ("hysteresis_n", ctypes.c_double),
        ("band_n", ctypes.c_double),
        ("tc_min_n", ctypes.c_double),
        ("preview_ticks", ctypes.c_int32),
        ("lead_ticks", ctypes.c_int32),
        ("ramp_ticks", ctypes.c_int32),
        ("dead_zone_spread", ctypes.c_double),
        ("breakaway", ctypes.c_double),
        ("slack_tension_n", ctypes.c_double),
        ("mu_per_inlet_rate", ctypes.c_double),
    ]


class WaveConfig(ctypes.Structure):
    """wave_config_t (wave.h)."""

    _fields_ = [
        ("kind", ctypes.c_int32),
        ("mean_n_q8", ctypes.c_int32),
        ("amplitude_n_q8", ctypes.c_int32),
        ("freq_hz_q16", ctypes.c_uint32),
        ("phase0", ctypes.c_uint32),
    ]


LOOP_FIELDS = (
    "kff",
    "kp",
    "ki_ts",
    "i_limit",
    "slew",
    "slew_en",
    "wdt_timeout",
    "adc_offset",
    "adc_gain",
    "adc_min",
    "adc_max",
    "adc_stale",
    "oc_timeout",
    "kv",
    "uff_limit",
)


class LoopConfig(ctypes.Structure):
    """fw_loop_config_t (fw.h): register words in the formats of bowden_regs.h."""

    _fields_ = [(name, ctypes.c_int32) for name in LOOP_FIELDS]


class EstConfig(ctypes.Structure):
    """fric_est_config_t (fric_est.h)."""

    _fields_ = [
        ("enable", ctypes.c_int32),
        ("tau_ticks", ctypes.c_int32),
        ("rate_q28", ctypes.c_int32),
        ("mu_phi_min_q28", ctypes.c_int32),
        ("mu_phi_max_q28", ctypes.c_int32),
        ("t_min_n_q8", ctypes.c_int32),
    ]


class CorrConfig(ctypes.Structure):
    """fric_corr_config_t (fric_est.h)."""

    _fields_ = [
        ("enable", ctypes.c_int32),
        ("ki_shift", ctypes.c_int32),
        ("hold_ticks", ctypes.c_int32),
        ("limit_q28", ctypes.c_int32),
        ("tare_ticks", ctypes.c_int32),
        ("tare_max_n_q8", ctypes.c_int32),
        ("slide_gate", ctypes.c_int32),
        ("offset_term", ctypes.c_int32),
        ("rev_enable", ctypes.c_int32),
        ("rev_ki_shift", ctypes.c_int32),
        ("rev_bin_shift", ctypes.c_int32),
        ("rev_lead_ticks", ctypes.c_int32),
        ("rev_leak_shift", ctypes.c_int32),
        ("rev_limit_n_q8", ctypes.c_int32),
        ("rev_index", ctypes.c_int32),
        ("kp_q16", ctypes.c_int32),
    ]


class FwConfig(ctypes.Structure):
    """fw_config_t (fw.h)."""

    _fields_ = [
        ("tick_rate_hz", ctypes.c_uint32),
        ("sample_rate_hz", ctypes.c_uint32),
        ("source", ctypes.c_int32),
        ("comp", CompConfig),
        ("wave", WaveConfig),
        ("loop", LoopConfig),
        ("est", EstConfig),
        ("corr", CorrConfig),
    ]


class Telemetry(ctypes.Structure):
    """fw_telemetry_t (fw.h)."""

    _fields_ = [
        ("ticks", ctypes.c_uint32),
        ("t_ref", ctypes.c_int32),
        ("t_c", ctypes.c_int32),
        ("t_in", ctypes.c_int32),
        ("u", ctypes.c_int32),
        ("status", ctypes.c_uint32),
        ("fault", ctypes.c_uint32),
        ("sample_count", ctypes.c_uint32),
        ("fault_ticks", ctypes.c_uint32),
        ("direction", ctypes.c_int32),
        ("blend_q30", ctypes.c_int32),
        ("t_out", ctypes.c_int32),
        ("est_mu_phi_q28", ctypes.c_int32),
        ("est_faults", ctypes.c_uint32),
        ("corr_n_q8", ctypes.c_int32),
        ("corr_faults", ctypes.c_uint32),
    ]


# fw_host_sizeof() selectors (fw_host.h) and the mirror each must match.
_SIZEOF = {
    1: CompConfig,
    3: CompF64Config,
    5: FwConfig,
    6: Telemetry,
}

_lib: ctypes.CDLL | None = None


def load_library(path: Path | str | None = None) -> ctypes.CDLL:
    """Load libbowden_fw.so once, declare the signatures and check the structure mirrors."""
    global _lib
    if _lib is not None and path is None:
        return _lib
    lib_path = Path(path) if path is not None else LIB_PATH
    if not lib_path.exists():
        raise FileNotFoundError(f"{lib_path} does not exist: build it with `make firmware`")
    lib = ctypes.CDLL(str(lib_path))
    i16, i32, u32, vp = ctypes.c_int16, ctypes.c_int32, ctypes.c_uint32, ctypes.c_void_p
    dbl = ctypes.c_double
    sigs = {
        "fw_host_sizeof": (u32, [i32]),
        "fw_strerror": (ctypes.c_char_p, [i32]),
        "comp_config_default": (None, [vp]),
        "comp_init": (None, [vp]),
        "comp_configure": (i32, [vp, vp]),
        "comp_reset": (None, [vp]),
        "comp_step_q7_8": (i16, [vp, i16]),
        "comp_direction": (i32, [vp]),
        "comp_blend_q1_30": (i32, [vp]),
        "comp_run_q7_8": (None, [vp, vp, vp, u32]),
        "comp_f64_config_default": (None, [vp]),
        "comp_f64_init": (None, [vp]),
        "comp_f64_configure": (i32, [vp, vp]),
        "comp_f64_reset": (None, [vp]),
        "comp_step_f64": (dbl, [vp, dbl]),
        "comp_run_f64": (None, [vp, vp, vp, u32]),
        "comp_set_tick_rate_hz": (i32, [vp, u32]),
        "comp_f64_set_tick_rate_hz": (i32, [vp, dbl]),
        "comp_hold_slack": (None, [vp, i32]),
        "comp_f64_hold_slack": (None, [vp, i32]),
        "fxp_exp_uq8_24": (u32, [i32]),
        "fw_config_default": (None, [vp]),
        "fw_host_init": (None, [vp]),
        "fw_host_configure": (i32, [vp, vp]),
        "fw_host_start": (None, [vp]),
        "fw_host_stop": (None, [vp]),
        "fw_host_fault_clear": (None, [vp]),
        "fw_host_tick": (i16, [vp, i16]),
        "fw_host_shadow_set": (None, [vp, u32, u32]),
        "fw_host_shadow_get": (u32, [vp, u32]),
        "fw_host_drain": (u32, [vp, vp, vp, u32]),
        "fw_host_telemetry": (None, [vp, vp]),
        "fw_host_log_dropped": (u32, [vp]),
        "fw_host_bad_access": (u32, [vp]),
    }
    for name, (res, args) in sigs.items():
        fn = getattr(lib, name)
        fn.restype = res
        fn.argtypes = args
    for which, struct in _SIZEOF.items():
        size = lib.fw_host_sizeof(which)
        if size != ctypes.sizeof(struct):
            raise RuntimeError(
                f"{struct.__name__}: the Python mirror has {ctypes.sizeof(struct)} bytes, the "
                f"library {size}: cosim/parts/firmware.py is out of date with firmware/include"
            )
    if path is None:
        _lib = lib
    return lib


def strerror(code: int) -> str:
    """The firmware's message for a status code (names the field and its allowed range)."""
    return load_library().fw_strerror(code).decode()


def _check(code: int) -> None:
    if code != 0:
        raise FirmwareConfigError(code, strerror(code))


def _real(name: str, value) -> float:
    """`value` as a finite float; FirmwareConfigError naming `name` otherwise (a bool is not a
    number here: True would silently mean 1)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise FirmwareConfigError(-1, f"{name}: expected a number; got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise FirmwareConfigError(-1, f"{name}: not a finite number ({value!r})")
    return v


def _fixed(name: str, value: float, frac_bits: int) -> int:
    """round(value * 2^frac_bits), saturated to int32 so that the firmware's own range check
    (not a Python overflow) rejects out-of-range values with the field's range. The saturation
    is decided before the product, which overflows a double for |value| near 1e300."""
    v = _real(name, value)
    limit = 2**31 / 2.0**frac_bits
    if v >= limit:
        return 2**31 - 1
    if v <= -limit:
        return -(2**31)
    return int(max(-(2**31), min(2**31 - 1, round(v * (1 << frac_bits)))))


def _whole(name: str, value, lo: int, hi: int, what: str) -> int:
    """A whole number in [lo, hi] (the C field's type); FirmwareConfigError naming `name` for a
    fraction (nothing is truncated), a non-number or a value beyond the type."""
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        v = int(value)
    else:
        f = _real(name, value)
        if f != math.floor(f):
            raise FirmwareConfigError(-1, f"{name}: {value!r} is not a whole number ({what})")
        v = int(f)
    if not lo <= v <= hi:
        raise FirmwareConfigError(-1, f"{name}: {value!r} is outside [{lo}, {hi}] ({what})")
    return v


def tension_word(t_n: float) -> int:
    """A tension in N as the Q7.8 bus word: rounded to 1/256 N and saturated to the int16 range."""
    v = float(t_n)
    if math.isnan(v):
        raise ValueError("t_ref_n: NaN is not a tension")
    if v >= FULL_SCALE_N:
        return Q7_8_MAX
    if v <= -FULL_SCALE_N:
        return Q7_8_MIN
    return max(Q7_8_MIN, min(Q7_8_MAX, int(round(v * 256.0))))


def tension_words(t_n) -> np.ndarray:
    """tension_word over an array, as int16: the same words at every value (rounded half to even
    as round() does, saturated at and beyond full scale), ValueError for a NaN. The native
    engine's set-up takes the firmware's T_ref words of a whole run at once with it."""
    v = np.asarray(t_n, dtype=np.float64)
    if np.isnan(v).any():
        raise ValueError("t_ref_n: NaN is not a tension")
    # Clipped to +-full scale first (no overflow for huge values): 128 N * 256 = 32768 rounds
    # and saturates to Q7_8_MAX as the scalar form does.
    q = np.rint(np.clip(v, -FULL_SCALE_N, FULL_SCALE_N) * 256.0)
    return np.clip(q, Q7_8_MIN, Q7_8_MAX).astype(np.int16)


_C_DEFAULTS: dict | None = None


def c_defaults() -> dict:
    """The compensator's defaults as the C firmware sets them (comp_f64_config_default), read
    from the host library once, when first needed: the one source of CompensatorParams'
    defaults (the fixed-point comp_config_default holds the same values, tests/firmware)."""
    global _C_DEFAULTS
    if _C_DEFAULTS is None:
        c = CompF64Config()
        load_library().comp_f64_config_default(ctypes.byref(c))
        values = {name: getattr(c, name) for name, _ in CompF64Config._fields_}
        values["mode"] = {code: name for name, code in MODES.items()}[values["mode"]]
        _C_DEFAULTS = values
    return dict(_C_DEFAULTS)


def _c_default(name: str):
    return field(default_factory=lambda: c_defaults()[name])


@dataclass
class CompensatorParams:
    """The compensator's configuration in SI units (comp.h gives the law and the limits), for
    the firmware and for a run (SimConfig.compensator, params files). Every default is the C
    firmware's (c_defaults), except phi_rad: None there means "the bending angle of the sheath
    at the scenario's start position", calibrated once per run as in the paper, where the
    compensator uses the friction identified in the characterisation
    (cosim.engines.reference.resolve_phi); the C structs get the firmware's default (2*pi, loop
    routing) when it is still None."""

    # none | paper | smooth | preview; a run takes it from --compensator (SimConfig leaves it out)
    mode: str = _c_default("mode")
    mu: float = _c_default("mu")  # friction coefficient, [0, 1] (paper Fig. 11)
    phi_rad: float | None = None  # bending angle, [0, 4*pi] (loop routing: 2*pi)
    # H as the firmware default (4 LSB of Q7.8); B chosen by `bowden tune` (the firmware default).
    band_n: float = _c_default("band_n")  # smooth inverse band B, [1/256, 128] N
    hysteresis_n: float = _c_default("hysteresis_n")  # direction detector band H, [1/256, 32] N
    offset_n: float = _c_default("offset_n")  # output sensor offset, [-64, 64] N (audit)
    # friction rising with tension, [-1/128, 1/128] 1/N (audit extension)
    mu_slope_per_n: float = _c_default("mu_slope_per_n")
    tc_min_n: float = _c_default("tc_min_n")  # floor of T_c (a cable cannot push), [0, 64] N
    # Preview mode (comp.h): T_ref handed preview_ticks firmware ticks ahead, [0, 128]; the gain
    # applies to T_ref lead_ticks ahead, [0, P]; a change of branch takes ramp_ticks, [1, 256].
    # Chosen by `bowden tune` on the tune scenario (hdl/README.md).
    preview_ticks: int = _c_default("preview_ticks")
    lead_ticks: int = _c_default("lead_ticks")
    ramp_ticks: int = _c_default("ramp_ticks")
    # Gradual dead zone's spread (comp.h: the inverse of the strands' PI model), log std of the
    # friction thresholds, [0, 1]; 0 is the sharp capstan inverse (audit: dead_zone_spread).
    dead_zone_spread: float = _c_default("dead_zone_spread")
    # Breakaway (comp.h: static friction's excess over mu after a reversal, placed so that the
    # cable's jump falls halfway), [0, 0.25]; 0 is off (audit: mu_static_excess).
    breakaway: float = _c_default("breakaway")
    # Slack (comp.h: pretension lost below this input tension, T_c = sqrt(T_c1 * S) there),
    # [0, 64] N; 0 is off (audit: slack_tension).
    slack_tension_n: float = _c_default("slack_tension_n")
    # Viscous friction (comp.h: the friction exponent grows by m_r * r_hat * phi on the branch,
    # r_hat the predicted inlet tension's rate), [0, 1/16] s/N; 0 is off (audit:
    # mu_viscous_tension_rate, or mu_viscous through the cable's stretch per inlet tension).
    mu_per_inlet_rate: float = _c_default("mu_per_inlet_rate")
    # Online friction estimate from the far-end load cell (firmware/include/fric_est.h; a part
    # of fw_config_t, not of comp_config_t), off by default: EstimatorParams's fields with est_.
    est_enable: int = 0
    est_tau_ticks: int = 128
    est_rate_per_s: float = 2.0
    est_mu_phi_min: float = 0.05
    est_mu_phi_max: float = 2.0
    est_t_min_n: float = 0.5
    # Far-end output correction (fric_est.h, "The far-end output correction"; a part of
    # fw_config_t), off by default: CorrectorParams's fields with corr_.
    corr_enable: int = 0
    corr_ki_shift: int = 6
    corr_hold_ticks: int = 30
    corr_limit: float = 0.5
    corr_tare_ticks: int = 64
    corr_tare_max_n: float = 0.5
    corr_slide_gate: int = 0
    corr_offset_term: int = 0
    corr_rev_enable: int = 0
    corr_rev_ki_shift: int = 4
    corr_rev_bin_shift: int = 6
    corr_rev_lead_ticks: int = 0
    corr_rev_leak_shift: int = 12
    corr_rev_limit_n: float = 2.0
    corr_rev_index: int = 0
    corr_kp: float = 0.0

    @property
    def phi_c_rad(self) -> float:
        """The bending angle the C structs get: phi_rad, or the firmware's default when None."""
        return c_defaults()["phi_rad"] if self.phi_rad is None else self.phi_rad

    def mode_code(self) -> int:
        if not isinstance(self.mode, str) or self.mode not in MODES:
            raise FirmwareConfigError(-1, f"comp.mode: {self.mode!r} is not one of {list(MODES)}")
        return MODES[self.mode]

    def to_c(self) -> CompConfig:
        return CompConfig(
            mode=self.mode_code(),
            mu_q28=_fixed("comp.mu", self.mu, 28),
            phi_rad_q24=_fixed("comp.phi_rad", self.phi_c_rad, 24),
            mu_slope_per_n_q28=_fixed("comp.mu_slope_per_n", self.mu_slope_per_n, 28),
            offset_n_q8=_fixed("comp.offset_n", self.offset_n, 8),
            hysteresis_n_q8=_fixed("comp.hysteresis_n", self.hysteresis_n, 8),
            band_n_q8=_fixed("comp.band_n", self.band_n, 8),
            tc_min_n_q8=_fixed("comp.tc_min_n", self.tc_min_n, 8),
            **self._ticks(),
            dead_zone_spread_q28=_fixed("comp.dead_zone_spread", self.dead_zone_spread, 28),
            breakaway_q28=_fixed("comp.breakaway", self.breakaway, 28),
            slack_tension_n_q8=_fixed("comp.slack_tension_n", self.slack_tension_n, 8),
            mu_per_inlet_rate_q28=_fixed("comp.mu_per_inlet_rate", self.mu_per_inlet_rate, 28),
        )

    def quantized(self) -> CompensatorParams:
        """The same parameters as the fixed-point compensator holds them (for the twin)."""
        c = self.to_c()
        return CompensatorParams(
            mode=self.mode,
            mu=c.mu_q28 / 2**28,
            phi_rad=c.phi_rad_q24 / 2**24,
            mu_slope_per_n=c.mu_slope_per_n_q28 / 2**28,
            offset_n=c.offset_n_q8 / 256.0,
            hysteresis_n=c.hysteresis_n_q8 / 256.0,
            band_n=c.band_n_q8 / 256.0,
            tc_min_n=c.tc_min_n_q8 / 256.0,
            preview_ticks=c.preview_ticks,
            lead_ticks=c.lead_ticks,
            ramp_ticks=c.ramp_ticks,
            dead_zone_spread=c.dead_zone_spread_q28 / 2**28,
            breakaway=c.breakaway_q28 / 2**28,
            slack_tension_n=c.slack_tension_n_q8 / 256.0,
            mu_per_inlet_rate=c.mu_per_inlet_rate_q28 / 2**28,
        )

    def to_c_f64(self) -> CompF64Config:
        values = {}
        for name in (
            "mu",
            "phi_rad",
            "mu_slope_per_n",
            "offset_n",
            "hysteresis_n",
            "band_n",
            "tc_min_n",
            "dead_zone_spread",
            "breakaway",
            "slack_tension_n",
            "mu_per_inlet_rate",
        ):
            value = self.phi_c_rad if name == "phi_rad" else getattr(self, name)
            values[name] = _real(f"comp.{name}", value)
        return CompF64Config(mode=self.mode_code(), **values, **self._ticks())

    def _ticks(self) -> dict[str, int]:
        """The preview fields as the C structs' int32 (comp_check_preview checks their ranges)."""
        return {
            name: _whole(f"comp.{name}", getattr(self, name), -(2**31), 2**31 - 1, "ticks")
            for name in ("preview_ticks", "lead_ticks", "ramp_ticks")
        }

    def gains(self, t_n: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """G_up and G_dn at output tension |T| (comp.h): the capstan relation integrated with
        mu(T) = mu + mu_slope_per_n*T; exp(+-mu*phi) without a slope."""
        a = np.minimum(np.abs(np.asarray(t_n, dtype=float)), Q7_8_MAX * Q7_8_LSB_N)
        a = np.minimum(a, MU_SLOPE_RANGE_N)  # the law's range; the gains stay there above it
        x = self.mu * self.phi_c_rad
        e = math.exp(x)
        q = self.phi_c_rad * math.expm1(x) / x if x > 0 else self.phi_c_rad
        c = self.mu_slope_per_n * q * a
        return e / (1.0 - c), 1.0 / (e + c)

    def _gain_stats(self) -> tuple[float, float, float, float]:
        """Largest G_up, G_up - G_dn, |dG/dT| and |d2G/dT2| of either branch over [0, 128] N
        (constant above MU_SLOPE_RANGE_N: the extremes lie in [0, MU_SLOPE_RANGE_N])."""
        x = self.mu * self.phi_c_rad
        e = math.exp(x)
        q = self.phi_c_rad * math.expm1(x) / x if x > 0 else self.phi_c_rad
        k = self.mu_slope_per_n * q
        a = np.linspace(0.0, MU_SLOPE_RANGE_N, 193)
        du, dd = 1.0 - k * a, e + k * a
        gu, gd = e / du, 1.0 / dd
        d1 = np.maximum(np.abs(e * k / du**2), np.abs(k / dd**2))
        d2 = np.maximum(np.abs(2 * e * k * k / du**3), np.abs(2 * k * k / dd**3))
        return float(gu.max()), float((gu - gd).max()), float(d1.max()), float(d2.max())

    def error_bound_n(self, tc_min_n=None):
        """Documented bound of |T_c fixed - T_c twin| in N (comp.h): 1 LSB, plus the linear
        interpolation of the gain table when the friction slope is not zero; with the viscous
        term, that bound times e^COMP_VISC_X_MAX (the largest factor it applies to the gain) plus
        1 LSB (the roundings of r_hat and of e^x, measured well below it); with a breakaway,
        that bound times e^(2 mu phi + 9b/8) (the hold's factor on the extreme Y of the T_c put
        out, the largest factor it applies to a T_c) plus 1 LSB (its two roundings); with a
        slack S, that bound times the root's slope sqrt(S / T_c1) / 2 where it exceeds 1, plus
        1/2 LSB (its rounding), for T_c1 (the T_c without the root) no smaller than `tc_min_n`
        (required with a slack: the slope grows without bound towards 0; a float or an array, one
        bound per T_c1)."""
        d2 = self._gain_stats()[3]
        bound = ERR_BOUND_LSB * Q7_8_LSB_N + FULL_SCALE_N * TABLE_STEP_N**2 / 8.0 * d2
        if self.mu_per_inlet_rate > 0:
            bound = bound * math.exp(VISC_X_MAX) + Q7_8_LSB_N
        if self.breakaway > 0:
            x = (2.0 * self.mu + 1.125 * self.breakaway) * self.phi_c_rad
            bound = bound * math.exp(x) + Q7_8_LSB_N
        if self.slack_tension_n > 0:
            if tc_min_n is None or not np.all(np.asarray(tc_min_n) > 0):
                raise ValueError("error_bound_n: with a slack, tc_min_n > 0 is required")
            slope = 0.5 * np.sqrt(self.slack_tension_n / np.asarray(tc_min_n, dtype=float))
            bound = bound * np.maximum(1.0, slope) + 0.5 * Q7_8_LSB_N
        return bound

    def step_bound_n(self, dref_n, tmax_n):
        """Documented bound of |T_c[k] - T_c[k-1]| in N in smooth mode (comp.h), for a reference
        step dref_n and the larger |T_ref - offset| tmax_n of the two steps (floats or arrays)."""
        gu_max, spread, d1, _ = self._gain_stats()
        return np.abs(dref_n) * (gu_max + tmax_n * (spread / self.band_n + d1)) + 2 * Q7_8_LSB_N


# The FMU's cable_EA and loadcell_stiffness defaults (fmu/gen_model.py; tests/fmu holds these
# copies to it): this layer cannot import the audit's twin, which holds them too.
FMU_CABLE_EA_N = 8000.0
FMU_LOADCELL_N_PER_M = 2e5


def mu_per_inlet_rate_of_cable_speed(
    mu_viscous_s_per_m: float,
    mu: float,
    phi_rad: float,
    sheath_length_m: float = 1.0,
    cable_ea_n: float | None = None,
    loadcell_stiffness_n_per_m: float | None = None,
) -> tuple[float, float]:
    """The compensator's m_r (s/N) that stands for the FMU's cable-speed form `mu_viscous`
    (fmu/README.md "Viscous friction": mu + mu_viscous |v_c|, v_c the inlet's speed), on the
    loading and on the unloading branch: on a sliding branch the inlet moves by the cable's
    stretch inside the sheath, T_in L_s / EA times (1 - e^(-a))/a loading and (e^a - 1)/a
    unloading (a = mu phi, the tension exponential along a sheath whose bend is spread evenly
    over its length, as the FMU's segments are), plus the load cell's give T_out / k_lc, so v_c
    = m |r_in| / mu_viscous with m the value returned for that branch. The defaults are the
    FMU's (sheath_length, cable_EA, loadcell_stiffness). The compensator takes one m_r for both
    branches (comp.h): their mean is the plain choice."""
    cable_ea_n = FMU_CABLE_EA_N if cable_ea_n is None else cable_ea_n
    if loadcell_stiffness_n_per_m is None:
        loadcell_stiffness_n_per_m = FMU_LOADCELL_N_PER_M
    a = mu * phi_rad
    up = -math.expm1(-a) / a if a > 0 else 1.0
    dn = math.expm1(a) / a if a > 0 else 1.0
    per_n = sheath_length_m / cable_ea_n
    return (
        mu_viscous_s_per_m * (per_n * up + math.exp(-a) / loadcell_stiffness_n_per_m),
        mu_viscous_s_per_m * (per_n * dn + math.exp(a) / loadcell_stiffness_n_per_m),
    )


def _params(params: CompensatorParams | None, overrides: dict) -> CompensatorParams:
    p = CompensatorParams() if params is None else params
    if overrides:
        p = CompensatorParams(**{**p.__dict__, **overrides})
    return p


class Compensator:
    """The fixed-point compensator (comp_step_q7_8): Q7.8 references in, Q7.8 T_c out, one step
    per tick of `tick_rate_hz` (whole Hz, [1, 65535]: the viscous term's rate; comp.h)."""

    def __init__(
        self,
        params: CompensatorParams | None = None,
        *,
        tick_rate_hz: float = 1000.0,
        **overrides,
    ):
        self._lib = load_library()
        self._buf = ctypes.create_string_buffer(self._lib.fw_host_sizeof(0))
        self._lib.comp_init(self._buf)
        hz = _whole("tick_rate_hz", tick_rate_hz, 0, 2**32 - 1, "Hz")
        _check(self._lib.comp_set_tick_rate_hz(self._buf, hz))
        self.params = CompensatorParams(mode="paper")
        self.configure(_params(params, overrides))

    def configure(self, params: CompensatorParams) -> None:
        """Apply a configuration; raises FirmwareConfigError and keeps the previous one."""
        _check(self._lib.comp_configure(self._buf, ctypes.byref(params.to_c())))
        self.params = params

    def reset(self) -> None:
        self._lib.comp_reset(self._buf)

    def hold_slack(self, held: bool) -> None:
        """The slack's root held off (True) or in force (False) from the next step
        (comp_hold_slack: the firmware holds it while the far-end cell is tared)."""
        self._lib.comp_hold_slack(self._buf, 1 if held else 0)

    def step_word(self, t_ref_word: int) -> int:
        """One step on bus words: T_ref (Q7.8, int16) -> T_c (Q7.8, int16)."""
        if not Q7_8_MIN <= int(t_ref_word) <= Q7_8_MAX:
            raise ValueError(f"t_ref_word: {t_ref_word} outside the int16 range of Q7.8")
        return int(self._lib.comp_step_q7_8(self._buf, int(t_ref_word)))

    def step(self, t_ref_n: float) -> float:
        """One step in newtons: T_ref is quantized to Q7.8 (saturated), T_c returned in N."""
        return self.step_word(tension_word(t_ref_n)) * Q7_8_LSB_N

    def run_words(self, t_ref_words: Iterable[int] | np.ndarray) -> np.ndarray:
        """Steps over an array of Q7.8 words (int16), returning the T_c words."""
        src = np.ascontiguousarray(np.asarray(t_ref_words), dtype=np.int64)
        if src.size and (src.min() < Q7_8_MIN or src.max() > Q7_8_MAX):
            raise ValueError("t_ref_words: outside the int16 range of Q7.8")
        src = src.astype(np.int16)
        out = np.empty_like(src)
        self._lib.comp_run_q7_8(self._buf, src.ctypes.data, out.ctypes.data, src.size)
        return out

    @property
    def direction(self) -> int:
        """+1 loading, -1 unloading (the held sign of dT_ref/dt)."""
        return int(self._lib.comp_direction(self._buf))

    @property
    def blend(self) -> float:
        """Smooth inverse blend weight s/B: 1 on the loading branch, 0 on the unloading one."""
        return self._lib.comp_blend_q1_30(self._buf) / 2**30


class CompensatorF64:
    """The double twin (comp_step_f64): the same law without quantization, one step per tick of
    `tick_rate_hz` ([1, 65535] Hz)."""

    def __init__(
        self,
        params: CompensatorParams | None = None,
        *,
        tick_rate_hz: float = 1000.0,
        **overrides,
    ):
        self._lib = load_library()
        self._buf = ctypes.create_string_buffer(self._lib.fw_host_sizeof(2))
        self._lib.comp_f64_init(self._buf)
        hz = _real("tick_rate_hz", tick_rate_hz)
        _check(self._lib.comp_f64_set_tick_rate_hz(self._buf, hz))
        self.params = CompensatorParams(mode="paper")
        self.configure(_params(params, overrides))

    def configure(self, params: CompensatorParams) -> None:
        """Apply a configuration; raises FirmwareConfigError and keeps the previous one."""
        _check(self._lib.comp_f64_configure(self._buf, ctypes.byref(params.to_c_f64())))
        self.params = params

    def reset(self) -> None:
        self._lib.comp_f64_reset(self._buf)

    def hold_slack(self, held: bool) -> None:
        """comp_hold_slack's twin."""
        self._lib.comp_f64_hold_slack(self._buf, 1 if held else 0)

    def step(self, t_ref_n: float) -> float:
        """One step: T_ref in N -> T_c in N (saturated to the Q7.8 range like the bus)."""
        v = float(t_ref_n)
        if not math.isfinite(v):
            raise ValueError(f"t_ref_n: not a finite tension ({t_ref_n!r})")
        return float(self._lib.comp_step_f64(self._buf, v))

    def run(self, t_ref_n: Iterable[float] | np.ndarray) -> np.ndarray:
        src = np.ascontiguousarray(np.asarray(t_ref_n), dtype=np.float64)
        if not np.all(np.isfinite(src)):
            raise ValueError("t_ref_n: not all finite")
        out = np.empty_like(src)
        self._lib.comp_run_f64(self._buf, src.ctypes.data, out.ctypes.data, src.size)
        return out


def _params_from(mode: str, params: CompensatorParams, phi_rad: float) -> CompensatorParams:
    """A run's compensator parameters with the run's mode and calibrated bending angle."""
    return replace(params, mode=mode, phi_rad=float(phi_rad))


def make_compensator(
    mode: str, params: CompensatorParams, phi_rad: float, tick_rate_hz: float = 1000.0
) -> Compensator:
    """The fixed-point compensator configured from a scenario's compensator parameters."""
    return Compensator(_params_from(mode, params, phi_rad), tick_rate_hz=tick_rate_hz)


def make_compensator_f64(
    mode: str, params: CompensatorParams, phi_rad: float, tick_rate_hz: float = 1000.0
) -> CompensatorF64:
    """The double twin configured exactly as the fixed-point compensator would be (its
    parameters quantized the same way, at the firmware's tick rate), for the co-simulation's
    float reference."""
    return CompensatorF64(
        _params_from(mode, params, phi_rad).quantized(), tick_rate_hz=tick_rate_hz
    )


@dataclass
class WaveParams:
    """The firmware's reference generator (wave.h)."""

    kind: str = "sine"  # constant | sine | triangle | ramp | step
    mean_n: float = 7.5
    amplitude_n: float = 7.5
    freq_hz: float = 0.5
    phase0_turns: float = 0.0

    def to_c(self) -> WaveConfig:
        if not isinstance(self.kind, str) or self.kind not in WAVE_KINDS:
            raise FirmwareConfigError(
                -1, f"wave.kind: {self.kind!r} is not one of {list(WAVE_KINDS)}"
            )
        freq = _fixed("wave.freq_hz", self.freq_hz, 16)
        if freq < 0:
            raise FirmwareConfigError(-1, f"wave.freq_hz: negative ({self.freq_hz})")
        turns = _real("wave.phase0_turns", self.phase0_turns)
        phase = int(round((turns % 1.0) * 2**32)) % 2**32  # UQ0.32 turns
        return WaveConfig(
            kind=WAVE_KINDS[self.kind],
            mean_n_q8=_fixed("wave.mean_n", self.mean_n, 8),
            amplitude_n_q8=_fixed("wave.amplitude_n", self.amplitude_n, 8),
            freq_hz_q16=min(freq, 2**32 - 1),
            phase0=phase,
        )


@dataclass
class EstimatorParams:
    """The online friction estimate (fric_est.h) in SI units: off by default; tau in accepted
    samples (a power of two), the largest change of mu*phi per second, its bounds, and the
    minimum tension on both cells below which no sample is used."""

    enable: int = 0  # 0 off, 1 on
    tau_ticks: int = 128  # forgetting time constant, power of two in [16, 32768] samples
    rate_per_s: float = 2.0  # largest change of mu*phi per second (0.002 per tick at 1 kHz)
    mu_phi_min: float = 0.05  # bounds of mu*phi, [0, 4]
    mu_phi_max: float = 2.0
    t_min_n: float = 0.5  # minimum tension on both cells, [0, 64] N

    def to_c(self, tick_rate_hz: float) -> EstConfig:
        # Per tick; a tick rate of 0 is the firmware check's to reject (tick_rate_hz), not a
        # ZeroDivisionError here.
        rate = _real("est.rate_per_s", self.rate_per_s) / max(1.0, float(tick_rate_hz))
        return EstConfig(
            enable=_whole("est.enable", self.enable, -(2**31), 2**31 - 1, "0 or 1"),
            tau_ticks=_whole("est.tau_ticks", self.tau_ticks, -(2**31), 2**31 - 1, "samples"),
            rate_q28=_fixed("est.rate", rate, 28),
            mu_phi_min_q28=_fixed("est.mu_phi_min", self.mu_phi_min, 28),
            mu_phi_max_q28=_fixed("est.mu_phi_max", self.mu_phi_max, 28),
            t_min_n_q8=_fixed("est.t_min_n", self.t_min_n, 8),
        )


def estimator_from(params) -> EstimatorParams:
    """EstimatorParams from an object with est_* fields (`CompensatorParams` above);
    the defaults (off) for any it lacks."""
    d = EstimatorParams()
    return EstimatorParams(
        enable=int(getattr(params, "est_enable", d.enable)),
        tau_ticks=int(getattr(params, "est_tau_ticks", d.tau_ticks)),
        rate_per_s=float(getattr(params, "est_rate_per_s", d.rate_per_s)),
        mu_phi_min=float(getattr(params, "est_mu_phi_min", d.mu_phi_min)),
        mu_phi_max=float(getattr(params, "est_mu_phi_max", d.mu_phi_max)),
        t_min_n=float(getattr(params, "est_t_min_n", d.t_min_n)),
    )


@dataclass
class CorrectorParams:
    """The far-end output correction (fric_est.h) in SI units: off by default; the integral
    rate 2^-ki_shift per tick, the ticks a branch is held after a change of branch, the bound of
    each branch's relative gain correction, the far-end tare's ticks and the largest T_in during
    it, its two options (slide gate, offset term) and the reversal table (rate 2^-rev_ki_shift
    per tick, bins of 2^rev_bin_shift ticks, the error credited rev_lead_ticks back, the leak
    2^-rev_leak_shift per update, the bound of an entry in N, and its index: 0 the ticks since
    the reversal, 1 the inlet tension's travel since it, bins of 2^rev_bin_shift / 256 N)."""

    enable: int = 0  # 0 off, 1 on
    ki_shift: int = 6  # rate 2^-ki_shift per tick, [4, 16]
    hold_ticks: int = 30  # [0, 4096]
    limit: float = 0.5  # bound of each branch's relative gain correction, [0, 1]
    tare_ticks: int = 64  # a power of two in [1, 1024]
    tare_max_n: float = 0.5  # [0, 8] N
    slide_gate: int = 0  # 1: integrate only while T_out slides with T_ref
    offset_term: int = 0  # 1: an offset per branch besides the gain
    rev_enable: int = 0  # 1: learn and apply the reversal table
    rev_ki_shift: int = 4  # [2, 16]
    rev_bin_shift: int = 6  # [0, 6]
    rev_lead_ticks: int = 0  # [0, 64]
    rev_leak_shift: int = 12  # [2, 24]
    rev_limit_n: float = 2.0  # [0, 8] N
    rev_index: int = 0  # 0 by ticks, 1 by the inlet tension's log travel (rev_bin_shift <= 7)
    kp: float = 0.0  # proportional gain on the far-end error, [0, 4] (0 off)

    def to_c(self) -> CorrConfig:
        return CorrConfig(
            enable=_whole("corr.enable", self.enable, -(2**31), 2**31 - 1, "0 or 1"),
            ki_shift=_whole("corr.ki_shift", self.ki_shift, -(2**31), 2**31 - 1, "a shift"),
            hold_ticks=_whole("corr.hold_ticks", self.hold_ticks, -(2**31), 2**31 - 1, "ticks"),
            limit_q28=_fixed("corr.limit", self.limit, 28),
            tare_ticks=_whole("corr.tare_ticks", self.tare_ticks, -(2**31), 2**31 - 1, "ticks"),
            tare_max_n_q8=_fixed("corr.tare_max_n", self.tare_max_n, 8),
            slide_gate=_whole("corr.slide_gate", self.slide_gate, -(2**31), 2**31 - 1, "0 or 1"),
            offset_term=_whole("corr.offset_term", self.offset_term, -(2**31), 2**31 - 1, "0 or 1"),
            rev_enable=_whole("corr.rev_enable", self.rev_enable, -(2**31), 2**31 - 1, "0 or 1"),
            rev_ki_shift=_whole(
                "corr.rev_ki_shift", self.rev_ki_shift, -(2**31), 2**31 - 1, "a shift"
            ),
            rev_bin_shift=_whole(
                "corr.rev_bin_shift", self.rev_bin_shift, -(2**31), 2**31 - 1, "a shift"
            ),
            rev_lead_ticks=_whole(
                "corr.rev_lead_ticks", self.rev_lead_ticks, -(2**31), 2**31 - 1, "ticks"
            ),
            rev_leak_shift=_whole(
                "corr.rev_leak_shift", self.rev_leak_shift, -(2**31), 2**31 - 1, "a shift"
            ),
            rev_limit_n_q8=_fixed("corr.rev_limit_n", self.rev_limit_n, 8),
            rev_index=_whole("corr.rev_index", self.rev_index, -(2**31), 2**31 - 1, "0 or 1"),
            kp_q16=_fixed("corr.kp", self.kp, 16),
        )


def corrector_from(params) -> CorrectorParams:
    """CorrectorParams from an object with corr_* fields (`CompensatorParams` above); the
    defaults (off) for any it lacks."""
    d = CorrectorParams()
    return CorrectorParams(
        enable=int(getattr(params, "corr_enable", d.enable)),
        ki_shift=int(getattr(params, "corr_ki_shift", d.ki_shift)),
        hold_ticks=int(getattr(params, "corr_hold_ticks", d.hold_ticks)),
        limit=float(getattr(params, "corr_limit", d.limit)),
        tare_ticks=int(getattr(params, "corr_tare_ticks", d.tare_ticks)),
        tare_max_n=float(getattr(params, "corr_tare_max_n", d.tare_max_n)),
        slide_gate=int(getattr(params, "corr_slide_gate", d.slide_gate)),
        offset_term=int(getattr(params, "corr_offset_term", d.offset_term)),
        rev_enable=int(getattr(params, "corr_rev_enable", d.rev_enable)),
        rev_ki_shift=int(getattr(params, "corr_rev_ki_shift", d.rev_ki_shift)),
        rev_bin_shift=int(getattr(params, "corr_rev_bin_shift", d.rev_bin_shift)),
        rev_lead_ticks=int(getattr(params, "corr_rev_lead_ticks", d.rev_lead_ticks)),
        rev_leak_shift=int(getattr(params, "corr_rev_leak_shift", d.rev_leak_shift)),
        rev_limit_n=float(getattr(params, "corr_rev_limit_n", d.rev_limit_n)),
        rev_index=int(getattr(params, "corr_rev_index", d.rev_index)),
        kp=float(getattr(params, "corr_kp", d.kp)),
    )


@dataclass
class FirmwareConfig:
    """The firmware's configuration (fw.h). `loop` overrides register words of the FPGA's loop
    by field name (LOOP_FIELDS, formats of bowden_regs.h); the rest keep their reset values."""

    tick_rate_hz: int = 1000
    sample_rate_hz: int = 10000
    source: str = "host"  # host | wave
    comp: CompensatorParams = field(default_factory=CompensatorParams)
    wave: WaveParams = field(default_factory=WaveParams)
    loop: dict[str, int] = field(default_factory=dict)
    est: EstimatorParams = field(default_factory=EstimatorParams)
    corr: CorrectorParams = field(default_factory=CorrectorParams)

    def to_c(self, lib: ctypes.CDLL) -> FwConfig:
        c = FwConfig()
        lib.fw_config_default(ctypes.byref(c))
        for name, value in (
            ("tick_rate_hz", self.tick_rate_hz),
            ("sample_rate_hz", self.sample_rate_hz),
        ):
            setattr(c, name, _whole(name, value, 0, 2**32 - 1, "an unsigned 32-bit rate in Hz"))
        if not isinstance(self.source, str) or self.source not in SOURCES:
            raise FirmwareConfigError(-1, f"source: {self.source!r} is not one of {list(SOURCES)}")
        c.source = SOURCES[self.source]
        c.comp = self.comp.to_c()
        c.wave = self.wave.to_c()
        for name, value in self.loop.items():
            if not isinstance(name, str) or name not in LOOP_FIELDS:
                raise FirmwareConfigError(
                    -1, f"loop.{name}: unknown, expected one of {LOOP_FIELDS}"
                )
            word = _whole(f"loop.{name}", value, -(2**31), 2**31 - 1, "a 32-bit register word")
            setattr(c.loop, name, word)
        c.est = self.est.to_c(self.tick_rate_hz)
        c.corr = self.corr.to_c()
        return c


def make_firmware(
    mode: str,
    params: CompensatorParams,
    phi_rad: float,
    tick_rate_hz: float = 1000.0,
    sample_rate_hz: float = 10000.0,
    loop: dict[str, int] | None = None,
) -> Firmware:
    """The firmware (host source for T_ref) with the compensator (and the online friction
    estimate, est_* fields) configured from a scenario's compensator parameters, as the
    co-simulation drives it; call start() and drain the writes."""
    config = FirmwareConfig(
        tick_rate_hz=tick_rate_hz,  # whole numbers of Hz (checked, not rounded)
        sample_rate_hz=sample_rate_hz,
        source="host",
        comp=_params_from(mode, params, phi_rad),
        loop=dict(loop or {}),
        est=estimator_from(params),
        corr=corrector_from(params),
    )
    return Firmware(config)


def _addr(reg: int | str) -> int:
    if isinstance(reg, str):
        from . import regmap  # noqa: PLC0415 (generated by the RTL part)

        return int(getattr(regmap, reg))
    return int(reg)


class Firmware:
    """The firmware on a register shadow: start, tick, drain the register writes (no callbacks into
    Python)."""

    def __init__(self, config: FirmwareConfig | None = None):
        self._lib = load_library()
        self._buf = ctypes.create_string_buffer(self._lib.fw_host_sizeof(4))
        self._lib.fw_host_init(self._buf)
        self._addrs = (ctypes.c_uint32 * 64)()
        self._values = (ctypes.c_uint32 * 64)()
        self._tel = Telemetry()
        self.config = FirmwareConfig()
        if config is not None:
            self.configure(config)

    def configure(self, config: FirmwareConfig) -> None:
        """Apply a configuration; raises FirmwareConfigError and keeps the previous one. The
        loop registers reach the FPGA at the next start()."""
        _check(self._lib.fw_host_configure(self._buf, ctypes.byref(config.to_c(self._lib))))
        self.config = config

    def start(self) -> None:
        """Queue the start-up writes: loop registers, TC = 0, fault clear, enable."""
        self._lib.fw_host_start(self._buf)

    def stop(self) -> None:
        self._lib.fw_host_stop(self._buf)

    def fault_clear(self) -> None:
        self._lib.fw_host_fault_clear(self._buf)

    def shadow_write(self, reg: int | str, value: int) -> None:
        """Mirror a register value read from the RTL into the shadow (not logged)."""
        self._lib.fw_host_shadow_set(self._buf, _addr(reg), int(value) & 0xFFFFFFFF)

    def shadow_read(self, reg: int | str) -> int:
        return int(self._lib.fw_host_shadow_get(self._buf, _addr(reg)))

    def tick_word(self, t_ref_word: int = 0) -> int:
        """One tick with T_ref as a Q7.8 word (ignored with the wave source); returns T_c."""
        if not Q7_8_MIN <= int(t_ref_word) <= Q7_8_MAX:
            raise ValueError(f"t_ref_word: {t_ref_word} outside the int16 range of Q7.8")
        return int(self._lib.fw_host_tick(self._buf, int(t_ref_word)))

    def tick(self, t_ref_n: float = 0.0) -> int:
        """One tick with T_ref in N (quantized to Q7.8); returns the T_c word written to TC."""
        return self.tick_word(tension_word(t_ref_n))

    def drain_writes(self) -> list[tuple[int, int]]:
        """The register writes since the last drain, oldest first, as (address, value)."""
        out = []
        while True:
            n = self._lib.fw_host_drain(self._buf, self._addrs, self._values, 64)
            out.extend((self._addrs[i], self._values[i]) for i in range(n))
            if n < 64:
                return out

    @property
    def log_dropped(self) -> int:
        """Writes lost because the log was full (drain at least every few ticks)."""
        return int(self._lib.fw_host_log_dropped(self._buf))

    @property
    def bad_access(self) -> int:
        return int(self._lib.fw_host_bad_access(self._buf))

    def telemetry(self) -> dict[str, int | float]:
        """The telemetry of the last tick, raw words plus T_ref, T_c, T_in in N and U in A."""
        self._lib.fw_host_telemetry(self._buf, ctypes.byref(self._tel))
        t = {name: getattr(self._tel, name) for name, _ in Telemetry._fields_}
        t["t_ref_n"] = t["t_ref"] * Q7_8_LSB_N
        t["t_c_n"] = t["t_c"] * Q7_8_LSB_N
        t["t_in_n"] = t["t_in"] * Q7_8_LSB_N
        t["u_a"] = t["u"] / 4096.0
        t["blend"] = t["blend_q30"] / 2**30
        t["t_out_n"] = t["t_out"] * Q7_8_LSB_N
        t["mu_phi"] = t["est_mu_phi_q28"] / 2**28
        t["corr_n"] = t["corr_n_q8"] * Q7_8_LSB_N
        return t
