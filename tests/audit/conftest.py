"""Model audit tests: put this folder on sys.path for the shared data makers (audit_data.py)."""

import sys
from pathlib import Path

HERE = str(Path(__file__).resolve().parent)
if HERE not in sys.path:
    sys.path.insert(0, HERE)
