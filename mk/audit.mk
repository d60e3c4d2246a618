# --- audit: the model audit, `bowden audit` (README.md "Model audit", cosim/audit/) ------------
#
#   make perf-audit  wall and CPU time of `bowden audit` on 60 s of 1 kHz data (target <= 30 s),
#                     for data with no effect, one effect, two effects and a recording of the
#                     bench emulator; then 20 min of 1 kHz data with two effects (target <= 2 min
#                     wall and <= 2 GB peak memory; `python -m cosim.perf.audit long` runs only
#                     that one) (part of `make perf`)
#   make audit-sweep  every cause of the vocabulary at random magnitudes, AUDIT_SEEDS seeds each,
#                     and no effect: the cause named against the hidden one (part of `make perf`;
#                     about 30 s a case)

AUDIT_SEEDS ?= 3

.PHONY: perf-audit audit-sweep
PERF_TARGETS += perf-audit audit-sweep

# (the emulator's library by its path: mk/bench.mk, which names it, is read after this file)
perf-audit: fmu $(VENV_STAMP) $(BUILD)/bench/host/libbowden_bench.so
	$(PY) -m cosim.perf.audit

audit-sweep: fmu $(VENV_STAMP)
	$(PY) -m cosim.studies.audit_sweep $(AUDIT_SEEDS)
