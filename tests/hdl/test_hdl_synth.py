"""Synthesis figures of each board (yosys + nextpnr, fixed seeds): timing met, within budget.

Runs hdl/synth/synth.py, which reuses build/synth/<board>/summary.json when the RTL, the
constraints and the script are unchanged, so this takes seconds after the first `make synth`.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from cosim.project.paths import BUILD_DIR, REPO_ROOT
from hdl.boards import table
from hdl.synth import synth

KEYS = {"luts", "ffs", "dsps", "brams", "fmax_mhz", "target_mhz"}


# make test synthesizes the UP5K, the board with the least room (its LUT budget and its DSPs'
# registers are checked here); the ECP5's synthesis of the same RTL is `make test-matrix`'s.
BOARDS = [
    pytest.param(b, marks=pytest.mark.matrix) if b.startswith("ecp5") else b
    for b in sorted(synth.BOARDS)
]
_SUMMARIES: dict[str, tuple[int, dict]] = {}


def summary(board: str) -> tuple[int, dict]:
    """Synthesize (or reuse) one board, once per session: the script's exit status and figures."""
    if board not in _SUMMARIES:
        result = subprocess.run(
            [sys.executable, "-m", "hdl.synth.synth", board],
            cwd=REPO_ROOT,
            capture_output=True,
            text=True,
        )
        print(result.stdout, result.stderr)
        figures = json.loads((BUILD_DIR / "synth" / board / "summary.json").read_text())
        _SUMMARIES[board] = (result.returncode, figures)
    return _SUMMARIES[board]


@pytest.mark.parametrize("board", BOARDS)
def test_synth_script_passes(board):
    """make synth's check: the board meets its target clock and LUT budget."""
    code, _ = summary(board)
    assert code == 0, f"hdl/synth/synth.py reported {board} missing its target"


@pytest.mark.parametrize("board", BOARDS)
def test_board_figures(board):
    """Fmax at or above the board table's target (hdl/boards/table.py), LUTs within the synthesis
    budget of the device's LUT4s, the multipliers in DSP blocks."""
    s = summary(board)[1]
    spec = synth.BOARDS[board]
    target_mhz = spec.target_mhz
    assert KEYS <= s.keys()
    assert s["target_mhz"] == target_mhz == table.BOARDS[board].rtl.target_mhz
    assert s["lut_capacity"] == table.BOARDS[board].fpga.luts
    assert s["fmax_mhz"] >= target_mhz, f"{board}: {s['fmax_mhz']} MHz < {target_mhz}"
    assert s["luts"] <= spec.max_lut_fraction * s["lut_capacity"]
    # Two loop multipliers and the PWM scaling: three 16 x 16 DSP multiplies.
    assert s["dsps"] == 3
    # The seed sweep: the board's seeds tried in order, the reported one the first at the target.
    tried = {int(k): v for k, v in s["fmax_by_seed_mhz"].items()}
    seeds = synth.BOARDS[board].seeds
    assert list(tried) == list(seeds[: len(tried)]) and s["seed"] == list(tried)[-1]
    assert tried[s["seed"]] == s["fmax_mhz"]
    assert all(f < target_mhz for seed, f in tried.items() if seed != s["seed"]), tried


def test_ice40_dsps_are_fully_registered():
    """Every SB_MAC16 has its input and output registers inside, so nextpnr times through it."""
    summary("ice40-up5k")
    netlist = json.loads((BUILD_DIR / "synth" / "ice40-up5k" / "ice40_up5k_top.json").read_text())
    macs = [
        cell
        for module in netlist["modules"].values()
        for cell in module["cells"].values()
        if cell["type"] == "SB_MAC16"
    ]
    assert len(macs) == 3
    for cell in macs:
        p = {k: int(v, 2) if isinstance(v, str) else v for k, v in cell["parameters"].items()}
        # A constant operand (the PWM scale factor) needs no register.
        b_const = all(bit in ("0", "1") for bit in cell["connections"]["B"])
        assert p["A_REG"] == 1, "DSP operand A not registered inside"
        assert p["B_REG"] == 1 or b_const, "DSP operand B not registered inside"
        # The product register went into the DSP's 16 x 16 pipeline register.
        assert p["PIPELINE_16x16_MULT_REG1"] == 1 or p["PIPELINE_16x16_MULT_REG2"] == 1, p
        # Output select 3: the 16 x 16 product (not the unregistered adder or 8 x 8 outputs).
        assert p["TOPOUTPUT_SELECT"] == 3 and p["BOTOUTPUT_SELECT"] == 3, p
