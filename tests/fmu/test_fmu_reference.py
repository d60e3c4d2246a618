"""The FMU reproduces its reference output (fmu/reference/, written by fmu/make_reference.py)."""

from __future__ import annotations

import numpy as np
from fmpy.util import read_csv

from fmu import make_reference


def test_reference_input_file_is_the_scripts_input():
    ref = make_reference
    stored = read_csv(str(ref.INPUT_CSV))
    signals = ref.input_signals()
    for name in signals.dtype.names:
        assert np.allclose(stored[name], signals[name], rtol=1e-12, atol=1e-15), name


def test_simulation_matches_reference_output(fmu_path):
    ref = make_reference
    stored = read_csv(str(ref.REF_CSV))
    result = ref.simulate(fmu_path)
    assert len(result) == len(stored) == 401
    for name in ref.OUTPUTS:
        diff = np.max(np.abs(result[name] - stored[name]))
        scale = max(1.0, float(np.max(np.abs(stored[name]))))
        assert diff <= 1e-7 * scale, f"{name}: max difference {diff}"
    # the reference is not trivial: tension built up, noise, motion out of the loop's plane
    assert np.max(stored["T_in"]) > 20.0 and np.ptp(stored["phi"]) > 0.05
    assert np.std(stored["T_in_meas"] - stored["T_in"]) > 0.03
