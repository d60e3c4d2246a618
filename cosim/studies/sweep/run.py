"""Run a sweep on Dask: one native closed-loop run per point (cosim/native), one result file per
point, one table at the end.

A worker only runs a point and returns its row through Dask; the client writes it. So a worker
needs the project (installed and built) but never the sweep's output folder: on a cluster whose
workers run in another folder or on another machine, every result still ends in the client's
--out.

Resumable by construction: the client writes each point's row as its result arrives, to
OUT/points/<point id>.json, atomically (a temporary file renamed into place), so a sweep killed
at any moment keeps every finished point and loses at most the runs in flight. A restart lists
the files, submits only the points that have none, and assembles the table (OUT/sweep.parquet)
from all of them. A point whose run fails is a result too (status "failed" and the error), and
the sweep goes on; it is not retried on resume (the same inputs fail the same way). A point whose
result never comes back (the scheduler lost, the client's connection cut) is no result: nothing
is written for it, and the sweep says how many came back and exits non-zero (SweepIncompleteError).
A row computed by a worker of another build than the client's is no result of this sweep either
(ForeignBuildError), and a run whose every point failed ends in SweepFailedError.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import time
import traceback
from pathlib import Path

from .atomic import write_text
from .spec import Point, SweepSpec

POINTS_DIR = "points"
TABLE = "sweep.parquet"
# Result figures copied from the run's result (cosim.engines.experiment.evaluate) into the table.
FIGURES = ("rms_error_n", "rms_error_pct", "peak_error_n", "peak_error_pct", "max_ref_n")


# What build_id hashes: what a point's result depends on. The package's Python sources but two
# folders: cosim/bench (the bench tool, which talks to a board over a link) and cosim/cli (the
# command lines, which parse arguments and call the studies; `bowden sweep`'s writes the rows as
# they came back). No point runs them, so an edit there cannot change a point's figures, while a
# resume refused for one ("build changed") runs the whole sweep again; they are also what is
# edited most while sweeps run. test_a_point_imports_nothing_the_build_stamp_leaves_out runs a
# point in a fresh interpreter and fails if it imports any module of them. Kept conservative:
# every other folder stays in, also those no point imports today (the audit, perf, the other
# studies), since a stale result taken for a new one costs more than a sweep run again.
STAMP_LEFT_OUT = ("bench", "cli")
# The build's files a point loads (under BUILD_DIR): the native engine (the Verilated RTL and the
# C++ loop), the firmware library it links at run time (a firmware rebuild may relink the native
# library to the same bytes) and the plant FMU.
STAMP_BUILD_FILES = (
    "native/libbowden_native.so",
    "firmware/host/libbowden_fw.so",
    "fmu/BowdenPlant.fmu",
)


def build_id(package_dir: Path | None = None, build_dir: Path | None = None) -> str:
    """The project build a point runs on: a hash of the Python package's sources (but
    STAMP_LEFT_OUT) and of the libraries a point loads (STAMP_BUILD_FILES), so that a rebuild or
    an edit makes earlier results stale. By default the package this module belongs to and the
    project's build folder (cosim.project.paths)."""
    from cosim.project.paths import BUILD_DIR, PACKAGE_DIR  # noqa: PLC0415

    package_dir = PACKAGE_DIR if package_dir is None else package_dir
    build_dir = BUILD_DIR if build_dir is None else build_dir
    left_out = {package_dir / name for name in STAMP_LEFT_OUT}
    files = [
        (f"cosim/{f.relative_to(package_dir).as_posix()}", f)
        for f in sorted(package_dir.rglob("*.py"))
        if not left_out.intersection(f.parents)
    ]
    files += [(f"build/{name}", build_dir / name) for name in STAMP_BUILD_FILES]
    h = hashlib.sha256()
    for name, f in files:
        h.update(name.encode() + b"\0")
        h.update(f.read_bytes() if f.is_file() else b"(absent)")
    return h.hexdigest()[:16]


def run_point(spec_dict: dict, values: dict, run_key: str = "") -> dict:
    """Run one point (in a Dask worker) and return its row; nothing is written here (the
    client writes the row: write_point). run_key: the client's SweepSpec.run_key (the point's
    id covers it)."""
    from .spec import parse_spec  # noqa: PLC0415

    point = Point(values, run_key)
    row = _row_base(point)
    t0 = time.perf_counter()
    try:
        row.update(_run(parse_spec(spec_dict), point))
        row["status"] = "ok"
        row["error"] = ""
    except Exception as exc:  # noqa: BLE001 (a failed point is a result: recorded, not raised)
        row["status"] = "failed"
        msg = str(exc).strip().splitlines()
        row["error"] = f"{type(exc).__name__}: {msg[0] if msg else ''}"[:500]
        row["traceback_tail"] = traceback.format_exc().splitlines()[-1][:500]
    row["wall_s"] = time.perf_counter() - t0
    row["build_id"] = running_build()  # the client saves only the rows of its own build
    return row


_RUNNING_BUILD: str | None = None


def running_build() -> str:
    """The build this process runs: build_id() when it ran its first point, kept for the
    process's life. Its modules and the libraries it loaded then are what it runs, whatever is
    edited or rebuilt on disk later (a Dask worker started before a rebuild)."""
    global _RUNNING_BUILD  # noqa: PLW0603 (one per process, as the loaded library: engine._LIB)
    if _RUNNING_BUILD is None:
        _RUNNING_BUILD = build_id()
    return _RUNNING_BUILD


def _row_base(point: Point) -> dict:
    row: dict = {"point_id": point.point_id}
    for name, value in point.values.items():
        if name == "position_m":
            row["x_m"], row["y_m"], row["z_m"] = (float(v) for v in value)
        else:
            row[name] = value
    return row


def run_record(spec: SweepSpec, point: Point) -> tuple[dict, dict, dict]:
    """One point's closed-loop run as the sweep runs it: its run_spec, its record (the native
    engine's series: t_s, T_ref_N, T_out_true_N, current_A, ...) and its cost."""
    from cosim.config.run import SimConfig  # noqa: PLC0415
    from cosim.config.scenarios import get_scenario  # noqa: PLC0415
    from cosim.engines.native import engine  # noqa: PLC0415
    from cosim.engines.reference import resolve_phi  # noqa: PLC0415

    run_spec = spec.run_spec(point)
    cfg = SimConfig.from_dict(run_spec["config"], source="point")
    # The compensator is calibrated once at the scenario's own start position (as the paper's
    # is), not at the point's position: the map shows what a fixed calibration leaves.
    run_spec["phi_rad"] = resolve_phi(get_scenario(spec.scenario), cfg, run_spec["loop_routing"])
    run_spec["config"] = cfg.to_dict()
    if run_spec["duration_s"] is None:
        run_spec["duration_s"] = get_scenario(spec.scenario).duration_s
    run_spec["bus"] = "native"
    run_spec["engine"] = "native"
    fixed, cost = engine.run_closed_loop(run_spec, progress=False)
    return run_spec, fixed, cost


def _run(spec: SweepSpec, point: Point) -> dict:
    from cosim.config.run import SimConfig  # noqa: PLC0415
    from cosim.engines import experiment as sim  # noqa: PLC0415
    from cosim.engines.native import engine  # noqa: PLC0415

    run_spec, fixed, cost = run_record(spec, point)
    cfg = SimConfig.from_dict(run_spec["config"], source="point")
    scen = engine.scenario_of(run_spec)
    result = sim.evaluate(scen, cfg, run_spec, fixed, None, cost["total_s"], cost)
    out = {k: result[k] for k in FIGURES}
    split = result["error_split"] or {}
    out["rms_near_reversal_n"] = split.get("rms_near_reversal_n")
    out["rms_away_n"] = split.get("rms_away_n")
    out["compensator_phi_rad"] = run_spec["phi_rad"]
    out["samples"] = result["samples"]
    # The same figures on the cable's true output tension (the plant's T_out, not the far-end
    # cell's reading): they differ from the above by what the cell adds (offset, gain, lag), which
    # a controller that trusts the cell cannot remove and a tare of it can.
    if "T_out_true_N" in fixed:
        from cosim.results import metrics  # noqa: PLC0415

        true = metrics.tracking_error(
            fixed["t_s"], fixed["T_ref_N"], fixed["T_out_true_N"], result["settle_s"]
        )
        out["rms_true_error_pct"] = true["rms_error_pct"]
        out["peak_true_error_pct"] = true["peak_error_pct"]
    return out


RUN_FILE = "run.json"  # the run context (SweepSpec.run_context) of the points in a folder


class SweepIncompleteError(RuntimeError):
    """Fewer results came back from Dask than points were run (one line: how many, and why)."""


class SweepFailedError(RuntimeError):
    """Every point run failed (one line: how many, the first error, how to run them again)."""


class ForeignBuildError(SweepIncompleteError):
    """Rows came back from workers of another build than the client's: not saved (one line:
    how many, which builds on which workers, and the client's)."""


class OutDirError(ValueError):
    """--out cannot hold a sweep (a file, or a folder that cannot be made): a usage error."""


class OutDirMismatchError(OutDirError):
    """--out holds the points of another spec, engine or build."""


def check_out_dir(spec: SweepSpec, out_dir: Path) -> None:
    """Refuse an --out folder whose points were computed for another run context (spec's
    scenario, duration, interface or configuration, engine, build), naming what changed."""
    path = out_dir / RUN_FILE
    if not path.is_file():
        if (out_dir / POINTS_DIR).is_dir() and any((out_dir / POINTS_DIR).glob("*.json")):
            raise OutDirMismatchError(
                f"--out {out_dir}: holds points of a sweep without {RUN_FILE} (an older "
                "version): use another --out folder"
            )
        return
    try:
        old = json.loads(path.read_text())
    except (OSError, ValueError):
        old = None
    if not isinstance(old, dict):
        raise OutDirMismatchError(f"--out {out_dir}: {RUN_FILE} is unreadable: use another --out")
    new = json.loads(json.dumps(spec.run_context()))  # as written (tuples -> lists)
    changed = sorted(_changed(old, new))
    if changed:
        raise OutDirMismatchError(
            f"--out {out_dir} holds a sweep of another run: {', '.join(changed)} changed "
            "(use another --out folder, or remove that one)"
        )


def make_out_dir(out_dir: Path) -> None:
    """Make --out (and its parents) unless it is there; OutDirError, naming it, when it is a
    file or cannot be made."""
    if out_dir.exists() and not out_dir.is_dir():
        raise OutDirError(f"--out {out_dir}: is a file, not a folder")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutDirError(
            f"--out {out_dir}: cannot make this folder ({exc.strerror or type(exc).__name__})"
        ) from None


def _changed(old, new, prefix: str = "") -> list[str]:
    """The dotted keys whose values differ (a mapping missing on one side counts as empty)."""
    if isinstance(old, dict) or isinstance(new, dict):
        old = old if isinstance(old, dict) else {} if old is None else {"": old}
        new = new if isinstance(new, dict) else {} if new is None else {"": new}
        out = []
        for k in sorted(set(old) | set(new)):
            out += _changed(old.get(k), new.get(k), f"{prefix}{k}.")
        return out
    return [] if old == new else [prefix.rstrip(".") or "spec"]


def _write_json(path: Path, data) -> None:
    write_text(path, json.dumps(data, indent=2, sort_keys=True) + "\n")


def write_point(out_dir: Path, point: Point, row: dict) -> Path:
    """Write a point's row atomically (temporary file, then rename)."""
    d = out_dir / POINTS_DIR
    d.mkdir(parents=True, exist_ok=True)
    path = d / f"{point.point_id}.json"
    write_text(path, json.dumps({"values": point.values, "row": _finite(row)}, sort_keys=True))
    return path


def _finite(row: dict) -> dict:
    """NaN and infinities as null (strict JSON)."""
    return {
        k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in row.items()
    }


def failed_row(point: Point, exc: BaseException) -> dict:
    """The row of a point whose task itself failed (a worker lost, an error outside the run)."""
    row = _row_base(point)
    msg = str(exc).strip().splitlines()
    row.update(status="failed", error=f"{type(exc).__name__}: {msg[0] if msg else ''}"[:500])
    return row


def done_points(out_dir: Path) -> dict[str, dict]:
    """point id -> row of every point with a result file."""
    d = out_dir / POINTS_DIR
    rows = {}
    if d.is_dir():
        for path in sorted(d.glob("*.json")):
            try:
                data = json.loads(path.read_text())
            except (OSError, ValueError):
                continue  # never half-written (atomic), but a foreign file is skipped
            rows[path.stem] = data["row"]
    return rows


def run_sweep(
    spec: SweepSpec,
    spec_dict: dict,
    out_dir: Path,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = True,
    log=print,
    retry_failed: bool = False,
) -> list[dict]:
    """Run every point without a result file on Dask (and, with retry_failed, those recorded as
    failed); return every point's row (spec order). SweepFailedError when every point run failed
    (_check_not_all_failed), SweepIncompleteError when points have no result."""
    from cosim.engines.native import engine  # noqa: PLC0415

    engine.load_library()  # built before its hash goes into the points' ids
    spec.build_id = build_id()
    check_out_dir(spec, out_dir)  # before anything is written there
    make_out_dir(out_dir)
    _write_json(out_dir / "spec.json", spec_dict)
    _write_json(out_dir / RUN_FILE, spec.run_context())
    points = spec.points()
    have = done_points(out_dir)
    if retry_failed:
        have = {k: v for k, v in have.items() if v.get("status") == "ok"}
    todo = [p for p in points if p.point_id not in have]
    log(f"sweep: {len(points)} points, {len(points) - len(todo)} already done, {len(todo)} to run")
    if todo:
        _dask_run(todo, spec_dict, out_dir, scheduler, workers, progress, log, spec.build_id)
    have = done_points(out_dir)
    missing = sum(p.point_id not in have for p in points)
    if missing:  # a table without them would look whole
        raise SweepIncompleteError(
            f"{missing} of the {len(points)} points have no result in {out_dir / POINTS_DIR} "
            "after the run: the same command again runs them"
        )
    rows = [have[p.point_id] for p in points]
    _check_not_all_failed(rows, {p.point_id for p in todo}, out_dir)
    return rows


def _check_not_all_failed(rows: list[dict], ran: set[str], out_dir: Path) -> None:
    """SweepFailedError when every point this run ran failed (what a worker's broken setup does
    to each), or, with nothing to run, when every point of the sweep is recorded as failed: the
    points stay saved as failed, and no table of failures stands for a sweep."""
    these = [r for r in rows if r["point_id"] in ran] if ran else rows
    if not these or any(r.get("status") == "ok" for r in these):
        return
    what = "points run failed" if ran else "points of this sweep are recorded as failed"
    raise SweepFailedError(
        f"all {len(these)} {what} (the first: {these[0].get('error') or 'no error recorded'}); "
        f"each is saved as failed in {out_dir / POINTS_DIR}: fix what made them fail (a "
        "worker's setup, the spec), then run the same command with --retry-failed"
    )


def _holders(client, futures) -> dict:
    """Task key -> the addresses of the workers holding its result, for a message: asked of the
    scheduler within 5 s (not the 180 s of DASK_TIMEOUTS), and nothing when it cannot say."""
    try:
        keys = [f.key for f in futures]
        return dict(client.sync(client.scheduler.who_has, keys=keys, callback_timeout=5))
    except Exception:  # noqa: BLE001 (only a message's detail)
        return {}


# Dask's connection timeouts (30 s by default) for a cluster on a loaded machine: starting a
# worker process that imports numpy and distributed took longer than that on 2 cores at load 9.
DASK_TIMEOUTS = {
    "distributed.comm.timeouts.connect": "180s",
    "distributed.comm.timeouts.tcp": "180s",
}


def _dask_run(todo, spec_dict, out_dir, scheduler, workers, progress, log, build) -> None:
    import dask  # noqa: PLC0415
    from distributed.utils import silence_logging_cmgr  # noqa: PLC0415

    # Only critical lines from Dask's own loggers, as from the local cluster's (below): what the
    # client logs at ERROR is its connection lost with the scheduler (a traceback per attempt to
    # connect again), which the sweep reports itself in one line (SweepIncompleteError).
    with dask.config.set(DASK_TIMEOUTS), silence_logging_cmgr(logging.CRITICAL):
        _dask_run_in(todo, spec_dict, out_dir, scheduler, workers, progress, log, build)


def _dask_run_in(todo, spec_dict, out_dir, scheduler, workers, progress, log, build) -> None:
    """Run the points of `todo` and save the row of each as it comes back, if it was computed by
    `build` (the client's build_id: the points' ids name it)."""
    from concurrent.futures import CancelledError  # noqa: PLC0415 (distributed's is one)

    from distributed import Client, LocalCluster, as_completed  # noqa: PLC0415

    cluster = None
    if scheduler:
        try:
            # An existing scheduler answers at once; a wrong address fails in seconds.
            client = Client(scheduler, timeout="10s")
        except Exception as exc:  # noqa: BLE001 (whatever Dask's client raises: one line)
            msg = str(exc).strip().splitlines()
            raise RuntimeError(
                f"cannot connect to the Dask scheduler {scheduler} ({msg[0] if msg else exc})"
            ) from None
    else:
        n = workers or os.cpu_count() or 1
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            # The scheduler still serves its HTTP routes, by default on port 8787, and warns
            # when a second sweep finds that port taken: any free local port, said nothing.
            scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
            # Nothing but critical: the sweep reports each point's failure itself (a failed
            # row, the progress line) and prints its own progress. What the cluster logs at
            # ERROR is its shutdown after Ctrl-C (a worker's heartbeat to the scheduler just
            # closed, with a traceback), which is no fault of the run and would bury the
            # sweep's one line.
            silence_logs=logging.CRITICAL,
        )
        client = Client(cluster)
    try:
        address = client.scheduler.address
        log(f"sweep: Dask scheduler {address}")
        if scheduler and not client.scheduler_info().get("workers"):
            log("sweep: the scheduler has no workers yet: the points wait for one to join")
        futures = {
            client.submit(
                run_point,
                spec_dict,
                p.values,
                p.run_key,
                key=f"point-{p.point_id}-{time.time_ns()}",
            ): p
            for p in todo
        }
        gathered = failed = 0
        lost = ""  # why the last result that never came back did not
        foreign: dict[str, list] = {}  # another build -> the futures of its rows
        n_foreign = 0
        t0 = time.perf_counter()
        for fut in as_completed(futures):
            point = futures[fut]
            mine = True  # computed by this client's build
            try:
                row = fut.result()
            except CancelledError as exc:  # no result: the scheduler or the connection lost
                lost = getattr(exc, "reason", None) or "cancelled"
                continue
            except Exception as exc:  # noqa: BLE001 (the task itself failed: recorded, go on)
                row = failed_row(point, exc)  # made here: no worker's build in it
            else:
                mine = row.get("build_id") == build
            if mine:
                write_point(out_dir, point, row)  # here, by the client alone, as it arrives
            else:  # another checkout or build: not a result of this run, whatever its status
                other = str(row.get("build_id") or "")  # none: a version before build ids
                foreign.setdefault(other, []).append(fut)
                n_foreign += 1
            gathered += 1
            failed += mine and row["status"] != "ok"
            if progress:
                rate = gathered / max(1e-9, time.perf_counter() - t0)
                other = f", {n_foreign} of another build" if n_foreign else ""
                log(
                    f"sweep: {gathered}/{len(todo)} points ({failed} failed{other}), "
                    f"{rate:.2f} points/s"
                )
        if foreign:
            holders = _holders(client, [f for futs in foreign.values() for f in futs])
            builds = []
            for other, futs in sorted(foreign.items()):
                on = sorted({w for f in futs for w in holders.get(f.key, ())})
                named = f"build {other}" if other else "no build named (an older version)"
                builds.append(named + (f" on {', '.join(on)}" if on else ""))
            builds = "; ".join(builds)
            raise ForeignBuildError(
                f"{n_foreign} of the {len(todo)} points run came back from workers of another "
                f"build ({builds}), not of this client's build {build}: they are not saved (the "
                f"points of this build are, in {out_dir / POINTS_DIR}); start the workers from "
                "this checkout and build, and the same command again runs the rest"
            )
        if gathered < len(todo):
            raise SweepIncompleteError(
                f"only {gathered} of the {len(todo)} points run came back from the Dask "
                f"scheduler {address} (the others: {lost or 'no result'}); the points that came "
                f"back are kept in {out_dir / POINTS_DIR}, and the same command again runs the rest"
            )
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
