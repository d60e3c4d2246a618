"""Procedures at the rig, built on the link: `diff` (a device's configuration against a backup,
a params file or the factory defaults) and `calibrate` (identify the plant, audit it, propose
and verify the compensator's parameters: the part of cosim.bench that imports the audit)."""
