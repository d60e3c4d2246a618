"""A lean AXI4-Lite master for the closed loop's per-tick register traffic.

cocotbext-axi's AxiLiteMaster (the other bus driver of the co-simulation) runs a coroutine per
channel that wakes on every clock while a transaction is open; on this machine one transaction
costs about 300 us of wall time, so the firmware's one write per millisecond alone is about a
third of a real-time budget. This master drives one transaction at a time from the caller's
coroutine and wakes once per clock edge it needs (about four per transaction), and reads and
writes the ports through cosim.engines.cocotb.fastio (cocotb's `.value` costs more than the edge).

Protocol (AMBA AXI4-Lite, the subset bowden_core's slave uses): a write presents AW and W
together with BREADY high and lowers each VALID once its READY was seen at a rising edge, then
waits for BVALID; a read presents AR with RREADY high and waits for RVALID. A transaction starts
at the first rising edge after the call, as with cocotbext-axi, so both drivers land a write on
the same clock. A response other
than OKAY raises. Same interface as AxiLiteMaster's read_dword / write_dword, so the testbench
takes either; tests/cosim holds the two to identical closed-loop results.
"""

from __future__ import annotations

from cocotb.triggers import RisingEdge

from . import fastio


class AxiLiteError(RuntimeError):
    """A transaction answered with SLVERR or DECERR."""


class LeanAxiLiteMaster:
    """One-outstanding-transaction AXI4-Lite master on the `s_axil_*` ports of `dut`."""

    def __init__(self, dut, prefix: str, clock) -> None:
        def sig(name):
            return getattr(dut, f"{prefix}_{name}")

        for name in ("awvalid", "wvalid", "bready", "arvalid", "rready", "awprot", "arprot"):
            sig(name).value = 0
        self.set_awaddr, self.set_awvalid, self.set_wdata, self.set_wstrb, self.set_wvalid = (
            fastio.writer(sig(name)) for name in ("awaddr", "awvalid", "wdata", "wstrb", "wvalid")
        )
        self.set_bready, self.set_araddr, self.set_arvalid, self.set_rready = (
            fastio.writer(sig(name)) for name in ("bready", "araddr", "arvalid", "rready")
        )
        readers = {}
        for name in ("awready", "wready", "bvalid", "bresp", "arready", "rvalid", "rdata", "rresp"):
            readers[name] = fastio.unsigned_reader(sig(name))
            fastio.check_port(sig(name), readers[name])
        self.awready, self.wready, self.bvalid, self.bresp = (
            readers[name] for name in ("awready", "wready", "bvalid", "bresp")
        )
        self.arready, self.rvalid, self.rdata, self.rresp = (
            readers[name] for name in ("arready", "rvalid", "rdata", "rresp")
        )
        self.edge = RisingEdge(clock)

    async def write_dword(self, addr: int, value: int) -> None:
        """Write the 32-bit word `value` at byte address `addr`."""
        # Drive from a clock edge, as cocotbext-axi's channel sources do, so that a write
        # reaches the registers at the same clock with either driver.
        await self.edge
        self.set_awaddr(addr)
        self.set_wdata(value & 0xFFFFFFFF)
        self.set_wstrb(0xF)
        self.set_awvalid(1)
        self.set_wvalid(1)
        self.set_bready(1)
        aw_open = w_open = True
        while aw_open or w_open:
            await self.edge
            if aw_open and self.awready():
                aw_open = False
                self.set_awvalid(0)
            if w_open and self.wready():
                w_open = False
                self.set_wvalid(0)
        while True:
            await self.edge
            if self.bvalid():
                break
        self.set_bready(0)
        resp = self.bresp()
        if resp:
            raise AxiLiteError(f"write of {value:#010x} at {addr:#04x}: response {resp}")

    async def read_dword(self, addr: int) -> int:
        """Read the 32-bit word at byte address `addr`."""
        await self.edge
        self.set_araddr(addr)
        self.set_arvalid(1)
        self.set_rready(1)
        ar_open = True
        while True:
            await self.edge
            if ar_open and self.arready():
                ar_open = False
                self.set_arvalid(0)
            if self.rvalid() and not ar_open:
                break
        data = self.rdata()
        resp = self.rresp()
        self.set_rready(0)
        if resp:
            raise AxiLiteError(f"read at {addr:#04x}: response {resp}")
        return data
