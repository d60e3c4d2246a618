# --- bench: the protocol, the device side in the firmware, the emulator and `bowden bench` ------
# (firmware/proto/PROTOCOL.md, cosim/bench/README.md)
#
#   make proto            regenerate the protocol's C, Python, document, DBC and test vectors from
#                         firmware/proto/bowden_proto.json (and the firmware's configuration)
#   make bench-build      build/bench/host: libbowden_bench.so (firmware + device + emulator loop,
#                         for ctypes), the C unit tests (plain and UBSan + ASan) and the
#                         random/mutation fuzzer of the decoder under ASan + UBSan
#   make bench-lint       generated files up to date, C with -Werror on the host and the M4
#   make bench-target     Cortex-M4 library of the protocol and device code, and its size report
#   make fuzz-proto       a long random/mutation run of the decoder and device (ASan + UBSan)
#   make fuzz-proto-libfuzzer  the libFuzzer harness (needs clang; says so when it is missing)
#   make perf-proto      figures: M4 size, instructions per frame (callgrind), host decoder
#                         frames per second, 60 s of 1 kHz telemetry over the emulator's pty

BENCH_OUT := $(BUILD)/bench
BENCH_HOST := $(BENCH_OUT)/host
BENCH_M4 := $(BENCH_OUT)/cortex-m4
# Every target source of the firmware (not the double twin): a file added there joins the build.
BENCH_TARGET_SRC := $(filter-out firmware/src/comp_f64.c firmware/src/fric_est_f64.c,$(sort $(wildcard firmware/src/*.c)))
BENCH_OWN_SRC := $(addprefix firmware/src/,crc32c.c proto.c proto_can.c proto_msgs.c settings.c params.c \
  params_table.c flash.c dev.c)
BENCH_HOST_SRC := firmware/host/flash_ram.c firmware/host/dev_host.c cosim/bench/emulate/native/emu.c
BENCH_HDR := $(sort $(wildcard firmware/include/*.h firmware/host/*.h cosim/bench/emulate/native/*.h \
  firmware/tests/*.h firmware/tests/bench/*.h))
BENCH_TEST_SRC := $(sort $(wildcard firmware/tests/bench/test_*.c)) firmware/tests/bench/bench_main.c \
  firmware/tests/unit_main.c
BENCH_INC := -Ifirmware/include -Ifirmware/host -Icosim/bench/emulate/native -Ifirmware/tests \
  -Ifirmware/tests/bench
# Build id: the first 32 bits of SHA-256 over the sources (HELLO reports it).
BENCH_BUILD_ID := 0x$(shell cat $(BENCH_TARGET_SRC) $(BENCH_HDR) 2>/dev/null | sha256sum | cut -c1-8)
BENCH_CC ?= gcc
BENCH_WARN := -std=c11 -Wall -Wextra -Wpedantic -Werror
BENCH_LINT_EXTRA := -Wshadow -Wstrict-prototypes -Wmissing-prototypes -Wcast-qual -Wundef
BENCH_SAN := -fsanitize=undefined,address -fno-sanitize-recover=all
BENCH_DEFS := -DBOWDEN_BUILD_ID=$(BENCH_BUILD_ID)UL
# The host device (emulator, tests) holds up to 4 channels; a board build sets its own maximum
# (settings.h: 1 unless the build says otherwise).
BENCH_HOST_DEFS := $(BENCH_DEFS) -DBOWDEN_CHANNELS_MAX=4U

BENCH_SO := $(BENCH_HOST)/libbowden_bench.so
BENCH_UNIT := $(BENCH_HOST)/bench_unit_tests
BENCH_UNIT_SAN := $(BENCH_HOST)/bench_unit_tests_san
BENCH_FUZZ := $(BENCH_HOST)/proto_fuzz_san
BENCH_LIBFUZZER := $(BENCH_HOST)/proto_libfuzzer
PERF_PROTO := $(BENCH_HOST)/perf_proto
BENCH_M4_LIB := $(BENCH_M4)/libbowden_bench.a
BENCH_M4_OBJ := $(patsubst firmware/src/%.c,$(BENCH_M4)/obj/%.o,$(BENCH_OWN_SRC))
PROTO_SRC := firmware/proto/bowden_proto.json firmware/proto/gen_proto.py

.PHONY: proto proto-check bench-build bench-lint bench-target perf-proto fuzz-proto \
  fuzz-proto-libfuzzer
BUILD_TARGETS += bench-build
LINT_TARGETS += bench-lint
PERF_TARGETS += perf-proto

proto: $(VENV_STAMP)
	$(PY) -m firmware.proto.gen_proto

proto-check: $(VENV_STAMP)
	$(PY) -m firmware.proto.gen_proto --check

bench-build: $(BENCH_SO) $(BENCH_UNIT) $(BENCH_UNIT_SAN) $(BENCH_FUZZ)

$(BENCH_SO): $(BENCH_TARGET_SRC) $(BENCH_HOST_SRC) $(BENCH_HDR)
	@mkdir -p $(dir $@)
	$(BENCH_CC) $(BENCH_WARN) -O2 -fPIC -shared $(BENCH_HOST_DEFS) $(BENCH_INC) $(BENCH_TARGET_SRC) \
	  $(BENCH_HOST_SRC) -lm -o $@

$(BENCH_UNIT): $(BENCH_TARGET_SRC) $(BENCH_HOST_SRC) $(BENCH_TEST_SRC) $(BENCH_HDR)
	@mkdir -p $(dir $@)
	$(BENCH_CC) $(BENCH_WARN) -O2 $(BENCH_HOST_DEFS) $(BENCH_INC) $(BENCH_TARGET_SRC) $(BENCH_HOST_SRC) \
	  $(BENCH_TEST_SRC) -lm -o $@

$(BENCH_UNIT_SAN): $(BENCH_TARGET_SRC) $(BENCH_HOST_SRC) $(BENCH_TEST_SRC) $(BENCH_HDR)
	@mkdir -p $(dir $@)
	$(BENCH_CC) $(BENCH_WARN) -O1 -g $(BENCH_SAN) $(BENCH_HOST_DEFS) $(BENCH_INC) $(BENCH_TARGET_SRC) \
	  $(BENCH_HOST_SRC) $(BENCH_TEST_SRC) -lm -o $@

$(BENCH_FUZZ): firmware/tests/bench/fuzz_proto.c firmware/tests/bench/fuzz_main.c \
  $(BENCH_TARGET_SRC) $(BENCH_HOST_SRC) $(BENCH_HDR)
	@mkdir -p $(dir $@)
	$(BENCH_CC) $(BENCH_WARN) -O1 -g $(BENCH_SAN) $(BENCH_HOST_DEFS) $(BENCH_INC) $(BENCH_TARGET_SRC) \
	  firmware/host/flash_ram.c firmware/host/dev_host.c firmware/tests/bench/fuzz_proto.c \
	  firmware/tests/bench/fuzz_main.c -o $@

$(PERF_PROTO): firmware/perf/perf_proto.c $(BENCH_TARGET_SRC) $(BENCH_HDR)
	@mkdir -p $(dir $@)
	$(BENCH_CC) $(BENCH_WARN) -O2 -g $(BENCH_INC) firmware/perf/perf_proto.c $(BENCH_TARGET_SRC) \
	  -o $@

bench-lint: proto-check
	@mkdir -p $(BENCH_M4)/lint
	@set -e; for f in $(BENCH_OWN_SRC) $(BENCH_HOST_SRC) $(BENCH_TEST_SRC) \
	  firmware/tests/bench/fuzz_proto.c firmware/tests/bench/fuzz_main.c firmware/perf/perf_proto.c; do \
	  $(BENCH_CC) $(BENCH_WARN) $(BENCH_LINT_EXTRA) $(BENCH_HOST_DEFS) $(BENCH_INC) -fsyntax-only $$f; \
	done; \
	for f in $(BENCH_OWN_SRC) firmware/tools/bench_sizes.c; do \
	  $(PY) -m ziglang cc $(FW_M4_FLAGS) $(BENCH_WARN) $(BENCH_LINT_EXTRA) -Ifirmware/include -c $$f \
	    -o $(BENCH_M4)/lint/$$(basename $$f .c).o; \
	done
	@echo "bench-lint: protocol tables up to date; C clean on the host ($(BENCH_CC)) and the Cortex-M4"

$(BENCH_M4)/obj/%.o: firmware/src/%.c $(BENCH_HDR) $(VENV_STAMP)
	@mkdir -p $(dir $@)
	$(PY) -m ziglang cc $(FW_M4_FLAGS) $(BENCH_WARN) $(BENCH_DEFS) -Ifirmware/include -c $< -o $@

$(BENCH_M4)/bench_sizes.o: firmware/tools/bench_sizes.c $(BENCH_HDR) $(VENV_STAMP)
	@mkdir -p $(dir $@)
	$(PY) -m ziglang cc $(FW_M4_FLAGS) $(BENCH_WARN) -Ifirmware/include -c $< -o $@

$(BENCH_M4_LIB): $(BENCH_M4_OBJ)
	@rm -f $@
	$(PY) -m ziglang ar rcs $@ $^

bench-target: $(BENCH_M4_LIB) $(BENCH_M4)/bench_sizes.o
	$(PY) -m firmware.tools.elf_report $(BENCH_M4_LIB) --sizes $(BENCH_M4)/bench_sizes.o \
	  --out $(BENCH_M4)/size.txt

# `make fuzz` (mk/fuzz.mk: the Hypothesis suites with the fuzz profile) runs this one too.
fuzz: fuzz-proto

fuzz-proto: $(BENCH_FUZZ)
	$(BENCH_FUZZ) --frames 20000000 --seed $$(date +%s)

# libFuzzer needs clang (absent on CI machines that have only gcc): say so instead of failing.
fuzz-proto-libfuzzer:
	@if command -v clang >/dev/null 2>&1; then \
	  mkdir -p $(BENCH_HOST) $(BENCH_HOST)/corpus; \
	  clang -std=c11 -g -O1 -fsanitize=fuzzer,address,undefined -DFUZZ_LIBFUZZER $(BENCH_INC) \
	    $(BENCH_TARGET_SRC) firmware/host/flash_ram.c firmware/host/dev_host.c \
	    firmware/tests/bench/fuzz_proto.c -o $(BENCH_LIBFUZZER) && \
	  $(BENCH_LIBFUZZER) -max_total_time=$${FUZZ_SECONDS:-300} $(BENCH_HOST)/corpus; \
	else \
	  echo "fuzz-proto-libfuzzer: clang not found: the libFuzzer harness (firmware/tests/bench/fuzz_proto.c) was NOT run; make fuzz-proto runs the gcc random/mutation fuzzer"; \
	fi

perf-proto: bench-target $(PERF_PROTO) $(BENCH_SO) fmu
	$(PY) -m cosim.perf.rig --cg $(PERF_PROTO) --size $(BENCH_M4)/size.txt
