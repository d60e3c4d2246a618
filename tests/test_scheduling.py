"""How `make test` hands its units to the workers (tests/conftest.py): longest first by
tests/durations.json, a unit the file does not name first of all, a formal task a unit of its
own, everything else by file; the order is taken once, as the queue was built."""

import json
from pathlib import Path

import pytest

CONFTEST = Path(__file__).with_name("conftest.py")


@pytest.fixture(name="conftest")
def _conftest(pytestconfig):
    """tests/conftest.py as pytest loaded it (not importable by name: tests/ is no package)."""
    for plugin in pytestconfig.pluginmanager.get_plugins():
        if Path(getattr(plugin, "__file__", "") or "") == CONFTEST:
            return plugin
    raise AssertionError(f"{CONFTEST} is not loaded")


class _Config:
    """The two settings the scheduler reads: the distribution mode and the workers."""

    def __init__(self, dist: str) -> None:
        self.dist = dist

    def getvalue(self, name: str):
        return {"dist": self.dist, "tx": ["2*popen"]}[name]


class _Node:
    """A worker that records the tests it is sent."""

    def __init__(self) -> None:
        self.sent: list[list[int]] = []

    def send_runtest_some(self, indexes: list[int]) -> None:
        self.sent.append(indexes)


def _scheduler(conftest, monkeypatch, seconds: dict[str, float]):
    monkeypatch.setattr(conftest, "DURATIONS_JSON", _Seconds(seconds))
    return conftest.pytest_xdist_make_scheduler(_Config("loadfile"), None)


class _Seconds:
    """Stands in for the durations file."""

    def __init__(self, seconds: dict[str, float]) -> None:
        self.seconds = seconds

    def read_text(self) -> str:
        return json.dumps(self.seconds)


COLLECTION = [
    "tests/a/test_short.py::test_one",
    "tests/a/test_short.py::test_two",
    "tests/b/test_long.py::test_one",
    "tests/hdl/test_hdl_formal.py::test_formal_task[x:prove]",
    "tests/hdl/test_hdl_formal.py::test_formal_task[y:cover]",
    "tests/c/test_new.py::test_one",
]


def _order(conftest, monkeypatch, seconds: dict[str, float]) -> list[list[str]]:
    sched = _scheduler(conftest, monkeypatch, seconds)
    node = _Node()
    sched.add_node(node)
    sched.add_node_collection(node, COLLECTION)
    for nodeid in COLLECTION:
        sched.workqueue.setdefault(sched._split_scope(nodeid), {})[nodeid] = False
    units = []
    while sched.workqueue:
        sched._assign_work_unit(node)
        units.append([COLLECTION[i] for i in node.sent[-1]])
    return units


def test_units_go_longest_first_new_ones_before_all(conftest, monkeypatch):
    seconds = {
        "tests/a/test_short.py": 2.0,
        "tests/b/test_long.py": 90.0,
        "tests/hdl/test_hdl_formal.py::test_formal_task[x:prove]": 30.0,
        "tests/hdl/test_hdl_formal.py::test_formal_task[y:cover]": 120.0,
    }
    units = _order(conftest, monkeypatch, seconds)
    assert units == [
        ["tests/c/test_new.py::test_one"],  # not in the file: may be long, so first
        ["tests/hdl/test_hdl_formal.py::test_formal_task[y:cover]"],
        ["tests/b/test_long.py::test_one"],
        ["tests/hdl/test_hdl_formal.py::test_formal_task[x:prove]"],
        ["tests/a/test_short.py::test_one", "tests/a/test_short.py::test_two"],
    ]


def test_a_file_is_one_unit_a_formal_task_its_own(conftest):
    assert conftest._unit("tests/a/test_short.py::test_two") == "tests/a/test_short.py"
    task = "tests/hdl/test_hdl_formal.py::test_formal_task[y:cover]"
    assert conftest._unit(task) == task
    other = "tests/hdl/test_hdl_formal.py::test_formal_mutant_is_killed"
    assert conftest._unit(other) == "tests/hdl/test_hdl_formal.py"


def test_only_loadfile_gets_this_scheduler(conftest):
    assert conftest.pytest_xdist_make_scheduler(_Config("load"), None) is None
