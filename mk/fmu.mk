# --- fmu: the plant as an FMI 2.0 co-simulation FMU (fmu/README.md) --------------------------
#
#   make fmu        build/fmu/BowdenPlant.fmu (linux64 binary, sources, modelDescription.xml)
#   make fmu-lint   the C sources with -Wall -Wextra -Wpedantic -Werror (part of `make lint`)
#   make perf-fmu  wall time per simulated second at a 100 us step (part of `make perf`)
#
# Rebuilds only what changed: the generator rewrites its outputs only when their text changes.

FMU_OUT := $(BUILD)/fmu
FMU_FILE := $(FMU_OUT)/BowdenPlant.fmu
FMU_GEN := $(FMU_OUT)/gen
FMU_STAGE := $(FMU_OUT)/stage
FMU_SO := $(FMU_STAGE)/binaries/linux64/BowdenPlant.so
FMU_C := $(sort $(wildcard fmu/src/*.c))
FMU_H := $(sort $(wildcard fmu/src/*.h))
FMU_CC ?= cc
FMU_WARN := -std=c99 -Wall -Wextra -Wpedantic -Werror
FMU_CFLAGS := $(FMU_WARN) -O2 -fPIC -fvisibility=hidden
# The FMI 2.0 headers ship inside fmpy (c-code/); '=' defers the query until a recipe runs,
# after the venv exists.
FMU_FMI2_INC = $(shell $(PY) -c 'import fmpy, os; print(os.path.join(os.path.dirname(fmpy.__file__), "c-code"))')
FMU_INC = -I$(FMU_FMI2_INC) -Ifmu/src -I$(FMU_GEN)

.PHONY: fmu fmu-lint perf-fmu
BUILD_TARGETS += fmu
LINT_TARGETS += fmu-lint
PERF_TARGETS += perf-fmu

fmu: $(FMU_FILE)

$(FMU_GEN)/.stamp: fmu/gen_model.py $(VENV_STAMP)
	@mkdir -p $(FMU_GEN)
	$(PY) -m fmu.gen_model $(FMU_GEN)
	@touch $@

$(FMU_GEN)/bowden_vars.h $(FMU_GEN)/modelDescription.xml: $(FMU_GEN)/.stamp ;

$(FMU_SO): $(FMU_C) $(FMU_H) $(FMU_GEN)/bowden_vars.h
	@mkdir -p $(dir $@)
	$(FMU_CC) $(FMU_CFLAGS) $(FMU_INC) -shared -o $@ $(FMU_C) -lm

$(FMU_STAGE)/modelDescription.xml: $(FMU_GEN)/modelDescription.xml
	@mkdir -p $(dir $@)
	cp $< $@

$(FMU_STAGE)/sources/%: fmu/src/%
	@mkdir -p $(dir $@)
	cp $< $@

$(FMU_STAGE)/sources/bowden_vars.h: $(FMU_GEN)/bowden_vars.h
	@mkdir -p $(dir $@)
	cp $< $@

FMU_STAGED_SOURCES := $(patsubst fmu/src/%,$(FMU_STAGE)/sources/%,$(FMU_C) $(FMU_H)) \
	$(FMU_STAGE)/sources/bowden_vars.h

$(FMU_FILE): $(FMU_SO) $(FMU_STAGE)/modelDescription.xml $(FMU_STAGED_SOURCES)
	rm -f $@
	cd $(FMU_STAGE) && $(PY) -m zipfile -c $@ modelDescription.xml binaries sources

fmu-lint: $(FMU_GEN)/.stamp
	$(FMU_CC) $(FMU_WARN) -O2 -fsyntax-only $(FMU_INC) $(FMU_C)

perf-fmu: $(FMU_FILE)
	$(PY) -m cosim.perf.fmu

# The FMU convergence study (cosim/convergence, fmu/README.md "Convergence"): max_step and sheath
# segments against a fine reference, on the native closed loop. Not part of `make test`.
.PHONY: fmu-convergence
fmu-convergence: $(FMU_FILE) native
	$(PY) -m cosim.studies.convergence

# The strands of the gradual dead zone against the continuous distribution they sample
# (cosim/studies/strands.py, fmu/README.md "Convergence"). Not part of `make test`.
.PHONY: fmu-strands
fmu-strands: $(VENV_STAMP)
	$(PY) -m cosim.studies.strands
