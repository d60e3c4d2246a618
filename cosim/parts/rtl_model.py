"""Bit-exact Python model of the RTL tension loop (hdl/rtl/tension_loop.v) and its float twin.

The fixed-point model is the definition the cocotb testbenches hold the RTL to, sample by sample.
Formats (hdl/README.md has the full table): tensions Q7.8 N, current Q3.12 A, Kff and Kp Q2.13 A/N,
Ki*Ts with LSB 2^-20 A/N per sample, integrator Q3.28 A, ADC gain with LSB 2^-20 Q7.8-LSB per code.

Per sample tick (`TensionLoopModel.tick`):

    T_in = sat16(floor(((raw - ADC_OFFSET) * ADC_GAIN + 2^19) / 2^20))
    T_c' = max(T_c, or clamp(T_c, T_c'[n-1] - SLEW, T_c'[n-1] + SLEW) with CTRL.SLEW_EN, TC_MIN)
    e    = sat16(T_c' - T_in)
    I'   = clamp(I + s, +-I_LIMIT*2^16), s = 0 if the previous output was saturated high and
           KI_TS*e > 0 (or low and < 0), else s = KI_TS*e          (Q3.28, anti-windup)
    r    = floor((Kff*T_c' + Kp*e + 2^8 + floor(I' / 2^7)) / 2^9) + UFF   (Q3.12, rounded)
    u    = clamp(r, +-I_LIMIT); saturated high/low = r > I_LIMIT / r < -I_LIMIT

UFF (Q3.12 A) is the processor's current feedforward (its rate feedforward, fw.h): a whole
number of output LSB added outside the PI, so the integrator never sees it.

`FloatTensionLoop` is the same loop in double precision (the oracle for the fixed-point error).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from . import regmap

# Formats (fractional bits) of the words the loop uses.
TENSION_FRAC = 8  # Q7.8 N
CURRENT_FRAC = 12  # Q3.12 A
GAIN_FRAC = 13  # Q2.13 A/N (Kff, Kp)
KI_TS_FRAC = 20  # A/N per sample
INTEG_FRAC = 28  # Q3.28 A
ADC_GAIN_FRAC = 20  # Q7.8 LSB per ADC code

ADC_CODE_MIN = -(1 << 23)
ADC_CODE_MAX = (1 << 23) - 1

#: Clocks from the sample tick to `out_valid` in tension_loop.v; ticks must be this far apart.
LATENCY_CLKS = 15
#: Default watchdog ramp of u towards zero, Q3.12 A per sample (tension_loop WDT_RAMP_STEP).
WDT_RAMP_STEP = regmap.WDT_RAMP_STEP

# Default calibration: reset values of the register map (+-2^23 codes = +-64 N).
DEFAULT_ADC_OFFSET = regmap.REGISTERS["ADC_OFFSET"].fields[0].reset
DEFAULT_ADC_GAIN = regmap.REGISTERS["ADC_GAIN"].fields[0].reset


def _sat(value: int, bits: int) -> int:
    lo, hi = -(1 << (bits - 1)), (1 << (bits - 1)) - 1
    return lo if value < lo else hi if value > hi else value


def _clamp(value: int, lo: int, hi: int) -> int:
    return lo if value < lo else hi if value > hi else value


def calibrate(raw: int, offset: int, gain: int) -> int:
    """Q7.8 tension from a raw 24-bit ADC code, as the RTL computes it (round half up)."""
    return _sat(((raw - offset) * gain + (1 << 19)) >> ADC_GAIN_FRAC, 16)


def adc_code_from_tension(
    tension_n: float, offset: int = DEFAULT_ADC_OFFSET, gain: int = DEFAULT_ADC_GAIN
) -> int:
    """The ideal load-cell ADC: the 24-bit code whose calibrated value is `tension_n`.

    Inverse of `calibrate` (code = offset + tension * 256 * 2^20 / gain, rounded), clipped to the
    24-bit code range as a real converter clips. Raises ValueError for gain == 0 or an offset
    outside the 24-bit range.
    """
    if gain == 0:
        raise ValueError("gain=0 outside the allowed range: a nonzero ADC_GAIN is needed")
    if not ADC_CODE_MIN <= offset <= ADC_CODE_MAX:
        raise ValueError(
            f"offset={offset} outside the allowed range {ADC_CODE_MIN}..{ADC_CODE_MAX}"
        )
    code = round(offset + tension_n * (1 << TENSION_FRAC) * (1 << ADC_GAIN_FRAC) / gain)
    return _clamp(code, ADC_CODE_MIN, ADC_CODE_MAX)


@dataclass
class LoopOutput:
    """What the RTL shows after one sample (all integers, formats as the registers)."""

    u: int
    out_en: bool
    saturated: bool
    wdt_ramp: bool
    faults: int
    t_in: int
    integ: int
    tc_eff: int
    sample_count: int


def _reset_regs() -> dict[str, int]:
    return {
        name: reg.fields[0].reset
        for name, reg in regmap.REGISTERS.items()
        if reg.fields[0].access == "rw" and len(reg.fields) == 1
    }


@dataclass
class TensionLoopModel:
    """Bit-exact model of tension_loop.v behind the register map.

    Drive it as the RTL is driven: `write(name, value)` for register writes (field values, e.g.
    `write("TC", 2560)`; CTRL takes the bit mask), `adc_sample(code)` for each valid ADC sample,
    and `tick()` at each sample tick, which returns the LoopOutput the RTL shows after it.
    """

    wdt_ramp_step: int = WDT_RAMP_STEP
    regs: dict[str, int] = field(default_factory=_reset_regs)
    enable: bool = False
    slew_en: bool = False

    def __post_init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """State after `rst`: registers at reset values, output disabled."""
        self.regs = _reset_regs()
        self.enable = False
        self.slew_en = False
        self.raw = 0
        self.fresh = False
        self.tc_written = False
        self.integ_reset_pending = False
        self.fault_clear_pending = False
        self.stale_cnt = 0
        self.wdt_cnt = 0
        self.oc_cnt = 0
        self.faults = 0
        self.sample_count = 0
        self.t_in = 0
        self.u = 0
        self.out_en = False
        self.saturated = False
        self.sat_hi = self.sat_lo = False
        self.wdt_ramp = False
        self.integ = 0
        self.tc_eff = 0

    # --- events between ticks ------------------------------------------------------------------

    def write(self, name: str, value: int) -> None:
        """A register write with the RTL's side effects (TC refreshes the watchdog; CTRL pulses).

        Raises ValueError naming the register when `value` is outside its field's range.
        """
        if name == "CTRL":
            if not 0 <= value <= 0xFFFFFFFF:
                raise ValueError(f"CTRL={value} outside the allowed range 0..0xFFFFFFFF")
            self.enable = bool(value & regmap.CTRL_ENABLE)
            self.slew_en = bool(value & regmap.CTRL_SLEW_EN)
            self.integ_reset_pending |= bool(value & regmap.CTRL_INTEG_RESET)
            self.fault_clear_pending |= bool(value & regmap.CTRL_FAULT_CLEAR)
            return
        if name not in self.regs:
            raise ValueError(f"{name} is not a writable register")
        regmap.encode(name, value)  # range check with a clear message
        self.regs[name] = value
        if name == "TC":
            self.tc_written = True

    def adc_sample(self, code: int) -> None:
        """A valid sample on the ADC stream (signed 24-bit code)."""
        if not ADC_CODE_MIN <= code <= ADC_CODE_MAX:
            raise ValueError(
                f"code={code} outside the allowed range {ADC_CODE_MIN}..{ADC_CODE_MAX}"
            )
        self.raw = code
        self.fresh = True

    # --- the sample ----------------------------------------------------------------------------

    def tick(self, group_stop: bool = False) -> LoopOutput:
        """One sample tick; returns the state the RTL shows at out_valid.

        `group_stop` is tension_loop_mc's safety group: another channel of this one's group had
        a latched fault at the tick, and this channel, unless its own faults say otherwise, runs
        the sample as under a watchdog-only fault (u one ramp step towards zero, integrator 0).
        tension_loop.v has no group: False.
        """
        r = self.regs
        self.sample_count = (self.sample_count + 1) & 0xFFFFFFFF

        fclr = self.fault_clear_pending
        stale_base = 0 if fclr else self.stale_cnt
        wdt_base = 0 if fclr else self.wdt_cnt
        oc_base = 0 if fclr else self.oc_cnt
        stale_now = 0 if self.fresh else min(stale_base + 1, 0xFFFF)
        wdt_now = 0 if (not self.enable or self.tc_written) else min(wdt_base + 1, 0xFFFF)
        range_bad = self.raw < r["ADC_MIN"] or self.raw > r["ADC_MAX"]
        detect = 0
        if self.enable:
            if r["ADC_STALE"] and stale_now >= r["ADC_STALE"]:
                detect |= regmap.FAULT_ADC_STALE
            if range_bad:
                detect |= regmap.FAULT_ADC_RANGE
            if r["WDT_TIMEOUT"] and wdt_now >= r["WDT_TIMEOUT"]:
                detect |= regmap.FAULT_WATCHDOG
            if r["OC_TIMEOUT"] and oc_base >= r["OC_TIMEOUT"]:
                detect |= regmap.FAULT_OVERCURRENT
        self.faults = (0 if fclr else self.faults) | detect
        self.stale_cnt, self.wdt_cnt, self.oc_cnt = stale_now, wdt_now, oc_base
        run = self.enable and self.faults == 0 and not group_stop
        ramp = self.enable and (
            self.faults == regmap.FAULT_WATCHDOG or (self.faults == 0 and group_stop)
        )
        integ_prev = 0 if self.integ_reset_pending else self.integ
        self.fresh = self.tc_written = False
        self.integ_reset_pending = self.fault_clear_pending = False

        tc = r["TC"]
        if self.slew_en:
            tce = _clamp(tc, self.tc_eff - r["SLEW"], self.tc_eff + r["SLEW"])
        else:
            tce = tc
        # The floor after the slew limit: a cable cannot push (TC_MIN, minimum pretension).
        tce = max(tce, r["TC_MIN"])
        self.t_in = calibrate(self.raw, r["ADC_OFFSET"], r["ADC_GAIN"])

        if run:
            lim = r["I_LIMIT"]
            e = _sat(tce - self.t_in, 16)
            ff = tce * r["KFF"]
            pp = e * r["KP"]
            pi = e * r["KI_TS"]
            windup = (self.sat_hi and pi > 0) or (self.sat_lo and pi < 0)
            # A held integrator is clamped too: I_LIMIT may have been lowered since it was stored.
            step = 0 if windup else pi
            self.integ = _clamp(integ_prev + step, -(lim << 16), lim << 16)
            r_out = ((ff + pp + 256 + (self.integ >> 7)) >> 9) + r["UFF"]
            self.u = _clamp(r_out, -lim, lim)
            self.sat_hi, self.sat_lo = r_out > lim, r_out < -lim
            self.saturated = self.sat_hi or self.sat_lo
            self.out_en = True
            self.wdt_ramp = False
            self.tc_eff = tce
            self.oc_cnt = min(self.oc_cnt + 1, 0xFFFF) if self.saturated else 0
        else:
            if ramp:
                step = self.wdt_ramp_step
                u = self.u - step if self.u > step else self.u + step if self.u < -step else 0
            else:
                u = 0
            self.u = u
            self.out_en = self.wdt_ramp = ramp and u != 0
            self.integ = 0
            self.saturated = self.sat_hi = self.sat_lo = False
            self.tc_eff = 0
            self.oc_cnt = 0
        return self.output()

    def output(self) -> LoopOutput:
        """The current outputs and read-backs."""
        return LoopOutput(
            u=self.u,
            out_en=self.out_en,
            saturated=self.saturated,
            wdt_ramp=self.wdt_ramp,
            faults=self.faults,
            t_in=self.t_in,
            integ=self.integ,
            tc_eff=self.tc_eff,
            sample_count=self.sample_count,
        )


class TensionLoopMcModel:
    """Bit-exact model of tension_loop_mc.v: N TensionLoopModel channels and their safety groups.

    `groups[k]` is channel k's group id (the RTL's GROUP parameter). At each tick a channel whose
    group holds another channel with a latched fault (as latched before the tick) runs with
    `group_stop`; every other channel is exactly a TensionLoopModel. Drive `channels[k]` with
    `write` and `adc_sample` as a single loop; `tick()` returns the N LoopOutputs the RTL shows
    at out_valid.
    """

    def __init__(self, groups: list[int], wdt_ramp_step: int = WDT_RAMP_STEP) -> None:
        if not groups:
            raise ValueError("groups=[] : expected one group id per channel, at least one channel")
        self.groups = list(groups)
        self.channels = [TensionLoopModel(wdt_ramp_step=wdt_ramp_step) for _ in self.groups]
        self.group_stop = [False] * len(self.groups)

    def reset(self) -> None:
        """State after `rst`."""
        for ch in self.channels:
            ch.reset()
        self.group_stop = [False] * len(self.groups)

    def tick(self) -> list[LoopOutput]:
        """One period: every channel's sample, with the group stops of the faults at the tick."""
        n = len(self.channels)
        self.group_stop = [
            any(
                j != k and self.groups[j] == self.groups[k] and self.channels[j].faults
                for j in range(n)
            )
            for k in range(n)
        ]
        return [ch.tick(stop) for ch, stop in zip(self.channels, self.group_stop, strict=True)]


@dataclass
class FloatTensionLoop:
    """The PI + feedforward loop in double precision, in SI units (the fixed-point oracle).

    Same structure as the RTL: u = Kff*T_c + u_ff + Kp*e + I, I += Ki*Ts*e unless the previous
    output was saturated in the direction e pushes; u and I clamped to +-i_limit_a. No
    quantization, no rounding, no fault logic. `uff_a` is the UFF register's current
    feedforward, which the caller sets as the processor writes it.
    """

    kff_a_per_n: float
    kp_a_per_n: float
    ki_ts_a_per_n: float
    i_limit_a: float
    integ_a: float = 0.0
    sat_sign: int = 0
    uff_a: float = 0.0

    def step(self, tc_n: float, t_in_n: float) -> float:
        """One sample: the current command in A for command `tc_n` and measurement `t_in_n`."""
        e = tc_n - t_in_n
        fp = self.kff_a_per_n * tc_n + self.kp_a_per_n * e
        pi = self.ki_ts_a_per_n * e
        if not ((self.sat_sign > 0 and pi > 0) or (self.sat_sign < 0 and pi < 0)):
            self.integ_a = min(max(self.integ_a + pi, -self.i_limit_a), self.i_limit_a)
        v = fp + self.integ_a + self.uff_a
        self.sat_sign = 1 if v > self.i_limit_a else -1 if v < -self.i_limit_a else 0
        return min(max(v, -self.i_limit_a), self.i_limit_a)

    @classmethod
    def from_registers(cls, regs: dict[str, int]) -> FloatTensionLoop:
        """The float loop with the gains a register set programs (values as in the registers)."""
        return cls(
            kff_a_per_n=regs["KFF"] / (1 << GAIN_FRAC),
            kp_a_per_n=regs["KP"] / (1 << GAIN_FRAC),
            ki_ts_a_per_n=regs["KI_TS"] / (1 << KI_TS_FRAC),
            i_limit_a=regs["I_LIMIT"] / (1 << CURRENT_FRAC),
            uff_a=regs.get("UFF", 0) / (1 << CURRENT_FRAC),
        )
