# --- soc: the whole controller on one FPGA (hdl/soc/, firmware/soc/; hdl/README.md "bowden_soc")
#
#   make firmware-soc   build/firmware/soc/: the RV32 firmware (bowden_fw.elf, .bin, the ROM's
#                       .hex and the flash image for the UP5K's boot copier) from the same sources
#                       as the host library plus start-up, linker script and drivers; size.txt with
#                       the image size, the worst-case stack and the soft-float/libm check (fails
#                       on any such symbol, as the Cortex-M4 build does); and the images of
#                       several cables, build/firmware/soc/ch2/ and ch4/ (below)

SOC_FW_OUT := $(BUILD)/firmware/soc
# The memory the RTL gives the firmware (hdl/soc/bowden_soc.v parameters ROM_WORDS, RAM_WORDS).
SOC_ROM_BYTES := 65536
SOC_RAM_BYTES := 16384
# The stack room link.ld keeps free, and the bound rv32_report.py must stay under.
SOC_STACK_BYTES := 4096
SOC_FW_SRC := $(filter-out firmware/src/comp_f64.c firmware/src/fric_est_f64.c,$(sort $(wildcard firmware/src/*.c))) \
  $(addprefix firmware/soc/,main.c spi_flash.c libc.c)
SOC_FW_ASM := firmware/soc/start.S
SOC_FW_HDR := $(sort $(wildcard firmware/include/*.h firmware/soc/*.h))
# RV32I with Zmmul (multiply, no divide: picorv32 with ENABLE_FAST_MUL, without ENABLE_DIV and
# COMPRESSED_ISA, which the UP5K has no room for; hdl/soc/bowden_soc.v). Division goes through
# firmware/soc/libc.c. No library is linked: a soft-float helper or a libm function would be an
# undefined symbol. Frames' CRCs run in the SoC's CRC unit (firmware/soc/soc.h, SOC_CRC_STATE).
# No frame pointer: it cost a register and two instructions in every call (the tick 11 % slower,
# the image 6 % larger; tests/soc/tb_soc_tick.py's figures); the stack bound needs none.
# HAL_MMIO_ONLY: every cable's registers are memory-mapped, read and written inline (hal.h).
SOC_FW_FLAGS := -target riscv32-freestanding-none -mcpu=generic_rv32+zmmul -ffreestanding -fno-builtin \
  -DCRC32C_UNIT_ADDR=0x30000040UL -DHAL_MMIO_ONLY -O2 -fomit-frame-pointer -ffunction-sections \
  -fdata-sections -fno-unwind-tables -fno-asynchronous-unwind-tables
SOC_FW_OBJ := $(patsubst %.c,$(SOC_FW_OUT)/obj/%.o,$(notdir $(SOC_FW_SRC))) \
  $(SOC_FW_OUT)/obj/start.o
SOC_FW_ELF := $(SOC_FW_OUT)/bowden_fw.elf
SOC_FW_BIN := $(SOC_FW_OUT)/bowden_fw.bin
SOC_FW_HEX := $(SOC_FW_OUT)/bowden_fw.hex
SOC_FW_FLASH := $(SOC_FW_OUT)/bowden_fw_flash.bin
SOC_FW_LIB := $(SOC_FW_OUT)/libbowden_fw_soc.a
SOC_FW_SIZE := $(SOC_FW_OUT)/size.txt
# The UP5K's boot loader (firmware/soc/boot.S): the block RAM at SOC_BOOT_BASE that the bitstream
# initialises (bowden_soc.v BOOT_INIT, BOOT_WORDS words).
SOC_BOOT_BASE := 0x40000000
SOC_BOOT_BYTES := 256
SOC_BOOT_HEX := $(SOC_FW_OUT)/boot.hex

.PHONY: firmware-soc
BUILD_TARGETS += firmware-soc

firmware-soc: $(SOC_FW_SIZE) $(SOC_FW_HEX) $(SOC_BOOT_HEX)

# The SoC's emulator (`bowden emulate --target soc`: the Verilated SoC with the image in its ROM,
# build/soc_sim), built with the other artefacts as the native engine is, so neither a user's
# first emulation nor the tests that talk to it wait on its C++ build; build.py keeps it while
# its inputs' fingerprint holds (0.4 s then).
.PHONY: soc-emu
BUILD_TARGETS += soc-emu
soc-emu: firmware-soc
	$(PY) -m cosim.bench.emulate.soc build

vpath %.c firmware/src firmware/soc
$(SOC_FW_OUT)/obj/%.o: %.c $(SOC_FW_HDR) $(VENV_STAMP) mk/soc.mk
	@mkdir -p $(dir $@)
	$(FW_ZIG_CC) $(SOC_FW_FLAGS) $(FW_WARN) $(FW_LINT_EXTRA) $(BENCH_DEFS) -Ifirmware/include -Ifirmware/soc -c $< -o $@

$(SOC_FW_OUT)/obj/start.o: $(SOC_FW_ASM) $(VENV_STAMP) mk/soc.mk
	@mkdir -p $(dir $@)
	$(FW_ZIG_CC) $(SOC_FW_FLAGS) -c $< -o $@

# The objects as an archive first: elf_report.py's check of undefined references names the
# object that asks for a soft-float helper or libm, before the link would fail on it.
$(SOC_FW_LIB): $(SOC_FW_OBJ)
	@rm -f $@
	$(FW_ZIG_AR) rcs $@ $^
	$(PY) -m firmware.tools.elf_report $@ --out $(SOC_FW_OUT)/objects.txt > /dev/null

$(SOC_FW_ELF): $(SOC_FW_LIB) firmware/soc/link.ld
	$(PY) -m ziglang ld.lld -T firmware/soc/link.ld --gc-sections --emit-relocs \
	  --defsym=__rom_bytes=$(SOC_ROM_BYTES) --defsym=__ram_bytes=$(SOC_RAM_BYTES) \
	  --defsym=__stack_min=$(SOC_STACK_BYTES) $(SOC_FW_OBJ) -o $@

$(SOC_FW_BIN): $(SOC_FW_ELF)
	$(PY) -m ziglang objcopy -O binary $< $@

$(SOC_FW_HEX): $(SOC_FW_BIN) firmware/soc/tools/mkimage.py
	$(PY) -m firmware.soc.tools.mkimage $< --rom-bytes $(SOC_ROM_BYTES) --hex $@ --flash $(SOC_FW_FLASH) \
	  --flash-hex $(SOC_FW_OUT)/bowden_fw_flash.hex

$(SOC_FW_OUT)/boot.elf: firmware/soc/boot.S $(VENV_STAMP) mk/soc.mk
	@mkdir -p $(SOC_FW_OUT)/obj
	$(FW_ZIG_CC) $(SOC_FW_FLAGS) -c $< -o $(SOC_FW_OUT)/obj/boot.o
	$(PY) -m ziglang ld.lld -e _boot -Ttext=$(SOC_BOOT_BASE) $(SOC_FW_OUT)/obj/boot.o -o $@

$(SOC_BOOT_HEX): $(SOC_FW_OUT)/boot.elf firmware/soc/tools/mkimage.py
	$(PY) -m ziglang objcopy -O binary $< $(SOC_FW_OUT)/boot.bin
	$(PY) -m firmware.soc.tools.mkimage $(SOC_FW_OUT)/boot.bin --rom-bytes $(SOC_BOOT_BYTES) --hex $@

$(SOC_FW_SIZE): $(SOC_FW_ELF) firmware/soc/tools/rv32_report.py
	$(PY) -m firmware.soc.tools.rv32_report $< --stack-max $(SOC_STACK_BYTES) --out $@

# The images of several cables (firmware/soc/main.c runs the SoC's count, SOC_SYS_CHANNELS, up to
# the image's BOWDEN_CHANNELS_MAX): build/firmware/soc/chN/, the same files as the one-cable
# image's, from the same sources with BOWDEN_CHANNELS_MAX N. A cable costs 4.6 KB of RAM (its
# firmware state, settings and stream buffer), so each count has its own image and the
# one-cable image stays as it was; their RAM is the 32 KiB the ECP5's top gives the four-cable
# SoC (RAM_WORDS 8192; the UP5K's SPRAM pair holds 64 KiB), the stack's room a settings table a
# cable larger (flash_load_channels and LOAD copy every cable's). size.txt says what each uses.
SOC_FW_MULTI := 2 4
SOC_FW_MULTI_RAM_BYTES := 32768
SOC_FW_MULTI_STACK_BYTES := 6144
# The four-cable image (the ECP5's) is built with link-time optimization: the calls between the
# firmware's files (the compensator, the sine, the frame packing and encoding: each a prologue
# and an epilogue of register saves at 5 clocks a load or store) are inlined across them, which
# took a tick of four cables from some 9 900 clocks to 8 800 (tests/soc/tb_soc_tick.py). Its
# profile by function (make soc-profile's tool) then names fewer functions; the one- and
# two-cable images (the UP5K's) keep theirs.
SOC_FW_FLAGS_4 := -flto

# soc_fw_image(N): the rules of the N-cable image.
define soc_fw_image
SOC_FW_OUT_$(1) := $(SOC_FW_OUT)/ch$(1)
SOC_FW_OBJ_$(1) := $$(patsubst %.c,$(SOC_FW_OUT)/ch$(1)/obj/%.o,$$(notdir $$(SOC_FW_SRC))) \
  $(SOC_FW_OUT)/obj/start.o
firmware-soc: $(SOC_FW_OUT)/ch$(1)/size.txt $(SOC_FW_OUT)/ch$(1)/bowden_fw.hex

$(SOC_FW_OUT)/ch$(1)/obj/%.o: %.c $$(SOC_FW_HDR) $$(VENV_STAMP) mk/soc.mk
	@mkdir -p $$(dir $$@)
	$$(FW_ZIG_CC) $$(SOC_FW_FLAGS) $$(SOC_FW_FLAGS_$(1)) -DBOWDEN_CHANNELS_MAX=$(1)U $$(FW_WARN) $$(FW_LINT_EXTRA) $$(BENCH_DEFS) \
	  -Ifirmware/include -Ifirmware/soc -c $$< -o $$@

$(SOC_FW_OUT)/ch$(1)/bowden_fw.elf: $$(SOC_FW_OBJ_$(1)) firmware/soc/link.ld
	$$(PY) -m ziglang ld.lld -T firmware/soc/link.ld --gc-sections --emit-relocs \
	  --defsym=__rom_bytes=$$(SOC_ROM_BYTES) --defsym=__ram_bytes=$$(SOC_FW_MULTI_RAM_BYTES) \
	  --defsym=__stack_min=$$(SOC_FW_MULTI_STACK_BYTES) $$(SOC_FW_OBJ_$(1)) -o $$@

$(SOC_FW_OUT)/ch$(1)/bowden_fw.bin: $(SOC_FW_OUT)/ch$(1)/bowden_fw.elf
	$$(PY) -m ziglang objcopy -O binary $$< $$@

$(SOC_FW_OUT)/ch$(1)/bowden_fw.hex: $(SOC_FW_OUT)/ch$(1)/bowden_fw.bin firmware/soc/tools/mkimage.py
	$$(PY) -m firmware.soc.tools.mkimage $$< --rom-bytes $$(SOC_ROM_BYTES) --hex $$@ \
	  --flash $(SOC_FW_OUT)/ch$(1)/bowden_fw_flash.bin --flash-hex $(SOC_FW_OUT)/ch$(1)/bowden_fw_flash.hex

$(SOC_FW_OUT)/ch$(1)/size.txt: $(SOC_FW_OUT)/ch$(1)/bowden_fw.elf firmware/soc/tools/rv32_report.py
	$$(PY) -m firmware.soc.tools.rv32_report $$< --stack-max $$(SOC_FW_MULTI_STACK_BYTES) --out $$@
endef
$(foreach n,$(SOC_FW_MULTI),$(eval $(call soc_fw_image,$(n))))

# --- RTL: lint (part of make lint) -------------------------------------------------------------
#
#   make lint-soc   verilator --lint-only -Wall on every module of hdl/soc/ as its own top, with
#                   picorv32 from its package (its own findings waived in hdl/soc/bowden_soc.vlt)

SOC_RTL := $(sort $(wildcard hdl/soc/*.v))
SOC_TOPS := $(sort $(wildcard hdl/soc/boards/*_top.v))
SOC_STUBS := $(sort $(wildcard hdl/soc/boards/stubs/*.v))
SOC_PICORV32 = $(shell $(PY) -c "import pythondata_cpu_picorv32 as p; print(p.data_location)")/picorv32.v
LINT_TARGETS += lint-soc

.PHONY: lint-soc
lint-soc: $(VENV_STAMP)
	@set -e; for f in $(SOC_RTL); do \
	  m=$$(basename $$f .v); \
	  verilator --lint-only --quiet -Wall -Ihdl/rtl --top-module $$m hdl/soc/bowden_soc.vlt \
	    $(SOC_PICORV32) $(HDL_RTL) $(SOC_RTL) $(SOC_STUBS); \
	done; \
	for f in $(SOC_TOPS); do \
	  m=$$(basename $$f .v); \
	  verilator --lint-only --quiet -Wall -Ihdl/rtl --top-module $$m hdl/soc/bowden_soc.vlt \
	    $(SOC_PICORV32) $(HDL_RTL) $(SOC_RTL) $(SOC_STUBS) $$f; \
	done
	@echo "lint-soc: $(words $(SOC_RTL)) SoC modules and $(words $(SOC_TOPS)) board tops clean"

# --- bitstreams ----------------------------------------------------------------------------------
#
#   make bitstream  build/bitstream/ice40-up5k/bowden.bin, two cables (+ bowden_fw_flash.bin, the
#                   image the UP5K boots from its flash) and build/bitstream/ecp5-25f/bowden.bit,
#                   four cables (the image in it), summary.json each (LUTs, logic cells, FFs, DSPs,
#                   RAMs, Fmax, the clock it runs at and Fmax's margin above it); fails when a
#                   board does not fit or misses its target (the UP5K's 26.4 MHz: 10 % above its
#                   24 MHz); cached by input hash. Part of make perf: both boards take 4 to 18
#                   minutes from nothing (most of it the routers), beyond make test's budget

PERF_TARGETS += bitstream
.PHONY: bitstream
bitstream: firmware-soc
	$(PY) -m hdl.soc.bitstream --all

#   make soc-cpus   the soft-CPU candidates (picorv32 configurations, VexRiscv, SERV), each
#                   synthesized alone for the UP5K: LUT4, carry, FFs, DSPs, block RAMs
#                   (build/soc/cpu/summary.json; hdl/README.md "The CPU, measured")

.PHONY: soc-cpus
soc-cpus: $(VENV_STAMP)
	$(PY) -m hdl.soc.cpu_candidates

# --- benchmark (part of make perf) -------------------------------------------------------------
#
#   make perf-soc-tick  the SoC's boot and the firmware's cycles per tick (worst, median) against the
#                   tick's budget, from the Verilator simulation, and its speed (simulated ns per
#                   wall second, cocotb's summary)
#   make perf-soc   the full-system co-simulation (`bowden emulate --target soc`, the plant FMU in
#                   the loop): simulated seconds per wall second (target >= 0.2x), the tick's
#                   cycles (worst, median) over a recorded run, the longest request handling

#   make soc-profile  where the firmware's clocks go: the program counter sampled at every clock
#                   of 24 ticks and of the received bytes' handling during a run (HELLOs
#                   arriving), by function of the image, median and worst span
#                   (firmware/soc/tools/rv32_profile.py)
#   make soc-gate   the gate-level runs of the UP5K's synthesized netlist (tests/soc/
#                   test_soc_gate.py: boot from the flash and HELLO, 100 ms of both cables); the
#                   netlist's C++ build (some 5 min cold) is beyond make test's budget

PERF_TARGETS += perf-soc-tick perf-soc soc-profile soc-gate
.PHONY: perf-soc-tick perf-soc soc-profile soc-gate
perf-soc-tick: firmware-soc
	@mkdir -p build/soc
	@$(PY) -m pytest tests/soc/test_soc_boot.py -q -n 0 -s -p no:cacheprovider \
	  > build/soc/perf-soc-tick.log 2>&1 || { cat build/soc/perf-soc-tick.log; exit 1; }
	@grep -E "boot:|cycles per tick|full receive buffer|TESTS=" build/soc/perf-soc-tick.log

perf-soc: firmware-soc fmu
	$(PY) -m cosim.perf.soc

soc-profile: firmware-soc
	@mkdir -p build/soc
	@$(PY) -m pytest tests/soc/test_soc_profile.py::test_soc_profile -q -n 0 -s -m long \
	  -p no:cacheprovider > build/soc/profile.log 2>&1 || { cat build/soc/profile.log; exit 1; }
	@sed -n '/^tick:/,/^$$/p' build/soc/profile.log

soc-gate: firmware-soc
	@mkdir -p build/soc
	@$(PY) -m pytest tests/soc/test_soc_gate.py -q -n 0 -s -m long -p no:cacheprovider \
	  > build/soc/gate.log 2>&1 || { cat build/soc/gate.log; exit 1; }
	@grep -E "gate level:|TESTS=" build/soc/gate.log
