"""A device's configuration as one set: written all or nothing (`write_all`, the device's
settings check deciding) and saved as `bowden bench backup` writes it (`backup_doc`). Used by
`bowden bench set`, `restore` and `calibrate`."""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

from . import messages as msgs
from .client import BenchClient, BenchUsageError, DeviceError
from .paramfiles import BACKUP_FORMAT
from .protocol import format_value, param


def write_all(client: BenchClient, todo: list, what: str) -> list:
    """Write (param, word) pairs all or nothing, the device's settings check deciding: a value
    that the check refuses only because of another one still to come (adc_min above the old
    adc_max) is tried again after the others; when some stay refused, every word written is put
    back in reverse order (each undo returns to a state the device accepted on the way) and
    the first refusal is raised with "nothing written". Returns (param, word in force) pairs."""
    before = {p.name: client.get_word(p.name) for p, _ in todo}
    done: list = []
    pending = list(todo)
    first_refusal: DeviceError | None = None
    while pending:
        left = []
        for p, word in pending:
            try:
                done.append((p, client.set_word(p.name, word)))
            except DeviceError as exc:
                if exc.code != "INVALID_VALUE":
                    _undo(client, done, before)
                    raise
                first_refusal = first_refusal or exc
                left.append((p, word))
        if len(left) == len(pending):  # no progress: the set as a whole is refused
            _undo(client, done, before)
            raise BenchUsageError(f"{what}: {first_refusal} (nothing written)")
        pending, first_refusal = left, None
    return done


def _undo(client: BenchClient, done: list, before: dict) -> None:
    for p, _ in reversed(done):
        client.set_word(p.name, before[p.name])


def backup_doc(client: BenchClient, info) -> dict:
    """The device's configuration as `bowden bench backup` writes it."""
    words = client.params()
    return {
        "bowden_bench_backup": BACKUP_FORMAT,
        "protocol_version": msgs.PROTOCOL_VERSION,
        "table_hash": f"{msgs.TABLE_HASH:08x}",
        "firmware": info.firmware,
        "build_id": f"{info.build_id:08x}",
        "saved_at": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "params": {
            name: {"word": w, "value": format_value(param(name), w)} for name, w in words.items()
        },
    }


def write_atomic(path: Path, data: bytes | str) -> None:
    """Write a file through a temporary name in its folder, fsync'ed, then renamed."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data.encode() if isinstance(data, str) else data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
