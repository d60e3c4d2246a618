"""SoC testbench set-up: this folder and tests/hdl (hdl_sim.run_cocotb) on sys.path, as
pytest's `pythonpath` (pyproject.toml) does for the RTL testbenches (cocotb's Python inherits
it)."""

import sys
from pathlib import Path

TB_DIR = Path(__file__).resolve().parent
for d in (TB_DIR, TB_DIR.parent / "hdl"):
    if str(d) not in sys.path:
        sys.path.insert(0, str(d))
