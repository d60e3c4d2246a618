# --- live: the bench tool's API reference (cosim/bench/README.md, "Python API") ---------------
#
#   make bench-docs      build/docs/api: the reference of cosim.bench.api (pdoc), any warning an error

.PHONY: bench-docs

bench-docs: $(VENV_STAMP)
	$(PY) -W error -m pdoc --output-directory $(BUILD)/docs/api cosim.bench.api
	@echo "bench-docs: $(BUILD)/docs/api/cosim/bench/api.html"
