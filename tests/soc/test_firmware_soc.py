"""The RV32 firmware image (`make firmware-soc`): built from the host library's sources plus
start-up, linker script and drivers; integer only (no soft-float helper, no libm); its size and
worst-case stack reported; and the checks shown to fail on code that breaks them.
"""

import shlex
import struct
import subprocess
import sys

import pytest

from cosim.project.paths import BUILD_DIR, REPO_ROOT

SOC = BUILD_DIR / "firmware" / "soc"
REPORT = [sys.executable, "-m", "firmware.soc.tools.rv32_report"]
ELF_REPORT = [sys.executable, "-m", "firmware.tools.elf_report"]
ZIG = [sys.executable, "-m", "ziglang"]
FLAGS = shlex.split(
    "-target riscv32-freestanding-none -mcpu=generic_rv32+zmmul -ffreestanding -fno-builtin -O2 "
    "-fno-unwind-tables -fno-asynchronous-unwind-tables"
)


@pytest.fixture(scope="module")
def soc_build():
    run = subprocess.run(
        ["make", "-s", "-o", ".venv/.installed", "firmware-soc"],
        cwd=REPO_ROOT,
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    return run.stdout


def _report(*args):
    return subprocess.run([*REPORT, *map(str, args)], cwd=REPO_ROOT, capture_output=True, text=True)


def test_image_is_rv32_and_starts_at_reset(soc_build):
    elf = (SOC / "bowden_fw.elf").read_bytes()
    assert elf[:4] == b"\x7fELF" and elf[4] == 1  # ELF32
    assert struct.unpack_from("<H", elf, 18)[0] == 243  # EM_RISCV
    assert struct.unpack_from("<I", elf, 24)[0] == 0  # entry: picorv32's PROGADDR_RESET
    words = (SOC / "bowden_fw.hex").read_text().split()
    assert len(words) == 65536 // 4  # padded to the ROM
    image = (SOC / "bowden_fw.bin").read_bytes()
    assert int(words[0], 16) == struct.unpack_from("<I", image, 0)[0]
    flash = (SOC / "bowden_fw_flash.bin").read_bytes()
    assert struct.unpack_from("<I", flash, 0)[0] == len(image) + (-len(image) % 4)
    assert flash[4 : 4 + len(image)] == image


def test_size_and_stack_reported(soc_build):
    text = (SOC / "size.txt").read_text()
    assert "no soft-float helper and no libm symbol" in text
    size = int(text.split("image (ROM: code + read-only data + .data init): ")[1].split()[0])
    assert 8000 < size <= 65536, text
    stack = int(text.split("worst-case stack (static bound): ")[1].split()[0])
    # The deepest path goes through the settings check (the gain tables' build) or the flash.
    assert 256 < stack <= 4096, text
    assert "path: main -> " in text


@pytest.mark.parametrize("channels", [2, 4])
def test_images_of_several_cables(soc_build, channels):
    """The images of two and four cables (build/firmware/soc/chN: BOWDEN_CHANNELS_MAX N): integer
    only, and their data, bss and worst-case stack inside the 32 KiB of RAM they are linked for
    (the ECP5's top gives the four-cable SoC RAM_WORDS 8192; the UP5K's SPRAM pair holds 64 KiB),
    a cable's RAM (its firmware state, settings and stream buffer: 4.6 KB) above the one-cable
    image's."""
    text = (SOC / f"ch{channels}" / "size.txt").read_text()
    assert "no soft-float helper and no libm symbol" in text
    bss = int(text.split(".bss ")[1].split()[0])
    stack = int(text.split("worst-case stack (static bound): ")[1].split()[0])
    one = (SOC / "size.txt").read_text()
    bss_one = int(one.split(".bss ")[1].split()[0])
    per_cable = (bss - bss_one) / (channels - 1)
    assert 4000 < per_cable < 5000, text
    assert bss + stack <= 32768, text
    image = (SOC / f"ch{channels}" / "bowden_fw.bin").read_bytes()
    flash = (SOC / f"ch{channels}" / "bowden_fw_flash.bin").read_bytes()
    assert flash[4 : 4 + len(image)] == image


def test_objects_have_no_soft_float_or_libm(soc_build):
    run = subprocess.run(
        [*ELF_REPORT, str(SOC / "libbowden_fw_soc.a")],
        cwd=REPO_ROOT,
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert "libm / soft-float references: none" in run.stdout


@pytest.fixture(scope="module")
def float_probe(tmp_path_factory):
    """Code using float and double, compiled and linked as the firmware is (without a library,
    the helpers left unresolved), to show that both checks catch it."""
    tmp = tmp_path_factory.mktemp("probe")
    src = tmp / "probe.c"
    src.write_text(
        "volatile float f; volatile double d;\n"
        "int main(void) { f = f * 3.0f; d = d / 3.0; for (;;) { } }\n"
    )
    obj = tmp / "probe.o"
    subprocess.run([*ZIG, "cc", *FLAGS, "-c", str(src), "-o", str(obj)], check=True)
    start = REPO_ROOT / "firmware" / "soc" / "start.S"
    sobj = tmp / "start.o"
    subprocess.run([*ZIG, "cc", *FLAGS, "-c", str(start), "-o", str(sobj)], check=True)
    elf = tmp / "probe.elf"
    subprocess.run(
        [*ZIG, "ld.lld", "-T", str(REPO_ROOT / "firmware" / "soc" / "link.ld"), "--emit-relocs",
         "--defsym=__rom_bytes=65536", "--defsym=__ram_bytes=16384", "--defsym=__stack_min=64",
         "--defsym=soc_ticks_seen=0x10000000", "--unresolved-symbols=ignore-all",
         str(sobj), str(obj), "-o", str(elf)],
        check=True,
    )  # fmt: skip
    return obj, elf


def test_float_probe_fails_the_object_check(float_probe):
    obj, _ = float_probe
    run = subprocess.run([*ELF_REPORT, str(obj)], cwd=REPO_ROOT, capture_output=True, text=True)
    assert run.returncode == 1
    assert "__mulsf3" in run.stdout and "__divdf3" in run.stdout


def test_float_probe_fails_the_image_check(float_probe):
    _, elf = float_probe
    run = _report(elf)
    assert run.returncode == 1
    assert "FAIL: soft-float or libm symbols in the image" in run.stdout
    assert "__mulsf3" in run.stdout


def test_stack_bound_can_fail(soc_build):
    run = _report(SOC / "bowden_fw.elf", "--stack-max", "256")
    assert run.returncode == 1
    assert "exceeds --stack-max 256" in run.stdout


def test_recursion_has_no_bound(tmp_path):
    """A recursive function has no static stack bound: the report says so and fails."""
    src = tmp_path / "rec.c"
    src.write_text(
        "volatile int sink;\n"
        "__attribute__((noinline)) int rec(int n) { volatile int pad[8]; pad[0] = n;"
        " return n ? rec(n - 1) + pad[0] : 0; }\n"
        "int main(void) { sink = rec(sink); for (;;) { } }\n"
    )
    obj, sobj, elf = tmp_path / "rec.o", tmp_path / "start.o", tmp_path / "rec.elf"
    subprocess.run([*ZIG, "cc", *FLAGS, "-c", str(src), "-o", str(obj)], check=True)
    subprocess.run(
        [*ZIG, "cc", *FLAGS, "-c", str(REPO_ROOT / "firmware/soc/start.S"), "-o", str(sobj)],
        check=True,
    )
    subprocess.run(
        [*ZIG, "ld.lld", "-T", str(REPO_ROOT / "firmware" / "soc" / "link.ld"), "--emit-relocs",
         "--defsym=__rom_bytes=65536", "--defsym=__ram_bytes=16384", "--defsym=__stack_min=64",
         "--defsym=soc_ticks_seen=0x10000000", str(sobj), str(obj), "-o", str(elf)],
        check=True,
    )  # fmt: skip
    run = _report(elf)
    assert run.returncode == 1
    assert "recursion through rec" in run.stdout


def test_division_routine_matches_c_division(tmp_path):
    """libc.c's __udivsi3 / __umodsi3 (the CPU has no divide instruction), built for the host and
    called directly: quotient and remainder equal Python's on the edges (0, 1, 2^31, 2^32 - 1,
    powers of two and their neighbours, dividend below, at and above the divisor) and on 20 000
    seeded random pairs of every magnitude; a zero divisor gives all ones and the dividend
    (RISC-V's DIVU and REMU)."""
    import ctypes  # noqa: PLC0415
    import random  # noqa: PLC0415

    lib_path = tmp_path / "libc_host.so"
    run = subprocess.run(
        ["gcc", "-O2", "-fPIC", "-shared", "-fno-builtin", str(REPO_ROOT / "firmware" / "soc" /
         "libc.c"), "-o", str(lib_path)],
        capture_output=True, text=True,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    lib = ctypes.CDLL(str(lib_path))
    for fn in (lib.__udivsi3, lib.__umodsi3):
        fn.restype = ctypes.c_uint32
        fn.argtypes = (ctypes.c_uint32, ctypes.c_uint32)
    edges = {0, 1, 2, 3, 7, 10, 1000, 2**31 - 1, 2**31, 2**31 + 1, 2**32 - 2, 2**32 - 1}
    edges |= {(1 << k) + e for k in range(32) for e in (-1, 0, 1) if 0 <= (1 << k) + e < 2**32}
    rng = random.Random(20261126)
    pairs = [(n, d) for n in edges for d in edges if d]
    for _ in range(20_000):
        n = rng.getrandbits(rng.randint(1, 32))
        d = rng.getrandbits(rng.randint(1, 32)) or 1
        pairs.append((n, d))
    bad = [(n, d) for n, d in pairs if (lib.__udivsi3(n, d), lib.__umodsi3(n, d)) != divmod(n, d)]
    assert not bad, bad[:5]
    assert lib.__udivsi3(12345, 0) == 2**32 - 1 and lib.__umodsi3(12345, 0) == 12345
