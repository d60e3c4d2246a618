"""The parameter files `bowden bench diff` and `restore` read, with one reader for both.

- `read_json`: strict JSON. A key given twice in one object is refused (json would keep the last
  silently), as are an integer too long to convert, nesting deeper than the parser goes and a
  file too large to be a parameter file: each is one line naming the file, never a traceback.
- `read_backup`: a backup as `bowden bench backup` writes it. Another backup format or protocol
  version is refused (its words may mean other things); each entry's `word` and `value` must
  agree, and the word must be one the device accepts for its parameter.
- `bench_params`: a params file of device parameters, values as `set` takes them.
- `restore_plan`: what `restore` writes from a backup.

Every value is checked against what the device's settings check accepts for its parameter alone
(`Param.accept_lo`..`accept_hi`, an enum's values), before anything is sent: a file that holds a
value the device refuses is refused, not compared or written in part. Errors are
`ParamFileError`, one line without the command's name (the command adds it).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from cosim.project import datafile
from cosim.project.datafile import HugeInt

from . import messages as msgs
from .protocol import ProtocolError, format_value, param, word_from_value

BACKUP_FORMAT = 1


class ParamFileError(ValueError):
    """A file that cannot be used: one line naming the file and the problem."""


def read_json(path: str | Path, what: str = "a file", not_json: str = "JSON") -> object:
    """The JSON document in `path`, read by the project's strict reader
    (cosim.project.datafile.read_json); `what` names the file expected ("a backup file") and
    `not_json` what it is not when it does not parse ("a JSON backup")."""
    return datafile.read_json(path, what, not_json, error=ParamFileError)


def accepted(p: msgs.Param) -> str:
    """The values the device accepts for `p` alone, for people: `[0, 1]`, `[0, 3.99988] A/N`."""
    if p.enum is not None:
        return "one of " + ", ".join(p.enum)
    lo, hi = p.accept_lo / (1 << p.frac), p.accept_hi / (1 << p.frac)
    return f"[{lo:g}, {hi:g}]" + (f" {p.unit}" if p.unit else "")


def _not_power_of_two(p: msgs.Param, word: int) -> bool:
    return p.accept_power_of_two and (word <= 0 or word & (word - 1) != 0)


def _json(value) -> str:
    """A value as the file wrote it (JSON), shortened: `819.0`, `"1"`, `true`."""
    if _huge(value):
        return _shown(value)
    try:
        text = json.dumps(value)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _huge(value) -> bool:
    """An integer beyond every double (json reads 10**400 as an int; float() would overflow)."""
    return isinstance(value, HugeInt) or (
        isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 1000
    )


def _shown(value) -> str:
    if isinstance(value, HugeInt):
        return repr(value)
    if _huge(value):
        return f"an integer of {len(str(abs(value)))} digits"
    if isinstance(value, float) and math.isfinite(value):
        return f"{value:g}"
    return str(value)


def word_of_value(p: msgs.Param, value: str | float | int) -> int:
    """The word for a value in SI units or a mode name, as `set` converts it (rounded to the
    parameter's fixed point; a phase in turns wraps), refused with ProtocolError when the device
    would refuse it on its own: outside the parameter's accepted range, not one of its enum's
    values, not a power of two where only those are taken."""
    if _huge(value):
        raise ProtocolError(f"{p.name}: {_shown(value)}, outside {accepted(p)}")
    given = value.strip() if isinstance(value, str) else value
    try:
        word = word_from_value(p, given)
    except ProtocolError:
        # Beyond the word itself: say what the device accepts, not the word's range.
        if p.enum is None and _beyond_the_word(p, given):
            raise ProtocolError(f"{p.name}={_shown(value)}: outside {accepted(p)}") from None
        raise
    w = word & 0xFFFFFFFF if p.unsigned else word
    if p.enum is not None:
        if w not in p.enum.values():
            raise ProtocolError(f"{p.name}={_shown(value)}: expected {accepted(p)}")
    elif not p.accept_lo <= w <= p.accept_hi:
        raise ProtocolError(f"{p.name}={_shown(value)}: outside {accepted(p)}")
    if _not_power_of_two(p, w):
        raise ProtocolError(f"{p.name}={_shown(value)}: not a power of two in {accepted(p)}")
    return word


def _beyond_the_word(p: msgs.Param, value) -> bool:
    """A finite number whose fixed-point word does not fit the parameter's 32 bits."""
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        return False
    if not math.isfinite(number):
        return False
    scaled = number * (1 << p.frac)
    return not math.isfinite(scaled) or not p.lo <= round(scaled) <= p.hi


def check_word(p: msgs.Param, word: int) -> None:
    """ProtocolError when the device would refuse `word` for `p` on its own."""
    w = word & 0xFFFFFFFF if p.unsigned else word
    if p.enum is not None:
        if w not in p.enum.values():
            names = ", ".join(f"{k}={v}" for k, v in p.enum.items())
            raise ProtocolError(f"{p.name}: word {w} is none of {names}")
    elif not p.accept_lo <= w <= p.accept_hi:
        raise ProtocolError(
            f"{p.name}: word {w} outside the words {p.accept_lo}..{p.accept_hi} the device "
            f"accepts ({accepted(p)})"
        )
    elif _not_power_of_two(p, w):
        raise ProtocolError(f"{p.name}: word {w} is not a power of two in {accepted(p)}")


def entry_word(path: Path, p: msgs.Param, entry) -> int:
    """A backup entry's word: `word` and `value` must agree (a value edited by hand is not
    silently replaced by the raw word); a value alone is converted, a word alone taken as it is.
    Either must be one the device accepts."""
    if not isinstance(entry, dict):
        raise ParamFileError(f"{path}: {p.name} must be an object with 'word' and 'value'")
    word = entry.get("word")
    value = entry.get("value")
    if word is not None and (
        isinstance(word, bool) or not isinstance(word, int) or not -(1 << 31) <= word < (1 << 32)
    ):
        raise ParamFileError(f"{path}: {p.name}.word must be a 32-bit integer; got {_json(word)}")
    if value is not None and (isinstance(value, bool) or not isinstance(value, str | int | float)):
        raise ParamFileError(f"{path}: {p.name}.value must be a string or a number")
    try:
        if word is not None:
            word = word - (1 << 32) if word >= 1 << 31 else word
            check_word(p, word)
        if value is None:
            if word is None:
                raise ParamFileError(f"{path}: {p.name} has neither 'word' nor 'value'")
            return word
        text = value.strip() if isinstance(value, str) else value
        if word is not None and text == format_value(p, word):
            return word
        if isinstance(text, str):
            text = text.split()[0] if text else text  # "0.0699463 A/N" -> its number
        from_value = word_of_value(p, text)
    except ProtocolError as exc:
        raise ParamFileError(f"{path}: {exc}") from None
    if word is not None and from_value != word:
        raise ParamFileError(
            f"{path}: {p.name}: value {value!r} and word {word} ({format_value(p, word)}) "
            "disagree: edit one to match the other or remove it"
        )
    return from_value


@dataclass
class Backup:
    """A backup's words by parameter name (file order), the names this host's table does not
    know, and the table hash it was saved with."""

    path: Path
    words: dict[str, int]
    unknown: list[str] = field(default_factory=list)
    table_hash: object = None

    @property
    def same_table(self) -> bool:
        return self.table_hash == f"{msgs.TABLE_HASH:08x}"


def is_backup(doc) -> bool:
    return isinstance(doc, dict) and "bowden_bench_backup" in doc


def read_backup(path: str | Path, doc=None) -> Backup:
    """A backup file (or its document, already read), checked entry by entry (ParamFileError)."""
    if doc is None:
        doc = read_json(path, "a backup file", "a JSON backup")
    path = Path(path)
    if not is_backup(doc):
        raise ParamFileError(f"{path} is not a bowden bench backup (format {BACKUP_FORMAT})")
    fmt = doc["bowden_bench_backup"]
    if type(fmt) is not int or fmt != BACKUP_FORMAT:
        raise ParamFileError(
            f"{path}: backup format {_json(fmt)}, this host reads format {BACKUP_FORMAT}"
        )
    version = doc.get("protocol_version")
    if type(version) is not int or version != msgs.PROTOCOL_VERSION:
        raise ParamFileError(
            f"{path} is a backup of protocol version {_json(version)}, this host speaks "
            f"{msgs.PROTOCOL_VERSION}: its words may mean other things; use a host of that version"
        )
    params = doc.get("params")
    if not isinstance(params, dict):
        raise ParamFileError(f"{path}: no 'params' object")
    if not params:
        raise ParamFileError(f"{path}: its 'params' object is empty")
    words, unknown = {}, []
    for name, entry in params.items():
        if name in msgs.PARAM_BY_NAME:
            words[name] = entry_word(path, param(name), entry)
        else:
            unknown.append(name)
    return Backup(path, words, unknown, doc.get("table_hash"))


def bench_params(path: str | Path, doc: dict) -> tuple[dict[str, int], list[str]]:
    """A params file of device parameters ({"loop.kp": 0.1, "comp.mode": "smooth"}): the words
    of the names this host knows, and the names it does not (ParamFileError for a bad value)."""
    words, unknown = {}, []
    for name, value in doc.items():
        if name not in msgs.PARAM_BY_NAME:
            unknown.append(name)
            continue
        if isinstance(value, bool) or not isinstance(value, int | float | str):
            raise ParamFileError(f"{path}: {name}: expected a number or a mode name")
        try:
            words[name] = word_of_value(param(name), value)
        except ProtocolError as exc:
            raise ParamFileError(f"{path}: {exc}") from None
    return words, unknown


def restore_plan(path: str | Path) -> tuple[list[tuple[msgs.Param, int]], str]:
    """What `restore` writes from the backup `path`: (parameter, word) for every writable one,
    and a note when the backup's table is not this host's (restored by name). A backup with
    names this host does not know is refused: restoring it in part would leave a configuration
    the backup never held."""
    b = read_backup(path)
    if b.unknown:
        raise ParamFileError(
            f"{b.path} has parameters this device does not know: {', '.join(b.unknown)} "
            f"(backup table {b.table_hash}, device table {msgs.TABLE_HASH:08x})"
        )
    todo = [(param(n), w) for n, w in b.words.items() if not param(n).read_only]
    note = (
        ""
        if b.same_table
        else f"backup of table {b.table_hash}, device table {msgs.TABLE_HASH:08x}: restoring by "
        "parameter name"
    )
    return todo, note
