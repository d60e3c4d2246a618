"""A lean AXI4-Lite master for the closed loop's per-tick register traffic.

cocotbext-axi's AxiLiteMaster (the default bus driver of the co-simulation) runs a coroutine per
channel that wakes on every clock while a transaction is open; on this machine one transaction
costs about 300 us of wall time, so the firmware's one write per millisecond alone is about a
third of a real-time budget. This master drives one transaction at a time from the caller's
coroutine and wakes once per clock edge it needs (about four per transaction).

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


class AxiLiteError(RuntimeError):
    """A transaction answered with SLVERR or DECERR."""


class LeanAxiLiteMaster:
    """One-outstanding-transaction AXI4-Lite master on the `s_axil_*` ports of `dut`."""

    def __init__(self, dut, prefix: str, clock) -> None:
        def sig(name):
            return getattr(dut, f"{prefix}_{name}")

        self.awaddr, self.awprot, self.awvalid, self.awready = (
            sig("awaddr"),
            sig("awprot"),
            sig("awvalid"),
            sig("awready"),
        )
        self.wdata, self.wstrb, self.wvalid, self.wready = (
            sig("wdata"),
            sig("wstrb"),
            sig("wvalid"),
            sig("wready"),
        )
        self.bresp, self.bvalid, self.bready = sig("bresp"), sig("bvalid"), sig("bready")
        self.araddr, self.arprot, self.arvalid, self.arready = (
            sig("araddr"),
            sig("arprot"),
            sig("arvalid"),
            sig("arready"),
        )
        self.rdata, self.rresp, self.rvalid, self.rready = (
            sig("rdata"),
            sig("rresp"),
            sig("rvalid"),
            sig("rready"),
        )
        self.edge = RisingEdge(clock)
        for s in (self.awvalid, self.wvalid, self.bready, self.arvalid, self.rready):
            s.value = 0
        self.awprot.value = 0
        self.arprot.value = 0

    async def write_dword(self, addr: int, value: int) -> None:
        """Write the 32-bit word `value` at byte address `addr`."""
        # Drive from a clock edge, as cocotbext-axi's channel sources do, so that a write
        # reaches the registers at the same clock with either driver.
        await self.edge
        self.awaddr.value = addr
        self.wdata.value = value & 0xFFFFFFFF
        self.wstrb.value = 0xF
        self.awvalid.value = 1
        self.wvalid.value = 1
        self.bready.value = 1
        aw_open = w_open = True
        while aw_open or w_open:
            await self.edge
            if aw_open and self.awready.value:
                aw_open = False
                self.awvalid.value = 0
            if w_open and self.wready.value:
                w_open = False
                self.wvalid.value = 0
        while True:
            await self.edge
            if self.bvalid.value:
                break
        self.bready.value = 0
        resp = self.bresp.value.to_unsigned()
        if resp:
            raise AxiLiteError(f"write of {value:#010x} at {addr:#04x}: response {resp}")

    async def read_dword(self, addr: int) -> int:
        """Read the 32-bit word at byte address `addr`."""
        await self.edge
        self.araddr.value = addr
        self.arvalid.value = 1
        self.rready.value = 1
        ar_open = True
        while True:
            await self.edge
            if ar_open and self.arready.value:
                ar_open = False
                self.arvalid.value = 0
            if self.rvalid.value and not ar_open:
                break
        data = self.rdata.value.to_unsigned()
        resp = self.rresp.value.to_unsigned()
        self.rready.value = 0
        if resp:
            raise AxiLiteError(f"read at {addr:#04x}: response {resp}")
        return data
