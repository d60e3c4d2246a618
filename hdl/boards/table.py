"""The boards: one table of their facts that every flow reads.

Each board's FPGA (family, nextpnr's device option, package, speed grade, LUT4s) and, for each of
its two designs, the top module, the pin file, the target clock (the clock nextpnr must reach: the
clock the design runs at, or above it by a margin) and the cables it drives: `rtl`
is the tension loop's top for an external MCU (`make synth`, hdl/synth/synth.py), `soc` the top
with the RISC-V firmware inside (`make bitstream`, hdl/soc/bitstream.py). bowden.core (FuseSoC)
writes the same facts in its own form; tests/test_packaging.py fails when the two differ.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

HDL = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Device:
    """One FPGA part, as nextpnr names it."""

    family: str  # "ice40" or "ecp5": yosys's synth_<family>, nextpnr-<family>
    device: str  # nextpnr's device option
    package: str
    speed: str  # the speed grade ("" where nextpnr takes none)
    luts: int  # LUT4s of the device

    @property
    def nextpnr_args(self) -> tuple[str, ...]:
        """nextpnr's options that choose this part."""
        speed = ("--speed", self.speed) if self.speed else ()
        return (self.device, "--package", self.package, *speed)


@dataclass(frozen=True)
class Design:
    """One top of a board: its module, pin file, target clock and the cables it drives."""

    top: str
    constraints: Path
    target_mhz: float  # the clock placement must reach (nextpnr's --freq)
    nextpnr_options: tuple[str, ...] = ()  # beyond the device's (flow choices of this top)
    channels: int = 1  # cables: the top's CHANNELS parameter, with pins for each in `constraints`
    clock_mhz: float | None = None  # the clock the top runs at, when the target is above it

    @property
    def runs_mhz(self) -> float:
        """The clock the top runs at (its CLK_HZ): clock_mhz, else the target."""
        return self.target_mhz if self.clock_mhz is None else self.clock_mhz


@dataclass(frozen=True)
class Board:
    name: str
    kit: str  # the development board the pin files are written for
    fpga: Device
    rtl: Design  # the tension loop for an external MCU
    soc: Design  # the tension loop with the RISC-V firmware inside


ICE40_UP5K = Device("ice40", "--up5k", "sg48", "", 5280)  # iCE40UP5K: 5280 LUT4 (FPGA-DS-02008)
ECP5_25F = Device("ecp5", "--25k", "CABGA381", "6", 24288)  # LFE5U-25F: 24k LUT4 (FPGA-DS-02012)

BOARDS = {
    "ice40-up5k": Board(
        name="ice40-up5k",
        kit="iCEBreaker",
        fpga=ICE40_UP5K,
        # --opt-timing: post-placement timing optimisation (nextpnr-ice40 option).
        rtl=Design("ice40_up5k_top", HDL / "boards" / "ice40_up5k.pcf", 48.0, ("--opt-timing",)),
        # Without --opt-timing: on this 93 % full device it cost routability, seed 4 measured
        # 238 s of routing at 25.13 MHz with it and 142 s at 26.30 MHz without (hdl/README.md
        # "Bitstreams").
        # Two cables (an antagonistic pair on one ADS131M04, hdl/README.md "Sensing") on the
        # sequenced datapath, 4442 of the 5280 logic cells; it runs at 24 MHz (the PLL's clock,
        # the top's CLK_HZ) and must place 10 % above it, at 26.4 MHz (hdl/README.md
        # "Bitstreams").
        soc=Design(
            "ice40_up5k_soc_top",
            HDL / "soc" / "boards" / "ice40_up5k_soc.pcf",
            26.4,
            channels=2,
            clock_mhz=24.0,
        ),
    ),
    "ecp5-25f": Board(
        name="ecp5-25f",
        kit="ULX3S",
        fpga=ECP5_25F,
        rtl=Design("ecp5_25f_top", HDL / "boards" / "ecp5_25f.lpf", 100.0),
        # Four cables, two antagonistic pairs on one ADS131M08 (hdl/README.md "Sensing").
        soc=Design(
            "ecp5_25f_soc_top", HDL / "soc" / "boards" / "ecp5_25f_soc.lpf", 25.0, channels=4
        ),
    ),
}
