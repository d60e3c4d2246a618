"""The sweep specification (SPEC.yaml of `bowden sweep`) and the points it expands to.

    scenario: fig14            # characterize | positions | fig14 (or an axis)
    duration_s: 6              # simulated seconds per point (default: the scenario's)
    interface: board           # board | adc | ideal (or an axis)
    sampling: grid             # grid: every combination of the axes; random: `samples` draws
    samples: 20                # random only
    seed: 1                    # random only
    config: {}                 # base configuration, as a --params file (cosim.config.scenarios)
    axes:
      compensator: [paper, smooth]
      loop_routing: [true, false]
      position_m: {x: [0.0], y: [0.3, 0.5, 0.7], z: [-0.2, 0.0, 0.2]}  # or [[x, y, z], ...]
      plant.mu: {nominal: 0.075, rel: 0.2, n: 3}   # n values over nominal * (1 -+ rel)
      plant.cable_EA: {min: 6400, max: 9600, n: 3}
      controller.kp_a_per_n: [0.03, 0.05]

Axes `scenario`, `interface` and `compensator` take lists of names (a sweep over scenarios runs
each for duration_s, default its own duration). Another axis is a list of values, {min, max, n}
or {nominal, rel, n} (grid: n evenly spaced values; random: uniform over [min, max]), and for
position_m a list of points or {x, y, z} lists (their product). Dotted axes set one field of
the run's configuration: plant.<FMU parameter>, controller.<field>, compensator.<field> or
board.<field>; every point is checked as a params file is (SimConfig.from_dict), so a bad value
is caught before anything runs. A bad spec is a SpecError: one line naming the file, the line
and the key.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import itertools
import json
import math
import random
from dataclasses import dataclass
from pathlib import Path

from cosim.config.run import COMPENSATORS, SimConfig
from cosim.config.scenarios import SCENARIO_NAMES
from cosim.parts.interface import INTERFACES
from cosim.project.cliargs import shown
from cosim.project.datafile import INT_DIGITS, HugeInt, read_text

TOP_KEYS = ("scenario", "duration_s", "interface", "sampling", "samples", "seed", "config", "axes")
PLAIN_AXES = ("scenario", "interface", "compensator", "loop_routing", "position_m")
CONFIG_GROUPS = ("plant", "controller", "compensator", "board")
MAX_POINTS = 100_000


class SpecError(ValueError):
    """A sweep specification that cannot be used (the message names file, line and key)."""


@dataclass(frozen=True)
class Point:
    """One run of a sweep: its axis values and the run they make."""

    values: dict  # axis name -> value (position_m as [x, y, z])
    run_key: str = ""  # what else decides the result (SweepSpec.run_key): spec, engine, build

    @property
    def point_id(self) -> str:
        """A stable name of the point: the hash of its values and of everything else that
        decides its result (run_key), so that a result is never taken for another spec's."""
        text = json.dumps({"values": self.values, "run": self.run_key}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


ENGINE = "native"  # every point runs on the native engine (cosim/engines/native)


@dataclass
class SweepSpec:
    """A parsed, checked sweep specification."""

    scenario: str
    duration_s: float | None
    interface: str
    sampling: str
    samples: int
    seed: int
    config: dict
    axes: dict  # name -> list of values (grid) or ("uniform", lo, hi) (random)
    source: str
    build_id: str = ""  # the project build the points run on (cosim.studies.sweep.run.build_id)

    def run_context(self) -> dict:
        """Everything besides a point's axis values that decides its result: the spec's
        scenario, duration, interface and base configuration, the engine and the build."""
        return {
            "scenario": self.scenario,
            "duration_s": self.duration_s,
            "interface": self.interface,
            "config": self.config,
            "engine": ENGINE,
            "build": self.build_id,
        }

    @property
    def run_key(self) -> str:
        text = json.dumps(self.run_context(), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def points(self) -> list[Point]:
        """Every point of the sweep, in a fixed order (the same on every resume)."""
        names = list(self.axes)
        key = self.run_key
        if self.sampling == "grid":
            combos = itertools.product(*(self.axes[n] for n in names))
            pts = [Point(dict(zip(names, c, strict=True)), key) for c in combos]
        else:
            rng = random.Random(self.seed)
            pts = []
            for _ in range(self.samples):
                vals = {}
                for n in names:
                    ax = self.axes[n]
                    if isinstance(ax, tuple):
                        vals[n] = rng.uniform(ax[1], ax[2])
                    else:
                        vals[n] = copy.deepcopy(rng.choice(ax))
                pts.append(Point(vals, key))
        return pts

    def run_config(self, point: Point) -> dict:
        """The point's configuration (a params-file dict): the base config and the axes."""
        cfg = copy.deepcopy(self.config)
        for name, value in point.values.items():
            if "." in name:
                group, key = name.split(".", 1)
                cfg.setdefault(group, {})[key] = value
        return cfg

    def run_spec(self, point: Point) -> dict:
        """What the run needs besides phi (cosim.studies.sweep.run adds it): scenario, compensator,
        loop routing, interface, duration, configuration, position."""
        v = point.values
        scenario = v.get("scenario", self.scenario)
        return {
            "scenario": scenario,
            "compensator": v.get("compensator", "paper" if scenario == "fig14" else "none"),
            "loop_routing": bool(v.get("loop_routing", True)),
            "interface": v.get("interface", self.interface),
            "duration_s": self.duration_s,
            "config": self.run_config(point),
            "position_m": v.get("position_m"),
        }


def _lines(text: str) -> dict[tuple[str, ...], int]:
    """1-based line of each key of the top level and of `axes` / `config` (for messages)."""
    import yaml  # noqa: PLC0415

    out: dict[tuple[str, ...], int] = {}
    try:
        root = yaml.compose(text)
    except yaml.YAMLError:
        return out
    if not isinstance(root, yaml.MappingNode):
        return out
    for knode, vnode in root.value:
        key = str(knode.value)
        out[(key,)] = knode.start_mark.line + 1
        if isinstance(vnode, yaml.MappingNode):
            for k2, _ in vnode.value:
                out[(key, str(k2.value))] = k2.start_mark.line + 1
    return out


class DuplicateKeyError(ValueError):
    """A mapping that names a key twice (YAML and JSON would keep the last one silently)."""

    def __init__(self, key, line: int) -> None:
        self.line = line
        super().__init__(f"key {key!r} appears twice in the same mapping (the last would win)")


@functools.cache
def unique_key_loader():
    """The YAML loader of specifications (built on first use: yaml is imported lazily)."""
    import yaml  # noqa: PLC0415

    class Loader(yaml.SafeLoader):
        """yaml.SafeLoader that refuses a key given twice in one mapping."""

        def construct_mapping(self, node, deep=False):
            seen = set()
            for knode, _ in node.value:
                key = self.construct_object(knode, deep=deep)
                try:
                    dup = key in seen
                except TypeError:  # an unhashable key: SafeLoader names it
                    break
                if dup:
                    raise DuplicateKeyError(key, knode.start_mark.line + 1)
                seen.add(key)
            return super().construct_mapping(node, deep=deep)

        def construct_yaml_int(self, node):
            if sum(c.isdigit() for c in str(node.value)) > INT_DIGITS:
                return HugeInt(str(node.value))  # int() would refuse it without a key
            return super().construct_yaml_int(node)

    Loader.add_constructor("tag:yaml.org,2002:int", Loader.construct_yaml_int)
    return Loader


def load_spec(path: str | Path) -> SweepSpec:
    """Read and check SPEC.yaml; SpecError (one line) for anything that cannot be run."""
    import yaml  # noqa: PLC0415

    p = Path(path)
    name = shown(p)
    text = read_text(p, "a YAML sweep specification", "a YAML sweep specification", name=name,
                     error=SpecError)  # fmt: skip
    try:
        data = yaml.load(text, Loader=unique_key_loader())  # noqa: S506 (a SafeLoader)
    except DuplicateKeyError as exc:
        raise SpecError(f"{name}: line {exc.line}: {exc}") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise SpecError(f"{name}:{where} is not valid YAML ({problem})") from None
    except RecursionError:
        raise SpecError(f"{name}: nested too deeply to be a sweep specification") from None
    return parse_spec(data, name, _lines(text))


def parse_spec(data, name: str = "spec", lines: dict | None = None) -> SweepSpec:
    """Check a specification already read (a dict); see load_spec."""
    lines = lines or {}

    def err(keys: tuple[str, ...], msg: str) -> SpecError:
        line = lines.get(keys) or lines.get(keys[:1])
        where = f" line {line}" if line else ""
        return SpecError(f"{name}:{where}: {'.'.join(keys)}: {msg}")

    if not isinstance(data, dict):
        raise SpecError(f"{name}: expected a mapping of keys ({', '.join(TOP_KEYS)})")
    for key in data:
        if key not in TOP_KEYS:
            raise err((str(key),), f"unknown key (allowed: {', '.join(TOP_KEYS)})")
    scenario = data.get("scenario", "fig14")
    if not isinstance(scenario, str) or scenario not in SCENARIO_NAMES:
        raise err(
            ("scenario",), f"must be one of {', '.join(SCENARIO_NAMES)}; got {_brief(scenario)}"
        )
    interface = data.get("interface", "board")
    if not isinstance(interface, str) or interface not in INTERFACES:
        raise err(
            ("interface",), f"must be one of {', '.join(INTERFACES)}; got {_brief(interface)}"
        )
    duration = data.get("duration_s")
    if duration is not None and (
        isinstance(duration, bool) or not _number(duration) or not 0.01 <= duration <= 3600
    ):
        raise err(
            ("duration_s",), f"must be a number of seconds in [0.01, 3600]; got {_brief(duration)}"
        )
    sampling = data.get("sampling", "grid")
    if not isinstance(sampling, str) or sampling not in ("grid", "random"):
        raise err(("sampling",), f"must be grid or random; got {_brief(sampling)}")
    samples = data.get("samples", 0 if sampling == "grid" else None)
    if sampling == "random" and (
        isinstance(samples, bool) or not isinstance(samples, int) or not 1 <= samples <= MAX_POINTS
    ):
        raise err(("samples",), f"random sampling needs a whole number in [1, {MAX_POINTS}]")
    seed = data.get("seed", 1)
    if isinstance(seed, bool) or not isinstance(seed, int) or abs(seed) >= 1 << 64:
        raise err(("seed",), f"must be a whole number below 2^64; got {_brief(seed)}")
    config = data.get("config", {}) or {}
    if not isinstance(config, dict):
        raise err(("config",), "must be a mapping (as a --params file)")
    try:
        SimConfig.from_dict(copy.deepcopy(config), source="config")
    except ValueError as exc:
        raise err(("config",), str(exc)) from None
    axes_in = data.get("axes", {}) or {}
    if not isinstance(axes_in, dict):
        raise err(("axes",), "must be a mapping of axis name -> values")
    axes = {}
    for key, raw in axes_in.items():
        axes[str(key)] = _axis(str(key), raw, sampling, lambda m, k=str(key): err(("axes", k), m))
    spec = SweepSpec(
        scenario=scenario,
        duration_s=None if duration is None else float(duration),
        interface=interface,
        sampling=sampling,
        samples=int(samples or 0),
        seed=seed,
        config=config,
        axes=axes,
        source=name,
    )
    if sampling == "grid":
        count = math.prod(len(v) for v in axes.values())
        if count > MAX_POINTS:
            raise err(("axes",), f"the grid has {count} points (at most {MAX_POINTS})")
    # Every value is checked as a params file would be, once per axis value (not per point).
    for key, ax in axes.items():
        if "." not in key:
            continue
        values = [ax[1], ax[2]] if isinstance(ax, tuple) else ax
        for v in values:
            probe = spec.run_config(Point({key: v}))
            try:
                SimConfig.from_dict(probe, source="axis")
            except ValueError as exc:
                raise err(("axes", key), str(exc).replace("axis: ", "")) from None
    return spec


def _number(value) -> bool:
    """A finite number (a whole number beyond every double is not one: no OverflowError)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def _brief(value, limit: int = 60) -> str:
    """A value for a message, on one line and shortened (a whole number by its digits)."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 200:
        return f"an integer of {len(str(abs(value)))} digits"
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _axis(key: str, raw, sampling: str, err):
    """An axis' values: a list (grid and random), or ("uniform", lo, hi) for a range sampled at
    random."""
    if key == "position_m":
        return _positions(raw, err)
    choices = {"compensator": COMPENSATORS, "scenario": SCENARIO_NAMES, "interface": INTERFACES}
    if key in choices:
        vals = raw if isinstance(raw, list) else [raw]
        if not vals:
            raise err(f"an empty list of values (give one or more of {', '.join(choices[key])})")
        for v in vals:
            if not isinstance(v, str) or v not in choices[key]:
                raise err(f"must be among {', '.join(choices[key])}; got {_brief(v)}")
        return vals
    if key == "loop_routing":
        vals = raw if isinstance(raw, list) else [raw]
        if not vals:
            raise err("an empty list of values (give true and/or false)")
        if not all(isinstance(v, bool) for v in vals):
            raise err("must be true and/or false")
        return vals
    group = key.split(".", 1)[0]
    if "." not in key or group not in CONFIG_GROUPS:
        raise err(
            f"unknown axis (allowed: {', '.join(PLAIN_AXES)}, or {'|'.join(CONFIG_GROUPS)}.<field>)"
        )
    if isinstance(raw, list):
        if not raw:
            raise err("an empty list of values")
        return raw
    if isinstance(raw, dict):
        if set(raw) == {"min", "max", "n"} or set(raw) == {"nominal", "rel", "n"}:
            if "nominal" in raw:
                nom, rel = raw["nominal"], raw["rel"]
                if not (_number(nom) and _number(rel) and 0 <= rel < 1):
                    raise err("nominal must be a number and rel a number in [0, 1)")
                lo, hi = nom * (1 - rel), nom * (1 + rel)
            else:
                lo, hi = raw["min"], raw["max"]
                if not (_number(lo) and _number(hi) and lo <= hi):
                    raise err("min and max must be numbers with min <= max")
            n = raw["n"]
            if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 1000:
                raise err("n must be a whole number in [1, 1000]")
            if sampling == "random":
                return ("uniform", float(lo), float(hi))
            if n == 1:
                return [0.5 * (lo + hi)]
            return [lo + (hi - lo) * i / (n - 1) for i in range(n)]
        raise err("a range is {min, max, n} or {nominal, rel, n}")
    return [raw]


def _positions(raw, err) -> list[list[float]]:
    def triple(p):
        if not (isinstance(p, list) and len(p) == 3 and all(_number(v) for v in p)):
            raise err(f"a position is [x, y, z] in m; got {_brief(p)}")
        return [float(v) for v in p]

    if isinstance(raw, list):
        if not raw:
            raise err("an empty list of positions")
        return [triple(p) for p in raw]
    if isinstance(raw, dict):
        if set(raw) - {"x", "y", "z"}:
            raise err("a grid of positions has keys x, y and z (lists of m)")
        lists = []
        for c in ("x", "y", "z"):
            v = raw.get(c, [0.0])
            v = v if isinstance(v, list) else [v]
            if not v or not all(_number(a) for a in v):
                raise err(f"{c} must be a number or a list of numbers (m)")
            lists.append([float(a) for a in v])
        count = math.prod(len(v) for v in lists)
        if count > MAX_POINTS:  # refused before the product is built
            raise err(f"the grid of positions has {count} points (at most {MAX_POINTS})")
        return [list(p) for p in itertools.product(*lists)]
    raise err("a list of [x, y, z] or a grid {x: [...], y: [...], z: [...]}")
