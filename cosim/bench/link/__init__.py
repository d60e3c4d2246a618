"""The link to a controller, and all a script that talks to one needs: the protocol's host side
(`messages`: the generated tables; `protocol`: frames, CAN segments, parameter words; `client`:
serial and CAN links, requests, the session's checks; `discover`: finding controllers), a run
recorded in the trace format (`recorder`), a configuration written as one set or saved as a
backup (`paramset`), parameter files read (`paramfiles`), and the Python API (`api`).

Nothing here imports the simulation (the audit, the engines, numba, fmpy): tests/test_layers.py
imports this package in a fresh interpreter and checks. `Bench(emulate=True)` starts the emulator
(cosim.bench.emulate), which it imports when it is called, not before.
"""
