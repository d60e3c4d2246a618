"""The native closed loop (`bowden sim --engine native`): the cocotb harness's loop in C++
(closed_loop.cpp) on the Verilated RTL, the firmware library and the plant FMU, built by
build.py (`make native`) and driven from engine.py."""
