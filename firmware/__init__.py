"""The firmware's tools as modules, run from the project folder: `python -m
firmware.proto.gen_proto`, `python -m firmware.tools.elf_report`, ... (the tests import them
from there too)."""
