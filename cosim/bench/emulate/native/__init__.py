"""C sources of the emulator's closed loop (emu.c, built by mk/bench.mk into
build/bench/host/libbowden_bench.so); a package only so that the wheel carries them."""
