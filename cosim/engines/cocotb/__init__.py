"""The closed-loop co-simulation harness: the cocotb testbench that runs the RTL (Verilator or
Icarus) with the firmware (host build, ctypes) and the plant FMU, and its runner.

- `runner.py`: builds the RTL once per simulator and runs the cocotb test in a subprocess; the
  run's configuration goes in as a JSON file, the results come back as an .npz file.
- `tb_closed_loop.py`: the cocotb test module (imported by cocotb inside the simulator).
"""
