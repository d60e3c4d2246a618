"""Tension traces on disk: ``trace.csv`` plus its sidecar ``trace.meta.json``.

One format for every time series of the project: co-simulation runs write it, bench recordings
are converted to it, and the model audit reads both. Reading validates the files and names the
first thing that is wrong (file, line, column, allowed range).

``trace.csv``
    Comma-separated, one header row, then one row per sample in time order. The required columns,
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

``trace.meta.json`` (same folder, same stem: ``<stem>.meta.json``)
    A JSON object with at least ``sample_rate_hz`` (number > 0), ``sheath_length_m`` (number > 0),
    ``loop_routing`` (true/false) and ``mu`` (number >= 0, the friction coefficient assumed or
    identified for the run). Other keys (``source``, ``scenario``, ``compensator``...) are kept.
"""

from __future__ import annotations

import csv
import json
import math
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

# Required sidecar keys: name -> (type check, allowed range as text).
META_REQUIRED = ("sample_rate_hz", "sheath_length_m", "loop_routing", "mu")

# Relative tolerance on the spacing of t_s against 1 / sample_rate_hz (recordings jitter a bit;
# the CSV keeps 9 significant digits).
TIME_STEP_RTOL = 0.05


class TraceError(ValueError):
    """A trace file (CSV or sidecar) that does not follow the format."""


@dataclass
class Trace:
    """A trace in memory: columns by name (float64 arrays of equal length) and the sidecar."""

    columns: dict[str, np.ndarray]
    meta: dict = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __len__(self) -> int:
        return len(self.columns["t_s"]) if "t_s" in self.columns else 0


def meta_path(csv_path: str | Path) -> Path:
    """The sidecar of `csv_path`: ``trace.csv`` -> ``trace.meta.json``."""
    p = Path(csv_path)
    return p.with_name(p.stem + ".meta.json")


def validate_meta(meta: object, where: str = "trace.meta.json") -> dict:
    """Check the sidecar's required keys and ranges; return it as a dict."""
    if not isinstance(meta, dict):
        raise TraceError(f"{where}: expected a JSON object, got {type(meta).__name__}")
    for key in META_REQUIRED:
        if key not in meta:
            raise TraceError(f"{where}: missing key {key!r} (required: {', '.join(META_REQUIRED)})")
    rate = meta["sample_rate_hz"]
    if not _is_number(rate) or not rate > 0:
        raise TraceError(f"{where}: sample_rate_hz must be a number > 0; got {rate!r}")
    length = meta["sheath_length_m"]
    if not _is_number(length) or not length > 0:
        raise TraceError(f"{where}: sheath_length_m must be a number > 0; got {length!r}")
    if not isinstance(meta["loop_routing"], bool):
        raise TraceError(
            f"{where}: loop_routing must be true or false; got {meta['loop_routing']!r}"
        )
    mu = meta["mu"]
    if not _is_number(mu) or mu < 0:
        raise TraceError(f"{where}: mu must be a number >= 0; got {mu!r}")
    return meta


def validate_columns(columns: dict[str, np.ndarray], meta: dict, where: str = "trace") -> None:
    """Check that the required columns exist, have equal length, are finite, and that t_s is
    strictly increasing with the spacing 1 / sample_rate_hz."""
    missing = [c for c in COLUMNS if c not in columns]
    if missing:
        raise TraceError(f"{where}: missing column(s) {', '.join(missing)}")
    n = len(columns["t_s"])
    if n < 1:
        raise TraceError(f"{where}: no samples")
    for name, values in columns.items():
        if len(values) != n:
            raise TraceError(f"{where}: column {name} has {len(values)} rows, t_s has {n}")
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise TraceError(
                f"{where}: column {name} data row {bad[0] + 1} is {float(values[bad[0]])!r}; "
                "values must be finite numbers"
            )
    t = columns["t_s"]
    if n > 1:
        dt = np.diff(t)
        nonincreasing = np.flatnonzero(dt <= 0)
        if nonincreasing.size:
            i = nonincreasing[0] + 1
            raise TraceError(
                f"{where}: t_s must be strictly increasing; data row {i + 1} has t_s = "
                f"{float(t[i])!r} after {float(t[i - 1])!r}"
            )
        period = 1.0 / float(meta["sample_rate_hz"])
        off = np.flatnonzero(np.abs(dt - period) > TIME_STEP_RTOL * period)
        if off.size:
            i = off[0] + 1
            raise TraceError(
                f"{where}: t_s step between data rows {i} and {i + 1} is {dt[i - 1]:.9g} s; "
                f"sample_rate_hz = {meta['sample_rate_hz']!r} needs {period:.9g} s "
                f"(+-{TIME_STEP_RTOL:.0%})"
            )


def write_trace(csv_path: str | Path, columns: dict[str, np.ndarray], meta: dict) -> Path:
    """Validate and write ``csv_path`` and its sidecar; return the CSV's path.

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


def read_trace(csv_path: str | Path) -> Trace:
    """Read and validate a trace and its sidecar; raise TraceError naming what is wrong."""
    path = Path(csv_path)
    mpath = meta_path(path)
    if not path.is_file():
        raise TraceError(f"{path}: no such file")
    if not mpath.is_file():
        raise TraceError(f"{path}: its sidecar {mpath.name} is missing")
    try:
        meta = json.loads(mpath.read_text())
    except json.JSONDecodeError as exc:
        raise TraceError(f"{mpath}: not valid JSON ({exc})") from None
    meta = validate_meta(meta, str(mpath))

    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        try:
            header = next(reader)
        except StopIteration:
            raise TraceError(f"{path}: empty file (expected a header row)") from None
        header = [h.strip() for h in header]
        if len(set(header)) != len(header):
            raise TraceError(f"{path}: duplicate column names in the header")
        missing = [c for c in COLUMNS if c not in header]
        if missing:
            raise TraceError(
                f"{path}: header lacks column(s) {', '.join(missing)} "
                f"(required: {', '.join(COLUMNS)})"
            )
        rows: list[list[float]] = []
        for lineno, row in enumerate(reader, start=2):
            if not row or all(not cell.strip() for cell in row):
                continue
            if len(row) != len(header):
                raise TraceError(
                    f"{path}:{lineno}: {len(row)} fields, the header has {len(header)}"
                )
            try:
                rows.append([float(cell) for cell in row])
            except ValueError:
                for col, cell in zip(header, row, strict=True):
                    try:
                        float(cell)
                    except ValueError:
                        raise TraceError(
                            f"{path}:{lineno}: column {col} is {cell!r}, not a number"
                        ) from None
                raise
    if not rows:
        raise TraceError(f"{path}: no data rows after the header")
    data = np.asarray(rows, dtype=np.float64)
    columns = {name: data[:, i].copy() for i, name in enumerate(header)}
    validate_columns(columns, meta, str(path))
    return Trace(columns=columns, meta=meta)


def _is_number(v: object) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def main(argv: list[str] | None = None) -> int:
    """`python -m cosim.trace FILE.csv...`: validate traces; print a line per file."""
    import sys  # noqa: PLC0415

    paths = sys.argv[1:] if argv is None else argv
    if not paths:
        print("usage: python -m cosim.trace TRACE.csv [...]", file=sys.stderr)
        return 2
    status = 0
    for p in paths:
        try:
            tr = read_trace(p)
        except TraceError as exc:
            print(f"invalid: {exc}", file=sys.stderr)
            status = 1
            continue
        t = tr["t_s"]
        print(
            f"ok: {p}: {len(tr)} samples, {t[-1] - t[0]:.3f} s at "
            f"{tr.meta['sample_rate_hz']:g} Hz, "
            f"loop_routing {tr.meta['loop_routing']}, mu {tr.meta['mu']:g}, "
            f"T_out {tr['T_out_N'].min():.2f} .. {tr['T_out_N'].max():.2f} N"
        )
    return status


if __name__ == "__main__":
    raise SystemExit(main())
