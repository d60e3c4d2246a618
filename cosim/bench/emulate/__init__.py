"""The controller emulated on this machine, for `bowden emulate` and `bench --emulate`:
`host_device` (the firmware's host build with the protocol's device side, and `LoopChain`, the
FPGA loop's model and the plant FMU it drives; `native/emu.c` is that loop in C, built by
mk/bench.mk), `emulator` (behind a pty, a TCP port or a CAN bus in real time, or stepped in this
process) and `soc/` (the whole board simulated: `bowden emulate --target soc`). It ranks above
the engines: the simulated board is built with the native engine's Verilator build."""
