"""The FMU convergence study's pieces (cosim/convergence; the study itself is `make
fmu-convergence`): the rule picks the cheapest setting within both tolerances, at any segment
count and at the FMU's own, and a variant build runs the closed loop with its segment count."""

from __future__ import annotations

import numpy as np

from cosim.studies import convergence as conv


def _row(step_us, seg, d_out, d_rms, us=1.0):
    return {
        "max_step_us": step_us,
        "segments": seg,
        "t_out_rms_diff_n": d_out,
        "d_rms_error_pct": d_rms,
        "fmu_us_per_sample": us,
    }


def test_rule_picks_the_cheapest_setting_within_both_tolerances():
    rows = [
        _row(100, 8, conv.TOL_T_OUT_N * 1.5, 0.0),  # cheapest, T_out too far
        _row(100, 16, 0.0, conv.TOL_RMS_PP * 2),  # next, RMS error moved too much
        _row(50, 16, 0.0, -conv.TOL_RMS_PP),  # within both (on the limit): cost 32
        _row(100, 32, conv.TOL_T_OUT_N, 0.0),  # within both: cost 32, slower measured
        _row(50, 32, 0.0, 0.0),  # within: cost 64
    ]
    rows[3]["fmu_us_per_sample"] = 2.0
    pick, at_default = conv.picks(rows)
    assert (pick["max_step_us"], pick["segments"]) == (50, 16)
    assert (at_default["max_step_us"], at_default["segments"]) == (100, 32)
    assert conv.picks([_row(100, 8, 1.0, 1.0)]) == (None, None)


def test_a_variant_build_runs_the_closed_loop_with_its_segments():
    coarse = conv.run_setting(100e-6, 8, duration_s=0.3)
    fine = conv.run_setting(100e-6, conv.DEFAULT_SEGMENTS, duration_s=0.3)
    assert len(coarse["T_out_N"]) == len(fine["T_out_N"]) == 3000
    # Same loop, same inputs: close, but the discretisation shows once the cable is loaded.
    diff = np.abs(coarse["T_out_N"] - fine["T_out_N"])
    assert 0.0 < diff.max() < 0.05, diff.max()
