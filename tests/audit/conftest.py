"""Model audit tests: put this folder on sys.path for the rig written here (rig_models.py)."""

import sys
from pathlib import Path

HERE = str(Path(__file__).resolve().parent)
if HERE not in sys.path:
    sys.path.insert(0, HERE)
