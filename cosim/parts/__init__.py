"""The built parts as Python sees them: bindings of the built artefacts (firmware: ctypes on
the host build of the C firmware; plant: the FMU) and the twins that define them bit for bit or
in double precision (rtl_model: the FPGA loop's fixed-point model; interface: the board's ADC
and PWM -> ESCON stage; geometry: the sheath's bending angle), and the generated register map
(regmap, from hdl/regmap/bowden_regs.json)."""
