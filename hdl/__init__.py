"""The RTL's tools as modules, run from the project folder: `python -m hdl.synth.synth`,
`python -m hdl.regmap.gen_regmap`, ... (the tests import them from there too)."""
