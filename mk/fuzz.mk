# --- fuzz: the property-based suites with many more examples (README, "Reliability") ---------
#
#   make fuzz   every Hypothesis test under tests/ (CLI arguments and real runs, params files,
#               trace reader, firmware configuration, FMU parameters, inputs and saved states)
#               with the `fuzz` profile of tests/conftest.py: random, 3000 examples a test
#               (100 real co-simulation runs). `make test` runs the same tests under the
#               bounded, repeatable `ci` profile. Takes about an hour on 2 cores.

.PHONY: fuzz

fuzz: build
	BOWDEN_HYPOTHESIS_PROFILE=fuzz $(PY) -m pytest -m hypothesis --hypothesis-show-statistics \
	  $(PYTEST_ARGS)
