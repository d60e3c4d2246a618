"""Strict reading of the files a user hands the project (a params file, a backup, a device
parameter file, a sweep specification): one reader, so every command refuses the same things
with the same words (read_text for any text file, read_json for the JSON ones).

Refused, each as one line naming the file: a path that is not a regular file (a FIFO or a device
would block the open or the read), a file larger than any such file can be, text that is not
UTF-8, an empty file, invalid JSON, a key given twice in one object (json would keep the last
silently), nesting deeper than the parser goes. An integer too long for Python's int conversion
is read as a `HugeInt`, which every range check refuses and a message names for what it is.
"""

from __future__ import annotations

import json
from pathlib import Path

# Larger than any parameter file (a backup is about 4 kB); a device file such as /dev/zero or a
# wrong file chosen by mistake is refused instead of read into memory.
MAX_FILE_BYTES = 16 << 20

INT_DIGITS = 4000  # under CPython's limit for int(str) (4300): longer ones become HugeInt


class HugeInt(float):
    """An integer too long for Python's int conversion (over INT_DIGITS digits) as a JSON or
    YAML loader read it: infinite as a number, so every range check refuses it, and named for
    what it is in a message."""

    def __new__(cls, text: str) -> HugeInt:
        v = super().__new__(cls, "-inf" if text.strip().startswith("-") else "inf")
        v.digits = sum(c.isdigit() for c in text)
        return v

    def __repr__(self) -> str:
        return f"an integer of {self.digits} digits"


def parse_int(text: str) -> int | HugeInt:
    """json's parse_int: a whole number, HugeInt when it is too long to convert."""
    return int(text) if len(text) <= INT_DIGITS else HugeInt(text)


class DuplicateKeyError(ValueError):
    """A JSON object that names a key twice (json would keep the last one silently)."""


def unique_keys(pairs: list[tuple[str, object]]) -> dict:
    """json's object_pairs_hook: the object as a dict, DuplicateKeyError for a key given twice."""
    out: dict = {}
    for key, value in pairs:
        if key in out:
            raise DuplicateKeyError(
                f"key {key!r} appears twice in the same object (the last would win)"
            )
        out[key] = value
    return out


class DataFileError(ValueError):
    """A file that cannot be used: one line naming the file and the problem."""


def read_text(
    path: str | Path,
    what: str = "a file",
    not_kind: str = "text",
    *,
    name: str | None = None,
    error: type[ValueError] = DataFileError,
) -> str:
    """The UTF-8 text of `path`, read strictly: a regular file (not a FIFO or a device, which
    could block or never end), at most MAX_FILE_BYTES, not empty; a byte-order mark dropped.
    `what` names the file expected ("a backup file"), `not_kind` what it is not when it is not
    UTF-8 ("a JSON backup"), `name` how the file is shown (default: the path as given); errors
    are `error`, one line each."""
    if not str(path).strip():
        raise error(f"an empty file name: expected {what}")
    path = Path(path)
    name = str(path) if name is None else name
    if path.exists() and not path.is_dir() and not path.is_file():
        raise error(f"{name} is not a regular file: expected {what}")
    try:
        with path.open("rb") as f:
            raw = f.read(MAX_FILE_BYTES + 1)
    except FileNotFoundError:
        raise error(f"{name} does not exist") from None
    except IsADirectoryError:
        raise error(f"{name} is a folder, not {what}") from None
    except OSError as exc:
        raise error(f"{name}: cannot read it ({exc.strerror or exc})") from None
    if len(raw) > MAX_FILE_BYTES:
        raise error(f"{name} is larger than {MAX_FILE_BYTES >> 20} MiB: too large to be {what}")
    raw = raw.removeprefix(b"\xef\xbb\xbf")  # a byte-order mark, as some editors write it
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(
            f"{name} is not {not_kind} (not UTF-8 text: byte 0x{raw[exc.start]:02x} at offset "
            f"{exc.start})"
        ) from None
    if not text.strip():
        raise error(f"{name} is empty: expected {what}")
    return text


def read_json(
    path: str | Path,
    what: str = "a file",
    not_json: str = "JSON",
    *,
    name: str | None = None,
    error: type[ValueError] = DataFileError,
) -> object:
    """The JSON document in `path`, read strictly (see the module and read_text). `what` names
    the file expected ("a backup file"), `not_json` what it is not when it does not parse ("a
    JSON backup"), `name` how the file is shown (default: the path as given); errors are
    `error`."""
    name = str(path) if name is None else name
    text = read_text(path, what, not_json, name=name, error=error)
    try:
        return json.loads(text, object_pairs_hook=unique_keys, parse_int=parse_int)
    except DuplicateKeyError as exc:
        raise error(f"{name}: {exc}") from None
    except json.JSONDecodeError as exc:
        raise error(f"{name} is not {not_json} ({exc})") from None
    except RecursionError:
        raise error(f"{name}: JSON nested too deeply to be {what}") from None
