"""The firmware as the co-simulation drives it, on top of cosim.parts.firmware (the firmware part's
ctypes wrapper of build/firmware/host/libbowden_fw.so): configuration from a SimConfig (the
loop's register words from the controller's SI gains), the register shadow, the tick and the
write log (the firmware never calls back into Python). The compensator's double twin and the Q7.8
words of T_ref come from cosim.parts.firmware directly.
"""

from __future__ import annotations

from cosim.config.run import ControllerParams, SimConfig
from cosim.parts import firmware, regmap, rtl_model


def _field_word(reg: str, value: float) -> int:
    """SI value -> register field word (regmap formats), range-checked with a clear error."""
    f = regmap.REGISTERS[reg].fields[0]
    word = int(round(value * (1 << f.frac)))
    if not f.min <= word <= f.max:
        lo, hi = f.min / (1 << f.frac), f.max / (1 << f.frac)
        raise ValueError(f"{reg} = {value!r} is outside the register's range [{lo:g}, {hi:g}]")
    return word


def loop_words(ctrl: ControllerParams, sample_rate_hz: float) -> dict[str, int]:
    """The tension loop's register words (fw_loop_config_t fields) for the controller's SI
    parameters; the ADC calibration is the RTL's default (rtl_model), full scale +-64 N."""
    return {
        "kff": _field_word("KFF", ctrl.kff_a_per_n),
        "kp": _field_word("KP", ctrl.kp_a_per_n),
        "ki_ts": _field_word("KI_TS", ctrl.ki_a_per_n_s / sample_rate_hz),
        "i_limit": _field_word("I_LIMIT", ctrl.i_limit_a),
        "slew": _field_word("SLEW", ctrl.slew_n_per_sample) if ctrl.slew_n_per_sample else 0,
        "slew_en": 1 if ctrl.slew_n_per_sample > 0 else 0,
        "adc_offset": rtl_model.DEFAULT_ADC_OFFSET,
        "adc_gain": rtl_model.DEFAULT_ADC_GAIN,
        # The rate feedforward (fw.h): kv in A s/N as Q7.24, its bound as UQ3.12 A.
        "kv": kv_word(ctrl.kv_a_s_per_n),
        "uff_limit": _field_word("UFF", ctrl.uff_limit_a),
    }


KV_FRAC = 24  # fw.h: loop.kv, A s/N, Q7.24


def kv_word(kv_a_s_per_n: float) -> int:
    """The firmware's rate feedforward gain word (fw.h loop.kv, Q7.24 A s/N), range-checked."""
    word = int(round(kv_a_s_per_n * (1 << KV_FRAC)))
    if not 0 <= word <= firmware.FW_KV_MAX:
        raise ValueError(f"kv = {kv_a_s_per_n!r} A s/N is outside the firmware's range [0, 1/16]")
    return word


class FirmwareBridge:
    """One firmware instance on a register shadow, configured for a co-simulation run."""

    def __init__(self, cfg: SimConfig, compensator: str, phi_rad: float) -> None:
        words = loop_words(cfg.controller, cfg.sample_rate_hz)
        self.fw = firmware.make_firmware(
            compensator,
            cfg.compensator,
            phi_rad,
            tick_rate_hz=cfg.firmware_rate_hz,
            sample_rate_hz=cfg.sample_rate_hz,
            loop=words,
        )
        self.adc_offset = words["adc_offset"]
        self.adc_gain = words["adc_gain"]

    def _drain(self) -> list[tuple[int, int]]:
        writes = self.fw.drain_writes()
        if self.fw.log_dropped:
            raise RuntimeError("the firmware's write log overflowed (writes were lost)")
        return writes

    def start(self) -> list[tuple[int, int]]:
        """fw_start: the register writes that configure and enable the loop, in order."""
        self.fw.start()
        return self._drain()

    def shadow_set(self, addr: int, value: int) -> None:
        """Mirror a register word read from the RTL into the firmware's shadow."""
        self.fw.shadow_write(addr, value)

    def tick(self, t_ref_n: float) -> tuple[float, list[tuple[int, int]]]:
        """One firmware tick with T_ref (N; the host passes it as a Q7.8 word): returns T_c (N)
        and the register writes to perform."""
        tc_word = self.fw.tick(t_ref_n)
        return tc_word / 256.0, self._drain()
