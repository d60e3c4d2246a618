"""What the SoC's testbenches share: the sources, the UART at bit level, the bench protocol's
frames on it, and the firmware's phase word.

The UART runs at the SoC's own bit time (soc_uart.v: the nearest whole number of clocks to
CLK_HZ / BAUD), driven and sampled in clocks, so a test is exact whatever the host's speed.
"""

from __future__ import annotations

import os
from pathlib import Path

import cocotb
import pythondata_cpu_picorv32
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, RisingEdge, Timer

from cosim.bench.link import protocol
from cosim.project.paths import BUILD_DIR, HDL_DIR

# The SoC's clock: the UP5K's 24 MHz, unless a test of another board's configuration sets
# SOC_CLK_HZ in the simulation's environment beside the SoC's CLK_HZ (the ECP5 runs at 25 MHz).
CLK_HZ = int(os.environ.get("SOC_CLK_HZ", "24000000"))
# The simulated clock's period (start_clock). Every count is in clocks, so the period only
# places the edges in simulated time, where `clocks` finds them.
CLK_PERIOD_NS = 40
BAUD = 921_600
BIT_CLKS = (CLK_HZ + BAUD // 2) // BAUD  # 26 at 24 MHz, 27 at 25
FW_HEX = BUILD_DIR / "firmware" / "soc" / "bowden_fw.hex"
# 125 ms at 24 MHz from reset to the firmware's idle loop (the UP5K's copy from the flash
# included): a boot that takes longer is a defect
BOOT_MAX_CLKS = 3_000_000

# -O3 for the model's speed (hdl_sim.run_cocotb keeps a Verilator model in one C++ file).
VERILATOR_ARGS = ["-O3"]

# firmware/soc/soc.h SOC_MARK_*
MARK_BOOT, MARK_IDLE, MARK_TICK, MARK_RX = 1, 2, 3, 4


def picorv32_source() -> Path:
    return Path(pythondata_cpu_picorv32.data_location) / "picorv32.v"


def soc_sources(tb: bool = True):
    rtl = sorted((HDL_DIR / "rtl").glob("*.v"))
    soc = sorted((HDL_DIR / "soc").glob("*.v"))
    sim = [HDL_DIR / "soc" / "sim" / "spi_flash_model.v", HDL_DIR / "soc" / "sim" / "soc_tb.v"]
    return [picorv32_source(), *rtl, *soc, *(sim if tb else [])]


def start_clock(dut) -> None:
    """The SoC's clock on dut.clk, edges at whole multiples of CLK_PERIOD_NS / 2."""
    cocotb.start_soon(Clock(dut.clk, CLK_PERIOD_NS, unit="ns").start())


async def clocks(dut, n: int) -> None:
    """Wait until the n-th rising edge of dut.clk from now: ClockCycles(dut.clk, n) with one timer
    and one edge instead of a Python wake-up at each of the n edges (which took most of a long
    simulation's time). From an edge, the timer ends half a period before the n-th edge, so it
    is that edge whichever order the simulator runs the two events of one time step in. (From
    between edges, more than half a period after the last, it is the edge after.)"""
    if n < 3:
        await ClockCycles(dut.clk, n)
        return
    await Timer((n - 1) * CLK_PERIOD_NS + CLK_PERIOD_NS // 2, unit="ns")
    await RisingEdge(dut.clk)


class Uart:
    """Both directions of the SoC's UART at bit level: `send` drives uart_rx, a background
    receiver collects every byte on uart_tx (`rx`), with framing errors counted."""

    def __init__(self, dut):
        self.dut = dut
        self.rx = bytearray()
        self.frame_errors = 0
        dut.uart_rx.value = 1
        self._task = cocotb.start_soon(self._receive())

    async def _receive(self):
        d = self.dut
        while True:
            await FallingEdge(d.uart_tx)
            await clocks(d, BIT_CLKS // 2)
            if int(d.uart_tx.value):
                continue  # glitch
            byte = 0
            for i in range(8):
                await clocks(d, BIT_CLKS)
                byte |= int(d.uart_tx.value) << i
            await clocks(d, BIT_CLKS)
            if not int(d.uart_tx.value):
                self.frame_errors += 1
            self.rx.append(byte)

    async def send(self, data: bytes):
        d = self.dut
        for b in data:
            for bit in [0, *((b >> i) & 1 for i in range(8)), 1]:
                d.uart_rx.value = bit
                await clocks(d, BIT_CLKS)


class Bench:
    """The bench protocol over `Uart`: requests out, decoded frames back."""

    def __init__(self, dut):
        self.dut = dut
        self.uart = Uart(dut)
        self.decoder = protocol.FrameDecoder()
        self.frames: list[protocol.Frame] = []
        self._seen = 0
        self.seq = 0

    def poll(self) -> list[protocol.Frame]:
        new = bytes(self.uart.rx[self._seen :])
        self._seen = len(self.uart.rx)
        self.frames += self.decoder.feed(new)
        return self.frames

    def encode(self, name: str, **values) -> bytes:
        """The next request `name` as it goes on the wire (its sequence number taken), unsent."""
        self.seq = (self.seq + 1) & 0xFF
        msg = protocol.msgs.MESSAGES[name].id
        frame = protocol.Frame(msg=msg, seq=self.seq, payload=protocol.pack(name, **values))
        return protocol.encode_frame(frame)

    async def request(self, name: str, timeout_clks: int = 2_000_000, **values):
        """Send `name` and wait for the reply with its sequence number (None on timeout)."""
        msg = protocol.msgs.MESSAGES[name].id
        await self.uart.send(self.encode(name, **values))
        waited = 0
        while waited < timeout_clks:
            for f in self.poll():
                if f.seq == self.seq and f.msg != msg and not f.name.startswith("TELEM"):
                    self.frames.remove(f)
                    return f
            await clocks(self.dut, 2000)
            waited += 2000
        return None


def mark(dut) -> int:
    return int(dut.soc.mark_reg.value)


async def wait_mark(dut, value: int, max_clks: int) -> int:
    """Clocks until the firmware writes `value` to its phase word (AssertionError past max)."""
    n = 0
    while mark(dut) != value:
        await clocks(dut, 1000)
        n += 1000
        assert not int(dut.cpu_trap.value), "the CPU trapped"
        assert n <= max_clks, f"phase {value} not reached in {max_clks} clocks (at {mark(dut)})"
    return n


async def reset(dut, clks: int = 20):
    dut.rst.value = 1
    await clocks(dut, clks)
    dut.rst.value = 0
    await RisingEdge(dut.clk)
