# --- firmware: the friction compensator and the processor's side of the FPGA (firmware/README.md)
#
#   make firmware         build/firmware/host/libbowden_fw.so (ctypes, cosim/parts/firmware.py) and the
#                         host unit-test program build/firmware/host/fw_unit_tests (run by pytest),
#                         also built with UBSan + ASan (fw_unit_tests_san): no overflow, no UB
#   make firmware-lint    every C file with -Wall -Wextra -Wpedantic -Werror, on the host and for
#                         the Cortex-M4 (part of `make lint`)
#   make firmware-target  Cortex-M4 static library (zig cc) and build/firmware/cortex-m4/size.txt;
#                         fails on any reference to libm or to a soft-float helper
#   make perf-firmware   instructions per compensator step under callgrind (part of `make perf`)

FW_OUT := $(BUILD)/firmware
FW_HOST_OUT := $(FW_OUT)/host
FW_M4_OUT := $(FW_OUT)/cortex-m4
FW_SO := $(FW_HOST_OUT)/libbowden_fw.so
FW_UNIT := $(FW_HOST_OUT)/fw_unit_tests
FW_UNIT_SAN := $(FW_HOST_OUT)/fw_unit_tests_san
FW_SAN := -fsanitize=undefined,address -fno-sanitize-recover=all
FW_PERF := $(FW_HOST_OUT)/perf_comp
FW_M4_LIB := $(FW_M4_OUT)/libbowden_fw.a
FW_M4_SIZE := $(FW_M4_OUT)/size.txt

FW_CC ?= gcc
FW_WARN := -std=c11 -Wall -Wextra -Wpedantic -Werror
FW_LINT_EXTRA := -Wshadow -Wstrict-prototypes -Wmissing-prototypes -Wcast-qual -Wundef
FW_INC := -Ifirmware/include -Ifirmware/host -Ifirmware/tests
# Code that runs on the target: integer only, no libm, no allocation.
FW_TARGET_SRC := $(addprefix firmware/src/,fxp.c comp.c fric_est.c hal.c wave.c fw.c)
# Host only: the double twin (libm) and the ctypes glue.
FW_HOST_SRC := firmware/src/comp_f64.c firmware/src/fric_est_f64.c firmware/host/fw_host.c
FW_TEST_SRC := $(sort $(wildcard firmware/tests/*.c))
FW_HDR := $(sort $(wildcard firmware/include/*.h firmware/host/*.h firmware/tests/*.h))

# Cortex-M4 through zig cc (PyPI `ziglang`, installed by `make setup`). The plain cortex_m4 CPU
# has no FPU features, so any float or double operation would become an __aeabi_f*/d* call
# that firmware/tools/elf_report.py rejects.
FW_ZIG_CC = $(PY) -m ziglang cc
FW_ZIG_AR = $(PY) -m ziglang ar
FW_M4_FLAGS := -target thumb-freestanding-eabihf -mcpu=cortex_m4 -ffreestanding -O2 \
  -fno-unwind-tables -fno-asynchronous-unwind-tables -ffunction-sections -fdata-sections
FW_M4_OBJ := $(patsubst firmware/src/%.c,$(FW_M4_OUT)/obj/%.o,$(FW_TARGET_SRC))

.PHONY: firmware firmware-lint firmware-target perf-firmware
BUILD_TARGETS += firmware
LINT_TARGETS += firmware-lint
PERF_TARGETS += perf-firmware

firmware: $(FW_SO) $(FW_UNIT) $(FW_UNIT_SAN)

$(FW_SO): $(FW_TARGET_SRC) $(FW_HOST_SRC) $(FW_HDR)
	@mkdir -p $(dir $@)
	$(FW_CC) $(FW_WARN) -O2 -fPIC -shared $(FW_INC) $(FW_TARGET_SRC) $(FW_HOST_SRC) -lm -o $@

$(FW_UNIT): $(FW_TARGET_SRC) $(FW_HOST_SRC) $(FW_TEST_SRC) $(FW_HDR)
	@mkdir -p $(dir $@)
	$(FW_CC) $(FW_WARN) -O2 $(FW_INC) $(FW_TARGET_SRC) $(FW_HOST_SRC) $(FW_TEST_SRC) -lm -o $@

# The same tests under the undefined-behaviour and address sanitizers: signed overflow, shifts
# out of range, out-of-bounds table reads would abort the program.
$(FW_UNIT_SAN): $(FW_TARGET_SRC) $(FW_HOST_SRC) $(FW_TEST_SRC) $(FW_HDR)
	@mkdir -p $(dir $@)
	$(FW_CC) $(FW_WARN) -O1 -g $(FW_SAN) $(FW_INC) $(FW_TARGET_SRC) $(FW_HOST_SRC) $(FW_TEST_SRC) \
	  -lm -o $@

$(FW_PERF): firmware/perf/perf_comp.c $(FW_TARGET_SRC) $(FW_HDR)
	@mkdir -p $(dir $@)
	$(FW_CC) $(FW_WARN) -O2 -g $(FW_INC) firmware/perf/perf_comp.c $(FW_TARGET_SRC) -o $@

firmware-lint: $(VENV_STAMP)
	@mkdir -p $(FW_M4_OUT)/lint
	@set -e; for f in $(FW_TARGET_SRC) $(FW_HOST_SRC) $(FW_TEST_SRC) firmware/perf/*.c; do \
	  $(FW_CC) $(FW_WARN) $(FW_LINT_EXTRA) $(FW_INC) -fsyntax-only $$f; \
	done; \
	for f in $(FW_TARGET_SRC) firmware/tools/target_sizes.c; do \
	  $(FW_ZIG_CC) $(FW_M4_FLAGS) $(FW_WARN) $(FW_LINT_EXTRA) -Ifirmware/include -c $$f -o $(FW_M4_OUT)/lint/$$(basename $$f .c).o; \
	done
	@echo "firmware-lint: C sources clean on the host ($(FW_CC)) and for the Cortex-M4 (zig cc)"

$(FW_M4_OUT)/obj/%.o: firmware/src/%.c $(FW_HDR) $(VENV_STAMP)
	@mkdir -p $(dir $@)
	$(FW_ZIG_CC) $(FW_M4_FLAGS) $(FW_WARN) -Ifirmware/include -c $< -o $@

$(FW_M4_OUT)/target_sizes.o: firmware/tools/target_sizes.c $(FW_HDR) $(VENV_STAMP)
	@mkdir -p $(dir $@)
	$(FW_ZIG_CC) $(FW_M4_FLAGS) $(FW_WARN) -Ifirmware/include -c $< -o $@

$(FW_M4_LIB): $(FW_M4_OBJ)
	@rm -f $@
	$(FW_ZIG_AR) rcs $@ $^

firmware-target: $(FW_M4_LIB) $(FW_M4_OUT)/target_sizes.o
	$(PY) -m firmware.tools.elf_report $(FW_M4_LIB) --sizes $(FW_M4_OUT)/target_sizes.o \
	  --out $(FW_M4_SIZE)

perf-firmware: $(FW_PERF) $(VENV_STAMP)
	$(PY) -m firmware.tools.bench_callgrind $(FW_PERF)
