"""Build build/native/libbowden_native.so: the Verilated cosim_top and, for the antagonistic
pair, cosim_pair_top (bowden_core_mc with N = 2) (verilator --cc, compiled into static
libraries with -fPIC) and
the C++ closed loop (closed_loop.cpp), linked with the
firmware's libbowden_fw.so; the FMI 2.0 types come from fmpy's bundled headers.

The build is reused while nothing it depends on changes (a fingerprint of the sources, the
firmware library, the flags and the Verilator version in build/native/fingerprint.txt).

    python -m cosim.engines.native build     # what `make native` runs
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from cosim.engines.harness import CLKS_PER_SAMPLE, ENGINES_DIR, PAIR_CLKS_PER_SAMPLE, rtl_sources
from cosim.parts.firmware import LIB_PATH as FW_LIB
from cosim.project import procs
from cosim.project.paths import BUILD_DIR, FIRMWARE_DIR, HDL_DIR
from cosim.project.toolchain import setup_env

NATIVE_DIR = Path(__file__).resolve().parent
OUT_DIR = BUILD_DIR / "native"
LIB_PATH = OUT_DIR / "libbowden_native.so"
CXX_SOURCES = (NATIVE_DIR / "closed_loop.cpp",)
HEADERS = (NATIVE_DIR / "bn_api.h",)
# The antagonistic pair's core, Verilated beside cosim_top (bn_run_pair).
PAIR_TOP = ENGINES_DIR / "cosim_pair_top.v"
# Verilator's options of the cocotb build (cosim/engines/cocotb/runner.py), minus VPI: no tracing,
# X's resolved at compile time, the model optimised for speed.
VERILATOR_ARGS = ("-O3", "--x-assign", "fast", "--x-initial", "fast", "-Wno-fatal")
# No contraction into fused multiply-adds, no fast math: the interface stage must round as
# Python does (bit-identical to the cocotb harness). -O3 and -fno-semantic-interposition (the
# model's functions call each other directly and inline although the library is built -fPIC,
# which no program interposes on) took the RTL from 2.2 to 2.0 us per sample (measured when the
# native engine was written). Verilator's makefile compiles the model with -Os unless told
# otherwise.
MAKEFLAGS = "OPT_FAST=-O3 OPT_SLOW=-O1 OPT_GLOBAL=-O3"
CXXFLAGS = (
    "-std=c++17",
    "-O3",
    "-fPIC",
    "-fno-semantic-interposition",
    "-ffp-contract=off",
    "-fno-fast-math",
)


def fmpy_include() -> Path:
    """fmpy's copy of the FMI 2.0 headers (fmi2FunctionTypes.h)."""
    import fmpy  # noqa: PLC0415

    path = Path(fmpy.__file__).resolve().parent / "c-code"
    if not (path / "fmi2FunctionTypes.h").is_file():
        raise RuntimeError(f"fmpy's FMI 2.0 headers are missing ({path})")
    return path


def verilator() -> tuple[str, Path]:
    """The venv's verilator launcher and its VERILATOR_ROOT (also the simulated board's build)."""
    exe = shutil.which("verilator")
    if exe is None:
        raise RuntimeError("verilator is not on PATH: run `make setup`")
    root = subprocess.run(
        [exe, "--getenv", "VERILATOR_ROOT"], capture_output=True, text=True, check=True
    ).stdout.strip()
    return exe, Path(root)


def _inputs() -> list[Path]:
    fw_headers = sorted((FIRMWARE_DIR / "include").glob("*.h")) + sorted(
        (FIRMWARE_DIR / "host").glob("*.h")
    )
    return [*rtl_sources(), PAIR_TOP, *CXX_SOURCES, *HEADERS, *fw_headers, FW_LIB]


def fingerprint() -> str:
    exe, _ = verilator()
    version = subprocess.run([exe, "--version"], capture_output=True, text=True).stdout
    h = hashlib.sha256()
    for path in _inputs():
        h.update(path.name.encode())
        h.update(path.read_bytes())
    params = (CLKS_PER_SAMPLE, PAIR_CLKS_PER_SAMPLE)
    h.update(repr((VERILATOR_ARGS, CXXFLAGS, MAKEFLAGS, params, version)).encode())
    # the library is linked with an rpath to this checkout's firmware library: a build folder
    # copied or moved to another checkout must be built again, or it runs the other's firmware
    h.update(str(FW_LIB.resolve()).encode())
    return h.hexdigest()


def model_inputs(obj: Path) -> list[str]:
    """The Verilated model's input ports other than clk (Vcosim_top.h), after checking what
    closed_loop.cpp's Harness::eval assumes to skip the input-combinational region when only clk
    changed: every input is a scalar port (VL_IN8/16/32/64, copied and compared as a value) and
    the region's code (ico_sequent) does not read clk."""
    header = (obj / "Vcosim_top.h").read_text()
    if "VL_INW(" in header:
        raise RuntimeError("cosim_top has a wide input port: Harness::eval compares scalars only")
    ports = re.findall(r"VL_IN(?:8|16|64)?\(&(\w+),", header)
    if "clk" not in ports:
        raise RuntimeError("cosim_top has no clk input")
    check_ico_ignores_clk(obj, "cosim_top")
    return [p for p in ports if p != "clk"]


def check_ico_ignores_clk(obj: Path, top: str) -> None:
    """Raise unless the input-combinational region (ico_sequent) of the Verilated model `top` in
    `obj` leaves clk unread: a harness that skips that region when only clk changed relies on it
    (closed_loop.cpp here, the simulated board's harness.cpp)."""
    root = f"V{top}___024root"
    head = re.compile(rf"void {root}___ico_sequent__\w+\({root}\* vlSelf\) \{{")
    for path in sorted(obj.glob(f"{root}__*.cpp")):
        text = path.read_text()
        bodies = re.findall(head.pattern + r"(.*?)\n\}", text, re.S)
        if len(bodies) != len(head.findall(text)):
            raise RuntimeError(f"cannot read the input-combinational region in {path.name}")
        if any(re.search(r"\bvlSelfRef\.clk\b|\bvlSelf->clk\b", b) for b in bodies):
            raise RuntimeError(f"{top}'s input-combinational region reads clk")


def run_logged(cmd: list[str], log: Path, what: str = "native build") -> None:
    """Run one build step with its output appended to `log`; a failure is one line naming the
    tool and the log (`what` names the build)."""
    with log.open("a") as f:
        f.write("$ " + " ".join(cmd) + "\n")
        f.flush()
        status = procs.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if status != 0:
        raise RuntimeError(f"{what} failed ({Path(cmd[0]).name}); see {log}")


def build(force: bool = False) -> Path:
    """Build libbowden_native.so, or reuse it when up to date; return its path. Processes that
    build at the same time (tests, a sweep's client) take turns on a lock file: the second one
    finds the first one's build up to date."""
    import fcntl  # noqa: PLC0415

    setup_env()
    if not FW_LIB.is_file():
        raise RuntimeError(f"{FW_LIB} does not exist: run `make firmware` first")
    OUT_DIR.mkdir(parents=True, exist_ok=True)
    with open(OUT_DIR / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        return _build_locked(force)


def _build_locked(force: bool) -> Path:
    stamp = OUT_DIR / "fingerprint.txt"
    fp = fingerprint()
    if not force and LIB_PATH.is_file() and stamp.is_file() and stamp.read_text() == fp:
        return LIB_PATH
    exe, root = verilator()
    log = OUT_DIR / "build.log"
    log.write_text("")

    def verilate(obj: Path, top: str, clks_per_sample: int, sources: list[Path], prefix=()):
        """One Verilated model of `top` into a fresh `obj`, its C++ built there."""
        shutil.rmtree(obj, ignore_errors=True)
        obj.mkdir(parents=True)
        run_logged(
            [
                exe,
                "--cc",
                "--build",
                "-j",
                "2",
                *VERILATOR_ARGS,
                "--top-module",
                top,
                *prefix,
                f"-GCLKS_PER_SAMPLE={clks_per_sample}",
                f"-I{HDL_DIR / 'rtl'}",
                "--Mdir",
                str(obj),
                "-CFLAGS",
                " ".join(CXXFLAGS),
                "-MAKEFLAGS",
                MAKEFLAGS,
                *[str(p) for p in sources],
            ],
            log,
        )

    obj = OUT_DIR / "obj"
    verilate(obj, "cosim_top", CLKS_PER_SAMPLE, rtl_sources())
    # The antagonistic pair's core (bn_run_pair): cosim_pair_top, a second model under its own
    # prefix.
    obj_core = OUT_DIR / "obj_pair_top"
    core_rtl = [p for p in rtl_sources() if p.parent == HDL_DIR / "rtl"]
    verilate(
        obj_core,
        "cosim_pair_top",
        PAIR_CLKS_PER_SAMPLE,
        [*core_rtl, PAIR_TOP],
        prefix=("--prefix", "Vpair_top"),
    )
    inputs = " ".join(f"X({p})" for p in model_inputs(obj))
    cxx = os.environ.get("CXX", "g++")
    tmp = LIB_PATH.with_name(f"{LIB_PATH.name}.{os.getpid()}")
    run_logged(
        [
            cxx,
            *CXXFLAGS,
            "-shared",
            "-Wall",
            "-Wextra",
            f"-DBN_CLKS_PER_SAMPLE={CLKS_PER_SAMPLE}",
            f"-DBN_PAIR_CLKS_PER_SAMPLE={PAIR_CLKS_PER_SAMPLE}",
            f"-DBN_INPUT_PORTS(X)={inputs}",
            f"-I{obj}",
            f"-I{obj_core}",
            "-isystem",
            str(root / "include"),
            "-isystem",
            str(root / "include" / "vltstd"),
            f"-I{fmpy_include()}",
            f"-I{FIRMWARE_DIR / 'include'}",
            f"-I{FIRMWARE_DIR / 'host'}",
            f"-I{NATIVE_DIR}",
            *[str(p) for p in CXX_SOURCES],
            str(obj / "Vcosim_top__ALL.a"),
            str(obj_core / "Vpair_top__ALL.a"),
            str(obj / "libverilated.a"),
            f"-L{FW_LIB.parent}",
            "-lbowden_fw",
            f"-Wl,-rpath,{FW_LIB.parent}",
            "-pthread",
            "-o",
            str(tmp),
        ],
        log,
    )
    os.replace(tmp, LIB_PATH)  # atomic: a run in parallel loads the old or the new library
    tmp_stamp = stamp.with_name(f"{stamp.name}.{os.getpid()}")
    tmp_stamp.write_text(fp)
    os.replace(tmp_stamp, stamp)
    return LIB_PATH


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if args != ["build"]:
        print("usage: python -m cosim.engines.native build", file=sys.stderr)
        return 2
    try:
        path = build()
    except RuntimeError as exc:
        print(f"native build: {exc}", file=sys.stderr)
        return 1
    print(f"built {path}")
    return 0
