"""The sequenced datapath's program (hdl/rtl/tension_loop_seq.v): `python -m hdl.seq.program`
writes its ROM, hdl/rtl/tension_loop_seq_rom.v; `--check` fails when that file is stale."""
