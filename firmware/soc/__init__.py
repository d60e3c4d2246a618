"""The RV32 firmware's start-up, drivers and linker script; its tools in tools/."""
