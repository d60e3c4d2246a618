# --- native: the closed loop compiled (cosim/native, `bowden sim --engine native`) ------------
#
#   make native   build/native/libbowden_native.so: the Verilated cosim_top (verilator --cc) and
#                 the C++ loop of cosim/native/closed_loop.cpp, linked with the firmware's
#                 libbowden_fw.so (python -m cosim.native build; reused while nothing changed)
#   (make bench-cosim prints its speed beside the cocotb harness's)

NATIVE_LIB := $(BUILD)/native/libbowden_native.so
NATIVE_SRC := $(sort $(wildcard hdl/rtl/*.v)) cosim/harness/cosim_top.v \
  $(wildcard cosim/native/*.cpp cosim/native/*.h) cosim/native/build.py

.PHONY: native
BUILD_TARGETS += native

native: $(NATIVE_LIB)

$(NATIVE_LIB): $(VENV_STAMP) $(FW_SO) $(NATIVE_SRC)
	$(PY) -m cosim.native build
