"""Benchmarks ("perf"; "bench" is the rig): programs that print speed figures, never tests
that fail on a slow machine. closed_loop: the engines per simulated second; fmu: the plant
FMU's step; rig: the bench protocol and emulator; live_view: a run's samples with the live
view on."""
