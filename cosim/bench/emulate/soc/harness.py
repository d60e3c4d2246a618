"""The full-system co-simulation from Python: `SocBoard` runs the native harness (harness.cpp,
soc_api.h mirrored here) in a thread, with its UART on a pseudo-terminal.

The pty is raw (tty.setraw: 0x0D, 0x03, 0x11, 0x13 pass unchanged, no echo) and its slave side
stays open here, so a client that closes it leaves the master readable (no EIO). The flash's
content lives in a file (2 MiB, the flash model's array; written temp + rename); a simulated
power cycle is a new SocBoard on the same file. Without a plant the ADC's channels carry
constant tensions; with one (`plant=` an opened cosim.parts.plant.Plant, or one for each cable)
the FMU is stepped every loop sample with its ESCON's current and its T_in and T_out go to the
cable's two ADC channels (CH 2k and 2k + 1). `channels`: the SoC's cables (1, 2 or 4: its
CHANNELS, each count a library of its own, build.py).
`findable`: while it runs, `bowden bench list` and `--port auto` find its pty, as they find the
host emulator's (cosim.bench.link.discover's registry; `bowden emulate --target soc` asks for it).
"""

from __future__ import annotations

import ctypes
import os
import tempfile
import threading
import tty
from ctypes import (
    POINTER,
    Structure,
    c_char,
    c_char_p,
    c_double,
    c_int32,
    c_int64,
    c_uint8,
    c_uint16,
)
from dataclasses import dataclass
from pathlib import Path

from cosim.bench.link.discover import register_emulator, unregister_emulator
from cosim.parts import rtl_model
from cosim.parts.plant import FMU_LINK_FIELDS

from . import build as soc_build

SOC_API_VERSION = 2
SOC_MAX_CHANNELS = 4
FLASH_BYTES = 1 << 21


class PlantLink(Structure):
    """soc_plant_t: one cable's FMU (Plant.link fills it)."""

    _fields_ = FMU_LINK_FIELDS


class Spec(Structure):
    _fields_ = [
        ("pty_fd", c_int32),
        ("flash_path", c_char_p),
        ("max_sim_s", c_double),
        ("realtime", c_int32),
        ("stop", c_int32),
        ("clear_stats", c_int32),
        ("channels", c_int32),
        ("adc_offset", c_int32),
        ("adc_gain", c_int32),
        ("const_t_in_n", c_double),
        ("const_t_out_n", c_double),
        ("plant", PlantLink * SOC_MAX_CHANNELS),
        ("escon_imax_a", c_double),
        ("clocks", c_int64),
        ("boot_clks", c_int64),
        ("ticks", c_int64),
        ("tick_worst_clks", c_int64),
        ("tick_median_clks", c_int64),
        ("rx_worst_clks", c_int64),
        ("tick_gap_worst_clks", c_int64),
        ("uart_rx_bytes", c_int64),
        ("uart_tx_bytes", c_int64),
        ("uart_frame_errors", c_int64),
        ("adc_frames", c_int64),
        ("flash_saves", c_int64),
        ("plant_steps", c_int64),
        ("cpu_trap", c_int32),
        ("wall_s", c_double),
        ("fmu_s", c_double),
        ("error", c_char * 256),
    ]


_libs: dict[int, ctypes.CDLL] = {}


def load_library(channels: int = 1) -> ctypes.CDLL:
    """Build (or reuse) the library of a SoC of `channels` cables and load it once per
    process."""
    if channels not in _libs:
        lib = ctypes.CDLL(str(soc_build.build(channels=channels)))
        lib.soc_run.argtypes = [POINTER(Spec)]
        lib.soc_run.restype = c_int32
        lib.soc_adc_crc.argtypes = [POINTER(c_uint8), c_int32]
        lib.soc_adc_crc.restype = c_uint16
        if (
            lib.soc_api_version() != SOC_API_VERSION
            or lib.soc_spec_size() != ctypes.sizeof(Spec)
            or lib.soc_channels() != channels
        ):
            raise RuntimeError(
                "libbowden_soc_sim.so does not match cosim/bench/emulate/soc/harness.py"
            )
        _libs[channels] = lib
    return _libs[channels]


def adc_crc(bits: list[int]) -> int:
    """The ADS131M02 model's CRC of a bit sequence (harness.cpp)."""
    arr = (c_uint8 * len(bits))(*bits)
    return int(load_library().soc_adc_crc(arr, len(bits)))


@dataclass
class SocStats:
    sim_s: float
    wall_s: float
    fmu_s: float
    boot_ms: float
    ticks: int
    tick_worst_clks: int
    tick_median_clks: int
    rx_worst_clks: int
    tick_gap_worst_clks: int
    uart_rx_bytes: int
    uart_tx_bytes: int
    uart_frame_errors: int
    adc_frames: int
    flash_saves: int
    plant_steps: int

    @property
    def speed(self) -> float:
        """Simulated seconds per wall second."""
        return self.sim_s / self.wall_s if self.wall_s > 0 else 0.0


def check_flash_file(path: Path, size_bytes: int = FLASH_BYTES) -> None:
    """A flash file is a whole flash image of `size_bytes` this process can read, or absent (a
    blank flash); either way in a folder it can write (a save writes a temporary file there and
    renames it): ValueError naming the file, before a board starts (a save that fails later
    stops the board)."""
    if path.exists() or path.is_symlink():
        if not path.is_file():
            raise ValueError(f"flash file {path}: not a regular file")
        size = path.stat().st_size
        if size != size_bytes:
            raise ValueError(f"flash file {path}: {size} bytes, a flash image has {size_bytes}")
        try:
            with path.open("rb"):
                pass
        except OSError as exc:
            raise ValueError(f"flash file {path}: cannot be read ({exc.strerror or exc})") from None
    folder = path.parent
    if not folder.is_dir():
        raise ValueError(f"flash file {path}: the folder {folder} does not exist")
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=f".{path.name}.", suffix=".tmp"):
            pass
    except OSError as exc:
        raise ValueError(
            f"flash file {path}: cannot be written in {folder} ({exc.strerror or exc})"
        ) from None


class SocBoard:
    """One power-on of the simulated board, from `start()` to `stop()`."""

    def __init__(
        self,
        flash_path: str | Path | None = None,
        pty: bool = True,
        realtime: bool = True,
        tensions_n: tuple[float, float] = (5.0, 5.0),
        plant=None,
        escon_imax_a: float = 2.0,
        max_sim_s: float = 0.0,
        findable: bool = False,
        channels: int = 1,
    ) -> None:
        if channels not in soc_build.CHANNELS:
            raise ValueError(
                f"channels {channels}: the simulated SoC is built for "
                f"{', '.join(map(str, soc_build.CHANNELS))} cables"
            )
        plants = list(plant) if isinstance(plant, (list, tuple)) else [plant] * channels
        if plant is not None and (len(plants) != channels or len(set(map(id, plants))) != channels):
            raise ValueError(f"{channels} cables need {channels} plants of their own")
        self.channels = channels
        self.findable = findable
        self._registration = None  # the registry file while it is findable
        self.lib = load_library(channels)
        self.flash_path = Path(flash_path) if flash_path is not None else None
        if self.flash_path is not None:
            check_flash_file(self.flash_path)
        s = self.spec = Spec()
        s.pty_fd = -1
        self._master = self._slave = None
        self.pty_name = None
        if pty:
            self._master, self._slave = os.openpty()
            tty.setraw(self._slave)
            os.set_blocking(self._master, False)
            self.pty_name = os.ttyname(self._slave)
            s.pty_fd = self._master
        self._flash_bytes = str(self.flash_path).encode() if self.flash_path else None
        s.flash_path = self._flash_bytes
        s.max_sim_s = max_sim_s
        s.realtime = int(realtime)
        s.adc_offset = rtl_model.DEFAULT_ADC_OFFSET
        s.adc_gain = rtl_model.DEFAULT_ADC_GAIN
        s.const_t_in_n, s.const_t_out_n = tensions_n
        s.escon_imax_a = escon_imax_a
        s.channels = channels
        self.plant = plant
        if plant is not None:
            for k, p in enumerate(plants):
                p.link(s.plant[k])
        self._thread: threading.Thread | None = None
        self.status: int | None = None

    def start(self) -> SocBoard:
        if self.findable and self.pty_name is not None:  # findable as soon as start returns
            self._registration = register_emulator({"pty": self.pty_name})
        self._thread = threading.Thread(target=self._run, name="soc-board", daemon=True)
        self._thread.start()
        return self

    def _run(self) -> None:
        try:
            self.status = self.lib.soc_run(ctypes.byref(self.spec))  # ctypes releases the GIL
        finally:
            self._unregister()  # however the run ends (stop(), an error, max_sim_s)

    def _unregister(self) -> None:
        registration, self._registration = self._registration, None
        unregister_emulator(registration)

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    @property
    def error(self) -> str:
        return self.spec.error.decode(errors="replace")

    def wait(self, timeout_s: float | None = None) -> bool:
        """Wait for the run to end (max_sim_s reached or an error); True when it has."""
        if self._thread is not None:
            self._thread.join(timeout_s)
        return not self.running

    def clear_stats(self) -> None:
        """Restart the tick and receive figures (from the harness's next look, within 1040
        clocks)."""
        self.spec.clear_stats = 1

    def stop(self) -> SocStats:
        """End the run (the flash is saved first), close the pty; the run's figures."""
        self.spec.stop = 1
        if self._thread is not None:
            self._thread.join()
        self._unregister()  # (stopped before it ran)
        for fd in (self._master, self._slave):
            if fd is not None:
                os.close(fd)
        self._master = self._slave = None
        return self.stats()

    def stats(self) -> SocStats:
        s = self.spec
        clk = soc_build.CLK_HZ
        return SocStats(
            sim_s=s.clocks / clk,
            wall_s=s.wall_s,
            fmu_s=s.fmu_s,
            boot_ms=s.boot_clks / clk * 1e3,
            ticks=s.ticks,
            tick_worst_clks=s.tick_worst_clks,
            tick_median_clks=s.tick_median_clks,
            rx_worst_clks=s.rx_worst_clks,
            tick_gap_worst_clks=s.tick_gap_worst_clks,
            uart_rx_bytes=s.uart_rx_bytes,
            uart_tx_bytes=s.uart_tx_bytes,
            uart_frame_errors=s.uart_frame_errors,
            adc_frames=s.adc_frames,
            flash_saves=s.flash_saves,
            plant_steps=s.plant_steps,
        )
