"""The closed loops that run a scenario: what every engine shares (common: the plant handle set
up for a run, the record, the sample timing; fwbridge: the firmware configured from a SimConfig),
the float reference (reference), the RTL co-simulation under cocotb (cocotb/), the compiled loop
(native/), and one run of a scenario through any of them, evaluated and written (experiment)."""
