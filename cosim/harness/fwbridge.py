"""The firmware's host build (build/firmware/host/libbowden_fw.so, `make firmware`) as the
co-simulation drives it: configuration from a SimConfig, the register shadow, the tick and the
write log (contract.md: no C -> Python callbacks), and the compensator's double twin for the float
reference.

The co-simulation needs only the C API of firmware/host/fw_host.h; the structures it fills
(fw_config_t, comp_f64_config_t) are mirrored here and checked against the library's own
fw_host_sizeof, so a change of layout is an error, not a silent corruption.
"""

from __future__ import annotations

import ctypes
import math
from ctypes import POINTER, c_double, c_int16, c_int32, c_uint32, c_void_p

from .. import regmap
from ..paths import BUILD_DIR
from ..scenarios import CompensatorParams, ControllerParams, SimConfig

LIB_PATH = BUILD_DIR / "firmware" / "host" / "libbowden_fw.so"

COMP_MODES = {"none": 0, "paper": 1, "smooth": 2}  # COMP_MODE_* (firmware/include/comp.h)
FW_SOURCE_HOST = 0  # fw.h

# fw_host_sizeof selectors (fw_host.h)
_SIZEOF_COMP_F64, _SIZEOF_COMP_F64_CONFIG, _SIZEOF_FW_HOST, _SIZEOF_FW_CONFIG = 2, 3, 4, 5


class _CompConfig(ctypes.Structure):  # comp_config_t (comp.h)
    _fields_ = [
        ("mode", c_int32),
        ("mu_q28", c_int32),  # Q3.28
        ("phi_rad_q24", c_int32),  # Q7.24 rad
        ("mu_slope_per_n_q28", c_int32),  # Q3.28 per N
        ("offset_n_q8", c_int32),  # Q7.8 N
        ("hysteresis_n_q8", c_int32),
        ("band_n_q8", c_int32),
    ]


class _WaveConfig(ctypes.Structure):  # wave_config_t (wave.h)
    _fields_ = [
        ("kind", c_int32),
        ("mean_n_q8", c_int32),
        ("amplitude_n_q8", c_int32),
        ("freq_hz_q16", c_uint32),
        ("phase0", c_uint32),
    ]


class _LoopConfig(ctypes.Structure):  # fw_loop_config_t (fw.h): register words
    _fields_ = [
        (name, c_int32)
        for name in (
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
        )
    ]


class _FwConfig(ctypes.Structure):  # fw_config_t (fw.h)
    _fields_ = [
        ("tick_rate_hz", c_uint32),
        ("sample_rate_hz", c_uint32),
        ("source", c_int32),
        ("comp", _CompConfig),
        ("wave", _WaveConfig),
        ("loop", _LoopConfig),
    ]


class _CompF64Config(ctypes.Structure):  # comp_f64_config_t (comp_f64.h)
    _fields_ = [
        ("mode", c_int32),
        ("mu", c_double),
        ("phi_rad", c_double),
        ("mu_slope_per_n", c_double),
        ("offset_n", c_double),
        ("hysteresis_n", c_double),
        ("band_n", c_double),
    ]


_lib = None


def load_library():
    """The firmware's host library, with the signatures the co-simulation uses."""
    global _lib
    if _lib is not None:
        return _lib
    if not LIB_PATH.is_file():
        raise RuntimeError(f"{LIB_PATH} does not exist: run `make firmware` first")
    lib = ctypes.CDLL(str(LIB_PATH))
    sigs = {
        "fw_host_sizeof": (c_uint32, [c_int32]),
        "fw_host_init": (None, [c_void_p]),
        "fw_host_configure": (c_int32, [c_void_p, c_void_p]),
        "fw_host_start": (None, [c_void_p]),
        "fw_host_tick": (c_int16, [c_void_p, c_int16]),
        "fw_host_shadow_set": (None, [c_void_p, c_uint32, c_uint32]),
        "fw_host_drain": (c_uint32, [c_void_p, POINTER(c_uint32), POINTER(c_uint32), c_uint32]),
        "fw_host_log_dropped": (c_uint32, [c_void_p]),
        "fw_config_default": (None, [c_void_p]),
        "fw_strerror": (ctypes.c_char_p, [c_int32]),
        "comp_f64_config_default": (None, [c_void_p]),
        "comp_f64_init": (None, [c_void_p]),
        "comp_f64_configure": (c_int32, [c_void_p, c_void_p]),
        "comp_step_f64": (c_double, [c_void_p, c_double]),
    }
    for name, (res, args) in sigs.items():
        fn = getattr(lib, name)
        fn.restype = res
        fn.argtypes = args
    for which, struct in (
        (_SIZEOF_FW_CONFIG, _FwConfig),
        (_SIZEOF_COMP_F64_CONFIG, _CompF64Config),
    ):
        size = lib.fw_host_sizeof(which)
        if size != ctypes.sizeof(struct):
            raise RuntimeError(
                f"{LIB_PATH.name}: {struct.__name__} is {size} bytes in C, "
                f"{ctypes.sizeof(struct)} in cosim/harness/fwbridge.py (layout changed)"
            )
    _lib = lib
    return lib


def _q(value: float, frac: int) -> int:
    return int(round(value * (1 << frac)))


def _field_word(reg: str, value: float) -> int:
    """SI value -> register field word (regmap formats), range-checked with a clear error."""
    f = regmap.REGISTERS[reg].fields[0]
    word = _q(value, f.frac)
    if not f.min <= word <= f.max:
        lo, hi = f.min / (1 << f.frac), f.max / (1 << f.frac)
        raise ValueError(f"{reg} = {value!r} is outside the register's range [{lo:g}, {hi:g}]")
    return word


def loop_words(ctrl: ControllerParams, sample_rate_hz: float) -> dict[str, int]:
    """The tension loop's gain and limit registers for the controller parameters."""
    return {
        "kff": _field_word("KFF", ctrl.kff_a_per_n),
        "kp": _field_word("KP", ctrl.kp_a_per_n),
        "ki_ts": _field_word("KI_TS", ctrl.ki_a_per_n_s / sample_rate_hz),
        "i_limit": _field_word("I_LIMIT", ctrl.i_limit_a),
        "slew": _field_word("SLEW", ctrl.slew_n_per_sample) if ctrl.slew_n_per_sample else 0,
        "slew_en": 1 if ctrl.slew_n_per_sample > 0 else 0,
    }


def _check(code: int, what: str) -> None:
    if code != 0:
        lib = load_library()
        raise ValueError(f"{what}: {lib.fw_strerror(code).decode()} (code {code})")


class FirmwareBridge:
    """One firmware instance on a register shadow, configured for a co-simulation run."""

    def __init__(self, cfg: SimConfig, compensator: str, phi_rad: float) -> None:
        lib = load_library()
        self._lib = lib
        self._h = ctypes.create_string_buffer(lib.fw_host_sizeof(_SIZEOF_FW_HOST))
        lib.fw_host_init(self._h)
        fc = _FwConfig()
        lib.fw_config_default(ctypes.byref(fc))
        fc.tick_rate_hz = int(round(cfg.firmware_rate_hz))
        fc.sample_rate_hz = int(round(cfg.sample_rate_hz))
        fc.source = FW_SOURCE_HOST
        _fill_comp(fc.comp, compensator, cfg.compensator, phi_rad)
        for name, word in loop_words(cfg.controller, cfg.sample_rate_hz).items():
            setattr(fc.loop, name, word)
        _check(lib.fw_host_configure(self._h, ctypes.byref(fc)), "firmware configuration")
        self.config = fc
        self.adc_offset = int(fc.loop.adc_offset)
        self.adc_gain = int(fc.loop.adc_gain)
        self._addrs = (c_uint32 * 64)()
        self._values = (c_uint32 * 64)()

    def _drain(self) -> list[tuple[int, int]]:
        n = self._lib.fw_host_drain(self._h, self._addrs, self._values, 64)
        if self._lib.fw_host_log_dropped(self._h):
            raise RuntimeError("the firmware's write log overflowed (writes were lost)")
        return [(self._addrs[i], self._values[i]) for i in range(n)]

    def start(self) -> list[tuple[int, int]]:
        """fw_start: the register writes that configure and enable the loop, in order."""
        self._lib.fw_host_start(self._h)
        return self._drain()

    def shadow_set(self, addr: int, value: int) -> None:
        """Mirror a register word read from the RTL into the firmware's shadow."""
        self._lib.fw_host_shadow_set(self._h, addr, value & 0xFFFFFFFF)

    def tick(self, t_ref_n: float) -> tuple[float, list[tuple[int, int]]]:
        """One firmware tick with T_ref (N, quantized to Q7.8 as the host source passes it):
        returns T_c (N) and the register writes to perform."""
        q = max(-32768, min(32767, int(round(t_ref_n * 256.0))))
        tc = self._lib.fw_host_tick(self._h, q)
        return tc / 256.0, self._drain()


def _fill_comp(cc: _CompConfig, mode: str, p: CompensatorParams, phi_rad: float) -> None:
    if mode not in COMP_MODES:
        raise ValueError(f"compensator must be one of {', '.join(COMP_MODES)}; got {mode!r}")
    cc.mode = COMP_MODES[mode]
    cc.mu_q28 = _q(p.mu, 28)
    cc.phi_rad_q24 = _q(phi_rad, 24)
    cc.mu_slope_per_n_q28 = _q(p.mu_slope_per_n, 28)
    cc.offset_n_q8 = _q(p.offset_n, 8)
    cc.hysteresis_n_q8 = max(1, _q(p.hysteresis_n, 8))
    cc.band_n_q8 = max(1, _q(p.band_n, 8))


class CompensatorF64:
    """The compensator's double twin (firmware/src/comp_f64.c), configured like the firmware's
    fixed-point one (same mode, mu, phi, band, hysteresis, extensions; no quantization)."""

    def __init__(self, mode: str, p: CompensatorParams, phi_rad: float) -> None:
        lib = load_library()
        if mode not in COMP_MODES:
            raise ValueError(f"compensator must be one of {', '.join(COMP_MODES)}; got {mode!r}")
        self._lib = lib
        self._c = ctypes.create_string_buffer(lib.fw_host_sizeof(_SIZEOF_COMP_F64))
        lib.comp_f64_init(self._c)
        cc = _CompF64Config()
        lib.comp_f64_config_default(ctypes.byref(cc))
        cc.mode = COMP_MODES[mode]
        cc.mu = p.mu
        cc.phi_rad = phi_rad
        cc.mu_slope_per_n = p.mu_slope_per_n
        cc.offset_n = p.offset_n
        # The fixed-point firmware holds H and B in Q7.8; the twin gets the same values.
        cc.hysteresis_n = max(1, _q(p.hysteresis_n, 8)) / 256.0
        cc.band_n = max(1, _q(p.band_n, 8)) / 256.0
        code = lib.comp_f64_configure(self._c, ctypes.byref(cc))
        _check(code, "compensator (double twin) configuration")
        self._step = lib.comp_step_f64

    def step(self, t_ref_n: float) -> float:
        """One step: T_ref (N) -> T_c (N)."""
        return self._step(self._c, t_ref_n)


def phi_is_valid(phi_rad: float) -> bool:
    return math.isfinite(phi_rad) and 0.0 <= phi_rad <= 4.0 * math.pi
