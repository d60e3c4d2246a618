"""`bowden bench diff`: how a device's parameters differ from a file or the factory defaults.

Three kinds of file are read (each checked before anything is sent to the device):

- a backup (`bowden bench backup`): the words as saved. A backup of another protocol version is
  refused in one line (its words may mean other things); one of another parameter table but the
  same protocol is compared by name, as `restore` writes it, and its names this device does not
  know are listed.
- a bench params file: a JSON object of parameter names and values as `set` takes them, in SI
  units or mode names (`{"loop.kp": 0.1, "comp.mode": "smooth"}`).
- a co-simulation params file (`bowden sim --params`, `bowden tune`'s tuned_params.json): the
  keys it sets in `controller` and `compensator` and its rates, as the device holds them
  (`controller.ki_a_per_n_s` is the device's `loop.ki_ts` times the file's sample rate); `plant`
  and `board` describe the model, not the device, and are skipped (said so).

Values are compared as the device's words (the file's SI values rounded to the parameter's fixed
point, as `set` would write them), and shown in SI units with the difference device - file.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from . import messages as msgs
from .protocol import ProtocolError, format_value, param, value_from_word, word_from_value

BACKUP_FORMAT = 1

# Co-simulation params file key -> device parameter (cosim.config.scenarios.SimConfig; the
# firmware's configuration holds the same quantities, fw.h and the register map).
SIM_TO_DEVICE = {
    "firmware_rate_hz": "tick_rate_hz",
    "sample_rate_hz": "sample_rate_hz",
    "controller.kff_a_per_n": "loop.kff",
    "controller.kp_a_per_n": "loop.kp",
    "controller.ki_a_per_n_s": "loop.ki_ts",
    "controller.i_limit_a": "loop.i_limit",
    "controller.slew_n_per_sample": "loop.slew",
    **{
        f"compensator.{k}": f"comp.{k}"
        for k in (
            "mu",
            "phi_rad",
            "band_n",
            "hysteresis_n",
            "offset_n",
            "mu_slope_per_n",
            "tc_min_n",
            "preview_ticks",
            "lead_ticks",
            "ramp_ticks",
        )
    },
}


class DiffFileError(ValueError):
    """The file cannot be compared: one line naming the file and the problem."""


@dataclass
class Reference:
    """What the device is compared with: words by parameter name, and what the file held
    besides (names this device does not know, sections that are not device parameters)."""

    label: str
    words: dict[str, int]
    unknown: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    note: str = ""


def load_file(path: str | Path) -> Reference:
    """Read a backup, bench params file or co-simulation params file (DiffFileError)."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise DiffFileError(f"diff: {path} does not exist") from None
    except IsADirectoryError:
        raise DiffFileError(f"diff: {path} is a directory, not a file") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DiffFileError(f"diff: {path} is not JSON ({exc})") from None
    if not isinstance(doc, dict):
        raise DiffFileError(f"diff: {path}: expected a JSON object at the top level")
    if "bowden_bench_backup" in doc:
        return _backup(path, doc)
    if any(k in msgs.PARAM_BY_NAME for k in doc):
        return _bench_params(path, doc)
    if any(k in doc for k in ("controller", "compensator", "sample_rate_hz", "firmware_rate_hz")):
        return _sim_params(path, doc)
    raise DiffFileError(
        f"diff: {path} is neither a bowden bench backup, nor a params file of device parameters "
        '(e.g. {"loop.kp": 0.1}), nor a co-simulation params file (controller, compensator)'
    )


def _backup(path: Path, doc: dict) -> Reference:
    if doc.get("bowden_bench_backup") != BACKUP_FORMAT:
        raise DiffFileError(
            f"diff: {path}: backup format {doc.get('bowden_bench_backup')!r}, this host reads "
            f"format {BACKUP_FORMAT}"
        )
    version = doc.get("protocol_version")
    if version != msgs.PROTOCOL_VERSION:
        raise DiffFileError(
            f"diff: {path} is a backup of protocol version {version}, this host speaks "
            f"{msgs.PROTOCOL_VERSION}: its words may mean other things; compare it with a host "
            "of that version"
        )
    params = doc.get("params")
    if not isinstance(params, dict):
        raise DiffFileError(f"diff: {path}: no 'params' object")
    words, unknown = {}, []
    for name, entry in params.items():
        if name not in msgs.PARAM_BY_NAME:
            unknown.append(name)
            continue
        word = entry.get("word") if isinstance(entry, dict) else None
        if isinstance(word, bool) or not isinstance(word, int) or not -(1 << 31) <= word < 1 << 32:
            raise DiffFileError(f"diff: {path}: {name}.word must be a 32-bit integer")
        words[name] = word - (1 << 32) if word >= 1 << 31 else word
    note = ""
    if doc.get("table_hash") != f"{msgs.TABLE_HASH:08x}":
        note = (
            f"backup of table {doc.get('table_hash')}, this host's table {msgs.TABLE_HASH:08x}: "
            "compared by parameter name"
        )
    return Reference(label=path.name, words=words, unknown=unknown, note=note)


def _bench_params(path: Path, doc: dict) -> Reference:
    words, unknown = {}, []
    for name, value in doc.items():
        if name not in msgs.PARAM_BY_NAME:
            unknown.append(name)
            continue
        if isinstance(value, bool) or not isinstance(value, int | float | str):
            raise DiffFileError(f"diff: {path}: {name}: expected a number or a mode name")
        try:
            words[name] = word_from_value(param(name), value)
        except ProtocolError as exc:
            raise DiffFileError(f"diff: {path}: {exc}") from None
    return Reference(label=path.name, words=words, unknown=unknown)


def _sim_params(path: Path, doc: dict) -> Reference:
    from cosim.config.scenarios import SimConfig  # noqa: PLC0415 (the co-simulation's checks, on demand)

    try:
        cfg = SimConfig.from_dict(doc, source=f"diff: {path}")
    except ValueError as exc:
        raise DiffFileError(str(exc)) from None
    words = {}
    for key, name in SIM_TO_DEVICE.items():
        group, _, leaf = key.rpartition(".")
        given = doc.get(group, {}) if group else doc
        if not isinstance(given, dict) or leaf not in given or given[leaf] is None:
            continue  # only what the file sets (the rest are the co-simulation's defaults)
        value = getattr(getattr(cfg, group), leaf) if group else getattr(cfg, leaf)
        if name == "loop.ki_ts":
            value = value / cfg.sample_rate_hz  # Ki * Ts, Ts one FPGA sample
        try:
            words[name] = word_from_value(param(name), value)
        except ProtocolError as exc:
            raise DiffFileError(f"diff: {path}: {key}: {exc}") from None
    skipped = [k for k in ("plant", "board") if doc.get(k)]
    return Reference(label=path.name, words=words, skipped=skipped)


@dataclass(frozen=True)
class Row:
    """One parameter: its words on the device and in the reference."""

    name: str
    device: int
    reference: int

    @property
    def differs(self) -> bool:
        p = param(self.name)
        mask = 0xFFFFFFFF
        return (
            (self.device & mask) != (self.reference & mask)
            if p.unsigned
            else (self.device != self.reference)
        )

    def cells(self) -> list[str]:
        p = param(self.name)
        dev, ref = value_from_word(p, self.device), value_from_word(p, self.reference)
        delta = ""
        if not isinstance(dev, str) and not isinstance(ref, str):
            delta = f"{dev - ref:+.6g}" + (f" {p.unit}" if p.unit else "")
        return [self.name, format_value(p, self.device), format_value(p, self.reference), delta]


def compare(device: dict[str, int], ref: Reference) -> list[Row]:
    """Rows in parameter order for every parameter the reference holds."""
    return [
        Row(p.name, device[p.name], ref.words[p.name])
        for p in msgs.PARAMS
        if p.name in ref.words and p.name in device
    ]


def render(rows: list[Row], ref: Reference, show_all: bool = False) -> str:
    """The differing rows (every row with show_all) as a table, then a one-line summary."""
    shown = [r for r in rows if show_all or r.differs]
    lines = []
    if ref.note:
        lines.append(f"note: {ref.note}")
    if shown:
        table = [["parameter", "device", ref.label, "device - file"]] + [r.cells() for r in shown]
        if ref.label == "factory default":
            table[0][3] = "device - default"
        widths = [max(len(t[c]) for t in table) for c in range(4)]
        lines += [
            "  ".join(c.ljust(w) for c, w in zip(t, widths, strict=True)).rstrip() for t in table
        ]
    n = sum(r.differs for r in rows)
    lines.append(
        f"{n} of {len(rows)} parameters differ"
        if n
        else f"no differences in {len(rows)} parameters"
    )
    if ref.unknown:
        lines.append(f"in {ref.label} but unknown to this device: {', '.join(ref.unknown)}")
    if ref.skipped:
        lines.append(
            f"not device parameters (the co-simulation's model), skipped: {', '.join(ref.skipped)}"
        )
    return "\n".join(lines)
