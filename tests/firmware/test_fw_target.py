"""The Cortex-M4 build (`make firmware-target`, zig cc): no libm, no floating point, size report.

The library is compiled for a Cortex-M4 without FPU features, so a float or double operation
would appear as an __aeabi_f*/__aeabi_d* helper reference; firmware/tools/elf_report.py (a small
ELF/ar reader) rejects those and libm names. A float-using probe compiled with the same flags
shows that the check does catch them.
"""

import shlex
import subprocess
import sys

import pytest

from cosim.project.paths import BUILD_DIR, REPO_ROOT
from firmware.tools import elf_report

M4 = BUILD_DIR / "firmware" / "cortex-m4"
ZIG_CC = [sys.executable, "-m", "ziglang", "cc"]
M4_FLAGS = shlex.split(
    "-target thumb-freestanding-eabihf -mcpu=cortex_m4 -ffreestanding -O2 "
    "-fno-unwind-tables -fno-asynchronous-unwind-tables"
)


@pytest.fixture(scope="module")
def target_build():
    # -o: never re-create the venv from inside a test (make test has just set it up).
    run = subprocess.run(
        ["make", "-s", "-o", ".venv/.installed", "firmware-target"],
        cwd=REPO_ROOT,
        capture_output=True,
        text=True,
    )
    print(run.stdout)
    assert run.returncode == 0, run.stdout + run.stderr
    return run.stdout


def test_fw_target_has_no_libm_or_soft_float(target_build):
    er = elf_report
    objs = er.read_objects(M4 / "libbowden_fw.a")
    assert {o.name for o in objs} == {"fxp.o", "comp.o", "fric_est.o", "hal.o", "wave.o", "fw.o"}
    assert all(o.data[18] == 40 for o in objs)  # e_machine = EM_ARM
    assert er.forbidden(objs) == []
    defined = {s.name for o in objs for s in o.symbols if s.defined}
    assert {"comp_step_q7_8", "fw_tick", "fxp_exp_uq8_24", "hal_init_mmio"} <= defined
    external = {s.name for o in objs for s in o.symbols if not s.defined} - defined
    # Only the run-time's memory helpers for structure copies, nothing else.
    assert external <= {"__aeabi_memcpy4", "__aeabi_memclr4", "__aeabi_memcpy", "__aeabi_memset"}


def test_fw_target_size_report_printed_and_written(target_build):
    text = (M4 / "size.txt").read_text()
    assert "libm / soft-float references: none" in text
    assert "comp_step_q7_8" in text and "RAM per instance" in text
    assert "total" in target_build and "comp_t" in target_build  # printed by make
    total = next(line for line in text.splitlines() if line.startswith("total"))
    text_bytes = int(total.split()[1])
    # A guard against code growing unnoticed, not a part's limit (the Cortex-M4 parts this targets
    # have 128 KiB of flash or more): 16.4 KiB measured with the dead-zone inverse, whose step is
    # compiled apart from the sharp law's so that the usual step keeps its instruction budget;
    # 17.9 KiB with the breakaway term's step beside them (one copy, with or without a spread);
    # 18.9 KiB with the slack's root in that copy, out of line (the sharp law's callgrind count);
    # 19.7 KiB (20142 bytes, from 19466) with the viscous term in that copy and the tick rate;
    # 20.0 KiB (20490 bytes) with the slack's turn; 20.6 KiB (21066 bytes) with the breakaway's
    # hold at the zone's width at the turn (a tension slope).
    assert 1000 < text_bytes < 21 * 1024, total


def test_fw_float_probe_is_caught(tmp_path, target_build):
    """Negative control: the same flags on code using float and double produce references that
    the check reports, so a clean report means something."""
    src = tmp_path / "probe.c"
    src.write_text(
        "float probe_f(float a, int b) { return a * (float)b; }\n"
        "double probe_d(double a) { return a / 3.0; }\n"
    )
    obj = tmp_path / "probe.o"
    subprocess.run([*ZIG_CC, *M4_FLAGS, "-c", str(src), "-o", str(obj)], check=True)
    bad = {name for _, name in elf_report.forbidden(elf_report.read_objects(obj))}
    assert any(n.startswith("__aeabi_f") for n in bad), bad
    assert any(n.startswith("__aeabi_d") for n in bad), bad
