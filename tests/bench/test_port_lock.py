"""The port lock (`cosim.bench.link.client.PortLock`): one client per port, a refusal that names
the holder, and no lock file left behind once the holder lets go."""

import os

import pytest

from cosim.bench.link import client


@pytest.fixture
def runtime(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    return tmp_path


def test_the_holder_removes_its_lock_file_when_it_lets_go(runtime):
    lock = client.PortLock("socket://localhost:1")
    assert [p.name for p in runtime.iterdir()] == [os.path.basename(lock.path)]
    lock.close()
    assert list(runtime.iterdir()) == []
    lock.close()  # twice is harmless


def test_a_second_client_is_refused_with_the_holder_then_served_after_it(runtime):
    first = client.PortLock("socket://localhost:2")
    with pytest.raises(client.PortBusyError) as refused:
        client.PortLock("socket://localhost:2")
    assert f"pid {os.getpid()}" in refused.value.holder
    first.close()
    second = client.PortLock("socket://localhost:2")
    assert os.path.exists(second.path)
    second.close()


def test_a_client_that_opened_a_removed_lock_file_takes_the_new_one(runtime, monkeypatch):
    """The race that removing lock files opens: B opens the file, A removes it and lets go, B
    locks the orphan. B must notice and lock the file the name leads to, or C would lock a new
    file beside B and two clients would hold one port."""
    a = client.PortLock("socket://localhost:3")
    real_open = os.open
    opened = []

    def open_then_holder_leaves(path, flags, mode=0o777):
        fd = real_open(path, flags, mode)
        if not opened:  # B's first open: A lets go (and removes the file) before B's flock
            opened.append(fd)
            a.close()
        return fd

    with monkeypatch.context() as patch:
        patch.setattr(client.os, "open", open_then_holder_leaves)
        b = client.PortLock("socket://localhost:3")
    assert opened, "the race was not staged"
    held = os.fstat(b._fd)
    named = os.stat(b.path)
    assert (held.st_dev, held.st_ino) == (named.st_dev, named.st_ino)
    with pytest.raises(client.PortBusyError):
        client.PortLock("socket://localhost:3")
    b.close()
