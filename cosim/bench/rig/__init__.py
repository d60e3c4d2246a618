"""Procedures at the rig, built on the link: `diff` (a device's configuration against a backup,
a params file or the factory defaults) and `calibrate` (identify the plant, audit it, propose
and verify the compensator's parameters: the part of cosim.bench that imports the audit)."""

# The compensator parameters `calibrate` proposes, in the order it reports them (calibrate.propose:
# one Change each): the help, the study of calibrate on random plants and the tests name them
# from here.
CALIBRATED_PARAMS = (
    "comp.mu",
    "comp.offset_n",
    "comp.mu_slope_per_n",
    "comp.dead_zone_spread",
    "comp.breakaway",
    "comp.slack_tension_n",
    "comp.mu_per_inlet_rate",
)
