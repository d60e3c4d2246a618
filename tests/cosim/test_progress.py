"""The progress bar redraws itself on a terminal and writes one line to a log."""

from __future__ import annotations

import io

from cosim.project.progress import Progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _run(stream) -> str:
    bar = Progress(1000, "fig14", 1000.0, stream=stream, interval_s=0.0)
    for k in range(0, 1000, 100):
        bar.update(k)
    bar.close()
    return stream.getvalue()


def test_a_log_gets_the_last_state_once():
    text = _run(io.StringIO())
    assert "\r" not in text
    assert text.count("\n") == 1 and text.startswith("fig14")
    assert "100.0 %" in text and "1.00/1.00 s sim" in text


def test_a_terminal_gets_each_redraw_over_the_last():
    text = _run(_Terminal())
    assert text.count("\r") == 11  # ten updates and the close
    assert text.endswith("real time\n") and "  0.0 %" in text


def test_an_interrupted_run_leaves_a_log_untouched_and_ends_a_terminal_line():
    log, term = io.StringIO(), _Terminal()
    for stream in (log, term):
        bar = Progress(1000, "fig14", 1000.0, stream=stream, interval_s=0.0)
        bar.update(300)
        bar.abandon()
    assert log.getvalue() == ""
    assert term.getvalue().endswith("\n") and "30.0 %" in term.getvalue()
