# --- calibrate: `bowden bench calibrate` on the emulated controller -----------------------------
# (cosim/bench/README.md, "Calibration"; docs/results.md)
#
#   make perf-calibrate  `calibrate --apply` on emulated plants with mu 0.06 and 0.09 (compensator
#                        at 0.075), paper and smooth modes: the verification error against the
#                        nominal plant's (target <= 1.3x) and the floor a perfect mu gives

.PHONY: perf-calibrate
PERF_TARGETS += perf-calibrate

perf-calibrate: $(BENCH_SO) fmu
	$(PY) -m cosim.perf.calibrate --modes paper,smooth
