"""`bowden sweep` never returns stale or silently wrong results: a point's id covers everything
that decides its result and a folder of another run is refused naming what changed; specs that
would be silently misread (duplicate keys, empty axes) or blow up (huge grids, huge integers) are
one line. Hypothesis keeps the spec's refusals one line for any such input."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cosim.config.run import load_params
from cosim.studies.sweep import run as sweep_run
from cosim.studies.sweep.spec import SpecError, load_spec, parse_spec


def _ids(data: dict, build: str = "b1") -> list[str]:
    spec = parse_spec(data)
    spec.build_id = build
    return [p.point_id for p in spec.points()]


BASE = {"scenario": "fig14", "duration_s": 0.05, "axes": {"compensator": ["paper"]}}


@pytest.mark.parametrize(
    "change",
    [
        {"duration_s": 0.06},
        {"scenario": "characterize"},
        {"interface": "ideal"},
        {"config": {"plant": {"mu": 0.09}}},
    ],
)
def test_point_id_covers_spec_scenario_and_build(change):
    assert _ids(BASE) != _ids({**BASE, **change})
    assert _ids(BASE) == _ids(json.loads(json.dumps(BASE)))  # stable
    assert _ids(BASE, "b1") != _ids(BASE, "b2")  # another build


def test_out_of_another_run_is_refused_naming_what_changed(tmp_path):
    out = tmp_path / "out"
    spec = parse_spec(BASE)
    spec.build_id = "b1"
    out.mkdir()
    sweep_run._write_json(out / sweep_run.RUN_FILE, spec.run_context())
    sweep_run.check_out_dir(spec, out)  # the same run: fine
    other = parse_spec({**BASE, "duration_s": 0.06, "config": {"plant": {"mu": 0.09}}})
    other.build_id = "b2"
    with pytest.raises(sweep_run.OutDirMismatchError) as info:
        sweep_run.check_out_dir(other, out)
    msg = str(info.value)
    assert "\n" not in msg and "duration_s" in msg and "config.plant.mu" in msg, msg
    assert "build" in msg


def _tree(root, files: dict) -> None:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def test_the_build_stamp_covers_what_a_point_runs_and_not_the_bench_tool_or_the_cli(tmp_path):
    """build_id changes with the engines, the plant, the config, the sweep (any module of the
    package but two) and each library a point loads, the firmware's included (a firmware rebuild
    can leave the native library's bytes as they were); it does not change with the bench tool or
    the command lines, whose edits by others made a sweep's resume say "build changed". A build
    folder outside the package's parent (BOWDEN_ROOT) is hashed too (it raised ValueError)."""
    package, build = tmp_path / "src" / "cosim", tmp_path / "elsewhere" / "build"
    _tree(
        package,
        {
            "__init__.py": "",
            "engines/native/engine.py": "a = 1\n",
            "studies/sweep/run.py": "b = 1\n",
            "bench/client.py": "c = 1\n",
            "cli/sweep.py": "d = 1\n",
            "cli/bench.py": "e = 1\n",
        },
    )
    _tree(build, {name: "lib 1" for name in sweep_run.STAMP_BUILD_FILES})

    def stamp():
        return sweep_run.build_id(package, build)

    first = stamp()
    assert first == stamp()
    for name in ("bench/client.py", "cli/sweep.py", "cli/bench.py", "bench/new.py"):
        _tree(package, {name: "edited = 2\n"})
        assert stamp() == first, name
    seen = {first}
    for name in ("engines/native/engine.py", "studies/sweep/run.py", "parts/new.py"):
        _tree(package, {name: "edited = 2\n"})
        assert stamp() not in seen, name
        seen.add(stamp())
    assert set(sweep_run.STAMP_BUILD_FILES) >= {
        "native/libbowden_native.so",
        "firmware/host/libbowden_fw.so",
        "fmu/BowdenPlant.fmu",
    }
    for name in sweep_run.STAMP_BUILD_FILES:
        _tree(build, {name: "lib 2"})
        assert stamp() not in seen, name
        seen.add(stamp())
        (build / name).unlink()
        assert stamp() not in seen, f"{name} removed"
        seen.add(stamp())


def test_a_point_imports_nothing_the_build_stamp_leaves_out():
    """What build_id leaves out must be what no point runs: a point run in a fresh interpreter
    (as in a Dask worker) imports no module of those folders."""
    code = (
        "import sys\n"
        "from cosim.studies.sweep.run import run_point\n"
        "from cosim.studies.sweep.spec import parse_spec\n"
        "data = {'scenario': 'fig14', 'duration_s': 0.05, 'axes': {'compensator': ['smooth']}}\n"
        "point = parse_spec(data).points()[0]\n"
        "assert run_point(data, point.values, point.run_key)['status'] == 'ok'\n"
        "print(' '.join(m for m in sys.modules if m.startswith('cosim')))\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    modules = proc.stdout.split()
    assert "cosim.engines.native.engine" in modules, modules
    left_out = tuple(f"cosim.{name}" for name in sweep_run.STAMP_LEFT_OUT)
    assert left_out, "the stamp leaves nothing out: this test checks nothing"
    imported = [
        m for m in modules if m in left_out or m.startswith(tuple(f"{p}." for p in left_out))
    ]
    assert imported == [], f"a point imports modules the build stamp leaves out: {imported}"


def test_a_row_says_which_build_computed_it():
    """run_point (what a worker runs) puts its own build into the row it returns."""
    data = {**BASE, "duration_s": 0.02}
    point = parse_spec(data).points()[0]
    row = sweep_run.run_point(data, point.values, point.run_key)
    assert row["status"] == "ok" and row["build_id"] == sweep_run.build_id(), row


def test_points_computed_by_another_build_are_not_saved_and_the_sweep_fails(tmp_path, monkeypatch):
    """A worker of another checkout or build returns rows under its own build (or none, from a
    version before rows named one): the client keeps the points of its own build and saves none of
    the others (their ids name the client's build), and the sweep fails with one line naming both
    builds (before, every row was saved as a result of the client's build and the sweep exited
    0)."""
    from distributed import LocalCluster  # noqa: PLC0415

    real = sweep_run.run_point

    def of_other_builds(spec_dict, values, run_key=""):
        row = real(spec_dict, values, run_key)
        if values["compensator"] == "smooth":
            row["build_id"] = "0ther0build00000"
        if values["compensator"] == "none":  # a worker of a version before rows named a build
            del row["build_id"]
        return row

    monkeypatch.setattr(sweep_run, "run_point", of_other_builds)
    data = {**BASE, "duration_s": 0.02, "axes": {"compensator": ["paper", "smooth", "none"]}}
    spec = parse_spec(data)
    out = tmp_path / "out"
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        with pytest.raises(sweep_run.SweepIncompleteError) as info:
            sweep_run.run_sweep(
                spec, data, out, scheduler=cluster.scheduler_address, progress=False, log=str
            )
    msg = str(info.value)
    assert "\n" not in msg, msg
    assert "2 of the 3 points" in msg and "0ther0build00000" in msg and spec.build_id in msg, msg
    assert "no build named" in msg and "not saved" in msg, msg
    done = sweep_run.done_points(out)
    by_mode = {p.values["compensator"]: p.point_id for p in spec.points()}
    assert set(done) == {by_mode["paper"]}, done
    assert all(r["status"] == "ok" and r["build_id"] == spec.build_id for r in done.values())
    assert not (out / sweep_run.TABLE).exists()


@pytest.mark.slow
def test_bowden_sweep_into_the_out_of_another_spec_exits_2(tmp_path):
    spec_path, out = tmp_path / "spec.yaml", tmp_path / "out"
    cmd = [sys.executable, "-m", "cosim", "sweep", str(spec_path), "--out", str(out)]
    spec_path.write_text("duration_s: 0.05\naxes:\n  compensator: [paper]\n")
    first = subprocess.run([*cmd, "--workers", "1", "--quiet"], capture_output=True, text=True)
    assert first.returncode == 0, first.stderr
    table = (out / sweep_run.TABLE).read_bytes()
    spec_path.write_text("duration_s: 0.06\naxes:\n  compensator: [paper]\n")
    second = subprocess.run([*cmd, "--workers", "1", "--quiet"], capture_output=True, text=True)
    assert second.returncode == 2, second.stderr
    assert second.stderr.count("\n") == 1 and "duration_s" in second.stderr, second.stderr
    assert (out / sweep_run.TABLE).read_bytes() == table
    assert json.loads((out / "spec.json").read_text())["duration_s"] == 0.05


def _spec_error(tmp_path, text: str, name: str = "spec.yaml") -> str:
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(SpecError) as info:
        load_spec(path)
    msg = str(info.value)
    assert "\n" not in msg, msg
    return msg


def test_huge_position_grid_is_refused_before_it_is_built(tmp_path):
    axis = "[" + ", ".join(str(0.001 * i) for i in range(1000)) + "]"
    # (Built, the grid took 4 GB and 22 s before the limit refused it.)
    msg = _spec_error(tmp_path, f"axes:\n  position_m: {{x: {axis}, y: {axis}, z: {axis}}}\n")
    assert "axes.position_m" in msg and "1000000000 points" in msg, msg


@pytest.mark.parametrize("axis", ["compensator", "scenario", "interface", "loop_routing"])
def test_an_empty_name_axis_is_refused(tmp_path, axis):
    msg = _spec_error(tmp_path, f"axes:\n  {axis}: []\n")
    assert f"axes.{axis}" in msg and "empty" in msg, msg


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("duration_s: 3\nduration_s: 3000\n", "'duration_s'"),
        ('{"config": {"plant": {"mu": 0.09, "mu": 0.5}}}', "'mu'"),
        ("axes:\n  compensator: [paper]\n  compensator: [smooth]\n", "'compensator'"),
    ],
)
def test_duplicate_keys_in_a_spec_are_refused(tmp_path, text, key):
    msg = _spec_error(tmp_path, text)
    assert key in msg and "twice" in msg, msg


def test_duplicate_keys_in_a_params_file_are_refused(tmp_path):
    p = tmp_path / "p.json"
    p.write_text('{"plant": {"mu": 0.09, "mu": 0.5}}')
    with pytest.raises(ValueError, match="'mu' appears twice") as info:
        load_params(p)
    assert "p.json" in str(info.value)


HUGE = "9" * 400


@pytest.mark.parametrize(
    ("text", "key"),
    [
        (f"duration_s: {HUGE}\n", "duration_s"),
        (f"axes:\n  plant.mu: [{HUGE}]\n", "axes.plant.mu"),
        (f"axes:\n  plant.mu: {{min: 0, max: {HUGE}, n: 2}}\n", "axes.plant.mu"),
        (f"config: {{plant: {{mu: {HUGE}}}}}\n", "config"),
        ("duration_s: " + "9" * 5000 + "\n", "spec.yaml"),
    ],
)
def test_huge_integers_in_a_spec_are_one_line_naming_the_key(tmp_path, text, key):
    msg = _spec_error(tmp_path, text)
    assert key in msg and "spec.yaml" in msg, msg


@pytest.mark.parametrize("digits", [400, 5000])
def test_huge_integers_in_a_params_file_are_one_line(tmp_path, digits):
    p = tmp_path / "p.json"
    p.write_text('{"plant": {"mu": ' + "9" * digits + "}}")
    with pytest.raises(ValueError) as info:
        load_params(p)
    msg = str(info.value)
    assert "\n" not in msg and "p.json" in msg and "mu" in msg, msg


_KEYS = st.sampled_from(["scenario", "duration_s", "interface", "axes", "config", "seed"])
_VALUES = st.one_of(
    st.integers(min_value=-(10**500), max_value=10**500),
    st.floats(allow_nan=True, allow_infinity=True),
    st.lists(st.integers(min_value=-(10**400), max_value=10**400), max_size=3),
    st.just([]),
    st.text(max_size=5),
)


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    pairs=st.lists(st.tuples(_KEYS, _VALUES), min_size=1, max_size=4),
    axis=st.sampled_from(["compensator", "loop_routing", "plant.mu", "position_m", "scenario"]),
    axis_value=_VALUES,
)
def test_any_spec_is_accepted_or_refused_in_one_line(tmp_path, pairs, axis, axis_value):
    """Duplicate keys, huge integers, empty axes, non-finite numbers: SpecError with one line,
    never another exception; a spec naming a key twice is never accepted."""
    lines = []
    for key, value in pairs:
        lines.append(f"{key}: {json.dumps(value)}")
    lines.append(f"axes: {{{json.dumps(axis)}: {json.dumps(axis_value)}}}")
    path = tmp_path / "h.yaml"
    path.write_text("\n".join(lines) + "\n")
    keys = [k for k, _ in pairs] + ["axes"]
    try:
        spec = load_spec(path)
    except SpecError as exc:
        assert "\n" not in str(exc) and "h.yaml" in str(exc)
        return
    assert len(keys) == len(set(keys)), "a key given twice was accepted"
    assert axis_value != [], "an empty axis was accepted"
    assert spec.points() is not None


# --- `--scheduler` that is not a Dask scheduler ------------------------------------------------


@pytest.fixture
def fake_scheduler():
    """A local TCP service of a given kind: "garbage" answers every connection with text (Dask's
    client read it as a 3 EiB frame), "silent" accepts and says nothing; "refused" is a port
    nothing listens on; "unknown" a host name that cannot resolve (.invalid, RFC 2606)."""
    import socket
    import threading

    servers = []

    def make(kind: str) -> str:
        if kind == "unknown":
            return "tcp://no-such-host.invalid:8786"
        srv = socket.create_server(("127.0.0.1", 0))
        port = srv.getsockname()[1]
        if kind == "refused":
            srv.close()  # the port is free again: connecting is refused
            return f"tcp://127.0.0.1:{port}"
        servers.append(srv)
        held = []

        def serve() -> None:
            while True:
                try:
                    conn, _ = srv.accept()
                except OSError:
                    return
                held.append(conn)
                if kind == "garbage":
                    conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")

        threading.Thread(target=serve, daemon=True).start()
        return f"tcp://127.0.0.1:{port}"

    yield make
    for srv in servers:
        srv.close()


@pytest.mark.parametrize(
    ("kind", "words"),
    [
        ("garbage", "not as a Dask scheduler"),
        ("silent", "no Dask greeting within 1 s"),
        ("refused", "connection refused"),
        ("unknown", "unknown host 'no-such-host.invalid'"),
    ],
)
def test_a_scheduler_address_that_is_no_scheduler_is_one_line_in_time(
    kind, words, fake_scheduler, tmp_path, capsys, monkeypatch
):
    """`bowden sweep --scheduler` at something that is not a Dask scheduler: one line naming the
    address and what is wrong, exit 2, within the probe's stated timeout (1 s here: each of the
    lookup, the connection and the greeting), and nothing written to --out."""
    import time

    from cosim.cli import main as cli_main
    from cosim.studies.sweep import scheduler

    monkeypatch.setattr(scheduler, "PROBE_TIMEOUT_S", 1.0)
    address = fake_scheduler(kind)
    spec_path = tmp_path / "spec.yaml"
    spec_path.write_text("duration_s: 0.05\n")
    t0 = time.monotonic()
    rc = cli_main(
        ["sweep", str(spec_path), "--out", str(tmp_path / "o"), "--scheduler", address, "--quiet"]
    )
    elapsed_s = time.monotonic() - t0
    err = capsys.readouterr().err
    assert rc == 2, err
    assert err.count("\n") == 1 and address in err and words in err, err
    assert elapsed_s < 3 * 1.0 + 1.0, elapsed_s  # three steps of 1 s, and the spec's loading
    assert not (tmp_path / "o").exists()


def test_the_probe_lets_a_real_scheduler_through():
    """The greeting check accepts what a Dask scheduler sends (its handshake), so the probe
    cannot refuse every address."""
    from distributed import LocalCluster

    from cosim.studies.sweep import scheduler

    with LocalCluster(
        n_workers=0, processes=False, protocol="tcp://", dashboard_address=None
    ) as cluster:
        scheduler.probe(cluster.scheduler_address, timeout_s=10.0)  # raises if refused


@pytest.mark.parametrize(
    ("address", "words"),
    [
        ("http://127.0.0.1:8787", "expected a tcp://, tls://, ws://, wss:// address"),
        ("ucx://127.0.0.1:8786", "expected a tcp://, tls://, ws://, wss:// address"),
        ("tcp://127.0.0.1:8786/status", "expected an address like tcp://HOST:PORT"),
        ("tls://127.0.0.1:8786", "needs Dask's TLS configuration"),
    ],
)
def test_a_scheduler_address_dask_cannot_use_is_one_line_before_anything_is_written(
    address, words, tmp_path, capsys
):
    """Addresses the probe does not read (http://, a Dask scheme that needs extra packages, a
    path after the port, tls:// without Dask's TLS settings) are refused like the others: exit 2,
    one line, nothing written. Before, they went to Dask's client after --out was written: exit 1
    for the first and third, a traceback for ucx:// and tls://."""
    import dask

    from cosim.cli import main as cli_main

    spec_path = tmp_path / "spec.yaml"
    spec_path.write_text("duration_s: 0.05\n")
    no_tls = {f"distributed.comm.tls.{k}": None for k in ("ca-file", "client.cert", "client.key")}
    with dask.config.set(no_tls):
        rc = cli_main(
            ["sweep", str(spec_path), "--out", str(tmp_path / "o"), "--scheduler", address]
        )
    err = capsys.readouterr().err
    assert rc == 2, err
    assert err.count("\n") == 1 and address in err and words in err, err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("out", "words"),
    [("afile", "is a file, not a folder"), ("afile/sub", "cannot make this folder")],
)
def test_an_out_that_is_a_file_is_one_line_and_exit_2(out, words, tmp_path, capsys, monkeypatch):
    """--out naming a file, or a folder under one: a usage error naming --out (it was exit 1
    with Python's '[Errno 17] File exists'), and the file is left as it was."""
    from cosim.cli import main as cli_main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "spec.yaml").write_text("duration_s: 0.05\n")
    (tmp_path / "afile").write_text("kept\n")
    rc = cli_main(["sweep", "spec.yaml", "--out", out, "--quiet"])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert err.count("\n") == 1 and f"--out {out}: {words}" in err, err
    assert (tmp_path / "afile").read_text() == "kept\n"


def test_workers_with_a_scheduler_is_a_usage_error(tmp_path, capsys):
    """--workers sizes the local cluster only: given with --scheduler it was silently ignored."""
    from cosim.cli import main as cli_main

    spec_path = tmp_path / "spec.yaml"
    spec_path.write_text("duration_s: 0.05\n")
    argv = ["sweep", str(spec_path), "--out", str(tmp_path / "o"), "--workers", "2"]
    rc = cli_main([*argv, "--scheduler", "tcp://127.0.0.1:8786"])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert err.count("\n") == 1 and "--workers" in err and "--scheduler" in err, err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "kind, words",
    [
        ("missing", "does not exist"),
        ("folder", "is a folder"),
        ("fifo", "is not a regular file"),
        ("binary", "not UTF-8"),
        ("empty", "is empty"),
    ],
)
def test_a_spec_that_is_no_text_file_is_one_line_without_blocking(tmp_path, kind, words):
    """The reader every command shares (cosim.project.datafile.read_text): a FIFO would block the
    read forever, so it is refused before it is opened."""
    path = tmp_path / "spec.yaml"
    if kind == "folder":
        path.mkdir()
    elif kind == "fifo":
        os.mkfifo(path)
    elif kind == "binary":
        path.write_bytes(b"axes:\n  mu: [\xff]\n")
    elif kind == "empty":
        path.write_text("  \n")
    with pytest.raises(SpecError) as exc:
        load_spec(path)
    message = str(exc.value)
    assert "\n" not in message and words in message and str(path) in message, message
