"""The SoC's RTL and its tools: `python -m hdl.soc.bitstream`,
`python -m hdl.soc.cpu_candidates`."""
