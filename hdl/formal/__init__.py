"""The formal proofs' runner (`python -m hdl.formal.formal`)."""
