"""Which load-cell front-end the board should have: the sensing study (hdl/README.md, "Sensing").

`python -m cosim.studies.sensing` runs the float reference (cosim.engines.reference) with the
board's PWM -> ESCON stage and four sensing options, and prints their tracking error and Kp margin
side by side (cosim.studies.sensing.study). hdl/README.md, section "Sensing", holds the table and
the decision.
"""

from __future__ import annotations

from .study import OPTIONS, SCENARIOS, kp_margin, make_option, run_study, sample_age_s

__all__ = ["OPTIONS", "SCENARIOS", "kp_margin", "make_option", "run_study", "sample_age_s"]
