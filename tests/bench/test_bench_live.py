"""The live view as a person sees it: the terminal view under tmux (capture-pane shows the axes,
the labels and the latest values, which match the recording), the page in headless Chromium (a
screenshot, and the values it shows checked against the recording), the page opened when no run
is active, and the ring buffer the recorder writes without waiting for a view."""

import json
import os
import re
import shutil
import subprocess
import sys
import time
import urllib.request

import numpy as np
import pytest

from cosim.bench import live
from cosim.bench.__main__ import main as bench_cli
from cosim.bench.api import Bench
from cosim.bench.emulator import Emulator
from cosim.project.paths import REPO_ROOT
from cosim.results import trace as trace_mod

CHROMIUM = next(
    (shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome") if shutil.which(n)),
    None,
)
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None,
    reason="no chromium on PATH (`make browser-setup` installs Debian's chromium as root; CI runs "
    "it): the page's headless-browser check did not run",
)


# Signal, trace column, words per SI unit (Q7.8 N, Q3.12 A): values compared as the words.
WORDS = (("T_ref", "T_ref_N", 256), ("T_out", "T_out_N", 256), ("current", "current_A", 4096))


@pytest.fixture(scope="module")
def emulator():
    emu = Emulator(tcp_port=0, pty=False).start()
    yield emu
    emu.stop()


def _telemetry(sample, t_ref=0, t_out=0, current=0, faults=0):
    return {
        "sample": sample,
        "t_ref": t_ref,
        "t_c": t_ref + 1,
        "t_in": t_ref + 2,
        "t_out": t_out,
        "current": current,
        "faults": faults,
    }


def test_ring_keeps_the_last_window_in_order():
    buf = live.LiveBuffer(rate_hz=1000.0, capacity_s=4.0)
    buf.start("test", 1000.0)
    for k in range(25_000):  # wraps the 4001-row ring six times
        buf.add(_telemetry(k, t_ref=k % 3000, t_out=-(k % 700), current=k % 4096, faults=k & 1))
    w = buf.window(1.5)
    np.testing.assert_array_equal(w["sample"], np.arange(23_500, 25_000))
    np.testing.assert_array_equal(w["t_s"], np.arange(23_500, 25_000) / 1000.0)
    np.testing.assert_array_equal(w["T_ref"], (np.arange(23_500, 25_000) % 3000) / 256.0)
    np.testing.assert_array_equal(w["T_out"], -(np.arange(23_500, 25_000) % 700) / 256.0)
    np.testing.assert_array_equal(w["current"], (np.arange(23_500, 25_000) % 4096) / 4096.0)
    np.testing.assert_array_equal(w["faults"], np.arange(23_500, 25_000) & 1)
    # At most half the ring: the rows a view copies are never the ones being written.
    assert len(buf.window(60.0)["sample"]) == buf.capacity // 2


def test_signals_and_window_options_are_checked(capsys):
    assert live.parse_signals("T_out, current") == ["T_out", "current"]
    args = ["bench", "--emulate", "run", "sine", "--seconds", "1", "--out", "x.csv", "--live"]
    assert bench_cli([*args, "--signals", "T_out,T_foo"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        "bowden bench: --signals 'T_out,T_foo': unknown T_foo; choose from "
        "T_ref,T_c,T_in,T_out,current,faults"
    )
    assert bench_cli([*args, "--window", "0.5"]) == 2
    assert capsys.readouterr().err.strip() == "bowden bench: --window 0.5: outside 1..60 s"


def _by_sample(path):
    """A recording's columns indexed by the sample number (rows are missing where samples
    were dropped, so a row's position is not its sample)."""
    from cosim.bench.api import _read_columns  # the API's reader: gaps allowed

    tr = _read_columns(path)
    samples = tr["sample"].astype(int)
    return {c: dict(zip(samples, tr[c], strict=True)) for c in ("T_ref_N", "T_out_N", "current_A")}


def _tmux(*args):
    # A server of this test's own (-L): other tmux users of the machine cannot end its session.
    sock = f"bowden-live-{os.getpid()}"
    return subprocess.run(["tmux", "-L", sock, *args], capture_output=True, text=True, check=False)


@pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed")
def test_terminal_view_under_tmux_shows_the_run(emulator, tmp_path):
    out = tmp_path / "live.csv"
    session = f"bowden-live-{id(out)}"
    cmd = (
        f"cd {REPO_ROOT} && {sys.executable} -m cosim.bench bench --port "
        f"{emulator.urls['socket']} run sine --mean 8 --amplitude 5 --freq 1 --seconds 6 "
        f"--out {out} --live --window 5 > {tmp_path}/stdout.txt 2> {tmp_path}/stderr.txt"
    )
    # The view draws on the terminal: stdout must be the pane, so only stderr is redirected.
    cmd = cmd.replace(f" > {tmp_path}/stdout.txt", "")
    assert _tmux("new-session", "-d", "-s", session, "-x", "140", "-y", "42", cmd).returncode == 0
    try:
        screen = ""
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # until the view has drawn a couple of seconds
            # The last screen the view drew: once the run has ended (a loaded machine may draw
            # slowly) the session is gone and a capture is empty.
            shot = _tmux("capture-pane", "-p", "-t", session).stdout
            if shot.strip():
                screen = shot
            elif _tmux("has-session", "-t", session).returncode != 0:
                break
            # The newest time on the screen (a line of an earlier frame may linger above it).
            shown_s = [float(v) for v in re.findall(r"t +(\d+\.\d+) s", screen)]
            if shown_s and max(shown_s) > 2.0:
                break
            time.sleep(0.2)
        while _tmux("has-session", "-t", session).returncode == 0 and time.monotonic() < deadline:
            time.sleep(0.2)  # the run goes on to its end
    finally:
        _tmux("kill-session", "-t", session)
    assert "bowden bench live: sine" in screen and "(last 5 s)" in screen, screen
    for label in ("T_ref", "T_c", "T_in", "T_out", "current", "t (s)", "fps", "faults now"):
        assert label in screen, (label, screen)
    assert re.search(r"^\s*1[0-9](\.\d+)?\s*[│┤]", screen, re.M), screen  # a y-axis tick in N
    sample = int(re.search(r"sample (\d+)", screen).group(1))
    shown = {
        k: float(v) for k, v in re.findall(r"(T_ref|T_c|T_in|T_out|current) +(-?\d+\.\d+)", screen)
    }
    tr = _by_sample(out)  # (a loaded machine may drop samples: the benchmark counts them)
    for name, col, _ in WORDS:  # the view prints 3 decimals of the recorded value
        assert f"{shown[name]:.3f}" == f"{tr[col][sample]:.3f}", name


def _chromium(*args, timeout=90):
    return subprocess.run(
        [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def _get_json(url):
    with urllib.request.urlopen(url + "data.json", timeout=10) as r:
        return json.loads(r.read())


def test_page_data_matches_the_recording(emulator, tmp_path):
    """The JSON the page draws from, while a run records, against the recording."""
    buf = live.LiveBuffer()
    server = live.LiveServer(buf, signals=["T_ref", "T_out", "current", "faults"]).start()
    assert server.httpd.server_address[0] == "127.0.0.1"
    snaps = []
    try:
        with Bench(emulator.urls["socket"]) as b:
            buf.start("sine", 1000.0)

            def tap(t):
                buf.add(t)
                if t["sample"] in (1500, 2500):
                    snaps.append(server.data(5.0, 1000))

            run = b.run("sine", 3.0, out=tmp_path / "r.csv", on_telemetry=tap)
            buf.stop(f"run ended: {run.result.summary()}")
        after = _get_json(server.url)
    finally:
        server.stop()
    tr = _by_sample(tmp_path / "r.csv")
    for snap in snaps:
        k = snap["latest"]["sample"]
        assert snap["active"] and snap["samples"] == min(k + 1, 5000)
        for name, col, lsb in WORDS:
            # The recording holds 9 significant digits of the same Q7.8 / Q3.12 word.
            assert round(snap["latest"]["values"][name] * lsb) == round(tr[col][k] * lsb)
            got = np.array(snap["series"][name])
            step = len(range(0, snap["samples"], -(-snap["samples"] // 1000)))
            assert len(got) == step
    assert not after["active"] and after["message"].startswith("run ended: 3000 samples of 3000")
    assert after["latest"]["sample"] == 2999


@needs_chromium
def test_page_in_headless_chromium_shows_the_run(emulator, tmp_path):
    buf = live.LiveBuffer()
    server = live.LiveServer(buf, window_s=5.0).start()
    shot = tmp_path / "live.png"
    try:
        with Bench(emulator.urls["socket"]) as b:
            buf.start("sine", 1000.0)
            import threading

            result = {}
            t = threading.Thread(
                target=lambda: result.setdefault(
                    "run", b.run("sine", 8.0, out=tmp_path / "w.csv", on_telemetry=buf.add)
                )
            )
            t.start()
            while buf.count < 1500:
                time.sleep(0.05)
            # ?frames=5: five frames, then a still (a page that polls for ever keeps headless
            # Chromium's virtual time from ending).
            dom = _chromium("--virtual-time-budget=3000", "--dump-dom", server.url + "?frames=5")
            shot_run = _chromium(
                f"--screenshot={shot}",
                "--window-size=1000,720",
                "--virtual-time-budget=3000",
                server.url + "?frames=5",
            )
            t.join()
    finally:
        server.stop()
    assert result["run"].samples > 1500
    assert shot.exists() and shot.stat().st_size > 10_000, shot_run.stderr
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    dom = dom.stdout
    m = re.search(r'data-sample="(\d+)"', dom)
    assert m, dom[:2000]
    k = int(m.group(1))
    tr = _by_sample(tmp_path / "w.csv")
    for name, col, lsb in WORDS:  # the page prints 6 decimals: the word exactly
        v = float(re.search(rf'id="v-{name}">(-?\d+\.\d+)<', dom).group(1))
        assert round(v * lsb) == round(tr[col][k] * lsb), name
    assert 'id="show-T_out"' in dom and "bowden bench live: sine" in dom


@needs_chromium
def test_page_without_a_run_says_so(tmp_path):
    server = live.LiveServer(live.LiveBuffer()).start()
    try:
        doc = _get_json(server.url)
        dom = _chromium("--virtual-time-budget=2000", "--dump-dom", server.url + "?frames=3").stdout
    finally:
        server.stop()
    assert doc == doc | {"active": False, "samples": 0, "message": live.NO_RUN_MESSAGE}
    assert live.NO_RUN_MESSAGE in dom, dom[:2000]
    assert 'data-sample="' not in dom  # no values: nothing was drawn


def test_watch_with_the_page_records_every_sample(tmp_path, capsys):
    out = tmp_path / "watch.csv"
    rc = bench_cli(
        ["bench", "--emulate", "watch", "--seconds", "1.5", "--out", str(out), "--live", "web"]
    )
    text = capsys.readouterr()
    assert rc == 0, text.err
    assert re.search(r"live view: http://127\.0\.0\.1:\d+/ \(this machine only\)", text.err)
    assert "1500 samples of 1500, drops 0" in text.out
    tr = trace_mod.read_trace(out)
    assert tr.meta["waveform"] == "sine" and len(tr) == 1500


def test_a_stalled_or_dead_view_costs_the_recording_nothing(tmp_path):
    """The views draw in a process of their own: one frozen (SIGSTOP: a terminal that does not
    drain, a drawing that hangs) and one killed mid-run, and the recording still has every
    sample; stopping the views afterwards does not hang."""
    import os
    import signal as sig

    buf = live.LiveBuffer(path=live.ring_file())
    views = {
        "term": live.ViewProcess(buf, "term", sink=os.devnull, size=(100, 30)),
        "web": live.ViewProcess(buf, "web"),
    }
    try:
        with Bench(emulate=True) as b:
            buf.start("sine", 1000.0)
            for v in views.values():
                v.start()
            assert views["web"].url.startswith("http://127.0.0.1:")

            def tap(t):
                buf.add(t)
                if t["sample"] == 500:
                    os.kill(views["term"]._proc.pid, sig.SIGSTOP)
                    views["web"]._proc.kill()
                if t["sample"] == 2500:
                    os.kill(views["term"]._proc.pid, sig.SIGCONT)

            run = b.run("sine", 3.0, out=tmp_path / "r.csv", on_telemetry=tap)
        t0 = time.monotonic()
        for v in views.values():
            v.stop(f"run ended: {run.result.summary()}")
        assert time.monotonic() - t0 < 30
    finally:
        os.unlink(buf.path)
    assert run.complete and run.samples == 3000
    assert views["term"].frames >= 1  # it drew, and drew the end after SIGCONT
    assert buf.count == 3000 and not buf.active
