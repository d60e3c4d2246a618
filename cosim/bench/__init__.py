"""The bench tool: the protocol's host side, the emulator of the controller, `bowden bench` and
`bowden emulate` (cosim/bench/README.md; the protocol: firmware/proto/PROTOCOL.md)."""
