"""The board's sensing and actuation chain between the plant and the FPGA core: one bounded stage,
shared by the cocotb harness, the bit-exact model chain and the float reference.

A co-simulation steps the plant FMU over each FPGA sample period [t_k, t_k+1) (t_k = k / f_s) and
hands the core one command per sample; between the two sit, on the board, the load-cell ADC and
the ESCON's PWM set value. `make_chain(cfg, name, fixed)` returns the stage for a run:

- ``ideal`` (the co-simulation's first interface): the core's tick k+1 gets T_in_meas(t_k+1) as a
  fresh sample, and the plant is driven by u_k over [t_k, t_k+1), with no delay.
- ``adc``: the board's ADC (below) in place of the ideal one; the drive stays ideal.
- ``board`` (the default of `bowden sim` and `bowden demo`): the board's ADC and PWM -> ESCON.

Sensing (`AdcModel`): a delta-sigma converter in continuous-conversion mode. Conversion i ends at
DRDY time d_i = t_phase + (i + 1) P (P the conversion period); its result is the mean of the
load cell's T_in_meas weighted by the digital filter's kernel over the window that ends at d_i:
order 1 averages over [d_i - P, d_i] (single-cycle settling, the ADS1220), order 3 is a sinc3
over [d_i - 3P, d_i] (the ADS131M02). Between plant samples T_in_meas is taken as linear, and the
kernel is evaluated at KERNEL_NODES_PER_PERIOD midpoints per period (the definition all three
chains share, so that they see the same value). The FPGA's reader clocks the result out in
`reader_latency_clks` board clocks after DRDY, and bowden_system's pipeline takes CORE_PIPE_CLKS
more to the core: read_clks in all; the result reaches the core's tick k+1 when
d_i + read_clks / clk_hz <= t_k+1, and only the newest such result is handed over (the core keeps
the latest sample). The fixed-point chains get the 24-bit code (`rtl_model.adc_code_from_tension`,
clipped at the rails), the float reference the value.

Actuation (`PwmEscon`): the core's pwm_escon makes one PWM period every R = f_s / f_pwm samples;
a period starts at a tick edge t_k+1 with (k + 1) % R == 0 and carries the command u_k of the tick
before (its duty is latched at the period boundary, hdl/rtl/pwm_escon.v; checked at bit level in
tests/hdl/test_bowden_system.py). Duty: fixed point, duty_clks / PERIOD_CLKS from the pwm_escon
formula at the board clock (`pwm_duty_clks`); float, 0.5 + 0.4 clamp(u, +-I_max) / I_max. The
ESCON measures each period (duty resolution 0.1 %, plus an optional constant duty error), and
its current set value (duty - 0.5) / 0.4 * I_max applies from the end of that period plus one
sample of its current controller (1 / 53.6 kHz): the plant steps over [t_k, t_k+1) in up to two
pieces when a new set value starts inside.

Sources (datasheet figures; every number has its name below):
- ADS1220 (TI SBAS501): 24 bit, PGA up to 128, 2000 SPS in turbo mode, continuous conversion,
  DRDY low when a result is ready; its digital filter settles within one conversion (TI E2E,
  "ADS1220: Delay required after changing mux?", thread 634706). Actual conversion period
  in turbo mode at 2000 SPS: 1036 modulator clocks at 2.048 MHz = 0.506 ms, taken from the table
  of conversion times of the ADS122C04 / ADS122U04 (TI SBAS751B / SBAS752B, Table 12: the same
  converter core and rate table; named assumption for the ADS1220), whose -3 dB bandwidths
  (0.44 .. 0.48 x the data rate) match an average over one conversion period (0.443 / P).
- ADS131M02 (TI SBAS853A): 2 channels sampled simultaneously, 24 bit, PGA up to 128, sinc3 filter
  (a step settles in three conversions, group delay 1.5 P), f_DATA = f_MOD / OSR with
  f_MOD = 4.096 MHz (8.192 MHz CLKIN, high-resolution mode); OSR 128 gives 32 kSPS.
- ESCON 36/2 DC (maxon, Hardware Reference rel9011, 3.4.4.1 Digital Input 1): PWM set value
  10 Hz .. 5 kHz, duty cycle range 10 .. 90 % with 0.1 % resolution, accuracy typically 2.5 % at
  5 kHz (0.5 % at 1 kHz: a fixed ~5 us timing error; modelled as an optional constant duty error,
  off by default, which the loop's integrator absorbs). Sampling rate of the PI current
  controller 53.6 kHz (ESCON family figure, ESCON Module 50/5 Hardware Reference rel9051, 2.1;
  named assumption for the 36/2 DC). When the ESCON applies a measured period is not stated:
  at its end plus one current-controller sample (named assumption).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from . import rtl_model

INTERFACES = ("board", "adc", "ideal")

# Registers between the front-end's reader and the core in bowden_system (placed for the
# iCE40's timing; hdl/rtl/bowden_system.v).
CORE_PIPE_CLKS = 2

# Kernel nodes per conversion period (midpoint rule): the shared definition of a conversion.
KERNEL_NODES_PER_PERIOD = 8

# Ticks per block of AdcModel's delivery plan (numpy, a few hundred kB per block).
PLAN_TICKS = 2048

# ESCON 36/2 DC PWM set value (Hardware Reference rel9011, DigIN1) and current controller.
ESCON_DUTY_MIN = 0.10
ESCON_DUTY_MAX = 0.90
ESCON_DUTY_RESOLUTION = 0.001
ESCON_CURRENT_LOOP_HZ = 53.6e3


@dataclass(frozen=True)
class AdcPart:
    """A load-cell ADC as the chain models it."""

    name: str
    period_s: float  # DRDY to DRDY in continuous conversion
    filter_order: int  # 1: mean over one period (single-cycle settling); 3: sinc3 over 3 periods
    frame_bits: int  # SPI bits the FPGA clocks out per result
    channels: int  # simultaneously sampled inputs (2: T_in and T_out)
    # The board reader's SCLK half period in board clocks (the RTL's SCLK_HALF_CLKS default):
    # ADS1220 3 MHz at 48 MHz; ADS131M02 6 MHz, so that its 96-bit frame (16 us) fits well
    # inside its 31.25 us conversion period (at 3 MHz it would take 32 us and miss every other
    # DRDY).
    sclk_half_clks: int = 8


ADC_PARTS = {
    "ads1220": AdcPart("ads1220", 1036 / 2.048e6, 1, 24, 1, 8),
    "ads131m02": AdcPart("ads131m02", 128 / 4.096e6, 3, 96, 2, 4),
}


def reader_latency_clks(frame_bits: int, sclk_half_clks: int) -> int:
    """Clocks from DRDY falling at the pin to adc_valid of the FPGA's reader (ads1220_reader.v,
    ads131m02_reader.v: two synchronizer flops, one clock to start, two SCLK half periods per
    bit, one clock to register the result); tests/hdl/test_ads1220_reader.py and
    test_ads131m02_reader.py measure it."""
    return 2 + 1 + 2 * sclk_half_clks * frame_bits + 1


def pwm_duty_clks(
    u_word: int,
    period_clks: int,
    imax_q12: int,
    enable: bool = True,
    constants: tuple[int, int, int] | None = None,
) -> int:
    """High time of one PWM period in clocks for command u (Q3.12 A), as hdl/rtl/pwm_escon.v:
    PERIOD/2 + floor(clamp(u, +-IMAX) * K / 2^SHIFT), K = round(SPAN * 2^SHIFT / IMAX),
    SPAN = 2 * PERIOD / 5, SHIFT the largest with K < 2^15; 50 % while disabled. `constants`:
    pwm_duty_constants(period_clks, imax_q12) when the caller holds them."""
    half, k, shift = constants or pwm_duty_constants(period_clks, imax_q12)
    uc = max(-imax_q12, min(imax_q12, u_word)) if enable else 0
    return half + ((uc * k) >> shift)


def pwm_duty_constants(period_clks: int, imax_q12: int) -> tuple[int, int, int]:
    """(PERIOD/2, K, SHIFT) of pwm_duty_clks for a period and a current limit: constants of a
    run, which PwmEscon computes once rather than at every PWM period."""
    half, span = period_clks // 2, 2 * period_clks // 5
    shift = 0
    while ((span << (shift + 1)) + imax_q12 // 2) // imax_q12 < 32768 and shift < 24:
        shift += 1
    return half, ((span << shift) + imax_q12 // 2) // imax_q12, shift


def _kernel(order: int, period_s: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Node offsets before DRDY (s) and weights (sum 1) of the filter's kernel."""
    m = KERNEL_NODES_PER_PERIOD * order
    width = order * period_s
    offsets = tuple(width * (m - 0.5 - j) / m for j in range(m))  # oldest node first
    if order == 1:
        raw = [1.0] * m
    elif order == 3:
        # sinc3 = three boxcars of width P convolved: piecewise quadratic over [0, 3P].
        def h(x: float) -> float:
            if x < 1.0:
                return 0.5 * x * x
            if x < 2.0:
                return 0.75 - (x - 1.5) ** 2
            return 0.5 * (3.0 - x) ** 2

        raw = [h(3.0 * (j + 0.5) / m) for j in range(m)]
    else:
        raise ValueError(f"filter order must be 1 or 3; got {order}")
    total = sum(raw)
    return offsets, tuple(w / total for w in raw)


class AdcModel:
    """Conversions of T_in_meas at the ADC's DRDY times; `deliver(k)` gives the newest result the
    reader has clocked out by tick k+1 (or None)."""

    def __init__(
        self,
        part: AdcPart,
        sample_rate_hz: float,
        clk_hz: float,
        sclk_half_clks: int,
        phase_s: float = 0.0,
    ) -> None:
        self.part = part
        self.dt = 1.0 / sample_rate_hz
        self.period = part.period_s
        self.phase = phase_s
        read_clks = reader_latency_clks(part.frame_bits, sclk_half_clks) + CORE_PIPE_CLKS
        self.read_s = read_clks / clk_hz
        self.offsets, self.weights = _kernel(part.filter_order, part.period_s)
        self._nodes = tuple(zip(self.offsets, self.weights, strict=True))
        self.hist: list[float] = []  # T_in_meas at t_j = j * dt
        self.last = -1  # index of the last conversion handed over
        self._plan_k0 = self._plan_end = 0
        self._plan: list[tuple[int, int, int, list[float]]] = []
        self._wsplit: dict[int, tuple[tuple[float, ...], tuple[float, ...]]] = {}

    def record(self, t_in_n: float) -> None:
        """T_in_meas at the next plant sample time (t_0 first)."""
        self.hist.append(t_in_n)

    def value(self, t_s: float) -> float:
        """T_in_meas at t_s, linear between plant samples (held before t_0)."""
        x = t_s / self.dt
        if x <= 0.0:
            return self.hist[0]
        j = int(x)
        h = self.hist
        if j + 1 >= len(h):
            return h[-1]
        return h[j] + (x - j) * (h[j + 1] - h[j])

    def conversion(self, i: int) -> float:
        """The result of conversion i (kernel-weighted mean before its DRDY): the exact sum
        (math.fsum) of w * value(d_i - offset) over the kernel's nodes. `value` is inlined here
        with the same operations, so the products are the same doubles (the native engine and
        tests/cosim hold all chains to them); the co-simulation calls this at every sample."""
        d = self.phase + (i + 1) * self.period
        h = self.hist
        dt = self.dt
        last = len(h) - 1
        terms = []
        for o, w in self._nodes:
            x = (d - o) / dt
            if x <= 0.0:
                v = h[0]
            else:
                j = int(x)
                if j >= last:
                    v = h[-1]
                else:
                    a = h[j]
                    v = a + (x - j) * (h[j + 1] - a)
            terms.append(w * v)
        return math.fsum(terms)

    def _make_plan(self, k0: int) -> None:
        """Plan ticks k0 .. k0 + PLAN_TICKS - 1: the conversion each would take (deliver's
        formula) and, where the kernel's nodes fall after t_0 and within two plant intervals
        [t_j, t_j+1), [t_j+1, t_j+2) (the ADS131M02's 3P = 94 us window at 10 kHz), the
        interval j, the count of nodes in the first one and each node's fraction x - j. numpy
        does `value`'s operations in the same order on doubles, so the fractions are `value`'s;
        other conversions (the ADS1220's window spans five intervals) take `conversion`."""
        ks = np.arange(k0, k0 + PLAN_TICKS, dtype=np.int64)
        t = (ks + 1) * self.dt
        ik = np.floor((t - self.read_s - self.phase) / self.period + 1e-12).astype(np.int64) - 1
        d = self.phase + (ik + 1) * self.period
        x = (d[:, None] - np.asarray(self.offsets)[None, :]) / self.dt
        j = np.floor(np.maximum(x, 0.0)).astype(np.int64)  # int(x) for x > 0
        j0 = j[:, 0]
        fast = (x[:, 0] > 0.0) & (j[:, -1] - j0 <= 1)  # nodes ascend in time: x[:, 0] is least
        self._plan_k0, self._plan_end = k0, k0 + PLAN_TICKS
        # Per tick: (conversion, first interval or -1 for `conversion`, nodes in it, fractions)
        self._plan = list(
            zip(
                ik.tolist(),
                np.where(fast, j0, -1).tolist(),
                (j == j0[:, None]).sum(axis=1).tolist(),
                (x - j).tolist(),
                strict=True,
            )
        )

    def deliver(self, k: int) -> float | None:
        """The result that reaches tick k+1 (newest clocked out by t_k+1), once; else None.

        The conversion index and the kernel's node positions come from the plan (_make_plan):
        the co-simulation calls this at every sample, and the planned sum costs a third of
        `conversion`'s; both give the same doubles (tests/cosim/test_cosim_interface.py)."""
        if not self._plan_k0 <= k < self._plan_end:
            self._make_plan(k)
        i, j, s, f = self._plan[k - self._plan_k0]
        if i <= self.last or i < 0:
            return None
        self.last = i
        h = self.hist
        if j >= 0:
            n = len(f)
            if (j + 1 if s == n else j + 2) < len(h):
                ws = self._wsplit.get(s)
                if ws is None:
                    ws = self._wsplit[s] = (self.weights[:s], self.weights[s:])
                # value(t) = h[j] + (x - j) (h[j+1] - h[j]) per node, a node's interval's
                # terms taken once.
                a0 = h[j]
                a1 = h[j + 1]
                d0 = a1 - a0
                terms = [w * (a0 + fr * d0) for fr, w in zip(f[:s], ws[0], strict=True)]
                if s < n:
                    d1 = h[j + 2] - a1
                    terms += [w * (a1 + fr * d1) for fr, w in zip(f[s:], ws[1], strict=True)]
                return math.fsum(terms)
        return self.conversion(i)


class PwmEscon:
    """The core's PWM set value measured by the ESCON: `segments(k, u)` gives the plant's current
    over [t_k, t_k+1) as ((dt, current_a), ...)."""

    def __init__(
        self,
        sample_rate_hz: float,
        pwm_hz: float,
        clk_hz: float,
        imax_q12: int,
        escon_imax_a: float,
        duty_error: float,
        fixed: bool,
        duty_resolution: float = ESCON_DUTY_RESOLUTION,
    ) -> None:
        ratio = sample_rate_hz / pwm_hz
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(
                f"board.pwm_hz must divide sample_rate_hz ({sample_rate_hz:g}); got {pwm_hz:g}"
            )
        self.ratio = int(round(ratio))
        self.dt = 1.0 / sample_rate_hz
        self.period_clks = int(round(clk_hz / pwm_hz))
        self.imax_q12 = imax_q12
        self.escon_imax = escon_imax_a
        self.duty_error = duty_error
        self.resolution = duty_resolution
        self.fixed = fixed
        self._duty_consts = pwm_duty_constants(self.period_clks, imax_q12)
        # The set value applies one current-controller sample after the period ends, inside
        # the step of the period's last tick: at this fraction of it.
        self.frac = min(1.0, (1.0 / ESCON_CURRENT_LOOP_HZ) / self.dt)
        self.current = 0.0  # set value in force (50 % duty before the first period)
        self.pending: list[tuple[int, float]] = []  # (sample index of the step, set value)

    def set_value(self, duty: float) -> float:
        """The ESCON's current set value for a measured duty cycle (0..1)."""
        d = duty + self.duty_error
        if self.resolution > 0.0:
            d = round(d / self.resolution) * self.resolution
        d = min(max(d, ESCON_DUTY_MIN), ESCON_DUTY_MAX)
        return (d - 0.5) / 0.4 * self.escon_imax

    def duty(self, u) -> float:
        """Duty cycle of the PWM period that carries command u (a Q3.12 word or amperes)."""
        if self.fixed:
            clks = pwm_duty_clks(
                int(u), self.period_clks, self.imax_q12, constants=self._duty_consts
            )
            return clks / self.period_clks
        imax = self.imax_q12 / 4096.0
        return 0.5 + 0.4 * min(max(float(u), -imax), imax) / imax

    def segments(self, k: int, u) -> tuple[tuple[float, float], ...]:
        if (k + 1) % self.ratio == 0:
            # Period [t_k+1, t_k+1+R) carries u_k; the ESCON applies it in step k + R.
            self.pending.append((k + self.ratio, self.set_value(self.duty(u))))
        if self.pending and self.pending[0][0] == k:
            _, new = self.pending.pop(0)
            old, self.current = self.current, new
            if new == old:
                return ((self.dt, new),)
            if self.frac >= 1.0:
                return ((self.dt, old),)
            return ((self.frac * self.dt, old), ((1.0 - self.frac) * self.dt, new))
        return ((self.dt, self.current),)


class Chain:
    """The interface stage of one run. Per sample k, in this order:

    1. ``drive(k, u_k)``: the plant's current over [t_k, t_k+1), as ((dt_s, current_a), ...);
       u_k is the command word (fixed-point chains) or amperes (float reference);
    2. the caller steps the plant over those pieces and calls ``sense(k, T_in_meas(t_k+1))``:
       the ADC sample that tick k+1 takes (a 24-bit code, or a value in N for the float
       reference), or None when no new sample reaches it.
    ``start(T_in_meas(t_0))`` gives the sample of the start-up (the plant at rest).
    """

    def __init__(
        self,
        name: str,
        adc: AdcModel | None,
        drive: PwmEscon | None,
        fixed: bool,
        adc_offset: int,
        adc_gain: int,
        dt_s: float,
    ) -> None:
        self.name = name
        self.adc = adc
        self.pwm = drive
        self.fixed = fixed
        self.offset = adc_offset
        self.gain = adc_gain
        self.dt = dt_s

    def _out(self, value: float):
        if self.fixed:
            return rtl_model.adc_code_from_tension(value, self.offset, self.gain)
        return value

    def start(self, t_in_n: float):
        if self.adc is not None:
            self.adc.record(t_in_n)
        return self._out(t_in_n)

    def drive(self, k: int, u) -> tuple[tuple[float, float], ...]:
        if self.pwm is None:
            return ((self.dt, u / 4096.0 if self.fixed else u),)
        return self.pwm.segments(k, u)

    def sense(self, k: int, t_in_n: float):
        adc = self.adc
        if adc is None:
            return self._out(t_in_n)
        adc.hist.append(t_in_n)  # adc.record, inlined: called at every sample
        v = adc.deliver(k)
        return None if v is None else self._out(v)


def sclk_half_clks(cfg) -> int:
    """The reader's SCLK half period of a run: cfg.board.sclk_half_clks, or its part's default."""
    b = cfg.board
    return int(ADC_PARTS[b.adc].sclk_half_clks if b.sclk_half_clks is None else b.sclk_half_clks)


def make_chain(
    cfg,
    name: str,
    fixed: bool,
    adc_offset: int = rtl_model.DEFAULT_ADC_OFFSET,
    adc_gain: int = rtl_model.DEFAULT_ADC_GAIN,
) -> Chain:
    """The interface stage `name` (one of INTERFACES) for a run configured by cfg (SimConfig:
    sample rate and cfg.board), for a fixed-point chain (codes, command words) or the float
    reference (values, amperes)."""
    if name not in INTERFACES:
        raise ValueError(f"interface must be one of {', '.join(INTERFACES)}; got {name!r}")
    b = cfg.board
    fs = cfg.sample_rate_hz
    adc = drive = None
    if name in ("board", "adc"):
        part = ADC_PARTS[b.adc]
        if b.adc_period_s is not None:
            part = replace(part, period_s=b.adc_period_s)
        adc = AdcModel(part, fs, b.clk_hz, sclk_half_clks(cfg), b.adc_phase_s)
    if name == "board":
        drive = PwmEscon(
            fs,
            b.pwm_hz,
            b.clk_hz,
            int(b.pwm_imax_q12),
            b.escon_imax_a,
            b.escon_duty_error,
            fixed,
            b.escon_duty_resolution,
        )
    return Chain(name, adc, drive, fixed, adc_offset, adc_gain, 1.0 / fs)
