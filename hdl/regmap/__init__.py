"""The register map's table and its generator (`python -m hdl.regmap.gen_regmap`)."""
