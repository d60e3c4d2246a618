# --- native: the closed loop compiled (cosim/native, `bowden sim --engine native`) ------------
#
#   make native   build/native/libbowden_native.so: the Verilated cosim_top (verilator --cc) and
#                 the C++ loop of cosim/engines/native/closed_loop.cpp, linked with the firmware's
#                 libbowden_fw.so (python -m cosim.engines.native build; reused while nothing changed)
#   (make perf-cosim prints its speed beside the cocotb harness's)

NATIVE_LIB := $(BUILD)/native/libbowden_native.so
NATIVE_SRC := $(sort $(wildcard hdl/rtl/*.v)) cosim/engines/cosim_top.v cosim/engines/cosim_pair_top.v \
  $(wildcard cosim/engines/native/*.cpp cosim/engines/native/*.h) cosim/engines/native/build.py

.PHONY: native
BUILD_TARGETS += native

native: $(NATIVE_LIB)

$(NATIVE_LIB): $(VENV_STAMP) $(FW_SO) $(NATIVE_SRC)
	$(PY) -m cosim.engines.native build
