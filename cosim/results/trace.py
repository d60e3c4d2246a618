"""Tension traces on disk: ``trace.csv`` plus its sidecar ``trace.meta.json``.

One format and one reader for every time series of the project: co-simulation runs write it,
bench recordings are converted to it, and the model audit reads those and users' own CSVs.
Reading validates the files and names the first thing that is wrong (file, line, column, allowed
range); a bad file never ends in another exception, and no NaN or infinity is ever accepted.

``trace.csv``
    Comma-separated, UTF-8 (a byte-order mark is allowed), one header row, then one row per
    sample in time order. The columns of a full trace (``mode="full"``, what `bowden sim` writes),
    in this order (extra columns may follow and are kept):

    =================  ====  ====================================================================
    column             unit  meaning
    =================  ====  ====================================================================
    ``t_s``            s     sample time, strictly increasing, spaced 1 / sample_rate_hz
    ``T_ref_N``        N     reference tension at the end-effector (input of the compensator)
    ``T_c_N``          N     compensated command to the tension loop (output of the compensator)
    ``T_in_N``         N     input tension at the actuator outlet, as its sensor reads it
    ``T_out_N``        N     output tension at the end-effector, as its sensor reads it
    ``x_m``            m     end-effector position relative to the actuator outlet
    ``y_m``            m     (paper Fig. 6: sheath leaves the actuator along +Y)
    ``z_m``            m
    ``current_A``      A     motor current command
    ``motor_angle_rad`` rad  motor shaft angle
    =================  ====  ====================================================================

    A measured trace (``mode="measured"``: a bench recording or a user's CSV) needs only ``t_s``,
    ``T_in_N`` and ``T_out_N``; ``x_m``, ``y_m``, ``z_m`` come all three or not at all, the other
    columns above are optional, and extra columns are kept (as numbers when every cell is one,
    else as text) and ignored.

    A cell is a plain decimal number: optional sign, digits with an optional point, an optional
    exponent, spaces or tabs around it (``-1.5``, ``2e-3``, `` 7 ``); not ``nan``, ``inf``,
    ``1_000``, hexadecimal or non-ASCII digits. A field may be at most 128 KiB long. Every known
    column has an allowed range (COLUMN_RANGES): tensions and positions are the plant FMU's input
    ranges (fmu/gen_model.py), so that every accepted trace can be re-simulated.

``trace.meta.json`` (same folder, same stem: ``<stem>.meta.json``)
    A JSON object. A full trace needs ``sample_rate_hz`` (Hz), ``sheath_length_m`` (m),
    ``loop_routing`` (true/false) and ``mu`` (the friction coefficient assumed or identified for
    the run). For a measured trace the sidecar and each key are optional: the sample rate is then
    taken from ``t_s``, the sheath is 1 m long with loop routing, and ``mu`` is unknown (absent
    or null: the audit fits it). Ranges in META_RANGES (the FMU's for mu and the sheath length).
    Other keys (``source``, ``scenario``, ``compensator``...) are kept.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

COLUMNS = (
    "t_s",
    "T_ref_N",
    "T_c_N",
    "T_in_N",
    "T_out_N",
    "x_m",
    "y_m",
    "z_m",
    "current_A",
    "motor_angle_rad",
)
# The columns a measured trace must have, and the positions it may have (all three or none).
MEASURED_COLUMNS = ("t_s", "T_in_N", "T_out_N")
POSITION_COLUMNS = ("x_m", "y_m", "z_m")
MODES = ("full", "measured")

# Allowed range of each known column: (low, high, unit). Tensions and positions are the plant
# FMU's input ranges (T_in_cmd, x, y, z in fmu/gen_model.py; a test holds them equal) and the
# current is its current_cmd range (the Q3.12 command word); time and motor angle are only kept
# finite and far from overflow (31 years, 160 000 turns).
COLUMN_RANGES: dict[str, tuple[float, float, str]] = {
    "t_s": (-1e9, 1e9, "s"),
    "T_ref_N": (-1000.0, 1000.0, "N"),
    "T_c_N": (-1000.0, 1000.0, "N"),
    "T_in_N": (-1000.0, 1000.0, "N"),
    "T_out_N": (-1000.0, 1000.0, "N"),
    "x_m": (-10.0, 10.0, "m"),
    "y_m": (-10.0, 10.0, "m"),
    "z_m": (-10.0, 10.0, "m"),
    "current_A": (-8.0, 8.0, "A"),
    "motor_angle_rad": (-1e6, 1e6, "rad"),
}
# Extra numeric columns are only required to be finite.

# Sidecar keys: the ones a full trace requires, and the allowed range of the numeric ones
# (low, high, unit, low end open). mu and the sheath length are the FMU's ranges (mu,
# sheath_length in fmu/gen_model.py).
META_REQUIRED = ("sample_rate_hz", "sheath_length_m", "loop_routing", "mu")
META_RANGES: dict[str, tuple[float, float, str, bool]] = {
    "sample_rate_hz": (0.0, 1e6, "Hz", True),
    "sheath_length_m": (0.01, 10.0, "m", False),
    "mu": (0.0, 1.0, "", False),
}
# Defaults of a measured trace's sidecar (the model audit's input): a 1 m sheath with loop routing,
# mu unknown.
MEASURED_META_DEFAULTS = {"sheath_length_m": 1.0, "loop_routing": True, "mu": None}

# Relative tolerance on the spacing of t_s against 1 / sample_rate_hz (recordings jitter a bit;
# the CSV keeps 9 significant digits).
TIME_STEP_RTOL = 0.05

# The longest field a trace may hold: the csv module's default limit, 128 KiB.
FIELD_MAX_CHARS = 131072

# A plain decimal number (see the module docstring), spaces or tabs around it.
_NUMBER = r"[ \t]*[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?[ \t]*"
_NUMBER_RE = re.compile(_NUMBER)
# A column's cells joined with newlines, checked in one pass of the regex engine per chunk of
# COLUMN_CHUNK_CELLS: the engine keeps a backtracking entry for every repetition of the group, so
# a whole 20-minute column (1.2 million cells) at once took 860 MB; a chunk takes a few.
_COLUMN_RE = re.compile(f"(?:{_NUMBER}\n)*{_NUMBER}")
COLUMN_CHUNK_CELLS = 8192
_BOM = b"\xef\xbb\xbf"


class TraceError(ValueError):
    """A trace file (CSV or sidecar) that does not follow the format."""


@dataclass
class Trace:
    """A trace in memory: numeric columns by name (finite float64 arrays of equal length), the
    sidecar (with defaults filled in for a measured trace), and for a measured trace its
    non-numeric extra columns (`text_columns`) and the sidecar keys taken from defaults."""

    columns: dict[str, np.ndarray]
    meta: dict = field(default_factory=dict)
    text_columns: dict[str, list[str]] = field(default_factory=dict)
    defaulted: tuple[str, ...] = ()
    mode: str = "full"

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __contains__(self, name: str) -> bool:
        return name in self.columns

    def __len__(self) -> int:
        return len(self.columns["t_s"]) if "t_s" in self.columns else 0

    @property
    def has_positions(self) -> bool:
        """True when the trace holds the end-effector position (x_m, y_m, z_m)."""
        return all(c in self.columns for c in POSITION_COLUMNS)


def meta_path(csv_path: str | Path) -> Path:
    """The sidecar of `csv_path`: ``trace.csv`` -> ``trace.meta.json``."""
    p = Path(csv_path)
    return p.with_name(p.stem + ".meta.json")


def _range_text(lo: float, hi: float, unit: str, open_low: bool = False) -> str:
    return f"{'(' if open_low else '['}{lo:g}, {hi:g}]{' ' + unit if unit else ''}"


def _in_range(v: float, lo: float, hi: float, open_low: bool = False) -> bool:
    return (v > lo if open_low else v >= lo) and v <= hi


def validate_meta(meta: object, where: str = "trace.meta.json", required: bool = True) -> dict:
    """Check the sidecar's keys and ranges; return it as a dict.

    required=True (a full trace): every key of META_REQUIRED must be there. required=False (a
    measured trace): each key is optional, and ``mu`` may be null (unknown)."""
    if not isinstance(meta, dict):
        raise TraceError(f"{where}: expected a JSON object, got {type(meta).__name__}")
    if required:
        for key in META_REQUIRED:
            if key not in meta:
                raise TraceError(
                    f"{where}: missing key {key!r} (required: {', '.join(META_REQUIRED)})"
                )
    for key, (lo, hi, unit, open_low) in META_RANGES.items():
        if key not in meta or (key == "mu" and meta[key] is None and not required):
            continue
        v = meta[key]
        allowed = _range_text(lo, hi, unit, open_low)
        if not _is_number(v):
            raise TraceError(f"{where}: {key} must be a number in {allowed}; got {_short(v)}")
        if not _in_range(float(v), lo, hi, open_low):
            raise TraceError(f"{where}: {key} = {v!r} is outside the allowed range {allowed}")
    if "loop_routing" in meta and not isinstance(meta["loop_routing"], bool):
        raise TraceError(
            f"{where}: loop_routing must be true or false; got {_short(meta['loop_routing'])}"
        )
    return meta


def validate_columns(columns: dict[str, np.ndarray], meta: dict, where: str = "trace") -> None:
    """Check a full trace in memory: the required columns exist, have equal length, are finite
    and in their ranges, and t_s is strictly increasing with the spacing 1 / sample_rate_hz."""
    missing = [c for c in COLUMNS if c not in columns]
    if missing:
        raise TraceError(f"{where}: missing column(s) {', '.join(missing)}")
    n = len(columns["t_s"])
    if n < 1:
        raise TraceError(f"{where}: no samples")
    for name, values in columns.items():
        if len(values) != n:
            raise TraceError(f"{where}: column {name} has {len(values)} rows, t_s has {n}")
        bad = _first_bad(values, name)
        if bad is not None:
            raise TraceError(
                f"{where}: column {name} data row {bad + 1} {_why_bad(values, bad, name)}"
            )
    _check_time(
        columns["t_s"], float(meta["sample_rate_hz"]), lambda i: f"{where}: data row {i + 1}"
    )


def _first_bad(values: np.ndarray, name: str) -> int | None:
    """Index of the first value that is not finite or outside the column's range, or None."""
    lo, hi, _ = COLUMN_RANGES.get(name, (-math.inf, math.inf, ""))
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(values) & (values >= lo) & (values <= hi)
    bad = np.flatnonzero(~ok)
    return int(bad[0]) if bad.size else None


def _why_bad(values: np.ndarray, i: int, name: str) -> str:
    v = float(values[i])
    if name in COLUMN_RANGES:
        lo, hi, unit = COLUMN_RANGES[name]
        return f"is {v!r}; allowed {_range_text(lo, hi, unit)}"
    return f"is {v!r}; values must be finite numbers"


def _check_time(t: np.ndarray, rate_hz: float, where) -> None:
    """t strictly increasing and spaced 1/rate_hz within TIME_STEP_RTOL; where(i) names sample
    i at the start of a message (a file and line, or a data row)."""
    if len(t) < 2:
        return
    dt = np.diff(t)
    nonincreasing = np.flatnonzero(dt <= 0)
    if nonincreasing.size:
        i = int(nonincreasing[0]) + 1
        raise TraceError(
            f"{where(i)}: t_s must be strictly increasing; t_s = {float(t[i])!r} follows "
            f"{float(t[i - 1])!r}"
        )
    period = 1.0 / rate_hz
    off = np.flatnonzero(np.abs(dt - period) > TIME_STEP_RTOL * period)
    if off.size:
        i = int(off[0]) + 1
        raise TraceError(
            f"{where(i)}: t_s step from the previous row is {dt[i - 1]:.9g} s; "
            f"sample_rate_hz = {rate_hz!r} needs {period:.9g} s (+-{TIME_STEP_RTOL:.0%})"
        )


def write_trace(csv_path: str | Path, columns: dict[str, np.ndarray], meta: dict) -> Path:
    """Validate and write ``csv_path`` and its sidecar (a full trace); return the CSV's path.

    The required COLUMNS come first in their order, then any extra column in the order given.
    """
    path = Path(csv_path)
    meta = validate_meta(dict(meta), str(meta_path(path)))
    cols = {k: np.asarray(v, dtype=np.float64) for k, v in columns.items()}
    validate_columns(cols, meta, str(path))
    names = list(COLUMNS) + [c for c in cols if c not in COLUMNS]
    data = np.column_stack([cols[c] for c in names])
    path.parent.mkdir(parents=True, exist_ok=True)
    # 9 significant digits: exact for t_s at 10 kHz over hours and for Q7.8 tensions.
    np.savetxt(path, data, fmt="%.9g", delimiter=",", header=",".join(names), comments="")
    meta_path(path).write_text(json.dumps(meta, indent=2, sort_keys=True) + "\n")
    return path


# --- reading -------------------------------------------------------------------------------


def _read_text(path: Path) -> str:
    """The file as text: UTF-8 with an optional byte-order mark; a bad byte is named with its
    line and (byte) column."""
    raw = path.read_bytes()
    skip = len(_BOM) if raw.startswith(_BOM) else 0
    try:
        return raw[skip:].decode("utf-8")
    except UnicodeDecodeError as exc:
        pos = exc.start + skip
        line = raw.count(b"\n", 0, pos) + 1
        col = pos - (raw.rfind(b"\n", 0, pos) + 1) + 1
        raise TraceError(
            f"{path}:{line}: byte 0x{raw[pos]:02x} at column {col} is not UTF-8 text "
            "(a trace and its sidecar are UTF-8 or ASCII)"
        ) from None


def _parse_int(text: str) -> int | float:
    """A whole number; one too long for int() (4300 digits) as infinity, so the range check
    names its key instead of int() failing without one."""
    return int(text) if len(text) <= 4000 else float("-inf" if text.startswith("-") else "inf")


def _reject_constant(name: str):
    raise ValueError(f"{name} is not a JSON number")


def _read_meta(mpath: Path) -> object:
    text = _read_text(mpath)
    try:
        return json.loads(text, parse_constant=_reject_constant, parse_int=_parse_int)
    except json.JSONDecodeError as exc:
        raise TraceError(
            f"{mpath}:{exc.lineno}: not valid JSON ({exc.msg}, column {exc.colno})"
        ) from None
    except ValueError as exc:  # NaN, Infinity
        raise TraceError(
            f"{mpath}: not valid JSON ({exc}; values must be finite numbers)"
        ) from None
    except RecursionError:
        raise TraceError(f"{mpath}: not valid JSON (nested too deeply)") from None


def sniff_delimiter(text: str) -> str:
    """The field separator of a CSV from its header row: a comma, else a semicolon or a tab when
    the header holds one of them and no comma (as spreadsheets in locales with a decimal comma
    write them)."""
    first = text.split("\n", 1)[0]
    if "," in first:
        return ","
    for sep in (";", "\t"):
        if sep in first:
            return sep
    return ","


# A number written with a decimal comma (1,5 or -0,25e-3): read where the separator is not a comma.
_DECIMAL_COMMA_RE = re.compile(r"[ \t]*[+-]?[0-9]+,[0-9]+(?:[eE][+-]?[0-9]+)?[ \t]*")


def _read_rows(
    path: Path, text: str, delimiter: str = ","
) -> tuple[list[str], list[list[str]], list[int]]:
    """Header, data rows (cells as text) and the file line of each row; blank rows skipped."""
    reader = csv.reader(io.StringIO(text, newline=""), delimiter=delimiter)
    rows: list[list[str]] = []
    lines: list[int] = []
    try:
        header = next(reader, None)
        if header is None:
            raise TraceError(f"{path}: empty file (expected a header row)")
        for row in reader:
            if not row or all(not cell.strip() for cell in row):
                continue
            rows.append(row)
            lines.append(reader.line_num)
    except csv.Error as exc:
        line = reader.line_num + (0 if "field larger" in str(exc) else 0)
        if "field larger" in str(exc):
            raise TraceError(
                f"{path}:{line}: a field is longer than 128 KiB ({FIELD_MAX_CHARS} characters), "
                "the longest a trace field may be"
            ) from None
        raise TraceError(f"{path}:{line}: not a CSV row ({exc})") from None
    return header, rows, lines


def _all_numbers(cells: list[str]) -> bool:
    """Whether every cell is a plain number (and none a quoted cell holding a line break), the
    cells checked COLUMN_CHUNK_CELLS at a time."""
    if not cells:
        return False
    for i in range(0, len(cells), COLUMN_CHUNK_CELLS):
        chunk = cells[i : i + COLUMN_CHUNK_CELLS]
        joined = "\n".join(chunk)
        if _COLUMN_RE.fullmatch(joined) is None or joined.count("\n") != len(chunk) - 1:
            return False
    return True


def _parse_column(
    path: Path, name: str, cells: list[str], lines: list[int], strict: bool
) -> np.ndarray | None:
    """The cells of one column as finite float64 values in the column's range. strict=False
    (an extra column of a measured trace): return None instead of raising when a cell is not a
    finite number."""
    if not _all_numbers(cells):
        if not strict:
            return None
        for cell, line in zip(cells, lines, strict=True):
            if "\n" in cell or _NUMBER_RE.fullmatch(cell) is None:
                raise TraceError(
                    f"{path}:{line}: column {name} is {_short(cell)}, not a number (a plain "
                    "decimal number such as -1.5 or 2e-3; not nan, inf or 1_000)"
                )
    values = np.array(cells, dtype=np.float64)
    bad = _first_bad(values, name)
    if bad is not None:
        if not strict:
            return None
        raise TraceError(f"{path}:{lines[bad]}: column {name} {_why_bad(values, bad, name)}")
    return values


def read_trace(csv_path: str | Path, mode: str = "full", resample: bool = False) -> Trace:
    """Read and validate a trace and its sidecar; raise TraceError naming what is wrong.

    mode="full": a trace as `bowden sim` writes it (all COLUMNS, the sidecar with every key).
    mode="measured": a bench recording or a user's CSV (only t_s, T_in_N and T_out_N required;
    the sidecar optional, its defaults in MEASURED_META_DEFAULTS, the sample rate taken from
    t_s when the sidecar does not give it). `Trace.defaulted` lists the keys taken by default.

    A measured trace may also come as a spreadsheet or a logger writes it: fields separated by
    semicolons or tabs (sniff_delimiter), then with decimal commas; a trailing separator on every
    row (an empty last column, dropped); Unix-epoch times (t_s from 1e8 s on: shifted to start
    at 0, the offset kept as meta["t_s_epoch_offset_s"]). With resample=True, timestamps that
    jitter (a PC's clock) are put on a uniform grid at the sample rate by linear interpolation
    (meta["resampled"] says so); without it they are refused with a line that names the option.
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}; got {mode!r}")
    path = Path(csv_path)
    mpath = meta_path(path)
    if not path.is_file():
        raise TraceError(f"{path}: no such file")
    measured = mode == "measured"
    if mpath.is_file():
        meta = validate_meta(_read_meta(mpath), str(mpath), required=not measured)
    elif measured:
        meta = {}
    else:
        raise TraceError(f"{path}: its sidecar {mpath.name} is missing")

    text = _read_text(path)
    delimiter = sniff_delimiter(text) if mode == "measured" else ","
    header, rows, lines = _read_rows(path, text, delimiter)
    if mode == "measured":
        header, rows = _measured_cells(header, rows, delimiter)
    header = [h.strip() for h in header]
    if not any(header):
        raise TraceError(f"{path}:1: blank line where the header row should be")
    for j, name in enumerate(header):
        if not name:
            raise TraceError(f"{path}:1: header column {j + 1} has no name")
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise TraceError(f"{path}:1: duplicate column name {dup!r} in the header")
    required = MEASURED_COLUMNS if measured else COLUMNS
    missing = [c for c in required if c not in header]
    if missing:
        raise TraceError(
            f"{path}: header lacks column(s) {', '.join(missing)} (required: {', '.join(required)})"
        )
    pos = [c for c in POSITION_COLUMNS if c in header]
    if pos and len(pos) < len(POSITION_COLUMNS):
        lacking = [c for c in POSITION_COLUMNS if c not in header]
        raise TraceError(
            f"{path}: header has {', '.join(pos)} but not {', '.join(lacking)} (the end-effector "
            "position needs x_m, y_m and z_m, or none of them)"
        )
    if not rows:
        raise TraceError(f"{path}: no data rows after the header")
    for row, line in zip(rows, lines, strict=True):
        if len(row) != len(header):
            raise TraceError(f"{path}:{line}: {len(row)} fields, the header has {len(header)}")
        if max(map(len, row)) > FIELD_MAX_CHARS:
            raise TraceError(
                f"{path}:{line}: a field is longer than 128 KiB ({FIELD_MAX_CHARS} characters), "
                "the longest a trace field may be"
            )

    columns: dict[str, np.ndarray] = {}
    text_columns: dict[str, list[str]] = {}
    epoch_offset = None
    for j, name in enumerate(header):
        cells = [row[j] for row in rows]
        if measured and name == "t_s":
            cells, epoch_offset = _epoch_shift(cells)
        known = name in COLUMNS or not measured
        values = _parse_column(path, name, cells, lines, strict=known)
        if values is None:
            text_columns[name] = cells
        else:
            columns[name] = values

    meta = dict(meta)
    defaulted: list[str] = []
    if measured:
        for key, value in MEASURED_META_DEFAULTS.items():
            if key not in meta or meta[key] is None:
                meta[key] = value
                defaulted.append(key)
        if "sample_rate_hz" not in meta:
            meta["sample_rate_hz"] = _rate_from_time(path, columns["t_s"], lines)
            defaulted.append("sample_rate_hz")
    if epoch_offset is not None:
        meta["t_s_epoch_offset_s"] = epoch_offset
    if measured and resample:
        columns, note = _resample(columns, float(meta["sample_rate_hz"]))
        if note:
            meta["resampled"] = note
    try:
        _check_time(columns["t_s"], float(meta["sample_rate_hz"]), lambda i: f"{path}:{lines[i]}")
    except TraceError as exc:
        if not measured or "t_s step" not in str(exc):
            raise
        raise TraceError(
            f"{exc}; timestamps that jitter (a PC's clock) can be put on a uniform grid by "
            "linear interpolation with --resample"
        ) from None
    return Trace(
        columns=columns,
        meta=meta,
        text_columns=text_columns,
        defaulted=tuple(defaulted),
        mode=mode,
    )


def _measured_cells(
    header: list[str], rows: list[list[str]], delimiter: str
) -> tuple[list[str], list[list[str]]]:
    """Drop a trailing empty column that every row has (a separator at the end of each line);
    with a separator other than a comma, read decimal commas as points."""
    if rows and all(len(r) > 1 and not r[-1].strip() for r in rows):
        if len(header) == len(rows[0]) and not header[-1].strip():
            header = header[:-1]
            rows = [r[:-1] for r in rows]
        elif len(header) == len(rows[0]) - 1:
            rows = [r[:-1] for r in rows]
    if delimiter != ",":
        fix = _DECIMAL_COMMA_RE.fullmatch
        rows = [[c.replace(",", ".") if fix(c) else c for c in r] for r in rows]
    return header, rows


# t_s from this value on is a Unix time (1973 on), not seconds since the start of a recording.
EPOCH_MIN_S = 1e8


def _epoch_shift(cells: list[str]) -> tuple[list[str], float | None]:
    """Unix-epoch times shifted to start at 0 (exactly: the offset is a whole number of seconds
    taken off in decimal), with the offset; other cells unchanged."""
    try:
        first = float(cells[0])
    except (ValueError, IndexError):
        return cells, None
    if not (math.isfinite(first) and first >= EPOCH_MIN_S):
        return cells, None
    from decimal import Decimal, InvalidOperation  # noqa: PLC0415

    whole = Decimal(int(first))
    try:
        shifted = [str(Decimal(c.strip()) - whole) for c in cells]
    except InvalidOperation:
        return cells, None
    return shifted, float(whole)


def _resample(columns: dict[str, np.ndarray], rate_hz: float) -> tuple[dict, str]:
    """Every numeric column linearly interpolated onto t_s[0] + k / rate_hz; a note, or "" when
    the times are on that grid already (within TIME_STEP_RTOL)."""
    t = columns["t_s"]
    if len(t) < 2 or np.any(np.diff(t) <= 0):
        return columns, ""  # _check_time names the bad row
    period = 1.0 / rate_hz
    dt = np.diff(t)
    if np.all(np.abs(dt - period) <= TIME_STEP_RTOL * period):
        return columns, ""
    n = int(math.floor((t[-1] - t[0]) * rate_hz + 1e-9)) + 1
    grid = t[0] + period * np.arange(n)
    out = {name: np.interp(grid, t, v) for name, v in columns.items() if name != "t_s"}
    out["t_s"] = grid
    jitter = float(np.std(dt) / np.mean(dt))
    note = (
        f"t_s jittered ({100 * jitter:.1f} % RMS of the step, largest step {dt.max():.4g} s): "
        f"{len(t)} samples resampled to {n} on a uniform {rate_hz:g} Hz grid by linear "
        "interpolation"
    )
    return {"t_s": out.pop("t_s"), **out}, note


def _rate_from_time(path: Path, t: np.ndarray, lines: list[int]) -> float:
    """The sample rate of a measured trace without one in its sidecar: 1 / median step of t_s."""
    if len(t) < 2:
        raise TraceError(
            f"{path}: one data row and no sample_rate_hz in a sidecar: the sample rate needs at "
            "least two rows of t_s"
        )
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.flatnonzero(dt <= 0)[0]) + 1
        raise TraceError(
            f"{path}:{lines[i]}: t_s must be strictly increasing; t_s = {float(t[i])!r} follows "
            f"{float(t[i - 1])!r}"
        )
    rate = 1.0 / float(np.median(dt))
    lo, hi, unit, open_low = META_RANGES["sample_rate_hz"]
    if not _in_range(rate, lo, hi, open_low):
        raise TraceError(
            f"{path}: the steps of t_s ({float(np.median(dt)):.3g} s) give a sample rate of "
            f"{rate:.3g} Hz; allowed {_range_text(lo, hi, unit, open_low)}"
        )
    return rate


def _is_number(v: object) -> bool:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return False
    try:
        return math.isfinite(v)
    except OverflowError:  # a whole number beyond every double
        return False


def _short(v: object, limit: int = 40) -> str:
    """repr of a value for a message, cut to `limit` characters (a field may be 128 KiB)."""
    if isinstance(v, int) and not isinstance(v, bool) and v.bit_length() > 200:
        return f"an integer of {len(str(abs(v)))} digits"
    text = repr(v)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def main(argv: list[str] | None = None) -> int:
    """`python -m cosim.results.trace [--measured] FILE.csv...`: validate traces; a line per
    file."""
    import sys  # noqa: PLC0415

    args = sys.argv[1:] if argv is None else list(argv)
    mode = "full"
    if args and args[0] == "--measured":
        mode, args = "measured", args[1:]
    if not args:
        print("usage: python -m cosim.results.trace [--measured] TRACE.csv [...]", file=sys.stderr)
        return 2
    status = 0
    for p in args:
        try:
            tr = read_trace(p, mode)
        except TraceError as exc:
            print(f"invalid: {exc}", file=sys.stderr)
            status = 1
            continue
        except OSError as exc:
            print(f"invalid: {p}: {exc.strerror or exc}", file=sys.stderr)
            status = 1
            continue
        t = tr["t_s"]
        mu = tr.meta.get("mu")
        print(
            f"ok: {p}: {len(tr)} samples, {t[-1] - t[0]:.3f} s at "
            f"{tr.meta['sample_rate_hz']:g} Hz, "
            f"loop_routing {tr.meta['loop_routing']}, mu {'unknown' if mu is None else f'{mu:g}'}, "
            f"T_out {tr['T_out_N'].min():.2f} .. {tr['T_out_N'].max():.2f} N"
            + (f" (defaults: {', '.join(tr.defaulted)})" if tr.defaulted else "")
        )
    return status


if __name__ == "__main__":
    raise SystemExit(main())
