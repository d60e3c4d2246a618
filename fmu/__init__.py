"""The plant FMU's generators as modules, run from the project folder: `python -m
fmu.gen_model OUTDIR`, `python -m fmu.make_reference`."""
