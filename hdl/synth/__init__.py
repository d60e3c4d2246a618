"""Synthesis of the board tops (`python -m hdl.synth.synth`)."""
