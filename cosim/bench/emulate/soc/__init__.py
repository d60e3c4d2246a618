"""The full-system co-simulation: bowden_soc executing the firmware image in Verilator, every
pin of the board modelled in C++ (harness.cpp), the UART on a pty (`bowden emulate --target
soc`)."""
