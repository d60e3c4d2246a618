"""Testbench of hdl/rtl/tension_loop_mc.v: every channel, sample by sample, against the models.

Each channel is held to two models after every period: the module's own model
`TensionLoopMcModel` (the channels with their safety groups), and a plain `TensionLoopModel`
per channel, the single tension_loop's bit-exact model, fed the same writes and samples. A
channel whose group is not stopped must equal the plain model exactly; while it is stopped by a
partner's fault it follows the group model, and its plain twin takes over its state (the stop is
the only way one channel reaches another).

Built for N = 2 (one antagonistic pair, one group) and N = 4 (two pairs, groups 0 0 1 1), each
in its own build folder, and N = 2 with the datapath reading and writing the state words in the
slot (LIVE_STATE 1, the UP5K's).
"""

from __future__ import annotations

import copy
import os
import random

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge
from hdl_sim import SIMULATORS, rtl, run_cocotb, signed, simulator_param

from cosim.parts import regmap
from cosim.parts.regmap import FAULT_ADC_RANGE, FAULT_WATCHDOG
from cosim.parts.rtl_model import (
    LATENCY_CLKS,
    WDT_RAMP_STEP,
    TensionLoopMcModel,
    TensionLoopModel,
)

# Register -> port of tension_loop_mc (channel k in bits [k*width +: width]).
PORTS = {
    "TC": "tc",
    "TC_MIN": "tc_min",
    "KFF": "kff",
    "UFF": "uff",
    "KP": "kp",
    "KI_TS": "ki_ts",
    "I_LIMIT": "i_limit",
    "SLEW": "slew",
    "WDT_TIMEOUT": "wdt_timeout",
    "ADC_OFFSET": "adc_offset",
    "ADC_GAIN": "adc_gain",
    "ADC_MIN": "adc_min",
    "ADC_MAX": "adc_max",
    "ADC_STALE": "adc_stale",
    "OC_TIMEOUT": "oc_timeout",
}
GROUP_W = 4  # tension_loop_mc's GROUP_W
# The builds: channels and their safety groups.
CONFIGS = {"n2": [0, 0], "n4": [0, 0, 1, 1], "n2_live": [0, 0]}
# The builds with LIVE_STATE 1.
LIVE = {"n2_live"}
# The build's groups, passed to the simulator's cocotb process by test_tension_loop_mc.
GROUPS = CONFIGS[os.environ.get("TENSION_LOOP_MC_CONFIG", "n2")]


def _width(name: str) -> int:
    return regmap.REGISTERS[name].fields[0].width


def _pack(values: list[int], bits: int) -> int:
    return sum((v & ((1 << bits) - 1)) << (k * bits) for k, v in enumerate(values))


def _field(word: int, k: int, bits: int, is_signed: bool = False) -> int:
    v = (word >> (k * bits)) & ((1 << bits) - 1)
    return signed(v, bits) if is_signed else v


class McTb:
    """Drives tension_loop_mc, its group model and the per-channel single-loop models in step."""

    def __init__(self, dut):
        self.dut = dut
        self.n = len(GROUPS)
        self.model = TensionLoopMcModel(GROUPS)
        self.plain = [TensionLoopModel() for _ in range(self.n)]
        self.pending: list[dict[str, int]] = [{} for _ in range(self.n)]
        self.samples = 0
        self.exact = 0  # channel-samples compared with the single loop's model
        self.stopped = 0  # channel-samples under a group stop
        self.latency = 1 + LATENCY_CLKS * self.n
        self.last = []

    async def start(self) -> None:
        """Clock, idle inputs, reset."""
        cocotb.start_soon(Clock(self.dut.clk, 10, unit="ns").start())
        d = self.dut
        for sig in (d.tick, d.adc_valid, d.adc_data, d.enable, d.slew_en):
            sig.value = 0
        for sig in (d.integ_reset, d.fault_clear, d.tc_wr):
            sig.value = 0
        d.rst.value = 1
        self.model.reset()
        for m in self.plain:
            m.reset()
        self._drive_config()
        for _ in range(3):
            await FallingEdge(d.clk)
        d.rst.value = 0
        await FallingEdge(d.clk)

    def _drive_config(self) -> None:
        chans = self.model.channels
        for name, port in PORTS.items():
            getattr(self.dut, port).value = _pack([m.regs[name] for m in chans], _width(name))
        self.dut.enable.value = _pack([int(m.enable) for m in chans], 1)
        self.dut.slew_en.value = _pack([int(m.slew_en) for m in chans], 1)

    def write(self, ch: int, name: str, value: int) -> None:
        """Queue a register write of channel `ch`; it lands with the next tick (same edge)."""
        self.pending[ch][name] = value

    def _adc(self, codes: list[int | None]) -> None:
        d = self.dut
        valid = [c is not None for c in codes]
        d.adc_valid.value = _pack([int(v) for v in valid], 1)
        d.adc_data.value = _pack([c or 0 for c in codes], 24)
        for k, c in enumerate(codes):
            if c is not None:
                self.model.channels[k].adc_sample(c)
                self.plain[k].adc_sample(c)

    async def sample(self, codes: list[int | None], late: list[int | None] | None = None) -> None:
        """Tick with the queued writes and the ADC samples `codes` (None: no sample), then
        compare every channel. `late`: ADC samples a few clocks after the tick, inside the
        period, which count for the next sample (as for a tension_loop)."""
        d = self.dut
        pulses = {"tc_wr": [0] * self.n, "integ_reset": [0] * self.n, "fault_clear": [0] * self.n}
        for k, writes in enumerate(self.pending):
            for name, value in writes.items():
                self.model.channels[k].write(name, value)
                self.plain[k].write(name, value)
                if name == "CTRL":
                    pulses["integ_reset"][k] = int(bool(value & regmap.CTRL_INTEG_RESET))
                    pulses["fault_clear"][k] = int(bool(value & regmap.CTRL_FAULT_CLEAR))
                pulses["tc_wr"][k] |= int(name == "TC")
            writes.clear()
        self._drive_config()
        for port, bits in pulses.items():
            getattr(d, port).value = _pack(bits, 1)
        self._adc(codes)
        d.tick.value = 1
        await FallingEdge(d.clk)
        d.tick.value = 0
        d.adc_valid.value = 0
        for port in pulses:
            getattr(d, port).value = 0
        assert d.cfg_busy.value, "cfg_busy low in the period"
        if late is not None:
            await ClockCycles(d.clk, 3, rising=False)
            exp = self.model.tick()
            plain = [m.tick() for m in self.plain]
            self._adc(late)  # after the models' tick: the next sample's
            await FallingEdge(d.clk)
            d.adc_valid.value = 0
            await ClockCycles(d.clk, self.latency - 6, rising=False)
        else:
            exp = self.model.tick()
            plain = [m.tick() for m in self.plain]
            await ClockCycles(d.clk, self.latency - 2, rising=False)
        assert not d.out_valid.value, "out_valid early"
        await FallingEdge(d.clk)
        assert d.out_valid.value, f"out_valid not {self.latency} clocks after the tick"
        assert not d.cfg_busy.value, "cfg_busy still high after the period"
        self.samples += 1
        got = self.outputs()
        for k in range(self.n):
            want = vars(exp[k])
            diff = {f: (got[k][f], want[f]) for f in want if got[k][f] != want[f]}
            assert not diff, f"sample {self.samples} channel {k}: RTL != model (rtl, model): {diff}"
            assert got[k]["grp_stop"] == self.model.group_stop[k], f"channel {k}: grp_stop"
            if self.model.group_stop[k]:
                # The plain loop would have run on: it takes the stopped channel's state.
                self.plain[k] = copy.deepcopy(self.model.channels[k])
                self.stopped += 1
            else:
                assert vars(plain[k]) == want, f"channel {k}: single-loop model differs"
                self.exact += 1
        self.last = exp

    def outputs(self) -> list[dict]:
        """Every channel's outputs as the RTL shows them."""
        d = self.dut
        words = {
            p: int(getattr(d, p).value)
            for p in ("u", "out_en", "saturated", "wdt_ramp", "faults", "t_in", "integ")
            + ("tc_eff", "grp_stop")
        }
        return [
            {
                "u": _field(words["u"], k, 16, True),
                "out_en": bool(_field(words["out_en"], k, 1)),
                "saturated": bool(_field(words["saturated"], k, 1)),
                "wdt_ramp": bool(_field(words["wdt_ramp"], k, 1)),
                "faults": _field(words["faults"], k, 4),
                "t_in": _field(words["t_in"], k, 16, True),
                "integ": _field(words["integ"], k, 32, True),
                "tc_eff": _field(words["tc_eff"], k, 16, True),
                "sample_count": int(d.sample_count.value),
                "grp_stop": bool(_field(words["grp_stop"], k, 1)),
            }
            for k in range(self.n)
        ]


def _code(m: TensionLoopModel, tension_q8: int) -> int:
    """An ADC code that calibrates to about `tension_q8` with channel model `m`'s calibration."""
    code = m.regs["ADC_OFFSET"] + (tension_q8 << 20) // m.regs["ADC_GAIN"]
    return max(-(1 << 23), min((1 << 23) - 1, code))


async def _started_without_faults(dut) -> McTb:
    """Every channel enabled, watchdog and over-current timer off, ADC limits at full scale."""
    tb = McTb(dut)
    await tb.start()
    for k in range(tb.n):
        tb.write(k, "WDT_TIMEOUT", 0)
        tb.write(k, "OC_TIMEOUT", 0)
        tb.write(k, "ADC_MIN", -(1 << 23))
        tb.write(k, "ADC_MAX", (1 << 23) - 1)
        tb.write(k, "CTRL", regmap.CTRL_ENABLE)
    await tb.sample([0] * tb.n)
    return tb


@cocotb.test()
async def random_against_models(dut):
    """Random references, gains, calibrations, control events and faults, different on every
    channel; ADC samples also inside the period. Every channel equals its models every sample."""
    tb = McTb(dut)
    await tb.start()
    rng = random.Random(7)
    corners16 = [-32768, -32767, -1, 0, 1, 32766, 32767]
    for k in range(tb.n):
        tb.write(k, "WDT_TIMEOUT", rng.choice([0, 0, 30]))
        tb.write(k, "OC_TIMEOUT", 40)
        tb.write(k, "CTRL", regmap.CTRL_ENABLE)
    await tb.sample([0] * tb.n)
    for _ in range(250):
        codes = []
        for k in range(tb.n):
            m = tb.model.channels[k]
            if rng.random() < 0.05:
                name = rng.choice(["KFF", "KP", "KI_TS"])
                tb.write(k, name, rng.choice(corners16 + [rng.randint(-32768, 32767)] * 4))
            if rng.random() < 0.03:
                tb.write(k, "I_LIMIT", rng.choice([0, 1, 4096, 32767, rng.randint(0, 32767)]))
            if rng.random() < 0.03:
                tb.write(k, "ADC_GAIN", rng.choice([-32768, 1, 2048, 32767]))
                tb.write(k, "ADC_OFFSET", rng.choice([0, -(1 << 23), rng.randint(-99, 99)]))
            if rng.random() < 0.02:
                tb.write(k, "SLEW", rng.choice([0, 1, 128, 32767]))
            if rng.random() < 0.3:
                tb.write(k, "TC", rng.choice(corners16 + [rng.randint(-32768, 32767)] * 6))
            if rng.random() < 0.1:
                tb.write(k, "UFF", rng.choice(corners16 + [rng.randint(-2048, 2048)] * 4))
            if rng.random() < 0.03:
                tb.write(k, "TC_MIN", rng.choice(corners16 + [rng.randint(-32768, 32767)]))
            if rng.random() < 0.04:
                extra = rng.choice([0, regmap.CTRL_SLEW_EN])
                extra |= rng.choice([0, regmap.CTRL_INTEG_RESET, regmap.CTRL_FAULT_CLEAR])
                enable = regmap.CTRL_ENABLE if rng.random() < 0.9 else 0
                tb.write(k, "CTRL", enable | extra)
            if m.faults and rng.random() < 0.5:
                tb.write(k, "CTRL", regmap.CTRL_ENABLE | regmap.CTRL_FAULT_CLEAR)
            codes.append(
                None
                if rng.random() < 0.01
                else rng.choice(
                    [-(1 << 23), (1 << 23) - 1] + [_code(m, rng.randint(-32768, 32767))] * 40
                )
            )
        late = None
        if rng.random() < 0.1:
            late = [rng.choice([None, _code(tb.model.channels[k], 0)]) for k in range(tb.n)]
        await tb.sample(codes, late)
    # Both kinds of comparison, often (seed 7: 219 and 283 of 502 channel-samples at N = 2,
    # 418 and 586 of 1004 at N = 4).
    assert tb.exact > 80 * tb.n and tb.stopped > 80 * tb.n, (tb.exact, tb.stopped)


@cocotb.test()
async def full_scale_saturation_per_channel(dut):
    """Full-scale errors at extreme gains, opposite on neighbouring channels: each saturates at
    its own +-I_LIMIT (full scale and 1 A) in the direction its own error pushes."""
    tb = await _started_without_faults(dut)
    lims = [32767 if k % 2 == 0 else 4096 for k in range(tb.n)]
    seen: set[tuple[int, int]] = set()
    for k in range(tb.n):
        tb.write(k, "I_LIMIT", lims[k])
    for kff, kp, ki in ((32767, 32767, 32767), (-32768, -32768, -32768), (0, 32767, 0)):
        for flip in (0, 1):
            codes = []
            for k in range(tb.n):
                tb.write(k, "KFF", kff)
                tb.write(k, "KP", kp)
                tb.write(k, "KI_TS", ki)
                hi = (k + flip) % 2 == 0
                tb.write(k, "TC", 32767 if hi else -32768)
                tb.write(k, "CTRL", regmap.CTRL_ENABLE | regmap.CTRL_INTEG_RESET)
                codes.append(-(1 << 23) if hi else (1 << 23) - 1)
            for _ in range(3):
                await tb.sample(codes)
                for k in range(tb.n):
                    seen.add((k, tb.last[k].u))
                    assert abs(tb.last[k].u) <= lims[k]
    for k in range(tb.n):
        assert {(k, lims[k]), (k, -lims[k])} <= seen, f"channel {k} missed a limit"


@cocotb.test()
async def fault_stops_its_group_only(dut):
    """A range fault on channel 0 zeroes it at once and ramps its partner (channel 1) to zero by
    WDT_RAMP_STEP a sample; the other pair runs on exactly as single loops. Then a watchdog
    fault on channel 2 (N = 4) ramps both of its pair down. Clearing restarts the partners."""
    tb = await _started_without_faults(dut)
    for k in range(tb.n):
        tb.write(k, "KP", 2048 + 512 * k)  # different gains and references per channel
        tb.write(k, "TC", (8 + 3 * k) * 256)
        tb.write(k, "ADC_MIN", -(1 << 22))
    good = [_code(tb.model.channels[k], (4 + k) * 256) for k in range(tb.n)]
    for _ in range(20):
        await tb.sample(good)
    assert all(o.out_en for o in tb.last)
    bad = list(good)
    bad[0] = -(1 << 22) - 1  # one code below channel 0's ADC_MIN
    await tb.sample(bad)
    assert tb.last[0].faults == FAULT_ADC_RANGE and tb.last[0].u == 0
    # The stop comes with the next tick: this sample channel 1 still ran as a single loop.
    assert tb.last[1].out_en and not tb.model.group_stop[1]
    u1 = tb.last[1].u
    assert u1 > 10 * WDT_RAMP_STEP
    ramp = []
    while tb.last[1].out_en:
        await tb.sample(good)
        ramp.append(tb.last[1].u)
        assert tb.last[0].u == 0 and not tb.last[0].out_en
        assert len(ramp) <= u1 // WDT_RAMP_STEP + 1
    want = [max(0, u1 - WDT_RAMP_STEP * (i + 1)) for i in range(len(ramp))]
    assert ramp == want, f"partner ramp {ramp[:5]}..., expected {want[:5]}..."
    assert tb.last[1].wdt_ramp is False and tb.last[1].faults == 0 and tb.last[1].integ == 0
    assert all(o.out_en for o in tb.last[2:]), "the other group stopped"
    # Channel 0 cleared: the partner restarts with the tick after the clear.
    tb.write(0, "CTRL", regmap.CTRL_ENABLE | regmap.CTRL_FAULT_CLEAR)
    await tb.sample(good)
    assert tb.last[0].out_en and not tb.last[1].out_en
    await tb.sample(good)
    assert tb.last[1].out_en and tb.last[1].u > 0
    if tb.n < 4:
        return
    # A watchdog fault on channel 2: it ramps (its own fault), channel 3 ramps (the group).
    u2, u3 = tb.last[2].u, tb.last[3].u
    tb.write(2, "WDT_TIMEOUT", 3)
    for k in range(tb.n):
        if k != 2:
            tb.write(k, "TC", (8 + 3 * k) * 256)
    n = 0
    while tb.last[2].faults != FAULT_WATCHDOG:
        await tb.sample(good)
        for k in (0, 1, 3):
            tb.write(k, "TC", (8 + 3 * k) * 256)
        n += 1
        assert n < 6
    await tb.sample(good)
    assert tb.last[2].wdt_ramp and tb.last[3].wdt_ramp and tb.last[3].u < u3
    assert tb.last[2].u < u2 and tb.last[0].out_en and tb.last[1].out_en


@pytest.mark.parametrize(
    ("simulator", "config"),
    [simulator_param(sim, c) for c in sorted(CONFIGS) for sim in SIMULATORS],
)
def test_tension_loop_mc(simulator, config):
    """Build tension_loop_mc for N channels with its groups and run every coroutine above."""
    groups = CONFIGS[config]
    group = sum(g << (GROUP_W * k) for k, g in enumerate(groups))
    run_cocotb(
        "tension_loop_mc",
        "test_tension_loop_mc",
        rtl("tension_loop_mc", "tension_loop_dp", "group_or", "mul_s16"),
        simulator,
        # GROUP as a sized literal: a plain integer is 32 bits, wider than N*GROUP_W for N < 8.
        parameters={
            "N": len(groups),
            "GROUP": f"{len(groups) * GROUP_W}'h{group:x}",
            "LIVE_STATE": int(config in LIVE),
        },
        tag=config,
        extra_env={"TENSION_LOOP_MC_CONFIG": config},
        optimize=False,
    )
