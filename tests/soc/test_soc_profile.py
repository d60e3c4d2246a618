"""The firmware's profile by function (make soc-profile): firmware/soc/tools/rv32_profile.py
names the function of each sampled program counter from the image's symbol table; the long test
runs the profile in the simulation (tb_soc_profile.py) and prints it."""

from __future__ import annotations

import json
import subprocess
import sys
from collections import Counter

import pytest
from hdl_sim import run_cocotb
from soc_sim import FW_HEX, VERILATOR_ARGS, soc_sources

from cosim.project.paths import BUILD_DIR, REPO_ROOT
from firmware.soc.tools.rv32_profile import Functions
from firmware.soc.tools.rv32_report import load

PROFILE = [sys.executable, "-m", "firmware.soc.tools.rv32_profile"]
ELF = BUILD_DIR / "firmware" / "soc" / "bowden_fw.elf"


@pytest.fixture(scope="module")
def funcs():
    assert ELF.exists(), "make firmware-soc first (make test builds it)"
    return Functions.of_elf(ELF)


def test_a_pc_is_named_by_the_function_that_holds_it(funcs):
    table = {name: (addr, size) for addr, (name, size) in load(ELF)[2].items()}
    addr, size = table["proto_encode"]
    assert funcs.name_at(addr) == "proto_encode"
    assert funcs.name_at(addr + size - 4) == "proto_encode"
    assert funcs.name_at(addr + size) != "proto_encode"  # the next function's, or "?"
    assert funcs.name_at(0x7FFF_FFF0) == "?"  # past the image
    hist = {addr: 5, addr + 4: 2, table["fw_tick"][0]: 3, 0x7FFF_FFF0: 1}
    assert funcs.attribute(hist) == {"proto_encode": 7, "fw_tick": 3, "?": 1}


def _tool(elf, profile):
    return subprocess.run(
        [*PROFILE, str(elf), str(profile)],
        cwd=REPO_ROOT,
        capture_output=True,
        text=True,
    )


@pytest.mark.parametrize(
    ("text", "says"),
    [
        (None, "none.json: no such file"),
        ("{bad", "not a profile of tb_soc_profile.py"),
        ('{"tick": [{"zz": 3}]}', "not a profile of tb_soc_profile.py"),
        ("[1, 2]", "not a profile of tb_soc_profile.py"),
    ],
)
def test_the_tool_refuses_a_bad_profile_in_one_line(tmp_path, text, says):
    path = tmp_path / "none.json"
    if text is not None:
        path.write_text(text)
    run = _tool(ELF, path)
    assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr
    assert says in run.stderr


def test_the_tool_refuses_a_file_that_is_not_an_image(tmp_path):
    (tmp_path / "p.json").write_text("{}")
    run = _tool(tmp_path / "p.json", tmp_path / "p.json")
    assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr
    assert "not an RV32 image with symbols" in run.stderr


@pytest.mark.long  # a Python callback a clock: some 20 s of simulation for 24 ticks
def test_soc_profile(tmp_path):
    out = tmp_path / "profile.json"
    params = {"ROM_INIT": f'"{FW_HEX}"', "ADC_WAIT_CLKS": 256}
    run_cocotb(
        "soc_tb", "tb_soc_profile", soc_sources(), "verilator", params, tag="boot",
        extra_env={"SOC_PROFILE_JSON": str(out)}, build_args=VERILATOR_ARGS, reuse=False,
    )  # fmt: skip
    profile = json.loads(out.read_text())
    funcs = Functions.of_elf(ELF)
    for phase, must in (
        ("tick", {"dev_tick_channels", "fw_tick", "proto_encode_in_place"}),
        ("received bytes", {"proto_rx_bytes"}),
    ):
        total = Counter()
        for span in profile[phase]:
            total.update(funcs.attribute({int(pc, 16): n for pc, n in span.items()}))
        # every clock of a phase is in some function of the image, and the tick's work is seen
        assert total["?"] == 0, f"{phase}: {total['?']} clocks outside the image's functions"
        assert must <= set(total), f"{phase}: {sorted(must - set(total))} not seen"
    report = subprocess.run(
        [*PROFILE, str(ELF), str(out)],
        cwd=REPO_ROOT, capture_output=True, text=True, check=True,
    )  # fmt: skip
    print("\n" + report.stdout)
