# --- audit: the model audit, `bowden audit` (README.md "Model audit", cosim/audit/) ------------
#
#   make bench-audit  wall and CPU time of `bowden audit` on 60 s of 1 kHz data (target <= 30 s),
#                     for data with no effect, one effect, two effects and a recording of the
#                     bench emulator (part of `make bench`)
#   make audit-sweep  every cause of the vocabulary at random magnitudes, AUDIT_SEEDS seeds each,
#                     and no effect: the cause named against the hidden one (part of `make bench`;
#                     about 30 s a case)

AUDIT_SEEDS ?= 3

.PHONY: bench-audit audit-sweep
BENCH_TARGETS += bench-audit audit-sweep

# (the emulator's library by its path: mk/bench.mk, which names it, is read after this file)
bench-audit: fmu $(VENV_STAMP) $(BUILD)/bench/host/libbowden_bench.so
	$(PY) tests/audit/bench_audit.py

audit-sweep: fmu $(VENV_STAMP)
	$(PY) tests/audit/sweep.py $(AUDIT_SEEDS)
