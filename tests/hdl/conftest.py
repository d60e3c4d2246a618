"""RTL testbench set-up: put this folder on sys.path.

cocotb runs the coroutines in the simulator's own Python, which inherits this process's sys.path,
so the testbench modules (test_<module>.py) and their helper hdl_sim.py must import from here.
"""

import sys
from pathlib import Path

TB_DIR = Path(__file__).resolve().parent
if str(TB_DIR) not in sys.path:
    sys.path.insert(0, str(TB_DIR))
