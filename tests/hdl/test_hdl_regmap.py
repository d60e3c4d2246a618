"""The register map: generated files match their one source, and the Python map is usable."""

from __future__ import annotations

import json

import pytest

from cosim.parts import regmap
from hdl.regmap import gen_regmap


def test_generated_files_are_fresh():
    """Every committed output equals what the generator makes from bowden_regs.json now."""
    gen = gen_regmap
    for path, text in gen.outputs(gen.load()).items():
        assert path.exists(), f"{path} missing: run make regmap"
        assert path.read_text() == text, f"{path} is stale: run make regmap"


def test_check_mode_detects_a_stale_file(tmp_path, monkeypatch):
    """The --check mode reports an edited output and leaves it untouched."""
    gen = gen_regmap
    stale = tmp_path / "regmap.py"
    stale.write_text("# edited by hand\n")
    monkeypatch.setattr(gen, "outputs", lambda spec: {stale: "generated\n"})
    monkeypatch.setattr(gen, "ROOT", tmp_path)
    assert gen.main(["--check"]) == 1
    assert stale.read_text() == "# edited by hand\n"
    assert gen.main([]) == 0
    assert stale.read_text() == "generated\n"


def test_source_rejects_overlapping_addresses(tmp_path):
    """A table with two registers at one address is an error naming both."""
    gen = gen_regmap
    spec = json.loads(gen.SOURCE.read_text())
    spec["registers"][1]["addr"] = spec["registers"][0]["addr"]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(spec))
    with pytest.raises(ValueError, match="CTRL.*already used by ID"):
        gen.load(bad)


def test_python_map_matches_contract_names():
    """Every register name of the contract exists, word aligned, with distinct addresses."""
    names = (
        "ID CTRL STATUS FAULT TC KFF KP KI_TS I_LIMIT SLEW WDT_TIMEOUT ADC_OFFSET ADC_GAIN "
        "ADC_MIN ADC_MAX ADC_STALE SAMPLE_COUNT T_IN U INTEG"
    ).split()
    addrs = [getattr(regmap, n) for n in names]
    assert all(a % 4 == 0 for a in addrs)
    assert len(set(addrs)) == len(addrs)
    assert regmap.REGISTERS["TC"].fields[0].frac == 8  # Q7.8 on the bus (contract)
    assert regmap.REGISTERS["U"].fields[0].frac == 12  # Q3.12 (contract)


def test_encode_decode_round_trip_and_range_error():
    """Signed fields sign-extend on decode; out-of-range values raise naming the register."""
    assert regmap.decode("TC", regmap.encode("TC", -32768)) == -32768
    assert regmap.decode("TC", 0xFFFFFFFF) == -1
    assert regmap.decode("I_LIMIT", regmap.encode("I_LIMIT", 32767)) == 32767
    with pytest.raises(ValueError, match="TC=32768 outside allowed -32768..32767"):
        regmap.encode("TC", 32768)


def test_bit_field_registers_refuse_single_value_decoding():
    """decode/encode of CTRL, STATUS or FAULT would silently drop fields: they raise instead."""
    for name in ("CTRL", "STATUS", "FAULT"):
        with pytest.raises(ValueError, match=f"{name} has bit fields"):
            regmap.decode(name, 0xF)
        with pytest.raises(ValueError, match=f"{name} has bit fields"):
            regmap.encode(name, 1)


def test_the_loops_parameters_default_to_the_tables_values():
    """A parameter of the loop that is not a register (the table's "parameters") has one value:
    every RTL module's default (tension_loop, its datapath, the cores) is the one the C header
    and regmap carry."""
    import re

    from cosim.project.paths import REPO_ROOT

    spec = gen_regmap.load()
    assert spec["parameters"], "the table lists the loop's parameters"
    header = (REPO_ROOT / "firmware" / "include" / "bowden_regs.h").read_text()
    for par in spec["parameters"]:
        name, value = par["name"], par["value"]
        assert getattr(regmap, name) == value
        assert re.search(rf"#define BOWDEN_{name} \(?{value}\)?\n", header), name
        declared = {}
        for rtl in sorted((REPO_ROOT / "hdl" / "rtl").glob("*.v")):
            pattern = rf"parameter\s+(?:\[[^\]]*\]\s*)?{name}\s*=\s*(?:\d+'d)?(\d+)"
            for v in re.findall(pattern, rtl.read_text()):
                declared[rtl.name] = int(v)
        assert {"tension_loop.v", "tension_loop_mc.v"} <= set(declared), (name, declared)
        assert set(declared.values()) == {value}, (name, declared)
