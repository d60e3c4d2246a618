"""`bowden sweep --scheduler` on a cluster started apart, as a user's is: a `dask scheduler` and
`dask worker` processes of their own, each working in a folder of its own, and the sweep run from
a third folder with a relative --out. Every result comes back to the client through Dask and is
written there (the workers' folders stay empty); a worker killed mid-sweep costs no point; a
scheduler killed mid-sweep ends the sweep with one line and a non-zero status, keeping the points
that came back and recording none of the others as failed."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from cosim.engines.native import engine
from cosim.studies.sweep import run as sweep_run
from cosim.studies.sweep.spec import load_spec
from cosim.studies.sweep.table import read_table

BOWDEN = os.path.join(os.path.dirname(sys.executable), "bowden")
START_TIMEOUT_S = 180  # a process importing numpy and distributed on 2 loaded cores


class Apart:
    """The processes one test starts, each in a session of its own with its log outside every
    working folder; stop() ends each of them and whatever it started, whatever the test did."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.logs = root / "logs"
        self.logs.mkdir()
        self.procs: list[subprocess.Popen] = []
        self.names: dict[str, subprocess.Popen] = {}  # the workers started and not stopped

    def folder(self, name: str) -> Path:
        path = self.root / name
        path.mkdir()
        return path

    def start(self, name: str, cmd: list[str], cwd: Path, **kwargs) -> subprocess.Popen:
        log = (self.logs / f"{name}.log").open("w")
        proc = subprocess.Popen(
            cmd, cwd=cwd, stdout=log, stderr=subprocess.STDOUT, start_new_session=True, **kwargs
        )
        log.close()
        self.procs.append(proc)
        return proc

    def log(self, name: str) -> str:
        return (self.logs / f"{name}.log").read_text()

    def scheduler(self) -> str:
        """Start a scheduler on a free local port; return its address once it serves."""
        file = self.root / "scheduler.json"
        proc = self.start(
            "scheduler",
            [
                sys.executable,
                "-m",
                "distributed.cli.dask_scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--dashboard-address",
                "127.0.0.1:0",
                "--scheduler-file",
                str(file),
            ],
            self.folder("scheduler_cwd"),
        )
        deadline = time.monotonic() + START_TIMEOUT_S
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                return json.loads(file.read_text())["address"]
            except (OSError, ValueError, KeyError):
                time.sleep(0.1)
        pytest.fail(f"the scheduler did not start:\n{self.log('scheduler')}")

    def workers(
        self, address: str, n: int, first: int = 0, preload: Path | None = None
    ) -> list[Path]:
        """Start n single-threaded workers (each with its nanny), named worker<first>... and
        each working in its own folder and keeping its scratch space outside it, each running
        `preload` (Dask's --preload) when given; return once the scheduler has exactly the
        workers started and not stopped."""
        folders = []
        for i in range(first, first + n):
            folders.append(self.folder(f"worker{i}_cwd"))
            self.start(
                f"worker{i}",
                [
                    sys.executable,
                    "-m",
                    "distributed.cli.dask_worker",
                    address,
                    "--nthreads",
                    "1",
                    "--no-dashboard",
                    "--name",
                    f"worker{i}",
                    "--local-directory",
                    str(self.root / f"worker{i}_scratch"),
                    *(["--preload", str(preload)] if preload is not None else []),
                ],
                folders[-1],
            )
            self.names[f"worker{i}"] = self.procs[-1]
        self.wait_for_workers(address)
        return folders

    def stop_worker(self, address: str, name: str) -> None:
        """SIGKILL a worker and its nanny; return once the scheduler has let it go."""
        proc = self.names.pop(name)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        self.wait_for_workers(address)

    def wait_for_workers(self, address: str) -> None:
        from distributed import Client  # noqa: PLC0415

        deadline = time.monotonic() + START_TIMEOUT_S
        with Client(address, timeout=f"{START_TIMEOUT_S}s") as client:
            while time.monotonic() < deadline:
                info = client.scheduler_info()["workers"].values()
                if sorted(w["name"] for w in info) == sorted(self.names):
                    return
                time.sleep(0.1)
        pytest.fail(f"the scheduler's workers are not {sorted(self.names)}")

    def sweep(self, cwd: Path, address: str, name: str = "sweep") -> subprocess.Popen:
        """`bowden sweep s.yaml --out out --scheduler ADDRESS` run in `cwd` (relative paths)."""
        return self.start(
            name, [BOWDEN, "sweep", "s.yaml", "--out", "out", "--scheduler", address], cwd
        )

    def stop(self) -> None:
        victims = []
        for proc in self.procs:
            try:
                victims += [psutil.Process(proc.pid), *psutil.Process(proc.pid).children(True)]
            except psutil.NoSuchProcess:
                pass
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
        for victim in victims:  # any that left its process group
            try:
                victim.kill()
            except psutil.NoSuchProcess:
                pass
        for proc in self.procs:
            proc.wait()
        _, alive = psutil.wait_procs(victims, timeout=10)
        assert not alive, f"processes of the test still run: {alive}"


@pytest.fixture
def apart(tmp_path):
    engine.load_library()  # built before the sweep hashes it into the points' ids
    started = Apart(tmp_path)
    try:
        yield started
    finally:
        started.stop()


def _wait_for_points(proc, points: Path, n: int, apart: Apart) -> int:
    """Wait until the sweep has written n points; return how many it has."""
    deadline = time.monotonic() + START_TIMEOUT_S
    while time.monotonic() < deadline and proc.poll() is None:
        have = len(list(points.glob("*.json"))) if points.is_dir() else 0
        if have >= n:
            return have
        time.sleep(0.05)
    pytest.fail(f"the sweep wrote fewer than {n} points in time:\n{apart.log('sweep')}")


def _ids(spec_path: Path) -> set[str]:
    spec = load_spec(spec_path)
    spec.build_id = sweep_run.build_id()
    return {p.point_id for p in spec.points()}


def _files(folder: Path) -> list[Path]:
    return sorted(folder.rglob("*"))


@pytest.mark.slow
def test_every_point_comes_back_to_the_client_from_workers_in_another_folder(apart):
    """The workers run in folders of their own, the sweep in another with `--out out`: the table
    holds every point, the points are in the client's folder, and the workers wrote nothing in
    theirs (before, each worker wrote its points under its own folder and the client's table had
    none, with exit status 0)."""
    client_dir = apart.folder("client_cwd")
    (client_dir / "s.yaml").write_text(
        "scenario: fig14\nduration_s: 0.2\n"
        "axes:\n  compensator: [paper, smooth]\n  loop_routing: [true, false]\n"
    )
    address = apart.scheduler()
    worker_dirs = apart.workers(address, 2)
    proc = apart.sweep(client_dir, address)
    assert proc.wait(timeout=300) == 0, apart.log("sweep")
    said = apart.log("sweep")
    assert "Traceback" not in said, said
    assert "wrote out/sweep.parquet (4 points)" in said, said
    rows = read_table(client_dir / "out" / sweep_run.TABLE)
    assert {r["point_id"] for r in rows} == _ids(client_dir / "s.yaml"), rows
    assert all(r["status"] == "ok" for r in rows), rows
    assert len(list((client_dir / "out" / sweep_run.POINTS_DIR).glob("*.json"))) == 4
    for folder in worker_dirs:
        assert _files(folder) == [], f"a worker wrote into its folder: {_files(folder)}"


# Points of 3 s, a few hundred ms each on the native engine: the sweep is still running when the
# first points are back.
LONG = (
    "scenario: fig14\nduration_s: 3\n"
    "axes:\n  compensator: [paper, smooth]\n  plant.mu: {nominal: 0.075, rel: 0.2, n: 4}\n"
)


@pytest.mark.slow
def test_a_worker_killed_mid_sweep_costs_no_point(apart):
    """SIGKILL to one of two workers (and its nanny) once the first point is back: Dask runs its
    points again on the other, and the table holds every point, each ok."""
    client_dir = apart.folder("client_cwd")
    (client_dir / "s.yaml").write_text(LONG)
    address = apart.scheduler()
    apart.workers(address, 2)
    victim = apart.procs[-1]
    proc = apart.sweep(client_dir, address)
    points = client_dir / "out" / sweep_run.POINTS_DIR
    have = _wait_for_points(proc, points, 1, apart)
    assert have < 8, "the sweep ended before a worker could be killed"
    os.killpg(victim.pid, signal.SIGKILL)
    assert proc.wait(timeout=300) == 0, apart.log("sweep")
    rows = read_table(client_dir / "out" / sweep_run.TABLE)
    assert {r["point_id"] for r in rows} == _ids(client_dir / "s.yaml")
    assert all(r["status"] == "ok" for r in rows), rows


@pytest.mark.slow
def test_a_scheduler_killed_mid_sweep_is_one_line_and_keeps_what_came_back(apart):
    """SIGKILL to the scheduler once the first point is back: the sweep says how many points came
    back and exits 1, writes no table, and records no other point (a resume runs them; before,
    each was written as failed and the sweep exited 0)."""
    client_dir = apart.folder("client_cwd")
    (client_dir / "s.yaml").write_text(LONG)
    address = apart.scheduler()
    apart.workers(address, 1)
    proc = apart.sweep(client_dir, address)
    points = client_dir / "out" / sweep_run.POINTS_DIR
    have = _wait_for_points(proc, points, 1, apart)
    assert have < 8, "the sweep ended before the scheduler could be killed"
    os.killpg(apart.procs[0].pid, signal.SIGKILL)
    assert proc.wait(timeout=120) == 1, apart.log("sweep")
    said = [line for line in apart.log("sweep").splitlines() if not line.startswith("sweep: ")]
    kept = [json.loads(p.read_text())["row"] for p in points.glob("*.json")]
    assert len(said) == 1, said
    assert said[0].startswith("bowden sweep: only ") and f"{address}" in said[0], said
    assert f"only {len(kept)} of the 8 points" in said[0], (said, len(kept))
    assert 1 <= len(kept) < 8 and all(r["status"] == "ok" for r in kept), kept
    assert not (client_dir / "out" / sweep_run.TABLE).exists()


# A worker's preload (Dask's --preload) that makes it a worker of another build, as one started
# from another checkout, or before a rebuild, is: no second checkout to build.
ANOTHER_BUILD = """\
from cosim.studies.sweep import run

run.build_id = lambda *args: "0ther0checkout00"
"""


@pytest.mark.slow
def test_points_from_a_worker_of_another_build_are_not_saved_and_a_worker_of_this_one_runs_them(
    apart,
):
    """A worker whose build differs from the client's (here by its preload) returns every point:
    none is saved, the sweep exits 1 with one line naming the worker's build and the client's,
    and once that worker is replaced by one of this build the same command runs every point
    (before, each was saved as a result of the client's build and the sweep exited 0)."""
    client_dir = apart.folder("client_cwd")
    (client_dir / "s.yaml").write_text(
        "scenario: fig14\nduration_s: 0.2\naxes:\n  compensator: [paper, smooth]\n"
    )
    preload = apart.root / "another_build.py"
    preload.write_text(ANOTHER_BUILD)
    address = apart.scheduler()
    apart.workers(address, 1, preload=preload)
    proc = apart.sweep(client_dir, address)
    assert proc.wait(timeout=300) == 1, apart.log("sweep")
    said = [line for line in apart.log("sweep").splitlines() if not line.startswith("sweep: ")]
    assert len(said) == 1, said
    assert "2 of the 2 points" in said[0] and "0ther0checkout00" in said[0], said
    assert f"this client's build {sweep_run.build_id()}" in said[0], said
    points = client_dir / "out" / sweep_run.POINTS_DIR
    assert not points.is_dir() or list(points.glob("*.json")) == []
    assert not (client_dir / "out" / sweep_run.TABLE).exists()

    apart.stop_worker(address, "worker0")
    apart.workers(address, 1, first=1)
    again = apart.sweep(client_dir, address, "sweep_again")
    assert again.wait(timeout=300) == 0, apart.log("sweep_again")
    assert "2 to run" in apart.log("sweep_again"), apart.log("sweep_again")
    rows = read_table(client_dir / "out" / sweep_run.TABLE)
    assert {r["point_id"] for r in rows} == _ids(client_dir / "s.yaml"), rows
    assert all(r["status"] == "ok" and r["build_id"] == sweep_run.build_id() for r in rows), rows
