"""Files of a sweep's --out written whole or not at all: each goes to a temporary name in the same
folder and is renamed into place (os.replace, atomic within one filesystem), so a reader, a crash
or a full disk never leaves half a file where a whole one was. The temporary name holds the
process id and a random part: two sweeps (or two writers of one process) finishing at once into
the same folder never write into the same temporary file, and the last rename wins with a whole
file. The names start with a dot and end in .tmp, so nothing that lists the results reads them."""

from __future__ import annotations

import os
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


def temporary_name(path: Path) -> Path:
    """A name beside `path` that no other writer uses."""
    return path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")


@contextmanager
def replacing(path: Path) -> Iterator[Path]:
    """Give the temporary path to write `path`'s new content to; rename it into place when the
    block ends, or remove it (keeping `path` as it was) when the block raises."""
    tmp = temporary_name(path)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_text(path: Path, text: str) -> None:
    """Write `text` (UTF-8) to `path` atomically."""
    with replacing(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
