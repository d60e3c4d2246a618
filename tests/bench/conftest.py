"""Shared helpers of the bench tests."""

import contextlib
import threading

import audit_cache
import pytest

from cosim.audit import core


@contextlib.contextmanager
def _kept_alive(client, period_s: float = 0.05):
    """Feed the device's host watchdog from `client` while the body runs (a test that holds a
    run open and does something else meanwhile, as the recorder's loop would)."""
    stop = threading.Event()

    def feed() -> None:
        while not stop.wait(period_s):
            client.keep_alive(0.0)

    t = threading.Thread(target=feed, daemon=True)
    t.start()
    try:
        yield client
    finally:
        stop.set()
        t.join()


@pytest.fixture
def kept_alive():
    """`with kept_alive(client): ...` feeds the device's host watchdog from client meanwhile."""
    return _kept_alive


@pytest.fixture(autouse=True)
def _audits_reused(monkeypatch, test_cache_dir):
    """The audits a bench procedure runs in this process (calibrate's, of the recording it made)
    reused by input hash, as the audit tests' own (tests/audit/audit_cache.py)."""
    monkeypatch.setattr(core, "run", audit_cache.run_cached(test_cache_dir))
