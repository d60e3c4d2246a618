# --- formal: SymbiYosys proofs of the RTL's safety properties (hdl/README.md, "Formal proofs") --
#
#   make formal          every task of hdl/formal/*.sby (yowasp-sby, yices from .venv): one line
#                        per task (PASS/FAIL, method, depth, time); results in
#                        build/formal/<name>_<task>/
#   make formal-mutants  every mutant of hdl/formal/formal.py, applied to a scratch copy of the
#                        RTL under build/formal/mutants/, must make its proof fail (KILLED)
#
# `make test` runs the same tasks, at the same depths, through tests/hdl/test_hdl_formal.py.

FORMAL_JOBS ?= 2

.PHONY: formal formal-mutants

formal: $(VENV_STAMP)
	$(PY) -m hdl.formal.formal --jobs $(FORMAL_JOBS)

formal-mutants: $(VENV_STAMP)
	$(PY) -m hdl.formal.formal --mutants --jobs $(FORMAL_JOBS)
