"""Testbench of hdl/rtl/bowden_core_mc.v: N register banks over AXI4-Lite (cocotbext-axi), the
time-multiplexed loops with their safety groups, and one PWM output per channel.

A monitor watches the bus and the ports every clock and replays into the bit-exact model
(cosim.parts.rtl_model.TensionLoopMcModel: one TensionLoopModel per channel and the group stops)
what the RTL sees at each clock edge: each cable's ADC sample (its T_in in ADC channel 2k), the
sample ticks, and every register write into the channel of its bank (byte address >> 8). Every
cmd_valid compares every channel's command, enable and fault with the model.

Built for N = 2 (one antagonistic pair, one group) and N = 4 (two pairs, groups 0 0 1 1), at
the minimum of clocks per sample (1 + 15 N; one more with CFG_RAM), each with the configuration
words in flip-flops and in the block RAM (CFG_RAM 1: N = 2 with the UP5K SoC's one-clock read
path, N = 4 with the three-stage one).
"""

from __future__ import annotations

import os
import random
from collections import deque

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, RisingEdge
from cocotbext.axi import AxiLiteBus, AxiLiteMaster
from hdl_sim import CORE_MC_RTL, SIMULATORS, replay_write, rtl, run_cocotb, signed

from cosim.parts import regmap
from cosim.parts.rtl_model import TensionLoopMcModel, adc_code_from_tension
from hdl.seq import program as seq_program

BANK_ADDR_W = regmap.BANK_STRIDE.bit_length() - 1  # bowden_core_mc's ADDR_W (generated map)
RESP_OKAY = 0
GROUP_W = 4
# name: (the channels' groups, CFG_RAM, RD_STAGES, SEQ)
CONFIGS = {
    "n2": ([0, 0], 0, 3, 0),
    "n4": ([0, 0, 1, 1], 0, 3, 0),
    "n2_cfgram": ([0, 0], 1, 1, 0),  # the UP5K SoC's
    "n4_cfgram": ([0, 0, 1, 1], 1, 3, 0),
    "n2_seq": ([0, 0], 1, 1, 1),  # the sequenced datapath (tension_loop_seq)
    "n2_seq_ramp16": ([0, 0], 1, 1, 1),  # the same, a ramp of 16 samples (WDT_RAMP_STEP below)
}
# WDT_RAMP_STEP of a config, where not the default: a ramp from any u in 16 samples, so
# tension_loop_seq's guard (u held at 0 from the 17th tick in a row with a fault in the group)
# acts within the run (at about 200 of its 625 ticks), and the outputs are held to the model's
# there too. A guard acting at the 9th tick fails it; one a tick early passes (it shows only
# with |u| near 32767 at the stop), which tension_loop_seq.sby's seq_guard_exact catches.
RAMP_STEP = {"n2_seq_ramp16": 2048}
CONFIG = os.environ.get("BOWDEN_CORE_MC_CONFIG", "n2")
GROUPS, CFG_RAM, _, SEQ = CONFIGS[CONFIG]
N = len(GROUPS)


def clks_per_sample(n: int, cfg_ram: int, seq: int = 0) -> int:
    """The fewest clocks a sample: the loops' 1 + 15 N, and with CFG_RAM a clock for the bus's
    reads (they wait while the loops read the memory); with SEQ the program's clocks and one."""
    if seq:
        return seq_program.assemble().latency(n) + 1
    return 1 + 15 * n + (1 if cfg_ram else 0)


CLKS_PER_SAMPLE = clks_per_sample(N, CFG_RAM, SEQ)


def bank_addr(ch: int, name: str) -> int:
    return regmap.bank_addr(ch, regmap.REGISTERS[name].addr)


class McCoreTb:
    """Clock, reset, AXI master, the ADC driver and the model-replaying monitor."""

    def __init__(self, dut):
        self.dut = dut
        self.model = TensionLoopMcModel(
            GROUPS, wdt_ramp_step=RAMP_STEP.get(CONFIG, regmap.WDT_RAMP_STEP)
        )
        self.expected: deque = deque()
        self.compared = 0
        self.stopped = 0  # channel-samples run under a partner's fault
        self.guarded = 0  # ticks at which tension_loop_seq's guard held a group's drives off
        self.axi: AxiLiteMaster | None = None

    async def start(self) -> None:
        d = self.dut
        cocotb.start_soon(Clock(d.clk, 10, unit="ns").start())
        d.adc_valid.value = 0
        d.adc_ch_data.value = 0
        d.adc_drdy_lost.value = 0
        d.adc_crc_err.value = 0
        d.rst.value = 1
        await FallingEdge(d.clk)
        self.axi = AxiLiteMaster(AxiLiteBus.from_prefix(d, "s_axil"), d.clk, d.rst)
        await ClockCycles(d.clk, 3)
        await FallingEdge(d.clk)
        self.model.reset()
        d.rst.value = 0
        cocotb.start_soon(self.monitor())

    async def monitor(self) -> None:
        """Mid-cycle, look at what the next rising edge captures and replay it in order."""
        d = self.dut
        while True:
            await FallingEdge(d.clk)
            if d.rst.value:
                continue
            if d.cmd_valid.value:
                assert self.expected, "cmd_valid without a sample tick"
                exp = self.expected.popleft()
                cur = int(d.cmd_current.value)
                en = int(d.cmd_enable.value)
                fault = int(d.fault.value)
                for k, want in enumerate(exp):
                    got = (signed((cur >> (16 * k)) & 0xFFFF, 16), bool(en >> k & 1))
                    assert got == (want.u, want.out_en), (
                        f"sample {want.sample_count} channel {k}: RTL {got} != model "
                        f"{(want.u, want.out_en)}"
                    )
                    assert bool(fault >> k & 1) == (want.faults != 0), f"channel {k}: fault"
                # the loop's read-backs and status, as the banks take them
                t_in, integ, tc_eff = int(d.t_in.value), int(d.integ.value), int(d.tc_eff.value)
                sat, ramp, faults = (
                    int(d.saturated.value),
                    int(d.wdt_ramp.value),
                    int(d.faults.value),
                )
                for k, want in enumerate(exp):
                    got = (
                        signed((t_in >> (16 * k)) & 0xFFFF, 16),
                        signed((integ >> (32 * k)) & 0xFFFFFFFF, 32),
                        signed((tc_eff >> (16 * k)) & 0xFFFF, 16),
                        bool(sat >> k & 1),
                        bool(ramp >> k & 1),
                        (faults >> (4 * k)) & 0xF,
                    )
                    assert got == (
                        want.t_in,
                        want.integ,
                        want.tc_eff,
                        want.saturated,
                        want.wdt_ramp,
                        want.faults,
                    ), f"sample {want.sample_count} channel {k}: RTL {got} != model"
                self.compared += 1
            if d.adc_valid.value:
                word = int(d.adc_ch_data.value)
                for k, ch in enumerate(self.model.channels):
                    ch.adc_sample(signed((word >> (48 * k)) & 0xFFFFFF, 24))
            if d.sample_tick.value:
                self.expected.append(self.model.tick())
                self.stopped += sum(self.model.group_stop)
                if SEQ:
                    self.guarded += int(d.g_seq.loop.guard_zero.value) != 0
            if d.s_axil_awvalid.value and d.s_axil_wvalid.value and d.s_axil_awready.value:
                addr = int(d.s_axil_awaddr.value)
                replay_write(
                    self.model.channels[addr >> BANK_ADDR_W],
                    addr & ((1 << BANK_ADDR_W) - 1),
                    int(d.s_axil_wdata.value),
                    int(d.s_axil_wstrb.value),
                )

    async def adc_stream(self, tension_n, rng: random.Random) -> None:
        """One conversion of every ADC channel at random phases: cable k's T_in in channel 2k
        from tension_n(k, i), its T_out in 2k + 1 (a code the loop does not read)."""
        d = self.dut
        i = 0
        while True:
            await ClockCycles(d.clk, rng.randint(1, CLKS_PER_SAMPLE - 1))
            word = 0
            for k in range(N):
                t_in = adc_code_from_tension(tension_n(k, i)) & 0xFFFFFF
                t_out = (0x100000 * (k + 1) + i) & 0xFFFFFF
                word |= t_in << (48 * k) | t_out << (48 * k + 24)
            d.adc_ch_data.value = word
            d.adc_valid.value = (1 << N) - 1  # one conversion: every cable's channels
            await RisingEdge(d.clk)
            d.adc_valid.value = 0
            i += 1

    async def write(self, ch: int, name: str, value: int) -> None:
        resp = await self.axi.write(bank_addr(ch, name), (value & 0xFFFFFFFF).to_bytes(4, "little"))
        assert int(resp.resp) == RESP_OKAY, f"write {ch}:{name}={value}: response {resp.resp}"

    async def read(self, ch: int, name: str) -> int:
        return regmap.decode(name, await self.axi.read_dword(bank_addr(ch, name)))


@cocotb.test()
async def banks_are_apart(dut):
    """Each channel's bank holds its own registers: a write to one bank leaves the others as
    they were; ID reads the same in every bank; T_OUT of bank k is cable k's far-end code."""
    tb = McCoreTb(dut)
    await tb.start()
    for k in range(N):
        await tb.write(k, "KP", 1000 + k)
        await tb.write(k, "TC", 256 * (k + 3))
    for k in range(N):
        assert await tb.read(k, "KP") == 1000 + k
        assert await tb.read(k, "TC") == 256 * (k + 3)
        assert await tb.read(k, "ID") == await tb.read(0, "ID")
    await tb.write(N - 1, "KP", -7)
    assert [await tb.read(k, "KP") for k in range(N)] == [1000 + k for k in range(N - 1)] + [-7]
    # byte strobes: a byte of a 24-bit signed word and of a 15-bit one, the rest kept
    await tb.write(0, "ADC_MIN", -0x123456)
    await tb.axi.write(bank_addr(0, "ADC_MIN") + 1, b"\x7f")
    assert await tb.read(0, "ADC_MIN") == signed((-0x123456 & 0xFF00FF) | 0x7F00, 24)
    i_limit_reset = regmap.REGISTERS["I_LIMIT"].fields[0].reset
    await tb.axi.write(bank_addr(N - 1, "I_LIMIT"), b"\x34")
    assert await tb.read(N - 1, "I_LIMIT") == (i_limit_reset & 0x7F00) | 0x34
    assert await tb.read(0, "I_LIMIT") == i_limit_reset
    rng = random.Random(1)
    cocotb.start_soon(tb.adc_stream(lambda k, i: 5.0, rng))
    await ClockCycles(dut.clk, 3 * CLKS_PER_SAMPLE)
    for k in range(N):
        code = await tb.read(k, "T_OUT")
        assert (code >> 20) == k + 1, f"bank {k}: T_OUT {code:#x} is not cable {k}'s"


@cocotb.test()
async def loops_through_axi_against_model(dut):
    """Random writes to random banks at random times, every cable with its own ADC stream and
    watchdog: every channel's command equals the model's, including the periods a partner's
    watchdog fault stops its group (the writes refresh each watchdog at random)."""
    tb = McCoreTb(dut)
    await tb.start()
    rng = random.Random(42 + N)
    for k in range(N):
        # the last channel's watchdog is short: it times out between its TC writes and stops
        # its group's partners
        await tb.write(k, "WDT_TIMEOUT", 4 if k == N - 1 else 40)
        await tb.write(k, "ADC_STALE", 4)
        await tb.write(k, "TC", (8 + 2 * k) * 256)
    cocotb.start_soon(tb.adc_stream(lambda k, i: 6.0 + k + 4.0 * ((i // (30 + 7 * k)) % 2), rng))
    for k in range(N):
        await tb.write(k, "CTRL", regmap.CTRL_ENABLE)
    for _ in range(300 * N):
        ch = rng.randrange(N)
        what = rng.random()
        if what < 0.45:
            await tb.write(ch, "TC", rng.randint(-20 * 256, 40 * 256))
        elif what < 0.55:
            await tb.write(ch, rng.choice(["KFF", "KP", "KI_TS"]), rng.randint(-32768, 32767))
        elif what < 0.6:
            await tb.write(ch, "I_LIMIT", rng.choice([2048, 8192, 16384, 32767]))
        elif what < 0.7:
            pulse = rng.choice([regmap.CTRL_INTEG_RESET, regmap.CTRL_SLEW_EN, 0])
            await tb.write(ch, "CTRL", regmap.CTRL_ENABLE | pulse)
        elif what < 0.8 and tb.model.channels[ch].faults:
            await tb.write(ch, "CTRL", regmap.CTRL_ENABLE | regmap.CTRL_FAULT_CLEAR)
        elif what < 0.9:
            await tb.read(ch, rng.choice(["U", "T_IN", "INTEG", "TC_EFF"]))
        else:  # a configuration word reads back what the model holds
            name = rng.choice(["TC", "KFF", "KP", "KI_TS", "I_LIMIT", "WDT_TIMEOUT", "ADC_MAX"])
            assert await tb.read(ch, name) == tb.model.channels[ch].regs[name], f"{ch}:{name}"
        await ClockCycles(dut.clk, rng.randint(0, 2 * CLKS_PER_SAMPLE))
    assert tb.compared > 300, f"only {tb.compared} periods compared"
    # the group stop was exercised: some channel ran periods under a partner's fault
    assert tb.stopped > 0, "no group stop in the run"
    if CONFIG in RAMP_STEP:  # and the sequenced datapath's guard, with the outputs compared
        assert tb.guarded > 10, f"the guard held the drives off at only {tb.guarded} ticks"


# n2_seq_ramp16 is long (41 s of CPU, the guard's case only). make test runs the configuration of
# the board make test synthesizes: n2_seq (the UP5K's two cables, the sequenced datapath). The
# others are `make test-matrix`'s, as the ECP5's synthesis is: n4 (four cables in two groups, the
# flip-flop banks of the ECP5's; make test proves the groups' separation on the sequenced
# datapath, tension_loop_seq:prove_apart and prove_n3), n2, n2_cfgram and n4_cfgram.
MATRIX = {"n2", "n4", "n2_cfgram", "n4_cfgram"}


def _mark(config: str):
    if config in RAMP_STEP:
        return pytest.param(config, marks=pytest.mark.long)
    return pytest.param(config, marks=pytest.mark.matrix) if config in MATRIX else config


@pytest.mark.parametrize("config", [_mark(c) for c in CONFIGS])
@pytest.mark.parametrize("simulator", SIMULATORS[:1])
def test_bowden_core_mc(simulator, config):
    """Build bowden_core_mc (N from the config) and run the coroutines above."""
    groups, cfg_ram, rd_stages, seq = CONFIGS[config]
    n = len(groups)
    group = sum(g << (GROUP_W * k) for k, g in enumerate(groups))
    params = {
        "N": n,
        # a sized literal: a plain integer is 32 bits, wider than N*GROUP_W for N < 8
        "GROUP": f"{n * GROUP_W}'h{group:x}",
        "CLK_HZ": 48_000_000,
        "CLKS_PER_SAMPLE": clks_per_sample(n, cfg_ram, seq),
        "CFG_RAM": cfg_ram,
        "RD_STAGES": rd_stages,
        "SEQ": seq,
    }
    if config in RAMP_STEP:
        params["WDT_RAMP_STEP"] = f"16'd{RAMP_STEP[config]}"
    run_cocotb(
        "bowden_core_mc",
        "test_bowden_core_mc",
        rtl(*CORE_MC_RTL, "tension_loop_seq", "tension_loop_seq_rom"),
        simulator,
        params,
        tag=config,
        extra_env={"BOWDEN_CORE_MC_CONFIG": config},
    )
