# --- cosim: closed-loop co-simulation of RTL + firmware + plant FMU (cosim/README.md) ----------
#
#   make cosim-build  Verilator model of the co-simulation top (build/cosim/verilator), reused by
#                     `bowden sim`, `bowden demo` and the tests/cosim suite
#   make perf-cosim  closed-loop speed: simulated seconds per wall second of the 30 s fig14 run,
#                     cost split RTL / FMU / firmware / harness (part of `make perf`)
#   make demo         (top-level) runs `bowden demo`: fig14 for paper/smooth with loop routing and
#                     paper without, outputs in build/demo/

COSIM_RTL := $(sort $(wildcard hdl/rtl/*.v)) cosim/engines/cosim_top.v cosim/engines/cosim_top.vlt \
  cosim/parts/rtl_model.py
COSIM_STAMP := $(BUILD)/cosim/verilator/.built

.PHONY: cosim-build perf-cosim
BUILD_TARGETS += cosim-build
PERF_TARGETS += perf-cosim

cosim-build: $(COSIM_STAMP)

$(COSIM_STAMP): $(VENV_STAMP) $(COSIM_RTL) cosim/engines/cocotb/runner.py
	$(PY) -m cosim.engines.cocotb.runner build
	@touch $@

perf-cosim: $(COSIM_STAMP) fmu firmware native
	$(PY) -m cosim.perf.closed_loop
