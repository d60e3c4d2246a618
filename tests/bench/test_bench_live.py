"""The live view as a person sees it: the terminal view under tmux (capture-pane shows the axes,
the labels and the latest values, which match the recording), the page in headless Chromium (a
screenshot, and the values it shows checked against the recording), the page opened when no run
is active, and the ring buffer the recorder writes without waiting for a view."""

import io
import json
import os
import re
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request

import numpy as np
import pytest

from cosim.bench.__main__ import main as bench_cli
from cosim.bench.api import Bench
from cosim.bench.emulate.emulator import Emulator
from cosim.bench.live import view as live
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
    from cosim.bench.link.api import _read_columns  # the API's reader: gaps allowed

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
            # The last whole frame the view drew: the lines that say how the run ended scroll
            # its header off the pane, and once the run has ended (a loaded machine may draw
            # slowly) the session is gone and a capture is empty.
            shot = _tmux("capture-pane", "-p", "-t", session).stdout
            if "bowden bench live:" in shot:
                screen = shot
            elif not shot.strip() and _tmux("has-session", "-t", session).returncode != 0:
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
    said = (tmp_path / "stderr.txt").read_text()  # how the run ended, when it did not draw
    assert "bowden bench live: sine" in screen and "(last 5 s)" in screen, (said, screen)
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
    # A profile of its own inside the checkout (conftest's runtime folder), and its crash reports
    # and cache there too (chromium puts them under XDG_CONFIG_HOME and XDG_CACHE_HOME).
    with tempfile.TemporaryDirectory(dir=os.environ["XDG_RUNTIME_DIR"]) as profile:
        env = {**os.environ, "XDG_CONFIG_HOME": profile, "XDG_CACHE_HOME": profile}
        return subprocess.run(
            [
                CHROMIUM,
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--hide-scrollbars",
                f"--user-data-dir={profile}",
                *args,
            ],
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
            env=env,
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


# --- what goes wrong around a view: each a one-line note, never a traceback -------------------


def _filled_buffer(path=None, samples=2000):
    buf = live.LiveBuffer(path=path)
    buf.start("sine", 1000.0)
    for k in range(samples):
        buf.add(_telemetry(k, t_ref=2000 + k % 500, t_out=1900, current=400))
    return buf


def _cursor_shown_last(text: str) -> bool:
    """The view hides the cursor while it draws: the last word on it must show it again."""
    return text.rfind("\x1b[?25h") > text.rfind("\x1b[?25l") >= 0


def test_a_terminal_of_no_size_gets_a_note_not_a_traceback(tmp_path, capfd):
    """A terminal that reports 0x0 (a serial console, some containers) or one too small for two
    panels: one line saying so, in the view's own thread and in its last frame."""
    import fcntl
    import struct
    import termios

    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 0, 0, 0, 0))
    try:
        with open(slave, "w", closefd=False) as tty:
            view = live.TermView(_filled_buffer(), out=tty)
            view.draw()  # the size as the terminal reports it
            shown = os.read(master, 65536).decode()
        assert "the terminal reports its size as 0x0: nothing drawn" in shown
    finally:
        os.close(master)
        os.close(slave)
    for cols, rows in ((30, 20), (100, 5)):
        small = live.TermView(_filled_buffer(), out=io.StringIO(), size=(cols, rows))
        small.draw()
        note = small.out.getvalue().replace("\x1b[H", "").split("\x1b[K")[0]
        assert note.startswith(f"{cols}x{rows}: too small for the live view"[:cols]), note
        assert len(note) <= cols
    # The view in its process, as `run --live` starts it: the note, and nothing on stderr.
    sink = tmp_path / "screen.txt"
    buf = _filled_buffer(path=live.ring_file())
    try:
        view = live.ViewProcess(buf, "term", sink=str(sink), size=(0, 0)).start()
        time.sleep(0.5)
        view.stop("run ended")
    finally:
        os.unlink(buf.path)
    assert view.ended == "" and view.frames >= 1
    assert "nothing drawn" in sink.read_text() and _cursor_shown_last(sink.read_text())
    assert "Traceback" not in capfd.readouterr().err


def test_a_page_port_in_use_is_refused_before_the_run(tmp_path, capfd, monkeypatch):
    """--http-port taken by another program: one line, exit 2, before a session is opened (so
    nothing is sent to the device); the view meeting it (taken meanwhile) says it too."""
    import socket

    from cosim.bench import command as bench_mod

    def no_session(*args, **kwargs):
        raise AssertionError("a session was opened")

    monkeypatch.setattr(bench_mod, "Bench", no_session)
    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen(1)
    port = taken.getsockname()[1]
    try:
        out = tmp_path / "x.csv"
        for argv in (
            ["run", "sine", "--seconds", "1", "--out", str(out), "--live", "web"],
            ["watch", "--seconds", "1", "--out", str(out), "--live", "web"],
        ):
            assert bench_cli(["bench", "--emulate", *argv, "--http-port", str(port)]) == 2
            err = capfd.readouterr().err
            assert err == (
                f"bowden bench: --http-port {port}: port {port} is in use (choose another, or 0 "
                "for a free one)\n"
            )
        assert not out.exists()
        buf = live.LiveBuffer(path=live.ring_file())
        try:
            with pytest.raises(OSError, match=rf"^the live page did not start \(port {port} is "):
                live.ViewProcess(buf, "web", http_port=port).start()
        finally:
            os.unlink(buf.path)
    finally:
        taken.close()
    assert "Traceback" not in capfd.readouterr().err


def test_page_data_query_is_checked(capfd):
    """`/data.json`'s window and points: what is not a finite number is a 400 with the reason,
    a number out of range is brought into it; never an empty answer or a traceback."""
    import urllib.error

    server = live.LiveServer(_filled_buffer()).start()

    def get(query):
        try:
            with urllib.request.urlopen(f"{server.url}data.json?{query}", timeout=10) as r:
                return r.status, json.loads(r.read())
        except urllib.error.HTTPError as exc:
            return exc.code, exc.read().decode()

    try:
        for query in (
            "window=nan",
            "window=NaN",
            "window=inf",
            "window=-inf",
            "window=1e999",
            "window=abc",
            "window=",
            "points=nan",
            "points=1e3",
            "points=" + "9" * 40,
        ):
            code, body = get(query)
            assert code == 400, (query, body)
            assert body.startswith(query.split("=")[0] + "=") and "expected" in body, body
        for query, window_s, samples in (
            ("window=-5", 1.0, 1000),
            ("window=1e300", 60.0, 2000),
            ("window=2&points=-1", 2.0, 2000),
            ("window=2&points=7", 2.0, 2000),
        ):
            code, doc = get(query)
            assert code == 200 and doc["window_s"] == window_s and doc["samples"] == samples
            assert len(doc["t_s"]) <= max(10, samples), query
        assert get("window=3")[1]["samples"] == 2000  # (3 s asked, 2 s recorded)
    finally:
        server.stop()
    assert "Traceback" not in capfd.readouterr().err


def _view_with_frames(tmp_path, buf):
    sink = tmp_path / "screen.txt"
    view = live.ViewProcess(buf, "term", sink=str(sink), size=(100, 30)).start()
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and not (
        sink.exists() and "\x1b[H" in sink.read_text(errors="replace")
    ):
        time.sleep(0.05)  # until it has drawn a frame: the cursor is hidden
    return view, sink


def test_a_stopped_or_hung_view_is_ended_soon_and_the_cursor_shown(tmp_path, monkeypatch):
    """SIGSTOP: the recording process does not wait for an answer that cannot come; a view that
    does not answer for another reason is given STOP_WAIT_S (here shortened); a view ended by
    SIGTERM shows the cursor itself. Each time `ended` says what happened, and the cursor is
    shown again where the view drew."""
    import signal as sig

    buf = _filled_buffer(path=live.ring_file())
    try:
        view, sink = _view_with_frames(tmp_path, buf)
        os.kill(view._proc.pid, sig.SIGSTOP)
        t0 = time.monotonic()
        view.stop("run ended")
        assert time.monotonic() - t0 < 2.0
        assert view.ended == "the view was stopped (SIGSTOP): ended it"
        assert _cursor_shown_last(sink.read_text(errors="replace"))

        monkeypatch.setattr(live, "_stopped", lambda pid: False)  # as if hung, not stopped
        view, sink = _view_with_frames(tmp_path, buf)
        os.kill(view._proc.pid, sig.SIGSTOP)
        t0 = time.monotonic()
        view.stop("run ended", wait_s=1.0)
        assert 0.9 < time.monotonic() - t0 < 3.0
        assert view.ended == "the view did not end within 1 s: ended it"
        assert _cursor_shown_last(sink.read_text(errors="replace"))
        monkeypatch.undo()

        view, sink = _view_with_frames(tmp_path, buf)
        view._proc.terminate()
        view._proc.wait(timeout=10)
        screen = sink.read_text(errors="replace")
        assert _cursor_shown_last(screen)  # by the view itself, before it ended
        view.stop("run ended")
        assert view.ended == "the view had ended early (by SIGTERM)"
    finally:
        os.unlink(buf.path)


def test_live_term_without_a_terminal_is_refused_first(tmp_path, capsys):
    """No terminal on stdout (a log, a pipe): `--live term` would write escape codes into it,
    tens of kB a second; refused before the run, and before `watch` makes its folder."""
    out = tmp_path / "x.csv"
    run = ["bench", "--emulate", "run", "sine", "--seconds", "1", "--out", str(out)]
    for argv in ([*run, "--live"], [*run, "--live", "term"]):
        assert bench_cli(argv) == 2
        text = capsys.readouterr()
        assert text.err == (
            "bowden bench: --live term draws in a terminal and the output is not one: use "
            "--live web, or no --live (a page on 127.0.0.1)\n"
        )
        assert text.out == ""
    assert not out.exists()
    assert bench_cli(["bench", "--emulate", "watch", "--seconds", "1", "--out", str(out)]) == 2
    assert "use --live web (a page on 127.0.0.1)" in capsys.readouterr().err
    assert not out.exists()


def test_watch_arguments_are_checked_before_any_side_effect(tmp_path, capsys, monkeypatch):
    """`watch --seconds 0` (or one shorter than a tick): refused before the screen is cleared,
    the view started or a folder made."""
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # where watch's folder would go
    for seconds in ("0", "-1", "nan", "inf"):
        argv = ["bench", "--emulate", "watch", "--live", "web", "--seconds", seconds]
        assert bench_cli(argv) == 2
        text = capsys.readouterr()
        assert text.err == (
            f"bowden bench watch: --seconds {float(seconds):g}: expected a duration > 0 s\n"
        )
        assert "\x1b[2J" not in text.out
    # Shorter than a tick: the device's tick rate says so, before the folder or the view.
    assert bench_cli(["bench", "--emulate", "watch", "--live", "web", "--seconds", "1e-6"]) == 2
    err = capsys.readouterr().err
    assert "--seconds 1e-06: shorter than one tick" in err and "live view:" not in err
    assert list(tmp_path.iterdir()) == []


def _run_in_pty(argv, act, timeout_s=60.0):
    """Run `argv` in a session of its own on a pseudo-terminal of 100x30 (as a user's shell
    does); `act(proc)` once the view has drawn its first frame. Returns (status, everything the
    terminal received, seconds from `act` to the end)."""
    import fcntl
    import struct
    import termios

    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))
    proc = subprocess.Popen(
        argv, stdin=slave, stdout=slave, stderr=slave, cwd=REPO_ROOT, start_new_session=True
    )
    os.close(slave)
    screen, acted, t_act = b"", False, None
    deadline = time.monotonic() + timeout_s
    try:
        while time.monotonic() < deadline:
            ready = select.select([master], [], [], 0.1)[0]
            if ready:
                try:
                    data = os.read(master, 65536)
                except OSError:  # EIO: every process on the terminal has gone
                    break
                screen += data
            if not acted and b"\x1b[H" in screen:
                acted, t_act = True, time.monotonic()
                act(proc)
            if not ready and proc.poll() is not None:
                break
        status = proc.wait(timeout=max(1.0, deadline - time.monotonic()))
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        os.close(master)
    return status, screen.decode(errors="replace"), time.monotonic() - (t_act or 0.0)


@pytest.mark.slow
def test_run_live_with_a_stopped_view_or_sigterm_ends_soon_with_the_cursor_shown(
    emulator, tmp_path
):
    """`run --live` on a terminal: a view frozen with SIGSTOP costs the command a moment after
    the run, one line says so, and the cursor is shown again; SIGTERM to the whole session
    (the view too) stops the device, confirmed, and leaves the cursor shown."""
    import psutil

    argv = [sys.executable, "-m", "cosim.bench", "bench", "--port", emulator.urls["socket"]]
    argv += ["run", "sine", "--seconds", "3", "--out", str(tmp_path / "x.csv"), "--live"]

    def freeze_view(proc):
        for child in psutil.Process(proc.pid).children():
            os.kill(child.pid, signal.SIGSTOP)

    status, screen, after_s = _run_in_pty(argv, freeze_view)
    assert status == 0, screen[-2000:]
    assert after_s < 3.0 + 5.0, after_s  # the run's 3 s, then not the view's 30
    assert "live view: the view was stopped (SIGSTOP): ended it" in screen
    assert _cursor_shown_last(screen)
    assert "3000 samples of 3000" in screen

    status, screen, _ = _run_in_pty(argv, lambda proc: os.killpg(proc.pid, signal.SIGTERM))
    assert status == 128 + signal.SIGTERM, screen[-2000:]
    assert "device stopped, output disabled (confirmed by the device)" in screen
    assert _cursor_shown_last(screen), screen[-500:]
    assert "Traceback" not in screen


def test_view_options_without_a_view_are_refused(tmp_path, capsys):
    """--signals, --window or --http-port with no view to take them (no --live; --http-port
    with the terminal's view) are refused, not ignored; a signal named twice is drawn once."""
    assert live.parse_signals("T_ref,T_out, T_ref") == ["T_ref", "T_out"]
    run = ["bench", "--emulate", "run", "sine", "--seconds", "1", "--out", str(tmp_path / "x")]
    for extra, text in (
        (["--signals", "T_ref"], "--signals: for the live view, which needs --live"),
        (["--window", "3", "--http-port", "0"], "--window, --http-port: for the live view"),
        (["--live", "--http-port", "8080"], "--http-port: for the page (--live web)"),
    ):
        assert bench_cli([*run, *extra]) == 2, extra
        err = capsys.readouterr().err
        assert len(err.splitlines()) == 1 and err.startswith(f"bowden bench: {text}"), err
    assert bench_cli(["bench", "--emulate", "watch", "--http-port", "8080"]) == 2
    assert "--http-port: for the page" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


_KILLED_PARENT = """
import os, sys, time
from cosim.bench.live import view as live
buf = live.LiveBuffer(path=live.ring_file())
buf.start("sine", 1000.0)
view = live.ViewProcess(buf, "term", sink=sys.argv[1], size=(100, 30)).start()
print(buf.path, view._proc.pid, flush=True)
time.sleep(1.0)
os.kill(os.getpid(), 9)
"""


def test_a_view_whose_recording_process_is_killed_ends_quietly(tmp_path):
    """The recording process killed outright (SIGKILL): its view says so in its last frame,
    shows the cursor, removes the ring nobody else will, and ends without a traceback."""
    import psutil

    sink = tmp_path / "screen.txt"
    parent = subprocess.Popen(
        [sys.executable, "-c", _KILLED_PARENT, str(sink)],
        cwd=REPO_ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    ring, view_pid = parent.stdout.readline().split()
    parent.wait(timeout=30)
    try:
        psutil.Process(int(view_pid)).wait(timeout=30)
    except psutil.NoSuchProcess:
        pass
    err = parent.stderr.read()  # the view wrote its stderr here too: all of it, now it is gone
    parent.stdout.close()
    parent.stderr.close()
    assert "Traceback" not in err and "Exception ignored" not in err, err
    assert not os.path.exists(ring)
    screen = sink.read_text()
    assert "the recording process is gone (killed?)" in screen and _cursor_shown_last(screen)


def test_an_interrupted_run_stops_the_device_before_the_view_ends(tmp_path, capsys, monkeypatch):
    """Ctrl-C in a run with a view: STOP goes to the device before the view is given its
    seconds to draw the end (the motor is not kept driven meanwhile), then the run's exit path
    confirms it."""
    from cosim.bench.rig import run as rig_run

    seen = {}
    real_record_run, real_stop = rig_run.record_run, live.ViewProcess.stop

    def record_run(client, out, tap, **kw):
        seen["client"] = client

        def interrupt(t):
            tap(t)
            if t["sample"] == 300:
                raise KeyboardInterrupt

        return real_record_run(client, out, tap=interrupt, **kw)

    def stop(self, message=None, **kw):
        seen["running"] = seen["client"].hello().running
        return real_stop(self, message, **kw)

    monkeypatch.setattr(rig_run, "record_run", record_run)
    monkeypatch.setattr(live.ViewProcess, "stop", stop)
    out = tmp_path / "x.csv"
    argv = ["bench", "--emulate", "run", "sine", "--seconds", "3", "--out", str(out)]
    assert bench_cli([*argv, "--live", "web"]) == 130
    assert seen["running"] is False
    assert "device stopped, output disabled (confirmed by the device)" in capsys.readouterr().err


def test_a_trace_a_channel_each_from_its_own_recording(tmp_path):
    """Two channels with different settings recorded together: the view's snapshot carries a
    trace a channel (`T_out[0]`, `T_out[1]`), each the words of its own channel's CSV, and the
    faults named with their channel; the terminal frame draws both."""
    from cosim.bench.link.recorder import channel_path, record_run

    buf = live.LiveBuffer(rate_hz=1000.0, channels=(0, 1))
    buf.start("sine", 1000.0)
    signals = ["T_ref", "T_out", "current", "faults"]
    snaps = []

    def tap(t):
        buf.add(t)
        if t["sample"] == 400 and t["channel"] == 1:  # both channels' frames of 400 are in
            snaps.append(live.snapshot(buf, signals, 5.0, 10_000))

    with Bench(emulate=True, channels=2) as bench:
        bench.client.set("loop.kp", 0.3, channel=1)
        bench.client.set("comp.mode", "smooth", channel=1)
        run = {"seconds": 0.5, "waveform": "sine", "mean_n": 8.5, "amplitude_n": 6.5}
        run["freq_hz"] = 2.0
        record_run(bench.client, tmp_path / "two.csv", channels=(0, 1), tap=tap, **run)
    (snap,) = snaps
    assert snap["channels"] == [0, 1] and snap["samples"] == 401
    assert {"T_out[0]", "T_out[1]", "current[1]", "faults[0]"} <= set(snap["signals"])
    assert snap["units"]["T_out[1]"] == "N" and snap["units"]["current[0]"] == "A"
    for c in (0, 1):
        tr = _by_sample(channel_path(tmp_path / "two.csv", c, (0, 1)))
        for name, col, lsb in WORDS:
            got = np.round(np.array(snap["series"][f"{name}[{c}]"]) * lsb)
            want = np.round(np.array([tr[col][k] for k in range(401)]) * lsb)
            np.testing.assert_array_equal(got, want, err_msg=f"{name}[{c}]")
            assert round(snap["latest"]["values"][f"{name}[{c}]"] * lsb) == want[-1]
    assert snap["series"]["T_out[0]"] != snap["series"]["T_out[1]"]  # the channels differ
    # a frame of a channel the view does not show is not kept; faults carry their channel
    buf.add({**_telemetry(500, faults=1), "channel": 3})
    assert buf.count_of(0) == buf.count_of(1) == 500
    buf.add({**_telemetry(500, faults=1), "channel": 1})
    snap = live.snapshot(buf, signals, 5.0, 100)
    assert snap["faults_in_window"] == ["1:" + n for n in live.fault_names(1)]
    frame = live.render_text(snap, 100, 30)
    assert "T_out[0]" in frame and "T_out[1]" in frame
