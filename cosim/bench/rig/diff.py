"""`bowden bench diff`: how a device's parameters differ from a file or the factory defaults.

Three kinds of file are read, told apart by their structure (each checked before anything is
sent to the device, with the reader `restore` uses: cosim.bench.link.paramfiles):

- a backup (`bowden bench backup`, it names its format): the words as saved. A backup of another
  protocol version is refused in one line (its words may mean other things); one of another
  parameter table but the same protocol is compared by name, as `restore` writes it, and its
  names this device does not know are listed.
- a co-simulation params file (`bowden sim --params`, `bowden tune`'s tuned_params.json: it has a
  `controller`, `compensator`, `plant` or `board` section or `firmware_rate_hz`): every key it
  sets in `controller` and `compensator` and its rates, as the co-simulation gives them to the
  firmware (SIM_TO_DEVICE; `controller.ki_a_per_n_s` is the device's `loop.ki_ts` times the
  file's sample rate). `plant` and `board` describe the model, not the device, and are skipped
  (said so); a key that is null (the scenario's bending angle) is listed as not compared.
- a bench params file: a JSON object of parameter names and values as `set` takes them, in SI
  units or mode names (`{"loop.kp": 0.1, "comp.mode": "smooth"}`).

Every value must be one the device accepts for its parameter (a file the device would refuse is
refused, one line). Values are compared as the device's words (the file's SI values rounded to
the parameter's fixed point, as `set` would write them), and shown in SI units with the difference
device - file. A value that acts only while a switch is on (the slew limit, the rate
feedforward's bound, the estimate's settings: SWITCHED_BY) is not a difference when the switch is
off on both sides; the table says "off" and a line names it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from pathlib import Path

from cosim.bench.link import messages as msgs
from cosim.bench.link.paramfiles import (
    BACKUP_FORMAT,
    ParamFileError,
    bench_params,
    is_backup,
    read_backup,
    read_json,
    word_of_value,
)
from cosim.bench.link.protocol import ProtocolError, format_value, param, value_from_word
from cosim.config.run import ControllerParams, SimConfig
from cosim.parts.firmware import CompensatorParams

__all__ = ["BACKUP_FORMAT", "DiffFileError", "Reference", "compare", "load_file", "render"]

# Co-simulation params file key -> device parameter, as the co-simulation gives each to the
# firmware (cosim.engines.fwbridge.loop_words for the loop's words, kv and its bound;
# cosim.parts.firmware.CompensatorParams.to_c and EstimatorParams.to_c for the compensator and the
# online estimate; FirmwareConfig for the rates), in the same units unless SIM_PER_RATE says:
# generated from the protocol's table (firmware/proto/bowden_proto.json, params.cosim).
SIM_TO_DEVICE = msgs.SIM_TO_DEVICE
# Keys given per second whose device word is per FPGA sample or per firmware tick: the value
# divided by the file's rate (Ki * Ts, Ts one FPGA sample; the estimate's rate per tick).
SIM_PER_RATE = {
    "controller.ki_a_per_n_s": "sample_rate_hz",
    "compensator.est_rate_per_s": "firmware_rate_hz",
}
# Keys whose 0 means "off": the device holds the switch apart (fwbridge: slew_en = slew > 0), and
# the value is compared only when on.
SIM_SWITCHED = {"controller.slew_n_per_sample": "loop.slew_en"}
# Keys with no device parameter of their own, and why.
SIM_NOT_ON_DEVICE = {
    "compensator.mode": "set by the run's --compensator, not by a params file",
    "plant": "the co-simulation's plant (FMU parameters)",
    "board": "the co-simulation's model of the board's sensing and drive chain",
}
# What a null value means where the co-simulation takes one.
SIM_NULL = {
    "compensator.phi_rad": "the scenario's bending angle at its start position, found per run; "
    "not a device value",
}

# A value that acts only while another parameter is on (non-zero): the slew limit with
# CTRL.SLEW_EN (the register map), the bound of the rate feedforward with a non-zero kv (fw.h:
# kv 0 writes no feedforward), the estimate's settings with est.enable (fric_est.h).
SWITCHED_BY = {
    "loop.slew": "loop.slew_en",
    "loop.uff_limit": "loop.kv",
    **{
        f"est.{k}": "est.enable"
        for k in ("tau_ticks", "rate", "mu_phi_min", "mu_phi_max", "t_min_n")
    },
}


class DiffFileError(ValueError):
    """The file cannot be compared: one line naming the file and the problem."""


@dataclass
class Reference:
    """What the device is compared with: words by parameter name, and what the file held
    besides (names this device does not know, sections that are not device parameters, keys
    not compared and why)."""

    label: str
    words: dict[str, int]
    unknown: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    note: str = ""
    not_compared: list[str] = field(default_factory=list)


# Top-level keys only a co-simulation params file has (its sample_rate_hz is also a device
# parameter's name, so it does not tell the kinds apart).
SIM_ONLY_KEYS = frozenset(f.name for f in fields(SimConfig) if f.name not in msgs.PARAM_BY_NAME)


def load_file(path: str | Path) -> Reference:
    """Read a backup, bench params file or co-simulation params file (DiffFileError)."""
    try:
        if not str(path).strip():
            raise ParamFileError("an empty file name: expected a backup or params file")
        path = Path(path)
        doc = read_json(path, "a backup or params file")
        if not isinstance(doc, dict):
            raise ParamFileError(f"{path}: expected a JSON object at the top level")
        if not doc:
            raise ParamFileError(f"{path} is an empty object: nothing to compare")
        if is_backup(doc):
            return _backup(path, doc)
        ref = read_params_file(path, doc)
        if ref is not None:
            return ref
    except ParamFileError as exc:
        raise DiffFileError(f"diff: {exc}") from None
    raise DiffFileError(
        f"diff: {path} is neither a bowden bench backup, nor a params file of device parameters "
        '(e.g. {"loop.kp": 0.1}), nor a co-simulation params file (controller, compensator)'
    )


def read_params_file(path: Path, doc: dict) -> Reference | None:
    """The words of a params file read into `doc`: a co-simulation params file (its controller
    and compensator, through SIM_TO_DEVICE) or one of device parameters by name; None when
    `doc` is neither (ParamFileError names a bad entry)."""
    if SIM_ONLY_KEYS & doc.keys():
        return _sim_params(path, doc)
    if any(k in msgs.PARAM_BY_NAME for k in doc):
        words, unknown = bench_params(path, doc)
        return Reference(label=path.name, words=words, unknown=unknown)
    return None


def _backup(path: Path, doc: dict) -> Reference:
    b = read_backup(path, doc)
    note = ""
    if not b.same_table:
        note = (
            f"backup of table {b.table_hash}, this host's table {msgs.TABLE_HASH:08x}: "
            "compared by parameter name"
        )
    return Reference(label=path.name, words=b.words, unknown=b.unknown, note=note)


def _sim_params(path: Path, doc: dict) -> Reference:
    try:
        cfg = SimConfig.from_dict(doc, source=str(path))
    except ValueError as exc:
        raise ParamFileError(str(exc)) from None
    try:
        words, not_compared = sim_words(doc, cfg)
    except ProtocolError as exc:
        raise ParamFileError(f"{path}: {exc}") from None
    skipped = [k for k in ("plant", "board") if doc.get(k)]
    return Reference(label=path.name, words=words, skipped=skipped, not_compared=not_compared)


def sim_words(doc: dict, cfg: SimConfig) -> tuple[dict[str, int], list[str]]:
    """The device words of the keys a co-simulation params file sets (`doc`, read into `cfg`),
    and the keys it sets that are not compared, with the reason. ProtocolError names the key
    of a value the device does not accept."""
    words: dict[str, int] = {}
    not_compared: list[str] = []
    for key, name in SIM_TO_DEVICE.items():
        group, _, leaf = key.rpartition(".")
        given = doc.get(group) if group else doc
        if not isinstance(given, dict) or leaf not in given:
            continue  # only what the file sets (the rest are the co-simulation's defaults)
        if given[leaf] is None:
            not_compared.append(f"{key} (null: {SIM_NULL[key]})")
            continue
        value = getattr(getattr(cfg, group), leaf) if group else getattr(cfg, leaf)
        if key in SIM_PER_RATE:
            value = value / getattr(cfg, SIM_PER_RATE[key])
        if key in SIM_SWITCHED:
            words[SIM_SWITCHED[key]] = 1 if value > 0 else 0
            if value == 0:
                continue  # off: the device's value of it means nothing
        try:
            words[name] = word_of_value(param(name), value)
        except ProtocolError as exc:
            raise ProtocolError(f"{key}: {exc}") from None
    return words, not_compared


def unmapped_sim_keys(controller=ControllerParams, compensator=CompensatorParams) -> list[str]:
    """Keys of a co-simulation params file (SimConfig's top level, its controller and compensator
    fields) that neither map to a device parameter nor are listed as having none."""
    keys = [f.name for f in fields(SimConfig) if f.name not in ("controller", "compensator")]
    keys += [f"controller.{f.name}" for f in fields(controller)]
    keys += [f"compensator.{f.name}" for f in fields(compensator)]
    return [k for k in keys if k not in SIM_TO_DEVICE and k not in SIM_NOT_ON_DEVICE]


@dataclass(frozen=True)
class Row:
    """One parameter: its words on the device and in the reference; `off` names the switch that
    is off on both sides (the words then change nothing the device does)."""

    name: str
    device: int
    reference: int
    off: str | None = None

    @property
    def words_differ(self) -> bool:
        p = param(self.name)
        mask = 0xFFFFFFFF
        return (
            (self.device & mask) != (self.reference & mask)
            if p.unsigned
            else (self.device != self.reference)
        )

    @property
    def differs(self) -> bool:
        return self.off is None and self.words_differ

    def cells(self) -> list[str]:
        p = param(self.name)
        dev, ref = value_from_word(p, self.device), value_from_word(p, self.reference)
        delta = ""
        if self.off is not None:
            delta = "off"
        elif not isinstance(dev, str) and not isinstance(ref, str):
            delta = f"{dev - ref:+.6g}" + (f" {p.unit}" if p.unit else "")
        return [self.name, format_value(p, self.device), format_value(p, self.reference), delta]


def compare(device: dict[str, int], ref: Reference) -> list[Row]:
    """Rows in parameter order for every parameter the reference holds. A switch the reference
    does not hold is the device's on its side (the file changes only what it names)."""
    rows = []
    for p in msgs.PARAMS:
        if p.name not in ref.words or p.name not in device:
            continue
        switch = SWITCHED_BY.get(p.name)
        off = None
        if switch is not None and switch in device:
            if device[switch] == 0 and ref.words.get(switch, device[switch]) == 0:
                off = switch
        rows.append(Row(p.name, device[p.name], ref.words[p.name], off))
    return rows


def render(rows: list[Row], ref: Reference, show_all: bool = False) -> str:
    """The differing rows (every row with show_all) as a table, then a one-line summary and what
    was not compared."""
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
    off = [f"{r.name} ({r.off} 0)" for r in rows if r.off is not None and r.words_differ]
    if off:
        lines.append(f"off on both sides, not a difference: {', '.join(off)}")
    if ref.unknown:
        lines.append(f"in {ref.label} but unknown to this device: {', '.join(ref.unknown)}")
    if ref.not_compared:
        lines.append(f"not compared: {', '.join(ref.not_compared)}")
    if ref.skipped:
        lines.append(
            f"not device parameters (the co-simulation's model), skipped: {', '.join(ref.skipped)}"
        )
    return "\n".join(lines)
